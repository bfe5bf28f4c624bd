//! The figures of outputs that README.md, docs/ and the shipped plans quote
//! (page counts, case counts, schema versions, metric values) are those
//! the outputs give. scripts/readme-figures.list names each quote and the
//! figure it holds; the tests that render a plan's report pass it to
//! `check`, and the tests here check that every quote is still in its
//! file, that every page count and schema id there is listed, and that
//! each exact figure's output is checked by some test. Times and sizes
//! vary by machine: scripts/readme-figures reports them.

use std::path::Path;

use crate::{ledflicker, pdf_text, root, scratch, text};

/// The outputs the integration tests pass to `check`: the customer test's
/// plans and comparison report, the legibility test's grid-192, and the
/// two rendered here. `results` and `schema` are checked here.
const CHECKED: [&str; 12] = [
    "daylight",
    "lowlight",
    "cms-night",
    "rgb-signal",
    "p2020-samples",
    "sweep-23k",
    "comparison",
    "grid-192",
    "cms-colour",
    "daylight-full",
    "results",
    "schema",
];

/// One row of the list: file, quote, figure names, kind.
struct Entry {
    file: String,
    quote: String,
    names: Vec<String>,
    kind: String,
}

fn entries() -> Vec<Entry> {
    let list = std::fs::read_to_string(root().join("scripts/readme-figures.list")).unwrap();
    list.lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let p: Vec<&str> = l.split(" || ").map(str::trim).collect();
            assert_eq!(p.len(), 4, "readme-figures.list: {l}");
            let names = match p[2] {
                "-" => vec![],
                n => n.split(',').map(|s| s.trim().to_string()).collect(),
            };
            Entry {
                file: p[0].into(),
                quote: p[1].into(),
                names,
                kind: p[3].into(),
            }
        })
        .collect()
}

/// The file's text with each run of whitespace one space, and the line
/// each byte of it comes from.
fn normalised(file: &str) -> (String, Vec<usize>) {
    let text = std::fs::read_to_string(root().join(file)).unwrap();
    let (mut out, mut lines, mut line, mut space) = (String::new(), Vec::new(), 1, false);
    for c in text.chars() {
        if !(c.is_whitespace() && space) {
            let c = if c.is_whitespace() { ' ' } else { c };
            out.push(c);
            lines.extend(std::iter::repeat_n(line, c.len_utf8()));
        }
        space = c.is_whitespace();
        line += usize::from(c == '\n');
    }
    (out, lines)
}

/// Where `quote` matches in `text`, and the figures at its `{}`s.
fn find(text: &str, quote: &str) -> Option<(usize, usize, Vec<String>)> {
    let quote = quote.split_whitespace().collect::<Vec<_>>().join(" ");
    let parts: Vec<&str> = quote.split("{}").collect();
    for (at, _) in text.match_indices(parts[0]) {
        let mut pos = at + parts[0].len();
        let mut values = Vec::new();
        for part in &parts[1..] {
            let rest = &text[pos..];
            let len = rest
                .find(|c: char| !(c.is_ascii_digit() || c == ',' || c == '.'))
                .unwrap_or(rest.len());
            let value = rest[..len].trim_end_matches(['.', ',']);
            if !value.starts_with(|c: char| c.is_ascii_digit()) {
                break;
            }
            pos += value.len();
            if !text[pos..].starts_with(part) {
                break;
            }
            values.push(value.to_string());
            pos += part.len();
        }
        if values.len() == parts.len() - 1 {
            return Some((at, pos, values));
        }
    }
    None
}

/// `actual` is the `quoted` figure at the quote's precision.
fn equal(quoted: &str, actual: f64) -> bool {
    let decimals = quoted.split_once('.').map_or(0, |(_, d)| d.len());
    let scale = 10f64.powi(decimals as i32);
    let q: f64 = quoted.replace(',', "").parse().unwrap();
    (actual * scale).round() == (q * scale).round()
}

