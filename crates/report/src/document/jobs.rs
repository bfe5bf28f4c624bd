//! The pictures of a report as jobs: each chart's or frame view's path and
//! how to draw it, drawn once, on first use, by whichever renderer asks
//! first.
//!
//! `plan` hands the PDF its pictures while they are drawn: Typst starts
//! laying out the document at once and draws a picture when a page shows it
//! (a page run blocks only on the pictures it shows), while the other
//! renderers draw the rest beside it. [`Jobs::draw_all`] gives the same
//! pictures, byte for byte, as drawing them one after the other.
//!
//! A drawing function must not use rayon: a thread that asks for a
//! picture another thread is drawing waits for it while holding its rayon
//! worker, so a drawing that waited on rayon work could wait for itself.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use super::super::charts::{self, ChartError};
use super::super::matrix;
use super::{
    ADVICE_CHART, finemap_chart_path, fold_chart_path, frame_image_path, matrix_chart_path,
    roi_map_chart_path, trace_chart_path, uv_chart_path, worst_phase_chart_path,
    worst_phase_image_path, zoom_chart_path,
};
use crate::model::frame::Stretch;
use crate::model::listing::listing;
use crate::model::{CaseInfo, CaseResult, Results, RoiKind};

/// Draws one picture.
type Draw<'a, T> = Box<dyn Fn() -> Result<T, ChartError> + Send + Sync + 'a>;

/// One picture: how to draw it, and the picture once drawn.
struct Job<'a, T> {
    draw: Draw<'a, T>,
    drawn: OnceLock<Result<T, ChartError>>,
}

/// Pictures of a report by path relative to the report directory: charts
/// (SVG text, [`ChartJobs`]) or frame views (PNG bytes, [`ViewJobs`]).
pub struct Jobs<'a, T> {
    jobs: BTreeMap<String, Job<'a, T>>,
}

/// Every chart of a report.
pub type ChartJobs<'a> = Jobs<'a, String>;

/// The annotated view of each case's sample frame.
pub type ViewJobs<'a> = Jobs<'a, Vec<u8>>;

impl<'a> ViewJobs<'a> {
    /// The view of each case's sample frame, with the model's display
    /// stretch and ROIs. Nothing is drawn yet.
    pub fn plan(model: &'a Results, results: &'a [CaseResult]) -> Self {
        let mut jobs = Jobs {
            jobs: BTreeMap::new(),
        };
        // The shown cases are those the model keeps in memory.
        let cases: BTreeMap<&str, &CaseInfo> =
            model.cases.resident().map(|c| (c.id.as_str(), c)).collect();
        for r in results {
            let info = cases.get(r.case.id.as_str()).copied();
            let Some(frame) = r.sample_frame.as_ref() else {
                continue;
            };
            let Some(info) = info.and_then(|c| c.sample_frame.as_ref()) else {
                continue;
            };
            jobs.add(frame_image_path(&r.case.id), move || {
                super::super::frames::view_png(frame, &info.rois, &info.stretch).map_err(|e| {
                    ChartError {
                        chart: format!("frame view {}", r.case.id),
                        message: e.to_string(),
                    }
                })
            });
        }
        for c in model.cases.resident() {
            let Some(w) = c.worst_phase.as_ref() else {
                continue;
            };
            let (Some(frame), Some(info)) = (w.rendered.as_ref(), w.sample_frame.as_ref()) else {
                continue;
            };
            jobs.add(worst_phase_image_path(&c.id), move || {
                super::super::frames::view_png(frame, &info.rois, &info.stretch).map_err(|e| {
                    ChartError {
                        chart: format!("worst-phase frame view {}", c.id),
                        message: e.to_string(),
                    }
                })
            });
        }
        jobs
    }
}

