//! Colour flicker end to end (docs/visibility.md, section 6): the shipped
//! plan test-plans/cms-colour.toml, a red PWM stop lamp at 90 Hz on an RGB
//! camera whose green plane is exposed 1.5 ms after its red one, reports
//! its chromaticity excursion and the frames that leave the UN R48 red
//! region; the same plan without the shift keeps one colour.

use ledflicker::model::Results;
use ledflicker::trace::Segment;

fn plan_text() -> String {
    std::fs::read_to_string(crate::root().join("test-plans/cms-colour.toml")).unwrap()
}

/// The plan from `text`, its run and its results model.
fn run(
    text: &str,
) -> (
    ledflicker::plan::Plan,
    Vec<ledflicker::runner::CaseResult>,
    Results,
) {
    let plan = ledflicker::plan::parse(
        text,
        &crate::root().join("test-plans/cms-colour.toml"),
        String::new(),
    )
    .unwrap();
    let cases = ledflicker::plan::expand_cases(&plan);
    let backend = ledflicker::backend::sim::Simulator::new(&plan);
    let results = ledflicker::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap();
    let model = ledflicker::model::assemble(&plan, "sim-ideal", &results);
    (plan, results, model)
}

/// Seconds of `[a, b)` in which a PWM light of `f` Hz and `duty`, rising
/// at 0, is on.
fn on_time(f: f64, duty: f64, a: f64, b: f64) -> f64 {
    let up_to = |t: f64| {
        let cycles = (t * f).floor();
        (cycles * duty + (t * f - cycles).min(duty)) / f
    };
    up_to(b) - up_to(a)
}

#[test]
fn a_red_pwm_lamp_with_a_chroma_shift_is_reported_with_its_delta_uv_and_violations() {
    let (plan, results, model) = run(&plan_text());
    let colour = plan.colour.clone().expect("cms-colour has colour");
    assert_eq!(colour.plane_offsets_s, [0.0, 0.0015, 0.0]);
    let lamp = &model.cases[0].rois[0];
    assert_eq!(lamp.name, "stop-lamp");
    assert_eq!(lamp.signal_colour.as_deref(), Some("red"));
    let delta = lamp.metrics["delta_uv"].unwrap();
    let outside = lamp.metrics["frames_outside_signal_colour"].unwrap();
    assert!(delta > 0.01, "{delta}");
    // Some PWM frames leave the red region, not all: only those in which
    // the green plane sees more of a pulse than the red one.
    let pwm = results[0]
        .acquisition
        .frames
        .iter()
        .filter(|f| f.segment == Segment::Pwm)
        .count() as f64;
    assert!(outside > 0.0 && outside < pwm, "{outside} of {pwm}");
    // The background has no colour figures.
    assert!(!model.cases[0].rois[1].metrics.contains_key("delta_uv"));

    // Each plane is the PWM's integral over that plane's own exposure:
    // DN = black + k L led_rgb[p] s_p, k = 100 DN/(cd/m^2 s) x 2 ms.
    let trace = &results[0].acquisition.rois[0];
    let rgb = trace.rgb.as_ref().expect("the lamp's colour planes");
    for (f, c) in results[0].acquisition.frames.iter().zip(rgb) {
        if f.segment != Segment::Pwm {
            continue;
        }
        for (p, (offset, led)) in colour
            .plane_offsets_s
            .iter()
            .zip(colour.led_rgb)
            .enumerate()
        {
            let start = f.time_s + offset;
            let s = on_time(90.0, 0.2, start, start + 0.002) / 0.002;
            let expected = 16.0 + 0.2 * 200.0 * led * s;
            assert!(
                (c[p] - expected).abs() < 1e-9,
                "frame {} plane {p}: {} vs {expected}",
                f.index,
                c[p]
            );
        }
    }

    // The report's driver section lists it; summary.csv has its columns.
    let doc =
        ledflicker::report::document::Document::build(&model, &results, "2026-01-01", Vec::new())
            .unwrap();
    let view = doc.driver().expect("cms-colour has a [display]");
    assert_eq!(view.colour.len(), 1);
    let row = &view.colour[0];
    assert!(
        row.over && row.outside == format!("{outside:.0}"),
        "{row:?}"
    );
    assert!(row.reading.contains("leaves the red region"), "{row:?}");
    let csv = ledflicker::report::export::summary_csv(&model).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(
        header.contains(",delta_uv,frames_outside_signal_colour,"),
        "{header}"
    );
}

#[test]
fn the_same_lamp_without_the_chroma_shift_keeps_one_colour() {
    let text = plan_text().replace(
        "colour-plane-offset-ms = [0.0, 1.5, 0.0]",
        "colour-plane-offset-ms = [0.0, 0.0, 0.0]",
    );
    assert_ne!(text, plan_text());
    let (_, _, model) = run(&text);
    let lamp = &model.cases[0].rois[0];
    let delta = lamp.metrics["delta_uv"].unwrap();
    assert!(delta < 1e-9, "{delta}");
    assert_eq!(lamp.metrics["frames_outside_signal_colour"], Some(0.0));
}

#[test]
fn colour_keys_without_a_chromaticity_or_outside_the_gamut_are_refused() {
    let without = plan_text().replace("led-chromaticity-xy = [0.6931, 0.3003]\n", "");
    let err = ledflicker::plan::parse(&without, std::path::Path::new("c.toml"), String::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("scene.signal-colour") && err.contains("led-chromaticity-xy"),
        "{err}"
    );
    // sRGB's matrix cannot make this red: its green plane would go negative.
    let start = plan_text().find("camera-to-xyz = [").unwrap();
    let end = start + plan_text()[start..].find("\n]\n").unwrap() + 3;
    let srgb = format!("{}{}", &plan_text()[..start], &plan_text()[end..]);
    let err = ledflicker::plan::parse(&srgb, std::path::Path::new("c.toml"), String::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("outside the camera's gamut") && err.contains("hint"),
        "{err}"
    );
}
