//! `[recorder]`: the camera recorder of a command plan with a light
//! source, from the serde mirror to a validated [`RecorderConfig`].

use crate::plan::check::{Checker, approx};
use crate::plan::raw::RawRecorder;
use crate::plan::recorder::{
    PLACEHOLDERS, RecorderConfig, RecorderKind, fill_plan_placeholders, gstreamer_argv,
    unknown_placeholders,
};
use crate::plan::{Sequence, source::SourceConfig};

/// Seconds recorded after the sequence's end.
const TAIL_S_RANGE: (f64, f64) = (0.0, 600.0);
/// Default of `tail-s`: a second keeps the last PWM frames clear of a
/// camera that starts late.
const DEFAULT_TAIL_S: f64 = 1.0;

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
            (RecorderKind::Command, argv, "recorder.command")
        }
    };
    // A GStreamer pipeline holds no placeholders of the plan's, and its
    // caps may hold braces of their own (`format={I420,NV12}`).
    let unknown: Vec<String> = match kind {
        RecorderKind::GStreamer(_) => Vec::new(),
        RecorderKind::Command => argv.iter().flat_map(|a| unknown_placeholders(a)).collect(),
    };
    if !unknown.is_empty() {
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
        ok = false;
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
        RecorderKind::GStreamer(pipeline) => gstreamer_argv(pipeline, frames),
        RecorderKind::Command => argv
            .iter()
            .map(|a| fill_plan_placeholders(a, frames, duration_s, fps))
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
    })
}
