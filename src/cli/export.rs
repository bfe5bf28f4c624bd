//! `ledflicker export DIR --case ID`: one case's trace CSV and frames,
//! written from the report directory's case store. A large run's report
//! writes them for the cases it lists only (docs/report.md, "Large
//! runs"); the files this writes are byte for byte those a `--detail full`
//! run writes.

use std::path::{Path, PathBuf};

use clap::Args;

use super::output::outln;
use super::{ExitCode, Failure};
use crate::error::UsageError;
use crate::model::frame::{RoiBox, Stretch};
use crate::model::{CaseResult, CaseSource, Results};
use crate::store::{self, StoredCases};

#[derive(Args, Debug)]
pub(super) struct ExportArgs {
    /// A report directory that `ledflicker plan` or `merge` wrote (it
    /// holds cases.sqlite).
    dir: PathBuf,
    /// The case, by its id in results.json and summary.csv (e.g.
    /// `2000lux-90hz-50pct`).
    #[arg(long = "case", value_name = "ID")]
    case: String,
    /// Where traces/ and frames/ go; created when missing. Default: DIR.
    #[arg(long, value_name = "DIR2")]
    out: Option<PathBuf>,
}

pub(super) fn export(a: ExportArgs) -> Result<ExitCode, Failure> {
    let path = a.dir.join(store::FILE);
    if !path.is_file() {
        return Err(UsageError(format!(
            "`{}` holds no case store ({})\n    hint: give a report directory written by `ledflicker plan` or `ledflicker merge`",
            a.dir.display(),
            store::FILE
        ))
        .into());
    }
    let stored = StoredCases::open(&path)?;
    let ids = stored.ids()?;
    let Some(idx) = ids.iter().position(|id| *id == a.case) else {
        return Err(UsageError(unknown_case(&a.case, &ids, &path)).into());
    };
    let unreadable = |why: String| {
        UsageError(format!(
            "cannot read case `{}` from `{}`: {why}",
            a.case,
            path.display()
        ))
    };
    let result = stored
        .read(idx..idx + 1)
        .map_err(|e| unreadable(e.to_string()))?
        .pop()
        .ok_or_else(|| unreadable("missing".to_string()))?;
    let out = a.out.as_deref().unwrap_or(&a.dir);
    let rois = frame_rois(&a.dir, &a.case)?;
    for written in write_case(out, &result, rois.as_deref())? {
        outln!("{}", written.display())?;
    }
    Ok(ExitCode::Pass)
}

/// The error for a case id the store does not hold, with the nearest id.
fn unknown_case(case: &str, ids: &[String], path: &Path) -> String {
    let nearest = ids
        .iter()
        .map(|id| (strsim::levenshtein(case, id), id))
        .min_by_key(|(d, _)| *d)
        .filter(|(d, _)| *d <= case.len().max(3) / 3)
        .map_or(String::new(), |(_, id)| format!("; did you mean `{id}`?"));
    format!(
        "no case `{case}` in `{}` ({} cases){nearest}\n    hint: summary.csv lists every case id (its first column)",
        path.display(),
        ids.len()
    )
}

/// The ROIs as the report draws them on a sample frame: those of any case
/// results.json holds with its frame (every case of a plan has the
/// plan's ROIs), preferring the case's own. `None` when no case has a
/// frame.
fn frame_rois(dir: &Path, case: &str) -> Result<Option<Vec<RoiBox>>, Failure> {
    let path = dir.join("results.json");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        UsageError(format!(
            "cannot read `{}`: {e}\n    hint: the report directory's results.json gives the ROIs its frames are drawn with",
            path.display()
        ))
    })?;
    let results: Results = crate::model::read_results(&text)
        .map_err(|m| UsageError(format!("`{}`: {m}", path.display())))?;
    let own = results
        .cases
        .iter()
        .find(|c| c.id == case)
        .and_then(|c| c.sample_frame.clone());
    let any = || results.cases.iter().find_map(|c| c.sample_frame.clone());
    Ok(own.or_else(any).map(|f| f.rois))
}

/// Writes `r`'s trace CSV into `out/traces/` and its sample frame and
/// view into `out/frames/`, as the report writes them; the paths written.
fn write_case(
    out: &Path,
    r: &CaseResult,
    rois: Option<&[RoiBox]>,
) -> Result<Vec<PathBuf>, Failure> {
    let mut files = vec![(
        Path::new("traces").join(format!("{}.csv", r.case.id)),
        crate::report::trace_csv(r).into_bytes(),
    )];
    if let (Some(frame), Some(rois)) = (&r.sample_frame, rois) {
        let frames = Path::new(crate::report::document::FRAMES_DIR);
        files.push((
            frames.join(format!("{}.png", r.case.id)),
            crate::report::frames::png_bytes(frame)?,
        ));
        let view = crate::report::frames::view_png(frame, rois, &Stretch::of_frame(frame))?;
        files.push((frames.join(format!("{}-view.png", r.case.id)), view));
    }
    let mut written = Vec::new();
    for (name, bytes) in files {
        let path = out.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| UsageError(format!("cannot create `{}`: {e}", parent.display())))?;
        }
        crate::util::write_atomic(&path, &bytes)
            .map_err(|e| UsageError(format!("cannot write `{}`: {e}", path.display())))?;
        written.push(path);
    }
    Ok(written)
}
