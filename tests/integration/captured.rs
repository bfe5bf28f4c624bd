//! Captured data: the P2020 sample videos against the reference pipeline,
//! image sequences, Y4M, CSV traces, the lab-rig command backend, line time,
//! and bad input (exit code 2, naming the file and frame).
//!
//! The video tests need the `ffmpeg` binary; scripts/test.sh installs it.
//! They fail (never skip) without it.

use std::collections::HashMap;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;

use ledflicker::capture::{
    self, LumaWeights, ReadOptions, RoiRect, VideoDecode, VideoRange, read_capture,
};
use serde_json::Value;

use crate::{ledflicker_in as ledflicker, root, scratch, stderr};

const VIDEOS: [&str; 3] = ["test_vid1", "test_vid2", "test_vid3"];

fn data(file: &str) -> PathBuf {
    root()
        .join("reference-data/p2020-flicker-videos")
        .join(file)
}

fn need_ffmpeg() {
    assert!(
        capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them (apt-get install ffmpeg)"
    );
}

fn csv_rows(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

/// The 36 ROIs of rois.csv, in file order, as the reference code truncates them.
fn sample_rois() -> Vec<RoiRect> {
    csv_rows(&data("rois.csv"))
        .iter()
        .map(|r| RoiRect {
            x: r["x_int"].parse().unwrap(),
            y: r["y_int"].parse().unwrap(),
            width: r["w_int"].parse().unwrap(),
            height: r["h_int"].parse().unwrap(),
        })
        .collect()
}

fn opts(decode: VideoDecode) -> ReadOptions {
    ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: decode,
        range: VideoRange::Auto,
        colour_transfer: ledflicker::capture::ColourTransfer::Linear,
        fps: None,
        decoder_threads: None,
    }
}

/// Runs `plan` into `dir/out` (exit 0 or 1); its results.json.
pub(crate) fn run_plan(plan: &Path, dir: &Path) -> Value {
    let out = dir.join("out");
    let o = ledflicker(
        &[
            "plan",
            plan.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ],
        dir,
    );
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{}",
        stderr(&o)
    );
    serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
}

