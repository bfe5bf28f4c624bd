//! Band estimates on frames of [`crate::band_frames`], a generator of its
//! own: the JPEG block grid is not banding; two lights side by side are
//! reported as two regions, never as one confident line time, and so is a
//! column group over a periodic overlay; the light's columns alone give
//! the answer.
//! The truth is the generator's closed form: `t_line = 1 / (f P)`.

use std::path::Path;

use crate::band_frames::{Frame, Light, small_leds};
use crate::{ledflicker, scratch, stderr};

/// Line time of the generated frames, us, and the PWM frequency that
/// gives a band period of `period_rows` with it, Hz.
const LINE_TIME_US: f64 = 25.0;
fn frequency_hz(period_rows: f64) -> f64 {
    1e6 / (LINE_TIME_US * period_rows)
}

/// `linetime`'s line time and sigma, us, from its second line.
fn line_time(out: &[u8]) -> (f64, f64) {
    let text = String::from_utf8_lossy(out);
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("line_time_us: "))
        .unwrap_or_else(|| panic!("no line time in {text}"));
    let (t, s) = line.split_once(" +- ").unwrap();
    (t.parse().unwrap(), s.parse().unwrap())
}

fn run_linetime(path: &Path, f: f64, roi: Option<&str>) -> std::process::Output {
    let f = f.to_string();
    let mut args = vec!["linetime", path.to_str().unwrap(), "--frequency-hz", &f];
    if let Some(r) = roi {
        args.extend(["--roi", r]);
    }
    ledflicker(&args)
}

#[test]
fn the_jpeg_block_grid_is_not_taken_for_bands() {
    let dir = scratch("bands-jpeg-grid");
    // A dark frame, a vertical gradient and a fine horizontal texture, and
    // three small LEDs: the only rows' pattern JPEG leaves is its grid.
    let leds = Frame {
        dark_dn: (8.0, 60.0),
        ripple_dn: 20.0,
        ..small_leds(640, 480, 21.7)
    };
    for q in [50u8, 60, 70, 80, 90, 95] {
        let path = dir.join(format!("leds-q{q}.jpg"));
        leds.save(&path, q);
        let o = run_linetime(&path, 500.0, None);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(7), "quality {q}: {e}");
        assert!(o.stdout.is_empty(), "quality {q}: {e}");
        assert!(
            ["block grid", "no periodic banding", "rows are flat"]
                .iter()
                .any(|r| e.contains(r)),
            "quality {q}: {e}"
        );
        if q <= 80 {
            assert!(
                e.contains("of the JPEG or video coding") && e.contains("hint:"),
                "{e}"
            );
        }
    }
    // Real bands survive the suppression at every quality.
    for q in [50u8, 75, 95] {
        let path = dir.join(format!("lit-q{q}.jpg"));
        Frame::lit(640, 480, 37.3).save(&path, q);
        let o = run_linetime(&path, frequency_hz(37.3), None);
        assert_eq!(o.status.code(), Some(0), "quality {q}: {}", stderr(&o));
        let (t, s) = line_time(&o.stdout);
        assert!(
            (t / LINE_TIME_US - 1.0).abs() < 1e-3,
            "quality {q}: {t} +- {s}"
        );
        assert!(String::from_utf8_lossy(&o.stdout).contains("block_grid: "));
    }
    // A true period within 2 cycles per frame of 16 rows is refused: in a
    // JPEG it cannot be told from the grid. The same frame as PNG is fine.
    let near = Frame::lit(640, 480, 16.3);
    let (jpg, png) = (dir.join("near-16.jpg"), dir.join("near-16.png"));
    near.save(&jpg, 90);
    near.save(&png, 90);
    let o = run_linetime(&jpg, frequency_hz(16.3), None);
    assert_eq!(o.status.code(), Some(7), "{}", stderr(&o));
    assert!(stderr(&o).contains("block grid"), "{}", stderr(&o));
    let o = run_linetime(&png, frequency_hz(16.3), None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (t, _) = line_time(&o.stdout);
    assert!((t / LINE_TIME_US - 1.0).abs() < 1e-3, "{t}");
}

/// Periods rows of the right-hand light of two-lights frame `k`.
fn right_period(k: usize) -> f64 {
    40.0 * (1.0 + 0.02 * (k + 1) as f64)
}

/// Two lights on one camera: 40-row bands on columns 0..320, bands of
/// `right_period(k)` rows at duty 0.3 on columns 320..640.
fn two_lights(k: usize) -> Frame {
    let mut f = Frame::lit(640, 1080, 40.0);
    f.lights[0].columns = 0..320;
    f.lights.push(Light {
        columns: 320..640,
        rows: 0..1080,
        period_rows: right_period(k),
        duty: 0.3,
        first_rise_rows: 7.0 * k as f64,
    });
    f
}

/// The `period P +- S rows` of `columns A..B: ...` in a refusal.
fn region_period(e: &str, columns: &str) -> f64 {
    let at = e
        .find(&format!("columns {columns}: period "))
        .unwrap_or_else(|| panic!("no region {columns} in {e}"));
    let rest = &e[at + columns.len() + 17..];
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn two_lights_give_two_regions_not_one_confident_line_time() {
    let dir = scratch("bands-two-lights");
    for k in 0..12 {
        let path = dir.join(format!("two-{k}.png"));
        two_lights(k).save(&path, 90);
        // The user names the right-hand light; the left one must not
        // answer for it.
        let o = run_linetime(&path, frequency_hz(right_period(k)), None);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(7), "frame {k}: {e}");
        assert!(e.contains("band at different periods"), "frame {k}: {e}");
        let (left, right) = (region_period(&e, "0..320"), region_period(&e, "320..640"));
        assert!((left / 40.0 - 1.0).abs() < 2e-3, "frame {k}: {e}");
        assert!(
            (right / right_period(k) - 1.0).abs() < 2e-3,
            "frame {k}: {e}"
        );
        assert!(e.contains("--roi"), "frame {k}: {e}");
    }
    // The user's next step: one region at a time.
    let path = dir.join("two-4.png");
    for (roi, period) in [("0,0,320,1080", 40.0), ("320,0,320,1080", right_period(4))] {
        let o = run_linetime(&path, frequency_hz(period), Some(roi));
        assert_eq!(o.status.code(), Some(0), "{roi}: {}", stderr(&o));
        let (t, _) = line_time(&o.stdout);
        assert!((t / LINE_TIME_US - 1.0).abs() < 1e-3, "{roi}: {t}");
    }
}

