//! Reports: the results model (results.json), trace CSVs, charts, the HTML
//! and PDF reports and the JUnit/CSV exports, written atomically into one
//! directory.
//!
//! Last stage of the pipeline. Only this crate touches minijinja and
//! plotters. It renders the results model of `ledflicker-core` and imports
//! nothing else of the pipeline but the leaf helpers (tests/architecture.rs
//! keeps that true; the tests reach further).
#![warn(missing_docs)]

use ledflicker_plan::{timings, util};
use ledflicker_results::{model, outdir};

pub mod charts;
pub mod comparison;
mod context;
pub mod document;
pub mod export;
pub mod frames;
pub mod golden;
pub mod history;
pub mod html;
pub mod matrix;
#[cfg(feature = "pdf")]
pub mod pdf;
pub mod progress;
mod staged;
pub mod terminal;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::model::{
    CaseReadError, CaseResult, CaseSource, Detail, InputFile, ReportMeta, Results, TRACE_COLUMNS,
};
use crate::util::write_atomic;
use staged::{StagedDir, replace_dir};

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// File system error.
    #[error("cannot write `{path}`: {source}")]
    Io {
        /// File or directory.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The directory holds a signed report (and `--force` is off).
    #[error(transparent)]
    OutDir(#[from] crate::outdir::OutDirError),
    /// A template failed to render.
    #[error("cannot render template `{template}`: {message}")]
    Template {
        /// Template name.
        template: String,
        /// minijinja's message.
        message: String,
    },
    /// A chart failed to draw.
    #[error(transparent)]
    Chart(#[from] charts::ChartError),
    /// The run's cases could not be read back from its case store.
    #[error("cannot read the run's cases back")]
    Cases(#[from] CaseReadError),
    /// JSON serialisation failed.
    #[error("cannot serialise results: {0}")]
    Json(#[from] serde_json::Error),
    /// summary.csv failed to write.
    #[error("cannot write summary.csv: {0}")]
    Csv(#[from] csv::Error),
    /// junit.xml failed to write.
    #[error("cannot write junit.xml: {0}")]
    Junit(#[from] quick_junit::SerializeError),
    /// The PDF engine failed.
    #[error("cannot render report.pdf: {message}")]
    Pdf {
        /// typst's diagnostics.
        message: String,
    },
    /// A file of an existing report is not what `ledflicker plan` writes.
    #[error("`{path}` is not usable: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a hint.
        message: String,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
    move |source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Options for writing a report.
#[derive(Debug, Clone)]
pub struct WriteOptions {
    /// Report date shown in the HTML, `YYYY-MM-DD`.
    pub date: String,
    /// Replace a signed report.
    pub force: bool,
    /// Signatories shown in the sign-off block; empty renders a DRAFT.
    pub signatories: Vec<document::Signatory>,
    /// Every input of the run ([`ledflicker_core::inputs::collect`]); empty lists
    /// the plan alone.
    pub inputs: Vec<InputFile>,
    /// How much of each case the report shows.
    pub detail: Detail,
    /// The earlier report in the same `--out` ([`crate::outdir::Generation::previous`]):
    /// a file of traces/, charts/ or frames/ whose bytes are the same as
    /// its file there is hard-linked from it instead of written.
    pub reuse_from: Option<PathBuf>,
    /// The report's look (`[report]`, `--profile`); the default is none.
    pub profile: crate::model::ReportProfile,
}

/// One case's trace as CSV: `frame,time_s,segment,<one luma column per ROI>`
/// ([`TRACE_COLUMNS`], then the ROIs), then, for each ROI with colour
/// planes (an LED ROI of a plan with colour), its columns `<roi>.r`,
/// `<roi>.g` and `<roi>.b`. Written by hand, not with the `csv` crate: its
/// writer costs 50 % more instructions here (docs/speed.md), and no field
/// needs quoting (numbers, segment names, ROI names of letters, digits,
/// `-` and `_`; `.` is in no ROI name, so a plane's column names no ROI).
pub fn trace_csv(result: &CaseResult) -> String {
    let acq = &result.acquisition;
    let mut out = TRACE_COLUMNS.join(",");
    for roi in &acq.rois {
        out.push(',');
        out.push_str(&roi.name);
    }
    let planes: Vec<(&str, &[[f64; 3]])> = acq
        .rois
        .iter()
        .filter_map(|r| Some((r.name.as_str(), r.rgb.as_deref()?)))
        .filter(|(_, rgb)| rgb.len() == acq.frames.len())
        .collect();
    for (name, _) in &planes {
        for p in ["r", "g", "b"] {
            let _ = write!(out, ",{name}.{p}");
        }
    }
    out.push('\n');
    // A ROI's luma takes few distinct values (a steady segment repeats
    // one, a locked PWM phase cycles a few), so each column remembers the
    // text of its recent values: the output is the same as `{}` of each.
    let columns = acq.rois.len() + 3 * planes.len();
    let mut recent: Vec<RecentValues> = (0..columns).map(|_| RecentValues::default()).collect();
    out.reserve(acq.frames.len() * (24 + 20 * columns));
    for (i, f) in acq.frames.iter().enumerate() {
        let _ = write!(out, "{},{},{}", f.index, f.time_s, f.segment.as_str());
        let values = acq
            .rois
            .iter()
            .map(|roi| roi.luma[i])
            .chain(planes.iter().flat_map(|(_, rgb)| rgb[i]));
        for (v, recent) in values.zip(&mut recent) {
            out.push(',');
            out.push_str(recent.text(v));
        }
        out.push('\n');
    }
    out
}

/// The `{}` text of the last few distinct values seen, most recent first.
#[derive(Default)]
struct RecentValues {
    entries: Vec<(u64, String)>,
}

impl RecentValues {
    /// How many distinct values a column keeps: enough for a PWM phase
    /// cycle of a few frames, small enough to search linearly.
    const CAPACITY: usize = 8;

    /// `value` formatted with `{}`; formatted again only when it is not
    /// one of the recent values (compared bit for bit).
    fn text(&mut self, value: f64) -> &str {
        let bits = value.to_bits();
        let at = match self.entries.iter().position(|(b, _)| *b == bits) {
            Some(at) => at,
            None => {
                if self.entries.len() == Self::CAPACITY {
                    self.entries.pop();
                }
                self.entries.push((bits, value.to_string()));
                self.entries.len() - 1
            }
        };
        // Keep the most recent value first, so a steady column finds it at once.
        self.entries[..=at].rotate_right(1);
        &self.entries[0].1
    }
}

/// traces/ and frames/ from one pass over the run's cases, a chunk at a
/// time: each case's trace CSV and worst-phase CSV, its full-size frame
/// and, beside it, the annotated view the document shows
/// ([`frames::view_path`]; drawn here for a case the document does not
/// show), then the worst-phase frames. The files of a chunk are made in
/// parallel and written as they come, so a large run's are never held at
/// once. frames/ is removed when no case has a frame.
fn write_case_files(
    dir: &Path,
    model: &Results,
    cases: &dyn CaseSource,
    doc: &document::Document,
    reuse: Option<&Path>,
) -> Result<(), ReportError> {
    use rayon::prelude::*;
    let _t = crate::timings::span("report: traces and frames");
    let worst_phase = frames::worst_phase_files(model, &doc.images)?;
    let framed = !worst_phase.is_empty() || model.cases.iter().any(|c| c.sample_frame.is_some());
    let mut traces = StagedDir::begin(dir, "traces", reuse)?;
    let mut frames_dir = match framed {
        true => Some(StagedDir::begin(dir, document::FRAMES_DIR, reuse)?),
        false => None,
    };
    for_each_detailed_chunk(model, cases, |chunk| {
        let made: Vec<CaseFiles> = chunk
            .par_iter()
            .map(|(k, r)| case_files(model.cases.get(*k).as_deref(), r, doc))
            .collect::<Result<_, ReportError>>()?;
        for files in made {
            for (name, bytes) in &files.traces {
                traces.put(name, bytes)?;
            }
            if let Some(frames_dir) = frames_dir.as_mut() {
                for (name, bytes) in &files.frames {
                    frames_dir.put(name, bytes)?;
                }
            }
        }
        Ok::<(), ReportError>(())
    })?;
    traces.finish()?;
    match frames_dir {
        Some(mut frames_dir) => {
            for (name, bytes) in &worst_phase {
                frames_dir.put(name, bytes)?;
            }
            frames_dir.finish()
        }
        None => {
            let old = dir.join(document::FRAMES_DIR);
            if old.exists() {
                std::fs::remove_dir_all(&old).map_err(io_err(&old))?;
            }
            Ok(())
        }
    }
}

/// Calls `f` with the cases results.json holds whole (every case, unless
/// the report lists only some: [`crate::model::Cases::is_detailed`]), a
/// chunk at a time, each with its position. Only those are read from the
/// store: the others' traces and frames stay in it, for `ledflicker
/// export`.
fn for_each_detailed_chunk(
    model: &Results,
    cases: &dyn CaseSource,
    mut f: impl FnMut(Vec<(usize, CaseResult)>) -> Result<(), ReportError>,
) -> Result<(), ReportError> {
    if !model.cases.has_rows() {
        return crate::model::for_each_chunk(cases, |first, chunk| {
            f(chunk
                .into_iter()
                .enumerate()
                .map(|(k, r)| (first + k, r))
                .collect())
        });
    }
    let wanted: Vec<usize> = model
        .cases
        .iter()
        .enumerate()
        .filter(|(_, c)| model.cases.is_detailed(&c.id))
        .map(|(k, _)| k)
        .collect();
    for block in wanted.chunks(ledflicker_results::cases::CHUNK) {
        let mut chunk = Vec::with_capacity(block.len());
        for &k in block {
            chunk.extend(cases.read(k..k + 1)?.into_iter().map(|r| (k, r)));
        }
        f(chunk)?;
    }
    Ok(())
}

/// The cases a report at `detail` writes whole (their entry in
/// results.json, trace CSV and frames): every case when it lists every
/// case or pages every one (`None`), else the listed cases and those of
/// the ROI map ([`map_cases`]).
pub fn detailed_cases(
    model: &Results,
    listing: &crate::model::listing::Listing,
    detail: Detail,
) -> Option<std::collections::BTreeSet<String>> {
    if detail == Detail::Full || listing.unlisted == 0 {
        return None;
    }
    let mut ids = listing.listed.clone();
    ids.extend(map_cases(model));
    Some(ids)
}

/// The ROI map's cases (`Cases::map_cases`): every capture's case with a
/// frame, or the one simulated case whose LED ROI is brightest in its
/// sample frame. The builder keeps them in memory, so no spilled case is
/// read back.
pub(crate) fn map_cases(model: &Results) -> std::collections::BTreeSet<String> {
    let each_capture = model.method.backend == crate::model::BackendName::Captured;
    model
        .cases
        .map_cases(each_capture)
        .into_iter()
        .filter_map(|i| model.cases.get(i).map(|c| c.id.clone()))
        .collect()
}

/// One case's files for traces/ and frames/.
struct CaseFiles {
    traces: Vec<(String, Vec<u8>)>,
    frames: Vec<(String, Vec<u8>)>,
}

/// [`CaseFiles`] of the run's case `r`, whose row in the model is `c`.
fn case_files(
    c: Option<&crate::model::CaseInfo>,
    r: &CaseResult,
    doc: &document::Document,
) -> Result<CaseFiles, ReportError> {
    // The model's cases are the run's, in the same order.
    let c = c.filter(|c| c.id == r.case.id);
    let mut traces = vec![(format!("{}.csv", r.case.id), trace_csv(r).into_bytes())];
    traces.extend(c.and_then(|c| export::worst_phase_trace(c, r)));
    let mut frames = Vec::new();
    if let Some(frame) = &r.sample_frame {
        frames.push((format!("{}.png", r.case.id), frames::png_bytes(frame)?));
        let shown = doc.images.get(&document::frame_image_path(&r.case.id));
        let view = match (shown, c.and_then(|c| c.sample_frame.as_ref())) {
            (Some(view), _) => Some(view.clone()),
            (None, Some(info)) => Some(frames::view_png(frame, &info.rois, &info.stretch)?),
            (None, None) => None,
        };
        frames.extend(view.map(|view| (format!("{}-view.png", r.case.id), view)));
    }
    Ok(CaseFiles { traces, frames })
}

/// Whether this build writes report.pdf (the `pdf` feature).
pub const WRITES_PDF: bool = cfg!(feature = "pdf");

/// report.pdf's bytes, laid out by Typst.
#[cfg(feature = "pdf")]
fn render_pdf(
    doc: &document::Document,
    (charts, views): (&document::ChartJobs<'_>, &document::ViewJobs<'_>),
    depth: usize,
) -> Result<Option<Vec<u8>>, ReportError> {
    let _t = crate::timings::span_at("report: pdf (typst)", depth);
    pdf::render_with(doc, pdf::Pictures::Jobs(charts, views)).map(|(bytes, _pages)| Some(bytes))
}

/// A build without the `pdf` feature writes no report.pdf.
#[cfg(not(feature = "pdf"))]
fn render_pdf(
    _doc: &document::Document,
    _pictures: (&document::ChartJobs<'_>, &document::ViewJobs<'_>),
    _depth: usize,
) -> Result<Option<Vec<u8>>, ReportError> {
    Ok(None)
}

/// What [`write_report`] makes while Typst lays out the PDF: traces/,
/// charts/ and frames/ (every picture, drawn now unless Typst drew it),
/// report.html, and junit.xml, summary.csv and results.json written and
/// flushed under temporary names, in that order, to be renamed after the
/// PDF.
fn write_beside_pdf(
    dir: &Path,
    model: &Results,
    cases: &dyn CaseSource,
    options: &WriteOptions,
    (charts, views): (&document::ChartJobs<'_>, &document::ViewJobs<'_>),
    layout_doc: &document::Document,
) -> Result<Vec<crate::util::Staged>, ReportError> {
    let t = crate::timings::span("report: charts and frame views");
    let (charts, images) = rayon::join(|| charts.draw_all(), || views.draw_all());
    let (charts, images) = (charts?, images?);
    let files = charts.iter().map(|(path, svg)| {
        let name = path.rsplit('/').next().unwrap_or(path).to_string();
        Ok((name, svg.clone().into_bytes()))
    });
    let reuse = options.reuse_from.as_deref();
    replace_dir(dir, document::CHARTS_DIR, files, reuse)?;
    drop(t);
    let doc = document::Document {
        charts,
        images,
        ..layout_doc.clone()
    };
    write_case_files(dir, model, cases, &doc, reuse)?;
    let html = {
        let _t = crate::timings::span("report: html");
        html::render_document(&doc)?
    };
    let path = dir.join("report.html");
    write_atomic(&path, html.as_bytes()).map_err(io_err(&path))?;
    let _t = crate::timings::span("report: exports and results.json");
    // junit.xml and summary.csv, streamed to their files rather than built
    // as strings.
    let path = dir.join(export::JUNIT_FILE);
    let junit = crate::util::Staged::write_with(&path, |out| {
        export::write_junit_xml(model, out).map_err(std::io::Error::other)
    });
    let mut staged = vec![junit.map_err(io_err(&path))?];
    let path = dir.join(export::CSV_FILE);
    let csv = crate::util::Staged::write_with(&path, |out| {
        export::write_summary_csv(model, out).map_err(std::io::Error::other)
    });
    staged.push(csv.map_err(io_err(&path))?);
    // The document's model is the run's model with its `report` metadata:
    // results.json, streamed to the file rather than built as one string.
    let path = dir.join("results.json");
    let json = crate::util::Staged::write_with(&path, |out| {
        serde_json::to_writer_pretty(out, &*doc.results).map_err(std::io::Error::other)
    });
    staged.push(json.map_err(io_err(&path))?);
    Ok(staged)
}

/// Writes results.json, traces/, charts/, report.html, report.pdf,
/// junit.xml and summary.csv into `dir`, from the run's `model` and its
/// `cases` (read a chunk at a time), and gives the model back. Every file
/// is written atomically; traces/ and charts/ are built aside and swapped
/// in whole, and results.json goes last, so its presence means the report
/// is complete.
pub fn write_report(
    dir: &Path,
    mut model: Results,
    cases: &dyn CaseSource,
    options: &WriteOptions,
) -> Result<Results, ReportError> {
    crate::outdir::check_overwrite(dir, options.force)?;
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    if options.force {
        for name in crate::outdir::SIGNOFF_FILES {
            let path = dir.join(name);
            if path.is_dir() {
                std::fs::remove_dir_all(&path).map_err(io_err(&path))?;
            } else if path.exists() {
                std::fs::remove_file(&path).map_err(io_err(&path))?;
            }
        }
    }

    let given = model.report.take();
    model.report = Some(ReportMeta {
        date: options.date.clone(),
        detail: options.detail.as_str().to_string(),
        inputs: options.inputs.clone(),
        notes: Vec::new(),
        profile: document::profile::meta(&options.profile),
    });
    document::profile::write_files(dir, &options.profile)?;
    let listing = crate::model::listing::listing(&model, options.detail);
    let detailed = detailed_cases(&model, &listing, options.detail);
    model.cases.set_detailed(detailed);
    // One model, shared by the PDF, the HTML and results.json: the
    // document's model is results.json as written.
    let layout_doc = document::Document::with_pictures(
        model,
        &options.date,
        options.signatories.clone(),
        BTreeMap::new(),
        BTreeMap::new(),
    )
    .with_profile_files(&options.profile);
    let shared = std::sync::Arc::clone(&layout_doc.results);
    let written = write_documents(dir, &shared, layout_doc, cases, options);
    let mut model = std::sync::Arc::try_unwrap(shared).unwrap_or_else(|m| (*m).clone());
    model.report = given;
    written.map(|()| model)
}

/// The files of [`write_report`], from the model with its `report`
/// metadata and the document laid out from it.
fn write_documents(
    dir: &Path,
    model: &Results,
    mut layout_doc: document::Document,
    cases: &dyn CaseSource,
    options: &WriteOptions,
) -> Result<(), ReportError> {
    // Typst starts on a document that names every picture, and draws a
    // chart or frame view when a page shows it; the pictures it does not
    // show (most traces), the HTML, the exports and the results.json text
    // are made beside it. Only the cases the document shows are read for
    // their pictures.
    let shown = shown_cases(model, &layout_doc.listing(), cases)?;
    let charts = document::ChartJobs::plan(model, &shown);
    let views = document::ViewJobs::plan(model, &shown);
    layout_doc.charts = charts
        .paths()
        .map(|p| (p.to_string(), String::new()))
        .collect();
    layout_doc.images = views.paths().map(|p| (p.to_string(), Vec::new())).collect();
    // The other renderers run on a thread of their own, not on a rayon
    // worker: their file writes block it, and Typst's parallel page runs
    // need every worker. Their drawing still runs on the pool.
    let depth = crate::timings::depth();
    let (pdf, others) = std::thread::scope(|scope| {
        let beside = scope.spawn(|| {
            crate::timings::at_depth(depth, || {
                write_beside_pdf(dir, model, cases, options, (&charts, &views), &layout_doc)
            })
        });
        let pdf = render_pdf(&layout_doc, (&charts, &views), depth);
        crate::util::release_free_memory();
        let others = beside
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (pdf, others)
    });
    let staged = others?;
    // A large run's case that could not be read back from its spill file
    // left some file short: nothing is committed.
    if let Some(why) = model.cases.read_error() {
        return Err(ReportError::Cases(why.into()));
    }
    // report.pdf, then the exports, then results.json: its presence means
    // the report is complete. Their flushes to disk ran beside Typst.
    if let Some(pdf) = pdf? {
        let path = dir.join("report.pdf");
        write_atomic(&path, &pdf).map_err(io_err(&path))?;
    }
    for file in staged {
        let path = file.path().to_path_buf();
        file.commit().map_err(io_err(&path))?;
    }
    Ok(())
}

/// The run's cases whose pictures the document shows: every case of a run
/// within [`crate::model::listing::EVERY_CASE_LISTED_MAX`], else the cases with
/// a page (only a case page shows a case's charts and frame), and those of
/// the ROI map ([`map_cases`]), in case order.
fn shown_cases(
    model: &Results,
    listing: &crate::model::listing::Listing,
    cases: &dyn CaseSource,
) -> Result<Vec<CaseResult>, ReportError> {
    if listing.unlisted == 0 {
        return Ok(cases.read(0..cases.len())?);
    }
    let map = map_cases(model);
    let mut shown = Vec::new();
    for (k, c) in model.cases.iter().enumerate() {
        if map.contains(&c.id) || listing.pages.contains(&c.id) {
            shown.extend(cases.read(k..k + 1)?);
        }
    }
    Ok(shown)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trace CSV as `{}` of every value, written plainly: each ROI's
    /// luma, then the R, G and B of each ROI with colour planes.
    fn plain_csv(result: &CaseResult) -> String {
        let acq = &result.acquisition;
        let mut out = String::from("frame,time_s,segment");
        for roi in &acq.rois {
            out.push_str(&format!(",{}", roi.name));
        }
        for roi in acq.rois.iter().filter(|r| r.rgb.is_some()) {
            out.push_str(&format!(",{0}.r,{0}.g,{0}.b", roi.name));
        }
        out.push('\n');
        for (i, f) in acq.frames.iter().enumerate() {
            out.push_str(&format!("{},{},{}", f.index, f.time_s, f.segment.as_str()));
            for roi in &acq.rois {
                out.push_str(&format!(",{}", roi.luma[i]));
            }
            for rgb in acq.rois.iter().filter_map(|r| r.rgb.as_ref()) {
                out.push_str(&format!(",{},{},{}", rgb[i][0], rgb[i][1], rgb[i][2]));
            }
            out.push('\n');
        }
        out
    }

    #[test]
    fn trace_csv_gives_colour_planes_columns_after_every_luma_column() {
        let (mut results, _) = document::small_run();
        let r = &mut results[0];
        // A second ROI, with colour, after the fixture's own.
        let mut lamp = r.acquisition.rois[0].clone();
        lamp.name = "lamp".to_string();
        r.acquisition.rois.push(lamp);
        let plain = trace_csv(r);
        let n = r.acquisition.frames.len();
        let name = "lamp";
        r.acquisition.rois[1].rgb = Some(
            (0..n)
                .map(|i| [i as f64 * 0.5, 3.0, (i % 7) as f64 + 0.25])
                .collect(),
        );
        let coloured = trace_csv(r);
        assert_eq!(coloured, plain_csv(r));
        let header = coloured.lines().next().unwrap();
        assert!(
            header.ends_with(&format!(",{name}.r,{name}.g,{name}.b")),
            "{header}"
        );
        // The luma columns are those of the trace without colour.
        for (a, b) in plain.lines().zip(coloured.lines()) {
            assert!(b.starts_with(a) && b.matches(',').count() == a.matches(',').count() + 3);
        }
    }

    #[test]
    fn trace_csv_is_every_value_formatted_with_display() {
        let (mut results, _) = document::small_run();
        // As simulated: steady segments and short PWM cycles.
        for r in &results {
            assert_eq!(trace_csv(r), plain_csv(r));
        }
        // Cycles longer than the remembered values, values that differ in
        // the last bit, signed zeros and a value too small for plain digits.
        let r = &mut results[0];
        let n = r.acquisition.frames.len();
        assert!(n > 40, "the fixture has {n} frames");
        let edge = [0.0, -0.0, 1e-300, f64::MAX, 44.1, 44.1f64.next_up()];
        for (k, roi) in r.acquisition.rois.iter_mut().enumerate() {
            for (i, v) in roi.luma.iter_mut().enumerate() {
                *v = match (i + k) % 3 {
                    0 => (i % (RecentValues::CAPACITY + 3)) as f64 * 0.1,
                    1 => edge[i % edge.len()],
                    _ => (i as f64).sqrt(),
                };
            }
        }
        assert_eq!(trace_csv(r), plain_csv(r));
    }
}
