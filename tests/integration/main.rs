//! Integration tests: one binary (ripgrep style) with a module per area.

mod banding;
mod beyond;
mod calibrate;
mod captured;
mod cli;
mod detect;
mod exact;
mod mutate;
mod physics;
mod plans;
mod recgen;
mod report;
mod results;
mod robust;
mod signoff;
mod verdicts;

use std::path::{Path, PathBuf};

/// The repository root.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh, empty scratch directory under target/.
pub fn scratch(name: &str) -> PathBuf {
    let dir = root()
        .join("target")
        .join("test-scratch")
        .join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
