//! Capture inputs that must be refused, not waited on or misread: a FIFO
//! where a capture, a frame, a sidecar or a rig's frame is read; Ctrl-C
//! during a long read; frames of one capture that differ in bit depth or
//! channels; CSV luma values out of range.
//!
//! Every run that could hang has a deadline: a regression fails the test
//! instead of hanging CI.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::{Ran, mkfifo, run_with_deadline, scratch};

/// Longest a refusal may take. A FIFO that is waited on never ends, so
/// anything past this is a hang.
const DEADLINE: Duration = Duration::from_secs(20);

/// Runs `ledflicker plan PLAN --out DIR/o -q` in `dir`, killed at
/// `deadline`; then releases `fifos`.
fn plan_with_deadline(dir: &Path, plan: &Path, fifos: &[PathBuf], deadline: Duration) -> Ran {
    let out = dir.join("o");
    let args = [
        "plan",
        plan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    run_with_deadline(&args, dir, fifos, deadline)
}

/// A captured plan with one case and one ROI, as `dir/plan.toml`.
fn one_case_plan(dir: &Path, source: &str, roi: (u32, u32, u32, u32), extra: &str) -> PathBuf {
    let text = format!(
        "[plan]\nid = \"t\"\ntitle = \"t\"\n[dut]\nbackend = \"captured\"\n[capture]\nframe-rate-fps = 30.0\n{extra}\n[[case]]\nsource = \"{source}\"\n[[roi]]\nname = \"a\"\nx-px = {}\ny-px = {}\nwidth-px = {}\nheight-px = {}\n",
        roi.0, roi.1, roi.2, roi.3
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Asserts that `ran` is a refusal with exit `code` whose message holds
/// every needle.
fn assert_refused(ran: &Ran, code: i32, needles: &[&str]) {
    assert!(
        ran.code.is_some(),
        "still running after {} s (waiting on a FIFO?); stderr: {}",
        DEADLINE.as_secs(),
        ran.stderr
    );
    assert_eq!(ran.code, Some(code), "{}", ran.stderr);
    for n in needles {
        assert!(ran.stderr.contains(n), "`{n}` not in: {}", ran.stderr);
    }
    assert!(!ran.stderr.contains("panicked"), "{}", ran.stderr);
}

/// A plan whose capture `name` is a FIFO exits 2 at once, naming it.
fn fifo_source_is_refused(tag: &str, name: &str) {
    let dir = scratch(tag);
    let fifo = dir.join(name);
    mkfifo(&fifo);
    let plan = one_case_plan(&dir, name, (0, 0, 1, 1), "");
    let ran = plan_with_deadline(&dir, &plan, &[fifo], DEADLINE);
    assert_refused(&ran, 2, &[name, "FIFO", "not a regular file"]);
}

#[test]
fn a_fifo_as_y4m_source_is_refused_not_waited_on() {
    fifo_source_is_refused("fifo-y4m", "c.y4m");
}

#[test]
fn a_fifo_as_csv_source_is_refused_not_waited_on() {
    fifo_source_is_refused("fifo-csv", "t.csv");
}

#[test]
fn a_fifo_as_png_source_is_refused_not_waited_on() {
    fifo_source_is_refused("fifo-png", "f.png");
}

/// A FIFO handed to ffprobe and ffmpeg would block them (the watchdog
/// stops them only after 120 s): it is refused before either starts.
#[test]
fn a_fifo_as_video_source_is_refused_before_ffmpeg_starts() {
    fifo_source_is_refused("fifo-video", "v.mp4");
}

fn save_grey8(path: &Path, w: u32, h: u32, v: u8) {
    image::GrayImage::from_pixel(w, h, image::Luma([v]))
        .save(path)
        .unwrap();
}

#[test]
fn a_fifo_as_one_frame_of_a_frame_directory_is_refused() {
    let dir = scratch("fifo-frame");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    save_grey8(&frames.join("f0.png"), 4, 4, 10);
    let fifo = frames.join("f1.png");
    mkfifo(&fifo);
    save_grey8(&frames.join("f2.png"), 4, 4, 10);
    let plan = one_case_plan(&dir, "frames", (0, 0, 1, 1), "");
    let ran = plan_with_deadline(&dir, &plan, &[fifo], DEADLINE);
    assert_refused(&ran, 2, &["f1.png", "frame 1", "FIFO"]);
}

/// A FIFO where the timestamp sidecar goes is refused, not skipped (its
/// times would be silently replaced by the frame rate's).
#[test]
fn a_fifo_as_timestamp_sidecar_is_refused_not_skipped() {
    let dir = scratch("fifo-sidecar");
    let mut text = String::from("frame,a\n");
    for k in 0..20 {
        text += &format!("{k},{}\n", if k < 5 { 10 } else { 50 + 40 * (k % 2) });
    }
    std::fs::write(dir.join("t.csv"), text).unwrap();
    let fifo = dir.join("t.csv.timestamps.csv");
    mkfifo(&fifo);
    let plan = one_case_plan(
        &dir,
        "t.csv",
        (0, 0, 1, 1),
        "off-frames = [0, 5]\npwm-frames = [5]",
    );
    let ran = plan_with_deadline(&dir, &plan, &[fifo], DEADLINE);
    assert_refused(&ran, 2, &["t.csv.timestamps.csv", "FIFO"]);
}

/// A rig that leaves a FIFO among its frames: the rig has exited, so its
/// `timeout-s` cannot help; the frame is refused (a backend error, exit 3,
/// as every unreadable frame of a rig is).
#[test]
fn a_fifo_left_by_a_rig_as_a_png_frame_is_refused() {
    let dir = scratch("fifo-rig");
    let plan = dir.join("plan.toml");
    let text = RIG_PLAN.replace(
        "RIG",
        "[\"sh\", \"-c\", \"mkfifo \\\"$LEDFLICKER_OUT_DIR/f000.png\\\"\"]",
    );
    std::fs::write(&plan, &text).unwrap();
    let ran = plan_with_deadline(&dir, &plan, &[], DEADLINE);
    assert_refused(&ran, 3, &["f000.png", "FIFO"]);
    // A FIFO as the one capture file is refused too, not passed over.
    std::fs::write(&plan, text.replace("f000.png", "cap.y4m")).unwrap();
    let ran = plan_with_deadline(&dir, &plan, &[], DEADLINE);
    assert_refused(&ran, 3, &["cap.y4m", "FIFO"]);
}

/// Ctrl-C while a large Y4M file is read (a sparse 64 GiB file: 2048
/// frames of 4096 x 4096 16-bit samples, which takes far longer than a
/// second to read) stops the run within a second, with exit 130.
#[test]
fn ctrl_c_during_a_long_y4m_read_exits_130_within_a_second() {
    let dir = scratch("sigint-y4m");
    let path = dir.join("long.y4m");
    let (w, h, frames) = (4096u64, 4096u64, 2048u64);
    let header = format!("YUV4MPEG2 W{w} H{h} F30:1 Cmono16\n");
    let frame_len = 6 + w * h * 2;
    {
        let mut f = std::fs::File::create(&path).unwrap();
        f.write_all(header.as_bytes()).unwrap();
        for k in 0..frames {
            std::os::unix::fs::FileExt::write_all_at(
                &f,
                b"FRAME\n",
                header.len() as u64 + k * frame_len,
            )
            .unwrap();
        }
        f.set_len(header.len() as u64 + frames * frame_len).unwrap();
    }
    let plan = one_case_plan(&dir, "long.y4m", (0, 0, 1, 1), "");
    interrupt_after_a_second(&dir, &plan, &path);
}

/// Ctrl-C while the run's inputs are hashed (a rig command naming a
/// sparse 64 GiB file, hashed as a rig script before any case runs) stops
/// the run within a second, with exit 130.
#[test]
fn ctrl_c_while_inputs_are_hashed_exits_130_within_a_second() {
    let dir = scratch("sigint-hash");
    let path = dir.join("big.dat");
    std::fs::File::create(&path)
        .unwrap()
        .set_len(64 << 30)
        .unwrap();
    let plan = dir.join("plan.toml");
    let text = RIG_PLAN.replace("RIG", "[\"true\", \"./big.dat\"]");
    std::fs::write(&plan, text).unwrap();
    interrupt_after_a_second(&dir, &plan, &path);
}

/// A command plan (one case, 8 x 8 global-shutter camera) whose
/// `[capture] command` is `RIG`.
const RIG_PLAN: &str = "[plan]\nid = \"t\"\ntitle = \"t\"\n[sequence]\non-s = 0.5\noff-s = 0.5\npwm-s = 1.0\n\
    [light]\nlevels-lux = [2000.0]\n[grid]\nfrequencies-hz = [90.0]\nduty-cycles = [0.5]\n\
    [[roi]]\nname = \"led\"\nx-px = 0\ny-px = 0\nwidth-px = 1\nheight-px = 1\n\
    [dut]\nbackend = \"command\"\n[dut.camera]\nshutter = \"global\"\nsensor-rows = 8\n\
    sensor-columns = 8\nexposure-ms = 1.0\nframe-rate-fps = 30.0\nresponse-dn-per-cd-m2-s = 1.0\n\
    [capture]\ncommand = RIG\ntimeout-s = 5.0\n";

/// Runs `plan`, sends SIGINT after a second, and checks that the run
/// stops within a second of it with exit 130, writing no report; then
/// removes the sparse file `big` (no disk, but 64 GiB to tools that sum
/// sizes).
fn interrupt_after_a_second(dir: &Path, plan: &Path, big: &Path) {
    let err_path = dir.join("stderr.txt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["plan", plan.to_str().unwrap(), "--out"])
        .arg(dir.join("o"))
        .arg("-q")
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(1));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the run ended before the signal: {}",
        std::fs::read_to_string(&err_path).unwrap_or_default()
    );
    // SAFETY: kill(2) on the child this test started.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let signalled = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if signalled.elapsed() >= Duration::from_secs(5) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let took = signalled.elapsed();
    let _ = std::fs::remove_file(big);
    let err = std::fs::read_to_string(&err_path).unwrap_or_default();
    let status = status.unwrap_or_else(|| panic!("still reading 5 s after SIGINT: {err}"));
    assert!(
        took <= Duration::from_secs(1),
        "stopped {took:?} after SIGINT"
    );
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("SIGINT"), "{err}");
    assert!(!dir.join("o/results.json").exists());
}

/// Runs `plan` (no FIFO: no deadline needed beyond the usual).
fn plan_exit(dir: &Path, plan: &Path) -> Ran {
    plan_with_deadline(dir, plan, &[], DEADLINE)
}

/// 8-bit OFF frames followed by 16-bit PWM frames: the 8-bit DN would be
/// read on the 16-bit scale (FDI 513 instead of 1). Refused, naming the
/// first frame that differs and how.
#[test]
fn mixed_bit_depths_in_one_capture_are_refused() {
    let dir = scratch("mixed-depth");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..4 {
        save_grey8(&frames.join(format!("f{k:02}.png")), 8, 4, 10);
    }
    for k in 4..10u16 {
        let v = if k % 2 == 0 { 30000 } else { 20000 };
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(8, 4, image::Luma([v]))
            .save(frames.join(format!("f{k:02}.png")))
            .unwrap();
    }
    let plan = one_case_plan(
        &dir,
        "frames",
        (0, 0, 2, 2),
        "off-frames = [0, 4]\npwm-frames = [4]",
    );
    let ran = plan_exit(&dir, &plan);
    assert_refused(
        &ran,
        2,
        &[
            "f04.png",
            "frame 4",
            "16-bit",
            "frame 0 is 8-bit",
            "bit depth",
        ],
    );
}

/// Grey frames followed by RGB frames: refused like mixed bit depths.
#[test]
fn mixed_channel_counts_in_one_capture_are_refused() {
    let dir = scratch("mixed-channels");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..4 {
        save_grey8(&frames.join(format!("f{k:02}.png")), 8, 4, 10);
    }
    for k in 4..10u8 {
        let v = if k % 2 == 0 { 200 } else { 120 };
        image::RgbImage::from_pixel(8, 4, image::Rgb([v, v, v]))
            .save(frames.join(format!("f{k:02}.png")))
            .unwrap();
    }
    let plan = one_case_plan(
        &dir,
        "frames",
        (0, 0, 2, 2),
        "off-frames = [0, 4]\npwm-frames = [4]",
    );
    let ran = plan_exit(&dir, &plan);
    assert_refused(
        &ran,
        2,
        &[
            "f04.png",
            "frame 4",
            "3 channels",
            "frame 0 has 1",
            "channel",
        ],
    );
}

/// CSV luma of 1e307 to 1e308 DN overflowed the metrics (Percent Flicker
/// `inf`); such values are refused at read time, naming the line and the
/// column, as are negative ones.
#[test]
fn csv_luma_values_out_of_range_are_refused_naming_line_and_column() {
    let dir = scratch("csv-huge");
    let write = |v: &dyn Fn(usize) -> String| {
        let mut text = String::from("frame,time_s,a\n");
        for k in 0..20 {
            text += &format!("{k},{},{}\n", k as f64 / 25.0, v(k));
        }
        std::fs::write(dir.join("t.csv"), text).unwrap();
    };
    let plan = one_case_plan(
        &dir,
        "t.csv",
        (0, 0, 1, 1),
        "off-time-s = [0.0, 0.2]\npwm-time-s = [0.2]",
    );
    write(&|k| {
        (if k < 5 {
            "1e307"
        } else if k % 2 == 0 {
            "1e308"
        } else {
            "5e307"
        })
        .to_string()
    });
    let ran = plan_exit(&dir, &plan);
    assert_refused(&ran, 2, &["t.csv", "line 2", "column `a`", "1e307", "1e12"]);
    write(&|k| {
        if k == 7 {
            "-3".to_string()
        } else {
            "100".to_string()
        }
    });
    let ran = plan_exit(&dir, &plan);
    assert_refused(&ran, 2, &["t.csv", "line 9", "column `a`", "-3"]);
    // The bound itself is accepted (with a saturation level above it).
    let plan = one_case_plan(
        &dir,
        "t.csv",
        (0, 0, 1, 1),
        "saturation-dn = 2e12\noff-time-s = [0.0, 0.2]\npwm-time-s = [0.2]",
    );
    write(&|k| {
        (if k < 5 {
            "1e11"
        } else if k % 2 == 0 {
            "1e12"
        } else {
            "5e11"
        })
        .to_string()
    });
    let ran = plan_exit(&dir, &plan);
    assert!(matches!(ran.code, Some(0 | 1)), "{}", ran.stderr);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("o/results.json")).unwrap())
            .unwrap();
    let pf = &json["cases"][0]["rois"][0]["metrics"]["percent_flicker"];
    let pf = pf.as_f64().unwrap_or_else(|| panic!("{pf}"));
    assert!((pf - 100.0 * 5e11 / 15e11).abs() < 1e-9, "{pf}");
}

