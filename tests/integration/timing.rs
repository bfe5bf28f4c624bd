//! Captures' own timing: a 29.97 fps capture of a 151 Hz PWM
//! LED, made here by a generator independent of the simulator, shows its
//! true beat `|151 - 5 x 30000/1001| = 1.14985 Hz`, with and without the
//! light's conditions in the plan; coverage is counted from the real frame
//! times; drops in a sidecar are folded where they fell.

use std::path::Path;

use serde_json::Value;

use crate::{ledflicker_in as ledflicker, scratch, stderr};

const F_HZ: f64 = 151.0;
const DUTY: f64 = 0.3;
const EXPOSURE_S: f64 = 0.010;
const FPS: f64 = 30000.0 / 1001.0;
const OFF_FRAMES: usize = 30;
/// The true beat: 151 Hz is 5.0383 frames' worth of cycles per frame.
const BEAT_HZ: f64 = 1.1499;

/// ON fraction of `[t, t + EXPOSURE_S]` for a PWM with a rising edge at 0,
/// by the midpoint rule over 4000 slices (not the tool's closed form).
fn on_fraction(t: f64) -> f64 {
    let slices = 4000;
    let on = (0..slices)
        .filter(|&i| {
            let s = t + (i as f64 + 0.5) * EXPOSURE_S / slices as f64;
            (s * F_HZ).fract() < DUTY
        })
        .count();
    on as f64 / slices as f64
}

/// Luma of a frame starting at `t` (LED lit when `lit`): background 20,
/// LED up to 220, rounded to 8 bits.
fn luma(t: f64, lit: bool) -> u8 {
    let led = if lit { 200.0 * on_fraction(t) } else { 0.0 };
    (20.0 + led).round() as u8
}

/// Writes a full-range 8x8 Y4M at 30000/1001 fps, one frame per time.
fn write_y4m(path: &Path, times: &[f64]) {
    let mut bytes = b"YUV4MPEG2 W8 H8 F30000:1001 C420jpeg XCOLORRANGE=FULL\n".to_vec();
    for (k, &t) in times.iter().enumerate() {
        bytes.extend_from_slice(b"FRAME\n");
        bytes.extend(vec![luma(t, k >= OFF_FRAMES); 64]);
        bytes.extend(vec![128u8; 32]);
    }
    std::fs::write(path, bytes).unwrap();
}

/// Runs a one-case captured plan on `c.y4m` and returns its case.
fn run(dir: &Path, conditions: bool) -> Value {
    run_source(dir, "c.y4m", conditions)
}

/// Runs a one-case captured plan on `source` and returns its case in
/// results.json.
fn run_source(dir: &Path, source: &str, conditions: bool) -> Value {
    run_case(dir, source, conditions, "frame-rate-fps = 29.97\n", (0, 0))
}

/// Runs a one-case captured plan on `source` (151 Hz at duty 0.3 given
/// when `conditions`; OFF for the first 30 frames, then PWM), with
/// `capture_keys` added to its `[capture]` table and an 8 x 8 LED ROI at
/// `roi_xy`, and returns the case in results.json.
pub(crate) fn run_case(
    dir: &Path,
    source: &str,
    conditions: bool,
    capture_keys: &str,
    (x, y): (u32, u32),
) -> Value {
    let cond = if conditions {
        format!("light-lux = 1000\nfrequency-hz = {F_HZ}\nduty-cycle = {DUTY}\n")
    } else {
        String::new()
    };
    let plan = format!(
        "[plan]\nid = \"t\"\ntitle = \"t\"\n[dut]\nbackend = \"captured\"\n[capture]\n{capture_keys}off-frames = [0, {OFF_FRAMES}]\npwm-frames = [{OFF_FRAMES}]\n[[case]]\nid = \"c\"\nsource = \"{source}\"\n{cond}[[roi]]\nname = \"led\"\nx-px = {x}\ny-px = {y}\nwidth-px = 8\nheight-px = 8\n"
    );
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    let out = dir.join("out");
    let o = ledflicker(
        &["plan", "plan.toml", "--out", out.to_str().unwrap(), "-q"],
        dir,
    );
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    json["cases"][0].clone()
}

