//! `[capture]` and `[[case]]`: how a captured or command plan reads its
//! frames, from the serde mirror to a validated [`CaptureConfig`].

use std::path::Path;

use super::grid;
use crate::plan::bounds::{CAPTURE_FPS_RANGE, TIMEOUT_S_RANGE};
use crate::plan::capture::{
    BlackLevel, CaptureCase, CaptureConfig, CommandSpec, SegmentSpec, Span,
};
use crate::plan::check::Checker;
use crate::plan::grid::condition_id;
use crate::plan::raw::{RawCaptureTable, RawCaseEntry, RawSegments};
use crate::plan::{ColourTransfer, DEFAULT_SETTLE_S, LumaWeights, VideoDecode, VideoRange};

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

/// Validates `[capture]` and `[[case]]`. `captured` is true for the captured
/// backend (cases from `[[case]]`), false for the command backend;
/// `recorder` is true when the plan has a `[recorder]`, whose command
/// takes the place of `[capture] command`.
pub(super) fn capture_config(
    c: &mut Checker<'_>,
    raw: Option<RawCaptureTable>,
    cases: Vec<RawCaseEntry>,
    (captured, recorder): (bool, bool),
    plan_path: &Path,
    pwm_s: Option<f64>,
) -> Option<CaptureConfig> {
    let mut raw = raw.unwrap_or_default();
    let (luma, video_decode, video_range) = decoding(c, &mut raw);
    let colour_transfer = match raw.colour_transfer.take() {
        None => Some(None),
        Some(v) => c
            .choice(
                Some(v),
                "capture.colour-transfer",
                ColourTransfer::Linear,
                &[
                    ("linear", ColourTransfer::Linear),
                    ("srgb", ColourTransfer::Srgb),
                    ("bt709", ColourTransfer::Bt709),
                ],
            )
            .map(Some),
    };
    let black_level = c.choice(
        raw.black_level.take(),
        "capture.black-level",
        BlackLevel::Camera,
        &[
            ("camera", BlackLevel::Camera),
            ("off-segment", BlackLevel::OffSegment),
        ],
    );
    let mut ok = true;
    let fps = raw.frame_rate_fps.and_then(|v| {
        let fps = c.within(
            v,
            "capture.frame-rate-fps",
            CAPTURE_FPS_RANGE,
            " fps",
            "frames per second, e.g. 30.0",
        );
        ok &= fps.is_some();
        fps
    });
    let saturation_dn = optional_positive(
        c,
        raw.saturation_dn,
        "capture.saturation-dn",
        "the P2020 reference code flags 240 of 255",
        &mut ok,
    );
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
    let command = command(c, raw.command, raw.timeout_s, (captured, recorder));
    let out_cases = case_entries(c, cases, (captured, pwm_s), plan_path, base, &mut ok);
    let command_ok = captured || command.is_some();
    if !(ok && command_ok) {
        return None;
    }
    Some(CaptureConfig {
        luma: luma?,
        video_decode: video_decode?,
        video_range: video_range?,
        colour_transfer: colour_transfer?,
        black_level: black_level?,
        frame_rate_fps: fps,
        saturation_dn,
        segments: base?,
        settle_s: settle_s?,
        command,
        cases: out_cases,
    })
}

/// `luma`, `video-decode` and `video-range`: how frames become luma.
fn decoding(
    c: &mut Checker<'_>,
    raw: &mut RawCaptureTable,
) -> (Option<LumaWeights>, Option<VideoDecode>, Option<VideoRange>) {
    let luma = c.choice(
        raw.luma.take(),
        "capture.luma",
        LumaWeights::Bt601,
        &[("bt601", LumaWeights::Bt601), ("bt709", LumaWeights::Bt709)],
    );
    let video_decode = c.choice(
        raw.video_decode.take(),
        "capture.video-decode",
        VideoDecode::Rgb,
        &[
            ("rgb", VideoDecode::Rgb),
            ("luma-plane", VideoDecode::LumaPlane),
        ],
    );
    let video_range = c.choice(
        raw.video_range.take(),
        "capture.video-range",
        VideoRange::Auto,
        &[
            ("auto", VideoRange::Auto),
            ("limited", VideoRange::Limited),
            ("full", VideoRange::Full),
        ],
    );
    (luma, video_decode, video_range)
}

/// An optional key that must be > 0 when given; an invalid value clears `ok`.
fn optional_positive(
    c: &mut Checker<'_>,
    value: Option<f64>,
    key: &str,
    hint: &str,
    ok: &mut bool,
) -> Option<f64> {
    let r = c.positive(value?, key, hint);
    *ok &= r.is_some();
    r
}

