//! `[recorder]`: the camera recorder of a command plan with a light
//! source, from the serde mirror to a validated [`RecorderConfig`].

use crate::plan::check::{Checker, approx};
use crate::plan::raw::RawRecorder;
use crate::plan::recorder::{
    CameraSettings, PLACEHOLDERS, RecorderConfig, RecorderKind, SETTABLE_SOURCES,
    fill_plan_placeholders, gstreamer_argv, is_caps, pipeline_args, unknown_placeholders,
};
use crate::plan::{Sequence, source::SourceConfig};

/// Seconds recorded after the sequence's end.
const TAIL_S_RANGE: (f64, f64) = (0.0, 600.0);
/// Default of `tail-s`: a second keeps the last PWM frames clear of a
/// camera that starts late.
const DEFAULT_TAIL_S: f64 = 1.0;
/// Exposure a camera may be set to, microseconds (aravissrc takes up to
/// 1e8; no flicker test exposes a frame for more than 10 s).
const EXPOSURE_US_RANGE: (f64, f64) = (1.0, 1e7);
/// Gain a camera may be set to, decibels.
const GAIN_DB_RANGE: (f64, f64) = (0.0, 100.0);

/// Where `[recorder]` stands in the plan: the command backend drives the
/// light, the source's lead-in, the sequence and the camera's frame rate.
pub(super) struct RecorderContext<'a> {
    /// True for the command backend, the only one that records.
    pub command: bool,
    /// True when the plan has a `[source]` table (valid or not).
    pub source_given: bool,
    /// The validated `[source]`, for its lead-in.
    pub source: Option<&'a SourceConfig>,
    /// The validated `[sequence]`.
    pub sequence: Option<Sequence>,
    /// The camera's frame rate, frames/s.
    pub fps: Option<f64>,
}

/// Validates `[recorder]`. `None` when absent or invalid (an error was
/// pushed in the second case); the flag is true when invalid.
pub(super) fn recorder_table(
    c: &mut Checker<'_>,
    raw: Option<RawRecorder>,
    ctx: RecorderContext<'_>,
) -> (Option<RecorderConfig>, bool) {
    let Some(raw) = raw else {
        return (None, false);
    };
    if !ctx.command {
        c.error(
            "recorder",
            "only the command backend records a camera",
            Some("set [dut] backend = \"command\" and give a [source], or remove [recorder]"),
        );
        return (None, true);
    }
    if !ctx.source_given {
        c.error(
            "recorder",
            "a recorder records the light source's sequence, and the plan has no [source]",
            Some(
                "add a [source] table, or record with [capture] command (docs/command-backend.md)",
            ),
        );
        return (None, true);
    }
    let cfg = recorder_config(c, raw, &ctx);
    let failed = cfg.is_none();
    (cfg, failed)
}

