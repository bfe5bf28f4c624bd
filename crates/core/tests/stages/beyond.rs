//! Issue 6 in results.json: apparent frequency, beat, hazard class, drive,
//! banding and phase coverage of a small plan, against closed forms.

use ledflicker_core::backend::sim::Simulator;
use ledflicker_core::{plan, runner};
use serde_json::Value;

use crate::root;

fn model(frequencies: &str, duties: &str) -> Value {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "frequencies-hz = [60.0, 150.0]",
            &format!("frequencies-hz = {frequencies}"),
        )
        .replace(
            "duty-cycles = [0.2, 0.5]",
            &format!("duty-cycles = {duties}"),
        )
        .replace("exposure-ms = 11.111", "exposure-ms = 2.0");
    let p = plan::parse(&text, std::path::Path::new("beyond.toml"), String::new()).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
    serde_json::to_value(ledflicker_core::model::assemble(&p, "sim-ideal", &results)).unwrap()
}

fn case<'a>(m: &'a Value, id: &str) -> &'a Value {
    m["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["id"] == id)
        .unwrap()
}

#[test]
fn results_name_the_beat_and_what_it_looks_like() {
    let m = model("[90.05, 91.5, 100.0]", "[0.05, 0.5]");
    assert!(!m.to_string().contains("NaN"));
    for c in m["cases"].as_array().unwrap() {
        let f = c["frequency_hz"].as_f64().unwrap();
        let d = c["duty"].as_f64().unwrap();
        let fa = (f - 30.0 * (f / 30.0).round()).abs();
        assert!((c["apparent_frequency_hz"].as_f64().unwrap() - fa).abs() < 1e-9);
        assert!((c["drive"]["flicker_index"].as_f64().unwrap() - (1.0 - d)).abs() < 1e-12);
        assert_eq!(c["drive"]["ieee1789_region"], "elevated-risk");
        let rows = 1.0 / (f * 14.565e-6);
        assert!((c["banding"]["band_period_rows"].as_f64().unwrap() - rows).abs() < 1e-6);
    }
    // 91.5 Hz at 30 fps: a 1.5 Hz beat, 90 flashes a minute.
    let c = case(&m, "2000lux-91.5hz-50pct");
    assert_eq!(c["hazard_class"], "turn-indicator-like");
    assert_eq!(c["beat"]["longer_than_capture"], false);
    let spec = c["rois"][0]["metrics"]["apparent_frequency_spectrum_hz"]
        .as_f64()
        .unwrap();
    assert!((spec - 1.5).abs() <= 30.0 / 120.0, "{spec}");
    // 100 Hz: 10 Hz, in the peak-annoyance band.
    assert_eq!(
        case(&m, "2000lux-100hz-50pct")["hazard_class"],
        "peak-annoyance"
    );
    // 90.05 Hz: a 20 s beat in a 4 s capture; the capture says how long it
    // would have to be.
    let c = case(&m, "2000lux-90.05hz-50pct");
    assert_eq!(c["beat"]["longer_than_capture"], true);
    assert!(
        c["beat"]["note"]
            .as_str()
            .unwrap()
            .contains("near phase lock")
    );
    let cov = &c["rois"][0]["analysis"]["phase_coverage"];
    assert!(cov["coverage"].as_f64().unwrap() < 0.5, "{cov}");
    let need = cov["needed_capture_s"].as_f64().unwrap();
    assert!((need - 20.0).abs() < 0.5, "{need}");
    // The background ROI never flickers: steady.
    for c in m["cases"].as_array().unwrap() {
        for roi in c["rois"].as_array().unwrap() {
            if roi["kind"] == "background" {
                assert_eq!(roi["analysis"]["hazard_class"], "steady");
            }
        }
    }
}

/// One case of base.toml at `frequency_hz`, 50 % duty, a 2 ms exposure and
/// the paper's 60 s PWM segment, with `extra` TOML appended.
fn model_with(frequency_hz: f64, extra: &str) -> Value {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "frequencies-hz = [60.0, 150.0]",
            &format!("frequencies-hz = [{frequency_hz:?}]"),
        )
        .replace("duty-cycles = [0.2, 0.5]", "duty-cycles = [0.5]")
        .replace("pwm-s = 4.0", "pwm-s = 60.0")
        .replace("exposure-ms = 11.111", "exposure-ms = 2.0")
        + extra;
    let p = plan::parse(&text, std::path::Path::new("ppm.toml"), String::new()).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
    serde_json::to_value(ledflicker_core::model::assemble(&p, "sim-ideal", &results)).unwrap()
}

