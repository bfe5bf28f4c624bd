//! Runs plans in-process: results.json snapshot, determinism across thread
//! counts, and the physics behind the daylight verdicts.

use ledflicker::backend::sim::Simulator;
use ledflicker::plan;
use ledflicker::report;
use ledflicker::runner;
use serde_json::Value;

use crate::root;

fn run(
    path: &str,
    threads: usize,
) -> (
    plan::Plan,
    Vec<runner::CaseResult>,
    ledflicker::model::Results,
) {
    let p = plan::load(std::path::Path::new(path)).unwrap();
    let cases = plan::expand_cases(&p);
    let backend = Simulator::new(&p);
    let results = runner::run(&p, &cases, &backend, Some(threads), &|_| {}).unwrap();
    let model = ledflicker::model::assemble(&p, "sim-ideal", &results);
    (p, results, model)
}

/// Rounds every float to 6 significant digits so that the snapshot does not
/// depend on the last bits of libm.
fn rounded(v: Value) -> Value {
    match v {
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap();
            if x == 0.0 {
                return Value::from(0.0);
            }
            let digits = 5 - x.abs().log10().floor() as i32;
            let scale = 10f64.powi(digits);
            Value::from((x * scale).round() / scale)
        }
        Value::Array(a) => Value::Array(a.into_iter().map(rounded).collect()),
        Value::Object(o) => Value::Object(o.into_iter().map(|(k, v)| (k, rounded(v))).collect()),
        other => other,
    }
}

/// The daylight results.json in reviewable parts: one snapshot of
/// everything but the cases (which lists the case ids, in order), and one
/// per case.
#[test]
fn daylight_results_match_the_snapshots() {
    let (_, _, model) = run("test-plans/daylight.toml", 2);
    let mut json = serde_json::to_value(&model).unwrap();
    // The tool version changes with releases; the numbers must not.
    json["tool"]["version"] = Value::from("[version]");
    let Value::Array(cases) = json["cases"].take() else {
        panic!("results.json has no case list");
    };
    json["cases"] = cases.iter().map(|c| c["id"].clone()).collect();
    insta::assert_json_snapshot!("daylight_results", rounded(json));
    assert_eq!(cases.len(), 35);
    for case in cases {
        let id = case["id"].as_str().unwrap().to_string();
        insta::assert_json_snapshot!(format!("daylight_case_{id}"), rounded(case));
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let one = serde_json::to_string(&run("test-plans/daylight.toml", 1).2).unwrap();
    let four = serde_json::to_string(&run("test-plans/daylight.toml", 4).2).unwrap();
    assert_eq!(one, four);
    let (_, r1, _) = run("test-plans/lowlight.toml", 1);
    let (_, r3, _) = run("test-plans/lowlight.toml", 3);
    for (a, b) in r1.iter().zip(&r3) {
        assert_eq!(a.acquisition, b.acquisition, "case {}", a.case.id);
    }
}

#[test]
fn results_json_keeps_its_contract() {
    let (_, _, model) = run("test-plans/daylight.toml", 2);
    let json = serde_json::to_value(&model).unwrap();
    assert_eq!(json["schema"], "ledflicker.results/5");
    for key in ["id", "title", "path", "sha256"] {
        assert!(json["plan"][key].is_string(), "plan.{key}");
    }
    assert!(["pass", "fail"].contains(&json["verdict"].as_str().unwrap()));
    for case in json["cases"].as_array().unwrap() {
        for key in ["light_lux", "frequency_hz", "duty"] {
            assert!(case[key].is_number(), "{key}");
        }
        assert!(["pass", "fail", "info"].contains(&case["verdict"].as_str().unwrap()));
        for roi in case["rois"].as_array().unwrap() {
            assert!(roi["name"].is_string());
            for m in ["fdi_2018", "percent_flicker"] {
                let v = &roi["metrics"][m];
                assert!(
                    v.is_number() || (v.is_null() && roi["reasons"][m].is_string()),
                    "{m}: {v}"
                );
            }
        }
    }
}

#[test]
fn phase_locked_case_shows_its_worst_case_beyond_the_captured_phase() {
    // 150 Hz at 30 fps locks: every frame sees one phase, so the capture is
    // flat while other phases flicker.
    let (_, results, _) = run("test-plans/daylight.toml", 2);
    let r = results
        .iter()
        .find(|r| r.case.id == "2000lux-150hz-20pct")
        .unwrap();
    let m = &r.metrics[0];
    assert!(m.percent_flicker.value.unwrap() < 1e-9);
    assert!(
        m.percent_flicker_worst_phase
            .as_ref()
            .unwrap()
            .value
            .unwrap()
            > 10.0
    );
    assert!(m.fdi_2018_worst_phase.as_ref().unwrap().value.unwrap() < m.fdi_2018.value.unwrap());
}

#[test]
fn exposure_of_whole_periods_shows_no_flicker_in_the_plan() {
    // 11.111 ms is 1/90 s to 4 digits: at 90 Hz the exposure spans one period
    // (to 1e-4), so the ROI hardly modulates at any phase.
    let (_, results, _) = run("test-plans/daylight.toml", 2);
    for r in results.iter().filter(|r| r.case.frequency_hz == 90.0) {
        let pf = r.metrics[0]
            .percent_flicker_worst_phase
            .as_ref()
            .unwrap()
            .value
            .unwrap();
        assert!(pf < 0.01, "{}: {pf}", r.case.id);
    }
}

#[test]
fn no_nan_reaches_the_report() {
    let (_, results, model) = run("test-plans/daylight.toml", 2);
    let json = serde_json::to_string(&model).unwrap();
    assert!(!json.contains("NaN") && !json.contains("Infinity"));
    let html = full_html(&model, &results);
    assert!(!html.contains("NaN"));
    // One trace and one zoom per case, one phase fold per LED ROI of each case, two
    // fine maps per light level, the exposure-advice curve and one matrix
    // for the single light level.
    let led_rois = model.cases[0]
        .rois
        .iter()
        .filter(|r| r.kind == ledflicker::plan::RoiKind::Led)
        .count();
    // Folds that hit fewer than MIN_FOLD_PHASES phase bins are a sentence.
    let folds: usize = model
        .cases
        .iter()
        .map(|c| {
            c.rois
                .iter()
                .filter(|r| r.kind == ledflicker::plan::RoiKind::Led)
                .filter(|r| {
                    r.analysis.phase_coverage.covered_bins >= report::charts::MIN_FOLD_PHASES
                })
                .count()
        })
        .sum();
    let sentences = results.len() * led_rois - folds;
    // Daylight (30 fps, 50-1000 Hz) visits 1 or 3 phases: every fold is a sentence.
    assert!(sentences > 0, "{folds} folds, {sentences} sentences");
    assert_eq!(
        html.matches("Phase fold of led not drawn").count(),
        sentences
    );
    // A case whose verdict rests on a worst-phase check it does not meet
    // also has the chart of its trace at that phase.
    let worst = model
        .cases
        .iter()
        .filter(|c| c.worst_phase.is_some())
        .count();
    assert_eq!(
        html.matches("<svg").count(),
        2 * results.len() + folds + worst + 2 * model.fine_maps.len() + 1 + 1
    );
    assert!(html.contains("ON level") && html.contains("OFF level"));
}

#[test]
fn dark_off_reference_is_reported_as_unbounded() {
    // No ambient light: L_OFF = 0, so FDI is +inf, stated, never NaN.
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "levels-lux = [2000.0]",
            "levels-lux = [2000.0]\n[scene]\nbackground-reflectance = 0.0",
        );
    let p = plan::parse(&text, std::path::Path::new("dark.toml"), String::new()).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(1), &|_| {}).unwrap();
    let model = ledflicker::model::assemble(&p, "sim-ideal", &results);
    let json = serde_json::to_value(&model).unwrap();
    let case = json["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["id"] == "2000lux-150hz-50pct")
        .unwrap();
    let roi = &case["rois"][0];
    assert!(roi["metrics"]["fdi_2018"].is_null());
    assert_eq!(roi["contrast_unbounded"], true);
    assert!(
        roi["reasons"]["fdi_2018"]
            .as_str()
            .unwrap()
            .contains("unbounded")
    );
    let html = full_html(&model, &results);
    assert!(html.contains("+&infin;") && html.contains("unbounded"));
}

