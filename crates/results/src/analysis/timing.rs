//! Frame timing of a trace, from the frames' own times.

use serde::{Deserialize, Serialize};

use ledflicker_plan::trace::Ratio;

/// Frame timing of a trace (module docs give the rule).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameTiming {
    /// Start of each frame as the analyses use it, seconds: the slot times
    /// `a + P k_i` when `slot_times`, else the times as measured.
    #[serde(skip)]
    pub times_s: Vec<f64>,
    /// Frame rate `1 / P`, frames/s: the stated rate when
    /// `stated_rate_used`, else the fit's.
    pub fps: f64,
    /// One-sigma uncertainty of the fitted rate, frames/s (>= 0).
    pub fps_uncertainty: f64,
    /// Resolution of the frame times (the quantum `q` they are whole
    /// multiples of), seconds; `None` when finer than every candidate.
    pub resolution_s: Option<f64>,
    /// The rate the container states, frames/s, if any.
    pub stated_fps: Option<Ratio>,
    /// The stated rate agrees with the fit and is the rate used.
    pub stated_rate_used: bool,
    /// The times are a constant rate rounded to `resolution_s`, and the
    /// analyses use the slot times.
    pub slot_times: bool,
    /// Largest `|t_i - a - P k_i|` of the final line, seconds.
    pub max_residual_s: f64,
    /// Every frame in its own consecutive slot, every interval within
    /// [`IRREGULAR_INTERVAL`] of the period.
    pub regular: bool,
    /// Empty slots between the first and last frame (dropped frames).
    pub dropped_frames: u64,
    /// First to last frame start plus one frame period, seconds.
    pub capture_s: f64,
}
