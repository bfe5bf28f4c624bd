//! The camera recorder through real GStreamer pipelines (`gst-launch-1.0`,
//! docs/lab.md), against the SCPI instrument simulator: a flickering
//! scene (the simulator's frames, read by `multifilesrc` at the camera's
//! pace) whose FDI and Percent Flicker are known from the simulator
//! backend, and Aravis' fake GigE Vision camera on loopback recorded
//! through `aravissrc`, with the exposure, gain and frame rate the plan
//! sets. They fail, never skip, without GStreamer and Aravis (installed
//! by scripts/test.sh).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::lab_bench::SimulatedBench;
use crate::{root, scratch, stderr};

/// Fails the test when a GStreamer element is missing.
fn require_elements(elements: &[&str]) {
    for e in elements {
        // `gst-inspect-1.0 --exists` misses Aravis' element (1.22).
        let found = Command::new("gst-inspect-1.0")
            .arg(e)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        assert!(
            found,
            "GStreamer element `{e}` not found: run scripts/test.sh, which installs gstreamer1.0-tools, gstreamer1.0-plugins-base, gstreamer1.0-plugins-good and aravis-tools"
        );
    }
}

/// The shipped bench plan with one case (137 Hz, 10 %), as `name` in
/// `dir`: its recorder replaced by `recorder` (the lines of a
/// `[recorder]` table; none without) and `capture` added to its
/// `[capture]` table.
fn one_case_bench(dir: &Path, name: &str, recorder: Option<&str>, capture: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("test-plans/bench-example.toml")).unwrap();
    let (head, tail) = text.split_once("[recorder]\n").unwrap();
    let tail = &tail[tail.find("[thresholds]").unwrap()..];
    let head = head
        .replace("frequencies-hz = [50.0, 137.0]", "frequencies-hz = [137.0]")
        .replace("[capture]\n", &format!("[capture]\n{capture}"));
    assert!(head.contains("[137.0]") && head.contains(capture), "{head}");
    let recorder = recorder
        .map(|r| format!("[recorder]\n{r}\n"))
        .unwrap_or_default();
    let path = dir.join(name);
    std::fs::write(&path, format!("{head}{recorder}{tail}")).unwrap();
    path
}

