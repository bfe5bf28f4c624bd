//! Frame times rounded to a time base: a 29.97 fps
//! capture of a 151 Hz PWM LED in Matroska (1 ms time base), in MP4 with
//! a 1/90000 s time base, and as a CSV trace with times in whole
//! milliseconds, with and without dropped frames. The frames are made
//! here, not by the simulator; the truth is computed in closed form:
//! 30000/1001 fps, a beat of `|151 - 5 x 30000/1001| = 1.14985 Hz`
//! (`turn-indicator-like`, 1.0-2.0 Hz, docs/beyond-the-paper.md), and the
//! drops made.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

use crate::{scratch, stderr};

const F_HZ: f64 = 151.0;
const DUTY: f64 = 0.3;
const EXPOSURE_S: f64 = 0.010;
/// The camera's rate, as a ratio: frames/s = `FPS_NUM / FPS_DEN`.
const FPS_NUM: u64 = 30000;
const FPS_DEN: u64 = 1001;
const OFF_FRAMES: u64 = 30;
const PWM_FRAMES: u64 = 150;
/// Frame side, pixels (even, for 4:2:0 chroma).
const SIDE: usize = 16;
/// Frame slots that a capture "with drops" leaves out (all in the PWM
/// segment: one lone drop and a run of three).
const DROPS: [u64; 4] = [70, 110, 111, 112];

fn fps() -> f64 {
    FPS_NUM as f64 / FPS_DEN as f64
}

/// The true beat: 151 Hz less the nearest multiple of the frame rate.
fn beat_hz() -> f64 {
    (F_HZ - (F_HZ / fps()).round() * fps()).abs()
}

/// Time the PWM is ON in `[0, x]` cycles, in cycles: `floor(x) D +
/// min(frac(x), D)` for a rising edge at 0.
fn on_cycles(x: f64) -> f64 {
    x.floor() * DUTY + (x - x.floor()).min(DUTY)
}

/// Luma of a frame exposed over `[t, t + EXPOSURE_S]`: background 20,
/// the LED adds 200 times its ON fraction of the exposure (when lit).
fn luma(t: f64, lit: bool) -> u8 {
    let on = (on_cycles(F_HZ * (t + EXPOSURE_S)) - on_cycles(F_HZ * t)) / (F_HZ * EXPOSURE_S);
    (20.0 + if lit { 200.0 * on } else { 0.0 }).round() as u8
}

/// The slots a capture keeps: every one, or all but [`DROPS`].
fn slots(drops: bool) -> Vec<u64> {
    (0..OFF_FRAMES + PWM_FRAMES)
        .filter(|k| !(drops && DROPS.contains(k)))
        .collect()
}

/// The true start of slot `k`, seconds.
fn slot_time(k: u64) -> f64 {
    (k * FPS_DEN) as f64 / FPS_NUM as f64
}

/// Encodes every slot's frame (grey, `SIDE` x `SIDE`) at 30000/1001 fps
/// into `name` with `codec_args`, leaving out [`DROPS`] with a `select`
/// filter that keeps the other frames' timestamps.
fn encode(dir: &Path, name: &str, codec_args: &[&str], drops: bool) {
    let raw: Vec<u8> = (0..OFF_FRAMES + PWM_FRAMES)
        .flat_map(|k| vec![luma(slot_time(k), k >= OFF_FRAMES); SIDE * SIDE])
        .collect();
    std::fs::write(dir.join("frames.gray"), raw).unwrap();
    let keep = if drops {
        let gone: Vec<String> = DROPS.iter().map(|k| format!("eq(n\\,{k})")).collect();
        format!("select='not({})'", gone.join("+"))
    } else {
        "null".to_string()
    };
    let size = format!("{SIDE}x{SIDE}");
    let rate = format!("{FPS_NUM}/{FPS_DEN}");
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "gray"])
        .args(["-s", &size, "-framerate", &rate, "-i", "frames.gray"])
        .args(["-vf", &keep, "-fps_mode", "passthrough"])
        .args(codec_args)
        .arg(name)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Writes a CSV trace of the kept slots with times rounded to whole
/// milliseconds, as many loggers write them.
fn write_csv(dir: &Path, name: &str, drops: bool) {
    let mut csv = "time_s,led\n".to_string();
    for k in slots(drops) {
        let ms = (slot_time(k) * 1000.0).round();
        csv += &format!(
            "{:.3},{}\n",
            ms / 1000.0,
            luma(slot_time(k), k >= OFF_FRAMES)
        );
    }
    std::fs::write(dir.join(name), csv).unwrap();
}

