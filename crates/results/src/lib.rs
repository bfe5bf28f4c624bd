//! The results contract of ledflicker: what a run produces and what the
//! report, `verify`, `compare` and every other reader take in. [`model`]
//! is every struct of results.json; [`cases`] is the record of one
//! finished case as the runner makes it and the case store and shards
//! keep it; [`analysis`] and [`advise`] are the analyses' findings as
//! results.json carries them; [`outdir`] keeps report directories, the
//! new generation staged beside the old and swapped in atomically.
//!
//! It holds types and the rules that read them (listings, planes, limit
//! tables), never a computation of the run: the simulator, the capture
//! readers and the analyses live in the stage crates that fill these types,
//! so a reader that depends on this crate alone (the report) cannot reach
//! them. Its types restate the plan's and the metrics' own, which it takes
//! from `ledflicker-plan` and `ledflicker-metrics`.
#![warn(missing_docs)]

pub mod advise;
pub mod analysis;
pub mod cases;
pub mod comparison;
pub mod exit;
pub mod inputs;
pub mod model;
pub mod outdir;

use ledflicker_metrics::metrics;
use ledflicker_plan::{plan, trace, util};