fn results(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

/// Frames in a Y4M file: its `FRAME` headers.
fn y4m_frames(path: &Path) -> usize {
    let bytes = std::fs::read(path).unwrap();
    let header = bytes.iter().position(|&b| b == b'\n').unwrap() + 1;
    let line = String::from_utf8_lossy(&bytes[..header]).into_owned();
    let size = |tag: char| -> usize {
        line.split(' ')
            .find_map(|f| f.strip_prefix(tag).and_then(|v| v.trim().parse().ok()))
            .unwrap()
    };
    // I420: a luma plane and two quarter-size chroma planes.
    let frame = size('W') * size('H') * 3 / 2 + "FRAME\n".len();
    assert_eq!((bytes.len() - header) % frame, 0, "{line}");
    (bytes.len() - header) / frame
}

/// The frames of a camera looking at the PWM LED of the bench plan's
/// only case (137 Hz, 10 %): the dark lead-in (0.5 s), ON, OFF, PWM
/// (`ledflicker render`, the plan's camera) and the dark tail (0.5 s), as
/// `f_%06d.png` in `scene`.
fn render_scene(dir: &Path) -> PathBuf {
    let render = dir.join("render");
    let o = crate::ledflicker(&[
        "render",
        "--frequency-hz",
        "137",
        "--duty",
        "0.1",
        "--fps",
        "30",
        "--exposure-ms",
        "11.111",
        "--shutter",
        "rolling",
        "--line-time-us",
        "14.565",
        "--on-s",
        "1",
        "--off-s",
        "1",
        "--pwm-s",
        "2",
        "--width",
        "64",
        "--height",
        "48",
        "--out",
        render.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let scene = dir.join("scene");
    std::fs::create_dir_all(&scene).unwrap();
    // A frame inside the OFF segment (frames 30..60) is the dark.
    let dark = render.join("frame_000045.png");
    let mut n = 0;
    let mut add = |from: &Path| {
        std::fs::copy(from, scene.join(format!("f_{n:06}.png"))).unwrap();
        n += 1;
    };
    (0..15).for_each(|_| add(&dark));
    for i in 0..120 {
        add(&render.join(format!("frame_{i:06}.png")));
    }
    (0..15).for_each(|_| add(&dark));
    scene
}

#[test]
fn lab_gstreamer_recording_of_a_flickering_scene_gives_the_known_fdi_and_percent_flicker() {
    require_elements(&[
        "multifilesrc",
        "pngdec",
        "identity",
        "videoconvert",
        "y4menc",
        "filesink",
    ]);
    let dir = scratch("lab-gst-scene");
    let scene = render_scene(&dir);
    // `identity sync=true` hands the frames on at 30 fps, as a camera
    // would, while the light source plays the sequence.
    let recorder = format!(
        "gstreamer = \"multifilesrc location={}/f_%06d.png index=0 caps=image/png,framerate=30/1 ! pngdec ! identity sync=true\"\nframe-rate-fps = 30.0\ntail-s = 0.5",
        scene.display()
    );
    // GStreamer passes the grey levels through unscaled and y4menc tags
    // no range: the recording is full range.
    let plan = one_case_bench(
        &dir,
        "gst.toml",
        Some(&recorder),
        "video-range = \"full\"\n",
    );
    let bench = SimulatedBench::start(&dir);
    let started = Instant::now();
    let o = bench.run(
        &[
            "plan",
            plan.to_str().unwrap(),
            "--out",
            "gst",
            "-q",
            "--keep-captures",
        ],
        &dir,
    );
    let took = started.elapsed();
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    assert!(!stderr(&o).contains("more than a frame"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("kept 1 recording(s) in"),
        "{}",
        stderr(&o)
    );
    // The same frames without GStreamer: a rig that leaves them as they
    // are, the light source played the same way.
    let copy = format!(
        "command = [\"sh\", \"-c\", \"cp {}/f_*.png \\\"$LEDFLICKER_OUT_DIR\\\"\"]\n",
        scene.display()
    );
    let direct = one_case_bench(&dir, "direct.toml", None, &copy);
    let d = bench.run(
        &["plan", direct.to_str().unwrap(), "--out", "direct", "-q"],
        &dir,
    );
    assert!(matches!(d.status.code(), Some(0 | 1)), "{}", stderr(&d));
    // The same grid on the simulator backend.
    let text = std::fs::read_to_string(&plan).unwrap();
    let (head, tail) = text.split_once("[capture]").unwrap();
    let tail = &tail[tail.find("[thresholds]").unwrap()..];
    let simulator = head.replace("backend = \"command\"", "backend = \"simulator\"");
    std::fs::write(dir.join("sim.toml"), format!("{simulator}{tail}")).unwrap();
    let s = crate::ledflicker_in(&["plan", "sim.toml", "--out", "sim", "-q"], &dir);
    assert!(matches!(s.status.code(), Some(0 | 1)), "{}", stderr(&s));
    let runs = ["gst", "direct", "sim"].map(|r| results(&dir.join(r)));
    let [g, d, s] = [0, 1, 2].map(|i| &runs[i]["cases"][0]);
    assert_eq!(g["id"], "2000lux-137hz-10pct");
    // The verdict of the same grid on the simulator backend.
    assert_eq!(g["verdict"], s["verdict"], "{g}\n{s}");
    assert_eq!(g["verdict"], "pass", "{g}");
    for key in ["fdi_2018", "percent_flicker"] {
        let metric = |c: &serde_json::Value| c["rois"][0]["metrics"][key].as_f64().unwrap();
        let (x, y, z) = (metric(g), metric(d), metric(s));
        eprintln!("{key}: GStreamer recording {x}, the frames read directly {y}, simulator {z}");
        // A flickering scene, not a steady one.
        assert!(y > 0.1, "{key}: {y}");
        // GStreamer hands on every frame and grey level unchanged, and
        // the same segments are found in them: the known values.
        assert!((x - y).abs() <= 1e-9 * y, "{key}: {x} vs {y}");
        // The simulator's frames fall at another PWM phase than the
        // rendered ones: its values differ by up to 15 %.
        assert!((x - z).abs() <= 0.15 * z, "{key}: {x} vs {z}");
    }
    // The recording went through GStreamer at the frame rate set, and was
    // kept: every frame of the recorder's count (0.5 s lead-in, 4 s of
    // sequence, 0.5 s tail at 30 fps).
    let capture = &g["capture"];
    assert_eq!(capture["camera"]["frame_rate_fps"], 30.0, "{capture}");
    assert_eq!(capture["camera"]["frame_rate_read_fps"], 30.0, "{capture}");
    assert!(capture["camera"]["exposure_us"].is_null(), "{capture}");
    assert_eq!(capture["kept"], "captures/2000lux-137hz-10pct", "{capture}");
    let kept = dir.join("gst/captures/2000lux-137hz-10pct/camera.y4m");
    assert_eq!(y4m_frames(&kept), 150);
    assert_eq!(capture["segments"]["capture_frames"], 150, "{capture}");
    eprintln!("GStreamer scene run: {took:?}");
}

/// Aravis' fake GigE Vision camera, serving on loopback in a process group
/// of its own until dropped.
struct FakeCamera {
    child: std::process::Child,
    name: String,
}

impl FakeCamera {
    fn start() -> Self {
        use std::os::unix::process::CommandExt;
        let serial = format!("LF{}", std::process::id());
        let child = Command::new("arv-fake-gv-camera-0.8")
            .args(["-i", "127.0.0.1", "-s", &serial])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .process_group(0)
            .spawn()
            .expect("arv-fake-gv-camera-0.8 not found: run scripts/test.sh, which installs aravis-tools");
        let camera = Self {
            child,
            name: format!("Aravis-Fake-{serial}"),
        };
        // Found on the network: the camera answers a register read.
        let started = Instant::now();
        while !camera.read(&["Width"]).contains("Width") {
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "the fake camera {} is not found",
                camera.name
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        camera
    }

    /// `arv-tool-0.8 control` reading `features`: its stdout, empty when
    /// it does not answer within 10 s.
    fn read(&self, features: &[&str]) -> String {
        let mut c = Command::new("timeout");
        c.args(["10", "arv-tool-0.8", "-n", &self.name, "control"])
            .args(features);
        c.output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default()
    }
}

impl Drop for FakeCamera {
    fn drop(&mut self) {
        // SAFETY: kill(2) on the process group of the child this test started.
        unsafe {
            libc::kill(-(self.child.id() as libc::pid_t), libc::SIGKILL);
        }
        let _ = self.child.wait();
    }
}

#[test]
fn lab_aravis_fake_camera_is_recorded_through_aravissrc_with_the_plans_settings() {
    require_elements(&["aravissrc", "videoconvert", "y4menc", "filesink"]);
    let dir = scratch("lab-aravis");
    let camera = FakeCamera::start();
    // The fake camera shows a fixed pattern, whose steps cannot be found:
    // the segments are given.
    let recorder = format!(
        "gstreamer = \"aravissrc camera-name={} ! video/x-raw,width=64,height=48\"\nexposure-us = 5000.0\ngain-db = 2.0\nframe-rate-fps = 30.0\ntail-s = 0.5",
        camera.name
    );
    let plan = one_case_bench(
        &dir,
        "aravis.toml",
        Some(&recorder),
        "off-frames = [0, 15]\npwm-frames = [75]\n",
    );
    let bench = SimulatedBench::start(&dir);
    let mut run = bench.command(
        &["plan", plan.to_str().unwrap(), "--out", "out", "-q"],
        &dir,
    );
    // As root, Aravis receives the stream on a packet socket, which sees
    // no loopback traffic; without CAP_NET_RAW it takes a UDP socket.
    // SAFETY: geteuid(2) has no preconditions.
    if unsafe { libc::geteuid() } == 0 {
        let mut wrapped = Command::new("setpriv");
        wrapped
            .args(["--bounding-set", "-net_raw", "--"])
            .arg(run.get_program())
            .args(run.get_args())
            .current_dir(&dir);
        for (k, v) in run.get_envs() {
            match v {
                Some(v) => wrapped.env(k, v),
                None => wrapped.env_remove(k),
            };
        }
        run = wrapped;
    }
    let started = Instant::now();
    let o = run.output().unwrap();
    eprintln!("aravis run: {:?}", started.elapsed());
    assert!(matches!(o.status.code(), Some(0 | 1 | 4)), "{}", stderr(&o));
    let r = results(&dir.join("out"));
    let case = &r["cases"][0];
    let capture = &case["capture"];
    // Every frame arrived, at the camera's 64 x 48, at the rate set.
    assert!(
        capture["format"].as_str().unwrap().contains("64x48"),
        "{capture}"
    );
    assert_eq!(capture["camera"]["frame_rate_read_fps"], 30.0, "{capture}");
    assert_eq!(capture["camera"]["exposure_us"], 5000.0, "{capture}");
    assert_eq!(capture["camera"]["gain_db"], 2.0, "{capture}");
    // Read back from the camera: its exposure (the fake camera's
    // `ExposureTimeAbs`); its gain is raw only (`GainRaw`), so not in dB.
    assert_eq!(capture["camera"]["exposure_read_us"], 5000.0, "{capture}");
    assert!(capture["camera"]["gain_read_db"].is_null(), "{capture}");
    assert_eq!(capture["segments"]["capture_frames"], 150, "{capture}");
    // The camera took the settings.
    let read = camera.read(&["ExposureTimeAbs", "GainRaw", "AcquisitionFrameRate"]);
    assert!(read.contains("ExposureTimeAbs = 5000"), "{read}");
    assert!(read.contains("GainRaw = 2"), "{read}");
    assert!(read.contains("AcquisitionFrameRate = 30"), "{read}");
    // The recorder ended with the run, and the recording was removed.
    let leftover = Command::new("pgrep")
        .args(["-f", &format!("camera-name={}", camera.name)])
        .output()
        .unwrap();
    assert!(leftover.stdout.is_empty(), "a recorder is still running");
    assert!(!dir.join("out/captures").exists());
}
