//! The physical camera end to end: Deegan 2018 Table 1, hard cases, noise
//! statistics, output bit depth, saturation, determinism.

use ledflicker_core::backend::sim::Simulator;
use ledflicker_core::metrics::RoiMetrics;
use ledflicker_core::plan;
use ledflicker_core::runner::{self, CaseResult};

use crate::{root, scratch};

/// A physical camera profile: global shutter, one capture, linear tone.
fn profile(extra: &str, noise: bool, fps: f64) -> String {
    format!(
        r#"
[camera]
name = "test-physical"
shutter = "global"
sensor-rows = 100
sensor-columns = 200
exposure-ms = 5.0
frame-rate-fps = {fps}
{extra}
[camera.sensor]
sensitivity-e-per-cd-m2-s = 4000.0
full-well-e = 12000.0
read-noise-e = {read}
shot-noise = {noise}
adc-bits = 12
"#,
        read = if noise { 3.0 } else { 0.0 },
    )
}

fn plan_text(profile_path: &str, freqs: &str, duties: &str, led: f64, seed: u64) -> String {
    format!(
        r#"
[plan]
id = "physics"
title = "physics test"
seed = {seed}

[sequence]
on-s = 1.0
off-s = 1.0
pwm-s = 6.0

[light]
levels-lux = [2000.0]

[grid]
frequencies-hz = {freqs}
duty-cycles = {duties}

[[roi]]
name = "led"
x-px = 50
y-px = 49

[dut]
camera-profile = "{profile_path}"

[scene]
led-luminance-cd-m2 = {led}
"#
    )
}

fn run_plan(
    dir: &std::path::Path,
    profile_text: &str,
    plan: &str,
    threads: usize,
) -> Vec<CaseResult> {
    std::fs::write(dir.join("camera.toml"), profile_text).unwrap();
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    let p = plan::load(&dir.join("plan.toml")).unwrap_or_else(|e| panic!("{e}"));
    let cases = plan::expand_cases(&p);
    runner::run(&p, &cases, &Simulator::new(&p), Some(threads), &|_| {}).unwrap()
}

fn led(r: &CaseResult) -> &RoiMetrics {
    &r.metrics[0]
}

#[test]
fn deegan2018_table1_is_reproduced_on_the_paper_like_profile() {
    let p = plan::load(&root().join("test-plans/deegan2018.toml")).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
    let by_f = |f: f64| led(results.iter().find(|r| r.case.frequency_hz == f).unwrap());
    let (m60, m150) = (by_f(60.0), by_f(150.0));
    let fdi60 = m60.fdi_2018.value.unwrap();
    let fdi150 = m150.fdi_2018.value.unwrap();
    let pf60 = m60.percent_flicker.value.unwrap();
    let pf150 = m150.percent_flicker.value.unwrap();
    // The issue's acceptance: the light appears OFF at 60 Hz, not at 150 Hz.
    assert!(fdi60 < 0.1 && fdi150 >= 0.1, "FDI {fdi60} {fdi150}");
    // The paper: -0.14 / 36 and 0.75 / 3. Residuals stay within these bounds.
    assert!((fdi60 - -0.14).abs() < 0.06, "FDI 60 Hz {fdi60}");
    assert!((pf60 - 36.0).abs() < 4.0, "PF 60 Hz {pf60}");
    assert!((fdi150 - 0.75).abs() < 0.06, "FDI 150 Hz {fdi150}");
    assert!((pf150 - 3.0).abs() < 1.5, "PF 150 Hz {pf150}");
    // Negative FDI needs the auto-exposure hysteresis: an ideal integrator gives 0.
    assert!(fdi60 < 0.0);
}

#[test]
fn phase_locked_frequencies_get_their_worst_case_computed() {
    let dir = scratch("phys-locked");
    let results = run_plan(
        &dir,
        &profile("", false, 30.0),
        &plan_text("camera.toml", "[60.0, 90.0]", "[0.1]", 2000.0, 1),
        1,
    );
    for r in &results {
        let m = led(r);
        // Locked: every PWM frame sees the same phase, so the capture is flat.
        assert!(m.percent_flicker.value.unwrap() < 1e-9, "{}", r.case.id);
        // 5 ms at 60 Hz, 10 % duty: T < (1 - D) / f, so some phase misses the pulse.
        let worst = m.fdi_2018_worst_phase.as_ref().unwrap().value.unwrap();
        if r.case.frequency_hz == 60.0 {
            assert!(worst.abs() < 1e-9, "the worst phase loses the LED: {worst}");
        }
        assert!(
            m.percent_flicker_worst_phase
                .as_ref()
                .unwrap()
                .value
                .unwrap()
                > 1.0
        );
    }
}

