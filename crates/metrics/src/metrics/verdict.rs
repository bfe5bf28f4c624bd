//! Verdicts: metrics against the plan's thresholds.
//!
//! A failed case is data (`Verdict::Fail`), not an error. A case whose PWM
//! frequency lies outside the range where the camera claims mitigation is
//! informational: it is measured and checked, but cannot fail the plan. So
//! is a case the plan marks `informative`, and one no limit applies to. A
//! plan with no judged case is `info` overall, never `pass`.

use serde::{Deserialize, Serialize};

use super::flicker::{Metric, RoiMetrics};
use super::p2020::P2020Metrics;
use ledflicker_plan::plan::{BackendKind, Limits, Roi, RoiKind, Thresholds, VerdictBasis};

/// Slack when comparing a metric with its threshold, in the metric's units.
/// A value within this of the threshold meets it, so that the last bit of a
/// floating-point sum cannot flip a verdict on a boundary case (e.g. an
/// exposure exactly on Deegan 2018 Eq. (1)).
pub const VERDICT_TOLERANCE: f64 = 1e-9;

/// Outcome of a case (or of a whole plan).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Every check met its threshold.
    Pass,
    /// Some check did not.
    Fail,
    /// Not judged (outside the claimed mitigation range, marked
    /// informative, or no limit applies): reported, never failing. As the
    /// plan verdict: no case was judged.
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
    pub comparison: Comparison,
    /// Threshold.
    pub threshold: f64,
    /// Whether the check is met.
    pub pass: bool,
    /// Why the value is missing, if it is.
    pub reason: Option<String>,
}

ledflicker_plan::trace::words! {
    /// How a check compares its value with its threshold.
    Comparison {
        /// The value must be at least the threshold.
        AtLeast = ">=",
        /// The value must be at most the threshold.
        AtMost = "<=",
    }
}

impl Check {
    /// Margin to the threshold, relative to the threshold's size: > 0 met
    /// with room, < 0 missed; -inf for an undefined value, +inf for an
    /// unbounded value that meets a minimum. Orders ROIs from worst to best.
    pub fn margin(&self) -> f64 {
        let scale = self.threshold.abs().max(1e-3);
        let min = self.comparison == Comparison::AtLeast;
        match (self.value, self.unbounded) {
            (_, true) if min => f64::INFINITY,
            (_, true) => f64::NEG_INFINITY,
            (None, false) => f64::NEG_INFINITY,
            (Some(v), false) if min => (v - self.threshold) / scale,
            (Some(v), false) => (self.threshold - v) / scale,
        }
    }

    /// One line for a person: `fmi 1.000 > 0.1 on roi07` when the check
    /// failed, `fmi 0.020 <= 0.1 on roi07` when it passed.
    pub fn describe(&self) -> String {
        let value = match (self.value, self.unbounded) {
            (_, true) => "+inf".to_string(),
            (Some(v), false) => ledflicker_plan::util::fixed(v, 3),
            (None, false) => "undefined".to_string(),
        };
        let undefined = self.value.is_none() && !self.unbounded;
        let op = match (self.pass, self.comparison) {
            (true, c) => c.as_str(),
            (false, Comparison::AtLeast) if undefined => "is not >=",
            (false, Comparison::AtLeast) => "<",
            (false, Comparison::AtMost) if undefined => "is not <=",
            (false, Comparison::AtMost) => ">",
        };
        format!(
            "{} {value} {op} {} on {}",
            self.metric, self.threshold, self.roi
        )
    }
}

/// Whether a value meets its threshold, within [`VERDICT_TOLERANCE`]: an
/// unbounded value meets every minimum and no maximum; an undefined value
/// meets nothing (it could not be shown to).
pub fn meets(value: Option<f64>, unbounded: bool, threshold: f64, min: bool) -> bool {
    if min {
        unbounded || value.is_some_and(|v| v >= threshold - VERDICT_TOLERANCE)
    } else {
        !unbounded && value.is_some_and(|v| v <= threshold + VERDICT_TOLERANCE)
    }
}

