//! Frames, traces and segments: what a backend hands the runner, and what
//! metrics, analyses and the report read. The lowest data module of the
//! pipeline (docs/architecture.md): it imports nothing of the crate but
//! [`crate::util`].

use serde::{Deserialize, Serialize};

/// The columns a trace CSV (`traces/<case>.csv`) starts with, in order,
/// before one luma column per ROI named after it. A ROI must not take one
/// of these names: its column would repeat the name, and a reader of the
/// trace (the CSV capture reader among them) takes the first column of a
/// name, so the ROI would read frame numbers or times as its luma. Plan
/// validation refuses them, and the trace writer writes this header.
pub const TRACE_COLUMNS: [&str; 3] = ["frame", "time_s", "segment"];

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
    /// Mean DN of each colour plane (R, G, B) per frame, for an LED ROI of
    /// a plan with colour (`scene.led-chromaticity-xy`); `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rgb: Option<Vec<[f64; 3]>>,
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

/// A run of pixels of equal luma along a row.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Run {
    /// Pixels in the run.
    pub len: u32,
    /// Luma of each, DN.
    pub value: f64,
}

/// A whole frame, as output luma, each row held as runs of equal values.
/// A simulated frame has a few runs per row (the lamp and the background),
/// so a 1280 x 800 frame takes kilobytes, not the 8 MB of one double per
/// pixel; a frame made from pixels keeps one run per change of value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderedFrame {
    /// Frame number.
    pub index: u64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Output full scale, DN (255 for 8-bit output).
    pub full_scale_dn: f64,
    /// Rows top to bottom, each as runs left to right. Pixels that a short
    /// row's runs do not reach read as NaN; runs past the width are ignored.
    rows: Vec<Vec<Run>>,
}

impl RenderedFrame {
    /// A frame of `width` x `rows.len()` pixels from its rows' runs.
    pub fn from_runs(index: u64, width: u32, full_scale_dn: f64, rows: Vec<Vec<Run>>) -> Self {
        Self {
            index,
            width,
            height: rows.len() as u32,
            full_scale_dn,
            rows,
        }
    }

    /// A frame from its pixels' luma, row-major; missing pixels read as NaN.
    pub fn from_pixels(
        index: u64,
        width: u32,
        height: u32,
        luma: &[f64],
        full_scale_dn: f64,
    ) -> Self {
        let w = width as usize;
        let rows = (0..height as usize)
            .map(|y| {
                let start = (y * w).min(luma.len());
                let row = &luma[start..(start + w).min(luma.len())];
                let mut runs: Vec<Run> = Vec::new();
                for &v in row {
                    match runs.last_mut() {
                        Some(r) if r.value.to_bits() == v.to_bits() => r.len += 1,
                        _ => runs.push(Run { len: 1, value: v }),
                    }
                }
                runs
            })
            .collect();
        Self {
            index,
            width,
            height,
            full_scale_dn,
            rows,
        }
    }

    /// Calls `f(x, value)` for every pixel `x` in `x0..x1` of row `y`, left
    /// to right (nothing for a row or columns outside the frame).
    pub fn for_each_in_row(&self, y: u32, (x0, x1): (u32, u32), mut f: impl FnMut(u32, f64)) {
        let x1 = x1.min(self.width);
        let Some(runs) = self.rows.get(y as usize) else {
            return;
        };
        let mut x = 0u32;
        let mut runs = runs.iter();
        while x < x1 {
            let (len, value) = runs.next().map_or((x1 - x, f64::NAN), |r| (r.len, r.value));
            let end = x.saturating_add(len).min(x1);
            for px in x.max(x0)..end {
                f(px, value);
            }
            x = end;
        }
    }

    /// The runs of row `y` as stored, left to right (empty outside the
    /// frame). Runs may reach past the width, and a row's pixels past its
    /// runs read as NaN (see [`RenderedFrame::for_each_in_row`]).
    pub fn runs(&self, y: u32) -> &[Run] {
        self.rows.get(y as usize).map_or(&[], Vec::as_slice)
    }

