//! The verdicts of an imported report, judged again from its data:
//! `import` records what the values and the plan's limits say, never what
//! results.json concludes (docs/campaigns.md, "What import trusts").
//!
//! Each case's checks are rebuilt from its ROIs' recorded values and the
//! limits of its light level (`thresholds`), with the tolerance and the
//! rules of the run itself (an undefined value fails; a case outside the
//! mitigation range, or with no limit that applies, is not judged); then
//! the case verdicts, the counts and the overall verdict. A report whose
//! conclusions differ from its own data was edited, or written by a tool
//! that judged otherwise: it is refused, naming the case.

use crate::model::{CaseInfo, Comparison, Results, RoiKind, VERDICT_TOLERANCE};
use crate::model::{Thresholds, Verdict};

/// The mismatches between what `r` concludes and what its data says, at
/// most `MAX` of them, one line each; empty when they agree.
pub fn mismatches(r: &Results) -> Vec<String> {
    const MAX: usize = 8;
    let mut out = Vec::new();
    let mut verdicts = Vec::new();
    let mut counts = [0usize; 3];
    for case in r.cases.iter() {
        let verdict = judge(&case, &r.thresholds, &mut out);
        if verdict != case.verdict {
            out.push(format!(
                "case `{}`: results.json says {}, its checks and limits say {}",
                case.id,
                case.verdict.as_str(),
                verdict.as_str()
            ));
        }
        counts[match verdict {
            Verdict::Pass => 0,
            Verdict::Fail => 1,
            Verdict::Info => 2,
        }] += 1;
        verdicts.push(verdict);
        if out.len() >= MAX {
            break;
        }
    }
    if out.is_empty() {
        let overall = crate::metrics::verdict::overall(verdicts);
        if overall != r.verdict {
            out.push(format!(
                "the overall verdict: results.json says {}, its cases say {}",
                r.verdict.as_str(),
                overall.as_str()
            ));
        }
        let said = [r.counts.pass, r.counts.fail, r.counts.info];
        if said != counts || r.counts.total != r.cases.len() {
            out.push(format!(
                "the counts: results.json says {} pass, {} fail, {} not judged of {}; its cases say {} pass, {} fail, {} not judged of {}",
                said[0],
                said[1],
                said[2],
                r.counts.total,
                counts[0],
                counts[1],
                counts[2],
                r.cases.len()
            ));
        }
    }
    out.truncate(MAX);
    out
}

/// The limit a check on `metric` takes from `lim`, and whether it is a
/// minimum; `None` for a metric no limit names.
fn limit_of(metric: &str, lim: &crate::plan::Limits) -> Option<(Option<f64>, bool)> {
    Some(match metric {
        "fdi_2018" | "fdi_2018_worst_phase" => (lim.fdi_2018_min, true),
        "percent_flicker" | "percent_flicker_worst_phase" => (lim.percent_flicker_max, false),
        "fmi" => (lim.fmi_max, false),
        "fdi_p2020" => (lim.fdi_p2020_min, true),
        "mmp" => (lim.mmp_min, true),
        "visibility" => (lim.visibility_max, false),
        "delta_uv" => (lim.delta_uv_max, false),
        _ => return None,
    })
}

/// The case's verdict from its data; what does not add up goes to `out`.
fn judge(case: &CaseInfo, t: &Thresholds, out: &mut Vec<String>) -> Verdict {
    let lux = (case.light_lux > 0.0).then_some(case.light_lux);
    let lim = t.limits_for(lux);
    let mut all_pass = true;
    for c in &case.checks {
        let Some((limit, min)) = limit_of(&c.metric, &lim) else {
            out.push(format!(
                "case `{}`: a check on `{}`, which no limit of the plan names",
                case.id, c.metric
            ));
            continue;
        };
        if limit != Some(c.threshold) || min != (c.comparison == Comparison::AtLeast) {
            out.push(format!(
                "case `{}`: the check of {} on `{}` has the limit {} {}, the plan's limits say {}",
                case.id,
                c.metric,
                c.roi,
                c.comparison.as_str(),
                c.threshold,
                limit.map_or("none".to_string(), |l| format!(
                    "{} {l}",
                    if min { ">=" } else { "<=" }
                ))
            ));
        }
        let roi = case.rois.iter().find(|r| r.name == c.roi);
        match roi {
            Some(r) if r.kind != RoiKind::Led => out.push(format!(
                "case `{}`: a check on the background ROI `{}`",
                case.id, c.roi
            )),
            None => out.push(format!(
                "case `{}`: a check on `{}`, which is not one of its ROIs",
                case.id, c.roi
            )),
            Some(r) => {
                if let Some(Some(v)) = r.metrics.get(&c.metric)
                    && c.value.is_some_and(|x| x.to_bits() != v.to_bits())
                {
                    out.push(format!(
                        "case `{}`: the check of {} on `{}` compares {}, the ROI's value is {v}",
                        case.id,
                        c.metric,
                        c.roi,
                        c.value.unwrap_or(f64::NAN)
                    ));
                }
            }
        }
        let pass = if min {
            c.unbounded
                || c.value
                    .is_some_and(|v| v >= c.threshold - VERDICT_TOLERANCE)
        } else {
            !c.unbounded
                && c.value
                    .is_some_and(|v| v <= c.threshold + VERDICT_TOLERANCE)
        };
        if pass != c.pass {
            out.push(format!(
                "case `{}`: the check of {} on `{}` says {}, its value and limit say {}",
                case.id,
                c.metric,
                c.roi,
                if c.pass { "pass" } else { "fail" },
                if pass { "pass" } else { "fail" }
            ));
        }
        all_pass &= pass;
    }
    missing_checks(case, &lim, out);
    let outside = case.frequency_hz > 0.0
        && !crate::metrics::verdict::in_mitigation_range(case.frequency_hz, t);
    match &case.not_judged {
        Some(why) if outside || case.checks.is_empty() || why.contains("informative") => {
            Verdict::Info
        }
        Some(why) => {
            out.push(format!(
                "case `{}`: not judged ({why}), though it is in the mitigation range and checked",
                case.id
            ));
            Verdict::Info
        }
        None if outside => {
            out.push(format!(
                "case `{}`: judged, though {} Hz is outside the mitigation range",
                case.id, case.frequency_hz
            ));
            Verdict::Info
        }
        None if case.checks.is_empty() => Verdict::Info,
        None if all_pass => Verdict::Pass,
        None => Verdict::Fail,
    }
}

/// Every LED ROI carries a check for each limit that applies, unless the
/// report says why it could not (`not_checked`) or the case is not judged.
fn missing_checks(case: &CaseInfo, lim: &crate::plan::Limits, out: &mut Vec<String>) {
    for r in case.rois.iter().filter(|r| r.kind == RoiKind::Led) {
        for family in [
            "fdi_2018",
            "percent_flicker",
            "fmi",
            "fdi_p2020",
            "mmp",
            "visibility",
            "delta_uv",
        ] {
            let Some((Some(_), _)) = limit_of(family, lim) else {
                continue;
            };
            let checked = case.checks.iter().any(|c| {
                c.roi == r.name
                    && c.metric.starts_with(family)
                    && limit_of(&c.metric, lim).is_some()
            });
            let excused = case
                .not_checked
                .iter()
                .any(|n| n.starts_with(&format!("{}: ", r.name)));
            if !checked && !excused && case.not_judged.is_none() {
                out.push(format!(
                    "case `{}`: ROI `{}` has no check of the plan's {family} limit",
                    case.id, r.name
                ));
            }
        }
    }
}
