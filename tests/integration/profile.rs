//! The report profile (`[report]`, `--profile`): company, logo, labels,
//! sections and replaced templates, in report.html and report.pdf.

use std::path::Path;
use std::process::Command;

use crate::{ledflicker, root, scratch, stderr};

/// Runs the small test plan with `--profile PROFILE` into `out`.
fn run(profile: &Path, out: &Path) -> std::process::Output {
    ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--profile",
        profile.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--date",
        "2026-01-01",
        "-q",
    ])
}

/// The text of a PDF, as pdftotext reads it.
fn pdf_text(path: &Path) -> String {
    let o = Command::new("pdftotext")
        .args([path.to_str().unwrap(), "-"])
        .output()
        .expect("pdftotext not found: install poppler-utils (scripts/test.sh does)");
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A run completed: pass (0) or some case failed (1).
fn assert_ran(o: &std::process::Output) {
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(o));
}

#[test]
fn a_profile_gives_the_report_its_company_logo_labels_and_sections() {
    let out = scratch("profile-acme");
    let profile = root().join("test-plans/profiles/acme.toml");
    assert_ran(&run(&profile, &out));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for text in [
        "Acme Automotive Cameras GmbH",
        "ACME-FLK-2026-0042",
        "<td>Prepared for</td>",
        "<td>Document No.</td>",
        "<td>Test laboratory</td>",
        "src=\"data:image/svg+xml;base64,",
        // summary, matrices, cases, method, notes, sign-off: numbered 1 to 6.
        "<h2 id=\"method\">4. Method</h2>",
        "<h2 id=\"signoff\">6. Sign-off</h2>",
    ] {
        assert!(html.contains(text), "report.html lacks {text:?}");
    }
    for dropped in [
        "id=\"verdicts\"",
        "id=\"environment\"",
        "id=\"glossary\"",
        "href=\"#glossary\"",
    ] {
        assert!(!html.contains(dropped), "report.html has {dropped:?}");
    }
    let pdf = pdf_text(&out.join("report.pdf"));
    for text in [
        "Acme Automotive Cameras GmbH",
        "ACME-FLK-2026-0042",
        "Prepared for",
        "Document No.",
        "Test laboratory",
    ] {
        assert!(pdf.contains(text), "report.pdf lacks {text:?}");
    }
    for dropped in ["Glossary of metrics", "Appendix A", "Case seeds"] {
        assert!(!pdf.contains(dropped), "report.pdf has {dropped:?}");
    }
    assert!(pdf.contains("Executive summary") && pdf.contains("Sign-off"));
    // The logo travels with the report, and results.json says so.
    let logo = std::fs::read(out.join("profile/logo.svg")).unwrap();
    assert_eq!(
        logo,
        std::fs::read(root().join("test-plans/profiles/acme-logo.svg")).unwrap()
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let p = &results["report"]["profile"];
    assert_eq!(p["company"], "Acme Automotive Cameras GmbH");
    assert_eq!(p["document_number"], "ACME-FLK-2026-0042");
    assert_eq!(p["logo"], "profile/logo.svg");
    assert_eq!(p["labels"]["company"], "Prepared for");
    assert_eq!(p["sections"].as_array().unwrap().len(), 6);
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_replaced_template_renders_in_both_reports_and_a_broken_one_names_its_line() {
    let dir = scratch("profile-templates");
    let built_in =
        |name: &str| std::fs::read_to_string(root().join("templates").join(name)).unwrap();
    // Working copies of the built-in templates, each with a mark.
    std::fs::create_dir_all(dir.join("mine")).unwrap();
    let body = "<body{% block bodyclass %}{% endblock %}>";
    let base = built_in("base.html.j2");
    assert!(base.contains(body));
    let base = base.replace(
        body,
        &format!("{body}\n<p>Zqx mark of the HTML override</p>"),
    );
    std::fs::write(dir.join("mine/base.html.j2"), base).unwrap();
    let typ = built_in("report.typ.j2");
    assert!(typ.contains("// ---- Cover\n"));
    let typ = typ.replace(
        "// ---- Cover\n",
        "// ---- Cover\nZqx mark of the PDF override\n",
    );
    std::fs::write(dir.join("mine/report.typ.j2"), typ).unwrap();
    std::fs::write(dir.join("mine.toml"), "[report]\ntemplates = \"mine\"\n").unwrap();
    let out = dir.join("out");
    assert_ran(&run(&dir.join("mine.toml"), &out));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<p>Zqx mark of the HTML override</p>"));
    assert!(pdf_text(&out.join("report.pdf")).contains("Zqx mark of the PDF override"));
    assert!(out.join("profile/templates/report.typ.j2").is_file());

    // A template minijinja cannot parse: the file and the line, exit 3.
    std::fs::create_dir_all(dir.join("broken")).unwrap();
    std::fs::write(
        dir.join("broken/report.html.j2"),
        "{% extends \"base.html.j2\" %}\n{% block body %}\n<p>{{ r.plan.id }</p>\n{% endblock %}\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("broken.toml"),
        "[report]\ntemplates = \"broken\"\n",
    )
    .unwrap();
    let o = run(&dir.join("broken.toml"), &dir.join("out-broken"));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let file = dir.join("broken/report.html.j2");
    assert!(
        err.contains(&format!(
            "cannot render template `{}`: line 3:",
            file.display()
        )),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_profile_with_a_missing_logo_fails_before_the_run() {
    let dir = scratch("profile-bad-logo");
    std::fs::write(dir.join("p.toml"), "[report]\nlogo = \"nope.png\"\n").unwrap();
    let o = run(&dir.join("p.toml"), &dir.join("out"));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("report.logo"), "{err}");
    assert!(
        err.contains(&dir.join("nope.png").display().to_string()),
        "{err}"
    );
    assert!(!dir.join("out").exists(), "no report written");
    std::fs::remove_dir_all(&dir).unwrap();
}