/// The plan's limits by the metric family each checks (the name a check
/// carries, before the basis's `_worst_phase`): the family, its limit in
/// `lim`, and whether the limit is a minimum.
pub fn limit_families(lim: &Limits) -> [(&'static str, Option<f64>, bool); 7] {
    [
        ("fdi_2018", lim.fdi_2018_min, true),
        ("percent_flicker", lim.percent_flicker_max, false),
        ("fmi", lim.fmi_max, false),
        ("fdi_p2020", lim.fdi_p2020_min, true),
        ("mmp", lim.mmp_min, true),
        ("visibility", lim.visibility_max, false),
        ("delta_uv", lim.delta_uv_max, false),
    ]
}

/// A case's verdict from its checks: info when it is not judged or has no
/// check, else pass when every check passes.
pub fn case_verdict(judged: bool, checks: impl IntoIterator<Item = bool>) -> Verdict {
    let mut any = false;
    for pass in checks {
        if !pass {
            return if judged { Verdict::Fail } else { Verdict::Info };
        }
        any = true;
    }
    if judged && any {
        Verdict::Pass
    } else {
        Verdict::Info
    }
}

fn check(roi: &str, name: &str, m: &Metric, threshold: f64, min: bool) -> Check {
    let pass = meets(m.value, m.unbounded, threshold, min);
    Check {
        roi: roi.to_string(),
        metric: name.to_string(),
        value: m.value,
        unbounded: m.unbounded,
        comparison: if min {
            Comparison::AtLeast
        } else {
            Comparison::AtMost
        },
        threshold,
        pass,
        reason: m.reason.clone(),
    }
}

/// Whether `frequency_hz` lies in the claimed mitigation range.
pub fn in_mitigation_range(frequency_hz: f64, t: &Thresholds) -> bool {
    frequency_hz >= t.mitigation_min_hz && t.mitigation_max_hz.is_none_or(|max| frequency_hz <= max)
}

/// The figure verdicts actually use: the worst phase exists only where the
/// backend computes it (the simulator), so captures and rigs are judged as
/// captured whatever `basis` says.
pub fn effective_basis(backend: BackendKind, t: &Thresholds) -> VerdictBasis {
    match backend {
        BackendKind::Simulator => t.basis,
        BackendKind::Captured | BackendKind::Command => VerdictBasis::AsCaptured,
    }
}

/// What a case's verdict needs besides its metrics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaseConditions {
    /// PWM frequency, Hz; `None` when unknown (a capture without conditions):
    /// the mitigation range then cannot exclude the case.
    pub frequency_hz: Option<f64>,
    /// Light level, lux; `None` when unknown: the global limits apply.
    pub light_lux: Option<f64>,
    /// The plan marks the case informative: measured, never judged.
    pub informative: bool,
}

/// One ROI's figures for the verdict.
#[derive(Debug, Clone, Copy)]
pub struct RoiFigures<'a> {
    /// The ROI.
    pub roi: &'a Roi,
    /// Deegan 2018 metrics.
    pub metrics: &'a RoiMetrics,
    /// IEEE P2020 KPIs, when computed.
    pub p2020: Option<&'a P2020Metrics>,
}

/// The verdict of one case and how it was reached.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// pass, fail or info.
    pub verdict: Verdict,
    /// Every threshold check made.
    pub checks: Vec<Check>,
    /// Why the case is informational, when it is.
    pub not_judged: Option<String>,
    /// Limits that could not apply to this case and why, one line each
    /// (e.g. an FDI on a capture without an OFF segment).
    pub not_checked: Vec<String>,
}

