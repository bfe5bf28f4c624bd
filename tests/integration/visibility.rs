//! The visibility of the displayed flicker end to end: a plan with
//! `[display]` and `visibility-max` judges it and every export carries
//! it; the same plan without `[display]` has none of it
//! (docs/visibility.md).

use std::path::Path;

use ledflicker::model::{Results, Verdict};

const BASE: &str = include_str!("../fixtures/plans/base.toml");

/// The fixture plan at 33 Hz (a 3 Hz beat at 30 fps) and 150 Hz (five
/// pulses a frame: steady), 20 % duty, every case judged; with a night
/// `[display]` and `visibility-max = 1` when `display`.
fn run(display: bool) -> Results {
    let mut text = BASE
        .replace(
            "frequencies-hz = [60.0, 150.0]",
            "frequencies-hz = [33.0, 150.0]",
        )
        .replace("duty-cycles = [0.2, 0.5]", "duty-cycles = [0.2]")
        .replace("mitigation-min-hz = 90.0", "mitigation-min-hz = 0.0");
    if display {
        text = text.replace("[thresholds]", "[thresholds]\nvisibility-max = 1.0");
        text.push_str("\n[display]\npreset = \"night\"\n");
    }
    let plan = ledflicker::plan::parse(&text, Path::new("vis.toml"), String::new()).unwrap();
    let cases = ledflicker::plan::expand_cases(&plan);
    let backend = ledflicker::backend::sim::Simulator::new(&plan);
    let results = ledflicker::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap();
    ledflicker::model::assemble(&plan, "sim-ideal", &results)
}

#[test]
fn a_beat_on_the_monitor_fails_visibility_max_in_every_export() {
    let m = run(true);
    let metric = |case: usize, name: &str| m.cases[case].rois[0].metrics[name];
    let (beat, steady) = (metric(0, "visibility"), metric(1, "visibility"));
    assert!(
        beat.is_some_and(|v| v > 1.0),
        "a 3 Hz beat is seen: {beat:?}"
    );
    assert!(
        steady.is_some_and(|v| v < 1e-6),
        "a locked PWM is steady: {steady:?}"
    );
    let peak = metric(0, "visibility_peak_hz").unwrap_or(0.0);
    assert!(
        (peak - 3.0).abs() < 0.6,
        "the beat is the most visible: {peak}"
    );
    assert!(metric(0, "display_luminance_cd_m2").is_some_and(|l| l > 0.0 && l <= 50.0));
    // The beat fails on visibility; the steady case passes it.
    let failed = |case: usize| {
        m.cases[case]
            .checks
            .iter()
            .any(|k| k.metric == "visibility" && !k.pass)
    };
    assert!(failed(0) && !failed(1));
    assert_eq!(m.cases[0].verdict, Verdict::Fail);

    let csv = ledflicker::report::export::summary_csv(&m).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[col("visibility_max")], "1");
    assert!(row[col("failed")].contains("visibility "), "{row:?}");
    let parsed: f64 = row[col("visibility")].parse().unwrap();
    assert!((parsed - beat.unwrap_or(0.0)).abs() < 1e-6);

    let junit = ledflicker::report::export::junit_xml(&m).unwrap();
    let failure = junit.split("<failure").nth(1).unwrap_or("");
    assert!(
        failure.contains("failed: fdi_2018_worst_phase, visibility"),
        "{junit}"
    );
    let table = ledflicker::report::terminal::summary(&m, Path::new("out"), true);
    assert!(table.lines().next().unwrap().contains("Visible"), "{table}");
}

#[test]
fn without_a_display_no_visibility_appears_anywhere() {
    let m = run(false);
    assert!(m.display.is_none());
    for c in &m.cases {
        assert!(c.rois.iter().all(|r| !r.metrics.contains_key("visibility")));
    }
    let json = serde_json::to_string(&m).unwrap();
    assert!(!json.contains("visib") && !json.contains("\"display\""));
    let csv = ledflicker::report::export::summary_csv(&m).unwrap();
    assert!(!csv.contains("visib"));
    let table = ledflicker::report::terminal::summary(&m, Path::new("out"), true);
    assert!(!table.contains("Visible"));
}

/// The shipped night CMS plan (test-plans/cms-night.toml) judges every
/// case on the monitor: a PWM locked to the frame rate (240 Hz, 4 pulses a
/// 60 fps frame; 600 Hz, 10) is steady, the 1 Hz beats of 119 and 121 Hz
/// are seen and fail `visibility-max`, and the summary prints the index
/// of every case.
#[test]
fn the_shipped_night_cms_plan_judges_visibility_in_every_case() {
    let plan = ledflicker::plan::load(&crate::root().join("test-plans/cms-night.toml")).unwrap();
    let d = plan.display.expect("cms-night has a [display]");
    assert_eq!((d.refresh_hz, d.peak_cd_m2), (60.0, 50.0));
    let cases = ledflicker::plan::expand_cases(&plan);
    let backend = ledflicker::backend::sim::Simulator::new(&plan);
    let results = ledflicker::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap();
    let m = ledflicker::model::assemble(&plan, "sim-ideal", &results);
    assert_eq!(m.thresholds.visibility_max, Some(1.0));
    let lamp = |id: &str| {
        let case = m.cases.iter().find(|c| c.id == id).unwrap();
        let roi = case.rois.iter().find(|r| r.name == "tail-lamp").unwrap();
        let failed = case
            .checks
            .iter()
            .any(|k| k.metric == "visibility" && !k.pass);
        (
            roi.metrics["visibility"],
            roi.metrics["visibility_peak_hz"],
            failed,
        )
    };
    for case in &m.cases {
        let (v, _, failed) = lamp(&case.id);
        let v = v.unwrap_or_else(|| panic!("{}: no visibility", case.id));
        assert!(v.is_finite() && v >= 0.0, "{}: {v}", case.id);
        assert_eq!(failed, v > 1.0, "{}: {v}", case.id);
        assert!(case.checks.iter().any(|k| k.metric == "visibility"));
        let shown = case.rois[0].metrics["display_luminance_cd_m2"].unwrap();
        assert!(shown > 0.0 && shown <= 50.0, "{}: {shown}", case.id);
    }
    for locked in [
        "10lux-240hz-10pct",
        "10lux-240hz-30pct",
        "10lux-600hz-30pct",
    ] {
        assert!(
            lamp(locked).0.unwrap() < 1e-6,
            "{locked}: {:?}",
            lamp(locked)
        );
    }
    for beat in ["10lux-119hz-30pct", "10lux-121hz-30pct"] {
        let (v, peak, failed) = lamp(beat);
        assert!(v.unwrap() > 2.0 && failed, "{beat}: {v:?}");
        assert!((peak.unwrap() - 1.0).abs() < 0.3, "{beat}: peak {peak:?}");
    }
    assert_eq!(m.cases[0].verdict, Verdict::Pass, "{}", m.cases[0].id);
    let table = ledflicker::report::terminal::summary(&m, Path::new("out"), true);
    let header = table.lines().next().unwrap();
    let col = header.find("Visible").expect("a Visible column");
    let rows: Vec<&str> = table.lines().filter(|l| l.starts_with("10lux-")).collect();
    assert_eq!(rows.len(), m.cases.len(), "{table}");
    for row in rows {
        let cell = row.get(col..col + 7).unwrap_or("").trim();
        assert!(cell.parse::<f64>().is_ok(), "no index in {row:?}\n{table}");
    }
}
