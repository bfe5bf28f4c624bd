//! Validated plan values for captured data and lab rigs: `[capture]` and
//! `[[case]]` (checked in `validate/capture.rs`), and the capture choices
//! (luma weights, video decode and range) that the readers in `capture`
//! take from here.
//!
//! `[dut] backend = "captured"` takes its cases from `[[case]]` (one capture
//! file each, with its light level, PWM frequency and duty cycle when they
//! are known); `backend = "command"` takes them from the grid and runs
//! `[capture] command` for each. Segments (OFF reference, steady ON, PWM)
//! are given in frames or seconds, or detected from the luma.

use std::path::PathBuf;

/// Default settle time after each detected step, seconds (`[capture] settle-s`).
pub const DEFAULT_SETTLE_S: f64 = 0.5;

/// Weights that turn R, G, B into luma.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LumaWeights {
    /// ITU-R BT.601: 0.299 R + 0.587 G + 0.114 B (OpenCV's grey; P2020 reference).
    Bt601,
    /// ITU-R BT.709: 0.2126 R + 0.7152 G + 0.0722 B.
    Bt709,
}

impl LumaWeights {
    /// Per-pixel luma of integer R, G, B, rounded to a whole DN. BT.601
    /// uses OpenCV's 14-bit fixed-point weights so that 8-bit grey is
    /// bit-identical to `cv2.cvtColor(.., COLOR_BGR2GRAY)`.
    #[inline]
    pub fn luma(self, r: u32, g: u32, b: u32) -> u32 {
        match self {
            LumaWeights::Bt601 => (r * 4899 + g * 9617 + b * 1868 + 8192) >> 14,
            LumaWeights::Bt709 => {
                ((r as f64 * 0.2126 + g as f64 * 0.7152 + b as f64 * 0.0722) + 0.5) as u32
            }
        }
    }
}

/// How video is decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VideoDecode {
    /// Decode to full-range RGB (FFmpeg's swscale, as OpenCV does in the P2020
    /// reference pipeline), then take luma: matches the reference exactly.
    Rgb,
    /// Read the Y' plane only and expand its range to full scale: no R, G, B
    /// means; 1.1-1.3 DN (max 2 DN) above the RGB path on the P2020
    /// samples, enough to move FMI and MMP by up to 0.05 there.
    LumaPlane,
}

/// How a recording's R, G and B codes encode light: the transfer function
/// its colour planes are decoded with before their ROI means (the luma
/// trace is always the codes' own).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ColourTransfer {
    /// The codes are linear in light (raw or linear sensor output).
    Linear,
    /// IEC 61966-2-1 (sRGB): most still images.
    Srgb,
    /// ITU-R BT.709's camera transfer, inverted: most video.
    Bt709,
}

impl ColourTransfer {
    /// Linear light of a code at `v` of full scale (0..1), 0..1.
    pub fn linear(self, v: f64) -> f64 {
        match self {
            ColourTransfer::Linear => v,
            // IEC 61966-2-1, section 5.2.
            ColourTransfer::Srgb if v <= 0.04045 => v / 12.92,
            ColourTransfer::Srgb => ((v + 0.055) / 1.055).powf(2.4),
            // ITU-R BT.709-6, item 1.2, inverted.
            ColourTransfer::Bt709 if v < 0.081 => v / 4.5,
            ColourTransfer::Bt709 => ((v + 0.099) / 1.099).powf(1.0 / 0.45),
        }
    }
}

/// Signal range of Y' in video and Y4M.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VideoRange {
    /// From the file's tag; limited (16-235) when untagged, as H.264 usually is.
    Auto,
    /// 16-235 (8-bit), expanded to 0-255.
    Limited,
    /// 0-255, used as is.
    Full,
}

/// A span of frames: `start` inclusive, `end` exclusive (`None`: to the end).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "unit", rename_all = "lowercase")]
pub enum Span {
    /// Frame indices from 0.
    Frames {
        /// First frame.
        start: u64,
        /// One past the last frame; `None` for the end of the capture.
        end: Option<u64>,
    },
    /// Seconds from the first frame's timestamp.
    Seconds {
        /// Start time, seconds.
        start: f64,
        /// End time (exclusive), seconds; `None` for the end of the capture.
        end: Option<f64>,
    },
}

/// Where the segments of a capture are. All `None`: detect them.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SegmentSpec {
    /// OFF reference (x_off, L_OFF).
    pub off: Option<Span>,
    /// Steady ON.
    pub on: Option<Span>,
    /// PWM segment.
    pub pwm: Option<Span>,
}

