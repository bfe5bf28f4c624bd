//! Reports a person can read in print: no text below 7 pt in the PDF, no
//! Markdown backtick in either report, metrics named for people, and
//! informational cases as table rows (docs/report.md).

use std::path::Path;
use std::process::Command;

use crate::{ledflicker, scratch, text};

/// The smallest text a printed report may hold, points.
const MIN_PT: f64 = 7.0;

/// A word of `pdftotext -bbox`: page, its box (points) and text.
struct Word {
    page: usize,
    width: f64,
    height: f64,
    text: String,
}

impl Word {
    /// Font size of the word, points. poppler's box of a horizontal word
    /// is exactly its font size high; a rotated one (a chart's y-axis
    /// title: "duty", "(%)", "(DN)") is that wide and as high as it is
    /// long, at least 1.7 times its size for 3 characters, where no
    /// horizontal word of 3 or more characters is 1.5 times higher than
    /// wide ("ill" is 1.2). A word taken for rotated by mistake would
    /// measure smaller than it is, so the guess can only make the test
    /// stricter.
    fn size(&self) -> f64 {
        let chars = self.text.chars().count();
        if chars >= 3 && self.height > 1.5 * self.width {
            self.width
        } else {
            self.height
        }
    }
}

fn words(pdf: &Path) -> Vec<Word> {
    let o = Command::new("pdftotext")
        .args(["-bbox", pdf.to_str().unwrap(), "-"])
        .output()
        .expect("pdftotext not found: install poppler-utils (scripts/test.sh does)");
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let attr = |tag: &str, name: &str| -> f64 {
        let v = tag.split(&format!(" {name}=\"")).nth(1).unwrap();
        v.split('"').next().unwrap().parse().unwrap()
    };
    let mut page = 0;
    let mut words = Vec::new();
    for line in out.lines() {
        let line = line.trim();
        if line.starts_with("<page ") {
            page += 1;
        }
        let Some(rest) = line.strip_prefix("<word ") else {
            continue;
        };
        let (tag, body) = rest.split_once('>').unwrap();
        let tag = format!(" {tag}");
        let tag = tag.as_str();
        words.push(Word {
            page,
            width: attr(tag, "xMax") - attr(tag, "xMin"),
            height: attr(tag, "yMax") - attr(tag, "yMin"),
            text: body.trim_end_matches("</word>").to_string(),
        });
    }
    words
}

/// Runs `plan` at the default detail into a scratch directory.
fn report_of(plan: &str) -> std::path::PathBuf {
    let dir = scratch(&format!("legible-{plan}"));
    let out = dir.join("out");
    let o = ledflicker(&[
        "plan",
        &format!("test-plans/{plan}.toml"),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{plan}: {}",
        text(&o)
    );
    out
}

/// `html` without its `open` .. `close` elements.
fn without(html: &str, open: &str, close: &str) -> String {
    let mut kept = String::new();
    let mut rest = html;
    while let Some(at) = rest.find(open) {
        kept.push_str(&rest[..at]);
        rest = rest[at..].split_once(close).map_or("", |(_, r)| r);
    }
    kept.push_str(rest);
    kept
}

/// The text of an HTML page without its tags, `<style>` and inline SVGs.
fn html_text(html: &str) -> String {
    let body = without(&without(html, "<style", "</style>"), "<svg", "</svg>");
    let mut text = String::new();
    let mut in_tag = false;
    for c in body.chars() {
        match c {
            '<' => in_tag = true,
            '>' => in_tag = false,
            c if !in_tag => text.push(c),
            _ => {}
        }
    }
    text
}

#[test]
fn pdf_text_is_at_least_7_pt_and_no_report_shows_a_backtick_or_a_metric_id() {
    for plan in ["daylight", "p2020-samples", "grid-192"] {
        let out = report_of(plan);
        let words = words(&out.join("report.pdf"));
        assert!(words.len() > 500, "{plan}: {} words", words.len());
        // Body text is 9 pt: the measure is calibrated.
        assert!(
            words.iter().any(|w| (w.height - 9.0).abs() < 0.01),
            "{plan}: no 9 pt word"
        );
        let small: Vec<String> = words
            .iter()
            .filter(|w| w.size() < MIN_PT - 1e-3)
            .take(10)
            .map(|w| format!("page {}: `{}` {:.2} pt", w.page, w.text, w.size()))
            .collect();
        assert!(
            small.is_empty(),
            "{plan}: text below {MIN_PT} pt: {small:#?}"
        );
        let backticks: Vec<&str> = words
            .iter()
            .filter(|w| w.text.contains('`'))
            .map(|w| w.text.as_str())
            .collect();
        assert!(backticks.is_empty(), "{plan}: PDF shows {backticks:?}");
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        let shown = html_text(&html);
        assert!(!shown.contains('`'), "{plan}: the HTML shows a backtick");
        // A metric id is shown only as an id: in the glossary, in code.
        for id in ["fdi_2018_worst_phase", "percent_flicker_worst_phase"] {
            let in_code = html.matches(&format!("<code>{id}</code>")).count();
            assert_eq!(
                shown.matches(id).count(),
                in_code,
                "{plan}: `{id}` shown outside code"
            );
        }
    }
}

#[test]
fn informational_cases_are_rows_at_the_default_detail_and_pages_at_full() {
    let out = report_of("grid-192");
    let figures = crate::doc_figures::check("grid-192", &out);
    assert!(figures.is_empty(), "{}", figures.join("\n"));
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let cases = results["cases"].as_array().unwrap();
    let info: Vec<&str> = cases
        .iter()
        .filter(|c| c["verdict"] == "info")
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    let fail = cases.iter().filter(|c| c["verdict"] == "fail").count();
    assert!(!info.is_empty(), "grid-192 has informational cases");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let section = html
        .split("id=\"informational\"")
        .nth(1)
        .expect("no table of informational cases")
        .split("id=\"cases\"")
        .next()
        .unwrap();
    for id in &info {
        assert!(
            section.contains(&format!("<td>{id}</td>")),
            "{id} has no row"
        );
        assert!(
            !html.contains(&format!("<section class=\"case\" id=\"{id}\">")),
            "{id} has a section at the default detail"
        );
    }
    assert_eq!(
        html.matches("<section class=\"case\"").count(),
        fail,
        "one section per failing case"
    );
    // `--detail full` keeps a page for every case and drops the table.
    let full = scratch("legible-full").join("out");
    let o = ledflicker(&[
        "plan",
        "test-plans/grid-192.toml",
        "--detail",
        "full",
        "--out",
        full.to_str().unwrap(),
        "-q",
    ]);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", text(&o));
    let html = std::fs::read_to_string(full.join("report.html")).unwrap();
    assert!(!html.contains("id=\"informational\""));
    for id in &info {
        assert!(html.contains(&format!("<section class=\"case\" id=\"{id}\">")));
    }
}
