//! Flicker metrics on per-frame ROI luma traces and the verdicts on them:
//! Deegan 2018 FDI and Percent Flicker, the IEEE P2020 KPIs (FMI, FDI,
//! MMP), chromaticity, the visibility of displayed flicker, and the checks
//! of a case against its plan's limits.
#![warn(missing_docs)]

pub mod fft;
pub mod metrics;