/// The checks of one LED ROI. A limit whose metric needs a segment the
/// trace lacks (FDI: OFF; MMP on the ON level: ON) does not apply; it is
/// listed in `not_checked` instead of failing.
fn roi_checks(
    r: &RoiFigures<'_>,
    lim: &Limits,
    basis: VerdictBasis,
    checks: &mut Vec<Check>,
    not_checked: &mut Vec<String>,
) {
    let name = r.roi.name.as_str();
    let m = r.metrics;
    let (fdi, pf, suffix) = match (
        basis,
        &m.fdi_2018_worst_phase,
        &m.percent_flicker_worst_phase,
    ) {
        (VerdictBasis::WorstPhase, Some(fdi), Some(pf)) => (fdi, pf, "_worst_phase"),
        _ => (&m.fdi_2018, &m.percent_flicker, ""),
    };
    let no_off = m.levels.off.is_none();
    let mut skip = |metric: &str, why: &str| {
        let metric = super::glossary::human_name(metric);
        not_checked.push(format!("{name}: {metric} not checked: {why}"));
    };
    if let Some(min) = lim.fdi_2018_min {
        if no_off {
            skip("fdi_2018", "the trace has no OFF segment (L_OFF)");
        } else {
            checks.push(check(name, &format!("fdi_2018{suffix}"), fdi, min, true));
        }
    }
    if let Some(max) = lim.percent_flicker_max {
        checks.push(check(
            name,
            &format!("percent_flicker{suffix}"),
            pf,
            max,
            false,
        ));
    }
    let p = r.p2020;
    if let Some(max) = lim.fmi_max {
        match p {
            Some(p) => checks.push(check(name, "fmi", &p.fmi, max, false)),
            None => skip("fmi", "no P2020 KPIs for this trace"),
        }
    }
    if let Some(min) = lim.fdi_p2020_min {
        match p {
            Some(p) if p.x_off.is_some() => {
                checks.push(check(name, "fdi_p2020", &p.fdi, min, true))
            }
            _ => skip("fdi_p2020", "the trace has no OFF segment (x_off)"),
        }
    }
    if let Some(min) = lim.mmp_min {
        match p {
            Some(p) if p.x_ref.is_some() => checks.push(check(name, "mmp", &p.mmp, min, true)),
            _ => skip("mmp", "the trace has no frames for the MMP reference level"),
        }
    }
    if let Some(max) = lim.visibility_max {
        match &m.visibility {
            Some(v) => checks.push(check(name, "visibility", &v.metric(), max, false)),
            None => skip("visibility", "no display to see it on"),
        }
    }
    if let Some(max) = lim.delta_uv_max {
        match &m.colour {
            Some(c) => checks.push(check(name, "delta_uv", &c.delta_uv_metric(), max, false)),
            None => skip("delta_uv", "no colour planes for this ROI"),
        }
    }
}

