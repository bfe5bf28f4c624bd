//! Exports of the report model for other tools: JUnit XML for CI pipelines
//! and a CSV summary for spreadsheets.
//!
//! Part of the report stage; both are pure functions of
//! [`Results`](crate::model::Results), written next to results.json.

use std::fmt::Write as _;

use crate::model::Verdict;
use crate::model::{CaseInfo, Results};

/// File name of the JUnit export.
pub const JUNIT_FILE: &str = "junit.xml";
/// File name of the CSV summary.
pub const CSV_FILE: &str = "summary.csv";

/// Metric columns of the CSV, as named in results.json.
pub const CSV_METRICS: [&str; 7] = [
    "fdi_2018",
    "fdi_2018_worst_phase",
    "percent_flicker",
    "percent_flicker_worst_phase",
    "fmi",
    "fdi_p2020",
    "mmp",
];

/// Limit columns of the CSV: the limits that applied to the case's light
/// level, as named in results.json's `thresholds`.
pub const CSV_LIMITS: [&str; 5] = [
    "fdi_2018_min",
    "percent_flicker_max",
    "fmi_max",
    "fdi_p2020_min",
    "mmp_min",
];

/// A number for the CSV: at most 6 decimals, trailing zeros dropped, and
/// never `-0` or `-4.5e-16` for a value that is zero to that precision.
pub fn csv_number(x: f64) -> String {
    let s = crate::util::fixed(x, 6);
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".to_string() } else { s }
}

/// A condition for the CSV: empty when unknown (stored as 0).
fn condition(x: f64) -> String {
    if x > 0.0 {
        csv_number(x)
    } else {
        String::new()
    }
}

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

/// One check as a sentence, e.g. `fmi 1.000 > 0.1 on roi07`, with the
/// reason of an undefined value.
fn check_line(k: &crate::model::Check) -> String {
    let mut s = k.describe();
    if let Some(r) = &k.reason {
        let _ = write!(s, " ({r})");
    }
    s
}

/// Every LED ROI's metrics on one line each, checked or not.
fn metric_lines(c: &CaseInfo) -> Vec<String> {
    c.rois
        .iter()
        .filter(|r| r.kind == crate::model::RoiKind::Led)
        .map(|r| {
            let values: Vec<String> = CSV_METRICS
                .iter()
                .filter_map(|m| {
                    let v = if r.is_unbounded(m) {
                        "+inf".to_string()
                    } else {
                        r.metrics
                            .get(*m)?
                            .map_or("n/a".to_string(), |x| crate::util::fixed(x, 4))
                    };
                    Some(format!("{m} {v}"))
                })
                .collect();
            format!("{}: {}", r.name, values.join(", "))
        })
        .collect()
}

fn testcase(out: &mut String, plan_id: &str, c: &CaseInfo) {
    let _ = writeln!(
        out,
        "    <testcase classname=\"{}\" name=\"{}\">",
        xml(&if c.light_lux > 0.0 {
            format!("{plan_id}.{}lux", c.light_lux)
        } else {
            format!("{plan_id}.unknown-lux")
        }),
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
            let mut metrics: Vec<&str> = Vec::new();
            for k in c.checks.iter().filter(|k| !k.pass) {
                if !metrics.contains(&k.metric.as_str()) {
                    metrics.push(&k.metric);
                }
            }
            let message = match failed.len() {
                0 => "FAIL: a check failed".to_string(),
                1 => format!("FAIL: {}", failed[0]),
                n => format!(
                    "FAIL: {} (+{} more; failed: {})",
                    failed[0],
                    n - 1,
                    metrics.join(", ")
                ),
            };
            let _ = writeln!(
                out,
                "      <failure type=\"threshold\" message=\"{}\">{}</failure>",
                xml(&message),
                xml(&failed.join("\n"))
            );
        }
        Verdict::Info => {
            let _ = writeln!(
                out,
                "      <skipped message=\"{}\"/>",
                xml(&format!(
                    "not judged: {}",
                    c.not_judged.as_deref().unwrap_or("informational")
                ))
            );
        }
        Verdict::Pass => {}
    }
    let mut all: Vec<String> = c.checks.iter().map(check_line).collect();
    all.extend(c.not_checked.iter().cloned());
    all.extend(metric_lines(c));
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
        ("tool.version", model.tool.version.as_str()),
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

/// CSV summary, one row per case and ROI: conditions (empty when
/// unknown), verdict, metrics (empty when undefined, `inf` for an unbounded
/// FDI), saturation, the limits that applied to the case (empty: none) and
/// the ROI's failed checks.
pub fn summary_csv(model: &Results) -> String {
    let mut out = String::from("case,light_lux,frequency_hz,duty,verdict,roi,kind");
    for m in CSV_METRICS {
        out.push(',');
        out.push_str(m);
    }
    out.push_str(",saturated");
    for l in CSV_LIMITS {
        out.push(',');
        out.push_str(l);
    }
    out.push_str(",failed\n");
    for c in &model.cases {
        let lux = (c.light_lux > 0.0).then_some(c.light_lux);
        let lim = model.thresholds.limits_for(lux);
        let limits = [
            lim.fdi_2018_min,
            lim.percent_flicker_max,
            lim.fmi_max,
            lim.fdi_p2020_min,
            lim.mmp_min,
        ];
        for r in &c.rois {
            let kind = match r.kind {
                crate::model::RoiKind::Led => "led",
                crate::model::RoiKind::Background => "background",
            };
            let _ = write!(
                out,
                "{},{},{},{},{},{},{}",
                csv_field(&c.id),
                condition(c.light_lux),
                condition(c.frequency_hz),
                condition(c.duty),
                c.verdict.as_str(),
                csv_field(&r.name),
                kind
            );
            for m in CSV_METRICS {
                out.push(',');
                if r.is_unbounded(m) {
                    out.push_str("inf");
                } else if let Some(v) = r.metrics.get(m).copied().flatten() {
                    out.push_str(&csv_number(v));
                }
            }
            let _ = write!(out, ",{}", r.saturated);
            for l in limits {
                out.push(',');
                if r.kind == crate::model::RoiKind::Led
                    && let Some(v) = l
                {
                    out.push_str(&csv_number(v));
                }
            }
            let failed: Vec<String> = c
                .checks
                .iter()
                .filter(|k| !k.pass && k.roi == r.name)
                .map(|k| k.describe())
                .collect();
            let _ = writeln!(out, ",{}", csv_field(&failed.join("; ")));
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
    fn csv_numbers_have_sensible_precision_and_no_negative_zero() {
        assert_eq!(csv_number(-4.5e-16), "0");
        assert_eq!(csv_number(0.0), "0");
        assert_eq!(csv_number(36.123456789), "36.123457");
        assert_eq!(csv_number(0.1), "0.1");
        assert_eq!(csv_number(2000.0), "2000");
        assert_eq!(csv_number(-0.25), "-0.25");
        assert_eq!(condition(0.0), "");
    }

    #[test]
    fn csv_fields_with_commas_or_quotes_are_quoted() {
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}