/// A 960-column frame of 40-row bands with ruled bright lines, 20 rows
/// thick every 40.3 rows, over columns 640..800: the fourth column group
/// of the ROI 160..800.
fn overlaid() -> Frame {
    let lines = (0..)
        .map(|i| (i as f64 * 40.3).round() as u32)
        .take_while(|&r| r < 1080)
        .map(|r| (640..800, r..r + 20))
        .collect();
    Frame {
        overlays: lines,
        ..Frame::lit(960, 1080, 40.0)
    }
}

#[test]
fn a_group_over_an_overlay_is_refused_and_named_and_the_rest_measured_alone() {
    // Ruled lines over one column group band at a period of their own: to
    // the estimator a second light there. Refused, both regions named; the
    // columns of the light alone (`--roi`) give its line time.
    let dir = scratch("bands-overlay");
    let path = dir.join("overlay.png");
    overlaid().save(&path, 90);
    let p = path.to_str().unwrap();
    let f = frequency_hz(40.0).to_string();
    let o = ledflicker(&[
        "calibrate",
        p,
        "--frequency-hz",
        &f,
        "--roi",
        "160,0,640,1080",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(7), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("band at different periods") && e.contains("640..800"),
        "{e}"
    );
    assert!(e.contains("--roi"), "{e}");
    let o = ledflicker(&[
        "calibrate",
        p,
        "--frequency-hz",
        &f,
        "--roi",
        "160,0,320,1080",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let narrow: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let t = narrow["line_time_us"].as_f64().unwrap();
    let sigma = narrow["line_time_us_sigma"].as_f64().unwrap();
    assert!((t / LINE_TIME_US - 1.0).abs() < 1e-3, "{t} +- {sigma}");
    assert!(narrow["dropped_columns"].as_array().unwrap().is_empty());
    // linetime refuses it too, naming the columns.
    let o = run_linetime(&path, frequency_hz(40.0), Some("160,0,640,1080"));
    assert_eq!(o.status.code(), Some(7), "{}", stderr(&o));
    assert!(stderr(&o).contains("columns 640..800"), "{}", stderr(&o));
}

#[test]
fn the_real_frame_with_an_overlay_over_one_group_is_refused_and_its_light_measured_alone() {
    // The gyroflow frame (1000 Hz, 68.6-row bands) with ruled bright lines,
    // 34 rows thick every 69.1 rows, over its right quarter: that group
    // bands at a period of its own, named in the refusal; the other three
    // quarters, given alone, give the clean frame's answer.
    let dir = scratch("bands-real-overlay");
    let frame = crate::root().join("reference-data/gyroflow-rs-banding/frame_example.png");
    let mut img = image::open(&frame).unwrap().to_rgb8();
    for i in 0.. {
        let top = (i as f64 * 69.1).round() as u32;
        if top >= img.height() {
            break;
        }
        for y in top..(top + 34).min(img.height()) {
            for x in 1440..1920 {
                img.put_pixel(x, y, image::Rgb([235, 235, 235]));
            }
        }
    }
    let height = img.height();
    let path = dir.join("overlaid.png");
    img.save(&path).unwrap();
    let clean = run_linetime(&frame, 1000.0, None);
    let over = run_linetime(&path, 1000.0, None);
    assert_eq!(over.status.code(), Some(7), "{}", stderr(&over));
    assert!(
        stderr(&over).contains("columns 1440..1920"),
        "{}",
        stderr(&over)
    );
    let left = run_linetime(&path, 1000.0, Some(&format!("0,0,1440,{height}")));
    assert_eq!(left.status.code(), Some(0), "{}", stderr(&left));
    let ((tc, sc), (tl, sl)) = (line_time(&clean.stdout), line_time(&left.stdout));
    assert!(
        (tl - tc).abs() < 3.5 * sc.hypot(sl),
        "{tl} +- {sl} vs {tc} +- {sc}"
    );
}

#[test]
fn a_video_is_read_with_its_block_grid_suppressed() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them"
    );
    let dir = scratch("bands-video");
    // Bands of 37.3 rows that roll by 11 rows a frame, coded as MPEG-4
    // (8 x 8 DCT, 16 x 16 macroblocks).
    for k in 0..8 {
        let mut f = Frame::lit(320, 240, 37.3);
        f.lights[0].first_rise_rows = 11.0 * k as f64;
        f.save(&dir.join(format!("frame-{k}.png")), 90);
    }
    let clip = dir.join("clip.mp4");
    let o = std::process::Command::new("ffmpeg")
        .args(["-y", "-loglevel", "error", "-framerate", "30", "-i"])
        .arg(dir.join("frame-%d.png"))
        .args(["-c:v", "mpeg4", "-q:v", "4", "-pix_fmt", "yuv420p"])
        .arg(&clip)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_linetime(&clip, frequency_hz(37.3), None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (t, s) = line_time(&o.stdout);
    assert!((t / LINE_TIME_US - 1.0).abs() < 1e-3, "{t} +- {s}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("block_grid: "), "{out}");
}