    /// Whether rows `a` and `b` hold the same runs, bit for bit (so every
    /// pixel of the one equals the same pixel of the other, NaN included).
    /// `false` when either row is outside the frame.
    pub fn same_runs(&self, a: u32, b: u32) -> bool {
        match (self.rows.get(a as usize), self.rows.get(b as usize)) {
            (Some(ra), Some(rb)) => {
                ra.len() == rb.len()
                    && ra
                        .iter()
                        .zip(rb)
                        .all(|(p, q)| p.len == q.len && p.value.to_bits() == q.value.to_bits())
            }
            _ => false,
        }
    }

    /// The luma of row `y`, `width` values (NaN outside the frame).
    pub fn row(&self, y: u32) -> Vec<f64> {
        let mut out = vec![f64::NAN; self.width as usize];
        self.for_each_in_row(y, (0, self.width), |x, v| out[x as usize] = v);
        out
    }

    /// The luma of pixel `(x, y)`; `None` outside the frame.
    pub fn pixel(&self, x: u32, y: u32) -> Option<f64> {
        let mut out = None;
        if y < self.height {
            self.for_each_in_row(y, (x, x.saturating_add(1)), |_, v| out = Some(v));
        }
        out
    }

    /// Every distinct run of the frame as `(value, pixels)`, row by row;
    /// the pixels of all pairs sum to `width * height`.
    pub fn value_counts(&self) -> Vec<(f64, u64)> {
        let mut out = Vec::new();
        for y in 0..self.height {
            let mut last: Option<(f64, u64)> = None;
            self.for_each_run(y, |value, len| match &mut last {
                Some((v, n)) if v.to_bits() == value.to_bits() => *n += len,
                _ => {
                    out.extend(last.take());
                    last = Some((value, len));
                }
            });
            out.extend(last);
        }
        out
    }

    /// Calls `f(value, pixels)` for each run of row `y` clipped to the width
    /// (and a NaN run for pixels the runs do not reach), left to right.
    pub fn for_each_run(&self, y: u32, mut f: impl FnMut(f64, u64)) {
        let Some(runs) = self.rows.get(y as usize) else {
            return;
        };
        let mut x = 0u32;
        for r in runs {
            let end = x.saturating_add(r.len).min(self.width);
            if end > x {
                f(r.value, u64::from(end - x));
            }
            x = end;
        }
        if x < self.width {
            f(f64::NAN, u64::from(self.width - x));
        }
    }
}

/// Where a case's segments are, in frames (start inclusive, end exclusive)
/// and in seconds from the first frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentsFound {
    /// "plan" or "detected".
    pub method: SegmentMethod,
    /// Detection rule: "sequence" or "off-then-pwm"; `None` for "plan".
    pub rule: Option<DetectionRule>,
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
    pub kind: StepKind,
    /// First frame after the step.
    pub frame: u64,
    /// Its time, seconds from the first frame.
    pub time_s: f64,
    /// "luma" (seen in the trace), "timing" (from the sequence's durations)
    /// or "capture" (the capture starts or ends there).
    pub from: StepSource,
}

/// What was read for one case, for the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaptureSummary {
    /// The source as written in the plan.
    pub source: String,
    /// What was read, e.g. "video h264 yuv420p 1280x800 (ffmpeg, rgb24)".
    pub format: String,
    /// Where frame times came from.
    pub timestamps: TimestampSource,
    /// Segments and how they were found.
    pub segments: SegmentsFound,
    /// The container's time base (the unit its timestamps count in),
    /// seconds, e.g. 1/1000 for Matroska; `null` when the frame times do
    /// not come from a container's timestamps.
    #[serde(default)]
    pub time_base_s: Option<Ratio>,
    /// The frame rate the container states (FFmpeg's `r_frame_rate`, else
    /// `avg_frame_rate`; a Y4M header's `F<num>:<den>`), frames/s; `null`
    /// when it states none.
    #[serde(default)]
    pub stated_frame_rate_fps: Option<Ratio>,
    /// The light source driven over SCPI while the capture was recorded
    /// (`[source]`); absent without one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_source: Option<SourceLog>,
    /// The camera settings a `[recorder]` applied, and the frame rate its
    /// recording states; absent when it sets none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraLog>,
    /// Where the recording was kept (`--keep-captures`), relative to the
    /// report directory; absent when it was removed after the analysis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kept: Option<String>,
    /// The frame the ROI set-up figure shows, one where the lamp is lit;
    /// absent when the backend shows no frame of the capture.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lit_frame: Option<LitFrame>,
}

