//! Plan keys for captured data and lab rigs: `[capture]`, `[[case]]` and
//! `[p2020]`, from the serde mirror to validated values.
//!
//! `[dut] backend = "captured"` takes its cases from `[[case]]` (one capture
//! file each, with its light level, PWM frequency and duty cycle when they
//! are known); `backend = "command"` takes them from the grid and runs
//! `[capture] command` for each. Segments (OFF reference, steady ON, PWM)
//! are given in frames or seconds, or detected from the luma.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::p2020::{MmpReference, P2020Options};
use super::validate::Checker;

/// Default settle time after each detected step, seconds (`[capture] settle-s`).
pub const DEFAULT_SETTLE_S: f64 = 0.5;

/// Weights that turn R, G, B into luma.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LumaWeights {
    /// ITU-R BT.601: 0.299 R + 0.587 G + 0.114 B (OpenCV's grey; P2020 reference).
    Bt601,
    /// ITU-R BT.709: 0.2126 R + 0.7152 G + 0.0722 B.
    Bt709,
}

/// How video is decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
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

/// Signal range of Y' in video and Y4M.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum VideoRange {
    /// From the file's tag; limited (16-235) when untagged, as H.264 usually is.
    Auto,
    /// 16-235 (8-bit), expanded to 0-255.
    Limited,
    /// 0-255, used as is.
    Full,
}

/// `[capture]`
#[derive(Debug, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawCapture {
    pub luma: Option<String>,
    pub video_decode: Option<String>,
    pub video_range: Option<String>,
    pub frame_rate_fps: Option<f64>,
    pub saturation_dn: Option<f64>,
    pub off_frames: Option<Vec<i64>>,
    pub on_frames: Option<Vec<i64>>,
    pub pwm_frames: Option<Vec<i64>>,
    pub off_time_s: Option<Vec<f64>>,
    pub on_time_s: Option<Vec<f64>>,
    pub pwm_time_s: Option<Vec<f64>>,
    pub command: Option<Vec<String>>,
    pub timeout_s: Option<f64>,
    pub settle_s: Option<f64>,
}

/// Segment keys, in `[capture]` (defaults) and in each `[[case]]` (no
/// `serde(flatten)`: it would hide unknown keys from the checks).
#[derive(Debug, Default)]
pub struct RawSegments {
    pub off_frames: Option<Vec<i64>>,
    pub on_frames: Option<Vec<i64>>,
    pub pwm_frames: Option<Vec<i64>>,
    pub off_time_s: Option<Vec<f64>>,
    pub on_time_s: Option<Vec<f64>>,
    pub pwm_time_s: Option<Vec<f64>>,
}

/// `[[case]]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawCaseEntry {
    pub id: Option<String>,
    pub source: Option<String>,
    pub light_lux: Option<f64>,
    pub frequency_hz: Option<f64>,
    pub duty_cycle: Option<f64>,
    pub off_frames: Option<Vec<i64>>,
    pub on_frames: Option<Vec<i64>>,
    pub pwm_frames: Option<Vec<i64>>,
    pub off_time_s: Option<Vec<f64>>,
    pub on_time_s: Option<Vec<f64>>,
    pub pwm_time_s: Option<Vec<f64>>,
    pub informative: Option<bool>,
}

/// `[p2020]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawP2020 {
    pub contrast_threshold: Option<f64>,
    pub mmp_delta: Option<f64>,
    pub mmp_reference: Option<String>,
}

/// A span of frames: `start` inclusive, `end` exclusive (`None`: to the end).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
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

/// `[capture]`, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureConfig {
    /// Luma weights for RGB frames.
    pub luma: LumaWeights,
    /// Video decode path.
    pub video_decode: VideoDecode,
    /// Y' range of video and Y4M.
    pub video_range: VideoRange,
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

fn span_frames(c: &mut Checker<'_>, v: Vec<i64>, key: &str) -> Option<Span> {
    let hint = "[start] or [start, end]: frame indices from 0, end exclusive";
    match v.as_slice() {
        [s] if *s >= 0 => Some(Span::Frames {
            start: *s as u64,
            end: None,
        }),
        [s, e] if *s >= 0 && e > s => Some(Span::Frames {
            start: *s as u64,
            end: Some(*e as u64),
        }),
        _ => {
            c.error(key, format!("{v:?} is not a frame span"), Some(hint));
            None
        }
    }
}

