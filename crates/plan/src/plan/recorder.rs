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
/// the same for every case and are filled when the plan is loaded
/// (`{exposure-us}` and `{gain-db}` only when `[recorder]` sets them).
pub const PLACEHOLDERS: &[&str] = &[
    "out-dir",
    "frames",
    "duration-s",
    "fps",
    "exposure-us",
    "gain-db",
];

/// The GStreamer source elements whose exposure and gain ledflicker sets,
/// with their property names: Aravis' `aravissrc` takes the exposure in
/// microseconds and the gain in decibels (its element's documentation,
/// `gst-inspect-1.0 aravissrc`). V4L2 drivers give the gain no unit, so
/// `v4l2src` gets its controls in the pipeline (`extra-controls`).
pub const SETTABLE_SOURCES: &[(&str, &str, &str)] = &[("aravissrc", "exposure", "gain")];

/// The camera settings `[recorder]` asks for; each `None` when the plan
/// leaves it to the camera.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CameraSettings {
    /// Exposure time, microseconds (> 0).
    pub exposure_us: Option<f64>,
    /// Gain, decibels (>= 0).
    pub gain_db: Option<f64>,
    /// Frame rate, frames/s (> 0); equal to `[dut.camera] frame-rate-fps`.
    pub frame_rate_fps: Option<f64>,
}

impl CameraSettings {
    /// True when nothing is set.
    pub fn is_empty(&self) -> bool {
        self.exposure_us.is_none() && self.gain_db.is_none() && self.frame_rate_fps.is_none()
    }
}

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
    /// The camera settings it applies.
    pub settings: CameraSettings,
}

