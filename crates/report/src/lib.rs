//! Reports: the results model (results.json), trace CSVs, charts, the HTML
//! and PDF reports and the JUnit/CSV exports, written atomically into one
//! directory.
//!
//! Last stage of the pipeline. Only this crate touches minijinja and
//! plotters. It renders the results model of `ledflicker-core` and imports
//! nothing else of the pipeline but the leaf helpers (tests/architecture.rs
//! keeps that true; the tests reach further).
#![warn(missing_docs)]

use ledflicker_core::{model, outdir, timings, util};

pub mod charts;
pub mod comparison;
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
pub mod terminal;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::model::{CaseResult, Detail, InputFile, ReportMeta, Results, TRACE_COLUMNS};
use crate::util::write_atomic;

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
/// ([`TRACE_COLUMNS`], then the ROIs). Written by hand, not with the `csv`
/// crate: its writer costs 50 % more instructions here (docs/speed.md),
/// and no field needs quoting (numbers, segment names, ROI names of
/// letters, digits, `-` and `_`).
pub fn trace_csv(result: &CaseResult) -> String {
    let acq = &result.acquisition;
    let mut out = TRACE_COLUMNS.join(",");
    for roi in &acq.rois {
        out.push(',');
        out.push_str(&roi.name);
    }
    out.push('\n');
    // A ROI's luma takes few distinct values (a steady segment repeats
    // one, a locked PWM phase cycles a few), so each column remembers the
    // text of its recent values: the output is the same as `{}` of each.
    let mut recent: Vec<RecentValues> = acq.rois.iter().map(|_| RecentValues::default()).collect();
    out.reserve(acq.frames.len() * (24 + 20 * acq.rois.len()));
    for (i, f) in acq.frames.iter().enumerate() {
        let _ = write!(out, "{},{},{}", f.index, f.time_s, f.segment.as_str());
        for (roi, recent) in acq.rois.iter().zip(&mut recent) {
            out.push(',');
            out.push_str(recent.text(roi.luma[i]));
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

/// Replaces `dir/name` by a directory holding `files` (name -> bytes),
/// built aside and renamed into place, so readers never see half of it.
/// A file whose bytes are those of the same file in `reuse`'s `name/` is
/// hard-linked from there ([`link_if_same`]) instead of written; every
/// other file is created anew, never written through an existing name.
fn replace_dir(
    dir: &Path,
    name: &str,
    files: &[(String, Vec<u8>)],
    reuse: Option<&Path>,
) -> Result<(), ReportError> {
    let staging = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
    }
    std::fs::create_dir_all(&staging).map_err(io_err(&staging))?;
    // The earlier report's folder, opened once, when it is a real folder
    // (a symbolic link may lead to a user's files), and what a file
    // written now would be: our owner, and the mode the umask leaves (read
    // off the folder just made, 0o777 less the umask).
    let earlier = reuse.and_then(|r| EarlierDir::open(r, name));
    let fresh = std::fs::metadata(&staging).map_err(io_err(&staging))?;
    let fresh = FileIdentity {
        uid: std::os::unix::fs::MetadataExt::uid(&fresh),
        mode: std::os::unix::fs::MetadataExt::mode(&fresh) & 0o666,
    };
    for (file, bytes) in files {
        let path = staging.join(file);
        if let Some(earlier) = &earlier
            && link_if_same(earlier, file, bytes, &path, fresh)
        {
            continue;
        }
        write_new(&path, bytes).map_err(io_err(&path))?;
    }
    let target = dir.join(name);
    if target.exists() {
        std::fs::remove_dir_all(&target).map_err(io_err(&target))?;
    }
    std::fs::rename(&staging, &target).map_err(io_err(&target))
}

/// Creates `path` holding `bytes`; a file already there (a name given
/// twice, or a link) is unlinked first, never written through: the last
/// bytes win, and a linked earlier file is left as it was.
fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    let create = || {
        std::fs::File::options()
            .write(true)
            .create_new(true)
            .open(path)
    };
    let mut file = match create() {
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            std::fs::remove_file(path)?;
            create()?
        }
        other => other?,
    };
    file.write_all(bytes)
}

/// Owner and permission bits a file created now gets.
#[derive(Debug, Clone, Copy)]
struct FileIdentity {
    uid: u32,
    mode: u32,
}

/// A folder of the earlier report (`traces/`, `charts/`, `frames/`),
/// opened once as a directory handle: every file is then opened and
/// linked relative to it, never by a path, so a folder swapped for a
/// symbolic link (to a user's own folder, say) while the run goes on
/// cannot make the new report share a user's file.
#[derive(Debug)]
struct EarlierDir(std::os::fd::OwnedFd);