#[test]
fn boundary_cases_of_eq1_duty_and_whole_periods() {
    let dir = scratch("phys-bounds");
    // 5 ms exposure: 200 Hz = 1 period, 400 Hz = 2 periods (no modulation);
    // 150 Hz with D = 0.25: T = (1 - D) / f exactly (Eq. 1).
    let results = run_plan(
        &dir,
        &profile("", false, 30.0),
        &plan_text(
            "camera.toml",
            "[150.0, 200.0, 400.0]",
            "[0.005, 0.25, 1.0]",
            300.0,
            1,
        ),
        2,
    );
    for r in &results {
        let m = led(r);
        let pf_worst = m
            .percent_flicker_worst_phase
            .as_ref()
            .unwrap()
            .value
            .unwrap();
        let whole_periods = r.case.frequency_hz == 200.0 || r.case.frequency_hz == 400.0;
        if r.case.duty == 1.0 || whole_periods {
            assert!(pf_worst < 1e-9, "{}: {pf_worst}", r.case.id);
        }
        if r.case.frequency_hz == 150.0 && r.case.duty == 0.25 {
            // On Eq. (1) the worst phase catches no light at all: FDI 0.
            let fdi = m.fdi_2018_worst_phase.as_ref().unwrap().value.unwrap();
            assert!(fdi.abs() < 1e-9, "{fdi}");
        }
        assert!(m.levels.min.is_finite() && !m.saturated, "{}", r.case.id);
    }
}

#[test]
fn noise_leaves_the_mean_within_its_statistical_bounds() {
    let quiet = run_plan(
        &scratch("phys-quiet"),
        &profile("", false, 30.0),
        &plan_text("camera.toml", "[200.0]", "[1.0]", 300.0, 3),
        1,
    );
    let noisy = run_plan(
        &scratch("phys-noisy"),
        &profile("", true, 30.0),
        &plan_text("camera.toml", "[200.0]", "[1.0]", 300.0, 3),
        1,
    );
    let pwm = |r: &CaseResult| -> Vec<f64> {
        r.acquisition
            .frames
            .iter()
            .zip(&r.acquisition.rois[0].luma)
            .filter(|(f, _)| f.segment == ledflicker_core::metrics::flicker::Segment::Pwm)
            .map(|(_, v)| *v)
            .collect()
    };
    let q = pwm(&quiet[0]);
    let n = pwm(&noisy[0]);
    assert!(
        q.iter().all(|v| (v - q[0]).abs() < 1e-9),
        "noise-free steady light is flat"
    );
    let mean = n.iter().sum::<f64>() / n.len() as f64;
    let sd = (n.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n.len() - 1) as f64).sqrt();
    assert!(sd > 0.0, "noise must show");
    // Expected sigma of a 2-row x 100-px mean: sqrt(e + read^2) / sqrt(200) in e-.
    // Linear tone: white (4095 DN) maps to 255.
    let e_per_dn = 12_000.0 / 4095.0;
    let luma_per_dn = 255.0 / 4095.0;
    let electrons = q[0] / luma_per_dn * e_per_dn;
    let expect_sd = ((electrons + 9.0) / 200.0).sqrt() / e_per_dn * luma_per_dn;
    assert!(
        (sd / expect_sd - 1.0).abs() < 0.25,
        "sd {sd} vs {expect_sd}"
    );
    let se = expect_sd / (n.len() as f64).sqrt();
    assert!(
        (mean - q[0]).abs() < 5.0 * se,
        "mean {mean} vs {} (se {se})",
        q[0]
    );
}

#[test]
fn sixteen_bit_output_scales_luma_and_keeps_the_metrics() {
    let tone8 = "[camera.tone]\ncurve = \"gamma\"\ngamma = 2.2\noutput-bits = 8\n";
    let tone16 = "[camera.tone]\ncurve = \"gamma\"\ngamma = 2.2\noutput-bits = 16\n";
    let plan = plan_text("camera.toml", "[137.0]", "[0.3]", 2000.0, 1);
    let r8 = run_plan(
        &scratch("phys-8"),
        &(profile("", false, 30.0) + tone8),
        &plan,
        1,
    );
    let r16 = run_plan(
        &scratch("phys-16"),
        &(profile("", false, 30.0) + tone16),
        &plan,
        1,
    );
    let (a, b) = (led(&r8[0]), led(&r16[0]));
    assert!((b.levels.max / a.levels.max - 65535.0 / 255.0).abs() < 1e-9);
    assert!((a.fdi_2018.value.unwrap() - b.fdi_2018.value.unwrap()).abs() < 1e-9);
    assert!((a.percent_flicker.value.unwrap() - b.percent_flicker.value.unwrap()).abs() < 1e-9);
    assert!(
        a.percent_flicker.value.unwrap() > 0.1,
        "the case must flicker to mean anything"
    );
}