impl<'a> ChartJobs<'a> {
    /// The charts of a finished run: per case its luma trace and zoom, one
    /// matrix per light level, a phase fold per LED ROI with enough phases,
    /// the fine maps and the exposure advice. Nothing is drawn yet.
    /// A run with more cases than a report lists draws the case charts of
    /// the cases with a page only ([`crate::model::listing::Listing::charts_case`]).
    pub fn plan(model: &'a Results, results: &'a [CaseResult]) -> Self {
        let mut jobs = Jobs {
            jobs: BTreeMap::new(),
        };
        let listing = listing(model, model.report_detail());
        // The charted cases are those the model keeps in memory.
        let cases: BTreeMap<&str, &CaseInfo> =
            model.cases.resident().map(|c| (c.id.as_str(), c)).collect();
        for r in results {
            if !listing.charts_case(&r.case.id) {
                continue;
            }
            let case = cases.get(r.case.id.as_str()).copied();
            let segments = case.and_then(|c| c.capture.as_ref()).map(|c| &c.segments);
            let apparent_hz = case.map_or(0.0, |c| c.apparent_frequency_hz);
            jobs.add(trace_chart_path(&r.case.id), move || {
                charts::luma_trace_svg(r, segments)
            });
            jobs.add(zoom_chart_path(&r.case.id), move || {
                charts::trace_zoom_svg(r, apparent_hz)
            });
            // The colour of each LED ROI of a plan with colour: the frames'
            // path is in the case result, not in results.json.
            let coloured = r.metrics.iter().enumerate().filter_map(|(k, m)| {
                let c = m.colour.as_ref().filter(|c| !c.path.is_empty())?;
                Some((k, c, r.acquisition.rois.get(k)?.name.as_str()))
            });
            for (k, c, roi) in coloured {
                let region = c.signal_colour();
                let title = format!("Colour of {roi} over the PWM segment, {}", r.case.id);
                jobs.add(uv_chart_path(&r.case.id, k), move || {
                    charts::uv_diagram_svg(&title, c, region)
                });
            }
            // The worst-phase trace is not in results.json: a model read
            // back from it has the sentence but no chart.
            if let Some(w) = case
                .and_then(|c| c.worst_phase.as_ref())
                .filter(|w| !w.luma.is_empty())
            {
                let fdi_min = model.thresholds.fdi_2018_min;
                jobs.add(worst_phase_chart_path(&r.case.id), move || {
                    charts::worst_phase_svg(r, w, fdi_min)
                });
            }
        }
        for (r, frame, info, stretch) in roi_map_cases(model, results, &cases) {
            jobs.add(roi_map_chart_path(&r.case.id), move || {
                charts::roi_map_svg(frame, &info.rois, &stretch)
            });
        }
        for (i, lux) in model.light_levels().into_iter().enumerate() {
            jobs.add(matrix_chart_path(i), move || matrix::matrix_svg(model, lux));
            if model.display.is_some() {
                jobs.add(super::visibility_matrix_chart_path(i), move || {
                    matrix::visibility_matrix_svg(model, lux)
                });
            }
        }
        for c in model
            .cases
            .resident()
            .filter(|c| listing.charts_case(&c.id))
        {
            let drawn = c.rois.iter().filter(|roi| {
                roi.kind == RoiKind::Led
                    && roi.analysis.phase_coverage.covered_bins >= charts::MIN_FOLD_PHASES
            });
            // Many ROIs: one chart of small panels instead of a chart each.
            if drawn.clone().count() > charts::FOLD_GRID_FROM {
                let rois: Vec<_> = drawn.collect();
                jobs.add(fold_chart_path(&c.id, 0), move || {
                    charts::fold_grid_svg(&c.id, &rois)
                });
                continue;
            }
            for (k, roi) in drawn.enumerate() {
                jobs.add(fold_chart_path(&c.id, k), move || {
                    charts::phase_fold_svg(
                        &format!("{}: {}", c.id, roi.name),
                        &roi.analysis.folded_bins,
                        roi.analysis.envelope,
                    )
                });
            }
        }
        let threshold = model.thresholds.fdi_2018_min;
        for (i, m) in model.fine_maps.iter().enumerate() {
            use charts::{FineMapKind, finemap_svg};
            jobs.add(finemap_chart_path(i, "fdi"), move || {
                finemap_svg(&m.map, FineMapKind::Fdi, threshold)
            });
            jobs.add(finemap_chart_path(i, "pf"), move || {
                finemap_svg(&m.map, FineMapKind::PercentFlicker, threshold)
            });
        }
        if let Some(a) = &model.advice {
            jobs.add(ADVICE_CHART.to_string(), move || {
                charts::advise_svg(&a.curve, a.advice.min_exposure_s)
            });
        }
        jobs
    }
}

