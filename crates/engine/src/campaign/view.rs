//! A [`Comparison`] as the comparison report shows it
//! ([`ledflicker_report::comparison::ComparisonView`]): the two runs, the
//! regressions worst first, the other gated KPIs, the flips, and a chart
//! per gated KPI with the regressed cases on top.

use std::collections::BTreeMap;

use super::compare::{
    ALPHA, Comparability, Comparison, Kpi, MIN_REPEAT_DF, PoolMethod, TRACE_INFLATION,
};
use super::query::{RunData, RunRow};
use ledflicker_report::comparison::{
    ChartPoint, ComparisonView, DeltaCell, DeltaMatrix, DifferenceRow, FlipRow, KpiChange,
    KpiChart, PooledRow, RunSide, TraceOverlay,
};

/// Charts in a report at most: the regressed KPIs come first, so a long
/// plan's report stays readable and never loses one of them.
const MAX_CHARTS: usize = 8;

fn side(r: &RunRow) -> RunSide {
    RunSide {
        id: r.id,
        plan: r.plan_id.clone(),
        plan_title: r.plan_title.clone(),
        supplier: r.supplier.clone(),
        model: r.model.clone(),
        serial: r.serial.clone(),
        firmware: r.firmware.clone(),
        date: r.date.clone(),
        tool: r.tool.clone(),
        backend: r.backend.clone(),
        verdict: r.verdict.clone(),
        cases: r.cases,
        signature: r.signature.clone(),
        report_dir: r.report_dir.clone(),
        as_run: r.setup.as_ref().and_then(|s| s.device_label()),
    }
}

fn change(k: &Kpi) -> KpiChange {
    KpiChange {
        case: k.case.clone(),
        roi: k.roi.clone(),
        metric: k.metric.clone(),
        a: k.a,
        b: k.b,
        delta: k.delta(),
        sigma: k.sigma.filter(|s| *s > 0.0),
        z: k.z(),
        worse: match k.worse {
            1 => "rise",
            -1 => "fall",
            _ => "",
        }
        .to_string(),
        k: k.k,
        regressed: k.regressed,
    }
}

/// Most worrying first: larger change towards worse in sigma, then (no
/// sigma) larger change towards worse.
fn by_concern(a: &KpiChange, b: &KpiChange) -> std::cmp::Ordering {
    let key = |k: &KpiChange| {
        let sign = if k.worse == "rise" { 1.0 } else { -1.0 };
        (
            k.z.unwrap_or(f64::INFINITY),
            k.delta.map_or(f64::INFINITY, |d| d * sign),
        )
    };
    key(b)
        .partial_cmp(&key(a))
        .unwrap_or(std::cmp::Ordering::Equal)
}

/// The sentences saying where the gate's sigma came from.
fn noise_source(c: &Comparison) -> String {
    let gated = c.gated();
    let n = c.noise_counts();
    let (repeats, trace, noiseless, unknown) = (n.repeats, n.trace, n.noiseless, n.unknown);
    let mut s = Vec::new();
    if repeats > 0 {
        let (runs, df) = c.repeats_in_words();
        s.push(format!(
            "For {repeats} of the {gated} gated KPIs σ is the run-to-run spread measured over the repeated runs of the same test in the database ({runs}; A and B left out), times √2 for two runs; the gate is Student's t at {df} degrees of freedom."
        ));
    }
    if trace > 0 {
        s.push(format!(
            "For {trace}, with too few repeated runs in the database to measure it from (at least {MIN_REPEAT_DF} degrees of freedom), σ is each run's frame-to-frame noise propagated through the KPI's formula, times {TRACE_INFLATION} (the most by which the real run-to-run spread exceeded it in our measurements)."
        ));
    }
    if noiseless > 0 {
        s.push(format!(
            "For {noiseless} the runs are free of noise (σ = 0): every change beyond the floor is real."
        ));
    }
    if unknown > 0 {
        s.push(format!(
            "For {unknown}, a trace was not readable when its run was recorded: any change towards worse beyond the floor counts."
        ));
    }
    s.push("A change smaller than its floor (by default 1 % of the KPI's limit) is never a regression.".to_string());
    s.join(" ")
}

