//! Errors that belong to no one stage: a usage or input error any layer may
//! raise (a bad `--shard`, a damaged shard directory, a flag out of range).
//! It sits at the bottom with `util`: it imports nothing of the crate, so
//! `shard`, `calibrate` and the CLI can all use it without importing `cli`.
//! The CLI maps it to exit code 2.

/// A usage or input error (exit code 2) that is not a plan error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// A command or option of a part this build was compiled without (exit
/// code 2): it names the part and how to get a build that has it.
#[derive(Debug, thiserror::Error)]
#[error(
    "{what} needs {part}, which this ledflicker was built without\n    hint: build with the default features (`cargo install --path .`, or `cargo build --release` without `--no-default-features`)"
)]
pub struct NotBuiltIn {
    /// What was asked, e.g. "`sign`".
    pub what: String,
    /// The part missing, e.g. "the sign-off (feature `signoff`)".
    pub part: &'static str,
}
