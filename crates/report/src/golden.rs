//! Golden results: compares a run with a stored results.json within
//! per-metric tolerances and reports the drift (e.g. after a camera firmware
//! update).
//!
//! Part of the report stage; used by `ledflicker plan --golden FILE`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use ledflicker_results::comparison::{self, Cases, Direction, Lead, Lookup, Pair, Tolerance};

use super::ReportError;
use crate::model::{CaseInfo, Results};

/// Absolute tolerance per metric, in the metric's units (FDI: a ratio;
/// Percent Flicker: percentage points).
#[derive(Debug, Clone, PartialEq)]
pub struct Tolerances(pub BTreeMap<String, f64>);

impl Default for Tolerances {
    /// FDI within 0.01 (a tenth of Deegan 2018's 0.1 appears-OFF limit),
    /// Percent Flicker within 0.5 percentage points.
    fn default() -> Self {
        let mut m = BTreeMap::new();
        for (k, v) in [
            ("fdi_2018", 0.01),
            ("fdi_2018_worst_phase", 0.01),
            ("percent_flicker", 0.5),
            ("percent_flicker_worst_phase", 0.5),
        ] {
            m.insert(k.to_string(), v);
        }
        Tolerances(m)
    }
}

impl Tolerances {
    /// Sets tolerances from `metric=value` pairs, e.g. `fdi_2018=0.05`.
    pub fn set(&mut self, spec: &str) -> Result<(), String> {
        let hint = || {
            format!(
                "--golden-tolerance `{spec}` is not METRIC=VALUE with VALUE >= 0\n    hint: metrics are {}",
                self.0.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        };
        let (k, v) = spec.split_once('=').ok_or_else(hint)?;
        let v: f64 = v.trim().parse().map_err(|_| hint())?;
        if !(v.is_finite() && v >= 0.0 && self.0.contains_key(k.trim())) {
            return Err(hint());
        }
        self.0.insert(k.trim().to_string(), v);
        Ok(())
    }
}

/// One metric of one ROI of one case, golden against current.
#[derive(Debug, Clone, PartialEq)]
pub struct Drift {
    /// Case id.
    pub case: String,
    /// ROI name.
    pub roi: String,
    /// Metric name as in results.json.
    pub metric: String,
    /// Golden value; `None` when undefined. `+inf` when unbounded.
    pub golden: Option<f64>,
    /// Current value, same conventions.
    pub current: Option<f64>,
    /// Tolerance used.
    pub tolerance: f64,
    /// Whether the two agree within the tolerance.
    pub within: bool,
}

impl Drift {
    /// |current - golden|, when both are finite.
    pub fn delta(&self) -> Option<f64> {
        comparison::delta(self.golden, self.current).map(f64::abs)
    }
}

/// The outcome of a comparison.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Comparison {
    /// Every value compared.
    pub values: Vec<Drift>,
    /// Cases whose verdict changed: (case, golden, current).
    pub verdict_changes: Vec<(String, String, String)>,
    /// Cases only in the golden file.
    pub missing: Vec<String>,
    /// Cases only in the current run.
    pub added: Vec<String>,
}

impl Comparison {
    /// No value beyond tolerance, no verdict change, same cases.
    pub fn ok(&self) -> bool {
        self.values.iter().all(|d| d.within)
            && self.verdict_changes.is_empty()
            && self.missing.is_empty()
            && self.added.is_empty()
    }

    /// A plain-text drift report.
    pub fn to_text(&self) -> String {
        let fmt = |v: Option<f64>| match v {
            Some(x) if x.is_infinite() => "+inf".to_string(),
            Some(x) => crate::util::fixed(x, 6),
            None => "undefined".to_string(),
        };
        let beyond: Vec<&Drift> = self.values.iter().filter(|d| !d.within).collect();
        let mut out = format!(
            "golden: {} values compared, {} beyond tolerance, {} verdict change(s)\n",
            self.values.len(),
            beyond.len(),
            self.verdict_changes.len()
        );
        let mut max: BTreeMap<&str, (f64, f64)> = BTreeMap::new();
        for d in &self.values {
            let e = max.entry(d.metric.as_str()).or_insert((0.0, d.tolerance));
            e.0 = e.0.max(d.delta().unwrap_or(0.0));
        }
        for (metric, (m, tol)) in max {
            let _ = writeln!(
                out,
                "  max drift {metric}: {} (tolerance {tol})",
                crate::util::fixed(m, 6)
            );
        }
        for d in beyond {
            let _ = writeln!(
                out,
                "  DRIFT {} / {} / {}: golden {}, now {} (tolerance {})",
                d.case,
                d.roi,
                d.metric,
                fmt(d.golden),
                fmt(d.current),
                d.tolerance
            );
        }
        for (case, a, b) in &self.verdict_changes {
            let _ = writeln!(out, "  VERDICT {case}: golden {a}, now {b}");
        }
        for case in &self.missing {
            let _ = writeln!(out, "  MISSING {case}: in the golden file, not in this run");
        }
        for case in &self.added {
            let _ = writeln!(out, "  ADDED {case}: in this run, not in the golden file");
        }
        out
    }
}