#[test]
fn fully_saturated_roi_is_flagged_not_scored_silently() {
    let r = run_plan(
        &scratch("phys-sat"),
        &profile("", false, 30.0),
        &plan_text("camera.toml", "[137.0]", "[0.5]", 1.0e7, 1),
        1,
    );
    let m = led(&r[0]);
    assert!(m.saturated);
    assert!(
        m.percent_flicker
            .reason
            .as_deref()
            .unwrap()
            .contains("saturated")
    );
}

#[test]
fn noisy_hdr_plan_gives_the_same_numbers_at_1_and_3_threads() {
    let p = plan::load(&root().join("test-plans/deegan2018.toml")).unwrap();
    let cases = plan::expand_cases(&p);
    let a = runner::run(&p, &cases, &Simulator::new(&p), Some(1), &|_| {}).unwrap();
    let b = runner::run(&p, &cases, &Simulator::new(&p), Some(3), &|_| {}).unwrap();
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.acquisition, y.acquisition);
    }
    // A different seed changes the noise.
    let mut p2 = p.clone();
    p2.seed += 1;
    let cases2 = plan::expand_cases(&p2);
    let c = runner::run(&p2, &cases2, &Simulator::new(&p2), Some(1), &|_| {}).unwrap();
    assert_ne!(a[0].acquisition.rois[0].luma, c[0].acquisition.rois[0].luma);
}

#[test]
fn invalid_profile_errors_name_the_profile_file_and_line() {
    let dir = scratch("phys-badprofile");
    std::fs::write(
        dir.join("camera.toml"),
        profile("", false, 30.0)
            .replace("full-well-e = 12000.0", "full-well-e = -5.0\nfull-wel = 3"),
    )
    .unwrap();
    std::fs::write(
        dir.join("plan.toml"),
        plan_text("camera.toml", "[100.0]", "[0.5]", 100.0, 1),
    )
    .unwrap();
    let err = plan::load(&dir.join("plan.toml")).unwrap_err().to_string();
    assert!(err.contains("camera.toml: line"), "{err}");
    assert!(
        err.contains("camera.sensor.full-well-e") && err.contains("camera.sensor.full-wel"),
        "{err}"
    );
    assert!(err.contains("did you mean `full-well-e`"), "{err}");
}

#[test]
fn rendered_rolling_shutter_frame_shows_bands_at_the_predicted_spacing() {
    use ledflicker_core::backend::Backend;
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "frequencies-hz = [60.0, 150.0]",
            "frequencies-hz = [1000.0]",
        )
        .replace("duty-cycles = [0.2, 0.5]", "duty-cycles = [0.5]")
        .replace("exposure-ms = 11.111", "exposure-ms = 0.0625");
    let p = plan::parse(&text, std::path::Path::new("bands.toml"), String::new()).unwrap();
    let cases = plan::expand_cases(&p);
    let sim = Simulator::new(&p);
    let frame = sim.render_frame(&cases[0], 40).unwrap().unwrap();
    assert_eq!((frame.width, frame.height), (1280, 800));
    // The lamp column through the middle of the sensor.
    let col = (frame.width / 2) as usize;
    let column: Vec<f64> = (0..frame.height as usize)
        .map(|r| frame.pixel(col as u32, r as u32).unwrap())
        .collect();
    let lamp: Vec<f64> = column[170..630].to_vec();
    let mid = (lamp.iter().cloned().fold(f64::MAX, f64::min)
        + lamp.iter().cloned().fold(f64::MIN, f64::max))
        / 2.0;
    let rises: Vec<usize> = (1..lamp.len())
        .filter(|&i| lamp[i - 1] < mid && lamp[i] >= mid)
        .collect();
    assert!(rises.len() >= 5, "{rises:?}");
    let spacing = (rises[rises.len() - 1] - rises[0]) as f64 / (rises.len() - 1) as f64;
    // docs/metrics.md: band period 1 / (f * t_line) = 68.66 rows at 1 kHz, 14.565 us.
    let expected = 1.0 / (1000.0 * 14.565e-6);
    assert!(
        (spacing - expected).abs() < 1.0,
        "spacing {spacing} vs {expected}"
    );
}

#[test]
fn physical_camera_gets_no_ideal_fine_map_but_says_why() {
    let p = plan::load(&root().join("test-plans/deegan2018.toml")).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
    let model = ledflicker_core::model::assemble(&p, "sim-physical", &results);
    assert!(model.fine_maps.is_empty());
    assert!(
        model
            .fine_maps_note
            .as_deref()
            .unwrap()
            .contains("physical sensor")
    );
    let daylight = plan::load(&root().join("test-plans/daylight.toml")).unwrap();
    assert!(ledflicker_core::analysis::fine_maps_note(&daylight).is_none());
}
