//! The customer's document speaks the customer's language: the PDF of six
//! shipped plans of different kinds (daylight, low light, a monitor at
//! night, colour, captured video, a 23,000-case sweep) and the README
//! campaign's comparison report carries no command line, flag, backend id,
//! path of the tool's docs, code notation or results.json id outside the
//! glossary and the environment (the machine-readable parts), no long
//! sentence printed more than 8 times, and no page under 15 % filled.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use crate::{ledflicker, scratch, text};

/// The plans, and the exit code each gives (1: some case fails).
const PLANS: [(&str, i32); 6] = [
    ("daylight", 0),
    ("lowlight", 0),
    ("cms-night", 1),
    ("rgb-signal", 1),
    ("p2020-samples", 1),
    ("sweep-23k", 1),
];

/// Text of page `k` (1-based) of `pdf`.
fn page_text(pdf: &Path, k: usize) -> Option<String> {
    let k = k.to_string();
    let o = Command::new("pdftotext")
        .args(["-f", &k, "-l", &k, "-layout"])
        .arg(pdf)
        .arg("-")
        .output()
        .expect("pdftotext (poppler-utils) runs");
    o.status
        .success()
        .then(|| String::from_utf8_lossy(&o.stdout).into_owned())
}

/// Every page's text, until pdftotext finds no more pages.
fn pages(pdf: &Path) -> Vec<String> {
    (1..).map_while(|k| page_text(pdf, k)).take(200).collect()
}

/// Whether `line` is the heading `title` (numbered, as the PDF sets it;
/// the contents' lines end in dot leaders and a page number).
fn is_heading(line: &str, title: &str) -> bool {
    line.trim()
        .trim_start_matches(|c: char| c.is_ascii_digit() || c == '.' || c == ' ')
        == title
}

/// The prose of each page: all of it but the environment and the glossary
/// (the machine-readable parts, which run from the Environment heading to
/// the appendix or the sign-off, across pages) and the running header.
fn prose(pages: &[String]) -> Vec<String> {
    let mut machine = false;
    pages
        .iter()
        .map(|page| {
            let mut kept = Vec::new();
            for line in page.lines() {
                if is_heading(line, "Environment") || is_heading(line, "Glossary of metrics") {
                    machine = true;
                } else if is_heading(line, "Sign-off")
                    || line
                        .trim_start()
                        .trim_start_matches(|c: char| c.is_ascii_digit())
                        .trim_start()
                        .starts_with("Appendix A")
                {
                    machine = false;
                }
                let header =
                    line.contains("DRAFT — NOT SIGNED") && line.contains("conformance report");
                if !machine && !header {
                    kept.push(line);
                }
            }
            kept.join("\n")
        })
        .collect()
}

/// What the reader must not meet, as (what, why) for each line of `page`
/// that has it; `names` are the plan's own names (case ids, ROI names),
/// which may look like ids.
fn internals(page: &str, names: &[String]) -> Vec<String> {
    let mut found = Vec::new();
    for line in page.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let flag = words.iter().any(|w| {
            w.strip_prefix("--")
                .is_some_and(|f| f.chars().next().is_some_and(|c| c.is_ascii_lowercase()))
        });
        let command = words.windows(2).any(|w| {
            w[0] == "ledflicker"
                && [
                    "plan", "sign", "verify", "advise", "compare", "merge", "render", "export",
                ]
                .contains(&w[1])
        });
        // A results.json id: lower-case words joined by '_' (file names
        // such as traces/2000lux-50hz-5pct.csv use '-').
        let id = words.iter().any(|w| {
            let w = w.trim_matches(|c: char| !c.is_ascii_alphanumeric() && c != '_');
            w.contains('_')
                && !names.iter().any(|n| n == w)
                && w.split('_').all(|p| {
                    !p.is_empty()
                        && p.chars()
                            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit())
                })
        });
        let checks = [
            (flag, "a command-line flag"),
            (command, "a command line"),
            (id, "a results.json id"),
            (
                line.contains("sim-ideal") || line.contains("sim-physical"),
                "a backend id",
            ),
            (line.contains("docs/"), "a path of the tool's docs"),
            (
                line.contains("T_exp") || line.contains("x_off ->"),
                "code notation",
            ),
        ];
        for (hit, what) in checks {
            if hit {
                found.push(format!("{what}: {}", line.trim()));
            }
        }
    }
    found
}

