//! Physics of the light source and the shutter: the exact closed-form
//! integral of a PWM waveform over each row's exposure.
//!
//! Sits under the backends: `backend::sim` asks this module what fraction of
//! an exposure the LED was ON, and never integrates time-stepped. Nothing in
//! here knows about plans or reports.

pub mod pwm;
pub mod shutter;

pub use pwm::PwmDrive;
pub use shutter::{Shutter, ShutterModel};