fn recorder_config(
    c: &mut Checker<'_>,
    raw: RawRecorder,
    ctx: &RecorderContext<'_>,
) -> Option<RecorderConfig> {
    let mut ok = true;
    let tail_s = c.within(
        raw.tail_s.unwrap_or(DEFAULT_TAIL_S),
        "recorder.tail-s",
        TAIL_S_RANGE,
        " s",
        "seconds recorded after the sequence's end; default 1",
    );
    ok &= tail_s.is_some();
    let settings = camera_settings(c, &raw, ctx.fps);
    ok &= settings.is_some();
    let settings = settings.unwrap_or_default();
    // Whether each setting is given, valid or not: where it may go.
    let given = CameraSettings {
        exposure_us: raw.exposure_us,
        gain_db: raw.gain_db,
        frame_rate_fps: raw.frame_rate_fps,
    };
    let hint_one = "give `gstreamer = \"v4l2src device=/dev/video0\"` (a GStreamer source pipeline) or `command = [...]`";
    let (kind, argv, key) = match (raw.gstreamer, raw.command) {
        (Some(_), Some(_)) => {
            c.error(
                "recorder.command",
                "[recorder] takes `gstreamer` or `command`, not both",
                Some(hint_one),
            );
            return None;
        }
        (None, None) => {
            c.error(
                "recorder",
                "[recorder] needs `gstreamer` or `command`",
                Some(hint_one),
            );
            return None;
        }
        (Some(pipeline), None) => {
            if pipeline.trim().is_empty() {
                c.error(
                    "recorder.gstreamer",
                    "the source pipeline is empty",
                    Some("e.g. \"v4l2src device=/dev/video0\" or \"aravissrc camera-name=...\""),
                );
                return None;
            }
            ok &= gstreamer_settable(c, &pipeline, &given);
            (
                RecorderKind::GStreamer(pipeline),
                Vec::new(),
                "recorder.gstreamer",
            )
        }
        (None, Some(argv)) => {
            if argv.first().is_none_or(|p| p.is_empty()) {
                c.error(
                    "recorder.command",
                    "the command is empty",
                    Some("program and arguments, e.g. [\"sh\", \"record.sh\", \"{out-dir}\", \"{frames}\"]"),
                );
                return None;
            }
            ok &= command_uses_settings(c, &argv, &given);
            (RecorderKind::Command, argv, "recorder.command")
        }
    };
    // A GStreamer pipeline holds no placeholders of the plan's, and its
    // caps may hold braces of their own (`format={I420,NV12}`).
    if kind == RecorderKind::Command {
        ok &= placeholders_known(c, key, &argv);
    }
    let (tail_s, sequence, fps) = (tail_s?, ctx.sequence?, ctx.fps?);
    let lead_in_s = ctx.source?.lead_in_s;
    let duration_s = lead_in_s + sequence.on_s + sequence.off_s + sequence.pwm_s + tail_s;
    // A few parts per billion above a whole frame count is the sum's
    // rounding, not another frame.
    let frames = ((duration_s * fps) * (1.0 - 1e-9)).ceil().max(1.0) as u64;
    if !ok {
        return None;
    }
    let argv = match &kind {
        RecorderKind::GStreamer(pipeline) => gstreamer_argv(pipeline, frames, &settings),
        RecorderKind::Command => argv
            .iter()
            .map(|a| fill_plan_placeholders(a, frames, duration_s, fps, &settings))
            .collect(),
    };
    if frames > 1_000_000 {
        c.error(
            "recorder",
            format!(
                "one recording would hold {frames} frames ({} s at {} fps)",
                approx(duration_s),
                approx(fps)
            ),
            Some("at most 1000000: shorten [sequence], [source] lead-in-s or tail-s"),
        );
        return None;
    }
    Some(RecorderConfig {
        kind,
        argv,
        tail_s,
        duration_s,
        frames,
        settings,
    })
}

