//! `ledflicker compare --report DIR`: the comparison report's directory,
//! written as a run's report is (crates/core/src/outdir): a new generation
//! beside DIR, swapped in whole, so that a killed `compare` leaves the old
//! comparison or the new one, and a file a user put there survives.

use std::path::Path;

use super::{Failure, UsageError};
use crate::outdir::{DirKind, Generation, classify};
use crate::report::comparison::ComparisonView;

/// The entries a comparison report writes.
const HTML: &str = "comparison.html";
/// See [`HTML`]; a build without the `pdf` feature writes no PDF.
#[cfg(feature = "pdf")]
const PDF: &str = "comparison.pdf";
/// See [`HTML`].
const JUNIT: &str = "junit.xml";

/// Writes `view` (and the JUnit XML `junit`) into `dir`; returns the file
/// names written. A run's report directory (it holds results.json) is
/// refused: the swap would replace that report.
pub(super) fn write(
    dir: &Path,
    view: &ComparisonView,
    junit: &str,
) -> Result<Vec<&'static str>, Failure> {
    if let DirKind::Report { owned, .. } = classify(dir)?
        && owned.contains("results.json")
        && dir.join("results.json").exists()
    {
        return Err(UsageError(format!(
            "`{}` is a run's report directory; a comparison report needs a directory of its own\n    hint: pass e.g. --report {}-compare",
            dir.display(),
            dir.display()
        ))
        .into());
    }
    crate::outdir::check_overwrite(dir, false)?;
    let generation = Generation::begin(dir)?;
    let write = |name: &str, bytes: &[u8]| {
        let path = generation.path().join(name);
        crate::util::write_atomic(&path, bytes)
            .map_err(|e| Failure::Internal(format!("cannot write `{}`: {e}", path.display())))
    };
    let mut written = vec![HTML];
    write(HTML, crate::report::comparison::html(view)?.as_bytes())?;
    #[cfg(feature = "pdf")]
    {
        let (pdf, _pages) = crate::report::comparison::pdf(view)?;
        write(PDF, &pdf)?;
        written.push(PDF);
    }
    write(JUNIT, junit.as_bytes())?;
    written.push(JUNIT);
    if let Some(w) = generation.commit()?.warning() {
        eprintln!("warning: {w}");
    }
    Ok(written)
}
