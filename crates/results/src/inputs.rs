//! The inputs of a run as results.json lists them.

/// One input file of the run, with its hash.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct InputFile {
    /// What it is, e.g. "plan".
    pub role: String,
    /// Path as given on the command line.
    pub path: String,
    /// SHA-256 of its bytes, lowercase hex.
    pub sha256: String,
    /// Size in bytes.
    pub size: u64,
}