#[test]
fn shipped_reports_show_no_tool_internals_and_no_repeated_caveat() {
    let dir = scratch("customer");
    let mut failures = Vec::new();
    for (plan, code) in PLANS {
        let out = dir.join(plan);
        let o = ledflicker(&[
            "plan",
            plan,
            "--out",
            out.to_str().unwrap(),
            "--date",
            "2026-01-15",
            "-q",
        ]);
        assert_eq!(o.status.code(), Some(code), "{plan}: {}", text(&o));
        let pdf = out.join("report.pdf");
        let pages = pages(&pdf);
        assert!(pages.len() >= 5, "{plan}: {} pages", pages.len());
        failures.extend(crate::doc_figures::check(plan, &out));
        if plan == "daylight" {
            failures.extend(crate::doc_figures::check("results", &out));
        }
        failures.extend(check_pdf(plan, &pdf, &pages, &plan_names(&out), &dir));
    }
    let pdf = comparison_report(&dir.join("campaign"));
    failures.extend(crate::doc_figures::check(
        "comparison",
        pdf.parent().unwrap(),
    ));
    failures.extend(crate::doc_figures::check_comparison_order(
        pdf.parent().unwrap(),
    ));
    let pages = pages(&pdf);
    assert!(pages.len() >= 3, "comparison: {} pages", pages.len());
    failures.extend(check_pdf("comparison", &pdf, &pages, &[], &dir));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// What the reader must not meet in one PDF: internals in its prose, a
/// long sentence printed more than 8 times, a page under 15 % filled.
fn check_pdf(
    plan: &str,
    pdf: &Path,
    pages: &[String],
    names: &[String],
    scratch: &Path,
) -> Vec<String> {
    let mut failures = Vec::new();
    let mut lines: BTreeMap<String, usize> = BTreeMap::new();
    for (k, page) in prose(pages).iter().enumerate() {
        let fill = filled(pdf, k + 1, scratch);
        if fill < 0.15 {
            failures.push(format!("{plan} p{}: {:.0} % filled", k + 1, fill * 100.0));
        }
        for hit in internals(page, names) {
            failures.push(format!("{plan} p{}: {hit}", k + 1));
        }
        // Sentences only: a table's rows may repeat.
        let sentence = |l: &&str| {
            l.split_whitespace()
                .filter(|w| w.chars().all(char::is_alphabetic))
                .count()
                >= 6
        };
        for line in page.lines().map(str::trim).filter(sentence) {
            *lines.entry(line.to_string()).or_default() += 1;
        }
    }
    // A long sentence printed on many pages is a caveat of a whole
    // class said per ROI or per case.
    for (line, n) in lines.iter().filter(|(_, n)| **n > 8) {
        failures.push(format!("{plan}: printed {n} times: {line}"));
    }
    failures
}

/// Share of page `k` of `pdf` (rendered as the visual test renders it)
/// that its content fills, top to bottom: the lowest row with ink between
/// the running header and footer, over the height between them. The DRAFT
/// watermark is too light to count.
fn filled(pdf: &Path, k: usize, scratch: &Path) -> f64 {
    let page = crate::visual::render(pdf, k, &scratch.join(format!("fill-{k}.png")));
    let (w, h) = page.dimensions();
    // The header and footer lines sit within 9 % of the page's edges.
    let (top, bottom) = ((f64::from(h) * 0.09) as u32, (f64::from(h) * 0.91) as u32);
    let ink = |y: u32| (0..w).any(|x| page.get_pixel(x, y)[0] < 200);
    let last = (top..bottom).rev().find(|&y| ink(y)).unwrap_or(top);
    f64::from(last - top) / f64::from(bottom - top)
}

/// The plan's own names (case ids, ROI names), from summary.csv: they may
/// look like results.json ids.
fn plan_names(out: &Path) -> Vec<String> {
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut names: Vec<String> = Vec::new();
    for row in csv.lines().skip(1) {
        let cells: Vec<&str> = row.split(',').collect();
        for i in [0, 5] {
            if let Some(n) = cells.get(i).filter(|n| !names.iter().any(|m| m == *n)) {
                names.push(n.to_string());
            }
        }
    }
    names
}

/// The comparison report of the README's campaign: daylight, then a
/// firmware that shortened the exposure, compared; its PDF.
fn comparison_report(dir: &Path) -> std::path::PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let (a, b, report) = (dir.join("fw-1.0"), dir.join("fw-1.1"), dir.join("compare"));
    let o = ledflicker(&["plan", "daylight", "--out", a.to_str().unwrap(), "-q"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let shown = ledflicker(&["plans", "show", "daylight"]);
    let plan = String::from_utf8(shown.stdout)
        .unwrap()
        .replace("firmware = \"ideal-1\"", "firmware = \"1.1\"")
        .replace("exposure-ms = 11.111", "exposure-ms = 5.0");
    assert!(plan.contains("exposure-ms = 5.0"));
    let path = dir.join("fw-1.1.toml");
    std::fs::write(&path, plan).unwrap();
    let o = ledflicker(&[
        "plan",
        path.to_str().unwrap(),
        "--out",
        b.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let o = ledflicker(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    report.join("comparison.pdf")
}

#[test]
fn the_check_finds_what_it_looks_for() {
    // Each planted line is found; plain prose and report file names are not.
    for bad in [
        "Sign it with ledflicker sign DIR --key FILE",
        "the full report: --detail full",
        "fdi_2018_worst_phase = 0.0000",
        "Frames come from the ideal camera simulator (backend sim-ideal)",
        "see docs/campaigns.md",
        "Eq. (1), T_exp = 11.111 ms",
        "the limit x_off -> 0+",
    ] {
        assert!(!internals(bad, &[]).is_empty(), "{bad}");
    }
    for good in [
        "Trace: traces/2000lux-50hz-5pct.csv (180 frames)",
        "FDI (Deegan 2018), worst phase 0.873 — 10 % duty",
        "Plan daylight, 2026-01-15",
        "Figure 1: ROIs on frame 471 of case test_vid1",
    ] {
        let names = ["test_vid1".to_string()];
        assert!(
            internals(good, &names).is_empty(),
            "{good}: {:?}",
            internals(good, &names)
        );
    }
}

/// A plan without an OFF segment cannot judge FDI: its matrix shows the
/// Percent Flicker it is judged on, and the verdict basis names that alone.
#[test]
fn a_run_without_an_off_segment_shows_the_percent_flicker_it_is_judged_on() {
    let dir = scratch("customer-pf");
    let shown = ledflicker(&["plans", "show", "daylight"]);
    let plan = String::from_utf8(shown.stdout)
        .unwrap()
        .replace("off-s = 2.0", "off-s = 0.0")
        .replace("pwm-s = 60.0", "pwm-s = 4.0")
        .replace(
            "fdi-2018-min = 0.1",
            "fdi-2018-min = 0.1\npercent-flicker-max = 15.0",
        );
    assert!(plan.contains("percent-flicker-max = 15.0") && plan.contains("off-s = 0.0"));
    let path = dir.join("pf.toml");
    std::fs::write(&path, plan).unwrap();
    let out = dir.join("out");
    let o = ledflicker(&[
        "plan",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let matrix = std::fs::read_to_string(out.join("charts/matrix-0.svg")).unwrap();
    assert!(
        matrix.contains("Percent Flicker, worst phase by PWM frequency and duty"),
        "{matrix}"
    );
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let basis = results["method"]["verdict_basis"].as_str().unwrap();
    assert!(
        basis.starts_with("Verdicts on Percent Flicker use"),
        "{basis}"
    );
}
