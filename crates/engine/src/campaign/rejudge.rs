//! The verdicts of an imported report, judged again from its data:
//! `import` records what the values and the plan's limits say, never what
//! results.json concludes (docs/campaigns.md, "`ledflicker import`").
//!
//! Each case's checks are rebuilt from its ROIs' recorded values and the
//! limits of its light level (`thresholds`), with the rules of the run
//! itself: the verdict basis (worst phase or as captured) picks the
//! metric a limit checks, the tolerance 1e-9, an undefined value fails, an
//! FDI is unbounded only where the ROI's contrast is, a limit may go
//! unchecked only where the data lacks what it needs (FDI: the OFF level;
//! the P2020 KPIs, visibility, colour: their values), a case outside the
//! mitigation range or with no limit that applies is not judged. Then the
//! case verdicts, the counts and the overall verdict. A report whose
//! conclusions differ from its own data was edited, or written by a tool
//! that judged otherwise: it is refused, naming the case.

use std::collections::BTreeSet;

use ledflicker_core::metrics::verdict::{case_verdict, limit_families, meets};
use ledflicker_core::model::{BackendName, CaseInfo, Comparison, Results, RoiInfo, RoiKind};
use ledflicker_core::model::{Verdict, VerdictBasis};
use ledflicker_core::plan::Limits;

/// Mismatches listed at most; the rest are counted.
const MAX: usize = 8;

/// Refuses a report whose verdicts do not follow from its own values and
/// limits (it was edited after it was written): the error names the
/// directory and each mismatch, says what is not done (`consequence`, e.g.
/// ", so it is not signed"; empty when nothing more) and what to do
/// instead (`hint`). `sign`, `import` and the Python package's `read`
/// share it, so a report refused by one is refused by all.
pub fn refuse_edited(
    dir: &std::path::Path,
    r: &Results,
    consequence: &str,
    hint: &str,
) -> Result<(), ledflicker_core::error::UsageError> {
    let problems = mismatches(r);
    if problems.is_empty() {
        return Ok(());
    }
    Err(ledflicker_core::error::UsageError(format!(
        "`{}`: its verdicts do not follow from its own values and limits{consequence}:\n  {}\n    hint: the report was edited after it was written; {hint}",
        dir.display(),
        problems.join("\n  ")
    )))
}

/// The mismatches between what `r` concludes and what its data says, at
/// most [`MAX`] of them and a count of the others, one line each; empty
/// when they agree.
pub fn mismatches(r: &Results) -> Vec<String> {
    let mut out = Vec::new();
    let mut verdicts = Vec::new();
    let mut counts = [0usize; 3];
    // Captures and rigs are judged as captured whatever `basis` says.
    let worst_phase = r.method.backend == BackendName::Simulator
        && r.thresholds.basis == VerdictBasis::WorstPhase;
    for case in r.cases.iter() {
        let verdict = judge(&case, r, worst_phase, &mut out);
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
    }
    let overall = ledflicker_core::metrics::verdict::overall(verdicts);
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
    if out.len() > MAX {
        let more = out.len() - MAX;
        out.truncate(MAX);
        out.push(format!("and {more} more"));
    }
    out
}

/// The family of a checked metric, its limit in `lim` and whether that
/// is a minimum, and the metric the family's check must name on `roi` (the
/// worst-phase figures where the basis takes them).
fn family_of(
    metric: &str,
    roi: &RoiInfo,
    lim: &Limits,
    worst_phase: bool,
) -> Option<(&'static str, Option<f64>, bool, String)> {
    let (family, limit, min) = limit_families(lim)
        .into_iter()
        .find(|(f, ..)| metric == *f || metric.strip_prefix(f) == Some("_worst_phase"))?;
    let suffix = if worst_phase
        && matches!(family, "fdi_2018" | "percent_flicker")
        && roi.metrics.contains_key("fdi_2018_worst_phase")
        && roi.metrics.contains_key("percent_flicker_worst_phase")
    {
        "_worst_phase"
    } else {
        ""
    };
    Some((family, limit, min, format!("{family}{suffix}")))
}

