use std::io::Write;

use super::*;
use ledflicker_plan::plan::{LumaWeights, VideoDecode, VideoRange};

/// Frame size of the generated captures.
const W: u32 = 160;
const H: u32 = 120;
/// The LED of the generated captures: odd position and size, so that an
/// off-by-one in any direction shows.
const LED: RoiRect = RoiRect {
    x: 57,
    y: 41,
    width: 37,
    height: 9,
};
const FPS: u32 = 30;

fn opts() -> DetectOptions {
    DetectOptions {
        read: ReadOptions {
            luma: LumaWeights::Bt601,
            video_decode: VideoDecode::Rgb,
            range: VideoRange::Auto,
            colour_transfer: ledflicker_acquisition::capture::ColourTransfer::Linear,
            fps: None,
            decoder_threads: None,
        },
        on_s: 2.0,
        off_s: 2.0,
        settle_s: ledflicker_plan::plan::DEFAULT_SETTLE_S,
    }
}

/// A noise source of its own (a 64-bit LCG), so that the frames are the
/// same on every run: the sum of 4 uniforms, about Gaussian, with standard
/// deviation `sd` DN.
struct Noise(u64);

impl Noise {
    fn next(&mut self, sd: f64) -> f64 {
        let mut s = 0.0;
        for _ in 0..4 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            s += (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        }
        // Var of one uniform on [-0.5, 0.5] is 1/12; of the sum of 4, 1/3.
        s * sd * 3f64.sqrt()
    }
}

/// Writes a full-range mono Y4M capture of `frames` (the LED's level in
/// each frame, DN) over a background that does not change: a gradient
/// from 30 to 70 DN, a brighter still patch (a sign that is not the lamp)
/// and noise of `sd` DN.
fn write_capture(path: &Path, led_levels: &[f64], sd: f64) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(
        f,
        "YUV4MPEG2 W{W} H{H} F{FPS}:1 Ip A1:1 Cmono XCOLORRANGE=FULL"
    )
    .unwrap();
    let mut noise = Noise(7);
    for &led in led_levels {
        f.write_all(b"FRAME\n").unwrap();
        let mut px = Vec::with_capacity((W * H) as usize);
        for y in 0..H {
            for x in 0..W {
                let inside =
                    |r: RoiRect| x >= r.x && x < r.x + r.width && y >= r.y && y < r.y + r.height;
                let background = 30.0 + 40.0 * f64::from(x) / f64::from(W);
                let sign = RoiRect {
                    x: 10,
                    y: 90,
                    width: 30,
                    height: 12,
                };
                let v = if inside(LED) {
                    led
                } else if inside(sign) {
                    180.0
                } else {
                    background
                };
                px.push((v + noise.next(sd)).round().clamp(0.0, 255.0) as u8);
            }
        }
        f.write_all(&px).unwrap();
    }
}

/// The paper's sequence at 30 fps: 2 s ON at 200 DN, 2 s OFF (the LED
/// shows the background behind it, 50 DN), 3 s PWM alternating 60 / 200 DN.
fn paper_sequence() -> Vec<f64> {
    let on = (0..2 * FPS).map(|_| 200.0);
    let off = (0..2 * FPS).map(|_| 50.0);
    let pwm = (0..3 * FPS).map(|k| if k % 3 == 0 { 60.0 } else { 200.0 });
    on.chain(off).chain(pwm).collect()
}

#[test]
fn detect_finds_the_rendered_led_exactly_with_a_strip_and_a_background_beside_it() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("seq.y4m");
    write_capture(&path, &paper_sequence(), 3.0);
    let p = detect(&path, &opts()).unwrap();
    assert_eq!(p.rule, DetectionRule::Sequence);
    assert_eq!(p.blobs.len(), 1, "{:?}", p.blobs);
    let blob = &p.blobs[0];
    assert_eq!(blob.bbox, LED);
    assert_eq!(blob.area_px, u64::from(LED.width * LED.height));
    // The step is the ON level over the OFF level (noise averages out).
    assert!((blob.step_dn - 150.0).abs() < 1.0, "{}", blob.step_dn);
    // Noise: the median OFF-segment spread is the generator's 3 DN.
    assert!((p.noise_dn - 3.0).abs() < 0.4, "{}", p.noise_dn);
    let led = &p.rois[0];
    assert_eq!((led.name.as_str(), led.kind), ("led1", RoiKind::Led));
    // A strip of 2 rows, as wide as the LED (under 100 px), inside it.
    assert_eq!((led.rect.width, led.rect.height), (LED.width, 2));
    assert_eq!(led.rect.x, LED.x);
    assert!(led.rect.y >= LED.y && led.rect.y + 2 <= LED.y + LED.height);
    let bg = &p.rois[1];
    assert_eq!(bg.kind, RoiKind::Background);
    assert_eq!((bg.rect.width, bg.rect.height), (LED.width, 2));
    // Beside the LED, not on it, and not on the bright still sign.
    let apart = |a: RoiRect, b: RoiRect| {
        a.x + a.width <= b.x
            || b.x + b.width <= a.x
            || a.y + a.height <= b.y
            || b.y + b.height <= a.y
    };
    assert!(apart(bg.rect, LED), "{:?}", bg.rect);
    let gap = bg.rect.y.saturating_sub(LED.y + LED.height);
    assert!(gap <= 8, "{:?}", bg.rect);
    // Frames: ON 0..60 less the guard frame, OFF after its settle time.
    assert!(
        p.lit_frames.0 == 0 && p.lit_frames.1 <= 60,
        "{:?}",
        p.lit_frames
    );
    assert!(
        p.off_frames.0 >= 60 && p.off_frames.1 <= 120,
        "{:?}",
        p.off_frames
    );
}

