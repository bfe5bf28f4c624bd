//! Exports of the report model for other tools: JUnit XML for CI pipelines
//! (a run's, and a comparison of two runs') and a CSV summary for
//! spreadsheets.
//!
//! Part of the report stage; both are pure functions of
//! [`Results`](crate::model::Results), written next to results.json.

use std::fmt::Write as _;

use quick_junit::{NonSuccessKind, Report, TestCase, TestCaseStatus, TestSuite};

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

/// Metric and limit columns added with `[display]`.
pub const CSV_VISIBILITY: ([&str; 2], &str) =
    (["visibility", "visibility_peak_hz"], "visibility_max");

/// Metric columns added for a plan with colour (`scene.led-chromaticity-xy`).
pub const CSV_COLOUR: [&str; 2] = ["delta_uv", "frames_outside_signal_colour"];

/// The P2020 KPIs of each colour plane, added for a plan with colour.
pub const CSV_PLANES: [&str; 9] = [
    "fmi_r",
    "fmi_g",
    "fmi_b",
    "fdi_p2020_r",
    "fdi_p2020_g",
    "fdi_p2020_b",
    "mmp_r",
    "mmp_g",
    "mmp_b",
];

/// The limit column added for a plan with colour.
pub const CSV_COLOUR_LIMIT: &str = "delta_uv_max";

/// The metric and limit columns of `model`'s CSV: the visibility ones only
/// for a plan with `[display]`, the colour ones only for a plan with
/// colour, so other plans keep their columns.
fn csv_columns(model: &Results) -> (Vec<&'static str>, Vec<&'static str>) {
    let (mut metrics, mut limits) = (CSV_METRICS.to_vec(), CSV_LIMITS.to_vec());
    if model.display.is_some() {
        metrics.extend(CSV_VISIBILITY.0);
        limits.push(CSV_VISIBILITY.1);
    }
    let coloured = model
        .cases
        .iter()
        .any(|c| c.rois.iter().any(|r| r.metrics.contains_key(CSV_COLOUR[0])));
    if coloured {
        metrics.extend(CSV_COLOUR);
        metrics.extend(CSV_PLANES);
        limits.push(CSV_COLOUR_LIMIT);
    }
    (metrics, limits)
}

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

/// Text for junit.xml: control characters but tab and line ends become
/// spaces. XML 1.0 forbids them even escaped, and quick-junit would drop
/// them, running the words on either side together.
fn xml_text(text: &str) -> String {
    text.chars()
        .map(|c| {
            if (c as u32) < 0x20 && !matches!(c, '\n' | '\t' | '\r') {
                ' '
            } else {
                c
            }
        })
        .collect()
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
                .chain(&CSV_VISIBILITY.0)
                .chain(&CSV_COLOUR)
                .chain(&CSV_PLANES)
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

fn testcase(plan_id: &str, c: &CaseInfo) -> TestCase {
    let failed: Vec<String> = c
        .checks
        .iter()
        .filter(|k| !k.pass)
        .map(check_line)
        .collect();
    let status = match c.verdict {
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
            let mut status = TestCaseStatus::non_success(NonSuccessKind::Failure);
            status
                .set_type("threshold")
                .set_message(xml_text(&message))
                .set_description(xml_text(&failed.join("\n")));
            status
        }
        Verdict::Info => {
            let mut status = TestCaseStatus::skipped();
            status.set_message(xml_text(&format!(
                "not judged: {}",
                c.not_judged.as_deref().unwrap_or("informational")
            )));
            status
        }
        Verdict::Pass => TestCaseStatus::success(),
    };
    let mut case = TestCase::new(xml_text(&c.id), status);
    case.set_classname(xml_text(&if c.light_lux > 0.0 {
        format!("{plan_id}.{}lux", c.light_lux)
    } else {
        format!("{plan_id}.unknown-lux")
    }));
    let mut all: Vec<String> = c.checks.iter().map(check_line).collect();
    all.extend(c.not_checked.iter().cloned());
    all.extend(metric_lines(c));
    if !all.is_empty() {
        case.set_system_out(xml_text(&all.join("\n")));
    }
    case
}

