//! `ledflicker roi`: a plan's ROIs drawn on its captures, and ROIs
//! proposed from a capture (docs/roi.md), on the IEEE P2020 sample videos.

use ledflicker::analysis::roi::detect::{DetectOptions, detect};
use ledflicker::capture::ReadOptions;
use ledflicker::plan::{self, RoiKind, VideoDecode};
use ledflicker::trace::DetectionRule;

use super::{ledflicker_in, root, scratch, stderr, text};

/// The shipped plan's ROIs sit on the lit target of the P2020 sample
/// videos. Coverage of a plan ROI is the share of its pixels that belong
/// to a lit region detection found; every ROI must reach 80 %, and the
/// region that holds it gets a proposed LED strip inside it.
#[test]
fn detect_on_the_p2020_videos_covers_the_shipped_plans_rois() {
    let plan = plan::load(&root().join("test-plans/p2020-samples.toml")).unwrap();
    let cap = plan.capture.as_ref().unwrap();
    // The plan's luma, from the Y' plane as `roi --detect` reads video.
    let read = ReadOptions {
        video_decode: VideoDecode::LumaPlane,
        ..ledflicker::backend::captured::read_options(cap)
    };
    let opts = DetectOptions {
        read,
        on_s: 2.0,
        off_s: 2.0,
        settle_s: plan::DEFAULT_SETTLE_S,
    };
    for case in &cap.cases {
        let p = detect(&case.source, &opts).unwrap();
        // The videos start dark, then the light comes on.
        assert_eq!(p.rule, DetectionRule::OffThenPwm, "{}", case.id);
        let mut worst = 1.0f64;
        for roi in &plan.rois {
            let mut covered = 0;
            for y in roi.y_px..roi.y_px + roi.height_px {
                for x in roi.x_px..roi.x_px + roi.width_px {
                    covered += usize::from(p.blob_at(x, y).is_some());
                }
            }
            let share = covered as f64 / f64::from(roi.width_px * roi.height_px);
            worst = worst.min(share);
            assert!(share >= 0.8, "{}: {} covered {share:.2}", case.id, roi.name);
            let blob = p.blob_at(roi.x_px + roi.width_px / 2, roi.y_px).unwrap();
            let strip = p
                .rois
                .iter()
                .find(|r| r.blob == blob && r.kind == RoiKind::Led)
                .unwrap_or_else(|| panic!("{}: no strip in region {blob}", case.id));
            // The strip lies in the region: both its rows, end to end.
            for x in strip.rect.x..strip.rect.x + strip.rect.width {
                for y in strip.rect.y..strip.rect.y + 2 {
                    assert_eq!(p.blob_at(x, y), Some(blob), "{}: ({x}, {y})", case.id);
                }
            }
        }
        eprintln!("{}: least covered plan ROI {:.0} %", case.id, 100.0 * worst);
    }
}