/// The case's verdict from its data; what does not add up goes to `out`.
fn judge(case: &CaseInfo, r: &Results, worst_phase: bool, out: &mut Vec<String>) -> Verdict {
    let lux = (case.light_lux > 0.0).then_some(case.light_lux);
    let lim = r.thresholds.limits_for(lux);
    let mut all_pass = true;
    let mut seen = BTreeSet::new();
    let mut bad = |what: String| out.push(format!("case `{}`: {what}", case.id));
    for c in &case.checks {
        if !seen.insert((c.roi.as_str(), c.metric.as_str())) {
            bad(format!(
                "the check of {} on `{}` appears twice",
                c.metric, c.roi
            ));
            continue;
        }
        let Some(roi) = case.rois.iter().find(|x| x.name == c.roi) else {
            bad(format!(
                "a check on `{}`, which is not one of its ROIs",
                c.roi
            ));
            continue;
        };
        if roi.kind != RoiKind::Led {
            bad(format!("a check on the background ROI `{}`", c.roi));
        }
        let Some((family, limit, min, expected)) = family_of(&c.metric, roi, &lim, worst_phase)
        else {
            bad(format!(
                "a check on `{}`, which no limit of the plan names",
                c.metric
            ));
            continue;
        };
        if c.metric != expected {
            bad(format!(
                "the limit of {family} on `{}` checks {}, the verdict basis says {expected}",
                c.roi, c.metric
            ));
        }
        if limit != Some(c.threshold) || min != (c.comparison == Comparison::AtLeast) {
            bad(format!(
                "the check of {} on `{}` has the limit {} {}, the plan's limits say {}",
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
        let recorded = roi.metrics.get(&c.metric).copied().flatten();
        if c.value.map(f64::to_bits) != recorded.map(f64::to_bits) {
            bad(format!(
                "the check of {} on `{}` compares {}, the ROI's value is {}",
                c.metric,
                c.roi,
                c.value.map_or("none".to_string(), |v| v.to_string()),
                recorded.map_or("none".to_string(), |v| v.to_string())
            ));
        }
        if c.unbounded != roi.is_unbounded(&c.metric) || (c.unbounded && c.value.is_some()) {
            bad(format!(
                "the check of {} on `{}` is marked {}unbounded, its ROI's data says otherwise",
                c.metric,
                c.roi,
                if c.unbounded { "" } else { "not " }
            ));
        }
        let pass = meets(c.value, c.unbounded, c.threshold, min);
        if pass != c.pass {
            bad(format!(
                "the check of {} on `{}` says {}, its value and limit say {}",
                c.metric,
                c.roi,
                if c.pass { "pass" } else { "fail" },
                if pass { "pass" } else { "fail" }
            ));
        }
        all_pass &= pass;
    }
    let outside = case.frequency_hz > 0.0
        && !ledflicker_core::metrics::verdict::in_mitigation_range(
            case.frequency_hz,
            &r.thresholds,
        );
    let informative = case
        .not_judged
        .as_deref()
        .is_some_and(|why| why.contains("informative"));
    // Outside the range or informative, a case is not judged whatever its
    // checks; else every limit that applies must be checked or excused
    // ("no threshold applies" included).
    if !outside && !informative {
        missing_checks(case, &lim, out);
    }
    verdict_of(case, outside || informative, all_pass, out)
}

/// The case's verdict: not judged outside the mitigation range or when
/// informative (`excused`), or with no check; else pass when every check
/// passes. A `not_judged` that the data does not bear out goes to `out`.
fn verdict_of(case: &CaseInfo, excused: bool, all_pass: bool, out: &mut Vec<String>) -> Verdict {
    match &case.not_judged {
        Some(_) if excused || case.checks.is_empty() => Verdict::Info,
        Some(why) => {
            out.push(format!(
                "case `{}`: not judged ({why}), though it is in the mitigation range and checked",
                case.id
            ));
            Verdict::Info
        }
        None if excused => {
            out.push(format!(
                "case `{}`: judged, though {} Hz is outside the mitigation range",
                case.id, case.frequency_hz
            ));
            Verdict::Info
        }
        None => case_verdict(true, (!case.checks.is_empty()).then_some(all_pass)),
    }
}

/// Every LED ROI carries a check for each limit that applies, unless its
/// data lacks what the limit needs and `not_checked` says so: FDI (2018)
/// needs the OFF level; Percent Flicker can always be checked; the P2020
/// KPIs, visibility and colour need their values.
fn missing_checks(case: &CaseInfo, lim: &Limits, out: &mut Vec<String>) {
    for r in case.rois.iter().filter(|r| r.kind == RoiKind::Led) {
        for (family, limit, _) in limit_families(lim) {
            if limit.is_none() {
                continue;
            }
            let checked = case.checks.iter().any(|c| {
                c.roi == r.name
                    && (c.metric == family || c.metric.strip_prefix(family) == Some("_worst_phase"))
            });
            if checked {
                continue;
            }
            let cannot = match family {
                "fdi_2018" => r.levels.off.is_none(),
                "percent_flicker" => false,
                other => r.metrics.get(other).copied().flatten().is_none(),
            };
            let said = case
                .not_checked
                .iter()
                .any(|n| n.starts_with(&format!("{}: ", r.name)));
            if !(cannot && said) {
                out.push(format!(
                    "case `{}`: ROI `{}` has no check of the plan's {family} limit, though its data allows one",
                    case.id, r.name
                ));
            }
        }
    }
}
