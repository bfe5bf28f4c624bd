//! Colour flicker of a captured RGB recording (docs/visibility.md,
//! section 6): a red PWM lamp filmed by a camera whose green plane is
//! exposed 1 ms after its red one, written here as 8-bit RGB PNG frames
//! and as a lossless RGB video, gives its Δu′v′, its frames outside the
//! UN R48 red region and each plane's FMI, FDI and MMP, as computed here
//! in closed form; a greyscale capture of a colour plan is refused.
//!
//! The video case needs the `ffmpeg` binary; scripts/test.sh installs it.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

use crate::captured::run_plan;
use crate::{ledflicker_in as ledflicker, scratch, stderr};

/// The camera's linear R, G, B to X, Y, Z: sRGB's with a red primary deep
/// enough for a signal red (x 0.700, y 0.295), as test-plans/cms-colour.toml.
const CAMERA_TO_XYZ: [[f64; 3]; 3] = [
    [0.4746, 0.3576, 0.1805],
    [0.2000, 0.7152, 0.0722],
    [0.0034, 0.1192, 0.9505],
];

/// Frame period 34 ms (29.41 fps), every exposure 2 ms; the green plane's
/// starts 1 ms after the frame's, the red and blue planes' with it.
const FRAME_MS: f64 = 34.0;
const EXPOSURE_MS: f64 = 2.0;
const PLANE_OFFSET_MS: [f64; 3] = [0.0, 1.0, 0.0];
/// The lamp at 125 Hz (8 ms period), on for 6 ms (75 % duty) from each
/// rise at 7 ms modulo 8.
const PERIOD_MS: f64 = 8.0;
const ON_MS: f64 = 6.0;
const RISE_MS: f64 = 7.0;
/// DN each plane reads over a whole exposure of the lit lamp: a red that
/// the camera sees with 1.5 % of green and no blue.
const LAMP_DN: [f64; 3] = [200.0, 3.0, 0.0];
/// Frames 0-7 OFF, 8-15 steady ON, 16-55 PWM (ten 4-frame cycles).
const OFF: (usize, usize) = (0, 8);
const ON: (usize, usize) = (8, 16);
const FRAMES: usize = 56;
/// The lamp fills columns 0-7 of each 16 x 8 frame; columns 8-15 are a
/// steady grey road.
const ROAD_DN: u8 = 50;

/// Milliseconds of `[a, b)` in which the PWM lamp is on: the exact
/// integral of its square wave.
fn lit_ms(a: f64, b: f64) -> f64 {
    let up_to = |t: f64| {
        let u = t - RISE_MS;
        let cycles = (u / PERIOD_MS).floor();
        cycles * ON_MS + (u - cycles * PERIOD_MS).min(ON_MS)
    };
    up_to(b) - up_to(a)
}

/// The lamp's R, G, B in frame `k`: dark, steady, or each plane's share of
/// its own exposure window that the PWM lamp is on.
fn lamp_rgb(k: usize) -> [f64; 3] {
    if k < OFF.1 {
        return [0.0; 3];
    }
    if k < ON.1 {
        return LAMP_DN;
    }
    let start = k as f64 * FRAME_MS;
    [0, 1, 2].map(|p| {
        let a = start + PLANE_OFFSET_MS[p];
        LAMP_DN[p] * lit_ms(a, a + EXPOSURE_MS) / EXPOSURE_MS
    })
}

/// The PWM frames' R, G, B, by hand: frame `k` starts `2k + 1` ms (mod 8)
/// after a rise, so the cycle of four frames sees the lamp at 1, 3, 5 and
/// 7 ms. Red reads [1, 3) and [3, 5) whole, half of [5, 7) and half of
/// [7, 9); green, 1 ms later, reads [2, 4) and [4, 6) whole, none of
/// [6, 8) and the whole of [8, 10). Every DN is a whole number, so 8-bit
/// frames hold the planes exactly and nothing below is a quantisation
/// tolerance.
const PWM_CYCLE: [[f64; 3]; 4] = [
    [200.0, 3.0, 0.0],
    [200.0, 3.0, 0.0],
    [100.0, 0.0, 0.0],
    [100.0, 3.0, 0.0],
];

