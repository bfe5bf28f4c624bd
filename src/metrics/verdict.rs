//! Verdicts: metrics against the plan's thresholds.
//!
//! A failed case is data (`Verdict::Fail`), not an error. A case whose PWM
//! frequency lies outside the range where the camera claims mitigation is
//! informational: it is measured and checked, but cannot fail the plan.

use serde::Serialize;

use super::flicker::{Metric, RoiMetrics};
use crate::plan::{Roi, RoiKind, Thresholds, VerdictBasis};

/// Slack when comparing a metric with its threshold, in the metric's units.
/// A value within this of the threshold meets it, so that the last bit of a
/// floating-point sum cannot flip a verdict on a boundary case (e.g. an
/// exposure exactly on Deegan 2018 Eq. (1)).
pub const VERDICT_TOLERANCE: f64 = 1e-9;

/// Outcome of a case (or of a whole plan).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Every check met its threshold.
    Pass,
    /// Some check did not.
    Fail,
    /// Outside the claimed mitigation range: reported, never failing.
    Info,
}

impl Verdict {
    /// Lowercase name, as in results.json.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "fail",
            Verdict::Info => "info",
        }
    }
}

/// One metric compared with one threshold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// ROI name.
    pub roi: String,
    /// Metric name as in results.json, e.g. `fdi_2018_worst_phase`.
    pub metric: String,
    /// The value compared; `None` when undefined or unbounded.
    pub value: Option<f64>,
    /// The value is +infinity (a contrast over a zero reference).
    pub unbounded: bool,
    /// `>=` or `<=`.
    pub comparison: &'static str,
    /// Threshold.
    pub threshold: f64,
    /// Whether the check is met.
    pub pass: bool,
    /// Why the value is missing, if it is.
    pub reason: Option<String>,
}

fn check_min(roi: &str, name: &str, m: &Metric, threshold: f64) -> Check {
    let pass = m.unbounded || m.value.is_some_and(|v| v >= threshold - VERDICT_TOLERANCE);
    Check {
        roi: roi.to_string(),
        metric: name.to_string(),
        value: m.value,
        unbounded: m.unbounded,
        comparison: ">=",
        threshold,
        pass,
        reason: m.reason.clone(),
    }
}

fn check_max(roi: &str, name: &str, m: &Metric, threshold: f64) -> Check {
    let pass = !m.unbounded && m.value.is_some_and(|v| v <= threshold + VERDICT_TOLERANCE);
    Check {
        roi: roi.to_string(),
        metric: name.to_string(),
        value: m.value,
        unbounded: m.unbounded,
        comparison: "<=",
        threshold,
        pass,
        reason: m.reason.clone(),
    }
}

/// Whether `frequency_hz` lies in the claimed mitigation range.
pub fn in_mitigation_range(frequency_hz: f64, t: &Thresholds) -> bool {
    frequency_hz >= t.mitigation_min_hz && t.mitigation_max_hz.is_none_or(|max| frequency_hz <= max)
}

/// Checks every LED ROI of a case against the thresholds and gives the
/// case verdict. An undefined metric fails its check (it could not be shown
/// to meet the threshold); its reason is kept.
pub fn evaluate_case(
    frequency_hz: f64,
    rois: &[(&Roi, &RoiMetrics)],
    t: &Thresholds,
) -> (Verdict, Vec<Check>) {
    let mut checks = Vec::new();
    for (roi, m) in rois {
        if roi.kind != RoiKind::Led {
            continue;
        }
        let (fdi, pf, suffix) = match (
            t.basis,
            &m.fdi_2018_worst_phase,
            &m.percent_flicker_worst_phase,
        ) {
            (VerdictBasis::WorstPhase, Some(fdi), Some(pf)) => (fdi, pf, "_worst_phase"),
            _ => (&m.fdi_2018, &m.percent_flicker, ""),
        };
        if let Some(min) = t.fdi_2018_min {
            checks.push(check_min(&roi.name, &format!("fdi_2018{suffix}"), fdi, min));
        }
        if let Some(max) = t.percent_flicker_max {
            checks.push(check_max(
                &roi.name,
                &format!("percent_flicker{suffix}"),
                pf,
                max,
            ));
        }
    }
    let verdict = if !in_mitigation_range(frequency_hz, t) {
        Verdict::Info
    } else if checks.iter().all(|c| c.pass) {
        Verdict::Pass
    } else {
        Verdict::Fail
    };
    (verdict, checks)
}

/// The plan verdict: fail if any case failed, else pass.
pub fn overall(verdicts: impl IntoIterator<Item = Verdict>) -> Verdict {
    if verdicts.into_iter().any(|v| v == Verdict::Fail) {
        Verdict::Fail
    } else {
        Verdict::Pass
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::flicker::{Levels, fdi_2018, percent_flicker};

    fn thresholds() -> Thresholds {
        Thresholds {
            fdi_2018_min: Some(0.1),
            percent_flicker_max: Some(10.0),
            mitigation_min_hz: 90.0,
            mitigation_max_hz: None,
            basis: VerdictBasis::AsCaptured,
        }
    }

    fn roi() -> Roi {
        Roi {
            name: "led".into(),
            kind: RoiKind::Led,
            x_px: 0,
            y_px: 0,
            width_px: 100,
            height_px: 2,
        }
    }

    fn metrics(min: f64, max: f64, off: f64) -> RoiMetrics {
        RoiMetrics {
            levels: Levels {
                off: Some(off),
                on: None,
                min,
                max,
                mean: (min + max) / 2.0,
            },
            fdi_2018: fdi_2018(min, Some(off)),
            percent_flicker: percent_flicker(min, max),
            fdi_2018_worst_phase: None,
            percent_flicker_worst_phase: None,
            saturated: false,
        }
    }

    #[test]
    fn verdict_on_the_threshold_does_not_flip_on_rounding() {
        // (22 - 20) / 20 is 0.1 with a rounding error in the last bit.
        let m = metrics(22.000000000000004, 22.5, 20.0);
        let (v, _) = evaluate_case(100.0, &[(&roi(), &m)], &thresholds());
        assert_eq!(v, Verdict::Pass);
        let m = metrics(21.9, 22.5, 20.0);
        let (v, checks) = evaluate_case(100.0, &[(&roi(), &m)], &thresholds());
        assert_eq!(v, Verdict::Fail);
        assert!(!checks[0].pass && checks[1].pass);
    }

    #[test]
    fn cases_below_the_mitigation_range_are_informational() {
        let m = metrics(20.0, 40.0, 20.0);
        let (v, checks) = evaluate_case(50.0, &[(&roi(), &m)], &thresholds());
        assert_eq!(v, Verdict::Info);
        assert!(checks.iter().any(|c| !c.pass));
        assert_eq!(overall([Verdict::Info, Verdict::Pass]), Verdict::Pass);
        assert_eq!(overall([Verdict::Info, Verdict::Fail]), Verdict::Fail);
    }

    #[test]
    fn unbounded_fdi_passes_its_minimum_and_undefined_fails() {
        let mut m = metrics(5.0, 5.0, 0.0);
        m.fdi_2018 = fdi_2018(5.0, Some(0.0));
        let (v, _) = evaluate_case(100.0, &[(&roi(), &m)], &thresholds());
        assert_eq!(v, Verdict::Pass);
        m.fdi_2018 = fdi_2018(0.0, Some(0.0));
        let (v, checks) = evaluate_case(100.0, &[(&roi(), &m)], &thresholds());
        assert_eq!(v, Verdict::Fail);
        assert!(checks[0].reason.is_some());
    }
}