#[test]
fn the_proposed_blocks_parse_as_the_roi_tables_of_a_plan() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("seq.y4m");
    write_capture(&path, &paper_sequence(), 3.0);
    let p = detect(&path, &opts()).unwrap();
    let blocks = to_toml(&p);
    let plan_text = format!(
        "format-version = 2\n[plan]\nid = \"pasted\"\ntitle = \"pasted\"\n[dut]\nbackend = \"captured\"\n\
         [[case]]\nid = \"seq\"\nsource = \"seq.y4m\"\n\n{blocks}"
    );
    let plan_path = tmp.path().join("pasted.toml");
    let plan = ledflicker_plan::plan::parse(&plan_text, &plan_path, String::new())
        .unwrap_or_else(|e| panic!("{e}\n{plan_text}"));
    assert_eq!(plan.rois.len(), p.rois.len());
    for (got, want) in plan.rois.iter().zip(&p.rois) {
        assert_eq!(got.name, want.name);
        assert_eq!(got.kind, want.kind);
        let rect = (got.x_px, got.y_px, got.width_px, got.height_px);
        assert_eq!(
            rect,
            (want.rect.x, want.rect.y, want.rect.width, want.rect.height)
        );
    }
}

#[test]
fn a_capture_without_a_step_is_refused_with_a_hint() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("flat.y4m");
    // The LED never changes: the whole capture is one level plus noise.
    write_capture(&path, &vec![120.0; 150], 2.0);
    let e = detect(&path, &opts()).map(|_| ()).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("no ON -> OFF step"), "{text}");
    assert!(text.contains("flat.y4m"), "{text}");
    assert!(text.contains("hint: record the paper's sequence"), "{text}");
    assert!(e.is_input_error());
    // A lamp that flickers from the first frame to the last (PWM only: no
    // steady ON and OFF segments, no dark baseline) is refused too.
    let path = tmp.path().join("pwm.y4m");
    let levels: Vec<f64> = (0..150).map(|k| [100.0, 140.0][k % 2]).collect();
    write_capture(&path, &levels, 2.0);
    let text = detect(&path, &opts()).map(|_| ()).unwrap_err().to_string();
    assert!(text.contains("no ON -> OFF step found"), "{text}");
    assert!(text.contains("hint:"), "{text}");
}

#[test]
fn a_missing_capture_is_named_in_the_error() {
    let e = detect(Path::new("/nonexistent/capture.mp4"), &opts())
        .map(|_| ())
        .unwrap_err();
    let text = e.to_string();
    assert!(text.contains("/nonexistent/capture.mp4"), "{text}");
    assert!(text.contains("no such file"), "{text}");
    assert!(e.is_input_error());
}

#[test]
fn blobs_are_four_connected_and_small_ones_are_left_out() {
    let (w, h) = (10u32, 6u32);
    let mut step = vec![0.0f32; (w * h) as usize];
    let mut set = |x: u32, y: u32| step[(y * w + x) as usize] = 50.0;
    // A 3 x 3 block (9 px) and, touching it only at a corner, 2 px.
    for y in 1..4 {
        for x in 1..4 {
            set(x, y);
        }
    }
    set(4, 4);
    set(5, 4);
    let (labels, blobs, left_out) = find_blobs(&step, w, h, 10.0);
    assert_eq!(blobs.len(), 1);
    assert_eq!(left_out, 1);
    assert_eq!(
        blobs[0].bbox,
        RoiRect {
            x: 1,
            y: 1,
            width: 3,
            height: 3
        }
    );
    assert_eq!(labels[(4 * w + 4) as usize], 0);
}

#[test]
fn the_strip_is_at_most_100_px_and_centred_in_a_wide_blob() {
    let (w, h) = (300u32, 40u32);
    let mut step = vec![0.0f32; (w * h) as usize];
    for y in 5..15 {
        for x in 20..280 {
            step[(y * w + x) as usize] = 80.0;
        }
    }
    let (labels, blobs, _) = find_blobs(&step, w, h, 10.0);
    let rois = propose(&labels, &blobs, &step, 10.0, (w, h));
    assert_eq!(
        rois[0].rect,
        RoiRect {
            x: 100,
            y: 9,
            width: 100,
            height: 2
        }
    );
    // Background: below the blob, a gap away, in still pixels.
    assert_eq!(
        rois[1].rect,
        RoiRect {
            x: 100,
            y: 15 + BACKGROUND_GAP_PX,
            width: 100,
            height: 2
        }
    );
}
