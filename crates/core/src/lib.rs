//! The analysis stage's assembly of the results model, and the stages
//! below it under one name. [`assemble`] turns a run's case results into
//! the results model of `ledflicker-results` ([`model`]: every struct of
//! results.json), running the analyses once per case. [`outdir`] keeps
//! report directories.
//!
//! The stages are crates of their own, from the bottom up, re-exported
//! here under their module names: `ledflicker-physics` ([`physics`]),
//! `ledflicker-plan` ([`plan`], [`trace`], [`util`], [`timings`]),
//! `ledflicker-metrics` ([`metrics`]), `ledflicker-results` ([`model`],
//! [`outdir`]), `ledflicker-acquisition` ([`backend`], [`capture`],
//! [`runner`], ...) and `ledflicker-analysis` ([`analysis`],
//! [`calibrate`], [`advise`]). Each imports only the ones below it, which
//! Cargo enforces; tests/architecture.rs checks the layers inside a crate.
#![warn(missing_docs)]

pub use ledflicker_acquisition::{backend, capture, error, inputs, interrupt, render, runner};
pub use ledflicker_analysis::{advise, analysis, calibrate};
pub use ledflicker_metrics::metrics;
pub use ledflicker_physics as physics;
pub use ledflicker_plan::{plan, timings, trace, util};
pub use ledflicker_results::outdir;

pub mod assemble;

/// The results model ([`ledflicker_results::model`]) with the functions
/// of [`assemble`] that fill it, under the paths the stages above use.
pub mod model {
    pub use crate::assemble::{assemble, assemble_from};
    pub use ledflicker_results::model::*;

    /// [`ledflicker_results::model::conditions`] and how they are stated.
    pub mod conditions {
        pub use crate::assemble::conditions::*;
        pub use ledflicker_results::model::conditions::*;
    }
    /// [`ledflicker_results::model::evidence`] and how it is filled.
    pub mod evidence {
        pub use crate::assemble::frame::worst_phase_info;
        pub use ledflicker_results::model::evidence::*;
    }
    /// [`ledflicker_results::model::method`] and how it is written.
    pub mod method {
        pub use crate::assemble::method::*;
        pub use ledflicker_results::model::method::*;
    }
    /// [`ledflicker_results::model::frame`] and how it is filled.
    pub mod frame {
        pub use crate::assemble::frame::{frame_banding, sample_frame_info};
        pub use ledflicker_results::model::frame::*;
    }
}