impl EarlierDir {
    /// `report/name` when both are real directories (neither a symbolic
    /// link); `None` otherwise, and then nothing is reused.
    fn open(report: &Path, name: &str) -> Option<EarlierDir> {
        use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
        use std::os::unix::ffi::OsStrExt;
        let flags = libc::O_RDONLY | libc::O_DIRECTORY | libc::O_NOFOLLOW | libc::O_CLOEXEC;
        let open_at = |at: libc::c_int, p: &[u8]| -> Option<OwnedFd> {
            let c = std::ffi::CString::new(p).ok()?;
            // SAFETY: a NUL-terminated path and a descriptor that outlives
            // the call; a non-negative result is a new descriptor we own.
            let fd = unsafe { libc::openat(at, c.as_ptr(), flags) };
            (fd >= 0).then(|| unsafe { OwnedFd::from_raw_fd(fd) })
        };
        if name.contains('/') {
            return None;
        }
        let report = open_at(libc::AT_FDCWD, report.as_os_str().as_bytes())?;
        open_at(report.as_raw_fd(), name.as_bytes()).map(EarlierDir)
    }

    /// `file` of this folder, opened for reading without following a
    /// symbolic link and without waiting on a FIFO or device.
    fn open_file(&self, file: &str) -> Option<std::fs::File> {
        use std::os::fd::{AsRawFd, FromRawFd};
        if file.contains('/') {
            return None;
        }
        let c = std::ffi::CString::new(file).ok()?;
        let flags = libc::O_RDONLY | libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_CLOEXEC;
        // SAFETY: as in `open`.
        let fd = unsafe { libc::openat(self.0.as_raw_fd(), c.as_ptr(), flags) };
        (fd >= 0).then(|| unsafe { std::fs::File::from_raw_fd(fd) })
    }

    /// Hard-links `file` of this folder to `to` (`linkat` without
    /// following a symbolic link).
    fn link(&self, file: &str, to: &Path) -> std::io::Result<()> {
        use std::os::fd::AsRawFd;
        use std::os::unix::ffi::OsStrExt;
        let c = |b: &[u8]| {
            std::ffi::CString::new(b)
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))
        };
        let (from, to) = (c(file.as_bytes())?, c(to.as_os_str().as_bytes())?);
        // SAFETY: two NUL-terminated paths that live across the call.
        let r = unsafe {
            libc::linkat(
                self.0.as_raw_fd(),
                from.as_ptr(),
                libc::AT_FDCWD,
                to.as_ptr(),
                0,
            )
        };
        if r == 0 {
            Ok(())
        } else {
            Err(std::io::Error::last_os_error())
        }
    }
}

/// Hard-links `file` of the earlier report's folder to `path` when it is
/// a file that a write now would make again: a regular file (not a
/// symbolic link), linked nowhere else, of this run's owner and permission
/// bits (`fresh`), holding exactly `bytes`. Returns false, with nothing
/// made, otherwise; the caller then writes the file.
///
/// Rewriting an unchanged file costs a new inode and, when the old report
/// is removed, a freed one; on ext4 without a journal each new inode is
/// searched for past the inodes freed in the last minutes, so a report
/// re-run in place got slower run after run (docs/speed.md, "Re-runs in
/// place link their unchanged files"). A file with other links (a user's
/// hard-linked copy of the report, say) is never shared. The file is read
/// and checked through one handle, and the link is kept only if it names
/// that same file, unchanged, with the one new link: a file replaced or
/// written between the check and the link is not taken. The linked file
/// keeps its modification time (it is the file of the earlier run).
fn link_if_same(
    earlier: &EarlierDir,
    file: &str,
    bytes: &[u8],
    path: &Path,
    fresh: FileIdentity,
) -> bool {
    use std::io::Read as _;
    use std::os::unix::fs::MetadataExt;
    let Some(mut handle) = earlier.open_file(file) else {
        return false;
    };
    let Ok(before) = handle.metadata() else {
        return false;
    };
    let ours = before.file_type().is_file()
        && before.nlink() == 1
        && before.uid() == fresh.uid
        && before.mode() & 0o7777 == fresh.mode
        && before.len() == bytes.len() as u64;
    let mut held = Vec::with_capacity(bytes.len());
    if !ours || handle.read_to_end(&mut held).is_err() || held != bytes {
        return false;
    }
    if earlier.link(file, path).is_err() {
        return false;
    }
    let unchanged = |m: &std::fs::Metadata| {
        m.dev() == before.dev()
            && m.ino() == before.ino()
            && m.nlink() == 2
            && m.len() == before.len()
            && (m.mtime(), m.mtime_nsec()) == (before.mtime(), before.mtime_nsec())
    };
    let kept = std::fs::symlink_metadata(path).is_ok_and(|m| unchanged(&m))
        && handle.metadata().is_ok_and(|m| unchanged(&m));
    if !kept {
        let _ = std::fs::remove_file(path);
    }
    kept
}

