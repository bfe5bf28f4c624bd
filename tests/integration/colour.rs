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
    // Its u'v' diagram: one cross per frame outside the region (plus the
    // legend's), in both panels where they fall, and the report shows it.
    let svg = &doc.charts[&row.chart];
    assert!(svg.contains("UN R48 red") && svg.contains("UN R48 amber"));
    assert!(
        svg.contains("a frame outside the red region"),
        "the legend names the crosses"
    );
    let fmi: Vec<f64> = row
        .planes_fmi
        .split(" / ")
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(fmi.len(), 3, "{row:?}");
    assert!((fmi[0] - lamp.metrics["fmi_r"].unwrap()).abs() < 1e-3);
    let html = ledflicker::report::html::render_document(&doc).unwrap();
    assert!(html.contains("each PWM frame's colour in the CIE 1976"));
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

/// The lamp at 125 Hz, 50 % duty (on 4 ms of each 8 ms), filmed at
/// 125 / 5.5 fps with 2 ms exposures that start 1 ms after a rise: each
/// frame is 5.5 periods after the last, so the red and blue planes see
/// the pulse whole ([1, 3] ms after a rise) in even frames and nothing
/// ([5, 7] ms) in odd ones; the green plane, 2 ms late, sees half of it
/// in both ([3, 5] ms and [7, 9] ms). Each plane's FMI, FDI (P2020) and
/// MMP then follow in closed form from its two levels.
#[test]
fn each_colour_plane_has_the_closed_form_kpis_of_its_own_pwm_integral() {
    let text = plan_text()
        .replace("frequencies-hz = [90.0]", "frequencies-hz = [125.0]")
        .replace("duty-cycles = [0.2]", "duty-cycles = [0.5]")
        .replace(
            "frame-rate-fps = 29.97",
            "frame-rate-fps = 22.727272727272727",
        )
        .replace("pwm-delay-ms = 0.0", "pwm-delay-ms = 7.0")
        .replace(
            "colour-plane-offset-ms = [0.0, 1.5, 0.0]",
            "colour-plane-offset-ms = [0.0, 2.0, 0.0]",
        );
    let (plan, results, model) = run(&text);
    let colour = plan.colour.clone().unwrap();
    let frames = &results[0].acquisition.frames;
    let pwm: Vec<u64> = frames
        .iter()
        .filter(|f| f.segment == Segment::Pwm)
        .map(|f| f.index)
        .collect();
    let n = pwm.len() as f64;
    let lit = pwm.iter().filter(|i| *i % 2 == 0).count() as f64;
    assert!(lit > 0.0 && lit < n, "{lit} of {n}");
    // Black 16 DN, no background; the lamp adds a = k L c_p over a whole
    // exposure, k = 100 DN/(cd/m^2 s) x 2 ms, L = 200 cd/m^2.
    let black = 16.0;
    let lamp = &model.cases[0].rois[0];
    let get = |name: &str| lamp.metrics[name].unwrap();
    for (p, s) in ["r", "b"].iter().zip([0, 2]) {
        let a = 0.2 * 200.0 * colour.led_rgb[s];
        if a < 1e-6 {
            // A plane that sees none of the lamp stays at black: FMI 0.
            assert!(get(&format!("fmi_{p}")).abs() < 1e-12);
            continue;
        }
        // Levels black and black + a: FMI = a / (2 black + a); FDI the lit
        // share when a / black > 0.1; MMP 0 when neither level is within
        // 10 % of the mean.
        let fmi = a / (2.0 * black + a);
        assert!((get(&format!("fmi_{p}")) - fmi).abs() < 1e-9, "{p}");
        let fdi = if a / black > 0.1 { lit / n } else { 0.0 };
        assert!((get(&format!("fdi_p2020_{p}")) - fdi).abs() < 1e-12, "{p}");
        let mean = black + a * lit / n;
        let inside = [black, black + a]
            .iter()
            .filter(|&&x| (x - mean).abs() < 0.1 * mean)
            .count();
        assert_eq!(inside, 0, "the closed form below assumes no level inside");
        assert_eq!(get(&format!("mmp_{p}")), 0.0, "{p}");
    }
    // Green: half the pulse in every frame, a steady black + a / 2.
    let a = 0.2 * 200.0 * colour.led_rgb[1];
    assert!(get("fmi_g").abs() < 1e-9, "{}", get("fmi_g"));
    assert_eq!(get("mmp_g"), 1.0);
    let fdi_g = if a / 2.0 / black > 0.1 { 1.0 } else { 0.0 };
    assert_eq!(get("fdi_p2020_g"), fdi_g);
    // The red plane's FMI is far from the luma's: the luma mixes the planes.
    assert!((get("fmi_r") - get("fmi")).abs() > 1e-3 || colour.led_rgb[1] == 0.0);
    // Only the LED ROI has the plane KPIs.
    assert!(!model.cases[0].rois[1].metrics.contains_key("fmi_r"));
}

