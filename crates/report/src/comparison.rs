//! The comparison report of `ledflicker compare --report DIR`: two
//! recorded runs of a campaign side by side, for the reader who asks
//! "what changed, and is it worse?" (docs/campaigns.md).
//!
//! The caller (the results database's `compare`) fills a
//! [`ComparisonView`] of formatted facts; this module lays it out as a
//! self-contained HTML page (templates/comparison.html.j2) and, with the
//! `pdf` feature, as a PDF through the report's Typst path
//! (templates/comparison.typ.j2), each with one chart per gated KPI
//! ([`crate::charts::kpi_change_svg`]).

use minijinja::value::{Serde, Value};
use minijinja::{Environment, UndefinedBehavior};
use serde::Serialize;

use super::ReportError;
use super::charts::{kpi_change_svg, trace_overlay_svg};

const BASE: &str = include_str!("../../../templates/base.html.j2");
const HTML: &str = include_str!("../../../templates/comparison.html.j2");
#[cfg(feature = "pdf")]
const TYPST: &str = include_str!("../../../templates/comparison.typ.j2");

/// One of the two runs.
#[derive(Debug, Clone, Serialize)]
pub struct RunSide {
    /// Run id in the results database.
    pub id: i64,
    /// Plan id and title.
    pub plan: String,
    /// See `plan`.
    pub plan_title: String,
    /// `[dut]` supplier, model (the camera), serial and firmware.
    pub supplier: String,
    /// See `supplier`.
    pub model: String,
    /// See `supplier`.
    pub serial: String,
    /// See `supplier`.
    pub firmware: String,
    /// Report date, `YYYY-MM-DD`.
    pub date: String,
    /// `ledflicker <version>` that wrote it.
    pub tool: String,
    /// Backend id.
    pub backend: String,
    /// Overall verdict: `pass`, `fail` or `info`.
    pub verdict: String,
    /// Cases: total, pass, fail, not judged.
    pub cases: [i64; 4],
    /// `unsigned`, `signed`, `intact`, `broken` or `unchecked`.
    pub signature: String,
    /// The run's report directory.
    pub report_dir: String,
    /// The device as run, from the recorded set-up (e.g. the simulated
    /// camera's exposure), whatever the model's free text says.
    pub as_run: Option<String>,
}

/// One set-up key that differs between the runs.
#[derive(Debug, Clone, Serialize)]
pub struct DifferenceRow {
    /// The key, as the plan names it.
    pub key: String,
    /// `test`, `device` or `run`.
    pub kind: String,
    /// Its value in A and in B (`(absent)` where a run lacks it).
    pub a: String,
    /// See `a`.
    pub b: String,
}

/// One KPI of one ROI of one case in both runs.
#[derive(Debug, Clone, Serialize)]
pub struct KpiChange {
    /// Case id.
    pub case: String,
    /// ROI name.
    pub roi: String,
    /// Metric id, as in results.json.
    pub metric: String,
    /// Value in A and in B; `None`: undefined.
    pub a: Option<f64>,
    /// See `a`.
    pub b: Option<f64>,
    /// `b - a`.
    pub delta: Option<f64>,
    /// Standard deviation of `b - a` the gate used; `None`: unknown.
    pub sigma: Option<f64>,
    /// The change towards worse in standard deviations.
    pub z: Option<f64>,
    /// Which way is worse: `rise`, `fall`, or empty when not gated.
    pub worse: String,
    /// The gate in standard deviations for this KPI.
    pub k: f64,
    /// The gate called it a regression.
    pub regressed: bool,
}

/// A case whose verdict differs.
#[derive(Debug, Clone, Serialize)]
pub struct FlipRow {
    /// Case id.
    pub case: String,
    /// Verdict in A and in B.
    pub from: String,
    /// See `from`.
    pub to: String,
    /// The case regressed (else the flip is within the noise, or better).
    pub regressed: bool,
    /// Why the verdict flipped, in words (a changed limit, a regression,
    /// the noise).
    pub cause: String,
}

/// One metric's changes pooled over the cases.
#[derive(Debug, Clone, Serialize)]
pub struct PooledRow {
    /// Metric id.
    pub metric: String,
    /// Pooled change towards worse, standard deviations.
    pub score: f64,
    /// Its gate.
    pub gate: f64,
    /// How the cases were pooled, in words.
    pub method: String,
    /// Cases pooled.
    pub n: usize,
    /// Beyond the pooled gate.
    pub regressed: bool,
}