/// Writes the recording's frames as 8-bit RGB PNG files into `dir`.
fn write_frames(dir: &Path) {
    write_frames_on(dir, [0; 3]);
}

/// [`write_frames`] with every pixel's R, G and B on a pedestal of
/// `pedestal` DN: a camera's black level.
fn write_frames_on(dir: &Path, pedestal: [u8; 3]) {
    std::fs::create_dir_all(dir).unwrap();
    for k in 0..FRAMES {
        let rgb = lamp_rgb(k);
        for v in rgb {
            assert_eq!(v, v.round(), "frame {k}: {rgb:?} is not whole DN");
        }
        if k >= ON.1 {
            assert_eq!(rgb, PWM_CYCLE[(k - ON.1) % 4], "frame {k}");
        }
        let lamp = image::Rgb([0, 1, 2].map(|p| rgb[p] as u8 + pedestal[p]));
        let road = image::Rgb(pedestal.map(|b| ROAD_DN + b));
        image::RgbImage::from_fn(16, 8, |x, _| if x < 8 { lamp } else { road })
            .save(dir.join(format!("f{k:03}.png")))
            .unwrap();
    }
}

/// A captured plan of one case, `source`, with the lamp's colour judged
/// against the red region; `camera` is the `[dut.camera]` table.
fn colour_plan(dir: &Path, source: &str, camera: &str) -> PathBuf {
    let text = format!(
        r#"[plan]
id = "captured-colour"
title = "A captured red PWM lamp with a chroma shift"

[dut]
backend = "captured"

{camera}

[capture]
colour-transfer = "linear"
frame-rate-fps = {fps}
off-frames = [{}, {}]
on-frames = [{}, {}]
pwm-frames = [{}]

[[case]]
id = "lamp"
source = "{source}"

[[roi]]
name = "lamp"
kind = "led"
x-px = 0
y-px = 0
width-px = 8
height-px = 8

[[roi]]
name = "road"
kind = "background"
x-px = 8
y-px = 0
width-px = 8
height-px = 8

[scene]
led-chromaticity-xy = [0.6931, 0.3003]
signal-colour = "red"

[display]
preset = "night"
refresh-hz = 60.0
image-width-px = 16
"#,
        OFF.0,
        OFF.1,
        ON.0,
        ON.1,
        ON.1,
        fps = 1000.0 / FRAME_MS,
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn matrix_camera() -> String {
    let rows: Vec<String> = CAMERA_TO_XYZ
        .iter()
        .map(|r| format!("  [{:?}, {:?}, {:?}],", r[0], r[1], r[2]))
        .collect();
    format!("[dut.camera]\ncamera-to-xyz = [\n{}\n]", rows.join("\n"))
}

/// CIE 1976 u′v′ of camera `rgb` through the matrix.
fn uv(rgb: [f64; 3]) -> (f64, f64) {
    let [x, y, z] = CAMERA_TO_XYZ.map(|r| r[0] * rgb[0] + r[1] * rgb[1] + r[2] * rgb[2]);
    let d = x + 15.0 * y + 3.0 * z;
    (4.0 * x / d, 9.0 * y / d)
}

/// UN R48 paragraph 2.30's red: `y <= 0.335` and `z <= 0.008`.
fn is_signal_red(rgb: [f64; 3]) -> bool {
    let [x, y, z] = CAMERA_TO_XYZ.map(|r| r[0] * rgb[0] + r[1] * rgb[1] + r[2] * rgb[2]);
    let s = x + y + z;
    y / s <= 0.335 && z / s <= 0.008
}

/// The figures of the PWM segment in closed form: Δu′v′ (the largest
/// distance of a frame's u′v′ from that of the frames' mean), the frames
/// outside the red region, and each plane's FMI `(max - min) / (max +
/// min)`.
struct Expected {
    delta_uv: f64,
    outside: usize,
    fmi: [Option<f64>; 3],
}

fn expected() -> Expected {
    let pwm: Vec<[f64; 3]> = (ON.1..FRAMES).map(|k| PWM_CYCLE[(k - ON.1) % 4]).collect();
    let (delta_uv, outside) = colour_of(&pwm);
    let fmi = [0, 1, 2].map(|p| {
        let hi = pwm.iter().map(|c| c[p]).fold(f64::MIN, f64::max);
        let lo = pwm.iter().map(|c| c[p]).fold(f64::MAX, f64::min);
        (hi + lo > 0.0).then(|| (hi - lo) / (hi + lo))
    });
    Expected {
        delta_uv,
        outside,
        fmi,
    }
}

/// IEC 61966-2-1's encoding of linear light `l` (0..1), and its decoding.
fn srgb_encode(l: f64) -> f64 {
    if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

fn srgb_decode(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The lamp's 8-bit sRGB codes in frame `k`, and the light they decode to
/// (DN on the 0-255 scale).
fn srgb_lamp(k: usize) -> ([u8; 3], [f64; 3]) {
    let codes = lamp_rgb(k).map(|l| (255.0 * srgb_encode(l / 255.0)).round() as u8);
    (
        codes,
        codes.map(|c| 255.0 * srgb_decode(f64::from(c) / 255.0)),
    )
}

/// Δu′v′ and the frames outside the red region of PWM frames `planes`.
fn colour_of(planes: &[[f64; 3]]) -> (f64, usize) {
    let n = planes.len() as f64;
    let mean = [0, 1, 2].map(|p| planes.iter().map(|c| c[p]).sum::<f64>() / n);
    let (u0, v0) = uv(mean);
    let delta = planes
        .iter()
        .map(|&c| {
            let (u, v) = uv(c);
            (u - u0).hypot(v - v0)
        })
        .fold(0.0, f64::max);
    (delta, planes.iter().filter(|&&c| !is_signal_red(c)).count())
}

/// Checks the lamp's and the road's figures in a run's outputs.
fn check_outputs(json: &Value, out: &Path, trace_csv: &str) {
    let want = expected();
    // The cycle's last frame is the one that leaves the region: its green
    // plane saw a whole pulse, its red one half.
    assert_eq!(want.outside, 10);
    assert!(want.delta_uv > 0.01, "{}", want.delta_uv);
    assert_eq!(want.fmi, [Some(1.0 / 3.0), Some(1.0), None]);

    let roi = &json["cases"][0]["rois"][0];
    assert_eq!(roi["name"], "lamp");
    assert_eq!(roi["signal_colour"], "red");
    let m = &roi["metrics"];
    let got = m["delta_uv"].as_f64().unwrap();
    assert!(
        (got - want.delta_uv).abs() < 1e-12,
        "{got} vs {}",
        want.delta_uv
    );
    assert_eq!(
        m["frames_outside_signal_colour"].as_f64(),
        Some(want.outside as f64)
    );
    for (p, fmi) in ["r", "g", "b"].iter().zip(want.fmi) {
        let got = m[format!("fmi_{p}")].as_f64();
        match (got, fmi) {
            (Some(g), Some(w)) => assert!((g - w).abs() < 1e-12, "fmi_{p}: {g} vs {w}"),
            (None, None) => {}
            _ => panic!("fmi_{p}: {got:?} vs {fmi:?}"),
        }
    }
    // Dark OFF reference: FDI is the share of PWM frames with light, 1 in
    // the red plane; green is dark in a quarter of them. No plane level
    // lies within 10 % of its PWM mean (150 DN red, 2.25 DN green): MMP 0.
    assert_eq!(m["fdi_p2020_r"].as_f64(), Some(1.0));
    assert_eq!(m["fdi_p2020_g"].as_f64(), Some(0.75));
    assert_eq!(m["mmp_r"].as_f64(), Some(0.0));
    assert_eq!(m["mmp_g"].as_f64(), Some(0.0));
    // The road has no colour figures.
    let road = &json["cases"][0]["rois"][1]["metrics"];
    assert!(road.get("delta_uv").is_none() && road.get("fmi_r").is_none());

    // The trace CSV gains the lamp's planes, after the luma columns.
    let trace = std::fs::read_to_string(out.join("traces").join(trace_csv)).unwrap();
    let mut lines = trace.lines();
    assert_eq!(
        lines.next(),
        Some("frame,time_s,segment,lamp,road,lamp.r,lamp.g,lamp.b")
    );
    for (k, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let planes: Vec<f64> = f[5..].iter().map(|v| v.parse().unwrap()).collect();
        assert_eq!(planes, lamp_rgb(k).to_vec(), "frame {k}: {line}");
    }

    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut rows = csv.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let lamp: Vec<&str> = rows
        .find(|r| r.contains(",lamp,"))
        .unwrap()
        .split(',')
        .collect();
    let col = |name: &str| lamp[header.iter().position(|h| *h == name).unwrap()];
    assert_eq!(col("frames_outside_signal_colour"), "10");
    let csv_delta: f64 = col("delta_uv").parse().unwrap();
    assert!((csv_delta - want.delta_uv).abs() < 1e-6, "{csv_delta}");
    let csv_fmi_g: f64 = col("fmi_g").parse().unwrap();
    assert!((csv_fmi_g - 1.0).abs() < 1e-9, "{csv_fmi_g}");

    let junit = std::fs::read_to_string(out.join("junit.xml")).unwrap();
    assert!(
        junit.contains("delta_uv") && junit.contains("fmi_r"),
        "{junit}"
    );
}

#[test]
fn a_captured_red_pwm_lamp_with_a_chroma_shift_gives_the_closed_form_colour_figures() {
    let dir = scratch("captured-colour");
    write_frames(&dir.join("frames"));
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let json = run_plan(&plan, &dir);
    check_outputs(&json, &dir.join("out"), "lamp.csv");
}

#[test]
fn a_rigs_rgb_recording_gives_the_same_figures_as_the_captured_frames() {
    // The command backend reads what a rig records as a captured plan
    // reads its files: the same frames, handed over by a rig that copies
    // them into its output directory, give the same colour figures.
    let dir = scratch("command-colour");
    let frames = dir.join("frames");
    write_frames(&frames);
    let captured = std::fs::read_to_string(colour_plan(&dir, "frames", &matrix_camera())).unwrap();
    let head = captured.split("[[case]]").next().unwrap();
    let rest = &captured[captured.find("[[roi]]").unwrap()..];
    let rig = format!("cp {}/*.png \"$LEDFLICKER_OUT_DIR\"/", frames.display());
    let text = format!(
        "{}command = [\"sh\", \"-c\", {rig:?}]\ntimeout-s = 60.0\n\n[sequence]\non-s = 0.272\noff-s = 0.272\npwm-s = 1.36\n\n[light]\nlevels-lux = [2000.0]\n\n[grid]\nfrequencies-hz = [125.0]\nduty-cycles = [0.75]\n\n{rest}",
        head.replace("backend = \"captured\"", "backend = \"command\"")
            .replace(
                "[dut.camera]\n",
                &format!(
                    "[dut.camera]\nshutter = \"global\"\nsensor-rows = 8\nsensor-columns = 16\nframe-rate-fps = {}\nexposure-ms = {EXPOSURE_MS}\nresponse-dn-per-cd-m2-s = 1.0\n",
                    1000.0 / FRAME_MS
                )
            )
    );
    let plan = dir.join("command.toml");
    std::fs::write(&plan, text).unwrap();
    let json = run_plan(&plan, &dir);
    let id = json["cases"][0]["id"].as_str().unwrap().to_string();
    check_outputs(&json, &dir.join("out"), &format!("{id}.csv"));
}

#[test]
fn a_lossless_rgb_video_of_the_lamp_gives_the_same_figures() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them"
    );
    let dir = scratch("captured-colour-video");
    let frames = dir.join("frames");
    write_frames(&frames);
    // FFV1 keeps the RGB planes as they are: no YUV conversion to round.
    let video = dir.join("lamp.mkv");
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-framerate", "500/17", "-i"])
        .arg(frames.join("f%03d.png"))
        .args(["-c:v", "ffv1", "-pix_fmt", "bgr0"])
        .arg(&video)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let plan = colour_plan(&dir, "lamp.mkv", &matrix_camera());
    let json = run_plan(&plan, &dir);
    assert!(
        json["cases"][0]["capture"]["format"]
            .as_str()
            .is_some_and(|f| f.contains("rgb24")),
        "{}",
        json["cases"][0]["capture"]
    );
    check_outputs(&json, &dir.join("out"), "lamp.csv");
}

#[test]
fn a_colour_plan_on_greyscale_frames_is_refused_naming_the_capture() {
    let dir = scratch("captured-colour-grey");
    let frames = dir.join("grey");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..FRAMES {
        let v = lamp_rgb(k)[0] as u8;
        image::GrayImage::from_pixel(16, 8, image::Luma([v]))
            .save(frames.join(format!("f{k:03}.png")))
            .unwrap();
    }
    let plan = colour_plan(&dir, "grey", &matrix_camera());
    let o = ledflicker(
        &["plan", plan.to_str().unwrap(), "--out", "out", "-q"],
        &dir,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for needle in [
        "grey",
        "scene.led-chromaticity-xy",
        "frames are greyscale",
        "hint: record RGB frames",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
    assert!(!dir.join("out/results.json").exists());
}

#[test]
fn colour_keys_a_captured_plan_cannot_use_are_refused_at_their_line() {
    let dir = scratch("captured-colour-keys");
    write_frames(&dir.join("frames"));
    // The recording has its own chroma shift: the simulator's is refused;
    // so is a video decode that keeps no R, G and B.
    let camera = format!(
        "{}\ncolour-plane-offset-ms = [0.0, 1.0, 0.0]",
        matrix_camera()
    );
    let plan = colour_plan(&dir, "frames", &camera);
    let text = std::fs::read_to_string(&plan)
        .unwrap()
        .replace("[capture]\n", "[capture]\nvideo-decode = \"luma-plane\"\n");
    std::fs::write(&plan, text).unwrap();
    let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for needle in [
        "dut.camera.colour-plane-offset-ms",
        "as recorded",
        "capture.video-decode",
        "reads no R, G, B",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
}

/// A recording on a pedestal of 12, 9 and 15 DN (R, G, B): read with the
/// camera's black level (0 here) every frame's colour is greyed by it;
/// with `capture.black-level = "off-segment"` the planes are measured
/// from their OFF frames, the pedestal, and give the pedestal-free
/// figures.
#[test]
fn a_pedestal_is_taken_from_the_off_segment_when_the_plan_asks() {
    const PEDESTAL: [u8; 3] = [12, 9, 15];
    let on_pedestal: Vec<[f64; 3]> = (ON.1..FRAMES)
        .map(|k| {
            let c = PWM_CYCLE[(k - ON.1) % 4];
            [0, 1, 2].map(|p| c[p] + f64::from(PEDESTAL[p]))
        })
        .collect();
    let (greyed, greyed_outside) = colour_of(&on_pedestal);
    let want = expected();
    assert!((greyed - want.delta_uv).abs() > 1e-3, "{greyed}");
    let figures = |json: &Value| {
        let m = &json["cases"][0]["rois"][0]["metrics"];
        (
            m["delta_uv"].as_f64().unwrap(),
            m["frames_outside_signal_colour"].as_f64().unwrap(),
            m["fmi_r"].as_f64().unwrap(),
        )
    };

    let dir = scratch("captured-colour-pedestal");
    write_frames_on(&dir.join("frames"), PEDESTAL);
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let (delta, outside, fmi_r) = figures(&run_plan(&plan, &dir));
    assert!((delta - greyed).abs() < 1e-12, "{delta} vs {greyed}");
    assert_eq!(outside, greyed_outside as f64);

    let dir = scratch("captured-colour-pedestal-off");
    write_frames_on(&dir.join("frames"), PEDESTAL);
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let text = std::fs::read_to_string(&plan)
        .unwrap()
        .replace("[capture]\n", "[capture]\nblack-level = \"off-segment\"\n");
    std::fs::write(&plan, text).unwrap();
    let (delta, outside, fmi_r_off) = figures(&run_plan(&plan, &dir));
    assert!(
        (delta - want.delta_uv).abs() < 1e-12,
        "{delta} vs {}",
        want.delta_uv
    );
    assert_eq!(outside, want.outside as f64);
    // The plane KPIs take no black level: the same either way.
    assert_eq!(fmi_r, fmi_r_off);
    println!("delta u'v': {delta} measured from the OFF frames, {greyed} on the pedestal");
}

#[test]
fn off_segment_black_needs_colour_and_off_frames() {
    let dir = scratch("captured-colour-black-refused");
    write_frames(&dir.join("frames"));
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let text = std::fs::read_to_string(&plan)
        .unwrap()
        .replace("[capture]\n", "[capture]\nblack-level = \"off-segment\"\n");
    // Without colour the key would change nothing.
    let no_colour = text
        .replace("led-chromaticity-xy = [0.6931, 0.3003]\n", "")
        .replace("signal-colour = \"red\"\n", "")
        .replace("colour-transfer = \"linear\"\n", "");
    let start = no_colour.find("[dut.camera]").unwrap();
    let end = start + no_colour[start..].find("\n]\n").unwrap() + 3;
    let no_colour = format!("{}{}", &no_colour[..start], &no_colour[end..]);
    std::fs::write(&plan, &no_colour).unwrap();
    let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("capture.black-level") && err.contains("no colour") && err.contains("hint"),
        "{err}"
    );
    // A case with no OFF frames has no black to take.
    let no_off = text.replace(&format!("off-frames = [{}, {}]\n", OFF.0, OFF.1), "");
    assert_ne!(no_off, text);
    std::fs::write(&plan, &no_off).unwrap();
    let o = ledflicker(
        &["plan", plan.to_str().unwrap(), "--out", "out", "-q"],
        &dir,
    );
    let err = stderr(&o);
    assert_ne!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("black-level") && err.contains("OFF frames"),
        "{err}"
    );
}

#[test]
fn an_led_of_dies_is_refused_in_a_captured_plan() {
    // The dies' duties and phases are simulated; a recording carries the
    // lamp's own colour and timing.
    let dir = scratch("captured-colour-dies");
    write_frames(&dir.join("frames"));
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let text = std::fs::read_to_string(&plan).unwrap().replace(
        "led-chromaticity-xy = [0.6931, 0.3003]\nsignal-colour = \"red\"\n",
        "signal-colour = \"red\"\n\n[[scene.led-die]]\nchromaticity-xy = [0.6931, 0.3003]\nluminance-share = 1.0\nduty-cycle = 1.0\n",
    );
    std::fs::write(&plan, text).unwrap();
    let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for needle in ["scene.led-die", "is simulated", "led-chromaticity-xy"] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
}

#[test]
fn an_srgb_recording_is_decoded_to_light_before_its_colour_is_computed() {
    let dir = scratch("captured-colour-srgb");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..FRAMES {
        let lamp = image::Rgb(srgb_lamp(k).0);
        let road = image::Rgb([ROAD_DN; 3]);
        image::RgbImage::from_fn(16, 8, |x, _| if x < 8 { lamp } else { road })
            .save(frames.join(format!("f{k:03}.png")))
            .unwrap();
    }
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let linear = std::fs::read_to_string(&plan).unwrap();
    let delta_of = |transfer: &str| {
        let text = linear.replace(
            "colour-transfer = \"linear\"",
            &format!("colour-transfer = \"{transfer}\""),
        );
        std::fs::write(&plan, text).unwrap();
        let json = run_plan(&plan, &dir);
        let m = &json["cases"][0]["rois"][0]["metrics"];
        let outside = m["frames_outside_signal_colour"].as_f64().unwrap();
        (m["delta_uv"].as_f64().unwrap(), outside as usize)
    };
    // The light the codes stand for, decoded here.
    let light: Vec<[f64; 3]> = (ON.1..FRAMES).map(|k| srgb_lamp(k).1).collect();
    let (want, want_outside) = colour_of(&light);
    let (got, outside) = delta_of("srgb");
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
    assert_eq!(outside, want_outside);
    // Read as if the codes were light, the same recording gives another
    // colour excursion: the encoding must be stated.
    let codes: Vec<[f64; 3]> = (ON.1..FRAMES)
        .map(|k| srgb_lamp(k).0.map(f64::from))
        .collect();
    let (as_codes, _) = colour_of(&codes);
    let (got_linear, _) = delta_of("linear");
    assert!(
        (got_linear - as_codes).abs() < 1e-9,
        "{got_linear} vs {as_codes}"
    );
    assert!(
        (got_linear - want).abs() > 0.05 * want,
        "{got_linear} vs {want}"
    );
}

#[test]
fn a_captured_colour_plan_must_state_how_its_codes_encode_light() {
    let dir = scratch("captured-colour-transfer");
    write_frames(&dir.join("frames"));
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let text = std::fs::read_to_string(&plan).unwrap();
    std::fs::write(&plan, text.replace("colour-transfer = \"linear\"\n", "")).unwrap();
    let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for needle in [
        "capture.colour-transfer",
        "is needed",
        "\"bt709\" for most video",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
    // Without colour the key would do nothing: it is refused too.
    let grey = text
        .replace("led-chromaticity-xy = [0.6931, 0.3003]\n", "")
        .replace("signal-colour = \"red\"\n", "")
        .replace(&matrix_camera(), "");
    std::fs::write(&plan, grey).unwrap();
    let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("capture.colour-transfer") && err.contains("needs the LED's colour"),
        "{err}"
    );
}

#[test]
fn a_red_plane_clipped_under_a_low_luma_is_flagged_on_the_roi_and_its_colour_figures() {
    // The same lamp on a red pedestal of 55 DN: its red plane reaches 255
    // in the steady ON frames and in half the PWM frames, while the luma
    // (mostly green) stays far below full scale.
    let dir = scratch("captured-colour-clipped");
    write_frames_on(&dir.join("frames"), [55, 0, 0]);
    let plan = colour_plan(&dir, "frames", &matrix_camera());
    let json = run_plan(&plan, &dir);
    let roi = &json["cases"][0]["rois"][0];
    assert_eq!(roi["name"], "lamp");
    assert_eq!(roi["saturated"], true, "{roi:#}");
    let luma_max = roi["levels"]["max"].as_f64().unwrap_or(0.0);
    assert!(luma_max < 200.0, "the luma stays low: {roi:#}");
    let reasons = roi["reasons"].to_string();
    for key in ["delta_uv", "fmi_r", "fdi_p2020_r", "mmp_r"] {
        assert!(
            roi["reasons"][key]
                .as_str()
                .is_some_and(|r| r.contains("red plane clipped")),
            "{key}: {reasons}"
        );
    }
    // The green plane did not clip, and its figures carry no such caveat.
    assert!(
        !roi["reasons"]["fmi_g"]
            .as_str()
            .unwrap_or("")
            .contains("clipped"),
        "{reasons}"
    );
    // The unclipped recording is not flagged.
    let clean = scratch("captured-colour-unclipped");
    write_frames(&clean.join("frames"));
    let plan = colour_plan(&clean, "frames", &matrix_camera());
    let json = run_plan(&plan, &clean);
    assert_eq!(json["cases"][0]["rois"][0]["saturated"], false);
}
