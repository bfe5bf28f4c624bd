//! Unit tests of segment detection on small synthetic traces.

use super::*;

const FPS: f64 = 30.0;

/// A trace at 30 fps: LED ROI from `led(t)`, background ROI constant.
fn trace(seconds: f64, led: impl Fn(f64) -> f64) -> CaptureTrace {
    let n = (seconds * FPS) as usize;
    let time_s: Vec<f64> = (0..n).map(|k| k as f64 / FPS).collect();
    CaptureTrace {
        luma: vec![time_s.iter().map(|&t| led(t)).collect(), vec![200.0; n]],
        time_s,
        rgb: None,
        full_scale_dn: 255.0,
        frame_size: (0, 0),
        timestamps: ledflicker_plan::trace::TimestampSource::Fps,
        format: "test".to_string(),
        time_base_s: None,
        stated_fps: None,
        video: None,
    }
}

fn detection(on_s: f64) -> Detection {
    Detection {
        sequence: Sequence {
            on_s,
            off_s: 2.0,
            pwm_s: 4.0,
        },
        settle_s: 0.5,
        led_rois: vec![0],
    }
}

/// ON from `on`, for 2 s, then 2 s OFF, then 4 s of a 3-frame pattern.
fn paper(on: f64) -> impl Fn(f64) -> f64 {
    move |t: f64| {
        let k = (t * FPS).round() as i64;
        if t < on {
            10.0
        } else if t < on + 2.0 - 1e-9 {
            100.0
        } else if t < on + 4.0 - 1e-9 {
            10.0
        } else if t < on + 8.0 - 1e-9 {
            [80.0, 100.0, 120.0][k.rem_euclid(3) as usize]
        } else {
            10.0
        }
    }
}

#[test]
fn sequence_rule_finds_on_off_pwm_after_a_lead_in_and_settles() {
    let t = trace(10.0, paper(1.0));
    let f = detect(&t, &detection(2.0), Path::new("x.csv")).unwrap();
    assert_eq!(
        f.rule,
        Some(ledflicker_plan::trace::DetectionRule::Sequence)
    );
    // Steps at frames 30, 90, 150; settle 15 frames; 1 guard frame.
    assert_eq!(f.on, Some((45, 89)));
    assert_eq!(f.off, Some((105, 149)));
    assert_eq!(f.pwm.0, 165);
    // 4 s of PWM end at frame 270; the frame before is left out.
    assert_eq!(f.pwm.1, 269);
    let levels = f.levels_dn.unwrap();
    assert_eq!((levels.on, levels.off), (Some(100.0), Some(10.0)));
    assert!(
        f.text
            .contains("ON frames 45..89 (1.500-2.967 s, 100.0 DN)"),
        "{}",
        f.text
    );
}

#[test]
fn a_capture_that_starts_in_on_is_detected() {
    let t = trace(8.0, paper(-0.5));
    let f = detect(&t, &detection(2.0), Path::new("x.csv")).unwrap();
    assert_eq!(f.on, Some((0, 44)));
    assert_eq!(f.off, Some((60, 104)));
    assert_eq!(f.steps[0].from, "capture");
}

#[test]
fn the_background_roi_does_not_steer_detection() {
    let mut t = trace(10.0, paper(1.0));
    // A bright background flash in the lead-in is ignored.
    t.luma[1][5] = 255.0;
    let f = detect(&t, &detection(2.0), Path::new("x.csv")).unwrap();
    assert_eq!(f.on, Some((45, 89)));
}

#[test]
fn an_on_segment_of_the_wrong_length_is_refused_with_the_times_found() {
    let t = trace(10.0, paper(1.0));
    let mut d = detection(2.0);
    d.sequence.on_s = 3.0;
    let e = detect(&t, &d, Path::new("x.csv")).unwrap_err().to_string();
    assert!(e.contains("the ON segment lasts 2.000 s"), "{e}");
    assert!(e.contains("on-time-s = [1.000, 3.000]"), "{e}");
    assert!(e.contains("x.csv"), "{e}");
}

#[test]
fn a_flat_capture_is_refused_and_no_on_keeps_the_off_then_pwm_rule() {
    let flat = trace(10.0, |_| 50.0);
    let e = detect(&flat, &detection(2.0), Path::new("x.csv")).unwrap_err();
    assert!(e.to_string().contains("cannot detect segments"), "{e}");
    // Dark, then PWM: the off-then-pwm rule of format version 1.
    let t = trace(10.0, |t| if t < 2.0 { 10.0 } else { 100.0 });
    let f = detect(&t, &detection(0.0), Path::new("x.csv")).unwrap();
    assert_eq!(
        f.rule,
        Some(ledflicker_plan::trace::DetectionRule::OffThenPwm)
    );
    assert_eq!(f.off, Some((0, 58)));
    assert_eq!(f.pwm, (75, 300));
}