/// The `gst-launch-1.0` command that records `frames` frames of `source`
/// (a source pipeline) into `{out-dir}/camera.y4m`, with `settings`
/// applied. `identity eos-after` ends the stream after the last frame
/// whatever the source (a live camera never ends by itself; `num-buffers`
/// is not a property of every source, e.g. `rtspsrc`), and `-e` turns the
/// end of stream into a complete file. `identity` ends the stream in
/// place of its `eos-after`-th buffer (GStreamer 1.22 writes 149 frames
/// with `eos-after=150`), so it is given one more than `frames`. The
/// frames are converted to I420, which `y4menc` writes and the Y4M reader
/// reads.
///
/// The exposure and gain become properties of the first element (an
/// element of [`SETTABLE_SOURCES`]; validation refuses others), and the
/// frame rate caps after the source pipeline, which a camera source
/// negotiates its rate from: added to the pipeline's last caps when it
/// ends with caps (two caps in a row are not a pipeline), else a caps
/// filter of their own.
pub fn gstreamer_argv(source: &str, frames: u64, settings: &CameraSettings) -> Vec<String> {
    let mut argv: Vec<String> = [GST_LAUNCH, "-q", "-e"].map(String::from).to_vec();
    let mut args = pipeline_args(source).unwrap_or_default();
    let end_of_first = args.iter().position(|a| a == "!").unwrap_or(args.len());
    if let Some((_, exposure, gain)) = args
        .first()
        .and_then(|first| SETTABLE_SOURCES.iter().find(|s| s.0 == first))
    {
        let mut props = Vec::new();
        if let Some(us) = settings.exposure_us {
            props.push(format!("{exposure}={}", plain(us)));
        }
        if let Some(db) = settings.gain_db {
            props.push(format!("{gain}={}", plain(db)));
        }
        args.splice(end_of_first..end_of_first, props);
    }
    if let Some(fps) = settings.frame_rate_fps {
        let (num, den) = fraction(fps);
        match args.last_mut() {
            Some(last) if is_caps(last) => last.push_str(&format!(",framerate={num}/{den}")),
            _ => args.extend([
                "!".to_string(),
                format!("video/x-raw,framerate={num}/{den}"),
            ]),
        }
    }
    argv.extend(args);
    argv.extend(
        [
            "!",
            "identity",
            &format!("eos-after={}", frames + 1),
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

/// True when a pipeline argument is caps (`video/x-raw,width=64`): its
/// media type holds a `/`, which no element name or property does.
pub fn is_caps(arg: &str) -> bool {
    let media = arg.split(',').next().unwrap_or_default();
    media.contains('/') && !media.contains('=')
}

/// A source pipeline's arguments for `gst-launch-1.0`: apart at white
/// space, except inside double quotes, which are removed, as a shell does
/// with `features="ExposureAuto=Off GainAuto=Off"` (gst-launch keeps the spaces of
/// one argument in one property value). `Err` names an unclosed quote.
pub fn pipeline_args(source: &str) -> Result<Vec<String>, String> {
    let mut args = Vec::new();
    let mut current: Option<String> = None;
    let mut quoted = false;
    for ch in source.chars() {
        match ch {
            '"' => {
                quoted = !quoted;
                current.get_or_insert_with(String::new);
            }
            c if c.is_whitespace() && !quoted => {
                if let Some(a) = current.take() {
                    args.push(a);
                }
            }
            c => current.get_or_insert_with(String::new).push(c),
        }
    }
    if quoted {
        return Err("a double quote is not closed".to_string());
    }
    args.extend(current);
    Ok(args)
}

/// `fps` as a GStreamer fraction: whole rates over 1, others in
/// thousandths, reduced (29.97 -> 2997/100).
fn fraction(fps: f64) -> (u64, u64) {
    let milli = (fps * 1000.0).round() as u64;
    let gcd = |mut a: u64, mut b: u64| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a.max(1)
    };
    let g = gcd(milli, 1000);
    (milli / g, 1000 / g)
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
/// `{duration-s}` (at most 6 decimals, no exponent), `{fps}`, and the
/// settings that are set (`{exposure-us}`, `{gain-db}`).
pub fn fill_plan_placeholders(
    text: &str,
    frames: u64,
    duration_s: f64,
    fps: f64,
    settings: &CameraSettings,
) -> String {
    let mut text = text
        .replace("{frames}", &frames.to_string())
        .replace("{duration-s}", &plain(duration_s))
        .replace("{fps}", &plain(fps));
    if let Some(us) = settings.exposure_us {
        text = text.replace("{exposure-us}", &plain(us));
    }
    if let Some(db) = settings.gain_db {
        text = text.replace("{gain-db}", &plain(db));
    }
    text
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
            &CameraSettings::default(),
        );
        assert_eq!(argv[..3], ["gst-launch-1.0", "-q", "-e"]);
        // Each element and `!` is its own argument: gst-launch escapes the
        // white space inside one argument.
        assert_eq!(argv[3..6], ["v4l2src", "device=/dev/video0", "!"]);
        assert!(argv.contains(&"eos-after=166".to_string()), "{argv:?}");
        assert_eq!(argv.last().unwrap(), "location={out-dir}/camera.y4m");
    }

    #[test]
    fn aravis_gets_exposure_and_gain_and_every_source_the_frame_rate_caps() {
        let settings = CameraSettings {
            exposure_us: Some(2500.0),
            gain_db: Some(6.5),
            frame_rate_fps: Some(29.97),
        };
        let argv = gstreamer_argv(
            "aravissrc camera-name=Fake \"features=Width=64 Height=48\" ! video/x-raw,format=GRAY8",
            10,
            &settings,
        );
        assert_eq!(
            argv[3..13],
            [
                "aravissrc",
                "camera-name=Fake",
                "features=Width=64 Height=48",
                "exposure=2500",
                "gain=6.5",
                "!",
                "video/x-raw,format=GRAY8,framerate=2997/100",
                "!",
                "identity",
                "eos-after=11"
            ]
        );
        // Another source gets the frame rate only (validation refuses
        // exposure and gain for it), as caps of their own.
        let argv = gstreamer_argv("v4l2src", 10, &settings);
        assert_eq!(
            argv[3..6],
            ["v4l2src", "!", "video/x-raw,framerate=2997/100"]
        );
        assert!(is_caps("image/png,framerate=30/1"));
        assert!(!is_caps("location=/tmp/f_%06d.png"));
        assert_eq!(fraction(30.0), (30, 1));
        assert_eq!(fraction(12.5), (25, 2));
        assert_eq!(pipeline_args("a \"b c\"d  e").unwrap(), ["a", "b cd", "e"]);
        assert!(pipeline_args("a \"b").is_err());
    }

    #[test]
    fn placeholders_are_filled_and_unknown_ones_named() {
        assert_eq!(
            fill_plan_placeholders(
                "{frames} {duration-s} {fps} {out-dir}",
                91,
                3.0000001,
                29.97,
                &CameraSettings::default()
            ),
            "91 3 29.97 {out-dir}"
        );
        let set = CameraSettings {
            exposure_us: Some(10000.0),
            gain_db: Some(0.0),
            frame_rate_fps: None,
        };
        assert_eq!(
            fill_plan_placeholders("{exposure-us} {gain-db}", 1, 1.0, 30.0, &set),
            "10000 0"
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
        assert!(cmd.argv.contains(&"eos-after=139".to_string()));
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

    #[test]
    fn camera_settings_reach_the_recorder_or_are_errors_at_their_keys() {
        let plan = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ngstreamer = \"aravissrc camera-name=C\"\nexposure-us = 8000.0\ngain-db = 3.0\nframe-rate-fps = 25.0\n"),
        )
        .unwrap();
        let rec = plan.recorder.unwrap();
        assert_eq!(rec.settings.exposure_us, Some(8000.0));
        assert!(
            rec.argv.contains(&"exposure=8000".to_string()),
            "{:?}",
            rec.argv
        );
        assert!(rec.argv.contains(&"gain=3".to_string()), "{:?}", rec.argv);
        assert!(rec.argv.contains(&"video/x-raw,framerate=25/1".to_string()));
        let e = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ngstreamer = \"v4l2src ! video/x-raw,framerate=30/1\"\nframe-rate-fps = 25.0\n"),
        )
        .unwrap_err();
        assert!(
            e.contains(
                "`recorder.frame-rate-fps`: the pipeline's last caps give a frame rate already"
            ),
            "{e}"
        );
        let plan = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ncommand = [\"rec\", \"{{exposure-us}}\"]\nexposure-us = 250.5\n"),
        )
        .unwrap();
        assert_eq!(plan.recorder.unwrap().argv, ["rec", "250.5"]);
        let e = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ngstreamer = \"v4l2src\"\nexposure-us = 0.5\ngain-db = 1.0\nframe-rate-fps = 30.0\n"),
        )
        .unwrap_err();
        for want in [
            "`recorder.exposure-us`: 0.5 us is below the 1 us limit",
            "`recorder.gain-db`: ledflicker sets the exposure and gain of aravissrc only, and the pipeline starts with `v4l2src`",
            "`recorder.frame-rate-fps`: the camera would be set to 30 fps, and the analysis runs at [dut.camera] frame-rate-fps = 25",
        ] {
            assert!(e.contains(want), "{want} not in {e}");
        }
        let e = plan_with(
            "",
            &format!(
                "{SOURCE}[recorder]\ncommand = [\"rec\", \"{{gain-db}}\"]\nexposure-us = 100.0\n"
            ),
        )
        .unwrap_err();
        assert!(
            e.contains("`recorder.exposure-us`: the recorder command takes no `{exposure-us}`"),
            "{e}"
        );
        assert!(e.contains("`recorder.command`: the command takes `{gain-db}`, and [recorder] sets no `gain-db`"), "{e}");
        let e = plan_with(
            "",
            &format!("{SOURCE}[recorder]\ngstreamer = \"aravissrc \\\"features=Width=64\"\n"),
        )
        .unwrap_err();
        assert!(
            e.contains("`recorder.gstreamer`: a double quote is not closed"),
            "{e}"
        );
    }
}
