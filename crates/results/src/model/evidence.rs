//! What results.json says of the evidence behind a worst-phase verdict:
//! the case's trace and darkest frame at the worst PWM phase
//! (the worst-phase analysis of `ledflicker-analysis`).

use serde::{Deserialize, Serialize};

use super::{RenderedFrame, SampleFrameInfo};

/// The case run again at the worst PWM phase of the ROI its verdict rests
/// on: present only for a simulated case (ideal camera) that fails, or is
/// informational, on a worst-phase check it does not meet.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct WorstPhaseInfo {
    /// The ROI whose worst-phase check fails by the widest margin.
    pub roi: String,
    /// That check's metric, e.g. `fdi_2018_worst_phase`.
    pub metric: String,
    /// That check's value as reported; `null` when undefined.
    pub reported: Option<f64>,
    /// Phase of row 0's exposure start in frame `frame`, cycles from a
    /// rising edge, in `[0, 1)`.
    pub phase_cycles: f64,
    /// First PWM rising edge after frame 0 starts that gives this run,
    /// milliseconds (the case ran at the plan's `pwm-delay-ms`).
    pub pwm_delay_ms: f64,
    /// The frame put at the worst phase: the case's darkest PWM frame of
    /// the ROI.
    pub frame: u64,
    /// FDI (Deegan 2018, Eq. 3) of `luma`: its PWM minimum against its OFF
    /// mean; `null` when undefined or unbounded.
    pub fdi_2018: Option<f64>,
    /// Percent Flicker of `luma`'s PWM segment; `null` when undefined.
    pub percent_flicker: Option<f64>,
    /// The trace at the worst phase as CSV, relative to the report
    /// directory: the ROI as run and at the worst phase, frame by frame.
    pub trace: String,
    /// The ROI's mean luma per frame at the worst phase (DN), frame for
    /// frame with the case's trace; in the CSV `trace`, not results.json.
    #[serde(skip)]
    pub luma: Vec<f64>,
    /// The frame `frame` at the worst phase, as written next to the report.
    pub sample_frame: Option<SampleFrameInfo>,
    /// The frame itself, for the report to draw; not part of results.json.
    #[serde(skip)]
    pub rendered: Option<RenderedFrame>,
}

/// Relative path of a case's trace CSV at the worst phase.
pub fn worst_phase_trace_path(case_id: &str) -> String {
    format!("traces/{case_id}-worst-phase.csv")
}

/// Relative path of a case's frame at the worst phase.
pub fn worst_phase_frame_path(case_id: &str) -> String {
    format!("frames/{case_id}-worst-phase.png")
}

/// Relative path of the annotated view of a case's frame at the worst
/// phase.
pub fn worst_phase_view_path(case_id: &str) -> String {
    format!("frames/{case_id}-worst-phase-view.png")
}
