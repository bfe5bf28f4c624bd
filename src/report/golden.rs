//! Golden results: compares a run with a stored results.json within
//! per-metric tolerances and reports the drift (e.g. after a camera firmware
//! update).
//!
//! Part of the report stage; used by `ledflicker plan --golden FILE`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::ReportError;
use crate::model::Results;

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
        match (self.golden, self.current) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => Some((b - a).abs()),
            _ => None,
        }
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

/// Reads a golden results.json.
pub fn load(path: &Path) -> Result<serde_json::Value, ReportError> {
    let text = std::fs::read_to_string(path).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| invalid(path, format!("not valid JSON: {e}")))?;
    if v["schema"].as_str() != Some(crate::model::RESULTS_SCHEMA) || !v["cases"].is_array() {
        return Err(invalid(
            path,
            format!(
                "not a `{}` file\n    hint: pass the results.json of an earlier run",
                crate::model::RESULTS_SCHEMA
            ),
        ));
    }
    Ok(v)
}

/// Compares `current` with `golden` (a results.json, see [`load`]).
pub fn compare(golden: &serde_json::Value, current: &Results, tol: &Tolerances) -> Comparison {
    let mut out = Comparison::default();
    let golden_cases: BTreeMap<&str, &serde_json::Value> = golden["cases"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|c| c["id"].as_str().map(|id| (id, c)))
        .collect();
    for case in &current.cases {
        let Some(g) = golden_cases.get(case.id.as_str()) else {
            out.added.push(case.id.clone());
            continue;
        };
        let gv = g["verdict"].as_str().unwrap_or("?");
        if gv != case.verdict.as_str() {
            out.verdict_changes.push((
                case.id.clone(),
                gv.to_string(),
                case.verdict.as_str().to_string(),
            ));
        }
        for roi in &case.rois {
            let groi = g["rois"]
                .as_array()
                .into_iter()
                .flatten()
                .find(|r| r["name"].as_str() == Some(roi.name.as_str()));
            for (metric, &tolerance) in &tol.0 {
                let unbounded_now = roi.contrast_unbounded && metric.starts_with("fdi");
                let current_v = if unbounded_now {
                    Some(f64::INFINITY)
                } else {
                    roi.metrics.get(metric).copied().flatten()
                };
                let golden_v = groi.and_then(|r| {
                    if r["contrast_unbounded"].as_bool() == Some(true) && metric.starts_with("fdi")
                    {
                        Some(f64::INFINITY)
                    } else {
                        r["metrics"][metric.as_str()].as_f64()
                    }
                });
                let present_now = roi.metrics.contains_key(metric);
                let present_then =
                    groi.is_some_and(|r| r["metrics"].get(metric.as_str()).is_some());
                if !present_now && !present_then {
                    continue;
                }
                let within = match (golden_v, current_v) {
                    (Some(a), Some(b)) if a.is_infinite() || b.is_infinite() => a == b,
                    (Some(a), Some(b)) => (a - b).abs() <= tolerance,
                    (None, None) => present_now == present_then,
                    _ => false,
                };
                out.values.push(Drift {
                    case: case.id.clone(),
                    roi: roi.name.clone(),
                    metric: metric.clone(),
                    golden: golden_v,
                    current: current_v,
                    tolerance,
                    within,
                });
            }
        }
    }
    for id in golden_cases.keys() {
        if !current.cases.iter().any(|c| c.id == *id) {
            out.missing.push(id.to_string());
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
