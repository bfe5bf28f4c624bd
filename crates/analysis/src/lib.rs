//! Analyses of a run beyond the metrics: apparent frequency, hazard class,
//! IEEE 1789 and the IES Flicker Index of the drive, phase coverage,
//! banding, fine maps, the worst phase, ROI detection and set-up, the
//! light-signal analysis of scope records (`light`), calibration of line
//! time, bands and camera profiles from real frames (`linetime`, `bands`,
//! `calibrate`), and the advice of the shortest safe exposure (`advise`).
#![warn(missing_docs)]

pub mod advise;
pub mod analysis;
pub mod calibrate;
