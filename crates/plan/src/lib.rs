//! Test plans: the TOML format, validation with every error located by
//! file, line and key, the limits a plan is estimated to run within, and
//! its expansion into test cases; with the trace types every later stage
//! shares (segments, acquisitions, frames) and the small utilities below
//! them all (atomic writes, checked input files, number formatting).
#![warn(missing_docs)]

pub mod image_io;
pub mod plan;
pub mod timings;
pub mod trace;
pub mod util;