/// Every exact figure quoted of `output` (a plan, `daylight-full`,
/// `comparison`, `results`), against `dir`: its results.json and its
/// report.pdf (comparison.pdf for the comparison report). One line per
/// figure that differs.
pub fn check(output: &str, dir: &Path) -> Vec<String> {
    let pdf = dir.join(if output == "comparison" {
        "comparison.pdf"
    } else {
        "report.pdf"
    });
    let results: Option<serde_json::Value> = std::fs::read_to_string(dir.join("results.json"))
        .ok()
        .map(|s| serde_json::from_str(&s).unwrap());
    let mut failures = Vec::new();
    for e in entries().iter().filter(|e| e.kind == "exact") {
        let (text, lines) = normalised(&e.file);
        let Some((at, _, values)) = find(&text, &e.quote) else {
            failures.push(format!("{}: no longer says `{}`", e.file, e.quote));
            continue;
        };
        for (name, quoted) in e.names.iter().zip(&values) {
            let Some(figure) = name.strip_prefix(&format!("{output}.")) else {
                continue;
            };
            let actual = figure_of(figure, &pdf, results.as_ref());
            if !equal(quoted, actual) {
                failures.push(format!(
                    "{}:{} says {quoted} for {name}; the output gives {actual}",
                    e.file, lines[at]
                ));
            }
        }
    }
    // A plan the docs quote no exact figure of (p2020-samples) has none to check.
    failures
}

/// One figure of a run's output (the names of scripts/readme-figures.list).
fn figure_of(figure: &str, pdf: &Path, results: Option<&serde_json::Value>) -> f64 {
    let r = || results.expect("results.json");
    let counts = |k: &str| r()["counts"][k].as_f64().unwrap();
    match figure {
        "pages" => pdf_text(pdf).split('\u{c}').count() as f64 - 1.0,
        "case-pages" => case_sections(&pdf_text(pdf), r()) as f64,
        "cases" => counts("total"),
        "pass" | "fail" | "info" => counts(figure),
        "schema" => r()["schema"]
            .as_str()
            .unwrap()
            .rsplit('/')
            .next()
            .unwrap()
            .parse()
            .unwrap(),
        "frames-per-case" => r()["cases"][0]["frames"].as_f64().unwrap(),
        _ => {
            let (case, metric) = figure
                .strip_prefix("case")
                .and_then(|f| f.split_once('.'))
                .unwrap_or_else(|| panic!("no such figure: {figure}"));
            let case = &r()["cases"][case.parse::<usize>().unwrap()];
            let led = case["rois"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["kind"] == "led");
            led.expect("an LED ROI")["metrics"][metric]
                .as_f64()
                .unwrap()
        }
    }
}

/// The cases that open a section of their own ("3.2 test_vid3: ...").
fn case_sections(text: &str, results: &serde_json::Value) -> usize {
    let ids: Vec<&str> = results["cases"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    let mut found: Vec<&str> = text
        .lines()
        .filter_map(|l| {
            let (number, rest) = l.trim_start().split_once(' ')?;
            let (a, b) = number.split_once('.')?;
            let numeric = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_digit());
            let id = rest.split_once(": ")?.0;
            (numeric(a) && numeric(b) && ids.contains(&id)).then_some(id)
        })
        .collect();
    found.sort_unstable();
    found.dedup();
    found.len()
}

/// The files a figure of an output may be quoted in; docs/changes.md
/// records past changes with the figures as they were.
fn scanned() -> Vec<String> {
    let mut files = vec!["README.md".to_string()];
    for dir in ["docs", "test-plans"] {
        let mut names: Vec<String> = std::fs::read_dir(root().join(dir))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| (n.ends_with(".md") && n != "changes.md") || n.ends_with(".toml"))
            .map(|n| format!("{dir}/{n}"))
            .collect();
        names.sort();
        files.extend(names);
    }
    files
}