impl<'a, T: Clone + Send + Sync> Jobs<'a, T> {
    fn add(&mut self, path: String, draw: impl Fn() -> Result<T, ChartError> + Send + Sync + 'a) {
        super::super::progress::planned();
        let job = Job {
            draw: Box::new(move || {
                let picture = draw();
                super::super::progress::drawn();
                picture
            }),
            drawn: OnceLock::new(),
        };
        self.jobs.insert(path, job);
    }

    /// The picture paths, in order.
    pub fn paths(&self) -> impl Iterator<Item = &str> {
        self.jobs.keys().map(String::as_str)
    }

    /// The picture at `path`, drawn now unless it was before (or is being
    /// drawn by another thread: then when that one is done). `None` when
    /// the report has no such picture.
    pub fn get(&self, path: &str) -> Option<Result<&T, &ChartError>> {
        let job = self.jobs.get(path)?;
        Some(job.drawn.get_or_init(&job.draw).as_ref())
    }

    /// Draws every picture not drawn yet, in parallel; returns them by
    /// path, or the first error in path order.
    pub fn draw_all(&self) -> Result<BTreeMap<String, T>, ChartError> {
        use rayon::prelude::*;
        let drawn: Vec<_> = self
            .jobs
            .par_iter()
            .map(|(path, job)| (path, job.drawn.get_or_init(&job.draw)))
            .collect();
        drawn
            .into_iter()
            .map(|(path, picture)| Ok((path.clone(), picture.clone()?)))
            .collect()
    }
}

/// Share of a frame's pixels that must be above [`DARK_SHARE_OF_FULL_SCALE`]
/// of full scale for the frame to show anything (the rule of `ledflicker
/// roi`'s preview: 0.1 % above 5 of 255).
const LIT_SHARE: f64 = 0.001;
/// Level below which a pixel is dark, as a share of full scale.
const DARK_SHARE_OF_FULL_SCALE: f64 = 5.0 / 255.0;

/// Whether `frame` shows anything: a capture's darkest PWM frame can be
/// black where the lamp was off for the whole exposure, and ROIs drawn on
/// black show nothing of where they are.
fn shows_anything(frame: &crate::model::RenderedFrame) -> bool {
    let dark = frame.full_scale_dn * DARK_SHARE_OF_FULL_SCALE;
    let mut lit = 0u64;
    for y in 0..frame.height {
        frame.for_each_in_row(y, (0, frame.width), |_, v| lit += u64::from(v > dark));
    }
    lit as f64 > LIT_SHARE * f64::from(frame.width) * f64::from(frame.height)
}

