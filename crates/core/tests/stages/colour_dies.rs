//! An LED of dies (`[[scene.led-die]]`, docs/visibility.md, section 6): a
//! red and a yellow-green die, each with its own chromaticity, luminance
//! share, duty and phase, on a camera that exposes its three planes
//! together. Every expectation is computed here from first principles:
//! CIE 1931 `(x, y)` to XYZ at `Y = 1`, XYZ mixed by weight, XYZ to
//! `(x, y)` and to CIE 1976 `(u', v')`, and which die a window of the PWM
//! period catches; nothing of the code under test is called for them.

use ledflicker_core::trace::Segment;

/// The camera's linear R, G, B to X, Y, Z, as in test-plans/rgb-signal.toml.
const CAMERA_TO_XYZ: [[f64; 3]; 3] = [
    [0.4146, 0.3291, 0.2068],
    [0.1495, 0.7678, 0.0827],
    [0.0000, 0.0000, 1.0891],
];

/// The dies: (x, y), luminance share, duty, phase in degrees.
const RED: ([f64; 2], f64, f64, f64) = ([0.700, 0.297], 0.4, 0.5, 0.0);
const GREEN: ([f64; 2], f64, f64, f64) = ([0.420, 0.575], 0.6, 0.5, 180.0);

const BLACK_DN: f64 = 16.0;
const RESPONSE: f64 = 100.0;
const LAMP_CD_M2: f64 = 200.0;

/// A plan of the two dies at `frequency` Hz, filmed at `fps` with
/// `exposure_ms` exposures, the LED's common rise `delay_ms` after frame
/// 0 starts, at case duties `duties`.
fn plan_text(frequency: f64, fps: f64, exposure_ms: f64, delay_ms: f64, duties: &str) -> String {
    let die = |(xy, share, duty, phase): ([f64; 2], f64, f64, f64)| {
        format!(
            "[[scene.led-die]]\nchromaticity-xy = [{}, {}]\nluminance-share = {share}\nduty-cycle = {duty}\nphase-deg = {phase}\n",
            xy[0], xy[1]
        )
    };
    let m = CAMERA_TO_XYZ;
    format!(
        r#"format-version = 1
[plan]
id = "dies"
title = "dies"
[sequence]
on-s = 0.5
off-s = 0.5
pwm-s = 2.0
[light]
levels-lux = [10.0]
[grid]
frequencies-hz = [{frequency}]
duty-cycles = {duties}
[[roi]]
name = "lamp"
kind = "led"
x-px = 620
y-px = 392
width-px = 24
height-px = 16
[dut]
backend = "simulator"
[dut.camera]
shutter = "global"
sensor-rows = 800
sensor-columns = 1280
line-time-us = 0.0
exposure-ms = {exposure_ms}
frame-rate-fps = {fps}
pwm-delay-ms = {delay_ms}
response-dn-per-cd-m2-s = {RESPONSE}
black-level-dn = {BLACK_DN}
full-scale-dn = 1000.0
saturation-dn = 990.0
camera-to-xyz = [[{}, {}, {}], [{}, {}, {}], [{}, {}, {}]]
[scene]
background-reflectance = 0.0
led-luminance-cd-m2 = {LAMP_CD_M2}
led-fill = 1.0
signal-colour = "amber"
{}
{}"#,
        m[0][0],
        m[0][1],
        m[0][2],
        m[1][0],
        m[1][1],
        m[1][2],
        m[2][0],
        m[2][1],
        m[2][2],
        die(RED),
        die(GREEN)
    )
}

fn run(text: &str) -> Vec<ledflicker_core::runner::CaseResult> {
    let plan = ledflicker_core::plan::parse(text, std::path::Path::new("dies.toml"), String::new())
        .unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let backend = ledflicker_core::backend::sim::Simulator::new(&plan);
    ledflicker_core::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap()
}

/// CIE 1931 XYZ of the chromaticity `(x, y)` at `Y = 1`.
fn xyz_of_xy([x, y]: [f64; 2]) -> [f64; 3] {
    [x / y, 1.0, (1.0 - x - y) / y]
}

/// `(x, y)` of XYZ.
fn xy_of([x, y, z]: [f64; 3]) -> [f64; 2] {
    [x / (x + y + z), y / (x + y + z)]
}

/// CIE 1976 `u' = 4X / (X + 15Y + 3Z)`, `v' = 9Y / (X + 15Y + 3Z)`.
fn uv_of([x, y, z]: [f64; 3]) -> (f64, f64) {
    let d = x + 15.0 * y + 3.0 * z;
    (4.0 * x / d, 9.0 * y / d)
}

/// The frame's light (planes less the black level) as XYZ.
fn frame_xyz(rgb: [f64; 3]) -> [f64; 3] {
    let light = rgb.map(|v| v - BLACK_DN);
    CAMERA_TO_XYZ.map(|row| row[0] * light[0] + row[1] * light[1] + row[2] * light[2])
}

