//! Units that are silently wrong: plausibility warnings of `validate`
//! (a valid value most likely written in another unit), and a captured
//! plan's ROI off a capture's frame, refused by `validate` with the ROI's
//! name (docs/plan-format.md, "Plausibility warnings" and "ROIs").

use std::path::{Path, PathBuf};
use std::process::Output;

use ledflicker::capture::{self, LumaWeights, ReadOptions, RoiRect, VideoDecode, VideoRange};

use crate::{ledflicker_in, root, scratch, stderr};

/// test-plans/daylight.toml with the line starting `key =` replaced by
/// `line` (which may hold several lines), written to `dir/name`; also
/// returns the 1-based line number of the replaced line.
fn daylight_with(dir: &Path, name: &str, key: &str, line: &str) -> (PathBuf, usize) {
    let text = std::fs::read_to_string(root().join("test-plans/daylight.toml")).unwrap();
    let mut at = None;
    let lines: Vec<&str> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if l.starts_with(&format!("{key} =")) {
                at = Some(i + 1);
                line
            } else {
                l
            }
        })
        .collect();
    let at = at.unwrap_or_else(|| panic!("no `{key} =` line in daylight.toml"));
    let path = dir.join(name);
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    (path, at)
}

/// `ledflicker validate PLAN` in `dir`: it must pass (exit 0, "is
/// valid"); returns its stderr.
fn validate_passes(plan: &Path, dir: &Path) -> String {
    let o: Output = ledflicker_in(&["validate", plan.to_str().unwrap()], dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("is valid"),
        "{err}"
    );
    err
}

/// Asserts that `err` holds one warning line naming `plan`, `key` at
/// `line`, and every one of `words`.
fn assert_warns(err: &str, plan: &Path, key: &str, line: usize, words: &[&str]) {
    let head = format!("warning: {}: line {line}, ", plan.display());
    let warning = err
        .split("warning: ")
        .map(|w| format!("warning: {w}"))
        .find(|w| w.contains(&format!("`{key}`")))
        .unwrap_or_else(|| panic!("no warning at `{key}` in: {err}"));
    assert!(
        warning.starts_with(&head),
        "`{head}` does not start: {warning}"
    );
    assert!(warning.contains("\n    hint: "), "no hint: {warning}");
    for w in words {
        assert!(warning.contains(w), "`{w}` not in: {warning}");
    }
}

#[test]
fn a_line_time_in_milliseconds_warns_at_line_time_us() {
    let dir = scratch("units-line-time");
    let (plan, line) = daylight_with(&dir, "plan.toml", "line-time-us", "line-time-us = 0.014565");
    let err = validate_passes(&plan, &dir);
    assert_warns(
        &err,
        &plan,
        "dut.camera.line-time-us",
        line,
        &["likely given in milliseconds", "0.014565 ms is 14.565 us"],
    );
    assert_eq!(err.matches("warning: ").count(), 1, "{err}");
}

#[test]
fn a_line_time_in_nanoseconds_is_an_error_whose_hint_names_the_unit() {
    let dir = scratch("units-line-time-ns");
    let (plan, line) = daylight_with(&dir, "plan.toml", "line-time-us", "line-time-us = 14565");
    let o = ledflicker_in(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("line {line}, column 1: `dut.camera.line-time-us`"))
            && err.contains("reads like nanoseconds (14.565 us"),
        "{err}"
    );
}

#[test]
fn an_exposure_in_microseconds_is_an_error_whose_hint_names_the_unit() {
    let dir = scratch("units-exposure-us");
    let (plan, line) = daylight_with(&dir, "plan.toml", "exposure-ms", "exposure-ms = 11111");
    let o = ledflicker_in(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("line {line}, column 1: `dut.camera.exposure-ms`"))
            && err.contains(
                "exposure-ms is in milliseconds: 11111 reads like microseconds (11.111 ms)"
            ),
        "{err}"
    );
}

#[test]
fn a_percent_flicker_limit_given_as_a_fraction_warns() {
    let dir = scratch("units-percent");
    // [thresholds] is daylight.toml's last table: a level table follows it.
    let (plan, line) = daylight_with(
        &dir,
        "plan.toml",
        "fdi-2018-min",
        "percent-flicker-max = 0.15\nfmi-max = 0.15",
    );
    let mut text = std::fs::read_to_string(&plan).unwrap();
    text += "[[thresholds.light-level]]\nlight-lux = 2000.0\npercent-flicker-max = 0.2\n";
    std::fs::write(&plan, &text).unwrap();
    let err = validate_passes(&plan, &dir);
    assert_warns(
        &err,
        &plan,
        "thresholds.percent-flicker-max",
        line,
        &["likely given as a fraction", "the fraction 0.15 is 15 %"],
    );
    assert_warns(
        &err,
        &plan,
        "thresholds.light-level[0].percent-flicker-max",
        nth_line(&plan, "percent-flicker-max", 1),
        &["likely given as a fraction", "the fraction 0.2 is 20 %"],
    );
    // FMI is a share: 0.15 is what it should be, and is not warned of.
    assert!(!err.contains("`thresholds.fmi-max`"), "{err}");
    assert_eq!(err.matches("warning: ").count(), 2, "{err}");
}

