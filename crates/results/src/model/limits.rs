//! The limits of one case as a ROI x metric table, worst ROI first: what
//! the failing-cases summary of both reports shows.
//!
//! Part of the results model; computed from a case's `checks`, so a report
//! rendered again from results.json shows the same table.
//!
//! "Worst" is the furthest beyond its limit: each check's margin is its
//! distance to the threshold relative to the threshold's size
//! ([`crate::metrics::Check::margin`]: `(value - limit) / |limit|` for a
//! minimum, `(limit - value) / |limit|` for a maximum, negative when not
//! met, minus infinity for a value that is undefined), and a ROI ranks by
//! its smallest margin, then its next smallest; ties keep plan order.

use serde::Serialize;

use super::{CaseInfo, Check};

/// One case's checks, one row per ROI that misses a limit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitTable {
    /// The metrics with a limit, in the order the checks first name them.
    pub columns: Vec<LimitColumn>,
    /// ROIs that miss at least one limit, worst first.
    pub rows: Vec<LimitRow>,
    /// ROIs with checks that meet every limit (not listed).
    pub rois_meeting_all: usize,
}

/// A metric column.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitColumn {
    /// Metric id, e.g. `fmi`.
    pub metric: String,
    /// The limit, e.g. `<= 0.1`, when every ROI has the same; `null` when
    /// they differ (each cell then gives its own).
    pub limit: Option<String>,
}

/// One ROI's checks, one cell per column.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitRow {
    /// ROI name.
    pub roi: String,
    /// Limits not met.
    pub failed: usize,
    /// Per column, the check; `null` when this ROI has none for it.
    pub cells: Vec<Option<LimitCell>>,
}

/// One check in the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitCell {
    /// The value; `null` when undefined or unbounded.
    pub value: Option<f64>,
    /// The value is +infinity.
    pub unbounded: bool,
    /// The limit, e.g. `>= 0.95`.
    pub limit: String,
    /// Met.
    pub met: bool,
    /// Distance to the limit relative to its size; < 0 not met.
    pub margin: f64,
}

fn limit_text(k: &Check) -> String {
    format!("{} {}", k.comparison, k.threshold)
}

impl CaseInfo {
    /// The case's checks as a ROI x metric table, worst ROI first (see
    /// the module's documentation for "worst").
    pub fn limit_table(&self) -> LimitTable {
        let mut metrics: Vec<&str> = Vec::new();
        let mut rois: Vec<&str> = Vec::new();
        for k in &self.checks {
            if !metrics.contains(&k.metric.as_str()) {
                metrics.push(&k.metric);
            }
            if !rois.contains(&k.roi.as_str()) {
                rois.push(&k.roi);
            }
        }
        let columns = metrics
            .iter()
            .map(|m| {
                let mut limits = self
                    .checks
                    .iter()
                    .filter(|k| k.metric == *m)
                    .map(limit_text);
                let first = limits.next();
                LimitColumn {
                    metric: m.to_string(),
                    limit: first.filter(|f| limits.all(|l| l == *f)),
                }
            })
            .collect();
        let mut ranked: Vec<(Vec<f64>, LimitRow)> = rois
            .iter()
            .map(|roi| {
                let mine: Vec<&Check> = self.checks.iter().filter(|k| k.roi == *roi).collect();
                let mut margins: Vec<f64> = mine.iter().map(|k| k.margin()).collect();
                margins.sort_by(f64::total_cmp);
                let cells = metrics
                    .iter()
                    .map(|m| {
                        mine.iter().find(|k| k.metric == *m).map(|k| LimitCell {
                            value: k.value,
                            unbounded: k.unbounded,
                            limit: limit_text(k),
                            met: k.pass,
                            margin: k.margin(),
                        })
                    })
                    .collect();
                let row = LimitRow {
                    roi: roi.to_string(),
                    failed: mine.iter().filter(|k| !k.pass).count(),
                    cells,
                };
                (margins, row)
            })
            .collect();
        let rois_meeting_all = ranked.iter().filter(|(_, r)| r.failed == 0).count();
        ranked.retain(|(_, r)| r.failed > 0);
        // A stable sort: equal margins keep plan order.
        ranked.sort_by(|a, b| {
            a.0.iter()
                .zip(&b.0)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        LimitTable {
            columns,
            rows: ranked.into_iter().map(|(_, r)| r).collect(),
            rois_meeting_all,
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::metrics::verdict::Comparison;

    pub(in crate::model) fn check(
        roi: &str,
        metric: &str,
        value: Option<f64>,
        min: bool,
        threshold: f64,
    ) -> Check {
        let comparison = if min {
            Comparison::AtLeast
        } else {
            Comparison::AtMost
        };
        let pass = value.is_some_and(|v| if min { v >= threshold } else { v <= threshold });
        Check {
            roi: roi.to_string(),
            metric: metric.to_string(),
            value,
            unbounded: false,
            comparison,
            threshold,
            pass,
            reason: None,
        }
    }

    pub(in crate::model) fn case(checks: Vec<Check>) -> CaseInfo {
        let mut c = minimal_case();
        c.checks = checks;
        c
    }

    fn minimal_case() -> CaseInfo {
        serde_json::from_value(serde_json::json!({
            "id": "c", "light_lux": 1.0, "frequency_hz": 90.0, "duty": 0.5, "seed": 1,
            "verdict": "fail", "not_judged": null, "not_checked": [], "acquisition": "",
            "in_mitigation_range": true, "frames": 0, "trace": "", "sample_frame": null,
            "rois": [], "checks": [], "apparent_frequency_hz": 0.0, "hazard_class": "steady",
            "beat": {"apparent_frequency_hz": 0.0, "method": "frame-times", "frame_rate_fps": 30.0,
                     "resolution_hz": null, "period_s": null, "capture_s": 1.0,
                     "longer_than_capture": true, "note": ""},
            "drive": {"percent_flicker": 0.0, "flicker_index": 0.0, "ieee1789_region": "no-observable-effect",
                      "ieee1789_low_risk_max_percent": null, "ieee1789_noel_max_percent": null},
            "banding": null
        }))
        .unwrap()
    }

    #[test]
    fn rows_are_the_failing_rois_furthest_beyond_their_limit_first() {
        let c = case(vec![
            // a: 20 % beyond fmi <= 0.1; b: 50 % beyond; c: undefined (worst);
            // d meets both limits.
            check("a", "fmi", Some(0.12), false, 0.1),
            check("a", "mmp", Some(0.95), true, 0.9),
            check("b", "fmi", Some(0.15), false, 0.1),
            check("b", "mmp", Some(0.5), true, 0.9),
            check("c", "fmi", None, false, 0.1),
            check("c", "mmp", Some(0.95), true, 0.9),
            check("d", "fmi", Some(0.05), false, 0.1),
            check("d", "mmp", Some(0.99), true, 0.9),
        ]);
        let t = c.limit_table();
        let order: Vec<&str> = t.rows.iter().map(|r| r.roi.as_str()).collect();
        assert_eq!(order, ["c", "b", "a"]);
        assert_eq!(t.rois_meeting_all, 1);
        assert_eq!(t.columns[0].limit.as_deref(), Some("<= 0.1"));
        assert_eq!(t.columns[1].limit.as_deref(), Some(">= 0.9"));
        // b misses both; its mmp margin (0.5 - 0.9) / 0.9 is its worst.
        assert_eq!(t.rows[1].failed, 2);
        let mmp = t.rows[1].cells[1].as_ref().unwrap();
        assert!(!mmp.met && (mmp.margin - (0.5 - 0.9) / 0.9).abs() < 1e-12);
    }
}
