//! `[recorder]`: the camera recorder of a command plan with a light
//! source (docs/lab.md). ledflicker starts it once per case, as the
//! command backend starts a `[capture] command`, and plays the light
//! source's sequence while it records; it stops by itself after a fixed
//! number of frames, which covers the dark lead-in, the sequence and a
//! tail. The recording is read like any capture (a Y4M file, a video or
//! frames in `{out-dir}`).
//!
//! Two kinds: a GStreamer source pipeline (a camera through V4L2, GenICam
//! through Aravis' `aravissrc`, an RTSP stream, a frame grabber's plugin),
//! which ledflicker completes into a `gst-launch-1.0` command that writes
//! a Y4M file; or any command, whose arguments may hold the recording's
//! numbers as placeholders.

/// The program a GStreamer recorder runs.
pub const GST_LAUNCH: &str = "gst-launch-1.0";

/// Placeholders a recorder's arguments may hold. `{out-dir}` is the
/// case's output directory, filled when the case starts; the others are
/// the same for every case and are filled when the plan is loaded.
pub const PLACEHOLDERS: &[&str] = &["out-dir", "frames", "duration-s", "fps"];

/// What the camera is recorded with.
#[derive(Debug, Clone, PartialEq)]
pub enum RecorderKind {
    /// A GStreamer source pipeline (`gstreamer = "v4l2src ..."`), as
    /// written in the plan.
    GStreamer(String),
    /// A command of the plan's own (`command = [...]`).
    Command,
}

/// `[recorder]`, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct RecorderConfig {
    /// How the camera is recorded.
    pub kind: RecorderKind,
    /// The command run per case: program and arguments, every placeholder
    /// but `{out-dir}` filled.
    pub argv: Vec<String>,
    /// Seconds recorded after the sequence's end (>= 0).
    pub tail_s: f64,
    /// Seconds one recording lasts: the light source's lead-in, the
    /// sequence and the tail.
    pub duration_s: f64,
    /// Frames one recording holds: `duration_s` at the camera's frame
    /// rate, rounded up (>= 1).
    pub frames: u64,
}

/// The `gst-launch-1.0` command that records `frames` frames of `source`
/// (a source pipeline, its elements apart at white space) into
/// `{out-dir}/camera.y4m`. `identity eos-after` ends the stream after the
/// last frame whatever the source (a live camera never ends by itself;
/// `num-buffers` is not a property of every source, e.g. `rtspsrc`), and
/// `-e` turns the end of stream into a complete file. The frames are
/// converted to I420, which `y4menc` writes and the Y4M reader reads.
pub fn gstreamer_argv(source: &str, frames: u64) -> Vec<String> {
    let mut argv: Vec<String> = [GST_LAUNCH, "-q", "-e"].map(String::from).to_vec();
    argv.extend(source.split_whitespace().map(String::from));
    argv.extend(
        [
            "!",
            "identity",
            &format!("eos-after={frames}"),
            "!",
            "videoconvert",
            "!",
            "video/x-raw,format=I420",
            "!",
            "y4menc",
            "!",
            "filesink",
            "location={out-dir}/camera.y4m",
        ]
        .map(String::from),
    );
    argv
}

/// The placeholders in `text` that are not in [`PLACEHOLDERS`].
pub fn unknown_placeholders(text: &str) -> Vec<String> {
    let mut unknown = Vec::new();
    let mut rest = text;
    while let Some(open) = rest.find('{') {
        let after = &rest[open + 1..];
        let Some(close) = after.find('}') else {
            break;
        };
        let name = &after[..close];
        if !PLACEHOLDERS.contains(&name) {
            unknown.push(name.to_string());
        }
        rest = &after[close + 1..];
    }
    unknown
}

/// `text` with the per-plan placeholders filled: `{frames}`,
/// `{duration-s}` (at most 6 decimals, no exponent) and `{fps}`.
pub fn fill_plan_placeholders(text: &str, frames: u64, duration_s: f64, fps: f64) -> String {
    text.replace("{frames}", &frames.to_string())
        .replace("{duration-s}", &plain(duration_s))
        .replace("{fps}", &plain(fps))
}