/// A frame of a capture where the lamp is lit: the ROIs drawn on it show
/// where the lamp is, which a frame where the lamp is dark cannot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LitFrame {
    /// Frame number.
    pub frame: u64,
    /// The segment it is in: `on` or `pwm`.
    pub segment: Segment,
}

impl LitFrame {
    /// The frame of `acq` where ROI `led` is brightest in the ON segment
    /// (the lamp is lit there by design), else in the PWM segment; the first
    /// of equals. None without such a frame or ROI.
    pub fn of(acq: &Acquisition, led: usize) -> Option<LitFrame> {
        let luma = &acq.rois.get(led)?.luma;
        let brightest = |segment: Segment| {
            acq.frames
                .iter()
                .zip(luma)
                .filter(|(f, _)| f.segment == segment)
                .rev()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map(|(f, _)| LitFrame {
                    frame: f.index,
                    segment,
                })
        };
        brightest(Segment::On).or_else(|| brightest(Segment::Pwm))
    }
}

/// The camera settings of a `[recorder]` for one case: what was set, and
/// what the recording shows of it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraLog {
    /// Exposure time set, microseconds; `null` when left to the camera.
    pub exposure_us: Option<f64>,
    /// Gain set, decibels; `null` when left to the camera.
    pub gain_db: Option<f64>,
    /// Frame rate set, frames/s; `null` when left to the camera.
    pub frame_rate_fps: Option<f64>,
    /// The frame rate the recording states (a Y4M header's), frames/s:
    /// the camera's rate as read back; `null` when it states none.
    pub frame_rate_read_fps: Option<f64>,
    /// The exposure the camera reports after the recording, microseconds
    /// (an Aravis camera's `ExposureTime` or `ExposureTimeAbs`); `null`
    /// when it was not read.
    #[serde(default)]
    pub exposure_read_us: Option<f64>,
    /// The gain the camera reports after the recording, decibels (an
    /// Aravis camera's `Gain`); `null` when it was not read.
    #[serde(default)]
    pub gain_read_db: Option<f64>,
}

/// What the light source was sent for one case, and when.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SourceLog {
    /// The template, e.g. "keysight-33500b" or "custom".
    pub instrument: String,
    /// `host:port` of its SCPI socket.
    pub address: String,
    /// Its answer to the identity query (`*IDN?`).
    pub identity: String,
    /// The steps, in the order sent.
    pub steps: Vec<SourceStep>,
}

/// One step of the light sequence as sent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SourceStep {
    /// "prepare", "on", "off", "pwm" or "end".
    pub step: String,
    /// When its first line was sent, seconds from the start of the
    /// capture command (host monotonic clock).
    pub time_s: f64,
    /// The SCPI lines sent.
    pub commands: Vec<String>,
}

/// An exact ratio `num / den` as a container states it: a time base in
/// seconds (1/1000), a frame rate in frames/s (30000/1001).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ratio {
    /// Numerator, > 0.
    pub num: u64,
    /// Denominator, > 0.
    pub den: u64,
}

impl Ratio {
    /// `num / den`; `None` unless both are positive.
    pub fn new(num: u64, den: u64) -> Option<Self> {
        (num > 0 && den > 0).then_some(Self { num, den })
    }

    /// Parses `num/den` (FFmpeg's form, e.g. `30000/1001`); `None` for
    /// `0/0`, signs, or anything else.
    pub fn parse(text: &str) -> Option<Self> {
        let (n, d) = text.trim().split_once('/')?;
        Self::new(n.parse().ok()?, d.parse().ok()?)
    }