/// The shipped plan with `delta-uv-max = limit` its only limit that can fail.
fn with_delta_uv_max(limit: f64) -> String {
    let text = plan_text();
    let start = text.find("[thresholds]").unwrap();
    let end = start + text[start..].find("\n\n").unwrap();
    format!(
        "{}[thresholds]\nmitigation-min-hz = 90.0\nfdi-2018-min = -1.0\ndelta-uv-max = {limit:e}{}",
        &text[..start],
        &text[end..]
    )
}

#[test]
fn delta_uv_max_flips_the_verdict_on_either_side_of_the_excursion() {
    let (_, _, model) = run(&with_delta_uv_max(1.0));
    let delta = model.cases[0].rois[0].metrics["delta_uv"].unwrap();
    assert!(delta > 0.01, "{delta}");
    assert_eq!(model.thresholds.delta_uv_max, Some(1.0));
    for (limit, verdict) in [
        (delta * (1.0 + 1e-6), "pass"),
        (delta * (1.0 - 1e-6), "fail"),
    ] {
        let (_, _, model) = run(&with_delta_uv_max(limit));
        let case = &model.cases[0];
        assert_eq!(case.verdict.as_str(), verdict, "limit {limit} on {delta}");
        let check = case
            .checks
            .iter()
            .find(|c| c.metric == "delta_uv")
            .expect("a delta_uv check");
        assert_eq!(check.value, Some(delta));
        assert_eq!(check.pass, verdict == "pass");
        assert_eq!(check.roi, "stop-lamp");
        assert!(
            !case.checks.iter().any(|c| c.roi == "road"),
            "a background ROI is not judged"
        );
        // The exports judge it too.
        let csv = ledflicker::report::export::summary_csv(&model).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        assert_eq!(row[col("verdict")], verdict);
        let written: f64 = row[col("delta_uv_max")].parse().unwrap();
        assert!((written - limit).abs() < 1e-6, "{written} vs {limit}");
        assert!(header.contains(&"fmi_r") && header.contains(&"mmp_b"));
        let junit = ledflicker::report::export::junit_xml(&model).unwrap();
        assert!(junit.contains("delta_uv"), "{junit}");
        assert_eq!(junit.contains("<failure"), verdict == "fail", "{junit}");
    }
    // Without colour the limit is refused, naming the key.
    let text = with_delta_uv_max(0.01).replace("led-chromaticity-xy = [0.6931, 0.3003]\n", "");
    let text = text.replace("signal-colour = \"red\"\n", "");
    let text = text.replace("colour-plane-offset-ms = [0.0, 1.5, 0.0]\n", "");
    let start = text.find("camera-to-xyz = [").unwrap();
    let end = start + text[start..].find("\n]\n").unwrap() + 3;
    let text = format!("{}{}", &text[..start], &text[end..]);
    let err = ledflicker::plan::parse(&text, std::path::Path::new("c.toml"), String::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("thresholds.delta-uv-max") && err.contains("led-chromaticity-xy"),
        "{err}"
    );
}