/// A number with at most 6 decimals and no exponent: `30`, `4.5`.
fn plain(x: f64) -> String {
    let s = format!("{x:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gstreamer_recorder_ends_after_its_frames_and_writes_y4m() {
        let argv = gstreamer_argv(
            "v4l2src device=/dev/video0 ! video/x-raw,framerate=30/1",
            165,
        );
        assert_eq!(argv[..3], ["gst-launch-1.0", "-q", "-e"]);
        // Each element and `!` is its own argument: gst-launch escapes the
        // white space inside one argument.
        assert_eq!(argv[3..6], ["v4l2src", "device=/dev/video0", "!"]);
        assert!(argv.contains(&"eos-after=165".to_string()), "{argv:?}");
        assert_eq!(argv.last().unwrap(), "location={out-dir}/camera.y4m");
    }

    #[test]
    fn placeholders_are_filled_and_unknown_ones_named() {
        assert_eq!(
            fill_plan_placeholders(
                "{frames} {duration-s} {fps} {out-dir}",
                91,
                3.0000001,
                29.97
            ),
            "91 3 29.97 {out-dir}"
        );
        assert_eq!(
            unknown_placeholders("a {fps} {frame} {out_dir} {"),
            ["frame", "out_dir"]
        );
        assert!(unknown_placeholders("{out-dir}/x.y4m").is_empty());
    }

    /// A command plan with `[capture]` table text `capture` and the
    /// tables `rest` (a `[source]`, a `[recorder]`).
    fn plan_with(capture: &str, rest: &str) -> Result<crate::plan::Plan, String> {
        let text = format!(
            "[plan]\nid = \"r\"\ntitle = \"r\"\n[sequence]\non-s = 1.0\noff-s = 1.0\npwm-s = 2.0\n[light]\nlevels-lux = [2000.0]\n[grid]\nfrequencies-hz = [90.0]\nduty-cycles = [0.1]\n[[roi]]\nname = \"led\"\nx-px = 10\ny-px = 20\nwidth-px = 40\nheight-px = 2\n[dut]\nbackend = \"command\"\n[dut.camera]\nshutter = \"global\"\nsensor-rows = 48\nsensor-columns = 64\nexposure-ms = 10.0\nframe-rate-fps = 25.0\nresponse-dn-per-cd-m2-s = 1.0\n{capture}{rest}"
        );
        crate::plan::parse(&text, std::path::Path::new("r.toml"), String::new())
            .map_err(|e| e.to_string())
    }

    const SOURCE: &str =
        "[source]\ninstrument = \"keysight-33500b\"\nhost = \"h\"\nlead-in-s = 0.5\n";

    #[test]
    fn a_recorder_becomes_the_plans_command_for_the_whole_recording() {
        let plan = plan_with(
            "[capture]\ntimeout-s = 30.0\n",
            &format!("{SOURCE}[recorder]\ngstreamer = \"aravissrc camera-name=Fake_1 ! video/x-raw,format={{GRAY8,I420}}\"\n"),
        )
        .unwrap();
        let rec = plan.recorder.unwrap();
        // Lead-in 0.5 s, 1 + 1 + 2 s of sequence, the default 1 s tail.
        assert!((rec.duration_s - 5.5).abs() < 1e-12, "{}", rec.duration_s);
        assert_eq!(rec.frames, 138);
        let cmd = plan.capture.unwrap().command.unwrap();
        assert_eq!(cmd.argv, rec.argv);
        assert_eq!(cmd.argv[3..5], ["aravissrc", "camera-name=Fake_1"]);
        assert!(cmd.argv.contains(&"eos-after=138".to_string()));
        assert!((cmd.timeout_s - 30.0).abs() < 1e-12);
        let plan = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ncommand = [\"rec\", \"{{out-dir}}/a.y4m\", \"{{frames}}\", \"{{duration-s}}\"]\ntail-s = 0\n"),
        )
        .unwrap();
        assert_eq!(
            plan.capture.unwrap().command.unwrap().argv,
            ["rec", "{out-dir}/a.y4m", "113", "4.5"]
        );
    }

    #[test]
    fn recorder_mistakes_are_errors_at_their_keys() {
        let rec = "[recorder]\ngstreamer = \"v4l2src\"\n";
        let e = plan_with(
            "[capture]\ncommand = [\"true\"]\n",
            &format!("{SOURCE}{rec}"),
        )
        .unwrap_err();
        assert!(
            e.contains("`capture.command`: the plan records the camera with [recorder]"),
            "{e}"
        );
        let e = plan_with("", rec).unwrap_err();
        assert!(e.contains("`recorder`: a recorder records the light source's sequence, and the plan has no [source]"), "{e}");
        let e = plan_with("", &format!("{SOURCE}[recorder]\ntail-s = 1.0\n")).unwrap_err();
        assert!(
            e.contains("`recorder`: [recorder] needs `gstreamer` or `command`"),
            "{e}"
        );
        let e = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ncommand = [\"rec\", \"{{out}}\"]\ntail-s = -1.0\n"),
        )
        .unwrap_err();
        assert!(
            e.contains("`recorder.command`: unknown placeholder `{out}`"),
            "{e}"
        );
        assert!(
            e.contains("`recorder.tail-s`: -1 s is below the 0 s limit"),
            "{e}"
        );
        let e = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ncamera = \"x\"\ngstreamer = \"v4l2src\"\n"),
        )
        .unwrap_err();
        assert!(e.contains("`recorder.camera`: unknown key"), "{e}");
    }
}