/// True when every placeholder of a recorder command is known; else an
/// error at `key` naming the unknown ones.
fn placeholders_known(c: &mut Checker<'_>, key: &str, argv: &[String]) -> bool {
    let unknown: Vec<String> = argv.iter().flat_map(|a| unknown_placeholders(a)).collect();
    if unknown.is_empty() {
        return true;
    }
    let known: Vec<String> = PLACEHOLDERS.iter().map(|p| format!("{{{p}}}")).collect();
    c.error(
        key,
        format!(
            "unknown placeholder{} {}",
            if unknown.len() == 1 { "" } else { "s" },
            unknown
                .iter()
                .map(|u| format!("`{{{u}}}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Some(&format!("the placeholders are {}", known.join(", "))),
    );
    false
}

/// `exposure-us`, `gain-db` and `frame-rate-fps`, each in range; the
/// frame rate must be the one the analysis uses. `None` after an error.
fn camera_settings(
    c: &mut Checker<'_>,
    raw: &RawRecorder,
    fps: Option<f64>,
) -> Option<CameraSettings> {
    let mut ok = true;
    let mut check = |c: &mut Checker<'_>, v: Option<f64>, key, range, unit, hint| {
        let v = v.map(|v| c.within(v, key, range, unit, hint));
        ok &= !matches!(v, Some(None));
        v.flatten()
    };
    let exposure_us = check(
        c,
        raw.exposure_us,
        "recorder.exposure-us",
        EXPOSURE_US_RANGE,
        " us",
        "the camera's exposure time in microseconds, e.g. 10000 for 10 ms",
    );
    let gain_db = check(
        c,
        raw.gain_db,
        "recorder.gain-db",
        GAIN_DB_RANGE,
        " dB",
        "the camera's gain in decibels, 0 for none",
    );
    let frame_rate_fps = raw.frame_rate_fps;
    if let (Some(set), Some(fps)) = (frame_rate_fps, fps)
        && (set - fps).abs() > 1e-9 * fps
    {
        c.error(
            "recorder.frame-rate-fps",
            format!(
                "the camera would be set to {} fps, and the analysis runs at [dut.camera] frame-rate-fps = {}",
                approx(set),
                approx(fps)
            ),
            Some("give both the camera's frame rate"),
        );
        ok = false;
    }
    ok.then_some(CameraSettings {
        exposure_us,
        gain_db,
        frame_rate_fps,
    })
}

/// True when the pipeline's quotes close and its first element takes the
/// exposure and gain asked for; else an error at the setting's key.
fn gstreamer_settable(c: &mut Checker<'_>, pipeline: &str, settings: &CameraSettings) -> bool {
    let args = match pipeline_args(pipeline) {
        Ok(args) => args,
        Err(e) => {
            c.error(
                "recorder.gstreamer",
                e,
                Some("quote a property value with spaces whole: features=\"Width=640 Height=480\""),
            );
            return false;
        }
    };
    let mut ok = true;
    if settings.frame_rate_fps.is_some()
        && args
            .last()
            .is_some_and(|a| is_caps(a) && a.contains("framerate="))
    {
        c.error(
            "recorder.frame-rate-fps",
            "the pipeline's last caps give a frame rate already",
            Some("give the frame rate once: remove `framerate=` from the caps, or frame-rate-fps"),
        );
        ok = false;
    }
    let first = args.first().map_or("", String::as_str);
    if SETTABLE_SOURCES.iter().any(|s| s.0 == first) {
        return ok;
    }
    for (key, set) in [
        ("recorder.exposure-us", settings.exposure_us.is_some()),
        ("recorder.gain-db", settings.gain_db.is_some()),
    ] {
        if set {
            c.error(
                key,
                format!("ledflicker sets the exposure and gain of aravissrc only, and the pipeline starts with `{first}`"),
                Some("set it in the pipeline (v4l2src: extra-controls=\"c,exposure_time_absolute=...\"), or remove the key"),
            );
            ok = false;
        }
    }
    ok
}

/// True when a recorder command takes each setting the plan gives, as its
/// placeholder, and names no placeholder of a setting the plan leaves out.
fn command_uses_settings(c: &mut Checker<'_>, argv: &[String], settings: &CameraSettings) -> bool {
    let mut ok = true;
    for (name, key, set) in [
        (
            "exposure-us",
            "recorder.exposure-us",
            settings.exposure_us.is_some(),
        ),
        ("gain-db", "recorder.gain-db", settings.gain_db.is_some()),
    ] {
        let used = argv.iter().any(|a| a.contains(&format!("{{{name}}}")));
        if set && !used {
            c.error(
                key,
                format!("the recorder command takes no `{{{name}}}`: the setting would not reach the camera"),
                Some(&format!("pass `{{{name}}}` to the command, or remove `{name}`")),
            );
            ok = false;
        } else if used && !set {
            c.error(
                "recorder.command",
                format!("the command takes `{{{name}}}`, and [recorder] sets no `{name}`"),
                Some(&format!("add `{name} = ...` to [recorder]")),
            );
            ok = false;
        }
    }
    ok
}