#[test]
fn frequencies_given_in_khz_warn() {
    let dir = scratch("units-khz");
    let (plan, line) = daylight_with(
        &dir,
        "grid.toml",
        "frequencies-hz",
        "frequencies-hz = [0.05, 0.09, 0.1, 0.15, 0.2, 0.5, 1.0]",
    );
    let err = validate_passes(&plan, &dir);
    assert_warns(
        &err,
        &plan,
        "grid.frequencies-hz[0]",
        line,
        &[
            "likely given in kHz",
            "7 of the grid's 7 frequencies",
            "0.05 kHz is 50 Hz",
        ],
    );
    assert_eq!(err.matches("warning: ").count(), 1, "{err}");

    let (plan, line) = daylight_with(
        &dir,
        "range.toml",
        "frequencies-hz",
        "frequency-range-hz = { start = 0.1, stop = 1.0, step = 0.1 }",
    );
    let err = validate_passes(&plan, &dir);
    assert_warns(
        &err,
        &plan,
        "grid.frequency-range-hz.start",
        line,
        &["likely given in kHz", "0.1 kHz is 100 Hz"],
    );

    let (plan, line) = daylight_with(
        &dir,
        "mitigation.toml",
        "mitigation-min-hz",
        "mitigation-min-hz = 90.0\nmitigation-max-hz = 2.0",
    );
    // Below mitigation-min-hz: an error, not a warning; keep min at 0.
    let text = std::fs::read_to_string(&plan)
        .unwrap()
        .replace("mitigation-min-hz = 90.0\n", "");
    std::fs::write(&plan, text).unwrap();
    let err = validate_passes(&plan, &dir);
    assert_warns(
        &err,
        &plan,
        "thresholds.mitigation-max-hz",
        line,
        &[
            "likely given in kHz",
            "every case above it is not judged",
            "2 kHz is 2000 Hz",
        ],
    );
}

/// One grey 8-bit PNG of `w` x `h` pixels at `path`.
fn save_png(path: &Path, w: u32, h: u32, level: u8) {
    image::GrayImage::from_pixel(w, h, image::Luma([level]))
        .save(path)
        .unwrap();
}

/// A captured plan in `dir` with the cases `cases` (`[[case]]` bodies)
/// and the ROIs `rois` (name, x, y, width, height).
fn captured_plan(dir: &Path, cases: &[&str], rois: &[(&str, u32, u32, u32, u32)]) -> PathBuf {
    let mut text = "[plan]\nid = \"t\"\ntitle = \"t\"\n[dut]\nbackend = \"captured\"\n[capture]\nframe-rate-fps = 30.0\noff-frames = [0, 1]\npwm-frames = [1]\n".to_string();
    for c in cases {
        text += &format!("[[case]]\n{c}\n");
    }
    for (name, x, y, w, h) in rois {
        text += &format!(
            "[[roi]]\nname = \"{name}\"\nx-px = {x}\ny-px = {y}\nwidth-px = {w}\nheight-px = {h}\n"
        );
    }
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The 1-based line of the `n`-th (from 0) line starting with `prefix`.
fn nth_line(path: &Path, prefix: &str, n: usize) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.starts_with(prefix))
        .nth(n)
        .map(|(i, _)| i + 1)
        .unwrap()
}

#[test]
fn a_captured_frequency_in_khz_warns() {
    let dir = scratch("units-case-khz");
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    for k in 0..3 {
        save_png(&dir.join(format!("frames/f{k}.png")), 16, 8, 10 + k as u8);
    }
    let plan = captured_plan(
        &dir,
        &["source = \"frames\"\nlight-lux = 2000.0\nfrequency-hz = 0.15\nduty-cycle = 0.2"],
        &[("led", 0, 0, 4, 2)],
    );
    let err = validate_passes(&plan, &dir);
    assert_warns(
        &err,
        &plan,
        "case[0].frequency-hz",
        nth_line(&plan, "frequency-hz", 0),
        &[
            "with a duty cycle",
            "likely given in kHz",
            "0.15 kHz is 150 Hz",
        ],
    );
}