#[test]
fn a_pwm_clock_offset_moves_the_beat_hazard_and_coverage_with_the_trace() {
    // 150 Hz at 30 fps is phase locked; 50 ppm fast, the LED runs at
    // 150.0075 Hz and the video beats at 150 * 50e-6 = 0.0075 Hz.
    let m = model_with(150.0, "\n[scene]\npwm-clock-offset-ppm = 50.0\n");
    let c = &m["cases"][0];
    let fa = c["beat"]["apparent_frequency_hz"].as_f64().unwrap();
    assert!((fa - 0.0075).abs() < 1e-12, "{fa}");
    assert!(!c["beat"]["note"].as_str().unwrap().contains("phase locked"));
    let roi = &c["rois"][0];
    let pf = roi["metrics"]["percent_flicker"].as_f64().unwrap();
    assert!(pf > 2.0, "the trace flickers visibly: PF {pf}");
    // 0.45 of a beat in 60 s: a slow pulsing, not a steady lamp.
    assert_eq!(c["hazard_class"], "slow-drift");
    let covered = roi["analysis"]["phase_coverage"]["covered_bins"]
        .as_u64()
        .unwrap();
    // The phase advances 0.0075 / 30 cycles a frame: 1800 frames sweep
    // 0.45 of the circle: 28.8 of 64 bins' width, so 29 to 30 bins hit
    // as the sweep's ends fall (30 here), give or take one.
    assert!((28..=31).contains(&covered), "{covered} bins");
    // Without the offset the same drive is locked: one bin, steady.
    let locked = model_with(150.0, "");
    let c = &locked["cases"][0];
    assert_eq!(c["beat"]["apparent_frequency_hz"].as_f64(), Some(0.0));
    assert_eq!(
        c["rois"][0]["analysis"]["phase_coverage"]["covered_bins"].as_u64(),
        Some(1)
    );
}

#[test]
fn decimal_beats_on_a_band_edge_fall_in_the_same_band_at_any_harmonic() {
    // 30.8, 90.8 and 150.8 Hz at 30 fps beat at 0.8 Hz, the lower edge of
    // traffic-signal-like (0.8-1.0 Hz, both ends included).
    for f in [30.8, 90.8, 150.8] {
        let m = model_with(f, "");
        let c = &m["cases"][0];
        assert_eq!(
            c["beat"]["apparent_frequency_hz"].as_f64(),
            Some(0.8),
            "{f}"
        );
        assert_eq!(c["hazard_class"], "traffic-signal-like", "{f} Hz");
    }
}

#[test]
fn the_pwm_delay_moves_the_folded_phase_as_it_moves_the_drive() {
    // Phase locked (150 Hz at 30 fps): every frame of the ROI sees one PWM
    // phase, frac(f (row offset - delay)) at its first row, so one bin of
    // 64 is hit, and which one follows the delay.
    for delay_ms in [0.0, 1.0, 2.5, 4.0] {
        let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
            .unwrap()
            .replace("frequencies-hz = [60.0, 150.0]", "frequencies-hz = [150.0]")
            .replace("duty-cycles = [0.2, 0.5]", "duty-cycles = [0.5]")
            .replace("exposure-ms = 11.111", "exposure-ms = 2.0")
            .replace(
                "response-dn-per-cd-m2-s = 18.5",
                &format!("response-dn-per-cd-m2-s = 18.5\npwm-delay-ms = {delay_ms:?}"),
            );
        let p = plan::parse(&text, std::path::Path::new("delay.toml"), String::new()).unwrap();
        let cases = plan::expand_cases(&p);
        let results = runner::run(&p, &cases, &Simulator::new(&p), Some(1), &|_| {}).unwrap();
        let a = ledflicker_core::analysis::analyse_case(&p, &results[0]);
        let hit: Vec<usize> = a.rois[0]
            .folded_bins
            .iter()
            .enumerate()
            .filter(|(_, b)| b.is_some())
            .map(|(i, _)| i)
            .collect();
        // 14.565 us a row (base.toml), from the ROI's first row.
        let row_offset_s = f64::from(p.rois[0].y_px) * 14.565e-6;
        let phase = (150.0 * (row_offset_s - delay_ms * 1e-3)).rem_euclid(1.0);
        assert_eq!(hit, [(phase * 64.0) as usize], "delay {delay_ms} ms");
    }
}
