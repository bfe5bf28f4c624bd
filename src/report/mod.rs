//! Reports: the results model (results.json), trace CSVs and the HTML
//! report, written atomically into one directory.
//!
//! Last stage of the pipeline. Only this module touches minijinja and
//! plotters.

pub mod charts;
pub mod frames;
pub mod html;
pub mod model;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::runner::CaseResult;
use crate::util::write_atomic;

pub use model::{Results, build};

/// A file in a report directory that marks it as signed; such a directory
/// is never overwritten without `--force`.
pub const SIGNOFF_FILE: &str = "signoff.json";

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
    /// The directory holds a signed report.
    #[error(
        "`{dir}` holds a signed report ({SIGNOFF_FILE}); refusing to overwrite it\n    hint: choose another --out directory, or pass --force to replace it"
    )]
    Signed {
        /// Report directory.
        dir: PathBuf,
    },
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
}

/// One case's trace as CSV: `frame,time_s,segment,<one luma column per ROI>`.
pub fn trace_csv(result: &CaseResult) -> String {
    let acq = &result.acquisition;
    let mut out = String::from("frame,time_s,segment");
    for roi in &acq.rois {
        out.push(',');
        out.push_str(&roi.name);
    }
    out.push('\n');
    for (i, f) in acq.frames.iter().enumerate() {
        let _ = write!(out, "{},{},{}", f.index, f.time_s, f.segment.as_str());
        for roi in &acq.rois {
            let _ = write!(out, ",{}", roi.luma[i]);
        }
        out.push('\n');
    }
    out
}

/// Fails if `dir` holds a signed report and `force` is off.
pub fn check_overwrite(dir: &Path, force: bool) -> Result<(), ReportError> {
    if !force && dir.join(SIGNOFF_FILE).exists() {
        return Err(ReportError::Signed {
            dir: dir.to_path_buf(),
        });
    }
    Ok(())
}

/// Writes results.json, traces/ and report.html into `dir`. Every file is
/// written atomically; traces/ is built aside and swapped in whole, and
/// results.json goes last, so its presence means the report is complete.
pub fn write_report(
    dir: &Path,
    model: &Results,
    results: &[CaseResult],
    options: &WriteOptions,
) -> Result<(), ReportError> {
    check_overwrite(dir, options.force)?;
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    if options.force {
        let signoff = dir.join(SIGNOFF_FILE);
        if signoff.exists() {
            std::fs::remove_file(&signoff).map_err(io_err(&signoff))?;
        }
    }

    let staging = dir.join(format!(".traces.tmp-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
    }
    std::fs::create_dir_all(&staging).map_err(io_err(&staging))?;
    for r in results {
        let path = staging.join(format!("{}.csv", r.case.id));
        std::fs::write(&path, trace_csv(r)).map_err(io_err(&path))?;
    }
    let frames_dir = dir.join("frames");
    let frame_staging = dir.join(format!(".frames.tmp-{}", std::process::id()));
    if frame_staging.exists() {
        std::fs::remove_dir_all(&frame_staging).map_err(io_err(&frame_staging))?;
    }
    if results.iter().any(|r| r.sample_frame.is_some()) {
        std::fs::create_dir_all(&frame_staging).map_err(io_err(&frame_staging))?;
        for r in results {
            if let Some(frame) = &r.sample_frame {
                let path = frame_staging.join(format!("{}.png", r.case.id));
                std::fs::write(&path, frames::png_bytes(frame)?).map_err(io_err(&path))?;
            }
        }
    }
    if frames_dir.exists() {
        std::fs::remove_dir_all(&frames_dir).map_err(io_err(&frames_dir))?;
    }
    if frame_staging.exists() {
        std::fs::rename(&frame_staging, &frames_dir).map_err(io_err(&frames_dir))?;
    }

    let traces = dir.join("traces");
    if traces.exists() {
        std::fs::remove_dir_all(&traces).map_err(io_err(&traces))?;
    }
    std::fs::rename(&staging, &traces).map_err(io_err(&traces))?;

    let html = html::render(model, results, &options.date)?;
    let path = dir.join("report.html");
    write_atomic(&path, html.as_bytes()).map_err(io_err(&path))?;

    let json = serde_json::to_string_pretty(model)?;
    let path = dir.join("results.json");
    write_atomic(&path, json.as_bytes()).map_err(io_err(&path))?;
    Ok(())
}