/// Bins of 64 hit by the PWM phases `frac(151 t)` of the PWM frames.
fn covered(times: &[f64]) -> usize {
    let mut hit = [false; 64];
    for t in &times[OFF_FRAMES..] {
        hit[((t * F_HZ).fract() * 64.0) as usize % 64] = true;
    }
    hit.iter().filter(|&&h| h).count()
}

fn check(case: &Value, times: &[f64], conditions: bool) {
    let fa = case["apparent_frequency_hz"].as_f64().unwrap();
    assert!((fa - BEAT_HZ).abs() < 0.01, "apparent {fa} Hz");
    let method = case["beat"]["method"].as_str().unwrap();
    assert_eq!(
        method,
        if conditions {
            "frame-times"
        } else {
            "spectrum"
        }
    );
    let fps = case["beat"]["frame_rate_fps"].as_f64().unwrap();
    assert!((fps - FPS).abs() < 1e-6, "{fps} fps");
    // Visible (PF well above 2 %) at 1.15 Hz: mistaken for a turn signal.
    assert_eq!(case["hazard_class"], "turn-indicator-like", "{case}");
    let roi = &case["rois"][0]["analysis"];
    assert_eq!(roi["hazard_class"], "turn-indicator-like");
    let want = covered(times);
    let got = roi["phase_coverage"]["covered_bins"].as_u64().unwrap() as usize;
    if conditions {
        assert_eq!(got, want, "coverage");
    } else {
        // Folded by the measured beat: the same bins up to a reflection,
        // give or take the bins the small beat error drifts across.
        assert!(got.abs_diff(want) <= 2, "coverage {got} vs {want}");
    }
}

#[test]
fn a_2997_fps_capture_of_151_hz_shows_its_true_beat() {
    let dir = scratch("timing-2997");
    // 4 s of PWM: 120 frames, about 4.6 beats.
    let times: Vec<f64> = (0..OFF_FRAMES + 120).map(|k| k as f64 / FPS).collect();
    write_y4m(&dir.join("c.y4m"), &times);
    // At an assumed 30 fps, 151 Hz advances exactly 1/30 cycle per frame
    // and hits 30 bins at most; the real times hit more.
    assert!(covered(&times) > 30, "{}", covered(&times));
    for conditions in [true, false] {
        let case = run(&dir, conditions);
        check(&case, &times, conditions);
    }
}

#[test]
fn dropped_frames_fold_at_their_real_times() {
    let dir = scratch("timing-drops");
    // Every 7th frame slot of the PWM segment dropped; the sidecar says when
    // each kept frame was taken.
    let times: Vec<f64> = (0..OFF_FRAMES + 240)
        .filter(|k| *k < OFF_FRAMES || k % 7 != 3)
        .map(|k| k as f64 / FPS)
        .collect();
    write_y4m(&dir.join("c.y4m"), &times);
    let sidecar: String = times.iter().map(|t| format!("{t}\n")).collect();
    std::fs::write(dir.join("c.y4m.timestamps.csv"), sidecar).unwrap();
    for conditions in [true, false] {
        let case = run(&dir, conditions);
        check(&case, &times, conditions);
        assert!(
            case["beat"]["note"]
                .as_str()
                .unwrap()
                .contains("dropped frames"),
            "{}",
            case["beat"]["note"]
        );
    }
}

/// The same capture as an H.264 MP4: the container's timestamps give the
/// frame rate (ffmpeg writes a 30000/1001 time base).
#[test]
fn an_h264_capture_at_2997_fps_uses_its_container_timestamps() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them"
    );
    let dir = scratch("timing-h264");
    let times: Vec<f64> = (0..OFF_FRAMES + 120).map(|k| k as f64 / FPS).collect();
    write_y4m(&dir.join("c.y4m"), &times);
    let o = std::process::Command::new("ffmpeg")
        .args([
            "-v", "error", "-y", "-i", "c.y4m", "-c:v", "libx264", "-qp", "0",
        ])
        .args(["-pix_fmt", "yuv420p", "c.mp4"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    for conditions in [true, false] {
        let case = run_source(&dir, "c.mp4", conditions);
        check(&case, &times, conditions);
    }
}