/// One chart per gated ROI and metric, regressed ones first.
fn charts(changes: &[KpiChange], b: &RunData) -> Vec<KpiChart> {
    let mut groups: BTreeMap<(String, String), Vec<&KpiChange>> = BTreeMap::new();
    for k in changes.iter().filter(|k| !k.worse.is_empty()) {
        groups
            .entry((k.roi.clone(), k.metric.clone()))
            .or_default()
            .push(k);
    }
    let threshold = |roi: &str, metric: &str, points: &[&KpiChange]| {
        let limits: Vec<f64> = points
            .iter()
            .filter_map(|p| b.cases.get(&p.case))
            .flat_map(|case| &case.checks)
            .filter(|x| x.roi == roi && x.metric == metric)
            .map(|x| x.threshold)
            .collect();
        let first = *limits.first()?;
        limits
            .iter()
            .all(|t| (t - first).abs() <= 1e-12 * first.abs().max(1.0))
            .then_some(first)
    };
    let mut out: Vec<KpiChart> = groups
        .into_iter()
        .map(|((roi, metric), mut points)| {
            points.sort_by_key(|p| std::cmp::Reverse(p.regressed));
            KpiChart {
                threshold: threshold(&roi, &metric, &points),
                name: ledflicker_core::model::human_name(&metric).to_string(),
                points: points
                    .iter()
                    .map(|p| ChartPoint {
                        case: p.case.clone(),
                        a: p.a,
                        b: p.b,
                        band: p.sigma.map(|s| s * p.k),
                        regressed: p.regressed,
                    })
                    .collect(),
                roi,
                metric,
            }
        })
        .collect();
    out.sort_by_key(|chart| !chart.points.iter().any(|p| p.regressed));
    out.truncate(MAX_CHARTS);
    out
}

/// Columns and rows of a grid matrix at most: a wider grid (a sweep) is
/// left to the per-case rows, which stay readable at any size.
const MAX_MATRIX_FREQUENCIES: usize = 12;
/// See [`MAX_MATRIX_FREQUENCIES`].
const MAX_MATRIX_DUTIES: usize = 20;

/// The charted KPIs over the frequency x duty grid, one matrix per light
/// level, with the conditions of run B's cases; none for a plan whose
/// cases form no grid (one condition each way) or a grid too large for a
/// page.
fn matrices(charts: &[KpiChart], changes: &[KpiChange], b: &RunData) -> Vec<DeltaMatrix> {
    let sorted = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let mut out = Vec::new();
    for chart in charts {
        let cells: Vec<(&KpiChange, &super::query::CaseData)> = changes
            .iter()
            .filter(|k| k.roi == chart.roi && k.metric == chart.metric)
            .filter_map(|k| b.cases.get(&k.case).map(|c| (k, c)))
            .collect();
        for lux in sorted(cells.iter().map(|(_, c)| c.light_lux).collect()) {
            let here: Vec<_> = cells.iter().filter(|(_, c)| c.light_lux == lux).collect();
            let frequencies = sorted(here.iter().map(|(_, c)| c.frequency_hz).collect());
            let duties = sorted(here.iter().map(|(_, c)| c.duty).collect());
            let grid = frequencies.len() * duties.len() > 1;
            if !grid
                || frequencies.len() > MAX_MATRIX_FREQUENCIES
                || duties.len() > MAX_MATRIX_DUTIES
            {
                continue;
            }
            let cell = |f: f64, d: f64| {
                here.iter()
                    .find(|(_, c)| c.frequency_hz == f && c.duty == d)
                    .map(|(k, _)| DeltaCell {
                        a: k.a,
                        b: k.b,
                        delta: k.delta,
                        regressed: k.regressed,
                    })
            };
            out.push(DeltaMatrix {
                roi: chart.roi.clone(),
                metric: chart.metric.clone(),
                light_lux: lux,
                cells: duties
                    .iter()
                    .map(|&d| frequencies.iter().map(|&f| cell(f, d)).collect())
                    .collect(),
                frequencies,
                duties,
            });
        }
    }
    out
}

/// Regressed cases whose traces a report overlays at most (worst first);
/// the rest are named in a sentence.
const MAX_OVERLAYS: usize = 6;

/// `(time s, value)` of the column `roi` of the trace CSV at `path`
/// (`frame,time_s,segment,<roi>...`), frames with no number left out;
/// `None` when the file or the column is not there.
fn trace_column(path: &std::path::Path, roi: &str) -> Option<Vec<(f64, f64)>> {
    let mut reader = csv::Reader::from_path(path).ok()?;
    let header = reader.headers().ok()?.clone();
    let time = header.iter().position(|h| h == "time_s")?;
    let column = header.iter().position(|h| h == roi)?;
    let mut out = Vec::new();
    for row in reader.records() {
        let row = row.ok()?;
        let number = |i: usize| row.get(i).and_then(|v| v.parse::<f64>().ok());
        if let (Some(t), Some(v)) = (number(time), number(column)) {
            out.push((t, v));
        }
    }
    Some(out)
}