/// The cases whose frame the ROI map shows, with that frame, its view and
/// its display stretch: those of [`crate::map_cases`]. Of a captured run,
/// each capture's frame where the lamp is lit (its `lit_frame`; else its
/// sample frame), those that show anything (else the brightest one, by the
/// same rule). Of a simulated run, whose frames all show the same scene,
/// the one case whose sample frame (its darkest PWM frame) is brightest,
/// so that the lamp is lit in it.
fn roi_map_cases<'a>(
    model: &Results,
    results: &'a [CaseResult],
    cases: &BTreeMap<&str, &'a CaseInfo>,
) -> Vec<(
    &'a CaseResult,
    &'a crate::model::RenderedFrame,
    &'a crate::model::SampleFrameInfo,
    Stretch,
)> {
    let captured = model.method.backend == crate::model::BackendName::Captured;
    let chosen = crate::map_cases(model);
    let mut framed: Vec<_> = results
        .iter()
        .filter(|r| chosen.contains(&r.case.id))
        .filter_map(|r| {
            let case = cases.get(r.case.id.as_str())?;
            let info = case.sample_frame.as_ref()?;
            let (frame, stretch) = match (captured, &r.lit_frame) {
                (true, Some(f)) => (f, Stretch::of_frame(f)),
                _ => (r.sample_frame.as_ref()?, info.stretch),
            };
            Some((r, frame, info, stretch, case.sample_frame_led_level()))
        })
        .collect();
    // In plan order, whatever order the report holds its cases in (a
    // large run's are its listed cases, worst first).
    framed.sort_by_key(|f| f.0.case.index);
    if captured && !framed.iter().any(|f| shows_anything(f.1)) {
        let mut brightest = crate::model::MapChoice::new(false);
        for (k, f) in framed.iter().enumerate() {
            brightest.offer_level(k, f.4);
        }
        let keep = brightest.positions();
        framed = keep.into_iter().map(|k| framed[k]).collect();
    } else if captured {
        framed.retain(|f| shows_anything(f.1));
    }
    framed
        .into_iter()
        .map(|(r, f, i, s, _)| (r, f, i, s))
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The small fixture plan (tests/fixtures/plans/base.toml) run on the
    /// simulator, and its model: the report's unit tests start from it.
    pub(crate) fn small_run() -> (Vec<CaseResult>, Results) {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("tests/fixtures/plans/base.toml");
        let plan = ledflicker_core::plan::load(&path).unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let simulator = ledflicker_core::backend::sim::Simulator::new(&plan);
        let results =
            ledflicker_core::runner::run(&plan, &cases, &simulator, Some(2), &|_| {}).unwrap();
        let model = ledflicker_core::model::assemble(&plan, "sim-ideal", &results);
        (results, model)
    }

    #[test]
    fn charts_drawn_on_demand_beside_draw_all_are_the_charts_drawn_alone() {
        let (results, model) = small_run();
        let alone = ChartJobs::plan(&model, &results).draw_all().unwrap();
        let first = &results[0].case.id;
        assert!(alone.contains_key(&trace_chart_path(first)));
        assert!(alone.contains_key(&zoom_chart_path(first)));
        assert!(alone.contains_key(&matrix_chart_path(0)));
        // Each chart is what its drawing function gives.
        assert_eq!(
            alone[&trace_chart_path(first)],
            charts::luma_trace_svg(&results[0], None).unwrap()
        );
        // A reader (the PDF) asks for charts while draw_all runs: each is
        // drawn once, and both see the same bytes.
        let jobs = ChartJobs::plan(&model, &results);
        let mut paths: Vec<&str> = jobs.paths().collect();
        paths.reverse();
        let (read, all) = rayon::join(
            || {
                paths
                    .iter()
                    .map(|p| jobs.get(p).unwrap().unwrap().clone())
                    .collect::<Vec<_>>()
            },
            || jobs.draw_all().unwrap(),
        );
        assert_eq!(all, alone);
        for (p, svg) in paths.iter().zip(&read) {
            assert_eq!(&alone[*p], svg, "{p}");
        }
        assert!(jobs.get("charts/no-such-chart.svg").is_none());
    }

    /// A black frame shows nothing; a frame with 0.2 % of its pixels lit
    /// does; 0.05 % (a few hot pixels) or a level of 4 DN in 255 does not.
    #[test]
    fn a_frame_shows_anything_when_more_than_a_thousandth_of_it_is_lit() {
        let frame = |lit: usize, level: f64| {
            let mut luma = vec![0.0; 100 * 100];
            luma[..lit].iter_mut().for_each(|v| *v = level);
            crate::model::RenderedFrame::from_pixels(0, 100, 100, &luma, 255.0)
        };
        assert!(!shows_anything(&frame(0, 0.0)));
        assert!(shows_anything(&frame(20, 200.0)));
        assert!(!shows_anything(&frame(5, 200.0)));
        assert!(!shows_anything(&frame(20, 4.0)));
    }
}
