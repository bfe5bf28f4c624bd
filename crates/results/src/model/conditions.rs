//! The conditions a report states, each from what was run: the segments
//! of the light sequence actually used (simulated, given in the plan or
//! detected in each capture), the frame rate (the simulated camera's, or
//! fitted to each capture's frame times), exposure, light levels, PWM
//! grid, the PWM clock against the camera clock, the scene and the ROIs.
//!
//! Part of the results model: results.json holds them as `conditions`,
//! structured and as the sentences the summary and the method print
//! (`stated`, `setup`), so HTML and PDF state the same conditions and a
//! test can check each sentence's figures against the per-case data.

use serde::{Deserialize, Serialize};

use super::{RoiKind, Segment};
use crate::util::fixed;

/// Everything the report states about the conditions of the run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Conditions {
    /// Each segment of the sequence, over the cases that have it, in the
    /// order ON, OFF, PWM.
    pub sequence: Vec<SegmentSpan>,
    /// Captured or rig cases whose segments the plan gives.
    pub segments_given: usize,
    /// Captured or rig cases whose segments were detected from the luma.
    pub segments_detected: usize,
    /// Frame rate, frames/s: the simulated camera's, or the range of the
    /// rates fitted to the cases' frame times; `null` when no case has one.
    pub frame_rate_fps: Option<Span>,
    /// Cases without a frame rate of their own (too few frames to fit one).
    pub frame_rate_unknown_cases: usize,
    /// Exposure of each capture of a frame, milliseconds (one for a
    /// single-exposure camera); empty when ledflicker does not know it (a
    /// capture or a rig).
    pub exposure_ms: Vec<f64>,
    /// Name of each capture of `exposure_ms` (e.g. "L", "M", "S"); empty
    /// for a single-exposure camera.
    pub exposure_captures: Vec<String>,
    /// The exposure is the starting point of auto exposure, not fixed.
    pub auto_exposure: bool,
    /// Light levels of the cases, lux, rising.
    pub light_lux: Vec<f64>,
    /// Cases whose light level is not stated (a capture without conditions).
    pub light_unknown_cases: usize,
    /// PWM frequencies of the cases, Hz, rising.
    pub frequencies_hz: Vec<f64>,
    /// Duty cycles of the cases, 0..1, rising.
    pub duty_cycles: Vec<f64>,
    /// The simulated PWM clock; `null` unless the simulator made the frames.
    pub pwm_clock: Option<PwmClock>,
    /// The plan's `pwm-clock-offset-ppm` when the simulator did not make
    /// the frames (so it was not applied); 0 otherwise.
    pub unapplied_ppm: f64,
    /// The simulated scene; `null` unless the simulator made the frames.
    pub scene: Option<SceneSetup>,
    /// The plan's ROIs, in plan order.
    pub rois: Vec<RoiSetup>,
    /// The conditions as the executive summary states them, in order.
    pub stated: Vec<Stated>,
    /// The set-up as the method section states it (light source, scene,
    /// camera), so that another lab can repeat the test.
    pub setup: Vec<Stated>,
}

/// A closed range of values; `min == max` for a single value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl Span {
    /// The range of `values`; `None` when empty.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Span> {
        values.into_iter().fold(None, |s, v| {
            Some(s.map_or(Span { min: v, max: v }, |s: Span| Span {
                min: s.min.min(v),
                max: s.max.max(v),
            }))
        })
    }

    /// `a` or `a-b` with `digits` decimals, and the unit.
    pub fn text(&self, digits: usize, unit: &str) -> String {
        let (a, b) = (fixed(self.min, digits), fixed(self.max, digits));
        if a == b {
            format!("{a} {unit}")
        } else {
            format!("{a}-{b} {unit}")
        }
    }
}

/// One segment of the sequence over the cases that have it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentSpan {
    /// on, off or pwm.
    pub segment: Segment,
    /// How many cases have it.
    pub cases: usize,
    /// Its frames `[first, end)` when every case that has it has the same;
    /// `null` when they differ.
    pub frames: Option<(u64, u64)>,
    /// Its first frame, over the cases.
    pub first_frame: Span,
    /// Frames in it, over the cases.
    pub frame_count: Span,
    /// Start, seconds from the first frame, over the cases.
    pub start_s: Span,
    /// Duration, seconds, over the cases.
    pub duration_s: Span,
}

/// The simulated PWM clock against the camera clock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PwmClock {
    /// The PWM clock's error, parts per million (`pwm-clock-offset-ppm`):
    /// the LED runs at `f (1 + ppm 1e-6)`.
    pub offset_ppm: f64,
    /// First PWM rising edge after frame 0 starts, milliseconds.
    pub delay_ms: f64,
    /// The cases' frequencies that are whole multiples of the frame rate
    /// (phase locked at 0 ppm), Hz, rising.
    pub multiples_hz: Vec<f64>,
    /// For each of `multiples_hz`, the time the offset takes to sweep the
    /// PWM phase once round, `1 / (f ppm 1e-6)`, seconds; `null` when that
    /// exceeds the largest number results.json holds (an offset near
    /// 1e-300 ppm); empty at 0 ppm (the phase never drifts).
    pub drift_period_s: Vec<Option<f64>>,
}

/// The simulated scene (`[scene]`, `[light]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneSetup {
    /// Luminance of the LED while ON, cd/m^2.
    pub led_luminance_cd_m2: f64,
    /// Share of an LED ROI the LED covers, 0..1.
    pub led_fill: f64,
    /// Reflectance of the grey background, 0..1.
    pub background_reflectance: f64,
    /// Per light level, the background's luminance `rho E / pi`, cd/m^2,
    /// as `(lux, cd/m^2)`.
    pub background_luminance_cd_m2: Vec<(f64, f64)>,
}

/// One ROI as the plan places it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoiSetup {
    /// Name.
    pub name: String,
    /// led or background.
    pub kind: RoiKind,
    /// Left column, 0-based, pixels.
    pub x_px: u32,
    /// Top row, 0-based, pixels.
    pub y_px: u32,
    /// Width, pixels.
    pub width_px: u32,
    /// Height, rows.
    pub height_px: u32,
    /// The frames it is read from: every case's (the plan's ROIs apply to
    /// every capture and every simulated frame).
    pub applies_to: String,
}

/// One stated condition: a label and its sentence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stated {
    /// Short label, e.g. "Sequence".
    pub label: String,
    /// What the report says.
    pub text: String,
}