#[test]
fn a_captured_roi_off_the_frame_fails_validate_naming_it() {
    let dir = scratch("units-roi-frame");
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    for k in 0..3 {
        save_png(&dir.join(format!("frames/f{k}.png")), 64, 48, 10 + k as u8);
    }
    // A Y4M of 32 x 24: header and two grey frames (4:2:0).
    let mut y4m = b"YUV4MPEG2 W32 H24 F30:1 C420jpeg\n".to_vec();
    for _ in 0..2 {
        y4m.extend_from_slice(b"FRAME\n");
        y4m.extend(std::iter::repeat_n(100u8, 32 * 24 + 2 * 16 * 12));
    }
    std::fs::write(dir.join("small.y4m"), &y4m).unwrap();
    let rois = [
        ("head", 0, 0, 10, 2),
        ("tail", 60, 2, 10, 2),
        ("low", 0, 30, 10, 2),
    ];
    // Frames of 64 x 48: `tail` passes the right edge; `low` fits.
    let plan = captured_plan(&dir, &["source = \"frames\""], &rois);
    let o = ledflicker_in(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let tail = format!(
        "line {}, column 1: `roi[1].x-px`: ROI `tail` (columns 60..70, rows 2..4) falls outside the 64x48 frame of capture `{}` (case `frames`)",
        nth_line(&plan, "x-px", 1),
        dir.join("frames").display()
    );
    assert!(err.contains(&tail), "`{tail}` not in: {err}");
    assert!(
        err.contains("hint: pixels are 0-based: x-px + width-px must be at most 64"),
        "{err}"
    );
    assert!(!err.contains("`head`") && !err.contains("`low`"), "{err}");
    // `plan` validates first: the same error, before any output.
    let out = dir.join("out");
    let o = ledflicker_in(
        &[
            "plan",
            plan.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains(&tail), "{}", stderr(&o));
    assert!(!out.join("results.json").exists());

    // A second capture of 32 x 24 (Y4M): `low` is off its frame (rows),
    // `tail` off both, named with the other capture.
    let plan = captured_plan(
        &dir,
        &["source = \"frames\"", "source = \"small.y4m\""],
        &rois,
    );
    let o = ledflicker_in(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(
            "`roi[1].x-px`: ROI `tail` (columns 60..70, rows 2..4) falls outside the 64x48 frame"
        ) && err.contains("(case `frames`) and 1 other capture"),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "line {}, column 1: `roi[2].y-px`: ROI `low` (columns 0..10, rows 30..32) falls outside the 32x24 frame of capture `{}` (case `small`)",
            nth_line(&plan, "y-px", 2),
            dir.join("small.y4m").display()
        )),
        "{err}"
    );
    assert!(!err.contains("`head`"), "{err}");
}

#[test]
fn a_captured_video_roi_off_the_frame_fails_validate() {
    assert!(
        capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them"
    );
    let dir = scratch("units-roi-video");
    let video = root().join("reference-data/p2020-flicker-videos/test_vid3.mp4");
    let plan = captured_plan(
        &dir,
        &[&format!("source = \"{}\"", video.display())],
        &[("edge", 1275, 10, 10, 2)],
    );
    let o = ledflicker_in(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("`roi[0].x-px`: ROI `edge` (columns 1275..1285, rows 10..12) falls outside the 1280x800 frame"),
        "{err}"
    );
}

#[test]
fn a_reader_names_the_roi_off_its_frame() {
    let dir = scratch("units-roi-reader");
    let png = dir.join("f.png");
    save_png(&png, 8, 8, 50);
    let opts = ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: VideoDecode::Rgb,
        range: VideoRange::Auto,
        colour_transfer: ledflicker::capture::ColourTransfer::Linear,
        fps: Some(30.0),
        decoder_threads: None,
    };
    let rois = [
        RoiRect {
            x: 0,
            y: 0,
            width: 2,
            height: 2,
        },
        RoiRect {
            x: 6,
            y: 0,
            width: 4,
            height: 2,
        },
    ];
    let names = ["ok".to_string(), "wide".to_string()];
    let e = capture::read_capture(&png, &rois, &names, &opts).unwrap_err();
    assert!(e.is_input_error());
    let text = e.to_string();
    assert!(
        text.contains("frame 0: ROI `wide` (columns 6..10, rows 0..2) falls outside the 8x8 frame"),
        "{text}"
    );
    // Without names, the ROI is named by its key path, counted from 0.
    let e = capture::read_capture(&png, &rois, &[], &opts).unwrap_err();
    assert!(e.to_string().contains("ROI `roi[1]`"), "{e}");
}

#[test]
fn shipped_plans_validate_without_a_warning() {
    let mut plans: Vec<PathBuf> = std::fs::read_dir(root().join("test-plans"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    plans.sort();
    assert!(plans.len() >= 7, "{plans:?}");
    for plan in &plans {
        let o = ledflicker_in(&["validate", plan.to_str().unwrap()], root());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(0), "{}: {err}", plan.display());
        assert!(!err.contains("warning"), "{}: {err}", plan.display());
    }
}