/// Page counts ("10-page", "19 pages") and schema ids
/// ("ledflicker.results/4") in `text`: their byte offsets.
fn figures_in(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    let digits_before = |end: usize| {
        let start = text[..end]
            .trim_end_matches(|c: char| c.is_ascii_digit())
            .len();
        (start < end).then_some(start)
    };
    for marker in ["-page", " page"] {
        for (at, _) in text.match_indices(marker) {
            if let Some(start) = digits_before(at) {
                found.push((start, text[start..at + marker.len()].trim().to_string()));
            }
        }
    }
    for (at, _) in text.match_indices("ledflicker.") {
        let rest = &text[at + "ledflicker.".len()..];
        let name = rest.trim_start_matches(|c: char| c.is_ascii_lowercase() || c == '-');
        let version = name.strip_prefix('/').unwrap_or("");
        let digits = version.len()
            - version
                .trim_start_matches(|c: char| c.is_ascii_digit())
                .len();
        if name.len() < rest.len() && digits > 0 {
            let end = text.len() - version.len() + digits;
            found.push((at, text[at..end].to_string()));
        }
    }
    found
}

#[test]
fn every_quoted_page_count_and_schema_id_is_listed_and_found() {
    let entries = entries();
    let mut failures = Vec::new();
    for file in scanned() {
        let (text, lines) = normalised(&file);
        let spans: Vec<(usize, usize)> = entries
            .iter()
            .filter(|e| e.file == file)
            .filter_map(|e| find(&text, &e.quote).map(|(s, end, _)| (s, end)))
            .collect();
        for (at, what) in figures_in(&text) {
            if !spans.iter().any(|&(s, e)| (s..e).contains(&at)) {
                failures.push(format!(
                    "{file}:{}: `{what}` is not in scripts/readme-figures.list",
                    lines[at]
                ));
            }
        }
    }
    for e in &entries {
        let (text, _) = normalised(&e.file);
        if find(&text, &e.quote).is_none() {
            failures.push(format!("{}: no longer says `{}`", e.file, e.quote));
        }
        for name in e.names.iter().filter(|_| e.kind == "exact") {
            let output = name.split('.').next().unwrap();
            if !CHECKED.contains(&output) {
                failures.push(format!("{name}: no test renders `{output}` and checks it"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_scan_finds_page_counts_and_schema_ids() {
    let found: Vec<String> =
        figures_in("a 10-page PDF, 19 pages, on page 3, `ledflicker.results/4`, ledflicker.toml")
            .into_iter()
            .map(|(_, w)| w)
            .collect();
    assert_eq!(found, ["10-page", "19 page", "ledflicker.results/4"]);
    assert_eq!(
        find("the report: 19 pages. Then", "report: {} pages."),
        Some((4, 21, vec!["19".to_string()]))
    );
    assert!(equal("0.406", 0.4056) && !equal("0.41", 0.4049) && equal("23,460", 23460.0));
}

#[test]
fn schema_ids_quoted_are_the_ones_the_source_writes() {
    let mut written = std::collections::BTreeMap::new();
    let mut dirs = vec![root().join("src"), root().join("crates")];
    while let Some(dir) = dirs.pop() {
        for e in std::fs::read_dir(dir).unwrap().map(Result::unwrap) {
            let path = e.path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|x| x == "rs") {
                let src = std::fs::read_to_string(&path).unwrap();
                for (at, _) in src.match_indices("\"ledflicker.") {
                    let id = src[at + 1..].split('"').next().unwrap();
                    if let Some((name, v)) = id
                        .strip_prefix("ledflicker.")
                        .and_then(|i| i.split_once('/'))
                        && let Ok(v) = v.parse::<u32>()
                    {
                        written.insert(name.to_string(), v);
                    }
                }
            }
        }
    }
    let mut failures = Vec::new();
    for e in entries() {
        for name in e.names.iter().filter_map(|n| n.strip_prefix("schema.")) {
            let (text, lines) = normalised(&e.file);
            let (at, _, values) = find(&text, &e.quote).expect("quote found");
            let quoted: u32 = values[0].parse().unwrap();
            if written.get(name) != Some(&quoted) {
                failures.push(format!(
                    "{}:{}: ledflicker.{name}/{quoted}; the source writes {:?}",
                    e.file,
                    lines[at],
                    written.get(name)
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The quoted figures of outputs no other test renders: cms-colour, and
/// daylight at `--detail full`.
#[test]
fn figures_of_cms_colour_and_the_full_daylight_report_are_the_outputs() {
    let dir = scratch("doc-figures");
    let mut failures = Vec::new();
    for (output, args, code) in [
        ("cms-colour", &["cms-colour"][..], 1),
        ("daylight-full", &["daylight", "--detail", "full"][..], 0),
    ] {
        let out = dir.join(output);
        let mut all = vec!["plan", "--out", out.to_str().unwrap(), "-q"];
        all.extend(args);
        let o = ledflicker(&all);
        assert_eq!(o.status.code(), Some(code), "{output}: {}", text(&o));
        failures.extend(check(output, &out));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The parts of the comparison report in the order README.md describes
/// them: a phrase of the README's description, then the heading that
/// starts the part in comparison.pdf.
const README_COMPARISON_ORDER: [(&str, &str); 8] = [
    ("page 1 lists what differs", "What differs between the runs"),
    ("names the two runs", "The two runs"),
    ("starts the table of the", "Regressions"),
    ("the traces of the worst", "Traces of the regressed cases"),
    ("frequency x duty grid of FDI", "Across the grid"),
    ("verdict flips with their causes", "Verdict flips"),
    (
        "a chart of FDI at the worst phase before and after",
        "Before and after, case by case",
    ),
    ("the table of the other gated KPIs", "Every other gated KPI"),
];

/// The same for docs/campaigns.md's description of comparison.html.
const CAMPAIGNS_COMPARISON_ORDER: [(&str, &str); 7] = [
    (
        "what differs between the runs",
        ">What differs between the runs<",
    ),
    ("the two runs (camera", ">The two runs<"),
    ("the regressions first", ">Regressions<"),
    (
        "the traces of the regressed cases",
        ">Traces of the regressed cases<",
    ),
    ("across the frequency x duty grid", ">Across the grid<"),
    ("verdict flips with their causes", ">Verdict flips<"),
    ("a chart per gated KPI", ">Before and after, case by case<"),
];

/// Each phrase found in `text` after the one before it; one line per
/// phrase missing or out of order.
fn in_order(what: &str, text: &str, phrases: &[&str]) -> Vec<String> {
    let mut from = 0;
    let mut failures = Vec::new();
    for p in phrases {
        match text[from..].find(p) {
            Some(at) => from += at + p.len(),
            None if text.contains(p) => failures.push(format!("{what}: `{p}` comes too early")),
            None => failures.push(format!("{what}: no `{p}`")),
        }
    }
    failures
}

/// The comparison report in `dir` (comparison.pdf and comparison.html)
/// has its parts in the order README.md and docs/campaigns.md give.
pub fn check_comparison_order(dir: &Path) -> Vec<String> {
    let mut failures = Vec::new();
    let (readme, _) = normalised("README.md");
    let (campaigns, _) = normalised("docs/campaigns.md");
    let pdf = pdf_text(&dir.join("comparison.pdf"));
    let html = std::fs::read_to_string(dir.join("comparison.html")).unwrap();
    for (doc, doc_text, out, out_text, order) in [
        (
            "README.md",
            &readme,
            "comparison.pdf",
            &pdf,
            &README_COMPARISON_ORDER[..],
        ),
        (
            "docs/campaigns.md",
            &campaigns,
            "comparison.html",
            &html,
            &CAMPAIGNS_COMPARISON_ORDER[..],
        ),
    ] {
        let said: Vec<&str> = order.iter().map(|(said, _)| *said).collect();
        let shown: Vec<&str> = order.iter().map(|(_, shown)| *shown).collect();
        failures.extend(in_order(doc, doc_text, &said));
        failures.extend(in_order(out, out_text, &shown));
    }
    failures
}

#[test]
fn the_order_check_finds_parts_out_of_order() {
    let text = "alpha beta gamma";
    assert!(in_order("t", text, &["alpha", "gamma"]).is_empty());
    assert_eq!(
        in_order("t", text, &["gamma", "alpha"]),
        ["t: `alpha` comes too early"]
    );
    assert_eq!(in_order("t", text, &["delta"]), ["t: no `delta`"]);
}
