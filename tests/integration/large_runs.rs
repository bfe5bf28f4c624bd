//! A run larger than its report lists keeps its cases on disk (the model's
//! spill file) and only the cases its report shows in memory. Everything
//! written from such a model must be what the same model held in memory
//! writes.

use std::path::Path;

use ledflicker::backend::sim::Simulator;
use ledflicker::model::listing::{CASE_PAGES_MAX, LISTED_CASES_MAX, listing};
use ledflicker::model::{self, Detail, Results};
use ledflicker::{plan, report, runner};

/// The benchmark sweep of 31 frequencies from 50 Hz x 10 duties at 40
/// and 2000 lux (620 cases) with a 5 ms exposure: below `(1 - D) / f` the
/// LED can be OFF in a frame, so low duties fail and are run again at
/// their worst phase.
fn sweep() -> (plan::Plan, Vec<runner::CaseResult>) {
    let text = ledflicker::bench::sweep_plan(31)
        .replace("exposure-ms = 11.111", "exposure-ms = 5.0")
        .replace("levels-lux = [2000.0]", "levels-lux = [40.0, 2000.0]");
    assert!(text.contains("exposure-ms = 5.0") && text.contains("[40.0, 2000.0]"));
    let p = plan::parse_within(&text, Path::new("sweep-620.toml"), String::new(), false).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
    (p, results)
}

fn json<T: serde::Serialize>(x: &T) -> String {
    serde_json::to_string(x).unwrap()
}

#[test]
fn a_spilled_model_writes_what_the_same_model_in_memory_writes() {
    let (p, results) = sweep();
    assert_eq!(results.len(), 620);
    // `--detail full` pages every case, so its model holds every case.
    let memory = model::assemble(&p, "sim-ideal", &results);
    let spilled: Results =
        model::assemble_from(&p, "sim-ideal", &results.as_slice(), Detail::Standard).unwrap();
    assert!(!memory.cases.is_spilled());
    assert!(spilled.cases.is_spilled());
    assert!(spilled.counts.fail > CASE_PAGES_MAX, "{:?}", spilled.counts);
    let worst_phase = memory
        .cases
        .iter()
        .filter(|c| c.worst_phase.is_some())
        .count();
    assert!(worst_phase > 0);

    // Only the cases a report can show stay in memory: the listed, the
    // paged, one with a frame for the ROI map, and those with a worst-phase
    // run (their frames and trace are not in results.json).
    let resident = spilled.cases.resident().count();
    assert!(
        resident <= LISTED_CASES_MAX + CASE_PAGES_MAX + 1 + worst_phase,
        "{resident} cases in memory"
    );
    assert!(resident < results.len() / 2, "{resident} cases in memory");

    // What results.json says of every case, and what is computed from all
    // of them.
    assert_eq!(json(&spilled.cases), json(&memory.cases));
    assert_eq!(json(&spilled.counts), json(&memory.counts));
    assert_eq!(spilled.verdict, memory.verdict);
    assert_eq!(json(&spilled.conditions), json(&memory.conditions));
    assert_eq!(spilled.notes, memory.notes);
    assert_eq!(spilled.light_levels(), memory.light_levels());
    assert_eq!(memory.light_levels().len(), 2);
    for lux in memory.light_levels() {
        for metric in ["fdi_2018", "percent_flicker"] {
            let (a, b) = (spilled.plane(lux, metric), memory.plane(lux, metric));
            assert_eq!(a.map(|p| p.cells), b.map(|p| p.cells), "{lux} lux {metric}");
        }
    }
    for detail in Detail::ALL {
        assert_eq!(
            listing(&spilled, detail),
            listing(&memory, detail),
            "{detail:?}"
        );
    }

    // The exports and the terminal's table, from every case.
    assert_eq!(
        report::export::summary_csv(&spilled).unwrap(),
        report::export::summary_csv(&memory).unwrap()
    );
    let whole = report::export::junit_xml(&memory).unwrap();
    assert_eq!(report::export::junit_xml(&spilled).unwrap(), whole);
    // Written as they are made, a chunk of cases at a time, they are the
    // same bytes.
    for m in [&spilled, &memory] {
        let mut streamed = Vec::new();
        report::export::write_junit_xml(m, &mut streamed).unwrap();
        assert_eq!(String::from_utf8(streamed).unwrap(), whole);
        let mut csv = Vec::new();
        report::export::write_summary_csv(m, &mut csv).unwrap();
        assert_eq!(
            String::from_utf8(csv).unwrap(),
            report::export::summary_csv(&memory).unwrap()
        );
    }
    let out = Path::new("report");
    assert_eq!(
        report::terminal::summary(&spilled, out, true),
        report::terminal::summary(&memory, out, true)
    );

    // The cases kept in memory are the model's own, worst-phase frames
    // and traces included.
    for c in spilled.cases.resident() {
        let i = memory.cases.iter().position(|m| m.id == c.id).unwrap();
        let m = &memory.cases[i];
        let (a, b) = (c.worst_phase.as_ref(), m.worst_phase.as_ref());
        assert_eq!(a.map(|w| &w.luma), b.map(|w| &w.luma), "{}", c.id);
        assert_eq!(
            a.map(|w| w.rendered.is_some()),
            b.map(|w| w.rendered.is_some())
        );
    }
    assert_eq!(spilled.cases.read_error(), None);
}
