//! Physics of the light source and the camera: the exact closed-form
//! integral of a PWM waveform over each row's exposure, the sensor, HDR
//! captures and merge, the tone curve and auto exposure.
//!
//! Sits under the backends: `backend::sim` asks this module what each ROI
//! row of each capture collected, and never integrates time-stepped.
//! Nothing in here knows about plans or reports.

#![warn(missing_docs)]

pub mod ae;
pub mod batch;
pub mod envelope;
pub mod extremes;
pub mod hdr;
pub mod pwm;
pub mod remainder;
pub mod sensor;
pub mod shutter;

pub use pwm::PwmDrive;
pub use shutter::{Shutter, ShutterModel};
