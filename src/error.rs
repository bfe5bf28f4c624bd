//! Errors that belong to no one stage: a usage or input error any layer may
//! raise (a bad `--shard`, a damaged shard directory, a flag out of range).
//! It sits at the bottom with `util`: it imports nothing of the crate, so
//! `shard`, `calibrate` and the CLI can all use it without importing `cli`.
//! The CLI maps it to exit code 2.

/// A usage or input error (exit code 2) that is not a plan error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);