fn span_seconds(c: &mut Checker<'_>, v: Vec<f64>, key: &str) -> Option<Span> {
    let hint = "[start] or [start, end]: seconds from the first frame, end exclusive";
    match v.as_slice() {
        [s] if s.is_finite() && *s >= 0.0 => Some(Span::Seconds {
            start: *s,
            end: None,
        }),
        [s, e] if s.is_finite() && e.is_finite() && *s >= 0.0 && e > s => Some(Span::Seconds {
            start: *s,
            end: Some(*e),
        }),
        _ => {
            c.error(key, format!("{v:?} is not a time span"), Some(hint));
            None
        }
    }
}

/// Validates segment keys under `prefix`, over `base`. `None` when invalid.
fn segments(
    c: &mut Checker<'_>,
    raw: RawSegments,
    prefix: &str,
    base: SegmentSpec,
) -> Option<SegmentSpec> {
    let mut out = base;
    let mut ok = true;
    let pairs = [
        ("off", raw.off_frames, raw.off_time_s),
        ("on", raw.on_frames, raw.on_time_s),
        ("pwm", raw.pwm_frames, raw.pwm_time_s),
    ];
    for (name, frames, secs) in pairs {
        let kf = format!("{prefix}.{name}-frames");
        let ks = format!("{prefix}.{name}-time-s");
        let span = match (frames, secs) {
            (Some(_), Some(_)) => {
                c.error(
                    &ks,
                    format!("give either `{name}-frames` or `{name}-time-s`, not both"),
                    Some("remove one of the two"),
                );
                ok = false;
                continue;
            }
            (Some(f), None) => span_frames(c, f, &kf),
            (None, Some(s)) => span_seconds(c, s, &ks),
            (None, None) => continue,
        };
        match span {
            Some(s) => match name {
                "off" => out.off = Some(s),
                "on" => out.on = Some(s),
                _ => out.pwm = Some(s),
            },
            None => ok = false,
        }
    }
    if !out.detect() && out.pwm.is_none() {
        c.error(
            &format!("{prefix}.pwm-frames"),
            "segments are given but the PWM segment is not",
            Some("add pwm-frames = [start] (to the end) or [start, end], or give no segments to detect them"),
        );
        ok = false;
    }
    ok.then_some(out)
}

fn choice<T: Copy>(
    c: &mut Checker<'_>,
    value: Option<String>,
    key: &str,
    default: T,
    options: &[(&str, T)],
) -> Option<T> {
    let Some(v) = value else {
        return Some(default);
    };
    if let Some((_, t)) = options.iter().find(|(name, _)| *name == v) {
        return Some(*t);
    }
    let names: Vec<String> = options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
    c.error(
        key,
        format!("unknown value `{v}`"),
        Some(&format!("use {}", names.join(" or "))),
    );
    None
}