    /// The value, rounded once to the nearest double.
    pub fn value(self) -> f64 {
        self.num as f64 / self.den as f64
    }
}

impl std::fmt::Display for Ratio {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.num, self.den)
    }
}

/// Declares a closed set of words that results.json holds as strings: the
/// enum, its serde names (the words), `as_str` / `Display` giving them,
/// and comparison with a word.
#[macro_export]
#[doc(hidden)]
macro_rules! __words {
    ($(#[$doc:meta])* $name:ident { $($(#[$vdoc:meta])* $variant:ident = $word:literal,)* }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, ::serde::Serialize, ::serde::Deserialize)]
        pub enum $name {
            $($(#[$vdoc])* #[serde(rename = $word)] $variant,)*
        }

        impl $name {
            /// The word results.json holds.
            pub fn as_str(self) -> &'static str {
                match self {
                    $($name::$variant => $word,)*
                }
            }
        }

        impl PartialEq<&str> for $name {
            fn eq(&self, word: &&str) -> bool {
                self.as_str() == *word
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

pub use crate::__words as words;

words! {
    /// How a case's segments were found.
    SegmentMethod {
        /// Given by the plan (frame ranges or `[capture]` keys).
        Plan = "plan",
        /// Detected from the luma.
        Detected = "detected",
    }
}

words! {
    /// The rule segment detection followed.
    DetectionRule {
        /// The plan's ON, OFF, PWM sequence.
        Sequence = "sequence",
        /// No ON segment: OFF, then PWM.
        OffThenPwm = "off-then-pwm",
    }
}

words! {
    /// A step of the sequence.
    StepKind {
        /// The light turns steadily ON.
        On = "on",
        /// The light turns OFF.
        Off = "off",
        /// The PWM starts.
        Pwm = "pwm",
        /// The PWM segment ends.
        End = "end",
    }
}

words! {
    /// How a step was placed.
    StepSource {
        /// Seen in the trace.
        Luma = "luma",
        /// From the sequence's durations.
        Timing = "timing",
        /// The capture starts or ends there.
        Capture = "capture",
    }
}

words! {
    /// Where a capture's frame times came from.
    TimestampSource {
        /// The container's timestamps.
        Container = "container",
        /// A `<capture>.timestamps.csv` sidecar.
        Sidecar = "sidecar",
        /// `[capture] frame-rate-fps`, or a Y4M header's rate.
        Fps = "fps",
        /// The CSV trace's time column.
        Csv = "csv",
        /// None: the capture cannot be timed.
        None = "none",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An acquisition of one ROI with these segments and luma.
    fn acquisition(frames: &[(Segment, f64)]) -> Acquisition {
        Acquisition {
            frames: (0u64..)
                .zip(frames)
                .map(|(index, &(segment, _))| FrameInfo {
                    index: index + 10,
                    time_s: index as f64 / 30.0,
                    segment,
                })
                .collect(),
            rois: vec![RoiTrace {
                name: "led".into(),
                luma: frames.iter().map(|f| f.1).collect(),
                phase_envelope: None,
                rgb: None,
            }],
            saturation_dn: 250.0,
            capture: None,
        }
    }

    #[test]
    fn the_lit_frame_is_the_brightest_on_frame_else_the_brightest_pwm_frame() {
        use Segment::{Off, On, Pwm};
        let with_on = acquisition(&[(Off, 5.0), (On, 90.0), (On, 91.0), (Pwm, 200.0)]);
        assert_eq!(
            LitFrame::of(&with_on, 0),
            Some(LitFrame {
                frame: 12,
                segment: On
            })
        );
        // The first of equals, in frame order.
        let pwm_only = acquisition(&[(Off, 5.0), (Pwm, 0.0), (Pwm, 80.0), (Pwm, 80.0)]);
        assert_eq!(
            LitFrame::of(&pwm_only, 0),
            Some(LitFrame {
                frame: 12,
                segment: Pwm
            })
        );
        assert_eq!(LitFrame::of(&pwm_only, 1), None);
        assert_eq!(LitFrame::of(&acquisition(&[(Off, 5.0)]), 0), None);
    }
}