/// Runs a one-case captured plan on `source` (the PWM conditions given
/// when `conditions`) and returns the case in results.json.
fn run(dir: &Path, source: &str, conditions: bool) -> Value {
    super::timing::run_case(dir, source, conditions, "", (4, 4))
}

/// The case reads the true rate (the stated one exactly when `stated`),
/// the true beat and class, and exactly the drops made, at resolution `q`.
fn check(case: &Value, what: &str, conditions: bool, drops: bool, q: f64, stated: bool) {
    let timing = &case["frame_timing"];
    let fps = timing["fps"].as_f64().unwrap();
    let sigma = timing["fps_uncertainty"].as_f64().unwrap();
    assert!(
        (fps - self::fps()).abs() <= sigma,
        "{what}: {fps} +/- {sigma} fps"
    );
    assert!(sigma < 0.01, "{what}: {sigma}");
    assert_eq!(timing["stated_rate_used"], stated, "{what}: {timing}");
    if stated {
        assert_eq!(fps, self::fps(), "{what}");
    }
    assert_eq!(timing["resolution_s"].as_f64(), Some(q), "{what}: {timing}");
    let dropped = if drops { DROPS.len() as u64 } else { 0 };
    assert_eq!(timing["dropped_frames"], dropped, "{what}: {timing}");
    assert_eq!(case["beat"]["frame_rate_fps"].as_f64(), Some(fps), "{what}");
    let fa = case["apparent_frequency_hz"].as_f64().unwrap();
    // Frame times: f_a moves 5 x the rate's error. Spectrum: a few
    // hundredths of its 0.2 Hz bin.
    let tolerance = if conditions { 5.0 * sigma + 1e-9 } else { 0.01 };
    assert!(
        (fa - beat_hz()).abs() <= tolerance,
        "{what}: apparent {fa} Hz, truth {} Hz",
        beat_hz()
    );
    assert_eq!(case["hazard_class"], "turn-indicator-like", "{what}");
    let note = case["beat"]["note"].as_str().unwrap();
    assert!(
        note.contains("fitted to the frames' own times"),
        "{what}: {note}"
    );
    assert_eq!(
        note.contains(&format!("{dropped} dropped frames")),
        drops,
        "{what}: {note}"
    );
}

#[test]
fn rounded_container_times_give_the_true_rate_beat_and_drops() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them"
    );
    let dir = scratch("time-base");
    let mkv = ["-c:v", "ffv1"];
    let mp4 = [
        "-c:v",
        "libx264",
        "-qp",
        "0",
        "-pix_fmt",
        "yuv420p",
        "-video_track_timescale",
        "90000",
    ];
    for drops in [false, true] {
        let tag = if drops { "drops" } else { "all" };
        let (mkv_name, mp4_name) = (format!("{tag}.mkv"), format!("{tag}.mp4"));
        encode(&dir, &mkv_name, &mkv, drops);
        encode(&dir, &mp4_name, &mp4, drops);
        for conditions in [true, false] {
            let case = run(&dir, &mkv_name, conditions);
            let what = format!("{mkv_name}, conditions {conditions}");
            check(&case, &what, conditions, drops, 1e-3, true);
            assert_eq!(case["capture"]["time_base_s"]["den"], 1000, "{what}");
            assert_eq!(case["capture"]["stated_frame_rate_fps"]["num"], FPS_NUM);
            // 1/90000 s: the times are exact, and the stated rate is used.
            let case = run(&dir, &mp4_name, conditions);
            let what = format!("{mp4_name}, conditions {conditions}");
            check(&case, &what, conditions, drops, 1.0 / 90_000.0, true);
            assert_eq!(case["capture"]["time_base_s"]["den"], 90_000, "{what}");
        }
    }
}

#[test]
fn a_csv_trace_with_millisecond_times_gives_the_true_rate_beat_and_drops() {
    let dir = scratch("time-base-csv");
    for drops in [false, true] {
        let name = format!("{drops}.csv");
        write_csv(&dir, &name, drops);
        for conditions in [true, false] {
            let case = run(&dir, &name, conditions);
            let what = format!("{name}, conditions {conditions}");
            // No container: no stated rate, the fit alone.
            check(&case, &what, conditions, drops, 1e-3, false);
        }
    }
}