/// Validates `[capture]` and `[[case]]`. `captured` is true for the captured
/// backend (cases from `[[case]]`), false for the command backend.
pub(super) fn capture_config(
    c: &mut Checker<'_>,
    raw: Option<RawCapture>,
    cases: Vec<RawCaseEntry>,
    captured: bool,
    plan_path: &Path,
) -> Option<CaptureConfig> {
    let raw = raw.unwrap_or_default();
    let luma = choice(
        c,
        raw.luma,
        "capture.luma",
        LumaWeights::Bt601,
        &[("bt601", LumaWeights::Bt601), ("bt709", LumaWeights::Bt709)],
    );
    let video_decode = choice(
        c,
        raw.video_decode,
        "capture.video-decode",
        VideoDecode::Rgb,
        &[
            ("rgb", VideoDecode::Rgb),
            ("luma-plane", VideoDecode::LumaPlane),
        ],
    );
    let video_range = choice(
        c,
        raw.video_range,
        "capture.video-range",
        VideoRange::Auto,
        &[
            ("auto", VideoRange::Auto),
            ("limited", VideoRange::Limited),
            ("full", VideoRange::Full),
        ],
    );
    let mut ok = true;
    let fps = match raw.frame_rate_fps {
        Some(v) => {
            let r = c.positive(v, "capture.frame-rate-fps", "frames per second, e.g. 30.0");
            ok &= r.is_some();
            r
        }
        None => None,
    };
    let saturation_dn = match raw.saturation_dn {
        Some(v) => {
            let r = c.positive(
                v,
                "capture.saturation-dn",
                "the P2020 reference code flags 240 of 255",
            );
            ok &= r.is_some();
            r
        }
        None => None,
    };
    let settle_s = c.non_negative(
        raw.settle_s.unwrap_or(DEFAULT_SETTLE_S),
        "capture.settle-s",
        "seconds left out after each detected step; default 0.5",
    );
    ok &= settle_s.is_some();
    let base = segments(
        c,
        RawSegments {
            off_frames: raw.off_frames,
            on_frames: raw.on_frames,
            pwm_frames: raw.pwm_frames,
            off_time_s: raw.off_time_s,
            on_time_s: raw.on_time_s,
            pwm_time_s: raw.pwm_time_s,
        },
        "capture",
        SegmentSpec::default(),
    );
    let command = match (raw.command, captured) {
        (Some(argv), false) if !argv.is_empty() => {
            let timeout_s = c.positive(
                raw.timeout_s.unwrap_or(300.0),
                "capture.timeout-s",
                "seconds one case may take",
            );
            timeout_s.map(|timeout_s| CommandSpec { argv, timeout_s })
        }
        (_, false) => {
            c.error(
                "capture.command",
                "backend = \"command\" needs a command",
                Some(
                    "e.g. command = [\"sh\", \"examples/sim-rig.sh\"]; see docs/command-backend.md",
                ),
            );
            None
        }
        (Some(_), true) => {
            c.error(
                "capture.command",
                "a command is only used with backend = \"command\"",
                Some("remove it, or set [dut] backend = \"command\""),
            );
            None
        }
        (None, true) => Some(CommandSpec {
            argv: Vec::new(),
            timeout_s: 0.0,
        }),
    };
    let command = command.filter(|cmd| !cmd.argv.is_empty());
    if !captured && !cases.is_empty() {
        c.error(
            "case",
            "[[case]] lists captures, which only backend = \"captured\" reads",
            Some("a command plan makes its cases from [light] and [grid]"),
        );
        ok = false;
    }
    let dir = plan_path.parent().unwrap_or(Path::new("."));
    let mut out_cases: Vec<CaptureCase> = Vec::new();
    if captured && cases.is_empty() {
        c.error(
            "case",
            "a captured plan needs at least one [[case]]",
            Some("add [[case]] with source = \"path/to/capture.mp4\""),
        );
        ok = false;
    }
    for (i, raw_case) in cases.into_iter().enumerate() {
        let k = |s: &str| format!("case[{i}].{s}");
        let Some(source_text) = c.required(
            raw_case.source,
            &k("source"),
            "a capture: video, .y4m, a directory of PNG/TIFF frames, or a .csv trace",
        ) else {
            ok = false;
            continue;
        };
        let source = dir.join(&source_text);
        if !source.exists() {
            c.error(
                &k("source"),
                format!("capture `{}` does not exist", source.display()),
                Some("paths are relative to the plan file's directory"),
            );
            ok = false;
        }
        let light_lux = raw_case
            .light_lux
            .and_then(|v| c.positive(v, &k("light-lux"), "illuminance in lux"));
        let frequency_hz = raw_case
            .frequency_hz
            .and_then(|v| c.positive(v, &k("frequency-hz"), "PWM frequency in Hz"));
        let duty = raw_case
            .duty_cycle
            .and_then(|v| c.duty(v, &k("duty-cycle")));
        let given = [
            raw_case.light_lux.is_some(),
            raw_case.frequency_hz.is_some(),
            raw_case.duty_cycle.is_some(),
        ];
        if given.contains(&true) && given.contains(&false) {
            c.error(
                &k("source"),
                "give all of light-lux, frequency-hz and duty-cycle, or none",
                Some("leave all three out when the conditions are unknown"),
            );
            ok = false;
        }
        let raw_segs = RawSegments {
            off_frames: raw_case.off_frames,
            on_frames: raw_case.on_frames,
            pwm_frames: raw_case.pwm_frames,
            off_time_s: raw_case.off_time_s,
            on_time_s: raw_case.on_time_s,
            pwm_time_s: raw_case.pwm_time_s,
        };
        let segs = base.and_then(|b| segments(c, raw_segs, &format!("case[{i}]"), b));
        let id = match raw_case.id {
            Some(id) => id,
            None => match (light_lux, frequency_hz, duty) {
                (Some(l), Some(f), Some(d)) => super::grid::condition_id(l, f, d),
                _ => Path::new(&source_text)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| format!("case{i}")),
            },
        };
        if id.is_empty()
            || !id
                .chars()
                .all(|ch| ch.is_ascii_alphanumeric() || ch == '-' || ch == '_' || ch == '.')
        {
            c.error(
                &k("id"),
                format!("case id `{id}` must be letters, digits, `-`, `_` or `.`"),
                Some("the id names the case's trace file; set id = \"...\""),
            );
            ok = false;
            continue;
        }
        if out_cases.iter().any(|o| o.id == id) {
            c.error(
                &k("id"),
                format!("case id `{id}` is used twice"),
                Some("give each [[case]] its own id = \"...\""),
            );
            ok = false;
            continue;
        }
        let Some(segs) = segs else {
            ok = false;
            continue;
        };
        out_cases.push(CaptureCase {
            id,
            source,
            source_text,
            light_lux,
            frequency_hz,
            duty,
            segments: segs,
            informative: raw_case.informative.unwrap_or(false),
        });
    }
    let command_ok = captured || command.is_some();
    if !(ok && command_ok) {
        return None;
    }
    Some(CaptureConfig {
        luma: luma?,
        video_decode: video_decode?,
        video_range: video_range?,
        frame_rate_fps: fps,
        saturation_dn,
        segments: base?,
        settle_s: settle_s?,
        command,
        cases: out_cases,
    })
}

