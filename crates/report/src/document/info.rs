//! The table of informational (not judged) cases that have no page: one
//! row each, its conditions, its key figures and why it was not judged.

use serde::Serialize;

use crate::model::{CaseInfo, Check, Comparison, Verdict, human_name};

/// One informational case as a table row; every field is text to print.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InfoRow {
    /// Case id.
    pub id: String,
    /// Light level, PWM frequency and duty, e.g. "2000 lux, 50 Hz, 5.0 %",
    /// or "conditions unknown".
    pub conditions: String,
    /// The figures of its LED ROI closest to failing, named for people,
    /// e.g. "led: FDI (Deegan 2018) 0.871 (limit ≥ 0.1: met)".
    pub figures: String,
    /// Why the case was not judged.
    pub why: String,
}

/// The row of an informational case, `None` for a judged one.
pub fn info_row(case: &CaseInfo) -> Option<InfoRow> {
    if case.verdict != Verdict::Info {
        return None;
    }
    let conditions = if case.duty > 0.0 {
        format!(
            "{} lux, {} Hz, {} % duty",
            case.light_lux,
            case.frequency_hz,
            crate::util::fixed(case.duty * 100.0, 1)
        )
    } else {
        "conditions unknown".to_string()
    };
    Some(InfoRow {
        id: case.id.clone(),
        conditions,
        figures: key_figures(case),
        why: case
            .not_judged
            .clone()
            .unwrap_or_else(|| "not judged".to_string()),
    })
}

/// The checks of the case's worst LED ROI, or its Percent Flicker when no
/// limit applies.
fn key_figures(case: &CaseInfo) -> String {
    let Some(roi) = case.worst_roi() else {
        return "no ROI".to_string();
    };
    let checks: Vec<String> = case
        .checks
        .iter()
        .filter(|k| k.roi == roi.name)
        .map(figure)
        .collect();
    if !checks.is_empty() {
        return format!("{}: {}", roi.name, checks.join("; "));
    }
    let pf = roi.metrics.get("percent_flicker").copied().flatten();
    format!(
        "{}: {} {}",
        roi.name,
        human_name("percent_flicker"),
        pf.map_or("n/a".to_string(), |v| format!(
            "{} %",
            crate::util::fixed(v, 2)
        ))
    )
}

/// "FDI (Deegan 2018) 0.871 (limit ≥ 0.1: met)".
fn figure(k: &Check) -> String {
    let value = match (k.value, k.unbounded) {
        (_, true) => "+\u{221e}".to_string(),
        (Some(v), false) => crate::util::fixed(v, 3),
        (None, false) => "n/a".to_string(),
    };
    let op = match k.comparison {
        Comparison::AtLeast => "\u{2265}",
        Comparison::AtMost => "\u{2264}",
    };
    format!(
        "{} {value} (limit {op} {}: {})",
        human_name(&k.metric),
        k.threshold,
        if k.pass { "met" } else { "not met" }
    )
}
