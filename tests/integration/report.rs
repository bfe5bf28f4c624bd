//! Report files through the binary: HTML snapshot, PDF text, JUnit/CSV
//! exports, golden-file drift (sign-off: signoff.rs).

use std::path::Path;
use std::process::{Command, Output};

use crate::{ledflicker, scratch, text};

const DATE: &str = "2026-01-15";

/// Runs `plan` into `dir` with a fixed date; returns the output.
fn run_plan(plan: &str, dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "plan",
        plan,
        "--out",
        dir.to_str().unwrap(),
        "--date",
        DATE,
        "-q",
    ];
    args.extend_from_slice(extra);
    ledflicker(&args)
}

/// `pdftotext -layout` (poppler-utils; scripts/test.sh installs it).
fn pdf_text(pdf: &Path) -> String {
    pdftotext(pdf, &[])
}

/// `pdftotext -layout` of one page.
fn pdf_page_text(pdf: &Path, page: usize) -> String {
    let p = page.to_string();
    pdftotext(pdf, &["-f", &p, "-l", &p])
}

fn pdftotext(pdf: &Path, pages: &[&str]) -> String {
    let o = Command::new("pdftotext")
        .args(pages)
        .args(["-layout", pdf.to_str().unwrap(), "-"])
        .output()
        .expect("pdftotext not found: install poppler-utils (scripts/test.sh does)");
    assert!(o.status.success(), "{}", text(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn pdf_pages(pdf: &Path) -> usize {
    let o = Command::new("pdfinfo")
        .arg(pdf)
        .output()
        .expect("pdfinfo not found: install poppler-utils (scripts/test.sh does)");
    let info = String::from_utf8_lossy(&o.stdout).into_owned();
    info.lines()
        .find_map(|l| l.strip_prefix("Pages:"))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no page count in pdfinfo output: {info}"))
}

/// Replaces every `start..end` run of `text` by `[kind: N bytes]`.
fn placeholders(text: &str, start: &str, end: &str, kind: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(start) {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        let Some(j) = tail[start.len()..].find(end) else {
            break;
        };
        let len = start.len() + j;
        out.push_str(&format!("[{kind}: {len} bytes]"));
        rest = &tail[len..];
    }
    out.push_str(rest);
    out
}

#[test]
fn html_report_of_the_small_plan_matches_the_snapshot() {
    let dir = scratch("html-snapshot");
    let o = run_plan("tests/fixtures/plans/base.toml", &dir, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let html = html.replace(env!("CARGO_PKG_VERSION"), "[version]");
    assert!(html.contains("DRAFT"), "an unsigned report is a draft");
    // The layout is the golden file; each chart and picture is checked by
    // its own tests, so its bytes are replaced by a placeholder with its size.
    let html = placeholders(&html, "<svg", "</svg>", "svg");
    let html = placeholders(&html, "data:image/png;base64,", "\"", "png");
    insta::assert_snapshot!("small_report_html", html);
}

#[test]
fn pdf_report_has_pages_cover_summary_and_environment_and_is_deterministic() {
    let a = scratch("pdf-a");
    let b = scratch("pdf-b");
    for dir in [&a, &b] {
        let o = run_plan("tests/fixtures/plans/small_failing.toml", dir, &[]);
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    }
    let pdf = std::fs::read(a.join("report.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF-"));
    assert_eq!(
        pdf,
        std::fs::read(b.join("report.pdf")).unwrap(),
        "same plan and date must give the same PDF bytes"
    );
    let pages = pdf_pages(&a.join("report.pdf"));
    assert!(pages >= 4, "{pages} pages");
    let t = pdf_text(&a.join("report.pdf"));
    // The simulator's darkest PWM frame is in the PDF too.
    assert!(
        t.contains("lowest LED-ROI luma"),
        "no sample frame in the PDF"
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("results.json")).unwrap()).unwrap();
    let sha = results["plan"]["sha256"].as_str().unwrap();
    let c = &results["counts"];
    let counts = format!(
        "{} cases: {} pass, {} fail; {} cases not judged",
        c["total"], c["pass"], c["fail"], c["info"]
    );
    assert!(c["fail"].as_u64().unwrap() > 0);
    for needle in [
        "LED FLICKER CONFORMANCE TEST REPORT",
        "Small test plan",
        "small-failing",
        "Ideal rolling",
        "DRAFT",
        "Executive summary",
        "Overall verdict",
        &counts,
        "Frequency × duty matrices",
        "Eq. (1)",
        "60hz-20pct",
        "fdi_2018_worst_phase",
        "FMI",
        "P2020",
        "MMP",
        "Method",
        "Deegan 2018",
        "Deviations and notes",
        "Environment",
        sha,
        "Sign-off",
        DATE,
        &format!("Page 1 of {pages}"),
        &format!("Page {pages} of {pages}"),
    ] {
        assert!(t.contains(needle), "`{needle}` not in the PDF text:\n{t}");
    }
    assert!(!t.contains("NaN"));
}

#[test]
fn junit_has_one_testcase_per_case_and_failures_name_metric_and_threshold() {
    let dir = scratch("junit");
    let o = run_plan("tests/fixtures/plans/small_failing.toml", &dir, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    let cases = results["cases"].as_array().unwrap();
    let junit = std::fs::read_to_string(dir.join("junit.xml")).unwrap();
    assert_eq!(junit.matches("<testcase ").count(), cases.len());
    let failed: Vec<&serde_json::Value> = cases.iter().filter(|c| c["verdict"] == "fail").collect();
    assert!(!failed.is_empty());
    assert_eq!(junit.matches("<failure ").count(), failed.len());
    for c in failed {
        let id = c["id"].as_str().unwrap();
        let start = junit.find(&format!("name=\"{id}\"")).unwrap();
        let block = &junit[start..start + junit[start..].find("</testcase>").unwrap()];
        let check = c["checks"]
            .as_array()
            .unwrap()
            .iter()
            .find(|k| k["pass"] == false)
            .unwrap();
        assert!(block.contains(check["metric"].as_str().unwrap()), "{block}");
        // e.g. "FAIL: fdi_2018_worst_phase 0.000 &lt; 0.1 on led"
        assert!(block.contains("message=\"FAIL: "), "{block}");
        assert!(
            block.contains(&format!(
                "&lt; {} on {}",
                check["threshold"],
                check["roi"].as_str().unwrap()
            )),
            "{block}"
        );
        // Every LED ROI's P2020 KPIs are listed, checked or not.
        assert!(block.contains("fmi ") && block.contains("mmp "), "{block}");
    }
    // It reads back as JUnit: one suite of the plan, the counts of
    // results.json, each case's name and status.
    let report = quick_junit::Report::deserialize_from_str(&junit).unwrap();
    let counts = &results["counts"];
    assert_eq!(report.tests as u64, counts["total"].as_u64().unwrap());
    assert_eq!(report.failures as u64, counts["fail"].as_u64().unwrap());
    assert_eq!(report.skipped as u64, counts["info"].as_u64().unwrap());
    assert_eq!(report.test_suites.len(), 1);
    let suite = &report.test_suites[0];
    assert_eq!(suite.name.as_str(), results["plan"]["id"].as_str().unwrap());
    for (tc, c) in suite.test_cases.iter().zip(cases) {
        assert_eq!(tc.name.as_str(), c["id"].as_str().unwrap());
        let failed = matches!(tc.status, quick_junit::TestCaseStatus::NonSuccess { .. });
        assert_eq!(failed, c["verdict"] == "fail", "{}", tc.name.as_str());
    }
    let csv = std::fs::read_to_string(dir.join("summary.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("case,light_lux,frequency_hz,duty,verdict,roi")
    );
    let rows: Vec<&str> = lines.collect();
    let rois: usize = cases
        .iter()
        .map(|c| c["rois"].as_array().unwrap().len())
        .sum();
    assert_eq!(rows.len(), rois);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for col in ["fmi", "fdi_p2020", "mmp", "fmi_max", "failed"] {
        assert!(header.contains(&col), "{col} not in {header:?}");
    }
    let first = &cases[0];
    let fields: Vec<&str> = rows[0].split(',').collect();
    assert!(rows[0].starts_with(first["id"].as_str().unwrap()));
    for m in ["fdi_2018", "fmi", "mmp"] {
        let want = first["rois"][0]["metrics"][m].as_f64().unwrap();
        let i = header.iter().position(|h| *h == m).unwrap();
        let got: f64 = fields[i].parse().unwrap();
        // Six decimals, never an exponent.
        assert!((got - want).abs() <= 5e-7, "{m}: {got} vs {want}");
        assert!(!fields[i].contains('e'), "{}", fields[i]);
    }
}

#[test]
fn golden_comparison_passes_on_itself_and_names_drift() {
    let base = scratch("golden");
    let first = base.join("first");
    let o = run_plan("tests/fixtures/plans/base.toml", &first, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let golden = first.join("results.json");
    let o = run_plan(
        "tests/fixtures/plans/base.toml",
        &base.join("second"),
        &["--golden", golden.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains(", 0 beyond tolerance"), "{}", text(&o));

    // Shift one stored value by more than its tolerance.
    let mut g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&golden).unwrap()).unwrap();
    let case = g["cases"][3]["id"].as_str().unwrap().to_string();
    let v = g["cases"][3]["rois"][0]["metrics"]["percent_flicker"]
        .as_f64()
        .unwrap();
    g["cases"][3]["rois"][0]["metrics"]["percent_flicker"] = serde_json::json!(v + 2.0);
    let shifted = base.join("shifted.json");
    std::fs::write(&shifted, serde_json::to_string(&g).unwrap()).unwrap();
    let o = run_plan(
        "tests/fixtures/plans/base.toml",
        &base.join("third"),
        &["--golden", shifted.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains(&format!("DRIFT {case} / ")) && text(&o).contains("percent_flicker"),
        "{}",
        text(&o)
    );
    // A wider tolerance accepts it.
    let o = run_plan(
        "tests/fixtures/plans/base.toml",
        &base.join("fourth"),
        &[
            "--golden",
            shifted.to_str().unwrap(),
            "--golden-tolerance",
            "percent_flicker=5",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // A file that is not results.json is invalid input.
    let o = run_plan(
        "tests/fixtures/plans/base.toml",
        &base.join("fifth"),
        &["--golden", "tests/fixtures/plans/base.toml"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

#[test]
fn results_json_reads_back_typed_field_for_field() {
    // Every field results.json holds is in the typed model both ways: the
    // file read back and written again is the same JSON, for a simulator
    // plan and a rig plan (capture summaries, detected segments).
    for (plan, name) in [
        ("tests/fixtures/plans/small_failing.toml", "typed-sim"),
        ("test-plans/command-sim-rig.toml", "typed-rig"),
    ] {
        let dir = scratch(name);
        let o = run_plan(plan, &dir, &[]);
        assert!(matches!(o.status.code(), Some(0 | 1)), "{}", text(&o));
        let json = std::fs::read_to_string(dir.join("results.json")).unwrap();
        let typed = ledflicker::model::read_results(&json).unwrap_or_else(|e| panic!("{e}"));
        let untyped: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(serde_json::to_value(&typed).unwrap(), untyped, "{plan}");
        assert!(typed.report.is_some() && !typed.cases.is_empty());
    }
    // A damaged file is refused, naming what is wrong.
    let e = ledflicker::model::read_results(r#"{"schema": "ledflicker.results/5", "cases": 3}"#)
        .unwrap_err();
    assert!(e.contains("not a readable"), "{e}");
    let e = ledflicker::model::read_results(r#"{"schema": "other/1"}"#).unwrap_err();
    assert!(e.contains("`other/1`"), "{e}");
}

#[test]
fn pdf_appendix_lists_every_case_once_on_well_filled_pages() {
    // Appendix A is one table a page (so that Typst lays the pages out in
    // parallel): each page's table must fit its page, or the page after
    // would hold a short spill-over before the next table.
    let dir = scratch("pdf-appendix");
    let o = run_plan("test-plans/daylight.toml", &dir, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    let ids: Vec<&str> = results["cases"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    let pdf = dir.join("report.pdf");
    let pages = pdf_pages(&pdf);
    let texts: Vec<String> = (1..=pages).map(|p| pdf_page_text(&pdf, p)).collect();
    // The last mentions: the contents page names both headings too.
    let first = texts
        .iter()
        .rposition(|t| t.contains("Appendix A: every case"))
        .expect("no Appendix A");
    let last = texts.iter().rposition(|t| t.contains("Sign-off")).unwrap() - 1;
    assert!(last > first, "the appendix of 35 cases fits no one page");
    // The first word of a line is the case id of the case's first ROI row.
    let rows_of = |t: &str| -> Vec<String> {
        t.lines()
            .filter_map(|l| l.split_whitespace().next())
            .filter(|w| ids.contains(&w.trim_end_matches('*')))
            .map(|w| w.trim_end_matches('*').to_string())
            .collect()
    };
    let mut listed = Vec::new();
    for (i, t) in texts[first..=last].iter().enumerate() {
        let cases = rows_of(t);
        let header = t
            .lines()
            .any(|l| l.trim_start().starts_with("Case") && l.contains("Verdict"));
        assert!(header, "page {} has no table header:\n{t}", first + i + 1);
        if first + i < last {
            assert!(
                cases.len() >= 20,
                "page {} holds only {} cases: a table spilled over its page",
                first + i + 1,
                cases.len()
            );
        }
        listed.extend(cases);
    }
    assert_eq!(listed, ids, "every case once, in order");
}