/// The dies' light averaged over time: each die's XYZ weighted by its
/// luminance share and duty.
fn fused_xyz() -> [f64; 3] {
    let mut sum = [0.0; 3];
    for (xy, share, duty, _) in [RED, GREEN] {
        for (s, v) in sum.iter_mut().zip(xyz_of_xy(xy)) {
            *s += share * duty * v;
        }
    }
    sum
}

/// UN R48 paragraph 2.30's amber: `0.398 <= y <= 0.429`, `z <= 0.007`.
fn amber([x, y]: [f64; 2]) -> bool {
    (0.398..=0.429).contains(&y) && 1.0 - x - y <= 0.007
}

/// The LED at 100 Hz (10 ms period) rises 9 ms after frame 0 starts: the
/// red die is on [9, 14) ms modulo 10, i.e. [-1, 4), the green one half a
/// period later, [4, 9). Frames are 45 ms (4.5 periods) apart, so a 2 ms
/// exposure covers [0, 2) ms of the period in even frames (red only) and
/// [5, 7) in odd ones (green only).
#[test]
fn a_short_exposure_that_catches_one_die_sees_that_dies_colour_and_the_reference_is_the_fused_mix()
{
    let results = run(&plan_text(100.0, 1000.0 / 45.0, 2.0, 9.0, "[1.0]"));
    let r = &results[0];
    let trace = &r.acquisition.rois[0];
    let rgb = trace.rgb.as_ref().expect("the lamp's colour planes");
    let k = RESPONSE * 0.002 * LAMP_CD_M2;
    let mut pwm_frames = 0;
    for (f, (c, luma)) in r.acquisition.frames.iter().zip(rgb.iter().zip(&trace.luma)) {
        if f.segment != Segment::Pwm {
            continue;
        }
        pwm_frames += 1;
        let (die, share) = if f.index % 2 == 0 {
            (RED.0, RED.1)
        } else {
            (GREEN.0, GREEN.1)
        };
        let got = xy_of(frame_xyz(*c));
        assert!(
            (got[0] - die[0]).abs() < 1e-9 && (got[1] - die[1]).abs() < 1e-9,
            "frame {}: {got:?}, the die {die:?}",
            f.index
        );
        // The luma is the mixed light's: the die's share of the lamp.
        let expected = BLACK_DN + k * share;
        assert!((luma - expected).abs() < 1e-9, "frame {}: {luma}", f.index);
    }
    assert!(pwm_frames > 40, "{pwm_frames}");
    // Over phase the light runs from the red die alone to the green alone.
    let (lo, hi) = trace.phase_envelope.unwrap();
    assert!((lo - (BLACK_DN + k * RED.1)).abs() < 1e-9, "{lo}");
    assert!((hi - (BLACK_DN + k * GREEN.1)).abs() < 1e-9, "{hi}");

    // Delta u'v' is measured from the colour the dies fuse to, which is
    // amber though no frame is.
    let fused = fused_xyz();
    assert!(amber(xy_of(fused)), "{:?}", xy_of(fused));
    assert!(!amber(RED.0) && !amber(GREEN.0));
    let colour = r.metrics[0].colour.as_ref().unwrap();
    let mean = colour.mean_uv.unwrap();
    let (u0, v0) = uv_of(fused);
    assert!(
        (mean.0 - u0).abs() < 1e-9 && (mean.1 - v0).abs() < 1e-9,
        "{mean:?} vs ({u0}, {v0})"
    );
    assert!(colour.mean_is_time_average);
    let far = [RED.0, GREEN.0]
        .map(|xy| {
            let (u, v) = uv_of(xyz_of_xy(xy));
            (u - u0).hypot(v - v0)
        })
        .into_iter()
        .fold(0.0, f64::max);
    let delta = colour.delta_uv.unwrap();
    assert!((delta - far).abs() < 1e-9, "{delta} vs {far}");
    assert_eq!(colour.frames_outside, Some(pwm_frames));
}

/// An exposure of one whole period (10 ms at 100 Hz) collects every die's
/// full duty whatever the phase: each frame is the fused mix exactly, and
/// a case duty of 0.5 halves each die's duty and keeps the colour.
#[test]
fn an_exposure_of_whole_periods_sees_the_duty_weighted_mix_at_every_case_duty() {
    let results = run(&plan_text(100.0, 29.97, 10.0, 3.7, "[1.0, 0.5]"));
    assert_eq!(results.len(), 2);
    let fused = xy_of(fused_xyz());
    for r in &results {
        let trace = &r.acquisition.rois[0];
        let rgb = trace.rgb.as_ref().unwrap();
        let mean_on = RED.1 * RED.2 + GREEN.1 * GREEN.2;
        let expected = BLACK_DN + RESPONSE * 0.010 * LAMP_CD_M2 * r.case.duty * mean_on;
        for (f, (c, luma)) in r.acquisition.frames.iter().zip(rgb.iter().zip(&trace.luma)) {
            if f.segment == Segment::Off {
                continue;
            }
            // The PWM frames and the ON segment (the lamp steady at its
            // PWM average) alike.
            let got = xy_of(frame_xyz(*c));
            assert!(
                (got[0] - fused[0]).abs() < 1e-9 && (got[1] - fused[1]).abs() < 1e-9,
                "duty {} frame {}: {got:?} vs {fused:?}",
                r.case.duty,
                f.index
            );
            assert!((luma - expected).abs() < 1e-9, "{luma} vs {expected}");
        }
        let colour = r.metrics[0].colour.as_ref().unwrap();
        assert!(colour.delta_uv.unwrap() < 1e-9, "{:?}", colour.delta_uv);
        assert_eq!(colour.frames_outside, Some(0));
    }
}