/// Checks every LED ROI of a case against its limits (per light level, else
/// global) and gives the case verdict. An undefined metric fails its check
/// (it could not be shown to meet the threshold); its reason is kept. A case
/// is `info` when the plan marks it informative, when its frequency is
/// known and outside the mitigation range, or when no check applies.
pub fn evaluate_case(
    cond: &CaseConditions,
    rois: &[RoiFigures<'_>],
    t: &Thresholds,
    basis: VerdictBasis,
) -> Evaluation {
    let lim = t.limits_for(cond.light_lux);
    let mut checks = Vec::new();
    let mut not_checked = Vec::new();
    for r in rois.iter().filter(|r| r.roi.kind == RoiKind::Led) {
        roi_checks(r, &lim, basis, &mut checks, &mut not_checked);
    }
    let not_judged = if cond.informative {
        Some("the plan marks this case informative (informative = true)".to_string())
    } else if let Some(f) = cond.frequency_hz.filter(|f| !in_mitigation_range(*f, t)) {
        Some(format!(
            "{f} Hz is outside the claimed mitigation range ({} Hz{})",
            t.mitigation_min_hz,
            t.mitigation_max_hz
                .map_or(" and up".to_string(), |m| format!(" to {m} Hz"))
        ))
    } else if checks.is_empty() {
        Some(if not_checked.is_empty() {
            "no threshold applies: the plan sets none for its LED ROIs".to_string()
        } else {
            format!("no threshold applies ({})", not_checked.join("; "))
        })
    } else {
        None
    };
    let verdict = case_verdict(not_judged.is_none(), checks.iter().map(|c| c.pass));
    Evaluation {
        verdict,
        checks,
        not_judged,
        not_checked,
    }
}

/// The plan verdict: fail if any case failed, else pass if any case was
/// judged, else info (nothing was judged: never a pass).
pub fn overall(verdicts: impl IntoIterator<Item = Verdict>) -> Verdict {
    let mut any_pass = false;
    for v in verdicts {
        match v {
            Verdict::Fail => return Verdict::Fail,
            Verdict::Pass => any_pass = true,
            Verdict::Info => {}
        }
    }
    if any_pass {
        Verdict::Pass
    } else {
        Verdict::Info
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::flicker::Segment;
    use crate::metrics::flicker::{Levels, fdi_2018, percent_flicker};
    use crate::metrics::p2020::{self, P2020Options};

    fn thresholds() -> Thresholds {
        Thresholds {
            limits: Limits {
                fdi_2018_min: Some(0.1),
                percent_flicker_max: Some(10.0),
                ..Limits::default()
            },
            light_levels: Vec::new(),
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
            visibility: None,
            colour: None,
        }
    }

    fn at(f: f64) -> CaseConditions {
        CaseConditions {
            frequency_hz: Some(f),
            light_lux: Some(2000.0),
            informative: false,
        }
    }

    fn eval(
        c: CaseConditions,
        m: &RoiMetrics,
        p: Option<&P2020Metrics>,
        t: &Thresholds,
    ) -> Evaluation {
        let r = roi();
        let figures = [RoiFigures {
            roi: &r,
            metrics: m,
            p2020: p,
        }];
        evaluate_case(&c, &figures, t, VerdictBasis::AsCaptured)
    }

    #[test]
    fn verdict_on_the_threshold_does_not_flip_on_rounding() {
        // (22 - 20) / 20 is 0.1 with a rounding error in the last bit.
        let m = metrics(22.000000000000004, 22.5, 20.0);
        let e = eval(at(100.0), &m, None, &thresholds());
        assert_eq!(e.verdict, Verdict::Pass);
        let m = metrics(21.9, 22.5, 20.0);
        let e = eval(at(100.0), &m, None, &thresholds());
        assert_eq!(e.verdict, Verdict::Fail);
        assert!(!e.checks[0].pass && e.checks[1].pass);
        assert_eq!(e.checks[0].describe(), "fdi_2018 0.095 < 0.1 on led");
    }

    #[test]
    fn the_shared_rules_judge_what_import_and_the_run_judge() {
        // A value a tolerance away meets its limit; two tolerances away not.
        assert!(meets(Some(0.1 - 0.5e-9), false, 0.1, true));
        assert!(!meets(Some(0.1 - 2e-9), false, 0.1, true));
        assert!(meets(Some(10.0 + 0.5e-9), false, 10.0, false));
        assert!(!meets(Some(10.0 + 2e-9), false, 10.0, false));
        assert!(meets(None, true, 0.1, true) && !meets(None, true, 10.0, false));
        assert!(!meets(None, false, 0.1, true) && !meets(None, false, 10.0, false));
        assert_eq!(case_verdict(true, [true, true]), Verdict::Pass);
        assert_eq!(case_verdict(true, [true, false]), Verdict::Fail);
        assert_eq!(case_verdict(false, [false]), Verdict::Info);
        assert_eq!(case_verdict(true, []), Verdict::Info);
        let families = limit_families(&thresholds().limits_for(None));
        assert_eq!(families.len(), 7);
        assert!(families.contains(&("fdi_2018", Some(0.1), true)));
    }

    #[test]
    fn cases_below_the_mitigation_range_are_informational() {
        let m = metrics(20.0, 40.0, 20.0);
        let e = eval(at(50.0), &m, None, &thresholds());
        assert_eq!(e.verdict, Verdict::Info);
        assert!(e.not_judged.unwrap().contains("50 Hz is outside"));
        assert!(e.checks.iter().any(|c| !c.pass));
        assert_eq!(overall([Verdict::Info, Verdict::Pass]), Verdict::Pass);
        assert_eq!(overall([Verdict::Info, Verdict::Fail]), Verdict::Fail);
    }

    #[test]
    fn a_plan_with_no_judged_case_is_never_a_pass() {
        assert_eq!(overall([Verdict::Info, Verdict::Info]), Verdict::Info);
        assert_eq!(overall([]), Verdict::Info);
    }

    #[test]
    fn unbounded_fdi_passes_its_minimum_and_undefined_fails() {
        let mut m = metrics(5.0, 5.0, 0.0);
        m.fdi_2018 = fdi_2018(5.0, Some(0.0));
        let e = eval(at(100.0), &m, None, &thresholds());
        assert_eq!(e.verdict, Verdict::Pass);
        m.fdi_2018 = fdi_2018(0.0, Some(0.0));
        let e = eval(at(100.0), &m, None, &thresholds());
        assert_eq!(e.verdict, Verdict::Fail);
        assert!(e.checks[0].reason.is_some());
        assert_eq!(e.checks[0].margin(), f64::NEG_INFINITY);
    }

    /// Issue 12: a capture with unknown conditions is judged on the limits
    /// that need no conditions; a capture without an OFF segment skips FDI.
    #[test]
    fn captures_without_conditions_are_judged_and_skip_what_they_cannot_measure() {
        let unknown = CaseConditions {
            frequency_hz: None,
            light_lux: None,
            informative: false,
        };
        let mut m = metrics(10.0, 90.0, 1.0);
        m.levels.off = None;
        m.fdi_2018 = fdi_2018(10.0, None);
        let e = eval(unknown, &m, None, &thresholds());
        assert_eq!(e.verdict, Verdict::Fail, "{e:?}");
        assert_eq!(e.checks.len(), 1);
        assert_eq!(e.checks[0].metric, "percent_flicker");
        assert!(e.not_checked[0].contains("no OFF segment"));
        // The line reaches the reports: the metric is named for people.
        assert!(
            e.not_checked[0].contains("FDI (Deegan 2018) not checked"),
            "{:?}",
            e.not_checked
        );
        // Only FDI (2018) set and no OFF segment: nothing applies, so info.
        let t = Thresholds {
            limits: Limits {
                percent_flicker_max: None,
                ..thresholds().limits
            },
            ..thresholds()
        };
        let e = eval(unknown, &m, None, &t);
        assert_eq!(e.verdict, Verdict::Info);
        assert!(e.not_judged.unwrap().starts_with("no threshold applies"));
        // Marked informative: info whatever the metrics.
        let e = eval(
            CaseConditions {
                informative: true,
                ..unknown
            },
            &m,
            None,
            &thresholds(),
        );
        assert_eq!(e.verdict, Verdict::Info);
    }

    #[test]
    fn p2020_limits_fail_a_beat_to_zero_and_pass_steady_light() {
        use Segment::*;
        let segs = [Off, Off, Pwm, Pwm, Pwm, Pwm];
        let t = Thresholds {
            limits: Limits {
                fmi_max: Some(0.1),
                fdi_p2020_min: Some(0.95),
                mmp_min: Some(0.9),
                ..Limits::default()
            },
            ..thresholds()
        };
        // Light to 0 DN in one frame of four: FMI 1, FDI 3/4, MMP 0.
        let beat = [0.0, 0.0, 100.0, 0.0, 100.0, 100.0];
        let p = p2020::evaluate(&beat, &segs, &P2020Options::default()).unwrap();
        let m = metrics(0.0, 100.0, 0.0);
        let e = eval(at(100.0), &m, Some(&p), &t);
        assert_eq!(e.verdict, Verdict::Fail);
        let failed: Vec<String> = e
            .checks
            .iter()
            .filter(|c| !c.pass)
            .map(Check::describe)
            .collect();
        assert_eq!(
            failed,
            [
                "fmi 1.000 > 0.1 on led",
                "fdi_p2020 0.750 < 0.95 on led",
                "mmp 0.000 < 0.9 on led"
            ]
        );
        let steady = [0.0, 0.0, 100.0, 100.0, 100.0, 100.0];
        let p = p2020::evaluate(&steady, &segs, &P2020Options::default()).unwrap();
        let e = eval(at(100.0), &metrics(100.0, 100.0, 0.0), Some(&p), &t);
        assert_eq!(e.verdict, Verdict::Pass, "{:?}", e.checks);
    }

    #[test]
    fn light_level_limits_override_the_global_ones() {
        let mut t = thresholds();
        t.light_levels.push(ledflicker_plan::plan::LevelLimits {
            light_lux: 40.0,
            limits: Limits {
                percent_flicker_max: Some(50.0),
                ..Limits::default()
            },
        });
        let m = metrics(22.5, 40.0, 20.0);
        assert_eq!(eval(at(100.0), &m, None, &t).verdict, Verdict::Fail);
        let low = CaseConditions {
            light_lux: Some(40.0),
            ..at(100.0)
        };
        let e = eval(low, &m, None, &t);
        assert_eq!(e.verdict, Verdict::Pass, "{:?}", e.checks);
        assert_eq!(e.checks[1].threshold, 50.0);
        assert_eq!(
            e.checks[0].threshold, 0.1,
            "unset keys come from [thresholds]"
        );
    }
}