/// One case of a [`KpiChart`].
#[derive(Debug, Clone, Serialize)]
pub struct ChartPoint {
    /// Case id.
    pub case: String,
    /// Value in A and B.
    pub a: Option<f64>,
    /// See `a`.
    pub b: Option<f64>,
    /// Half-width of the gate's band around A: `k` standard deviations.
    pub band: Option<f64>,
    /// The case regressed on this KPI.
    pub regressed: bool,
}

/// A KPI of one ROI before and after, case by case.
#[derive(Debug, Clone, Serialize)]
pub struct KpiChart {
    /// ROI name.
    pub roi: String,
    /// Metric id.
    pub metric: String,
    /// Its human name (the x axis).
    pub name: String,
    /// The check's limit, when all cases share one.
    pub threshold: Option<f64>,
    /// The cases, regressed first.
    pub points: Vec<ChartPoint>,
}

/// One cell of a [`DeltaMatrix`]: a case's KPI in both runs.
#[derive(Debug, Clone, Serialize)]
pub struct DeltaCell {
    /// Value in A and in B (`None`: undefined).
    pub a: Option<f64>,
    /// See `a`.
    pub b: Option<f64>,
    /// `b - a`.
    pub delta: Option<f64>,
    /// The case regressed on this KPI.
    pub regressed: bool,
}

/// A gated KPI of one ROI over the plan's frequency x duty grid at one
/// light level: A and B side by side in each cell, with the change.
#[derive(Debug, Clone, Serialize)]
pub struct DeltaMatrix {
    /// ROI name.
    pub roi: String,
    /// Metric id.
    pub metric: String,
    /// Ambient light, lux.
    pub light_lux: f64,
    /// Columns: PWM frequencies, Hz, ascending.
    pub frequencies: Vec<f64>,
    /// Rows: duty cycles (0..1), ascending.
    pub duties: Vec<f64>,
    /// `cells[row][column]`; `None` where the grid has no case.
    pub cells: Vec<Vec<Option<DeltaCell>>>,
}

/// A regressed case's trace of one ROI in both runs: `(time s, mean
/// luma DN)` per frame.
#[derive(Debug, Clone, Serialize)]
pub struct TraceOverlay {
    /// Case id.
    pub case: String,
    /// ROI name.
    pub roi: String,
    /// Legend of run A's line, e.g. `A: run 1, firmware ideal-1`.
    pub a_label: String,
    /// See `a_label`.
    pub b_label: String,
    /// Run A's frames; only the chart reads them.
    #[serde(skip)]
    pub a: Vec<(f64, f64)>,
    /// See `a`.
    #[serde(skip)]
    pub b: Vec<(f64, f64)>,
}

/// Everything the comparison report shows.
#[derive(Debug, Clone, Serialize)]
pub struct ComparisonView {
    /// The baseline A and the run B compared with it.
    pub a: RunSide,
    /// See `a`.
    pub b: RunSide,
    /// Date the comparison was made, `YYYY-MM-DD`.
    pub date: String,
    /// KPIs compared, and how many a check gates.
    pub compared: usize,
    /// See `compared`.
    pub gated: usize,
    /// The gate of one KPI in standard deviations, in words: one number,
    /// or a range when KPIs have sigmas from different numbers of repeats.
    pub k: String,
    /// What differs between the runs' set-ups: test keys first, then the
    /// device's, then the run's.
    pub differences: Vec<DifferenceRow>,
    /// Why the runs are not comparable, when they are not.
    pub not_comparable: Option<String>,
    /// The tests differ and the user accepted it (`--accept-changes`).
    pub accepted: bool,
    /// False-alarm rate of the whole comparison.
    pub alpha: f64,
    /// Where the noise came from, one sentence.
    pub noise_source: String,
    /// Cases with a regressed KPI, in plan order.
    pub regressed_cases: Vec<String>,
    /// Regressed KPIs, worst first.
    pub regressions: Vec<KpiChange>,
    /// The other gated KPIs, largest change towards worse first.
    pub gated_changes: Vec<KpiChange>,
    /// Verdict flips.
    pub flips: Vec<FlipRow>,
    /// Pooled scores per metric.
    pub pooled: Vec<PooledRow>,
    /// Cases in only one run.
    pub unmatched: Vec<String>,
    /// One chart per gated KPI and ROI, regressed ones first.
    pub charts: Vec<KpiChart>,
    /// Side-by-side and delta matrices of the charted KPIs, per light
    /// level (plans whose cases form a frequency x duty grid).
    pub matrices: Vec<DeltaMatrix>,
    /// The traces of the regressed cases, worst first, A and B overlaid.
    pub overlays: Vec<TraceOverlay>,
    /// Why some regressed cases have no overlay (more than the report
    /// draws, or a trace file gone from a run's report), one sentence.
    pub overlay_note: Option<String>,
}