impl SegmentSpec {
    /// True when nothing is given and the segments are to be detected.
    pub fn detect(&self) -> bool {
        self.off.is_none() && self.on.is_none() && self.pwm.is_none()
    }
}

/// The lab-rig command of `backend = "command"`.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandSpec {
    /// Program and arguments; a relative program path is resolved against
    /// the plan's directory when it exists there.
    pub argv: Vec<String>,
    /// Longest time one case may take, seconds (> 0).
    pub timeout_s: f64,
}

/// What a captured colour plan subtracts from its colour planes before
/// their chromaticity (`capture.black-level`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlackLevel {
    /// `"camera"`: `dut.camera.black-level-dn` (0 without it), the same
    /// for every plane.
    Camera,
    /// `"off-segment"`: each plane's own mean over the case's OFF frames:
    /// the recording's pedestal (and any steady light in the ROI), per
    /// plane and per case.
    OffSegment,
}

/// `[capture]`, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureConfig {
    /// Luma weights for RGB frames.
    pub luma: LumaWeights,
    /// Video decode path.
    pub video_decode: VideoDecode,
    /// Y' range of video and Y4M.
    pub video_range: VideoRange,
    /// How the R, G and B codes encode light (`colour-transfer`); `None`
    /// when not given (a colour plan must give it).
    pub colour_transfer: Option<ColourTransfer>,
    /// What the colour planes are measured from (`black-level`).
    pub black_level: BlackLevel,
    /// Frame rate for sources without timestamps, frames/s.
    pub frame_rate_fps: Option<f64>,
    /// Saturation flag level, DN; `None`: 240/255 of the source's full scale.
    pub saturation_dn: Option<f64>,
    /// Default segments of every case.
    pub segments: SegmentSpec,
    /// Time left out after each detected step (auto exposure settling),
    /// seconds (>= 0); `[capture] settle-s`, default
    /// [`DEFAULT_SETTLE_S`].
    pub settle_s: f64,
    /// The lab-rig command (command backend only).
    pub command: Option<CommandSpec>,
    /// Cases of a captured plan, in plan order.
    pub cases: Vec<CaptureCase>,
}

/// One `[[case]]` of a captured plan.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureCase {
    /// Case id, filename-safe.
    pub id: String,
    /// Capture file or directory, resolved against the plan's directory.
    pub source: PathBuf,
    /// The source as written in the plan.
    pub source_text: String,
    /// Illuminance, lux, when known.
    pub light_lux: Option<f64>,
    /// PWM frequency, Hz, when known.
    pub frequency_hz: Option<f64>,
    /// Duty cycle in (0, 1], when known.
    pub duty: Option<f64>,
    /// Segments (the case's keys over `[capture]`'s).
    pub segments: SegmentSpec,
    /// `informative = true`: measured and reported, never judged.
    pub informative: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The standards' encodings (IEC 61966-2-1; ITU-R BT.709-6, item 1.2),
    /// written forwards, which the decoding inverts.
    fn encode(t: ColourTransfer, l: f64) -> f64 {
        match t {
            ColourTransfer::Linear => l,
            ColourTransfer::Srgb if l <= 0.0031308 => 12.92 * l,
            ColourTransfer::Srgb => 1.055 * l.powf(1.0 / 2.4) - 0.055,
            ColourTransfer::Bt709 if l < 0.018 => 4.5 * l,
            ColourTransfer::Bt709 => 1.099 * l.powf(0.45) - 0.099,
        }
    }

    #[test]
    fn each_colour_transfer_inverts_its_standards_encoding() {
        let all = [
            ColourTransfer::Linear,
            ColourTransfer::Srgb,
            ColourTransfer::Bt709,
        ];
        for t in all {
            for i in 0..=1000 {
                let l = f64::from(i) / 1000.0;
                let back = t.linear(encode(t, l));
                assert!((back - l).abs() < 1e-12, "{t:?} {l}: {back}");
            }
            assert_eq!(t.linear(0.0), 0.0);
            assert!((t.linear(1.0) - 1.0).abs() < 1e-12, "{t:?}");
        }
        // Mid grey, worked by hand: ((0.5 + 0.055) / 1.055)^2.4 and
        // ((0.5 + 0.099) / 1.099)^(1 / 0.45).
        assert!((ColourTransfer::Srgb.linear(0.5) - 0.214_041_140_5).abs() < 1e-9);
        assert!((ColourTransfer::Bt709.linear(0.5) - 0.259_589_400_5).abs() < 1e-9);
    }
}
