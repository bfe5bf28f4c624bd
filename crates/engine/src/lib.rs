//! The run of a ledflicker plan as a library, between the stages below
//! (`ledflicker-core`: plan to results model; `ledflicker-report`: the
//! report files; `ledflicker-signoff`) and the command line above:
//!
//! - [`store`]: the case store, every case result of a run in SQLite, from
//!   which an interrupted run resumes;
//! - [`pipeline`]: from a run's case results to a finished, signed report
//!   directory and its outcome, the one path of `plan` and `merge`;
//! - [`shard`]: a plan split into shards that run apart and merge again,
//!   each shard's data judged again when merged;
//! - [`campaign`]: the results database across runs (`history`,
//!   `compare`, `trend`, `import`), on SQLite or PostgreSQL;
//! - [`bench`]: the workloads of `ledflicker bench`.
//!
//! It prints nothing: progress reaches callbacks, failures are typed
//! errors, so that the command line and other front ends share it.
#![warn(missing_docs)]

pub mod bench;
pub mod campaign;
pub mod pipeline;
pub mod shard;
pub mod store;