/// Replaces frames/ by each case's full-size frame and, beside it, the
/// annotated view the document shows ([`frames::view_path`]); removes it
/// when no case has a frame.
fn write_frames(
    dir: &Path,
    results: &[CaseResult],
    full_frames: Vec<(String, Vec<u8>)>,
    worst_phase: Vec<(String, Vec<u8>)>,
    doc: &document::Document,
    reuse: Option<&Path>,
) -> Result<(), ReportError> {
    let _t = crate::timings::span("report: write frames");
    if full_frames.is_empty() && worst_phase.is_empty() {
        let old = dir.join(document::FRAMES_DIR);
        if old.exists() {
            std::fs::remove_dir_all(&old).map_err(io_err(&old))?;
        }
        return Ok(());
    }
    let mut files = Vec::with_capacity(2 * full_frames.len());
    let mut full = full_frames.into_iter();
    for r in results.iter().filter(|r| r.sample_frame.is_some()) {
        files.extend(full.next());
        if let Some(view) = doc.images.get(&document::frame_image_path(&r.case.id)) {
            files.push((format!("{}-view.png", r.case.id), view.clone()));
        }
    }
    files.extend(worst_phase);
    replace_dir(dir, document::FRAMES_DIR, &files, reuse)
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
    results: &[CaseResult],
    options: &WriteOptions,
    (charts, views): (&document::ChartJobs<'_>, &document::ViewJobs<'_>),
    layout_doc: &document::Document,
) -> Result<Vec<crate::util::Staged>, ReportError> {
    let t = crate::timings::span("report: charts and frame views");
    let (charts, images) = rayon::join(|| charts.draw_all(), || views.draw_all());
    let (charts, images) = (charts?, images?);
    let files: Vec<(String, Vec<u8>)> = charts
        .iter()
        .map(|(path, svg)| {
            let name = path.rsplit('/').next().unwrap_or(path).to_string();
            (name, svg.clone().into_bytes())
        })
        .collect();
    let reuse = options.reuse_from.as_deref();
    replace_dir(dir, document::CHARTS_DIR, &files, reuse)?;
    drop(t);
    let t = crate::timings::span("report: traces and frames");
    let traces: Vec<(String, Vec<u8>)> = {
        use rayon::prelude::*;
        results
            .par_iter()
            .map(|r| (format!("{}.csv", r.case.id), trace_csv(r).into_bytes()))
            .collect()
    };
    let mut traces = traces;
    traces.extend(export::worst_phase_traces(model, results));
    replace_dir(dir, "traces", &traces, reuse)?;

    // PNG encoding is independent per frame: in parallel, in case order.
    let full_frames: Vec<(String, Vec<u8>)> = {
        use rayon::prelude::*;
        results
            .par_iter()
            .filter_map(|r| r.sample_frame.as_ref().map(|f| (r, f)))
            .map(|(r, f)| Ok((format!("{}.png", r.case.id), frames::png_bytes(f)?)))
            .collect::<Result<_, ReportError>>()?
    };
    drop(t);
    let doc = document::Document {
        charts,
        images,
        ..layout_doc.clone()
    };
    let worst_phase = frames::worst_phase_files(model, &doc.images)?;
    write_frames(dir, results, full_frames, worst_phase, &doc, reuse)?;
    let html = {
        let _t = crate::timings::span("report: html");
        html::render_document(&doc)?
    };
    let path = dir.join("report.html");
    write_atomic(&path, html.as_bytes()).map_err(io_err(&path))?;
    let _t = crate::timings::span("report: exports and results.json");
    // The model plus its `report` metadata, in the model's field order.
    let mut full = model.clone();
    full.report = Some(document::report_meta(&full, &options.date, options.detail));
    let files = [
        (export::JUNIT_FILE, export::junit_xml(model)?),
        (export::CSV_FILE, export::summary_csv(model)?),
        ("results.json", serde_json::to_string_pretty(&full)?),
    ];
    files
        .into_iter()
        .map(|(name, text)| {
            let path = dir.join(name);
            crate::util::Staged::write(&path, text.as_bytes()).map_err(io_err(&path))
        })
        .collect()
}

