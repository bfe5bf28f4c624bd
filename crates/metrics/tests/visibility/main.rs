//! The visibility metrics (PstLM and SVM) against the published reference
//! lamps in the repository's tests/data.

mod pstlm;
mod svm;

use std::path::Path;

/// The repository root, where tests/data is.
pub fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}