/// The overlays of the regressed cases, worst regression first, one per
/// case (the ROI of its worst regression), read from each run's report
/// directory; and a sentence on the cases left without one.
fn overlays(c: &Comparison, regressions: &[KpiChange]) -> (Vec<TraceOverlay>, Option<String>) {
    let mut seen = std::collections::BTreeSet::new();
    let worst: Vec<&KpiChange> = regressions
        .iter()
        .filter(|k| seen.insert(k.case.clone()))
        .collect();
    let label = |side: &str, r: &super::query::RunRow| {
        format!("{side}: run {}, firmware {}", r.id, r.firmware)
    };
    let (mut out, mut gone) = (Vec::new(), Vec::new());
    for k in worst.iter().take(MAX_OVERLAYS) {
        let trace = ledflicker_core::model::trace_path(&k.case);
        let read = |dir: &str| trace_column(&std::path::Path::new(dir).join(&trace), &k.roi);
        match (read(&c.a.report_dir), read(&c.b.report_dir)) {
            (Some(a), Some(b)) => out.push(TraceOverlay {
                case: k.case.clone(),
                roi: k.roi.clone(),
                a_label: label("A", &c.a),
                b_label: label("B", &c.b),
                a,
                b,
            }),
            _ => gone.push(k.case.as_str()),
        }
    }
    let mut note = Vec::new();
    if !gone.is_empty() {
        note.push(format!(
            "No traces to overlay for {} (a run's report directory or its trace file is gone).",
            gone.join(", ")
        ));
    }
    if worst.len() > MAX_OVERLAYS {
        note.push(format!(
            "The traces of the {} other regressed cases are in the two report directories.",
            worst.len() - MAX_OVERLAYS
        ));
    }
    (out, (!note.is_empty()).then(|| note.join(" ")))
}

/// The report's view of `c`, made on `date` (`YYYY-MM-DD`); `b` is run B
/// whole (for its checks' limits).
pub fn view(c: &Comparison, b: &RunData, date: &str) -> ComparisonView {
    let changes: Vec<KpiChange> = c.kpis.iter().map(change).collect();
    let mut regressions: Vec<KpiChange> = changes.iter().filter(|k| k.regressed).cloned().collect();
    regressions.sort_by(by_concern);
    let mut gated_changes: Vec<KpiChange> = changes
        .iter()
        .filter(|k| !k.regressed && !k.worse.is_empty())
        .cloned()
        .collect();
    gated_changes.sort_by(by_concern);
    let regressed_cases: Vec<String> = c
        .regressed_cases()
        .into_iter()
        .map(str::to_string)
        .collect();
    let (overlays, overlay_note) = overlays(c, &regressions);
    let charts = charts(&changes, b);
    ComparisonView {
        matrices: matrices(&charts, &changes, b),
        a: side(&c.a),
        b: side(&c.b),
        date: date.to_string(),
        compared: c.kpis.len(),
        gated: c.gated(),
        k: c.gate_words(),
        differences: c
            .differences
            .iter()
            .map(|d| {
                let (a, b) = d.shown();
                DifferenceRow {
                    key: d.key.clone(),
                    kind: d.kind.to_string(),
                    a,
                    b,
                }
            })
            .collect(),
        not_comparable: match &c.comparability {
            Comparability::Not { why, .. } => Some(format!("{why}.")),
            _ => None,
        },
        accepted: c.comparability == Comparability::Accepted,
        alpha: ALPHA,
        noise_source: noise_source(c),
        flips: c
            .flips
            .iter()
            .map(|f| FlipRow {
                case: f.case.clone(),
                from: f.from.clone(),
                to: f.to.clone(),
                regressed: regressed_cases.contains(&f.case),
                cause: f.cause.describe(),
            })
            .collect(),
        pooled: c
            .pooled
            .iter()
            .map(|p| PooledRow {
                metric: p.metric.clone(),
                score: p.score,
                gate: p.gate,
                n: p.n,
                method: match p.method {
                    PoolMethod::RunSums(df) => {
                        format!("each run's sum over the cases, its spread over the repeats ({df} degrees of freedom)")
                    }
                    PoolMethod::MeanZ => "the mean of the cases' changes in σ (valid however the cases are correlated)".to_string(),
                },
                regressed: p.regressed,
            })
            .collect(),
        unmatched: c.unmatched.clone(),
        charts,
        regressed_cases,
        regressions,
        gated_changes,
        overlays,
        overlay_note,
    }
}
