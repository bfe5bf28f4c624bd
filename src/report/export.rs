//! Exports of the report model for other tools: JUnit XML for CI pipelines
//! and a CSV summary for spreadsheets.
//!
//! Part of the report stage; both are pure functions of
//! [`Results`](super::model::Results), written next to results.json.

use std::fmt::Write as _;

use super::model::{CaseInfo, Results};
use crate::metrics::Verdict;

/// File name of the JUnit export.
pub const JUNIT_FILE: &str = "junit.xml";
/// File name of the CSV summary.
pub const CSV_FILE: &str = "summary.csv";

/// Metric columns of the CSV, as named in results.json.
pub const CSV_METRICS: [&str; 4] = [
    "fdi_2018",
    "fdi_2018_worst_phase",
    "percent_flicker",
    "percent_flicker_worst_phase",
];

/// Escapes text for an XML attribute or element.
fn xml(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // XML 1.0 forbids most control characters even when escaped.
            c if (c as u32) < 0x20 && !matches!(c, '\n' | '\t' | '\r') => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// One check as a sentence: `led: fdi_2018_worst_phase = 0.05, required >= 0.1`.
fn check_line(k: &crate::metrics::Check) -> String {
    let value = if k.unbounded {
        "+inf".to_string()
    } else {
        k.value
            .map_or_else(|| "undefined".to_string(), |v| format!("{v}"))
    };
    let mut s = format!(
        "{}: {} = {value}, required {} {}",
        k.roi, k.metric, k.comparison, k.threshold
    );
    if let Some(r) = &k.reason {
        let _ = write!(s, " ({r})");
    }
    s
}

fn testcase(out: &mut String, plan_id: &str, c: &CaseInfo) {
    let _ = writeln!(
        out,
        "    <testcase classname=\"{}\" name=\"{}\">",
        xml(&format!("{plan_id}.{}lux", c.light_lux)),
        xml(&c.id)
    );
    let failed: Vec<String> = c
        .checks
        .iter()
        .filter(|k| !k.pass)
        .map(check_line)
        .collect();
    match c.verdict {
        Verdict::Fail => {
            let _ = writeln!(
                out,
                "      <failure type=\"threshold\" message=\"{}\">{}</failure>",
                xml(failed.first().map_or("a check failed", String::as_str)),
                xml(&failed.join("\n"))
            );
        }
        Verdict::Info => {
            let _ = writeln!(
                out,
                "      <skipped message=\"informational: {} Hz is outside the claimed mitigation range\"/>",
                c.frequency_hz
            );
        }
        Verdict::Pass => {}
    }
    let all: Vec<String> = c.checks.iter().map(check_line).collect();
    if !all.is_empty() {
        let _ = writeln!(
            out,
            "      <system-out>{}</system-out>",
            xml(&all.join("\n"))
        );
    }
    out.push_str("    </testcase>\n");
}

/// JUnit XML: one `<testsuite>` per plan, one `<testcase>` per case.
/// Failed cases carry a `<failure>` naming each failed metric, its value and
/// its threshold; informational cases are `<skipped>`.
pub fn junit_xml(model: &Results) -> String {
    let c = &model.counts;
    let mut out = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        out,
        "<testsuites name=\"ledflicker\" tests=\"{}\" failures=\"{}\" skipped=\"{}\" errors=\"0\">",
        c.total, c.fail, c.info
    );
    let _ = writeln!(
        out,
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" skipped=\"{}\" errors=\"0\">",
        xml(&model.plan.id),
        c.total,
        c.fail,
        c.info
    );
    out.push_str("    <properties>\n");
    for (name, value) in [
        ("plan.title", model.plan.title.as_str()),
        ("plan.sha256", model.plan.sha256.as_str()),
        ("standard", model.plan.standard.as_str()),
        ("dut.backend", model.dut.backend.as_str()),
        ("tool.version", model.tool.version),
    ] {
        let _ = writeln!(
            out,
            "      <property name=\"{name}\" value=\"{}\"/>",
            xml(value)
        );
    }
    out.push_str("    </properties>\n");
    for case in &model.cases {
        testcase(&mut out, &model.plan.id, case);
    }
    out.push_str("  </testsuite>\n</testsuites>\n");
    out
}

/// Quotes a CSV field when it needs it (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// CSV summary, one row per case and ROI. An undefined metric is empty; an
/// unbounded FDI is `inf`.
pub fn summary_csv(model: &Results) -> String {
    let mut out = String::from("case,light_lux,frequency_hz,duty,verdict,roi,kind");
    for m in CSV_METRICS {
        out.push(',');
        out.push_str(m);
    }
    out.push_str(",saturated\n");
    for c in &model.cases {
        for r in &c.rois {
            let kind = serde_json::to_value(r.kind)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            let _ = write!(
                out,
                "{},{},{},{},{},{},{}",
                csv_field(&c.id),
                c.light_lux,
                c.frequency_hz,
                c.duty,
                c.verdict.as_str(),
                csv_field(&r.name),
                kind
            );
            for m in CSV_METRICS {
                out.push(',');
                if r.contrast_unbounded && m.starts_with("fdi") {
                    out.push_str("inf");
                } else if let Some(v) = r.metrics.get(m).copied().flatten() {
                    let _ = write!(out, "{v}");
                }
            }
            let _ = writeln!(out, ",{}", r.saturated);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xml_escapes_markup_and_drops_control_characters() {
        assert_eq!(
            xml("a<b & \"c\" 'd'>\u{1}"),
            "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&gt; "
        );
    }

    #[test]
    fn csv_fields_with_commas_or_quotes_are_quoted() {
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}