impl ComparisonView {
    /// File name of chart `i` (`charts/kpi-<i>.svg` in the PDF's world).
    #[cfg(feature = "pdf")]
    fn chart_path(i: usize) -> String {
        format!("charts/kpi-{i}.svg")
    }

    /// File name of overlay `i` (`charts/trace-<i>.svg`).
    #[cfg(feature = "pdf")]
    fn overlay_path(i: usize) -> String {
        format!("charts/trace-{i}.svg")
    }

    /// The KPI charts' SVGs in the order of `charts`, then the overlays'
    /// in the order of `overlays`.
    fn chart_svgs(&self) -> Result<(Vec<String>, Vec<String>), ReportError> {
        let kpis = self
            .charts
            .iter()
            .map(kpi_change_svg)
            .collect::<Result<Vec<_>, _>>()?;
        let overlays = self
            .overlays
            .iter()
            .map(trace_overlay_svg)
            .collect::<Result<Vec<_>, _>>()?;
        Ok((kpis, overlays))
    }

    /// Every chart's SVG by its path.
    #[cfg(feature = "pdf")]
    fn svgs(&self) -> Result<std::collections::BTreeMap<String, String>, ReportError> {
        let (kpis, overlays) = self.chart_svgs()?;
        let kpis = kpis
            .into_iter()
            .enumerate()
            .map(|(i, svg)| (Self::chart_path(i), svg));
        let overlays = overlays
            .into_iter()
            .enumerate()
            .map(|(i, svg)| (Self::overlay_path(i), svg));
        Ok(kpis.chain(overlays).collect())
    }
}

fn num(v: Option<f64>, digits: usize) -> String {
    v.filter(|v| v.is_finite())
        .map_or_else(|| "–".to_string(), |v| crate::util::fixed(v, digits))
}

fn environment() -> Environment<'static> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.add_filter("num", |v: Serde<Option<f64>>, digits: Option<usize>| {
        num(v.0, digits.unwrap_or(4))
    });
    env.add_filter("metric", |id: &str| {
        crate::model::human_name(id).to_string()
    });
    env
}

fn template_error(name: &str) -> impl Fn(minijinja::Error) -> ReportError + '_ {
    move |e| ReportError::Template {
        template: name.to_string(),
        message: format!("{e:#}"),
    }
}

/// The comparison as one self-contained HTML page (charts inline).
pub fn html(view: &ComparisonView) -> Result<String, ReportError> {
    let mut env = environment();
    let err = template_error("comparison.html.j2");
    env.add_template("base.html.j2", BASE).map_err(&err)?;
    env.add_template("comparison.html.j2", HTML).map_err(&err)?;
    let (kpis, overlays) = view.chart_svgs()?;
    let safe = |svgs: Vec<String>| -> Vec<Value> {
        svgs.into_iter().map(Value::from_safe_string).collect()
    };
    let (charts, overlays) = (safe(kpis), safe(overlays));
    env.get_template("comparison.html.j2")
        .and_then(|t| {
            t.render(
                minijinja::context! { v => Serde(view), charts => charts, overlays => overlays },
            )
        })
        .map_err(err)
}

/// The Typst markup of the PDF.
#[cfg(feature = "pdf")]
pub fn typst_markup(view: &ComparisonView) -> Result<String, ReportError> {
    let mut env = environment();
    let err = template_error("comparison.typ.j2");
    env.add_filter("t", |v: Value| crate::pdf::typst_str(&v));
    env.add_template("comparison.typ.j2", TYPST).map_err(&err)?;
    let charts: Vec<String> = (0..view.charts.len())
        .map(ComparisonView::chart_path)
        .collect();
    let overlays: Vec<String> = (0..view.overlays.len())
        .map(ComparisonView::overlay_path)
        .collect();
    env.get_template("comparison.typ.j2")
        .and_then(|t| {
            t.render(
                minijinja::context! { v => Serde(view), charts => charts, overlays => overlays },
            )
        })
        .map_err(err)
}