/// `roi PLAN` writes one full-resolution picture per capture, prints where
/// and the ROI table, replaces its own pictures on a second run, and
/// refuses a directory it did not write.
#[test]
fn roi_plan_draws_each_capture_and_prints_the_roi_table() {
    let dir = scratch("roi-plan");
    let plan = root().join("test-plans/p2020-samples.toml");
    let plan = plan.to_str().unwrap();
    let o = ledflicker_in(&["roi", plan, "--out", "pics"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for id in ["test_vid1", "test_vid2", "test_vid3"] {
        let png = dir.join("pics").join(format!("{id}.png"));
        let img = image::open(&png).unwrap_or_else(|e| panic!("{png:?}: {e}"));
        assert_eq!((img.width(), img.height()), (1280, 800));
        // The first frames are black: the picture is of the first lit one.
        assert!(
            out.contains(&format!("{id}: pics/{id}.png (frame ")),
            "{out}"
        );
        assert!(
            !out.contains(&format!("{id}: pics/{id}.png (frame 0,")),
            "{out}"
        );
        // roi0 is outlined in red just left of its first pixel.
        let px = img.to_rgb8().get_pixel(456, 247).0;
        assert_eq!(px, [235, 40, 40], "{id}");
    }
    // The table: a header and one row per ROI, in plan order.
    let rows: Vec<&str> = out.lines().skip_while(|l| !l.starts_with("name")).collect();
    assert_eq!(rows.len(), 37, "{out}");
    let roi0: Vec<&str> = rows[1].split_whitespace().collect();
    assert_eq!(roi0, ["roi0", "led", "457", "247", "20", "2"]);
    let again = ledflicker_in(&["roi", plan, "--out", "pics"], &dir);
    assert_eq!(again.status.code(), Some(0), "{}", text(&again));
    std::fs::create_dir(dir.join("mine")).unwrap();
    std::fs::write(dir.join("mine/test_vid1.png"), b"not ledflicker's").unwrap();
    let refused = ledflicker_in(&["roi", plan, "--out", "mine"], &dir);
    assert_eq!(refused.status.code(), Some(2));
    assert!(
        stderr(&refused).contains("did not write"),
        "{}",
        stderr(&refused)
    );
    assert_eq!(
        std::fs::read(dir.join("mine/test_vid1.png")).unwrap(),
        b"not ledflicker's"
    );
}

/// `roi --detect` prints `[[roi]]` blocks that, pasted into a plan, make
/// it valid; with --out it writes the picture of what it found.
#[test]
fn roi_detect_prints_blocks_that_a_plan_accepts() {
    let dir = scratch("roi-detect");
    let video = root().join("reference-data/p2020-flicker-videos/test_vid3.mp4");
    let video = video.to_str().unwrap();
    let o = ledflicker_in(&["roi", "--detect", video, "--out", "pics"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let blocks = String::from_utf8(o.stdout).unwrap();
    assert!(
        blocks.contains("[[roi]]\nname = \"led1\"\nkind = \"led\""),
        "{blocks}"
    );
    let img = image::open(dir.join("pics/test_vid3-detect.png")).unwrap();
    assert_eq!((img.width(), img.height()), (1280, 800));
    let plan = format!(
        "format-version = 2\n[plan]\nid = \"pasted\"\ntitle = \"pasted ROIs\"\n\
         [dut]\nbackend = \"captured\"\n[capture]\noff-frames = [0, 25]\npwm-frames = [100]\n\
         [[case]]\nid = \"vid3\"\nsource = \"{video}\"\n\n{blocks}"
    );
    std::fs::write(dir.join("pasted.toml"), plan).unwrap();
    let v = ledflicker_in(&["validate", "pasted.toml"], &dir);
    assert_eq!(v.status.code(), Some(0), "{}", text(&v));
    assert!(text(&v).contains("2 ROIs"), "{}", text(&v));
}

#[test]
fn roi_detect_refuses_a_missing_capture_and_a_still_one_with_hints() {
    let dir = scratch("roi-bad");
    let o = ledflicker_in(&["roi", "--detect", "nowhere.mp4"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let e = stderr(&o);
    assert!(
        e.starts_with("error: cannot read capture `nowhere.mp4`"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    // The sample TIFF is one frame: nothing changes, so no step.
    let tiff = root().join("reference-data/p2020-flicker-videos/test.tiff");
    let tiff = tiff.to_str().unwrap();
    let o = ledflicker_in(&["roi", "--detect", tiff], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("hint: give its frame rate, e.g. --fps 30"),
        "{}",
        stderr(&o)
    );
    let o = ledflicker_in(&["roi", "--detect", tiff, "--fps", "30"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let e = stderr(&o);
    assert!(e.contains("no ON -> OFF step"), "{e}");
    assert!(e.contains("hint: "), "{e}");
    // A plan is not a capture, and a capture is not a plan.
    let o = ledflicker_in(&["roi"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = ledflicker_in(&["roi", "--detect", "a.mp4", "--on-s", "0"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("--on-s and --off-s must be > 0 s"),
        "{}",
        stderr(&o)
    );
}

/// The completions and the manual page come from the command line's
/// definition: `roi` and its flags are in them.
#[test]
fn roi_is_in_the_completions_and_the_manual_pages() {
    let bash = super::text(&super::ledflicker(&["completions", "bash"]));
    assert!(
        bash.contains("roi") && bash.contains("--detect"),
        "bash completions lack `roi`"
    );
    let page = super::text(&super::ledflicker(&["man", "roi"]));
    assert!(
        page.contains("ledflicker\\-roi") && page.contains("\\-\\-detect"),
        "{page}"
    );
}