/// Validates `[p2020]`.
pub(super) fn p2020_options(c: &mut Checker<'_>, raw: Option<RawP2020>) -> Option<P2020Options> {
    let mut o = P2020Options::default();
    let Some(raw) = raw else {
        return Some(o);
    };
    let mut ok = true;
    if let Some(v) = raw.contrast_threshold {
        match c.positive(v, "p2020.contrast-threshold", "the reference code uses 0.1") {
            Some(v) => o.contrast_threshold = v,
            None => ok = false,
        }
    }
    if let Some(v) = raw.mmp_delta {
        match c.positive(
            v,
            "p2020.mmp-delta",
            "a fraction; the reference code uses 0.1",
        ) {
            Some(v) if v < 1.0 => o.mmp_delta = v,
            Some(v) => {
                c.error(
                    "p2020.mmp-delta",
                    format!("{v} is not below 1"),
                    Some("a fraction of the reference level; the reference code uses 0.1"),
                );
                ok = false;
            }
            None => ok = false,
        }
    }
    match choice(
        c,
        raw.mmp_reference,
        "p2020.mmp-reference",
        MmpReference::PwmMean,
        &[
            ("pwm-mean", MmpReference::PwmMean),
            ("on-level", MmpReference::OnLevel),
        ],
    ) {
        Some(r) => o.mmp_reference = r,
        None => ok = false,
    }
    ok.then_some(o)
}

/// The camera of a plan without `[dut.camera]` (captured data): unbounded
/// sensor, so ROIs are checked against each capture's frames instead.
pub(super) fn no_camera() -> super::CameraConfig {
    super::CameraConfig {
        name: "captured".to_string(),
        description: "captured data: no simulated camera".to_string(),
        source: "plan".to_string(),
        physical: None,
        shutter: super::ShutterKind::Global,
        sensor_rows: u32::MAX / 2,
        sensor_columns: u32::MAX / 2,
        line_time_s: 0.0,
        exposure_s: 1.0 / 30.0,
        fps: 30.0,
        pwm_delay_s: 0.0,
        response_dn_per_cd_m2_s: 1.0,
        black_level_dn: 0.0,
        full_scale_dn: 255.0,
        saturation_dn: 240.0,
    }
}
