//! The stages run as a library, without the command line or the report
//! (and so without building the PDF engine): the simulator's physics,
//! its camera profiles, colour captures and the beyond-the-paper analyses.
//! One binary with a module per area, as tests/integration is.

mod beyond;
mod camera_model;
mod colour_dies;
mod physics;

use std::path::{Path, PathBuf};

/// The repository root, where test-plans/ and reference-data/ are.
pub fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
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