fn invalid(path: &Path, message: String) -> ReportError {
    ReportError::Invalid {
        path: path.to_path_buf(),
        message,
    }
}

/// Reads a golden results.json, typed.
pub fn load(path: &Path) -> Result<Results, ReportError> {
    let text = crate::util::read_input_to_string(path).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    crate::model::read_results(&text).map_err(|m| {
        // One hint: the reader's own (write it again) when it has one.
        let hint = if m.contains("hint:") {
            ""
        } else {
            "\n    hint: pass the results.json of an earlier run"
        };
        invalid(path, format!("{m}{hint}"))
    })
}

/// A metric of an ROI: +infinity when the FDI is unbounded, else its value.
fn metric_value(roi: &crate::model::RoiInfo, metric: &str) -> Option<f64> {
    if roi.contrast_unbounded && metric.starts_with("fdi") {
        Some(f64::INFINITY)
    } else {
        roi.metrics.get(metric).copied().flatten()
    }
}

/// The golden results.json's cases, for the comparison engine: by id,
/// in id order (the order the missing cases are named in).
struct ById<'r>(BTreeMap<&'r str, &'r CaseInfo>);

impl Cases for ById<'_> {
    type Case = CaseInfo;
    fn each(&self, f: &mut dyn FnMut(&str, &CaseInfo)) {
        self.0.iter().for_each(|(id, c)| f(id, c));
    }
    fn verdict<'c>(&self, case: &'c CaseInfo) -> &'c str {
        case.verdict.as_str()
    }
}

impl Lookup for ById<'_> {
    fn get(&self, id: &str) -> Option<&CaseInfo> {
        self.0.get(id).copied()
    }
}

/// The current run's cases, in its own order (read one at a time when
/// they are spilled).
struct InOrder<'r>(&'r Results);

impl Cases for InOrder<'_> {
    type Case = CaseInfo;
    fn each(&self, f: &mut dyn FnMut(&str, &CaseInfo)) {
        self.0.cases.iter().for_each(|c| f(&c.id, &c));
    }
    fn verdict<'c>(&self, case: &'c CaseInfo) -> &'c str {
        case.verdict.as_str()
    }
}

/// Compares `current` with `golden` (a results.json, see [`load`]).
pub fn compare(golden: &Results, current: &Results, tol: &Tolerances) -> Comparison {
    let mut out = Comparison::default();
    let golden_cases: Vec<_> = golden.cases.iter().collect();
    let by_id = ById(golden_cases.iter().map(|c| (c.id.as_str(), &**c)).collect());
    // Every case is compared whatever its conditions: a golden run is
    // the same plan by construction.
    let flips = comparison::pair(
        &InOrder(current),
        &by_id,
        Lead::B,
        |_, _| true,
        |p| match p {
            Pair::Matched { id, lead, other } => out.values.extend(drifts(id, other, lead, tol)),
            Pair::OnlyLead(id) => out.added.push(id.to_string()),
            Pair::OnlyOther(id) => out.missing.push(id.to_string()),
            Pair::Differs(_) => {}
        },
    );
    out.verdict_changes = flips.into_iter().map(|f| (f.case, f.from, f.to)).collect();
    out
}

/// Every toleranced metric of every ROI of `case`, golden (`g`) against
/// current.
fn drifts(id: &str, g: &CaseInfo, case: &CaseInfo, tol: &Tolerances) -> Vec<Drift> {
    let mut out = Vec::new();
    for roi in &case.rois {
        let groi = g.rois.iter().find(|r| r.name == roi.name);
        for (metric, &tolerance) in &tol.0 {
            let current_v = metric_value(roi, metric);
            let golden_v = groi.and_then(|r| metric_value(r, metric));
            let present_now = roi.metrics.contains_key(metric);
            let present_then = groi.is_some_and(|r| r.metrics.contains_key(metric));
            if !present_now && !present_then {
                continue;
            }
            let within = match (golden_v, current_v) {
                (Some(a), Some(b)) if a.is_infinite() || b.is_infinite() => a == b,
                (Some(a), Some(b)) => {
                    !Tolerance::fixed(tolerance).exceeded(Direction::Either, a, b)
                }
                (None, None) => present_now == present_then,
                _ => false,
            };
            out.push(Drift {
                case: id.to_string(),
                roi: roi.name.clone(),
                metric: metric.clone(),
                golden: golden_v,
                current: current_v,
                tolerance,
                within,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tolerances_parse_metric_value_pairs_and_reject_unknown_metrics() {
        let mut t = Tolerances::default();
        t.set("fdi_2018=0.05").unwrap();
        assert_eq!(t.0["fdi_2018"], 0.05);
        assert!(t.set("fdi=0.05").unwrap_err().contains("hint: metrics are"));
        assert!(t.set("fdi_2018=-1").is_err());
        assert!(t.set("fdi_2018").is_err());
    }
}
