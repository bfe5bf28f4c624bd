//! The renderers' input: results.json plus the charts and the signatories.
//!
//! Sits between the report model ([`crate::model::Results`]) and the
//! renderers (HTML, PDF). Everything in a [`Document`] is stored in the report
//! directory (results.json, `charts/*.svg`, signoff.json), so a report can be
//! rendered again from its directory alone; `ledflicker sign` does that to
//! put a new signatory on the cover without rerunning the plan.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

mod driver;
mod info;
mod jobs;
mod notes;
pub mod profile;

pub use driver::{DriverRow, DriverView};
pub use info::{InfoRow, info_row};
#[cfg(test)]
pub(crate) use jobs::tests::small_run;
pub use jobs::{ChartJobs, Jobs, ViewJobs};

use super::ReportError;
use crate::model::{CaseResult, Detail, InputFile, ReportMeta, Results, RoiKind};

/// Folder of the chart SVGs, relative to the report directory.
pub const CHARTS_DIR: &str = "charts";

/// A person who signed the report, as shown in the sign-off block.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Signatory {
    /// "Name, Role" as given to `--signer`.
    pub signer: String,
    /// Date of signing, `YYYY-MM-DD`.
    pub date: String,
    /// First 16 hex digits of the SHA-256 of the signer's certificate.
    pub key_id: String,
}

/// Chart file name of one case's luma trace, relative to the report dir.
pub fn trace_chart_path(case_id: &str) -> String {
    format!("{CHARTS_DIR}/trace-{case_id}.svg")
}

/// Chart file name of one case's zoomed trace panels (the segment steps
/// and two beat periods at full resolution).
pub fn zoom_chart_path(case_id: &str) -> String {
    format!("{CHARTS_DIR}/zoom-{case_id}.svg")
}

/// Chart file name of the matrix of the `index`-th light level.
pub fn matrix_chart_path(index: usize) -> String {
    format!("{CHARTS_DIR}/matrix-{index}.svg")
}

/// Chart file name of the visibility matrix of the `index`-th light
/// level (plans with `[display]`).
pub fn visibility_matrix_chart_path(index: usize) -> String {
    format!("{CHARTS_DIR}/matrix-visibility-{index}.svg")
}

/// Chart of the `k`-th LED ROI's phase fold of one case.
pub fn fold_chart_path(case_id: &str, k: usize) -> String {
    format!("{}{k:02}.svg", fold_chart_prefix(case_id))
}

/// Common prefix of a case's phase-fold charts.
pub fn fold_chart_prefix(case_id: &str) -> String {
    format!("{CHARTS_DIR}/fold-{case_id}-")
}

/// Fine-map chart of the `index`-th light level; `kind` is "fdi" or "pf".
pub fn finemap_chart_path(index: usize, kind: &str) -> String {
    format!("{CHARTS_DIR}/finemap-{index}-{kind}.svg")
}

/// Chart of the ROIs drawn and named on a whole frame of one case: the
/// frame of each capture, or of the simulated camera.
pub fn roi_map_chart_path(case_id: &str) -> String {
    format!("{CHARTS_DIR}/rois-{case_id}.svg")
}

/// Common prefix of the ROI maps' paths.
pub const ROI_MAP_PREFIX: &str = "charts/rois-";

/// The u′v′ diagram of the `k`-th ROI of one case (an LED ROI of a plan
/// with colour).
pub fn uv_chart_path(case_id: &str, k: usize) -> String {
    format!("{CHARTS_DIR}/uv-{case_id}-{k:02}.svg")
}

/// Chart of the exposure advice.
pub const ADVICE_CHART: &str = "charts/advice.svg";

/// Chart of one case's trace at the worst PWM phase beside the trace as
/// run (the evidence of a worst-phase verdict).
pub fn worst_phase_chart_path(case_id: &str) -> String {
    format!("{CHARTS_DIR}/worst-phase-{case_id}.svg")
}

/// A case's frame at the worst PWM phase, as the document names it: the
/// full-size frame's path.
pub fn worst_phase_image_path(case_id: &str) -> String {
    crate::model::evidence::worst_phase_frame_path(case_id)
}

/// Folder of the sample frames, relative to the report directory.
pub const FRAMES_DIR: &str = "frames";

/// A case's sample frame, relative to the report directory.
pub fn frame_image_path(case_id: &str) -> String {
    format!("{FRAMES_DIR}/{case_id}.png")
}