#[test]
fn p2020_samples_agree_with_the_reference_pipeline_per_roi() {
    need_ffmpeg();
    let dir = scratch("p2020-samples");
    let json = run_plan(&root().join("test-plans/p2020-samples.toml"), &dir);
    let expected = csv_rows(&data("expected_p2020.csv"));
    let cases = json["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 3);
    for (case, name) in cases.iter().zip(VIDEOS) {
        assert_eq!(case["id"], name);
        assert!(
            case["source"]
                .as_str()
                .unwrap()
                .ends_with(&format!("{name}.mp4"))
        );
        assert!(
            case["frequency_hz"].is_null(),
            "unknown conditions are null"
        );
        let pwm = case["capture"]["segments"]["pwm"].as_array().unwrap();
        assert_eq!(pwm[0], 100);
        let rois = case["rois"].as_array().unwrap();
        assert_eq!(rois.len(), 36);
        let exp: Vec<_> = expected.iter().filter(|r| r["video"] == name).collect();
        let n_pwm = (pwm[1].as_u64().unwrap() - 100) as f64;
        // Tolerances for a different H.264 decoder (about 1 DN): FMI within
        // 0.005, FDI and MMP within 2 frames of the PWM segment.
        let (mut d_fmi, mut d_fdi, mut d_mmp) = (0.0f64, 0.0f64, 0.0f64);
        for (roi, e) in rois.iter().zip(exp) {
            let m = &roi["metrics"];
            let get = |k: &str| m[k].as_f64().unwrap_or_else(|| panic!("{name} {k}: {m}"));
            let want = |k: &str| e[k].parse::<f64>().unwrap();
            d_fmi = d_fmi.max((get("fmi") - want("fmi")).abs());
            d_fdi = d_fdi.max((get("fdi_p2020") - want("fdi_p2020")).abs());
            d_mmp = d_mmp.max((get("mmp") - want("mmp")).abs());
            let x_off = roi["levels"]["off"].as_f64().unwrap();
            assert!(
                (x_off - want("x_off")).abs() <= 1.0,
                "{name}: x_off {x_off}"
            );
            assert_eq!(roi["saturated"], e["saturated"] == "1", "{name} saturation");
        }
        eprintln!("{name}: max |diff| fmi {d_fmi:.2e} fdi {d_fdi:.2e} mmp {d_mmp:.2e}");
        assert!(d_fmi <= 0.005, "{name}: FMI differs by {d_fmi}");
        assert!(
            d_fdi <= 2.0 / n_pwm + 1e-9,
            "{name}: FDI differs by {d_fdi}"
        );
        assert!(
            d_mmp <= 2.0 / n_pwm + 1e-9,
            "{name}: MMP differs by {d_mmp}"
        );
    }
}

#[test]
fn p2020_sample_report_draws_each_videos_phase_folds_as_one_chart_of_panels() {
    need_ffmpeg();
    let dir = scratch("p2020-folds");
    let json = run_plan(&root().join("test-plans/p2020-samples.toml"), &dir);
    let out = dir.join("out");
    for case in json["cases"].as_array().unwrap() {
        let id = case["id"].as_str().unwrap();
        // The ROIs whose fold is drawn (the others are a sentence).
        let names: Vec<&str> = case["rois"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|r| r["analysis"]["phase_coverage"]["covered_bins"].as_u64() >= Some(4))
            .map(|r| r["name"].as_str().unwrap())
            .collect();
        assert!(names.len() >= 35, "{id}: {} folds drawn", names.len());
        let folds: Vec<PathBuf> = std::fs::read_dir(out.join("charts"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| {
                let name = p.file_name().unwrap().to_string_lossy();
                name.starts_with(&format!("fold-{id}-"))
            })
            .collect();
        assert_eq!(folds.len(), 1, "{id}: {folds:?}");
        // Every ROI keeps its panel, named, with its Percent Flicker.
        let svg = std::fs::read_to_string(&folds[0]).unwrap();
        for name in &names {
            assert!(
                svg.contains(&format!("\n{name}\n")),
                "{id}: no panel {name}"
            );
        }
        assert_eq!(svg.matches("\nPF ").count(), names.len(), "{id}");
    }
    let pdf = out.join("report.pdf");
    if !pdf.exists() {
        return; // built without the `pdf` feature
    }
    let info = Command::new("pdfinfo").arg(&pdf).output().unwrap();
    let info = String::from_utf8_lossy(&info.stdout).into_owned();
    let pages: usize = info
        .lines()
        .find_map(|l| l.strip_prefix("Pages:"))
        .and_then(|n| n.trim().parse().ok())
        .unwrap();
    assert!(pages <= 20, "{pages} pages");
    // The panels' ROI names and figures are set at 7 pt at least in print
    // (pdftotext's word boxes are as tall as the font is large).
    let o = Command::new("pdftotext")
        .args(["-bbox", pdf.to_str().unwrap(), "-"])
        .output()
        .unwrap();
    let boxes = String::from_utf8_lossy(&o.stdout).into_owned();
    let attr = |line: &str, key: &str| -> f64 {
        let at = line.find(&format!("{key}=\"")).unwrap() + key.len() + 2;
        line[at..].split('"').next().unwrap().parse().unwrap()
    };
    // Only the pages of the panels: "PF" is in other tables too.
    let fold_pages = boxes
        .split("<page ")
        .filter(|page| page.contains(">panel:</word>"));
    let mut panels = 0;
    for line in fold_pages
        .flat_map(str::lines)
        .filter(|l| l.contains("<word"))
    {
        let word = line
            .rsplit_once("\">")
            .map_or("", |(_, w)| w.trim_end_matches("</word>"));
        if word == "PF" {
            panels += 1;
            let height = attr(line, "yMax") - attr(line, "yMin");
            assert!(height >= 7.0 - 1e-3, "panel text {height:.2} pt high");
        }
    }
    assert!(panels >= 72, "{panels} panel figures in the PDF");
}

fn grey_diff(name: &str, decode: VideoDecode) -> (f64, f64) {
    let rois = sample_rois();
    let trace = read_capture(&data(&format!("{name}.mp4")), &rois, &[], &opts(decode)).unwrap();
    let expected = csv_rows(&data(&format!("expected_grey_{name}.csv")));
    assert_eq!(trace.time_s.len(), expected.len(), "{name}: frame count");
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0.0);
    for (k, row) in expected.iter().enumerate() {
        for (i, t) in trace.luma.iter().enumerate() {
            let d = t[k] - row[&format!("roi{i}")].parse::<f64>().unwrap();
            max = max.max(d.abs());
            sum += d.abs();
            n += 1.0;
        }
    }
    (max, sum / n)
}

#[test]
fn video_grey_matches_the_reference_frame_by_frame() {
    need_ffmpeg();
    for name in VIDEOS {
        // RGB decode: the reference's own conversion, so within rounding.
        let (max, mean) = grey_diff(name, VideoDecode::Rgb);
        eprintln!("{name} rgb: max {max:.3} mean {mean:.4} DN");
        assert!(max <= 0.5, "{name}: rgb grey differs by {max} DN");
        // Y' plane, range-expanded: about 1 DN (swscale's RGB path rounds down).
        let (max, mean) = grey_diff(name, VideoDecode::LumaPlane);
        eprintln!("{name} luma-plane: max {max:.3} mean {mean:.4} DN");
        assert!(
            max <= 2.5 && mean <= 1.5,
            "{name}: luma-plane differs by {max} (mean {mean}) DN"
        );
    }
}

#[test]
fn video_timestamps_come_from_the_container() {
    need_ffmpeg();
    let trace = read_capture(
        &data("test_vid3.mp4"),
        &sample_rois(),
        &[],
        &opts(VideoDecode::Rgb),
    )
    .unwrap();
    assert_eq!(trace.timestamps, "container");
    assert_eq!(trace.time_s.len(), 369);
    // About 30 fps (the PTS span gives 29.9; OpenCV's average rate 30.08).
    let fps = 368.0 / trace.time_s[368];
    assert!((fps - 30.0).abs() < 0.3, "{fps}");
    assert!(trace.time_s.windows(2).all(|w| w[1] > w[0]));
    // R, G, B means come with the RGB decode.
    assert_eq!(trace.rgb.as_ref().unwrap().len(), 36);
}

#[test]
fn lzw_rgb_tiff_rois_match_opencv() {
    let rois = sample_rois();
    let trace = read_capture(
        &data("test.tiff"),
        &rois,
        &[],
        &ReadOptions {
            fps: Some(30.0),
            decoder_threads: None,
            ..opts(VideoDecode::Rgb)
        },
    )
    .unwrap();
    let rgb = trace.rgb.unwrap();
    for (i, e) in csv_rows(&data("expected_tiff_rois.csv")).iter().enumerate() {
        let want = |k: &str| e[k].parse::<f64>().unwrap();
        assert!((trace.luma[i][0] - want("grey")).abs() < 1e-3, "roi {i}");
        for (c, k) in ["r", "g", "b"].iter().enumerate() {
            assert!((rgb[i][0][c] - want(k)).abs() < 1e-3, "roi {i} {k}");
        }
    }
}

#[test]
fn segments_are_detected_from_the_dark_baseline_and_the_on_step() {
    need_ffmpeg();
    let dir = scratch("detect");
    let text = std::fs::read_to_string(root().join("test-plans/p2020-samples.toml"))
        .unwrap()
        .replace("off-frames = [0, 25]\n", "")
        .replace("pwm-frames = [100]\n", "")
        // No ON segment in these recordings: the off-then-pwm rule.
        .replace("[dut]\n", "[sequence]\non-s = 0.0\n\n[dut]\n")
        .replace(
            "../reference-data",
            root().join("reference-data").to_str().unwrap(),
        );
    let plan = dir.join("detect.toml");
    std::fs::write(&plan, text).unwrap();
    let json = run_plan(&plan, &dir);
    for case in json["cases"].as_array().unwrap() {
        let s = &case["capture"]["segments"];
        assert_eq!(s["method"], "detected");
        assert_eq!(s["rule"], "off-then-pwm");
        let off_end = s["off"][1].as_u64().unwrap();
        let pwm_start = s["pwm"][0].as_u64().unwrap();
        // SOURCE.md: the first ~48-71 frames are black.
        assert!((40..=75).contains(&off_end), "{}: {s}", case["id"]);
        assert!(
            pwm_start > off_end && pwm_start < 100,
            "{}: {s}",
            case["id"]
        );
        for roi in case["rois"].as_array().unwrap() {
            assert_eq!(roi["levels"]["off"].as_f64(), Some(0.0));
        }
    }
}

/// A captured plan with one case and one ROI.
fn one_case_plan(dir: &Path, source: &str, roi: (u32, u32, u32, u32), extra: &str) -> PathBuf {
    let text = format!(
        "[plan]\nid = \"t\"\ntitle = \"t\"\n[dut]\nbackend = \"captured\"\n[capture]\nframe-rate-fps = 30.0\n{extra}\n[[case]]\nsource = \"{source}\"\n[[roi]]\nname = \"a\"\nx-px = {}\ny-px = {}\nwidth-px = {}\nheight-px = {}\n",
        roi.0, roi.1, roi.2, roi.3
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn save_grey16(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> u16) {
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| image::Luma([f(x, y)]))
        .save(path)
        .unwrap();
}

#[test]
fn png_sequences_8_and_16_bit_give_exact_roi_means() {
    let dir = scratch("png-seq");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    // Frames 0-3 dark (OFF), 4-9 with a level that alternates (PWM).
    let level = |k: u32| {
        if k < 4 {
            1000
        } else if k.is_multiple_of(2) {
            30000
        } else {
            20000
        }
    };
    for k in 0..10u32 {
        save_grey16(&frames.join(format!("f{k:03}.png")), 16, 8, |x, _| {
            level(k) + x as u16
        });
    }
    let plan = one_case_plan(
        &dir,
        "frames",
        (2, 3, 4, 2),
        "off-frames = [0, 4]\npwm-frames = [4]",
    );
    let json = run_plan(&plan, &dir);
    let roi = &json["cases"][0]["rois"][0];
    // Columns 2..6 add 2..5: mean +3.5.
    assert_eq!(roi["levels"]["off"].as_f64(), Some(1003.5));
    assert_eq!(roi["levels"]["max"].as_f64(), Some(30003.5));
    let fmi = roi["metrics"]["fmi"].as_f64().unwrap();
    assert!((fmi - 10000.0 / 50007.0).abs() < 1e-12, "{fmi}");
    assert_eq!(roi["metrics"]["fdi_p2020"].as_f64(), Some(1.0));

    // 8-bit RGB frames: BT.601 and BT.709 luma differ as they should.
    let rgb = dir.join("rgb");
    std::fs::create_dir_all(&rgb).unwrap();
    image::RgbImage::from_pixel(8, 4, image::Rgb([200, 100, 50]))
        .save(rgb.join("a.png"))
        .unwrap();
    let rois = [RoiRect {
        x: 0,
        y: 0,
        width: 8,
        height: 4,
    }];
    let mut o = ReadOptions {
        fps: Some(30.0),
        decoder_threads: None,
        ..opts(VideoDecode::Rgb)
    };
    let t = read_capture(&rgb, &rois, &[], &o).unwrap();
    assert_eq!(t.luma[0][0], 124.0); // round(0.299*200 + 0.587*100 + 0.114*50)
    assert_eq!(t.rgb.unwrap()[0][0], [200.0, 100.0, 50.0]);
    o.luma = LumaWeights::Bt709;
    let t = read_capture(&rgb, &rois, &[], &o).unwrap();
    assert_eq!(t.luma[0][0], 118.0); // round(0.2126*200 + 0.7152*100 + 0.0722*50)
}

fn write_y4m(path: &Path, header: &str, frames: &[Vec<u8>]) {
    let mut bytes = format!("YUV4MPEG2 {header}\n").into_bytes();
    for f in frames {
        bytes.extend_from_slice(b"FRAME\n");
        bytes.extend_from_slice(f);
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn y4m_reads_only_the_luma_plane_and_expands_limited_range() {
    let dir = scratch("y4m");
    let (w, h) = (8usize, 6usize);
    let frame = |y: u8| {
        let mut f = vec![y; w * h];
        f.extend(vec![128u8; 2 * (w / 2) * (h / 2)]);
        f
    };
    let path = dir.join("c.y4m");
    write_y4m(
        &path,
        "W8 H6 F30:1 C420jpeg",
        &[frame(16), frame(235), frame(126)],
    );
    let rois = [RoiRect {
        x: 1,
        y: 2,
        width: 4,
        height: 2,
    }];
    let t = read_capture(&path, &rois, &[], &opts(VideoDecode::Rgb)).unwrap();
    assert_eq!(t.luma[0], vec![0.0, 255.0, 128.0]);
    assert_eq!(t.time_s[2], 2.0 / 30.0);
    write_y4m(&path, "W8 H6 F30:1 C420jpeg XCOLORRANGE=FULL", &[frame(16)]);
    assert_eq!(
        read_capture(&path, &rois, &[], &opts(VideoDecode::Rgb))
            .unwrap()
            .luma[0],
        vec![16.0]
    );
    // A truncated last frame is named.
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() - 5);
    std::fs::write(&path, bytes).unwrap();
    let e = read_capture(&path, &rois, &[], &opts(VideoDecode::Rgb)).unwrap_err();
    assert!(
        e.to_string().contains("frame 0") && e.to_string().contains("truncated"),
        "{e}"
    );
}

#[test]
fn csv_traces_from_other_tools_are_measured() {
    let dir = scratch("csv-trace");
    let mut text = String::from("frame,time_s,a\n");
    for k in 0..20 {
        let v = if k < 5 {
            10.0
        } else if k % 3 == 0 {
            60.0
        } else {
            100.0
        };
        text += &format!("{k},{},{v}\n", k as f64 / 25.0);
    }
    std::fs::write(dir.join("t.csv"), text).unwrap();
    let plan = one_case_plan(
        &dir,
        "t.csv",
        (0, 0, 1, 1),
        "off-time-s = [0.0, 0.2]\npwm-time-s = [0.2]",
    );
    let json = run_plan(&plan, &dir);
    let case = &json["cases"][0];
    assert_eq!(case["capture"]["timestamps"], "csv");
    // A trace has no frame to show, so no lit frame is named.
    assert!(case["capture"].get("lit_frame").is_none(), "{case}");
    assert_eq!(
        case["capture"]["segments"]["off"],
        serde_json::json!([0, 5])
    );
    let m = &case["rois"][0]["metrics"];
    assert_eq!(m["fmi"].as_f64(), Some(40.0 / 160.0));
    assert_eq!(m["percent_flicker"].as_f64(), Some(25.0));
    // PWM mean: 5 of 15 frames at 60, 10 at 100 -> 86.67; band (78, 95.3).
    assert_eq!(m["mmp"].as_f64(), Some(0.0));
}

fn expect_invalid(dir: &Path, plan: &Path, needles: &[&str]) {
    let o = ledflicker(
        &[
            "plan",
            plan.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ],
        dir,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dir.join("o/results.json").exists());
}

#[test]
fn bad_captures_exit_2_naming_the_file_and_frame() {
    let dir = scratch("bad-captures");
    // Missing file: found by validation, with its key and line.
    let plan = one_case_plan(&dir, "nope.mp4", (0, 0, 1, 1), "");
    expect_invalid(
        &dir,
        &plan,
        &["case[0].source", "nope.mp4", "does not exist", "line 10"],
    );

    // Mixed frame sizes and a corrupt frame in an image sequence.
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..3 {
        save_grey16(&frames.join(format!("f{k}.png")), 8, 8, |_, _| 100);
    }
    save_grey16(&frames.join("f3.png"), 8, 6, |_, _| 100);
    let plan = one_case_plan(&dir, "frames", (0, 0, 2, 2), "");
    expect_invalid(&dir, &plan, &["f3.png", "frame 3", "mixed frame sizes"]);
    std::fs::write(frames.join("f3.png"), b"\x89PNG\r\n\x1a\n garbage").unwrap();
    expect_invalid(&dir, &plan, &["f3.png", "frame 3", "corrupt"]);
    std::fs::remove_file(frames.join("f3.png")).unwrap();

    // ROI outside the frame: found by validation, at the ROI's line.
    let plan = one_case_plan(&dir, "frames", (6, 0, 4, 2), "");
    expect_invalid(
        &dir,
        &plan,
        &["roi[0].x-px", "ROI `a`", "outside the 8x8 frame"],
    );

    // A capture shorter than the plan's segments.
    let plan = one_case_plan(
        &dir,
        "frames",
        (0, 0, 2, 2),
        "off-frames = [0, 1]\npwm-frames = [1, 50]",
    );
    expect_invalid(
        &dir,
        &plan,
        &[
            "frames",
            "has 3 frames, shorter than the plan's PWM segment",
        ],
    );

    // Uniform frames: nothing to detect.
    let plan = one_case_plan(&dir, "frames", (0, 0, 2, 2), "");
    expect_invalid(&dir, &plan, &["cannot detect segments", "hint"]);
}

#[test]
fn bad_videos_exit_2_naming_the_file() {
    need_ffmpeg();
    let dir = scratch("bad-videos");
    // An empty file and a truncated MP4.
    std::fs::write(dir.join("empty.mp4"), b"").unwrap();
    let plan = one_case_plan(&dir, "empty.mp4", (0, 0, 2, 2), "");
    expect_invalid(&dir, &plan, &["empty.mp4"]);
    let bytes = std::fs::read(data("test_vid1.mp4")).unwrap();
    std::fs::write(dir.join("cut.mp4"), &bytes[..bytes.len() / 2]).unwrap();
    let plan = one_case_plan(&dir, "cut.mp4", (0, 0, 2, 2), "");
    expect_invalid(&dir, &plan, &["cut.mp4"]);
    // A video with no frames.
    let o = Command::new("ffmpeg")
        .args([
            "-v",
            "error",
            "-y",
            "-f",
            "lavfi",
            "-i",
            "color=c=black:s=64x48:r=30",
        ])
        .args(["-frames:v", "0", "-c:v", "libx264"])
        .arg(dir.join("zero.mp4"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let plan = one_case_plan(&dir, "zero.mp4", (0, 0, 2, 2), "");
    expect_invalid(&dir, &plan, &["zero.mp4"]);
    // ROI outside the 1280x800 frame.
    std::fs::copy(data("test_vid3.mp4"), dir.join("v.mp4")).unwrap();
    let plan = one_case_plan(&dir, "v.mp4", (1270, 0, 20, 2), "");
    expect_invalid(
        &dir,
        &plan,
        &[
            "v.mp4",
            "roi[0].x-px",
            "ROI `a`",
            "outside the 1280x800 frame",
        ],
    );
}

#[test]
fn command_backend_runs_the_example_rig_end_to_end() {
    let dir = scratch("command-rig");
    let json = run_plan(&root().join("test-plans/command-sim-rig.toml"), &dir);
    assert_eq!(json["dut"]["backend"], "command");
    let cases = json["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 4);
    for case in cases {
        // The rig's frames against the simulator's exact trace for the ROI
        // rows: each pixel is 20 + 200 s rounded, so within 0.5 DN.
        let f = case["frequency_hz"].as_f64().unwrap();
        let d = case["duty"].as_f64().unwrap();
        let o = ledflicker(
            &[
                "simulate",
                "--frequency-hz",
                &f.to_string(),
                "--duty",
                &d.to_string(),
                "--exposure-ms",
                "11.111",
                "--fps",
                "30",
                "--frames",
                "90",
                "--shutter",
                "rolling",
                "--line-time-us",
                "14.565",
                "--rows",
                "20:22",
            ],
            root(),
        );
        let sim: Vec<f64> = String::from_utf8_lossy(&o.stdout)
            .lines()
            .skip(1 + 30)
            .map(|l| 20.0 + 200.0 * l.split(',').nth(2).unwrap().parse::<f64>().unwrap())
            .collect();
        let lo = sim.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = sim.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let levels = &case["rois"][0]["levels"];
        assert!(
            (levels["min"].as_f64().unwrap() - lo).abs() <= 0.5,
            "{}: {levels} vs {lo}",
            case["id"]
        );
        assert!(
            (levels["max"].as_f64().unwrap() - hi).abs() <= 0.5,
            "{}: {levels} vs {hi}",
            case["id"]
        );
        assert_eq!(levels["off"].as_f64(), Some(20.0));
        assert_eq!(
            case["capture"]["segments"]["pwm"],
            serde_json::json!([30, 90])
        );
    }
}

#[test]
fn command_backend_timeout_and_failure_are_backend_errors() {
    let dir = scratch("command-bad");
    let base = std::fs::read_to_string(root().join("test-plans/command-sim-rig.toml")).unwrap();
    for (cmd, needle) in [
        (
            "[\"sleep\", \"5\"]\ntimeout-s = 0.3",
            "did not finish within 0.3 s",
        ),
        (
            "[\"sh\", \"-c\", \"echo rig offline >&2; exit 4\"]",
            "rig offline",
        ),
    ] {
        let text = base
            .replace(
                "command = [\"sh\", \"../examples/sim-rig.sh\"]",
                &format!("command = {cmd}"),
            )
            .replace("timeout-s = 60.0\n", "");
        let plan = dir.join("p.toml");
        std::fs::write(&plan, text).unwrap();
        let o = ledflicker(
            &[
                "plan",
                plan.to_str().unwrap(),
                "--out",
                dir.join("o").to_str().unwrap(),
            ],
            &dir,
        );
        assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{}", stderr(&o));
    }
}

#[test]
fn linetime_of_the_gyroflow_frame_matches_the_stated_readout() {
    let o = ledflicker(
        &[
            "linetime",
            "reference-data/gyroflow-rs-banding/frame_example.png",
            "--frequency-hz",
            "1000",
        ],
        root(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let us: f64 = out.lines().next().unwrap().trim().parse().unwrap();
    // Upstream: 15.730 ms readout over 1080 rows = 14.565 us per line.
    assert!((us / 14.565 - 1.0).abs() < 0.005, "{us} us");
    assert!(out.contains("band_period_rows: 68."), "{out}");
    let o = ledflicker(&["linetime", "nope.png", "--frequency-hz", "1000"], root());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nope.png"));
}

#[test]
fn sidecar_timestamps_override_the_frame_rate() {
    let dir = scratch("sidecar");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..3 {
        save_grey16(&frames.join(format!("f{k}.png")), 4, 4, |_, _| 7);
    }
    let rois = [RoiRect {
        x: 0,
        y: 0,
        width: 2,
        height: 2,
    }];
    let o = ReadOptions {
        fps: Some(30.0),
        decoder_threads: None,
        ..opts(VideoDecode::Rgb)
    };
    assert_eq!(
        read_capture(&frames, &rois, &[], &o).unwrap().time_s[2],
        2.0 / 30.0
    );
    std::fs::write(
        dir.join("frames.timestamps.csv"),
        "frame,time_s\n0,0.0\n1,0.1\n2,0.25\n",
    )
    .unwrap();
    let t = read_capture(&frames, &rois, &[], &o).unwrap();
    assert_eq!(t.time_s, vec![0.0, 0.1, 0.25]);
    assert_eq!(t.timestamps, "sidecar");
    std::fs::write(dir.join("frames.timestamps.csv"), "0.0\n0.1\n").unwrap();
    let e = read_capture(&frames, &rois, &[], &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("2 timestamps for 3 frames"), "{e}");
    // No frame rate and no sidecar: an error with a hint, not NaN times.
    std::fs::remove_file(dir.join("frames.timestamps.csv")).unwrap();
    let e = read_capture(&frames, &rois, &[], &opts(VideoDecode::Rgb))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no timestamps") && e.contains("frame-rate-fps"),
        "{e}"
    );
}

#[test]
fn decoded_frames_are_counted_and_a_run_off_a_terminal_prints_no_progress() {
    let dir = scratch("decode-progress");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..10u32 {
        let level = if k < 4 {
            1000
        } else {
            20000 + 5000 * (k % 2) as u16
        };
        save_grey16(&frames.join(format!("f{k:03}.png")), 16, 8, |_, _| level);
    }
    let rois = [RoiRect {
        x: 2,
        y: 3,
        width: 4,
        height: 2,
    }];
    let o = ReadOptions {
        fps: Some(30.0),
        decoder_threads: None,
        ..opts(VideoDecode::Rgb)
    };
    let before = capture::frames_decoded();
    read_capture(&frames, &rois, &[], &o).unwrap();
    // Other tests in this process may decode at the same time.
    assert!(capture::frames_decoded() >= before + 10);

    // The progress line is for terminals: a run without -q whose stderr is
    // a pipe prints no "frames decoded".
    let plan = one_case_plan(
        &dir,
        "frames",
        (2, 3, 4, 2),
        "off-frames = [0, 4]\npwm-frames = [4]",
    );
    let out = dir.join("out");
    let args = [
        "plan",
        plan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let o = ledflicker(&args, &dir);
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{}",
        stderr(&o)
    );
    assert!(!stderr(&o).contains("decoded"), "{}", stderr(&o));
}

/// Processes whose command line names `needle` (a path of a scratch
/// directory), as their program names.
fn processes_naming(needle: &str) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let is_pid = entry
            .file_name()
            .to_string_lossy()
            .bytes()
            .all(|b| b.is_ascii_digit());
        let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) else {
            continue;
        };
        let args: Vec<String> = cmdline
            .split(|&b| b == 0)
            .map(|a| String::from_utf8_lossy(a).into_owned())
            .collect();
        if is_pid && args.iter().any(|a| a.contains(needle)) {
            found.push(args[0].clone());
        }
    }
    found.sort();
    found
}

/// ROIs touching the right and bottom edges of the frame (where FFmpeg
/// starts before the probe with a layout the frame then clamps, so a second
/// FFmpeg reads them) read the means of the pixels FFmpeg decodes for the
/// whole frame, computed here. (The sample videos are black at their
/// edges, so the video is FFmpeg's moving colour test pattern.)
#[test]
fn video_rois_touching_the_frame_edge_read_the_decoded_pixels() {
    need_ffmpeg();
    let dir = scratch("video-edge-rois");
    let path = dir.join("pattern.mp4");
    let (w, h, frames) = (320usize, 240usize, 12usize);
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-f", "lavfi", "-i"])
        .arg(format!("testsrc2=s={w}x{h}:r=30"))
        .args(["-frames:v", &frames.to_string(), "-c:v", "libx264"])
        .args(["-pix_fmt", "yuv420p"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let rect = |x, y, width, height| RoiRect {
        x,
        y,
        width,
        height,
    };
    // Right edge, bottom edge, bottom-right corner (odd), inside.
    let rois = [
        rect(310, 0, 10, 2),
        rect(100, 236, 6, 4),
        rect(313, 231, 7, 9),
        rect(150, 101, 20, 2),
    ];
    let trace = read_capture(&path, &rois, &[], &opts(VideoDecode::Rgb)).unwrap();
    assert_eq!(trace.luma[0].len(), frames);
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(&path)
        .args(["-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(o.stdout.len(), frames * w * h * 3);
    let mut distinct = std::collections::BTreeSet::new();
    for (k, frame) in o.stdout.chunks(w * h * 3).enumerate() {
        for (i, r) in rois.iter().enumerate() {
            let mut sum = 0u64;
            for y in r.y as usize..(r.y + r.height) as usize {
                for x in r.x as usize..(r.x + r.width) as usize {
                    let p = 3 * (y * w + x);
                    let [cr, cg, cb] = [frame[p], frame[p + 1], frame[p + 2]].map(u32::from);
                    sum += u64::from(LumaWeights::Bt601.luma(cr, cg, cb));
                }
            }
            let mean = sum as f64 / f64::from(r.width * r.height);
            let got = trace.luma[i][k];
            assert!(
                (got - mean).abs() < 1e-9,
                "ROI {i} frame {k}: {got} vs {mean}"
            );
            distinct.insert(mean.to_bits());
        }
    }
    // Not a trivially uniform picture.
    assert!(distinct.len() > 8, "{distinct:?}");
}

/// A file that is not a video is ffprobe's error, exit 2, and neither
/// FFmpeg tool is left running.
#[test]
fn a_capture_that_is_not_a_video_exits_2_and_leaves_no_ffmpeg_running() {
    need_ffmpeg();
    let dir = scratch("not-a-video");
    std::fs::write(dir.join("notes.mp4"), b"this is not a video\n").unwrap();
    let plan = one_case_plan(&dir, "notes.mp4", (0, 0, 2, 2), "");
    expect_invalid(
        &dir,
        &plan,
        &[
            "notes.mp4",
            "ffprobe cannot read it",
            "hint: check that the file is a complete video",
        ],
    );
    let dir_text = dir.to_string_lossy().into_owned();
    assert_eq!(processes_naming(&dir_text), Vec::<String>::new());
}

/// A capture FFmpeg reads for ever: `slow.ffconcat`, a regular file (so
/// ledflicker hands it to FFmpeg) whose only entry is a FIFO nobody
/// writes, which ffprobe and ffmpeg then wait on. Returns the FIFO.
fn stalling_video(dir: &Path) -> PathBuf {
    let fifo = dir.join("slow.mp4");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    std::fs::write(
        dir.join("slow.ffconcat"),
        "ffconcat version 1.0\nfile slow.mp4\n",
    )
    .unwrap();
    fifo
}

/// Interrupted while ffprobe (and ffmpeg, started with it) wait on a FIFO
/// nobody writes: the run stops with exit 130 naming the capture, and both
/// process groups are gone.
#[test]
fn an_interrupted_video_capture_leaves_no_ffmpeg_running() {
    need_ffmpeg();
    let dir = scratch("interrupted-video");
    let fifo = stalling_video(&dir);
    let plan = one_case_plan(&dir, "slow.ffconcat", (600, 400, 20, 2), "");
    let why = ["slow.ffconcat", "was stopped", "SIGINT"];
    interrupt_while_probing(&dir, &plan, &fifo, 2, &why);
}

/// Several videos are probed and their decoders started together, then
/// read one per core: interrupted while one probe waits on a FIFO, and the
/// other video's ffmpeg waits to be read, the run stops with exit 130, and
/// no FFmpeg process of either video is left.
#[test]
fn an_interrupted_capture_of_several_videos_leaves_no_ffmpeg_running() {
    need_ffmpeg();
    let dir = scratch("interrupted-videos");
    let fifo = stalling_video(&dir);
    std::fs::copy(data("test_vid3.mp4"), dir.join("v.mp4")).unwrap();
    let plan = cases_plan(&dir, &["v.mp4", "slow.ffconcat"], (600, 400, 20, 2));
    // The first case may be read, or stopped too, after the interrupt.
    interrupt_while_probing(&dir, &plan, &fifo, 3, &["was stopped", "SIGINT"]);
}

/// Among several videos, a file that is not a video is the same error as
/// alone (exit 2), whichever case it is, and no FFmpeg process is left.
#[test]
fn a_capture_that_is_not_a_video_among_videos_exits_2() {
    need_ffmpeg();
    let dir = scratch("not-a-video-among");
    std::fs::write(dir.join("notes.mp4"), b"this is not a video\n").unwrap();
    std::fs::copy(data("test_vid3.mp4"), dir.join("v.mp4")).unwrap();
    std::fs::copy(data("test_vid1.mp4"), dir.join("w.mp4")).unwrap();
    let needles = [
        "notes.mp4",
        "ffprobe cannot read it",
        "hint: check that the file is a complete video",
    ];
    for cases in [
        ["notes.mp4", "v.mp4", "w.mp4"],
        ["w.mp4", "notes.mp4", "v.mp4"],
    ] {
        let plan = cases_plan(&dir, &cases, (600, 400, 20, 2));
        expect_invalid(&dir, &plan, &needles);
    }
    let dir_text = dir.to_string_lossy().into_owned();
    assert_eq!(processes_naming(&dir_text), Vec::<String>::new());
}

/// A captured plan with one case per source and one ROI.
fn cases_plan(dir: &Path, sources: &[&str], roi: (u32, u32, u32, u32)) -> PathBuf {
    let mut text = "[plan]\nid = \"t\"\ntitle = \"t\"\n[dut]\nbackend = \"captured\"\n[capture]\nframe-rate-fps = 30.0\n".to_string();
    for (i, s) in sources.iter().enumerate() {
        text += &format!("[[case]]\nid = \"c{i}\"\nsource = \"{s}\"\n");
    }
    text += &format!(
        "[[roi]]\nname = \"a\"\nx-px = {}\ny-px = {}\nwidth-px = {}\nheight-px = {}\n",
        roi.0, roi.1, roi.2, roi.3
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `plan`, whose capture `fifo` nobody writes, until at least `tools`
/// FFmpeg processes name the scratch directory `dir`, interrupts it, and
/// checks that it stops with exit 130 saying so (`why`) and leaves none.
fn interrupt_while_probing(dir: &Path, plan: &Path, fifo: &Path, tools: usize, why: &[&str]) {
    let mut run = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["plan", plan.to_str().unwrap(), "--out"])
        .arg(dir.join("o"))
        .arg("-q")
        .current_dir(dir)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let needle = dir.to_string_lossy().into_owned();
    let start = std::time::Instant::now();
    let running = || {
        processes_naming(&needle)
            .iter()
            .filter(|p| p.ends_with("ffmpeg") || p.ends_with("ffprobe"))
            .count()
    };
    while running() < tools {
        assert!(
            start.elapsed().as_secs() < 60,
            "ffmpeg and ffprobe never started"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    // SAFETY: kill(2) on the child this test started.
    assert_eq!(
        unsafe { libc::kill(run.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let stopped = std::time::Instant::now();
    let status = loop {
        if let Some(status) = run.try_wait().unwrap() {
            break status;
        }
        if stopped.elapsed().as_secs() >= 60 {
            let _ = run.kill();
            // A writer lets the tools blocked on the FIFO go on, and end.
            let _ = std::fs::OpenOptions::new()
                .write(true)
                .custom_flags(libc::O_NONBLOCK)
                .open(fifo);
            panic!("ledflicker did not stop within 60 s of SIGINT");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut run.stderr.take().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    for w in why {
        assert!(err.contains(w), "`{w}` not in: {err}");
    }
    assert_eq!(processes_naming(&needle), Vec::<String>::new());
}
