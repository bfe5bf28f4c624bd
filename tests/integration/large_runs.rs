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
    // of them. The banding KPIs of a case are worked out only if the report
    // can detail it, so only the cases in memory have them.
    let held: std::collections::BTreeSet<&str> =
        spilled.cases.resident().map(|c| c.id.as_str()).collect();
    let listed = listing(&spilled, Detail::Standard).listed;
    assert!(listed.iter().all(|id| held.contains(id.as_str())));
    assert_eq!(spilled.cases.len(), memory.cases.len());
    let mut unbanded = 0;
    for (a, b) in spilled.cases.iter().zip(memory.cases.iter()) {
        let mut b = b.into_owned();
        assert!(b.banding.is_some(), "{}: a rolling shutter's KPIs", b.id);
        if !held.contains(b.id.as_str()) {
            b.banding = None;
            unbanded += 1;
        }
        assert_eq!(json(&a), json(&b));
    }
    assert!(
        unbanded > results.len() / 2,
        "{unbanded} cases left unbanded"
    );
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

/// The benchmark sweep of 11 frequencies x 10 duties at 40 and 2000 lux
/// (220 cases, more than a report lists) with a 5 ms exposure, whose low
/// duties fail, as a plan file in `dir`.
fn lean_sweep_plan(dir: &Path) -> std::path::PathBuf {
    let text = ledflicker::bench::sweep_plan(11)
        .replace("exposure-ms = 11.111", "exposure-ms = 5.0")
        .replace("levels-lux = [2000.0]", "levels-lux = [40.0, 2000.0]");
    assert!(text.contains("exposure-ms = 5.0") && text.contains("[40.0, 2000.0]"));
    let path = dir.join("sweep-220.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The names of the files in `dir`, sorted; none when it is missing.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

#[test]
fn a_sweep_at_the_default_detail_writes_its_listed_cases_and_export_gives_the_rest_as_full_does() {
    let dir = crate::scratch("lean-sweep");
    let plan = lean_sweep_plan(&dir);
    let plan = plan.to_str().unwrap();
    for (out, detail) in [("std", "standard"), ("full", "full")] {
        let o = crate::ledflicker_in(
            &[
                "plan",
                plan,
                "--out",
                out,
                "--detail",
                detail,
                "-q",
                "--date",
                "2026-01-01",
                "--max-memory",
                "4GB",
            ],
            &dir,
        );
        assert!(
            matches!(o.status.code(), Some(0 | 1)),
            "{}",
            crate::text(&o)
        );
    }
    let (std, full) = (dir.join("std"), dir.join("full"));
    // The ROI map shows the same case, the one whose lamp is brightest,
    // whether the other cases are written whole or not.
    let maps = |d: &Path| -> Vec<String> {
        let mut m: Vec<String> = names(&d.join("charts"))
            .into_iter()
            .filter(|n| n.starts_with("rois-"))
            .collect();
        m.sort();
        m
    };
    assert_eq!(maps(&std), maps(&full));
    assert_eq!(maps(&full).len(), 1, "{:?}", maps(&full));

    // results.json holds every case; the listed ones whole, the others as
    // summary rows that name the store.
    let text = std::fs::read_to_string(std.join("results.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cases = json["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 220);
    let (rows, whole): (Vec<_>, Vec<_>) =
        cases.iter().partition(|c| c.get("full_record").is_some());
    assert!(!rows.is_empty() && !whole.is_empty(), "{} rows", rows.len());
    assert!(
        whole.len() <= model::listing::LISTED_CASES_MAX + 1,
        "{}",
        whole.len()
    );
    for row in &rows {
        assert_eq!(row["full_record"], "cases.sqlite");
        assert!(row.get("trace").is_none() && row.get("sample_frame").is_none());
        assert!(row["rois"][0]["metrics"].get("fdi_2018").is_some(), "{row}");
    }
    // The trace CSVs and frames are the whole cases', and only theirs.
    let id = |c: &serde_json::Value| c["id"].as_str().unwrap().to_string();
    let mut traces: Vec<String> = whole.iter().map(|c| format!("{}.csv", id(c))).collect();
    traces.extend(
        whole
            .iter()
            .filter(|c| c.get("worst_phase").is_some())
            .map(|c| format!("{}-worst-phase.csv", id(c))),
    );
    traces.sort();
    assert_eq!(names(&std.join("traces")), traces);
    for name in names(&std.join("frames")) {
        let case = name.trim_end_matches(".png").trim_end_matches("-view");
        let case = case.trim_end_matches("-worst-phase");
        assert!(whole.iter().any(|c| id(c) == case), "{name}");
    }
    assert!(names(&std.join("frames")).len() < names(&full.join("frames")).len());
    // The store is the record of every case, as at full detail.
    assert_eq!(
        std::fs::read(std.join("cases.sqlite")).unwrap(),
        std::fs::read(full.join("cases.sqlite")).unwrap()
    );
    // A model read back holds every case, rows told from whole cases.
    let back = model::read_results(&text).unwrap();
    assert_eq!(back.cases.len(), 220);
    assert!(back.cases.has_rows());
    assert!(!back.cases.is_detailed(&id(rows[0])));
    assert!(back.cases.is_detailed(&id(whole[0])));
    assert_eq!(serde_json::to_string_pretty(&back).unwrap(), text);

    // `export` writes a row's files byte for byte as the full run did.
    let case = id(rows[0]);
    let o = crate::ledflicker_in(
        &["export", "std", "--case", &case, "--out", "exported"],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{}", crate::text(&o));
    let exported = dir.join("exported");
    let files = [
        format!("traces/{case}.csv"),
        format!("frames/{case}.png"),
        format!("frames/{case}-view.png"),
    ];
    for f in &files {
        let (a, b) = (exported.join(f), full.join(f));
        assert!(b.is_file() && !std.join(f).exists(), "{f}");
        assert!(
            std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
            "{f} differs"
        );
    }
    // A whole case's export is the file the report wrote.
    let listed = id(whole[0]);
    let o = crate::ledflicker_in(
        &["export", "std", "--case", &listed, "--out", "again"],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{}", crate::text(&o));
    let f = format!("traces/{listed}.csv");
    assert_eq!(
        std::fs::read(dir.join("again").join(&f)).unwrap(),
        std::fs::read(std.join(&f)).unwrap()
    );

    // An unknown case and a directory without a store are refused.
    let typo = format!("{}x", &case[..case.len() - 1]);
    let o = crate::ledflicker_in(&["export", "std", "--case", &typo], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", crate::text(&o));
    assert!(
        crate::stderr(&o).contains(&format!("did you mean `{case}`?")),
        "{}",
        crate::stderr(&o)
    );
    let o = crate::ledflicker_in(&["export", "exported", "--case", &case], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", crate::text(&o));
    assert!(
        crate::stderr(&o).contains("holds no case store"),
        "{}",
        crate::stderr(&o)
    );
}
