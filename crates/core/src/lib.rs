//! The results model of ledflicker and the stages below it under one
//! name. [`model`] is every struct of results.json and
//! [`model::assemble`], which turns a run's case results into it; the
//! report renders this model. [`outdir`] keeps report directories: the
//! new generation staged beside the old, swapped in atomically.
//!
//! The stages are crates of their own, from the bottom up, re-exported
//! here under their module names: `ledflicker-physics` ([`physics`]),
//! `ledflicker-plan` ([`plan`], [`trace`], [`util`]), `ledflicker-metrics`
//! ([`metrics`]), `ledflicker-acquisition` ([`backend`], [`capture`],
//! [`runner`], ...) and `ledflicker-analysis` ([`analysis`],
//! [`calibrate`], [`advise`]). Each imports only the ones below it, which
//! Cargo enforces; tests/architecture.rs checks the layers inside a crate.
#![warn(missing_docs)]

pub use ledflicker_acquisition::{
    backend, capture, error, inputs, interrupt, render, runner, timings,
};
pub use ledflicker_analysis::{advise, analysis, calibrate};
pub use ledflicker_metrics::metrics;
pub use ledflicker_physics as physics;
pub use ledflicker_plan::{plan, trace, util};

pub mod model;
pub mod outdir;