/// `command` and `timeout-s`: the lab rig's command, required by the
/// command backend and refused by the captured one. `None` when absent or
/// invalid (the captured backend has none). With a `[recorder]`, the
/// command is the recorder's: `argv` is left empty here and filled once
/// `[recorder]` is validated, and `timeout-s` still bounds each case.
fn command(
    c: &mut Checker<'_>,
    argv: Option<Vec<String>>,
    timeout_s: Option<f64>,
    (captured, recorder): (bool, bool),
) -> Option<CommandSpec> {
    let timeout = |c: &mut Checker<'_>| {
        c.within(
            timeout_s.unwrap_or(300.0),
            "capture.timeout-s",
            TIMEOUT_S_RANGE,
            " s",
            "seconds one case may take",
        )
    };
    match (argv, captured) {
        (Some(_), false) if recorder => {
            c.error(
                "capture.command",
                "the plan records the camera with [recorder], so it has no [capture] command",
                Some("keep one of them: [recorder] for a camera recorded while the light source plays, or [capture] command for a rig that does both"),
            );
            None
        }
        (None, false) if recorder => timeout(c).map(|timeout_s| CommandSpec {
            argv: Vec::new(),
            timeout_s,
        }),
        (Some(argv), false) if !argv.is_empty() => {
            timeout(c).map(|timeout_s| CommandSpec { argv, timeout_s })
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
        (None, true) => None,
    }
}

/// `[[case]]`: the captures of a captured plan (a command plan must have
/// none). `base` holds `[capture]`'s segments, `None` when they are
/// invalid. Every problem clears `ok`; a case with a missing source or
/// incomplete conditions is still returned so that later ids are checked
/// against it.
fn case_entries(
    c: &mut Checker<'_>,
    cases: Vec<RawCaseEntry>,
    (captured, pwm_s): (bool, Option<f64>),
    plan_path: &Path,
    base: Option<SegmentSpec>,
    ok: &mut bool,
) -> Vec<CaptureCase> {
    if !captured && !cases.is_empty() {
        c.error(
            "case",
            "[[case]] lists captures, which only backend = \"captured\" reads",
            Some("a command plan makes its cases from [light] and [grid]"),
        );
        *ok = false;
    }
    let dir = plan_path.parent().unwrap_or(Path::new("."));
    let mut out: Vec<CaptureCase> = Vec::new();
    if captured && cases.is_empty() {
        c.error(
            "case",
            "a captured plan needs at least one [[case]]",
            Some("add [[case]] with source = \"path/to/capture.mp4\""),
        );
        *ok = false;
    }
    for (i, raw_case) in cases.into_iter().enumerate() {
        match case_entry(c, raw_case, (i, pwm_s), dir, base, &out, ok) {
            Some(case) => out.push(case),
            None => *ok = false,
        }
    }
    out
}

/// One `[[case]]`, `i` its index; `earlier` are the cases before it.
/// `pwm_s`, the `[sequence]` PWM segment's length, bounds its frequency.
fn case_entry(
    c: &mut Checker<'_>,
    raw_case: RawCaseEntry,
    (i, pwm_s): (usize, Option<f64>),
    dir: &Path,
    base: Option<SegmentSpec>,
    earlier: &[CaptureCase],
    ok: &mut bool,
) -> Option<CaptureCase> {
    let k = |s: &str| format!("case[{i}].{s}");
    let source_text = c.required(
        raw_case.source,
        &k("source"),
        "a capture: video, .y4m, a directory of PNG/TIFF frames, or a .csv trace",
    )?;
    let source = dir.join(&source_text);
    // A shipped plan's capture is built into the binary and read from
    // there when it is not on disk.
    if !source.exists() && crate::plan::shipped::data_at(&source).is_none() {
        c.error(
            &k("source"),
            format!("capture `{}` does not exist", source.display()),
            Some("paths are relative to the plan file's directory"),
        );
        *ok = false;
    }
    let light_lux = raw_case
        .light_lux
        .and_then(|v| grid::light_lux(c, v, &k("light-lux")));
    let frequency_hz = raw_case
        .frequency_hz
        .and_then(|v| grid::frequency_hz(c, v, &k("frequency-hz"), grid::frequency_range(pwm_s)));
    let duty = raw_case
        .duty_cycle
        .and_then(|v| grid::duty(c, v, &k("duty-cycle")));
    if let (Some(f), Some(_)) = (frequency_hz, duty) {
        grid::warn_low_frequency(
            c,
            (&k("frequency-hz"), "frequency-hz"),
            "a PWM frequency",
            f,
            " with a duty cycle",
        );
    }
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
        *ok = false;
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
            (Some(l), Some(f), Some(d)) => condition_id(l, f, d),
            _ => Path::new(&source_text)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| format!("case{i}")),
        },
    };
    case_id(c, &id, &k("id"), earlier)?;
    Some(CaptureCase {
        id,
        source,
        source_text,
        light_lux,
        frequency_hz,
        duty,
        segments: segs?,
        informative: raw_case.informative.unwrap_or(false),
    })
}

/// A case id: filename-safe and not used by an earlier case.
fn case_id(c: &mut Checker<'_>, id: &str, key: &str, earlier: &[CaptureCase]) -> Option<()> {
    if id.is_empty()
        || !id
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || ch == '-' || ch == '_' || ch == '.')
    {
        c.error(
            key,
            format!("case id `{id}` must be letters, digits, `-`, `_` or `.`"),
            Some("the id names the case's trace file; set id = \"...\""),
        );
        return None;
    }
    if earlier.iter().any(|o| o.id == id) {
        c.error(
            key,
            format!("case id `{id}` is used twice"),
            Some("give each [[case]] its own id = \"...\""),
        );
        return None;
    }
    Some(())
}