/// A case's worst-phase run as a trace CSV for traces/:
/// `frame,time_s,segment,<roi> as run,<roi> at the worst phase`, named
/// like [`crate::model::evidence::worst_phase_trace_path`]; none for a
/// case without one. `c` is the model's row of the run's case `r`.
pub fn worst_phase_trace(
    c: &crate::model::CaseInfo,
    r: &crate::model::CaseResult,
) -> Option<(String, Vec<u8>)> {
    let w = c.worst_phase.as_ref()?;
    let acq = &r.acquisition;
    let roi = acq.rois.iter().find(|t| t.name == w.roi)?;
    let mut out = format!("frame,time_s,segment,{0},{0}_worst_phase\n", w.roi);
    for ((f, run), worst) in acq.frames.iter().zip(&roi.luma).zip(&w.luma) {
        let _ = writeln!(
            out,
            "{},{},{},{run},{worst}",
            f.index,
            f.time_s,
            f.segment.as_str()
        );
    }
    let name = format!("{}-worst-phase.csv", c.id);
    Some((name, out.into_bytes()))
}

/// JUnit XML, written by quick-junit: one `<testsuite>` per plan, one
/// `<testcase>` per case. Failed cases carry a `<failure>` naming each
/// failed metric, its value and its threshold; informational cases are
/// `<skipped>`. The counts are the verdicts of the cases.
pub fn junit_xml(model: &Results) -> Result<String, quick_junit::SerializeError> {
    let mut suite = junit_suite(model);
    suite.add_test_cases(model.cases.iter().map(|c| testcase(&model.plan.id, &c)));
    let mut report = Report::new("ledflicker");
    report.add_test_suite(suite);
    report.to_string()
}

/// The suite of junit.xml without its test cases: the plan's properties.
fn junit_suite(model: &Results) -> TestSuite {
    let mut suite = TestSuite::new(xml_text(&model.plan.id));
    for (name, value) in [
        ("plan.title", model.plan.title.as_str()),
        ("plan.sha256", model.plan.sha256.as_str()),
        ("standard", model.plan.standard.as_str()),
        ("dut.backend", model.dut.backend.as_str()),
        ("tool.version", model.tool.version.as_str()),
    ] {
        suite.add_property((name.to_string(), xml_text(value)));
    }
    suite
}

/// Test cases serialised at a time by [`write_junit_xml`].
const JUNIT_CHUNK: usize = 256;

/// [`junit_xml`] into `out`, a chunk of test cases at a time, so that a
/// sweep's report is never held whole. quick_junit serialises the report's
/// frame (the suite's properties and counts: a case that fails is a
/// failure, one not judged is skipped) and each chunk's test cases in a
/// suite of their own; the chunks' test-case lines go between the frame's
/// properties and its closing tags. The bytes are [`junit_xml`]'s (test).
pub fn write_junit_xml(
    model: &Results,
    mut out: impl std::io::Write,
) -> Result<(), quick_junit::SerializeError> {
    let broken = |what: &str| {
        let why = format!("junit.xml: quick_junit's {what} is not as expected");
        quick_junit::SerializeError::from(std::io::Error::other(why))
    };
    let mut frame = junit_suite(model);
    frame.tests = model.counts.total;
    frame.failures = model.counts.fail;
    frame.skipped = model.counts.info;
    let mut report = Report::new("ledflicker");
    report.add_test_suite(frame);
    let frame = report.to_string()?;
    let end = frame
        .find(SUITE_END)
        .ok_or_else(|| broken("report frame"))?;
    out.write_all(&frame.as_bytes()[..end])?;
    let mut chunk = Vec::with_capacity(JUNIT_CHUNK);
    let mut cases = model.cases.iter().peekable();
    while cases.peek().is_some() {
        chunk.clear();
        chunk.extend(
            cases
                .by_ref()
                .take(JUNIT_CHUNK)
                .map(|c| testcase(&model.plan.id, &c)),
        );
        let mut suite = TestSuite::new("chunk");
        suite.add_test_cases(chunk.drain(..));
        let mut report = Report::new("ledflicker");
        report.add_test_suite(suite);
        let text = report.to_string()?;
        // The lines after the suite's start tag, up to its end tag.
        let start = text
            .find("<testsuite ")
            .and_then(|i| text[i..].find('\n').map(|j| i + j + 1))
            .ok_or_else(|| broken("test suite"))?;
        let end = text.rfind(SUITE_END).ok_or_else(|| broken("test suite"))?;
        out.write_all(&text.as_bytes()[start..end])?;
    }
    if let Some(why) = model.cases.read_error() {
        return Err(std::io::Error::other(why).into());
    }
    out.write_all(&frame.as_bytes()[end..])?;
    Ok(())
}

