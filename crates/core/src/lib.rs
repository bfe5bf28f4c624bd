//! The pipeline of ledflicker up to its results model: plans, captures,
//! metrics, backends, the runner, the analyses beyond the paper,
//! calibration and [`model::assemble`], which turns a run into the
//! results model that results.json publishes and the report renders.
//!
//! The modules are layered (tests/architecture.rs): each imports only the
//! ones below it, from `util` at the bottom to `model` at the top. The
//! physics is its own crate underneath (`ledflicker-physics`), re-exported
//! here as [`physics`].
#![warn(missing_docs)]

pub use ledflicker_acquisition::{
    backend, capture, error, inputs, interrupt, render, runner, timings,
};
pub use ledflicker_metrics::metrics;
pub use ledflicker_physics as physics;
pub use ledflicker_plan::{plan, trace, util};

pub mod advise;
pub mod analysis;
pub mod calibrate;
pub mod model;
pub mod outdir;
