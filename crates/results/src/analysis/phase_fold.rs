//! How well a capture sampled the flicker signal over phase.

use serde::{Deserialize, Serialize};

/// How well a capture sampled the flicker signal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhaseCoverage {
    /// Bins of the phase circle.
    pub bins: usize,
    /// Bins with at least one frame.
    pub covered_bins: usize,
    /// `covered_bins / bins`, 0..=1.
    pub coverage: f64,
    /// Duration of the PWM capture, seconds.
    pub capture_s: f64,
    /// Capture length that covers every bin at this frame rate, seconds;
    /// `None` when no capture up to the longest capture the analysis considers does (at or
    /// very near phase lock).
    pub needed_capture_s: Option<f64>,
    /// Whether the trace reached the exact worst case over phase (within 1 %
    /// of the envelope's range); `None` when the backend cannot compute the
    /// envelope (captured data).
    pub worst_case_seen: Option<bool>,
    /// Set when the capture is too short to have seen its worst case.
    pub warning: Option<String>,
}