/// Two runs compared, as their JUnit XML shows them: `compare`'s
/// junit.xml.
#[derive(Debug, Clone, Default)]
pub struct ComparisonJunit {
    /// The suite's name, e.g. `ledflicker compare 3 7`.
    pub suite: String,
    /// What differs between the runs' set-ups, one line each.
    pub differences: Vec<String>,
    /// Why the runs may not be compared, when they may not.
    pub not_comparable: Option<String>,
    /// Every case compared, in order, with what regressed in it (empty:
    /// nothing).
    pub cases: Vec<(String, Vec<String>)>,
}

/// JUnit XML of a run comparison: one suite, a `set-up` test case first
/// (failed when the runs may not be compared; the differences as its
/// output and as properties, so a CI reading only the failures sees an
/// unaccepted difference), then one test case per case compared, failed
/// with its regressions.
pub fn comparison_junit_xml(c: &ComparisonJunit) -> Result<String, quick_junit::SerializeError> {
    let mut suite = TestSuite::new(c.suite.as_str());
    for (i, d) in c.differences.iter().enumerate() {
        suite.add_property(quick_junit::Property::new(
            format!("difference.{}", i + 1),
            d.as_str(),
        ));
    }
    let setup = match &c.not_comparable {
        Some(why) => {
            let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
            s.set_message(format!("not comparable: {why}"));
            s
        }
        None => TestCaseStatus::success(),
    };
    let mut case = TestCase::new("set-up", setup);
    if !c.differences.is_empty() {
        case.set_system_out(c.differences.join("\n"));
    }
    suite.add_test_case(case);
    for (case, bad) in &c.cases {
        let status = if bad.is_empty() {
            TestCaseStatus::success()
        } else {
            let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
            s.set_message(format!("regressed: {}", bad.join("; ")));
            s
        };
        suite.add_test_case(TestCase::new(case.as_str(), status));
    }
    let mut report = Report::new("ledflicker compare");
    report.add_test_suite(suite);
    report.to_string()
}

/// The end tag of junit.xml's suite, as quick_junit indents it.
const SUITE_END: &str = "    </testsuite>";

/// A CSV writer into memory, `capacity` bytes reserved: a field is quoted
/// when it holds a comma, a quote or a line end (RFC 4180), and a row ends
/// in `\n`.
pub(crate) fn csv_writer(capacity: usize) -> csv::Writer<Vec<u8>> {
    csv::WriterBuilder::new().from_writer(Vec::with_capacity(capacity))
}

