//! `linetime`, `bands` and `calibrate` on real and synthetic frames: the
//! gyroflow frame's published figures, parameter recovery under
//! degradations, agreement of the commands, the no-confidence exit, ROIs
//! and video input.

use std::path::{Path, PathBuf};
use std::process::Output;

use ledflicker::calibrate::recovery;
use ledflicker::calibrate::synth::SynthFrame;

use crate::{ledflicker, root, scratch, stderr};

const GYROFLOW: &str = "reference-data/gyroflow-rs-banding/frame_example.png";

fn json(o: &Output) -> serde_json::Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("`{key}` is not a number: {v}"))
}

/// Line time (us) printed by `linetime` on its first line.
fn linetime_us(args: &[&str]) -> f64 {
    let o = ledflicker(args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    out.lines().next().unwrap().trim().parse().unwrap()
}

#[test]
fn gyroflow_frame_gives_the_published_camera() {
    // SOURCE.md: 1000 Hz, 50 % duty, 1/16000 s, 15.730 ms over 1080 rows.
    let dir = scratch("calibrate-gyroflow");
    let out = dir.join("nikon-1j1.toml");
    // Without the duty, the frame fits two readings (exposure and duty
    // swapped); the published camera is one of them.
    let v = json(&ledflicker(&[
        "calibrate",
        GYROFLOW,
        "--frequency-hz",
        "1000",
        "--json",
    ]));
    let solutions = v["solutions"].as_array().unwrap();
    assert!(
        solutions
            .iter()
            .any(|s| (s["duty"].as_f64().unwrap() - 0.5).abs() < 0.05
                && (s["exposure_us"].as_f64().unwrap() / 62.5 - 1.0).abs() < 0.30),
        "{v:#}"
    );
    // With the duty the firmware sets, one camera, and its profile.
    let v = json(&ledflicker(&[
        "calibrate",
        GYROFLOW,
        "--frequency-hz",
        "1000",
        "--duty",
        "0.5",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]));
    eprintln!("{v:#}");
    let t = num(&v, "line_time_us");
    assert!((t / 14.565 - 1.0).abs() < 0.005, "line time {t} us");
    let e = num(&v, "exposure_us");
    assert!((e / 62.5 - 1.0).abs() < 0.30, "exposure {e} us");
    let rms = num(&v, "profile_rms");
    assert!(rms <= 0.05, "profile_rms {rms}");
    for key in ["line_time_us", "exposure_us", "gamma"] {
        let s = num(&v, &format!("{key}_sigma"));
        assert!(s.is_finite() && s > 0.0, "{key}_sigma {s}");
    }
    // The black level is a value with a sigma, or only bounded by the dark
    // level (it trades off with ambient light).
    if v["black_level_dn"].is_null() {
        assert!(num(&v, "black_level_dn_max") > 0.0, "{v}");
    } else {
        assert!(num(&v, "black_level_dn_sigma") > 0.0, "{v}");
    }
    // The profile names its source with its SHA-256 and runs in a plan.
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("2ab4efe174e3e9bd96857626823632e24e6bdb8aad0684a3d9a01aefb4c7b9be"),
        "{text}"
    );
    let plan = dir.join("plan.toml");
    std::fs::write(
        &plan,
        "format-version = 2\n[plan]\nid = \"calibrated\"\ntitle = \"Calibrated camera\"\n[sequence]\non-s = 0.5\noff-s = 0.5\npwm-s = 1.0\n[light]\nlevels-lux = [2000.0]\n[grid]\nfrequencies-hz = [90.0, 1000.0]\nduty-cycles = [0.5]\n[dut]\ncamera-profile = \"nikon-1j1.toml\"\n[thresholds]\nfdi-2018-min = 0.1\n",
    )
    .unwrap();
    let o = ledflicker(&["validate", plan.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report = dir.join("report");
    let o = ledflicker(&[
        "plan",
        plan.to_str().unwrap(),
        "--out",
        report.to_str().unwrap(),
        "-q",
    ]);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    assert!(report.join("results.json").is_file());
}

#[test]
fn bands_and_linetime_agree_on_every_test_frame() {
    let dir = scratch("calibrate-agree");
    let mut frames: Vec<(PathBuf, f64)> = vec![(root().join(GYROFLOW), 1000.0)];
    for (i, case) in recovery::cases().iter().enumerate() {
        // Two lights and an overlay are refused (below).
        if !matches!(case.scene, recovery::Scene::Plain) {
            continue;
        }
        let p = dir.join(format!("f{i}.{}", case.ext));
        recovery::write_case(case, &p).unwrap();
        frames.push((p, case.frame.frequency_hz));
    }
    for (path, f) in &frames {
        let p = path.to_str().unwrap();
        let t = linetime_us(&["linetime", p, "--frequency-hz", &f.to_string()]);
        let v = json(&ledflicker(&["bands", p, "--line-time-us", &t.to_string()]));
        let got = num(&v, "estimated_frequency_hz");
        // linetime prints 3 decimals: 1e-4 relative at most.
        assert!((got / f - 1.0).abs() < 2e-4, "{p}: {got} Hz for {f} Hz");
    }
}

/// Largest accepted `|error| / sigma` over the recovery set: about 45
/// values; with honest Gaussian sigmas the largest exceeds 3.5 with a
/// probability near 2 %, and a sigma 24 times too small (the covariance
/// alone on the gyroflow frame) fails it at once.
const MAX_Z: f64 = 3.5;

#[test]
fn degraded_synthetic_frames_give_back_their_parameters() {
    let dir = scratch("calibrate-recovery");
    let mut failures = Vec::new();
    for (i, case) in recovery::cases().iter().enumerate() {
        // Two lights (over half or a quarter of the columns) and an
        // overlay: a refusal naming both regions, each light's period
        // within 0.1 % of its own.
        if !matches!(case.scene, recovery::Scene::Plain) {
            match recovery::refusal(case, &dir, i) {
                Ok(regions) => eprintln!("{}: {regions:?}", case.name),
                Err(e) => failures.push(e),
            }
            continue;
        }
        match recovery::recover(case, &dir, i) {
            Ok(e) => {
                eprintln!("{}: {e:?}", case.name);
                for f in e.failures(case) {
                    failures.push(format!("{}: {f}", case.name));
                }
                // The truth lies within MAX_Z reported sigmas.
                if e.max_z() > MAX_Z {
                    failures.push(format!("{}: an error of {:.1} sigma", case.name, e.max_z()));
                }
            }
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Exit 4, no estimate on stdout, one of `reasons` and a hint on stderr.
fn expect_no_confidence(args: &[&str], reasons: &[&str]) {
    let o = ledflicker(args);
    assert_eq!(o.status.code(), Some(7), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("no confident estimate") && reasons.iter().any(|r| e.contains(r)),
        "{e}"
    );
    assert!(e.contains("hint:"), "{e}");
    assert!(
        o.stdout.is_empty(),
        "an estimate was printed: {:?}",
        o.stdout
    );
}

#[test]
fn frames_without_banding_exit_7_with_the_reason() {
    let dir = scratch("calibrate-none");
    // A lit scene with texture and noise, but steady light.
    let flat = dir.join("flat.png");
    SynthFrame {
        duty: 1.0,
        texture: 0.3,
        noise_dn: 2.0,
        ..SynthFrame::base()
    }
    .save(&flat, 90)
    .unwrap();
    // A dark scene with a few small, directly imaged PWM LEDs.
    let leds = dir.join("leds.png");
    let img = image::ImageBuffer::from_fn(640, 480, |x, y| {
        let led = [(100u32, 80u32), (400, 200), (250, 390)]
            .iter()
            .any(|&(cx, cy)| x.abs_diff(cx) < 4 && y.abs_diff(cy) < 4 && (y / 2) % 2 == 0);
        image::Luma([if led { 250u8 } else { 12 }])
    });
    img.save(&leds).unwrap();
    // Texture alone can look like one or two long "bands"; the strip
    // median of the LED frame is its constant dark level. Each reason is a
    // refusal.
    let reasons = [
        "no periodic banding",
        "fewer than 3 bands",
        "the rows are flat",
    ];
    for p in [&flat, &leds] {
        let p = p.to_str().unwrap();
        expect_no_confidence(&["linetime", p, "--frequency-hz", "500"], &reasons);
        expect_no_confidence(&["bands", p, "--line-time-us", "14.565"], &reasons);
        expect_no_confidence(&["calibrate", p, "--frequency-hz", "500"], &reasons);
    }
    // Two bands only.
    let two = dir.join("two.png");
    SynthFrame {
        frequency_hz: 2.0 / (1080.0 * 14.565e-6),
        ..SynthFrame::base()
    }
    .save(&two, 90)
    .unwrap();
    expect_no_confidence(
        &["linetime", two.to_str().unwrap(), "--frequency-hz", "127"],
        &["fewer than 3 bands"],
    );
}

#[test]
fn roi_separates_two_lights_of_different_frequencies() {
    // Left half: 700 Hz; right half: 1900 Hz; same camera.
    let dir = scratch("calibrate-roi");
    let base = SynthFrame {
        width: 320,
        ..SynthFrame::base()
    };
    let left = SynthFrame {
        frequency_hz: 700.0,
        ..base.clone()
    }
    .render()
    .unwrap();
    let right = SynthFrame {
        frequency_hz: 1900.0,
        duty: 0.3,
        ..base.clone()
    }
    .render()
    .unwrap();
    let img = image::ImageBuffer::from_fn(640, 1080, |x, y| {
        let i = (y * 320 + x % 320) as usize;
        image::Luma([(if x < 320 { left[i] } else { right[i] }).round() as u8])
    });
    let path = dir.join("two-lights.png");
    img.save(&path).unwrap();
    let p = path.to_str().unwrap();
    for (roi, f) in [("0,0,320,1080", 700.0), ("320,0,320,1080", 1900.0)] {
        let t = linetime_us(&[
            "linetime",
            p,
            "--roi",
            roi,
            "--frequency-hz",
            &f.to_string(),
        ]);
        assert!((t / 14.565 - 1.0).abs() < 1e-3, "roi {roi}: {t} us");
    }
    let o = ledflicker(&[
        "linetime",
        p,
        "--roi",
        "600,0,100,10",
        "--frequency-hz",
        "700",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--roi") && stderr(&o).contains("two-lights.png"));
}

/// Writes a grey Y4M video of `frames` frames.
fn write_y4m(path: &Path, w: u32, h: u32, frames: &[Vec<u8>]) {
    let mut bytes = format!("YUV4MPEG2 W{w} H{h} F30:1 Ip A1:1 Cmono\n").into_bytes();
    for f in frames {
        bytes.extend_from_slice(b"FRAME\n");
        bytes.extend_from_slice(f);
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn video_frames_are_combined_with_the_texture_divided_out() {
    // Strong static texture; the bands roll from frame to frame (the PWM's
    // first edge moves by 0.29 ms a frame).
    let dir = scratch("calibrate-video");
    let frames: Vec<Vec<u8>> = (0..8)
        .map(|k| {
            SynthFrame {
                width: 320,
                height: 480,
                texture: 0.6,
                first_rise_s: 0.29e-3 * k as f64,
                noise_dn: 1.0,
                seed: 5,
                ..SynthFrame::base()
            }
            .render()
            .unwrap()
            .iter()
            .map(|v| v.round() as u8)
            .collect()
        })
        .collect();
    let path = dir.join("clip.y4m");
    write_y4m(&path, 320, 480, &frames);
    let p = path.to_str().unwrap();
    let o = ledflicker(&["linetime", p, "--frames", "1..7", "--frequency-hz", "1000"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let t: f64 = out.lines().next().unwrap().trim().parse().unwrap();
    assert!((t / 14.565 - 1.0).abs() < 1e-3, "{out}");
    assert!(out.contains("6 frame(s), texture divided out"), "{out}");
    let o = ledflicker(&["linetime", p, "--frames", "5..20", "--frequency-hz", "1000"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--frames"), "{}", stderr(&o));
}

/// A banding frame of our own, independent of the simulator: row `r`
/// collects the ON time of a square wave of duty `duty` over its exposure
/// window `[phi + r / period, phi + r / period + exposure)` (in PWM
/// cycles), as a fraction of the window, shown as `20 + 200 s` DN with a
/// fixed +-1 DN dither.
fn banding_png(path: &Path, duty: f64, exposure: f64, period_rows: f64, phase: f64) {
    let on_until = |x: f64| x.floor() * duty + (x - x.floor()).min(duty);
    let (w, h) = (160u32, 960u32);
    let img = image::GrayImage::from_fn(w, h, |x, r| {
        let u = phase + f64::from(r) / period_rows;
        let s = (on_until(u + exposure) - on_until(u)) / exposure;
        let dither = f64::from((x * 7 + r * 13) % 3) - 1.0;
        image::Luma([(20.0 + 200.0 * s + dither).round().clamp(0.0, 255.0) as u8])
    });
    img.save(path).unwrap();
}

#[test]
fn an_exposure_longer_than_the_on_time_is_not_read_as_the_duty() {
    // 1000 Hz, 48 rows a band: line time 20.833 us. Exposure 0.5 cycles
    // (500 us), duty 0.2: the band profile is the same as duty 0.5 seen
    // for 200 us, so without the duty both readings are given and no
    // profile is written; with the duty, the exposure comes back.
    let dir = scratch("calibrate-mirror");
    let true_line_us = 1e6 / (1000.0 * 48.0);
    let frames: Vec<PathBuf> = (0..3)
        .map(|k| {
            let p = dir.join(format!("long-{k}.png"));
            banding_png(&p, 0.2, 0.5, 48.0, 0.13 + 0.31 * f64::from(k));
            p
        })
        .collect();
    let mut args: Vec<&str> = vec!["calibrate"];
    args.extend(frames.iter().map(|p| p.to_str().unwrap()));
    args.extend(["--frequency-hz", "1000", "--json"]);
    let v = json(&ledflicker(&args));
    assert!(
        (num(&v, "line_time_us") / true_line_us - 1.0).abs() < 1e-3,
        "{v:#}"
    );
    assert!(v["duty"].is_null() && v["exposure_us"].is_null(), "{v:#}");
    let solutions = v["solutions"].as_array().unwrap();
    assert_eq!(solutions.len(), 2, "{v:#}");
    let truth = solutions
        .iter()
        .find(|s| (s["duty"].as_f64().unwrap() - 0.2).abs() < 0.02)
        .unwrap_or_else(|| panic!("no reading with duty 0.2: {v:#}"));
    let e = truth["exposure_us"].as_f64().unwrap();
    assert!((e / 500.0 - 1.0).abs() < 0.05, "{e}");
    let other = solutions.iter().find(|s| *s != truth).unwrap();
    assert!(
        (other["duty"].as_f64().unwrap() - 0.5).abs() < 0.05,
        "{v:#}"
    );
    assert!(
        (other["exposure_us"].as_f64().unwrap() / 200.0 - 1.0).abs() < 0.1,
        "{v:#}"
    );
    // No profile that would have to pick one.
    let profile = dir.join("cam.toml");
    let mut with_out = args.clone();
    with_out.retain(|a| *a != "--json");
    with_out.extend(["--out", profile.to_str().unwrap()]);
    let o = ledflicker(&with_out);
    assert_eq!(o.status.code(), Some(7), "{}", stderr(&o));
    assert!(stderr(&o).contains("--duty"), "{}", stderr(&o));
    assert!(!profile.exists());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("2 readings fit alike"), "{text}");
    // The known duty breaks the tie.
    let mut known = args.clone();
    known.extend(["--duty", "0.2"]);
    let v = json(&ledflicker(&known));
    let e = num(&v, "exposure_us");
    let sigma = num(&v, "exposure_us_sigma");
    assert!(
        (e / 500.0 - 1.0).abs() < 0.05 && (e - 500.0).abs() < 3.5 * sigma.max(1.0),
        "{e} +- {sigma}"
    );
    assert!(v["solutions"].as_array().unwrap().is_empty());
}

#[test]
fn with_ambient_light_the_complements_are_readings_too_and_one_holds_the_camera() {
    // Exposure 0.45 cycles, duty 0.7: the sum is over a cycle, so the
    // complements (duty 0.3, exposure 0.55) and (0.55, 0.3) render the rows
    // alike over some ambient light. Whichever the fit lands on, the
    // readings hold the camera.
    let dir = scratch("calibrate-complement");
    let frames: Vec<PathBuf> = (0..3)
        .map(|k| {
            let p = dir.join(format!("c-{k}.png"));
            banding_png(&p, 0.7, 0.45, 48.0, 0.07 + 0.29 * f64::from(k));
            p
        })
        .collect();
    let mut args: Vec<&str> = vec!["calibrate"];
    args.extend(frames.iter().map(|p| p.to_str().unwrap()));
    args.extend(["--frequency-hz", "1000", "--json"]);
    let v = json(&ledflicker(&args));
    let solutions = v["solutions"].as_array().unwrap();
    assert!(solutions.len() >= 2, "{v:#}");
    assert!(
        solutions
            .iter()
            .any(|s| (s["duty"].as_f64().unwrap() - 0.7).abs() < 0.02
                && (s["exposure_us"].as_f64().unwrap() / 450.0 - 1.0).abs() < 0.05),
        "{v:#}"
    );
    // The duty picks the camera.
    let mut known = args.clone();
    known.extend(["--duty", "0.7"]);
    let v = json(&ledflicker(&known));
    let e = num(&v, "exposure_us");
    assert!((e / 450.0 - 1.0).abs() < 0.05, "{e}: {v:#}");
}