/// Everything a renderer needs.
#[derive(Debug, Clone)]
pub struct Document {
    /// results.json, typed (the results model, with `report` metadata);
    /// shared, because the HTML, the PDF and results.json are written at
    /// once from the same model and a large run's model is large.
    pub results: std::sync::Arc<Results>,
    /// Chart path relative to the report dir (see [`trace_chart_path`]) ->
    /// SVG text.
    pub charts: BTreeMap<String, String>,
    /// Signatories so far; empty for a draft.
    pub signatories: Vec<Signatory>,
    /// Image path (see [`frame_image_path`]) -> small PNG for the renderers;
    /// the full-size frames are in the report directory.
    pub images: BTreeMap<String, Vec<u8>>,
    /// The report profile's files (logo, replaced templates); empty
    /// without a profile.
    pub look: profile::Look,
}

/// Reasons of an LED ROI that both reports print in the case table (the
/// spectrum's reason and the phase-coverage warning), so not as caveats.
const SHOWN_IN_CASE_TABLE: [&str; 2] = ["apparent_frequency_spectrum_hz", "phase_coverage"];

/// The caveat of an FDI (2018) that is +∞, said once for all the ROIs of a
/// case that have it.
const UNBOUNDED_FDI: &str =
    "the OFF reference is 0 (dark): the contrast is unbounded (+∞), so the light never appears OFF";

impl Document {
    /// Builds the document of a finished run: draws every chart and frame
    /// view and adds the `report` metadata (date, inputs, notes) to the
    /// model.
    pub fn build(
        model: &Results,
        results: &[CaseResult],
        date: &str,
        signatories: Vec<Signatory>,
    ) -> Result<Document, ReportError> {
        let (charts, images) = rayon::join(
            || ChartJobs::plan(model, results).draw_all(),
            || ViewJobs::plan(model, results).draw_all(),
        );
        Ok(Self::with_pictures(
            model.clone(),
            date,
            signatories,
            charts?,
            images?,
        ))
    }

    /// [`Self::build`] with the charts and frame views given (path ->
    /// picture): adds the `report` metadata to the model.
    pub fn with_pictures(
        mut model: Results,
        date: &str,
        signatories: Vec<Signatory>,
        charts: BTreeMap<String, String>,
        images: BTreeMap<String, Vec<u8>>,
    ) -> Document {
        let detail = model
            .report
            .as_ref()
            .and_then(|r| Detail::parse(&r.detail))
            .unwrap_or_default();
        model.report = Some(report_meta(&model, date, detail));
        Document {
            results: std::sync::Arc::new(model),
            charts,
            signatories,
            images,
            look: profile::Look::default(),
        }
    }

    /// The report is a draft: nobody has signed it.
    pub fn is_draft(&self) -> bool {
        self.signatories.is_empty()
    }

    /// results.json as the renderers read it: the JSON value of the
    /// model, so HTML and PDF show exactly what results.json says. Its
    /// `cases` are the listed ones ([`Self::listing`]), in case order: a
    /// report shows no other, and a large run's every case would cost the
    /// renderers memory in proportion to the run.
    pub fn json(&self) -> Result<serde_json::Value, ReportError> {
        let listing = self.listing();
        if listing.unlisted == 0 {
            return Ok(serde_json::to_value(&*self.results)?);
        }
        let mut shown = self.results.without_cases();
        // Every listed case is among those the model keeps in memory.
        shown.cases = (self.results.cases.resident())
            .filter(|c| listing.listed.contains(&c.id))
            .cloned()
            .collect();
        Ok(serde_json::to_value(&shown)?)
    }

    /// Ids of the cases the templates see (the listed ones, [`Self::json`]),
    /// in plan order.
    pub fn case_ids(&self) -> Vec<String> {
        let listing = self.listing();
        (self.results.cases.resident())
            .filter(|c| listing.listed.contains(&c.id))
            .map(|c| c.id.clone())
            .collect()
    }

    /// The `--detail` the report was written with (results.json
    /// `report.detail`; reports written before it existed are `full`).
    pub fn detail(&self) -> Detail {
        self.results.report_detail()
    }

    /// Which cases the report shows: pages, and rows of the per-case
    /// tables ([`crate::model::listing`]).
    pub fn listing(&self) -> crate::model::listing::Listing {
        crate::model::listing::listing(&self.results, self.detail())
    }

    /// Ids of the cases that get their own page at this report's detail.
    pub fn case_pages(&self) -> std::collections::BTreeSet<String> {
        self.listing().pages
    }

    /// The glossary the report lists: the visibility metrics follow the
    /// others only for a plan with `[display]`, whose cases have them.
    pub fn glossary(&self) -> Vec<crate::model::MetricName> {
        let visibility = self.results.display.is_some();
        let extra = crate::model::VISIBILITY_GLOSSARY
            .iter()
            .filter(|_| visibility);
        crate::model::GLOSSARY
            .iter()
            .chain(extra)
            .copied()
            .collect()
    }

