//! Acquisition: where a case's frames come from and how they become ROI
//! traces. The backends (the camera simulator, captured images and
//! videos, a lab rig driven by a command or an instrument), the capture
//! readers, the run's inputs and their hashes, and the runner that
//! acquires every case in parallel and measures it, deterministic
//! whatever the thread count.
#![warn(missing_docs)]

pub mod backend;
pub mod capture;
pub mod error;
pub mod inputs;
pub mod interrupt;
pub mod render;
pub mod runner;
pub use ledflicker_plan::timings;
