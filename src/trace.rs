//! Frames, traces and segments: what a backend hands the runner, and what
//! metrics, analyses and the report read. The lowest data module of the
//! pipeline (docs/architecture.md): it imports nothing of the crate but
//! [`crate::util`].

use serde::{Deserialize, Serialize};

use crate::util::{Word, static_str, static_str_opt};

/// Which part of the light sequence a frame belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Segment {
    /// Steady ON, luminance matched to the PWM average.
    On,
    /// LED off: the reference level.
    Off,
    /// PWM drive.
    Pwm,
}

impl Segment {
    /// Lowercase name used in trace CSVs.
    pub fn as_str(self) -> &'static str {
        match self {
            Segment::On => "on",
            Segment::Off => "off",
            Segment::Pwm => "pwm",
        }
    }
}

/// One frame of an acquisition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameInfo {
    /// Frame number from 0.
    pub index: u64,
    /// Start of row 0's exposure, seconds from the start of frame 0.
    pub time_s: f64,
    /// ON, OFF or PWM.
    pub segment: Segment,
}

/// The luma trace of one ROI.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Acquisition {
    /// Every frame, in order.
    pub frames: Vec<FrameInfo>,
    /// One trace per plan ROI, in plan order.
    pub rois: Vec<RoiTrace>,
    /// Luma at or above which an ROI is flagged saturated, DN.
    pub saturation_dn: f64,
    /// What was read, for captured and rig cases (`None` for the
    /// simulator): the source, its format, frame times and segments.
    pub capture: Option<CaptureSummary>,
}

/// A whole frame, as output luma, row-major.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

/// Where a case's segments are, in frames (start inclusive, end exclusive)
/// and in seconds from the first frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentsFound {
    /// "plan" or "detected".
    #[serde(deserialize_with = "static_str")]
    pub method: Word,
    /// Detection rule: "sequence" or "off-then-pwm"; `None` for "plan".
    #[serde(deserialize_with = "static_str_opt")]
    pub rule: Option<Word>,
    /// OFF reference frames.
    pub off: Option<(u64, u64)>,
    /// Steady-ON frames.
    pub on: Option<(u64, u64)>,
    /// PWM frames.
    pub pwm: (u64, u64),
    /// OFF reference, seconds from the first frame: start of its first
    /// frame to the start of the frame after its last.
    pub off_time_s: Option<(f64, f64)>,
    /// Steady ON, seconds (as `off_time_s`).
    pub on_time_s: Option<(f64, f64)>,
    /// PWM segment, seconds (as `off_time_s`).
    pub pwm_time_s: (f64, f64),
    /// Frames in the capture.
    pub capture_frames: u64,
    /// Detection threshold on the mean LED-ROI luma, DN (detected only).
    pub threshold_dn: Option<f64>,
    /// Settle time left out after each detected step, seconds (detected only).
    pub settle_s: Option<f64>,
    /// Mean LED-ROI luma of each detected segment, DN (detected only).
    pub levels_dn: Option<LevelsFound>,
    /// The steps found, in order (detected only).
    pub steps: Vec<StepFound>,
    /// One sentence for the reports: method, spans in frames and seconds,
    /// levels and settle time.
    pub text: String,
    /// The detection signal for the trace chart: (frame time in the
    /// capture's clock in seconds, mean LED-ROI luma in DN) of every frame (detected
    /// only; not in results.json).
    #[serde(skip)]
    pub signal: Vec<(f64, f64)>,
}

impl SegmentsFound {
    /// Fills [`SegmentsFound::text`]: `how` the segments were found, then
    /// each segment's frames, seconds and level, the settle time and the
    /// steps.
    pub fn with_text(mut self, how: &str) -> Self {
        let levels = self.levels_dn;
        let part = |name: &str, f: Option<(u64, u64)>, s: Option<(f64, f64)>, l: Option<f64>| {
            let (Some((a, b)), Some((ta, tb))) = (f, s) else {
                return None;
            };
            let level = l.map_or(String::new(), |l| format!(", {l:.1} DN"));
            Some(format!("{name} frames {a}..{b} ({ta:.3}-{tb:.3} s{level})"))
        };
        let parts: Vec<String> = [
            part("ON", self.on, self.on_time_s, levels.and_then(|l| l.on)),
            part("OFF", self.off, self.off_time_s, levels.and_then(|l| l.off)),
            part(
                "PWM",
                Some(self.pwm),
                Some(self.pwm_time_s),
                levels.map(|l| l.pwm_mean),
            ),
        ]
        .into_iter()
        .flatten()
        .collect();
        let mut text = format!("{how}: {}", parts.join(", "));
        if let Some(settle) = self.settle_s {
            text += &format!("; {settle} s left out after each step");
        }
        if !self.steps.is_empty() {
            let steps: Vec<String> = self
                .steps
                .iter()
                .map(|s| {
                    format!(
                        "{} at frame {} ({:.3} s, {})",
                        s.kind, s.frame, s.time_s, s.from
                    )
                })
                .collect();
            text += &format!("; steps: {}", steps.join(", "));
        }
        text += &format!("; {} frames in the capture", self.capture_frames);
        self.text = text;
        self
    }
}

/// Mean LED-ROI luma of the detected segments, DN.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LevelsFound {
    /// OFF reference (settled part).
    pub off: Option<f64>,
    /// Steady ON (settled part).
    pub on: Option<f64>,
    /// PWM segment mean.
    pub pwm_mean: f64,
}

/// One step of the sequence as found in the capture.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StepFound {
    /// "on", "off", "pwm" or "end" (end of the PWM segment).
    #[serde(deserialize_with = "static_str")]
    pub kind: Word,
    /// First frame after the step.
    pub frame: u64,
    /// Its time, seconds from the first frame.
    pub time_s: f64,
    /// "luma" (seen in the trace), "timing" (from the sequence's durations)
    /// or "capture" (the capture starts or ends there).
    #[serde(deserialize_with = "static_str")]
    pub from: Word,
}

/// What was read for one case, for the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaptureSummary {
    /// The source as written in the plan.
    pub source: String,
    /// What was read, e.g. "video h264 yuv420p 1280x800 (ffmpeg, rgb24)".
    pub format: String,
    /// Where frame times came from.
    #[serde(deserialize_with = "static_str")]
    pub timestamps: Word,
    /// Segments and how they were found.
    pub segments: SegmentsFound,
}
