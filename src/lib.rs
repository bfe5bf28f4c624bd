//! ledflicker: a conformance test suite and report generator for LED flicker
//! in automotive cameras.
//!
//! The pipeline runs one way:
//!
//! ```text
//! TOML plan --plan::load--> Plan --expand_cases--> Vec<TestCase>
//!   --runner::run (rayon) + dyn Backend--> Vec<CaseResult>
//!   --crate::model::assemble--> Results (results.json) --report::{html,pdf,export}-->
//!   report.html, report.pdf, junit.xml, summary.csv --signoff--> signed report.pdf,
//!   manifest.txt, signoff.p7s
//! ```
//!
//! - [`plan`]: the TOML format, validation with every error located by line;
//! - [`physics`]: the exact closed-form PWM integral, global and rolling shutters;
//! - [`backend`]: where frames come from (the simulator's ideal camera);
//! - [`metrics`]: Deegan 2018 FDI and Percent Flicker, verdicts;
//! - [`runner`]: cases in parallel, deterministic whatever the thread count;
//! - [`report`]: results.json, trace CSVs and the HTML report;
//! - [`analysis`]: apparent frequency, hazard class, IEEE 1789, phase
//!   coverage, banding and fine maps (beyond the paper);
//! - [`advise`]: the shortest exposure that never loses a PWM LED.
//! - [`calibrate`]: line time, band frequency and a fitted camera profile
//!   from real banding frames (`linetime`, `bands`, `calibrate`).
//! - [`report`]: results.json, trace CSVs, charts, the HTML and PDF reports,
//!   JUnit/CSV exports and golden-file comparison;
//! - [`inputs`]: the evidence (inputs) of a run, hashed for the report and
//!   the sign-off;
//! - [`signoff`]: X.509 certificates, PDF and CMS signatures of a report
//!   directory, and their verification.
//! - [`pipeline`]: from a run's case results to a finished, signed report
//!   directory and its outcome, the one path of `plan` and `merge`.
//! - [`campaign`]: the results database across runs (`history`, `compare`).
//!
//! The stages are crates of this workspace, re-exported here under their
//! module names: `ledflicker-physics` ([`physics`]), `ledflicker-core`
//! (plan up to the results model), `ledflicker-report` ([`report`]) and
//! `ledflicker-signoff` ([`signoff`]). This crate adds sharding, the
//! benchmarks and the command line on top.
#![warn(missing_docs)]

pub use ledflicker_core::{
    advise, analysis, backend, calibrate, capture, error, inputs, interrupt, metrics, model,
    outdir, physics, plan, render, runner, timings, trace, util,
};
pub use ledflicker_report as report;
pub use ledflicker_results::exit;
#[cfg(feature = "signoff")]
pub use ledflicker_signoff as signoff;

pub use ledflicker_engine::{bench, campaign, pipeline, shard, store};

pub mod cli;