/// One die of the LED's own colour at duty 1 and phase 0 is the LED of
/// one colour: the same luma and planes.
#[test]
fn one_die_at_full_duty_is_the_led_of_one_colour() {
    let dies = plan_text(90.0, 29.97, 2.0, 0.0, "[0.2, 0.7]");
    let start = dies.find("[[scene.led-die]]").unwrap();
    let one_die = format!(
        "{}[[scene.led-die]]\nchromaticity-xy = [0.6, 0.39]\nluminance-share = 1.0\nduty-cycle = 1.0\n",
        &dies[..start]
    );
    let one_colour = format!("{}led-chromaticity-xy = [0.6, 0.39]\n", &dies[..start]);
    let (a, b) = (run(&one_die), run(&one_colour));
    for (a, b) in a.iter().zip(&b) {
        let (ta, tb) = (&a.acquisition.rois[0], &b.acquisition.rois[0]);
        assert_eq!(ta.luma, tb.luma);
        assert_eq!(ta.phase_envelope, tb.phase_envelope);
        for (x, y) in ta
            .rgb
            .as_ref()
            .unwrap()
            .iter()
            .zip(tb.rgb.as_ref().unwrap())
        {
            for p in 0..3 {
                assert!((x[p] - y[p]).abs() < 1e-12, "{x:?} vs {y:?}");
            }
        }
    }
}

#[test]
fn bad_dies_are_refused_naming_the_key_with_a_hint() {
    let good = plan_text(100.0, 29.97, 2.0, 0.0, "[1.0]");
    let bad = [
        (
            good.replace(
                "signal-colour = \"amber\"",
                "signal-colour = \"amber\"\nled-chromaticity-xy = [0.58, 0.41]",
            ),
            "`scene.led-die`: and scene.led-chromaticity-xy both give the LED's colour",
        ),
        (
            good.replace("luminance-share = 0.6", "luminance-share = 0.7"),
            "luminance-share values sum to 1.1",
        ),
        (
            good.replace("luminance-share = 0.6", "luminance-share = 0.0"),
            "`scene.led-die[1].luminance-share`: must be > 0",
        ),
        (
            good.replace(
                "duty-cycle = 0.5\nphase-deg = 180",
                "duty-cycle = 1.5\nphase-deg = 180",
            ),
            "`scene.led-die[1].duty-cycle`: duty cycle 1.5 is outside (0, 1]",
        ),
        (
            good.replace("phase-deg = 180", "phase-deg = 360"),
            "`scene.led-die[1].phase-deg`: 360 is not a phase",
        ),
        (
            good.replace("[0.42, 0.575]", "[0.2, 0.75]"),
            "`scene.led-die[1].chromaticity-xy`: (0.2, 0.75) is outside the camera's gamut",
        ),
        (
            good.replace("chromaticity-xy = [0.42, 0.575]\n", ""),
            "`scene.led-die[1].chromaticity-xy`: missing required key",
        ),
        (
            good.replace("phase-deg = 180", "phase-deg = 180\ncolour = 1"),
            "`scene.led-die[1].colour`: unknown key",
        ),
    ];
    for (text, expected) in bad {
        assert_ne!(text, good);
        let err =
            ledflicker_core::plan::parse(&text, std::path::Path::new("d.toml"), String::new())
                .unwrap_err()
                .to_string();
        assert!(err.contains(expected), "{expected}\n---\n{err}");
        assert!(err.contains("hint"), "{err}");
    }
}

#[test]
fn the_shipped_amber_signal_reads_as_red_or_green_at_a_short_exposure() {
    let path = crate::root().join("test-plans/rgb-signal.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let plan = ledflicker_core::plan::parse(&text, &path, String::new()).unwrap();
    let colour = plan.colour.as_ref().unwrap();
    assert_eq!(colour.dies.len(), 2);
    assert!(amber(colour.led_xy), "{:?}", colour.led_xy);
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let backend = ledflicker_core::backend::sim::Simulator::new(&plan);
    let results = ledflicker_core::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap();
    assert_eq!(results.len(), 2);
    for r in &results {
        let c = r.metrics[0].colour.as_ref().unwrap();
        let outside = c.frames_outside.unwrap();
        assert!(
            outside > c.frames / 2,
            "{} Hz: {outside} of {}",
            r.case.frequency_hz,
            c.frames
        );
        assert!(c.delta_uv.unwrap() > 0.05, "{:?}", c.delta_uv);
    }
}