/// Writes results.json, traces/, charts/, report.html, report.pdf,
/// junit.xml and summary.csv into `dir`. Every file is written atomically;
/// traces/ and charts/ are built aside and swapped in whole, and
/// results.json goes last, so its presence means the report is complete.
pub fn write_report(
    dir: &Path,
    model: &Results,
    results: &[CaseResult],
    options: &WriteOptions,
) -> Result<(), ReportError> {
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

    let mut model = model.clone();
    model.report = Some(ReportMeta {
        date: options.date.clone(),
        detail: options.detail.as_str().to_string(),
        inputs: options.inputs.clone(),
        notes: Vec::new(),
        profile: document::profile::meta(&options.profile),
    });
    let model = &model;
    document::profile::write_files(dir, &options.profile)?;
    // Typst starts on a document that names every picture, and draws a
    // chart or frame view when a page shows it; the pictures it does not
    // show (most traces), the HTML, the exports and the results.json text
    // are made beside it.
    let charts = document::ChartJobs::plan(model, results);
    let views = document::ViewJobs::plan(model, results);
    let layout_doc = document::Document::with_pictures(
        model,
        &options.date,
        options.signatories.clone(),
        charts
            .paths()
            .map(|p| (p.to_string(), String::new()))
            .collect(),
        views.paths().map(|p| (p.to_string(), Vec::new())).collect(),
    )
    .with_profile_files(&options.profile);
    // The other renderers run on a thread of their own, not on a rayon
    // worker: their file writes block it, and Typst's parallel page runs
    // need every worker. Their drawing still runs on the pool.
    let depth = crate::timings::depth();
    let (pdf, others) = std::thread::scope(|scope| {
        let beside = scope.spawn(|| {
            crate::timings::at_depth(depth, || {
                write_beside_pdf(dir, model, results, options, (&charts, &views), &layout_doc)
            })
        });
        let pdf = render_pdf(&layout_doc, (&charts, &views), depth);
        let others = beside
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (pdf, others)
    });
    let staged = others?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The trace CSV as `{}` of every value, written plainly.
    fn plain_csv(result: &CaseResult) -> String {
        let acq = &result.acquisition;
        let mut out = String::from("frame,time_s,segment");
        for roi in &acq.rois {
            out.push_str(&format!(",{}", roi.name));
        }
        out.push('\n');
        for (i, f) in acq.frames.iter().enumerate() {
            out.push_str(&format!("{},{},{}", f.index, f.time_s, f.segment.as_str()));
            for roi in &acq.rois {
                out.push_str(&format!(",{}", roi.luma[i]));
            }
            out.push('\n');
        }
        out
    }

    /// A fresh scratch folder for one test.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("ledflicker-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn replace_dir_links_only_unchanged_files_the_earlier_report_alone_holds() {
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        let dir = scratch("link");
        let (earlier, new) = (dir.join("earlier"), dir.join("new"));
        let old = earlier.join("traces");
        std::fs::create_dir_all(&old).unwrap();
        std::fs::create_dir_all(&new).unwrap();
        let put = |path: &Path, bytes: &[u8]| write_new(path, bytes).unwrap();
        for name in [
            "same.csv",
            "changed.csv",
            "longer.csv",
            "shared.csv",
            "private.csv",
        ] {
            put(&old.join(name), b"1,2\n");
        }
        put(&old.join("dup.csv"), b"A\n");
        // A FIFO where a file was: opening it must not wait for a writer.
        let fifo =
            std::ffi::CString::new(old.join("fifo.csv").into_os_string().into_encoded_bytes())
                .unwrap();
        // SAFETY: a NUL-terminated path that lives across the call.
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
        // A user's hard-linked copy, a symbolic link to a user's file of
        // the same bytes, and a file of other permission bits.
        std::fs::hard_link(old.join("shared.csv"), dir.join("users-copy.csv")).unwrap();
        put(&dir.join("users.csv"), b"1,2\n");
        std::os::unix::fs::symlink(dir.join("users.csv"), old.join("link.csv")).unwrap();
        let mode = std::fs::metadata(old.join("private.csv")).unwrap().mode() & 0o7777;
        let other = std::fs::Permissions::from_mode(mode ^ 0o020);
        std::fs::set_permissions(old.join("private.csv"), other).unwrap();
        let ino = |p: &Path| std::fs::symlink_metadata(p).unwrap().ino();
        let before: Vec<(String, u64)> = std::fs::read_dir(&old)
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| {
                (
                    p.file_name().unwrap().to_string_lossy().into_owned(),
                    ino(&p),
                )
            })
            .collect();
        let files: Vec<(String, Vec<u8>)> = [
            ("same.csv", &b"1,2\n"[..]),
            ("changed.csv", b"1,3\n"),
            ("longer.csv", b"1,2,3\n"),
            ("shared.csv", b"1,2\n"),
            ("link.csv", b"1,2\n"),
            ("private.csv", b"1,2\n"),
            ("missing.csv", b"1,2\n"),
            ("fifo.csv", b""),
            // A name given twice: the second must not write through the
            // link the first made.
            ("dup.csv", b"A\n"),
            ("dup.csv", b"B\n"),
        ]
        .iter()
        .map(|(n, b)| (n.to_string(), b.to_vec()))
        .collect();
        replace_dir(&new, "traces", &files, Some(&earlier)).unwrap();

        let got = new.join("traces");
        let linked: Vec<&str> = [
            "same.csv",
            "changed.csv",
            "longer.csv",
            "shared.csv",
            "link.csv",
            "private.csv",
            "dup.csv",
        ]
        .into_iter()
        .filter(|n| ino(&got.join(n)) == ino(&old.join(n)))
        .collect();
        assert_eq!(linked, ["same.csv"]);
        // Every file holds its bytes (the last of a name given twice) ...
        for (name, bytes) in &files[..8] {
            assert_eq!(&std::fs::read(got.join(name)).unwrap(), bytes, "{name}");
        }
        assert_eq!(std::fs::read(got.join("dup.csv")).unwrap(), b"B\n");
        assert!(
            !std::fs::symlink_metadata(got.join("link.csv"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        // ... and the earlier report and the user's files are as they were.
        for (name, ino_before) in &before {
            assert_eq!(ino(&old.join(name)), *ino_before, "{name}");
        }
        assert_eq!(std::fs::read(old.join("dup.csv")).unwrap(), b"A\n");
        assert_eq!(std::fs::read(old.join("changed.csv")).unwrap(), b"1,2\n");
        assert_eq!(std::fs::metadata(dir.join("users.csv")).unwrap().nlink(), 1);
        assert_eq!(
            std::fs::metadata(dir.join("users-copy.csv"))
                .unwrap()
                .nlink(),
            2
        );

        // An earlier traces/ that is a symbolic link (to a user's folder of
        // the same files) is not looked into.
        let (earlier2, new2) = (dir.join("earlier2"), dir.join("new2"));
        std::fs::create_dir_all(&earlier2).unwrap();
        std::fs::create_dir_all(&new2).unwrap();
        std::os::unix::fs::symlink(&old, earlier2.join("traces")).unwrap();
        replace_dir(&new2, "traces", &files[..1], Some(&earlier2)).unwrap();
        assert_ne!(
            ino(&new2.join("traces/same.csv")),
            ino(&old.join("same.csv"))
        );
        assert_eq!(std::fs::metadata(old.join("same.csv")).unwrap().nlink(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_folder_swapped_for_a_link_to_a_users_folder_mid_run_shares_none_of_its_files() {
        use std::os::unix::fs::MetadataExt;
        let dir = scratch("swap");
        let (earlier, users, new) = (dir.join("earlier"), dir.join("users"), dir.join("new"));
        for d in [&earlier.join("traces"), &users, &new] {
            std::fs::create_dir_all(d).unwrap();
        }
        write_new(&earlier.join("traces/case.csv"), b"1,2\n").unwrap();
        write_new(&users.join("case.csv"), b"1,2\n").unwrap();
        let fresh = std::fs::metadata(earlier.join("traces/case.csv")).unwrap();
        let fresh = FileIdentity {
            uid: fresh.uid(),
            mode: fresh.mode() & 0o7777,
        };
        // The folder is opened when the report starts writing it; then,
        // while the run goes on, someone puts a link to the user's folder
        // in its place.
        let handle = EarlierDir::open(&earlier, "traces").unwrap();
        std::fs::rename(earlier.join("traces"), earlier.join("moved")).unwrap();
        std::os::unix::fs::symlink(&users, earlier.join("traces")).unwrap();
        let path = new.join("case.csv");
        link_if_same(&handle, "case.csv", b"1,2\n", &path, fresh);
        let ino = |p: &Path| std::fs::metadata(p).unwrap().ino();
        assert_ne!(ino(&path), ino(&users.join("case.csv")));
        assert_eq!(
            std::fs::metadata(users.join("case.csv")).unwrap().nlink(),
            1
        );
        // A folder that is a link when the report starts is not opened.
        assert!(EarlierDir::open(&earlier, "traces").is_none());
        std::fs::remove_dir_all(&dir).unwrap();
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