    /// The section on what the driver sees, over the listed cases; `None`
    /// for a plan without `[display]`.
    pub fn driver(&self) -> Option<DriverView> {
        let listing = self.listing();
        driver::driver_view(&self.results, |id| listing.listed.contains(id))
    }

    /// The listed informational cases without a page of their own, one
    /// table row each, in plan order ([`Detail::shows_case`]).
    pub fn info_rows(&self) -> Vec<InfoRow> {
        let listing = self.listing();
        self.results
            .cases
            .resident()
            .filter(|c| !listing.pages.contains(&c.id) && listing.listed.contains(&c.id))
            .filter_map(info_row)
            .collect()
    }

    /// Per failing case, its limits as a ROI x metric table, worst ROI
    /// first ([`crate::model::limits`]), for the failing-cases summary.
    pub fn limit_tables(&self) -> BTreeMap<String, crate::model::limits::LimitTable> {
        let listing = self.listing();
        // A run beyond the listed cases gives a table to the failing cases
        // with a page (the worst); Appendix A and summary.csv hold the rest.
        let tabled = |id: &String| match listing.unlisted {
            0 => listing.listed.contains(id),
            _ => listing.pages.contains(id),
        };
        self.results
            .cases
            .resident()
            .filter(|c| c.verdict == crate::model::Verdict::Fail)
            .filter(|c| tabled(&c.id))
            .map(|c| (c.id.clone(), c.limit_table()))
            .collect()
    }

    /// Per listed case, the sentences that stand for its phase folds that are not
    /// drawn ([`super::charts::degenerate_fold_sentence`]); ROIs with the
    /// same reason share one sentence ("Phase fold of roi0, roi1 not drawn").
    pub fn fold_notes(&self) -> BTreeMap<String, Vec<String>> {
        const NAME: &str = "\u{0}";
        let mut out = BTreeMap::new();
        let listing = self.listing();
        for c in (self.results.cases.resident()).filter(|c| listing.listed.contains(&c.id)) {
            let frequency_known = c.frequency_hz > 0.0;
            // Sentence with a placeholder name -> the ROIs it stands for.
            let mut notes: Vec<(String, Vec<&str>)> = Vec::new();
            for roi in c.rois.iter().filter(|r| r.kind == RoiKind::Led) {
                let cov = &roi.analysis.phase_coverage;
                let sentence = super::charts::degenerate_fold_sentence(
                    NAME,
                    cov.covered_bins,
                    cov.bins,
                    frequency_known,
                );
                let Some(sentence) = sentence else { continue };
                match notes.iter_mut().find(|(s, _)| *s == sentence) {
                    Some((_, names)) => names.push(&roi.name),
                    None => notes.push((sentence, vec![&roi.name])),
                }
            }
            let notes = notes
                .into_iter()
                .map(|(s, names)| s.replace(NAME, &names.join(", ")))
                .collect();
            out.insert(c.id.clone(), notes);
        }
        out
    }

    /// Per listed case, its caveats (metric values undefined or qualified), each
    /// text once, metrics by their names for people:
    /// `"led, background / FDI (Deegan 2018): <why>"`. Reasons in
    /// [`SHOWN_IN_CASE_TABLE`] are left out: the case table's "Apparent
    /// flicker" and "Phase coverage" rows print an LED ROI's, and a
    /// background ROI is flat by design.
    pub fn caveats(&self) -> BTreeMap<String, Vec<String>> {
        let mut out = BTreeMap::new();
        let listing = self.listing();
        for c in (self.results.cases.resident()).filter(|c| listing.listed.contains(&c.id)) {
            // Reason text -> (ROIs, metrics), in order of first appearance.
            let mut seen: Vec<(&str, Vec<&str>, Vec<&str>)> = Vec::new();
            for roi in &c.rois {
                for (metric, why) in &roi.reasons {
                    // An LED ROI's table prints these; a background ROI is
                    // flat by design, so its "no flicker to measure" is expected.
                    if SHOWN_IN_CASE_TABLE.contains(&metric.as_str()) {
                        continue;
                    }
                    // Each ROI's unbounded FDI names its own minimum luma;
                    // the table shows +∞, so one line serves every ROI.
                    let why: &str = if roi.is_unbounded(metric) {
                        UNBOUNDED_FDI
                    } else {
                        why
                    };
                    let at = match seen.iter().position(|(w, _, _)| *w == why) {
                        Some(i) => i,
                        None => {
                            seen.push((why, Vec::new(), Vec::new()));
                            seen.len() - 1
                        }
                    };
                    let (_, rois, metrics) = &mut seen[at];
                    if !rois.contains(&roi.name.as_str()) {
                        rois.push(&roi.name);
                    }
                    if !metrics.contains(&metric.as_str()) {
                        metrics.push(metric);
                    }
                }
            }
            let lines = seen
                .into_iter()
                .map(|(why, rois, metrics)| {
                    let names: Vec<&str> = metrics
                        .iter()
                        .map(|m| crate::model::human_name(m))
                        .collect();
                    format!("{} / {}: {why}", rois.join(", "), names.join(", "))
                })
                .collect();
            out.insert(c.id.clone(), lines);
        }
        out
    }