/// The comparison as PDF (A4, the report's fonts): its bytes and pages.
#[cfg(feature = "pdf")]
pub fn pdf(view: &ComparisonView) -> Result<(Vec<u8>, usize), ReportError> {
    let markup = typst_markup(view)?;
    let svgs = view.svgs()?;
    crate::pdf::render_standalone(
        markup,
        &svgs,
        &view.date,
        &format!("ledflicker-compare-{}-{}", view.a.id, view.b.id),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn side(id: i64, firmware: &str) -> RunSide {
        RunSide {
            id,
            plan: "p".to_string(),
            plan_title: "Plan \"quoted\" <b>".to_string(),
            supplier: "S".to_string(),
            model: "EX-1".to_string(),
            serial: "1".to_string(),
            firmware: firmware.to_string(),
            date: "2026-01-02".to_string(),
            tool: "ledflicker 0".to_string(),
            backend: "sim".to_string(),
            verdict: "fail".to_string(),
            cases: [2, 1, 1, 0],
            signature: "unsigned".to_string(),
            report_dir: "/r/#a [b]".to_string(),
            as_run: Some("exposure 11.111 ms".to_string()),
        }
    }

    fn view() -> ComparisonView {
        let k = KpiChange {
            case: "c<1>".to_string(),
            roi: "led".to_string(),
            metric: "fdi_2018".to_string(),
            a: Some(1.0),
            b: Some(0.2),
            delta: Some(-0.8),
            sigma: Some(0.1),
            z: Some(8.0),
            worse: "fall".to_string(),
            k: 2.24,
            regressed: true,
        };
        ComparisonView {
            a: side(1, "1.0"),
            b: side(2, "1.1 \"beta\" #x"),
            date: "2026-01-03".to_string(),
            compared: 2,
            gated: 1,
            k: "2.24".to_string(),
            differences: vec![DifferenceRow {
                key: "dut.camera.exposure-ms".to_string(),
                kind: "device".to_string(),
                a: "11.111".to_string(),
                b: "5.0 <x>".to_string(),
            }],
            not_comparable: None,
            accepted: false,
            alpha: 0.05,
            noise_source: "From the traces.".to_string(),
            regressed_cases: vec!["c<1>".to_string()],
            regressions: vec![k.clone()],
            gated_changes: Vec::new(),
            flips: vec![FlipRow {
                case: "c<1>".to_string(),
                from: "pass".to_string(),
                to: "fail".to_string(),
                regressed: true,
                cause: "a KPI regressed".to_string(),
            }],
            pooled: Vec::new(),
            unmatched: vec!["only-a".to_string()],
            charts: vec![KpiChart {
                roi: "led".to_string(),
                metric: "fdi_2018".to_string(),
                name: "FDI".to_string(),
                threshold: Some(0.1),
                points: vec![ChartPoint {
                    case: "c<1>".to_string(),
                    a: Some(1.0),
                    b: Some(0.2),
                    band: Some(0.224),
                    regressed: true,
                }],
            }],
            matrices: vec![DeltaMatrix {
                roi: "led".to_string(),
                metric: "fdi_2018".to_string(),
                light_lux: 40.0,
                frequencies: vec![90.0, 150.0],
                duties: vec![0.1],
                cells: vec![vec![
                    Some(DeltaCell {
                        a: Some(1.0),
                        b: Some(0.2),
                        delta: Some(-0.8),
                        regressed: true,
                    }),
                    None,
                ]],
            }],
            overlays: vec![TraceOverlay {
                case: "c<1>".to_string(),
                roi: "led".to_string(),
                a_label: "A: run 1".to_string(),
                b_label: "B: run 2".to_string(),
                a: vec![(0.0, 10.0), (1.0, 12.0)],
                b: vec![(0.0, 10.0), (1.0, 2.0)],
            }],
            overlay_note: Some("Traces gone: c2.".to_string()),
        }
    }

    #[test]
    fn the_html_names_the_runs_and_the_regressed_case_and_escapes_text() {
        let html = html(&view()).unwrap();
        assert!(html.contains("c&lt;1&gt;"), "the case id is escaped");
        assert!(!html.contains("<b>\""), "the title is escaped");
        assert!(html.contains("firmware 1.0 → 1.1"), "{html}");
        assert!(html.contains("0.8000") || html.contains("-0.8000"));
        assert!(html.contains("<svg"), "the chart is inline");
        assert!(html.contains("only-a"));
        assert_eq!(
            html.matches("<svg").count(),
            2,
            "a KPI chart and an overlay"
        );
        assert!(html.contains("A: run 1") && html.contains("Traces gone: c2."));
        assert!(html.contains("40 lux") && html.contains("150 Hz"), "{html}");
        assert!(html.contains("1.00 → 0.20"), "the matrix cell");
    }

    #[cfg(feature = "pdf")]
    #[test]
    fn the_pdf_lays_out_text_that_typst_would_read_as_markup() {
        let (pdf, pages) = pdf(&view()).unwrap();
        assert!(pdf.starts_with(b"%PDF"));
        assert!(pages >= 1);
        let markup = typst_markup(&view()).unwrap();
        assert!(markup.contains("\"1.1 \\\"beta\\\" #x\""), "{markup}");
        assert!(markup.contains("charts/trace-0.svg"), "{markup}");
    }
}