/// `linetime`, `bands` and `calibrate` read frame files through the same
/// readers: a FIFO given as a frame (a still, a Y4M file, a video) is
/// refused at once.
#[test]
fn a_fifo_given_to_linetime_as_a_frame_is_refused() {
    let dir = scratch("fifo-linetime");
    for name in ["f.png", "c.y4m", "v.mp4"] {
        let fifo = dir.join(name);
        mkfifo(&fifo);
        let args = ["linetime", name, "--frequency-hz", "500"];
        let ran = run_with_deadline(&args, &dir, &[fifo], DEADLINE);
        assert_refused(&ran, 2, &[name, "FIFO", "not a regular file"]);
    }
}

/// Frames of two bit depths given to `linetime` are refused, naming the
/// first frame of the other depth.
#[test]
fn mixed_bit_depths_given_to_linetime_are_refused() {
    let dir = scratch("mixed-depth-linetime");
    save_grey8(&dir.join("a.png"), 64, 48, 100);
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(64, 48, image::Luma([25600]))
        .save(dir.join("b.png"))
        .unwrap();
    let args = ["linetime", "a.png", "b.png", "--frequency-hz", "500"];
    let ran = run_with_deadline(&args, &dir, &[], DEADLINE);
    assert_refused(&ran, 2, &["b.png", "16-bit", "8-bit", "mixed bit depths"]);
}

/// A device where a capture is read (here /dev/null, through a symbolic
/// link with the capture's name) is refused as one, naming the capture.
#[test]
fn a_device_as_capture_source_is_refused() {
    let dir = scratch("device-source");
    for name in ["t.csv", "c.y4m", "f.png", "v.mp4"] {
        std::os::unix::fs::symlink("/dev/null", dir.join(name)).unwrap();
        let plan = one_case_plan(&dir, name, (0, 0, 1, 1), "");
        let ran = plan_with_deadline(&dir, &plan, &[], DEADLINE);
        assert_refused(&ran, 2, &[name, "is a device, not a regular file"]);
    }
}