    /// Report date from results.json, or "" when missing.
    pub fn date(&self) -> &str {
        self.results.report.as_ref().map_or("", |r| r.date.as_str())
    }

    /// Reads results.json and `charts/*.svg` from a report directory.
    /// Signatories are left empty (the caller reads signoff.json).
    pub fn load(dir: &Path) -> Result<Document, ReportError> {
        let path = dir.join("results.json");
        let text = crate::util::read_input_to_string(&path).map_err(|source| ReportError::Io {
            path: path.clone(),
            source,
        })?;
        let results =
            crate::model::read_results(&text).map_err(|message| ReportError::Invalid {
                path: path.clone(),
                message,
            })?;
        if results.report.is_none() {
            return Err(ReportError::Invalid {
                path,
                message: format!(
                    "not a `{}` file written by `ledflicker plan` (no `report` section)",
                    crate::model::RESULTS_SCHEMA
                ),
            });
        }
        let mut charts = BTreeMap::new();
        let charts_dir = dir.join(CHARTS_DIR);
        let entries = std::fs::read_dir(&charts_dir).map_err(|source| ReportError::Io {
            path: charts_dir.clone(),
            source,
        })?;
        for entry in entries {
            let entry = entry.map_err(|source| ReportError::Io {
                path: charts_dir.clone(),
                source,
            })?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if !name.ends_with(".svg") {
                continue;
            }
            let svg = crate::util::read_input_to_string(&entry.path()).map_err(|source| {
                ReportError::Io {
                    path: entry.path(),
                    source,
                }
            })?;
            charts.insert(format!("{CHARTS_DIR}/{name}"), svg);
        }
        let mut images = BTreeMap::new();
        for case in results.cases.iter().filter(|c| c.worst_phase.is_some()) {
            let view = dir.join(crate::model::evidence::worst_phase_view_path(&case.id));
            if let Ok(bytes) = crate::util::read_input(&view) {
                images.insert(worst_phase_image_path(&case.id), bytes);
            }
        }
        for case in &results.cases {
            let id = case.id.as_str();
            let rel = frame_image_path(id);
            // The annotated view as written, else (older reports) the frame.
            let view = dir.join(super::frames::view_path(id));
            if let Ok(bytes) = crate::util::read_input(&view) {
                images.insert(rel, bytes);
                continue;
            }
            let path = dir.join(&rel);
            if !path.exists() {
                continue;
            }
            let bytes = crate::util::read_input(&path).map_err(|source| ReportError::Io {
                path: path.clone(),
                source,
            })?;
            let img = ledflicker_plan::image_io::decode_png(&bytes)
                .map_err(|e| ReportError::Invalid {
                    path: path.clone(),
                    message: format!("not a readable PNG: {e}"),
                })?
                .to_luma16();
            let luma: Vec<f64> = img.pixels().map(|p| f64::from(p.0[0])).collect();
            let frame = crate::model::RenderedFrame::from_pixels(
                case.sample_frame.as_ref().map_or(0, |f| f.frame),
                img.width(),
                img.height(),
                &luma,
                65535.0,
            );
            let small = super::frames::thumbnail(&frame, super::frames::THUMBNAIL_WIDTH);
            images.insert(rel, super::frames::png_bytes(&small)?);
        }
        let look = profile::Look::load(dir, &results)?;
        Ok(Document {
            results: std::sync::Arc::new(results),
            charts,
            signatories: Vec::new(),
            images,
            look,
        })
    }
}

/// The `report` section of results.json for a run reported on `date`. The
/// inputs are those already in `model.report` (set by
/// [`super::write_report`] from [`ledflicker_core::inputs::collect`]), else the plan;
/// the notes are the model's ([`Results::notes`]).
pub fn report_meta(model: &Results, date: &str, detail: Detail) -> ReportMeta {
    let inputs = model
        .report
        .as_ref()
        .map(|r| r.inputs.clone())
        .filter(|i| !i.is_empty())
        .unwrap_or_else(|| {
            vec![InputFile {
                role: "plan".to_string(),
                path: model.plan.path.clone(),
                sha256: model.plan.sha256.clone(),
                size: std::fs::metadata(&model.plan.path).map_or(0, |m| m.len()),
            }]
        });
    ReportMeta {
        date: date.to_string(),
        detail: detail.as_str().to_string(),
        inputs,
        notes: model.notes.clone(),
        profile: model.report.as_ref().and_then(|r| r.profile.clone()),
    }
}
