//! Backends: where a case's frames come from.
//!
//! The runner hands each [`TestCase`] to a [`Backend`] and gets back an
//! [`Acquisition`]: per-frame timing and segment labels, and the mean luma of
//! every ROI in every frame. The built-in simulator is [`sim::Simulator`];
//! captured data and lab rigs plug in through the same trait, and
//! [`for_plan`] builds the one a plan names.

pub mod captured;
pub mod command;
pub mod factory;
pub mod rig;
pub mod segments;
pub mod sim;

pub use factory::{PlanBackend, SetupError, for_plan};

use crate::metrics::flicker::Segment;
use crate::plan::TestCase;

/// One frame of an acquisition.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameInfo {
    /// Frame number from 0.
    pub index: u64,
    /// Start of row 0's exposure, seconds from the start of frame 0.
    pub time_s: f64,
    /// ON, OFF or PWM.
    pub segment: Segment,
}

/// The luma trace of one ROI.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoiTrace {
    /// ROI name, as in the plan.
    pub name: String,
    /// Mean ROI luma of each frame, DN; same length as the frames.
    pub luma: Vec<f64>,
    /// Lowest and highest PWM-segment luma over every PWM phase, when the
    /// backend can compute it exactly (the simulator can, a capture cannot).
    pub phase_envelope: Option<(f64, f64)>,
}

/// Frames and ROI traces for one case.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Acquisition {
    /// Every frame, in order.
    pub frames: Vec<FrameInfo>,
    /// One trace per plan ROI, in plan order.
    pub rois: Vec<RoiTrace>,
    /// Luma at or above which an ROI is flagged saturated, DN.
    pub saturation_dn: f64,
}

/// A backend failed to acquire a case.
#[derive(Debug, thiserror::Error)]
#[error("backend `{backend}` failed on case `{case}`: {message}")]
pub struct BackendError {
    /// Backend id.
    pub backend: String,
    /// Case id.
    pub case: String,
    /// What went wrong.
    pub message: String,
}

/// A whole frame, as output luma, row-major.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderedFrame {
    /// Frame number.
    pub index: u64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Luma of each pixel, DN, `width * height` values.
    pub luma: Vec<f64>,
    /// Output full scale, DN (255 for 8-bit output).
    pub full_scale_dn: f64,
}

/// A source of frames for test cases: a camera simulator or captured data.
pub trait Backend: Send + Sync {
    /// Stable id used in reports, e.g. "sim-ideal".
    fn id(&self) -> &str;
    /// Frames and ROI traces for `case`.
    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError>;
    /// A full picture of frame `frame` of `case`, for the report, when the
    /// backend can make one. Traces never need it: only asked for pictures.
    fn render_frame(
        &self,
        _case: &TestCase,
        _frame: u64,
    ) -> Option<Result<RenderedFrame, BackendError>> {
        None
    }
}