/// report.html of a run at `--detail full`: a section for every case.
fn full_html(
    model: &ledflicker::model::Results,
    results: &[ledflicker::runner::CaseResult],
) -> String {
    let mut model = model.clone();
    model.report = Some(ledflicker::model::ReportMeta {
        date: "2026-01-01".to_string(),
        detail: "full".to_string(),
        inputs: Vec::new(),
        notes: Vec::new(),
        profile: None,
    });
    report::html::render(&model, results, "2026-01-01").unwrap()
}

/// results.json reads back as written, every double exact; its fixed words
/// (a check's comparison, how segments were found, the shutter) read back
/// as what they are, and a word outside the set is refused, naming it, not
/// carried into a report.
#[test]
fn results_json_reads_back_exactly_and_refuses_words_outside_their_set() {
    let (_, _, model) = run("test-plans/daylight.toml", 2);
    let text = serde_json::to_string(&model).unwrap();
    let back = ledflicker::model::read_results(&text).unwrap();
    assert_eq!(back.cases[0].checks[0].comparison, ">=");
    assert_eq!(back.method.backend, "simulator");
    // Read back, it is the same file: every double exactly as written.
    assert!(
        serde_json::to_string(&back).unwrap() == text,
        "results.json does not read back as written"
    );
    for (word, forged) in [
        ("\"comparison\":\">=\"", "\"comparison\":\"==\""),
        ("\"shutter\":\"rolling\"", "\"shutter\":\"sideways\""),
        ("\"backend\":\"simulator\"", "\"backend\":\"oracle\""),
    ] {
        assert!(text.contains(word), "{word}");
        let e = ledflicker::model::read_results(&text.replacen(word, forged, 1)).unwrap_err();
        let bad = forged.split(':').nth(1).unwrap().trim_matches('"');
        assert!(e.contains(bad), "{forged}: {e}");
    }
}
