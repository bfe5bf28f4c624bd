//! What was really done, in words: the acquisition of each case and of the
//! whole run per backend, the verdict basis actually used, and where the run
//! departs from the method of Deegan 2018.
//!
//! Part of the results model. The text goes into results.json (`method`,
//! each case's `acquisition` and the report's `notes`), so HTML and PDF, and
//! a report re-rendered at signing, all say the same.

use serde::{Deserialize, Serialize};

/// How the run was done, for the report's method section.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Method {
    /// "simulator", "captured" or "command".
    pub backend: super::BackendName,
    /// Where the frames came from, one paragraph.
    pub acquisition: String,
    /// The verdict basis actually used, one sentence.
    pub verdict_basis: String,
    /// The limits in words: the global ones, then one line per light level
    /// with its own.
    pub limits: Vec<String>,
}