/// The text a [`csv_writer`] wrote.
pub(crate) fn csv_text(out: csv::Writer<Vec<u8>>) -> Result<String, csv::Error> {
    let bytes = out
        .into_inner()
        .map_err(|e| csv::Error::from(e.into_error()))?;
    // Every field written was a `&str`, so this never fails.
    String::from_utf8(bytes)
        .map_err(|e| csv::Error::from(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
}

/// CSV summary, one row per case and ROI: conditions (empty when
/// unknown), verdict, metrics (empty when undefined, `inf` for an unbounded
/// FDI), saturation, the limits that applied to the case (empty: none) and
/// the ROI's failed checks (empty for a case not judged).
pub fn summary_csv(model: &Results) -> Result<String, csv::Error> {
    let mut out = csv_writer(0);
    write_summary_rows(model, &mut out)?;
    csv_text(out)
}

/// [`summary_csv`] into `out` as it is made, row by row: a sweep's table
/// is never held whole.
pub fn write_summary_csv(model: &Results, out: impl std::io::Write) -> Result<(), csv::Error> {
    let mut out = csv::WriterBuilder::new().from_writer(out);
    write_summary_rows(model, &mut out)?;
    out.flush()?;
    Ok(())
}

fn write_summary_rows<W: std::io::Write>(
    model: &Results,
    out: &mut csv::Writer<W>,
) -> Result<(), csv::Error> {
    let (metric_columns, limit_columns) = csv_columns(model);
    out.write_record(
        [
            "case",
            "light_lux",
            "frequency_hz",
            "duty",
            "verdict",
            "roi",
            "kind",
        ]
        .into_iter()
        .chain(metric_columns.iter().copied())
        .chain(["saturated"])
        .chain(limit_columns.iter().copied())
        .chain(["failed"]),
    )?;
    for c in &model.cases {
        let lux = (c.light_lux > 0.0).then_some(c.light_lux);
        let lim = model.thresholds.limits_for(lux);
        let limits: Vec<Option<f64>> = limit_columns
            .iter()
            .map(|&name| match name {
                "fdi_2018_min" => lim.fdi_2018_min,
                "percent_flicker_max" => lim.percent_flicker_max,
                "fmi_max" => lim.fmi_max,
                "fdi_p2020_min" => lim.fdi_p2020_min,
                "mmp_min" => lim.mmp_min,
                "visibility_max" => lim.visibility_max,
                "delta_uv_max" => lim.delta_uv_max,
                _ => None,
            })
            .collect();
        for r in &c.rois {
            let kind = match r.kind {
                crate::model::RoiKind::Led => "led",
                crate::model::RoiKind::Background => "background",
            };
            let mut row = vec![
                c.id.clone(),
                condition(c.light_lux),
                condition(c.frequency_hz),
                condition(c.duty),
                c.verdict.as_str().to_string(),
                r.name.clone(),
                kind.to_string(),
            ];
            row.extend(metric_columns.iter().map(|&m| {
                if r.is_unbounded(m) {
                    "inf".to_string()
                } else {
                    r.metrics
                        .get(m)
                        .copied()
                        .flatten()
                        .map_or(String::new(), csv_number)
                }
            }));
            row.push(r.saturated.to_string());
            row.extend(limits.iter().map(|l| match l {
                Some(v) if r.kind == crate::model::RoiKind::Led => csv_number(*v),
                _ => String::new(),
            }));
            // A case that was not judged failed nothing, whatever its
            // values against the limits (results.json keeps its checks).
            let failed: Vec<String> = c
                .checks
                .iter()
                .filter(|k| !k.pass && k.roi == r.name && c.verdict != Verdict::Info)
                .map(|k| k.describe())
                .collect();
            row.push(failed.join("; "));
            out.write_record(&row)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn junit_text_turns_control_characters_into_spaces() {
        assert_eq!(xml_text("a\u{1}b\u{1b}[31mc\td\ne"), "a b [31mc\td\ne");
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
    fn csv_fields_with_commas_quotes_or_line_ends_are_quoted() {
        let mut out = csv_writer(0);
        out.write_record(["plain", "a,b", "say \"hi\"", "two\nlines", "", "cr\r"])
            .unwrap();
        assert_eq!(
            csv_text(out).unwrap(),
            "plain,\"a,b\",\"say \"\"hi\"\"\",\"two\nlines\",,\"cr\r\"\n"
        );
    }
}
