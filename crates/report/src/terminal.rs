//! The summary table `ledflicker plan` prints: one row per case, for the
//! case's worst LED ROI, with every metric, the failed criterion, a legend
//! and the overall line.
//!
//! Part of the report stage; a pure function of [`Results`] so that tests
//! read exactly what a user sees.

use std::borrow::Cow;
use std::fmt::Write as _;
use std::path::Path;

use crate::model::Verdict;
use crate::model::{CaseInfo, Results, RoiInfo, SegmentMethod};

/// Metric columns: header, results.json name, decimals.
const COLUMNS: [(&str, &str, usize); 7] = [
    ("FDI", "fdi_2018", 3),
    ("FDI worst", "fdi_2018_worst_phase", 3),
    ("PF %", "percent_flicker", 2),
    ("PF worst", "percent_flicker_worst_phase", 2),
    ("FMI", "fmi", 3),
    ("FDI P2020", "fdi_p2020", 3),
    ("MMP", "mmp", 3),
];

/// The column of a plan with `[display]`.
const VISIBILITY_COLUMN: (&str, &str, usize) = ("Visible", "visibility", 2);

/// The legend line of that column.
pub const VISIBILITY_LEGEND: &str = "Visible = visibility index of the flicker on the plan's \
monitor for the standard observer (elaTCSF): 1 = at threshold, above 1 seen (docs/visibility.md)";

/// The column of a plan with colour (`scene.led-chromaticity-xy`).
const COLOUR_COLUMN: (&str, &str, usize) = ("Δu′v′", "delta_uv", 4);

/// The legend line of that column.
pub const COLOUR_LEGEND: &str = "Δu′v′ = largest distance of a PWM frame's colour from the \
colour the frames fuse to (CIE 1976 u′v′); frames outside the signal-colour region in results.json \
and the report (docs/visibility.md, section 6)";

/// The legend printed under the table.
pub const LEGEND: &str = "legend: roi = the case's worst LED ROI (least margin to its limits; \
highest Percent Flicker when nothing was checked); worst = worst case over PWM phase (simulator only); \
+inf = unbounded FDI (OFF reference 0 DN, light present); n/a = undefined (reason in results.json) \
or not computed by this backend; FDI = Deegan 2018; FDI P2020, FMI, MMP = IEEE P2020";

fn cell(roi: &RoiInfo, name: &str, digits: usize) -> String {
    if roi.is_unbounded(name) {
        return "+inf".to_string();
    }
    roi.metrics
        .get(name)
        .copied()
        .flatten()
        .map_or("n/a".to_string(), |x| crate::util::fixed(x, digits))
}

/// Why the case has its verdict: the worst ROI's first failed check (and
/// how many others failed), or why it was not judged.
fn criterion(case: &CaseInfo, roi: Option<&RoiInfo>) -> String {
    match case.verdict {
        Verdict::Pass => String::new(),
        Verdict::Info => format!(
            "not judged: {}",
            case.not_judged.as_deref().unwrap_or("informational")
        ),
        Verdict::Fail => {
            let failed: Vec<_> = case.checks.iter().filter(|k| !k.pass).collect();
            let on_roi = |k: &&&crate::model::Check| roi.is_none_or(|r| k.roi == r.name);
            let first = failed
                .iter()
                .filter(on_roi)
                .min_by(|a, b| a.margin().total_cmp(&b.margin()))
                .or(failed.first());
            let mut metrics: Vec<&str> = Vec::new();
            for k in &failed {
                if !metrics.contains(&k.metric.as_str()) {
                    metrics.push(&k.metric);
                }
            }
            match first {
                Some(k) if failed.len() > 1 => format!(
                    "FAIL: {} (+{} more; failed: {})",
                    k.describe(),
                    failed.len() - 1,
                    metrics.join(", ")
                ),
                Some(k) => format!("FAIL: {}", k.describe()),
                None => "FAIL".to_string(),
            }
        }
    }
}

/// The overall line: never PASS when no case was judged.
pub fn overall_line(model: &Results) -> String {
    let c = &model.counts;
    let not_judged = match c.info {
        1 => "1 case not judged".to_string(),
        n => format!("{n} cases not judged"),
    };
    let word = match model.verdict {
        Verdict::Info => "NOT JUDGED",
        Verdict::Pass => "PASS",
        Verdict::Fail => "FAIL",
    };
    format!(
        "overall: {word} ({} pass, {} fail of {} cases; {not_judged})",
        c.pass, c.fail, c.total
    )
}

/// Most rows the summary table prints unless every case is asked for: a
/// sweep's table belongs in summary.csv and the report, not the terminal.
pub const LISTED_CASES: usize = 50;

/// What the table takes from the cases, in one pass over them (a large
/// run reads its cases back from its spill file for each pass): the cases
/// it lists (all of them up to [`LISTED_CASES`], or with `all`; else the
/// failing ones, at most [`LISTED_CASES`]), how many are left out, the
/// widths of the id and ROI columns, and whether any case is a capture
/// with detected segments or has colour figures.
struct Listed<'a> {
    cases: Vec<Cow<'a, crate::model::CaseInfo>>,
    left_out: usize,
    id_w: usize,
    roi_w: usize,
    detected: bool,
    coloured: bool,
}

/// `*` marks a captured case whose segments were detected from the luma.
fn detected(c: &crate::model::CaseInfo) -> bool {
    c.capture
        .as_ref()
        .is_some_and(|s| s.segments.method == SegmentMethod::Detected)
}

fn listed(model: &Results, all: bool) -> Listed<'_> {
    let every = all || model.cases.len() <= LISTED_CASES;
    let mut l = Listed {
        cases: Vec::new(),
        left_out: 0,
        id_w: 4,
        roi_w: 3,
        detected: false,
        coloured: false,
    };
    for c in model.cases.iter() {
        l.id_w = l.id_w.max(c.id.len());
        l.roi_w = (c.rois.iter().map(|r| r.name.len())).fold(l.roi_w, usize::max);
        l.detected |= detected(&c);
        l.coloured |= (c.rois.iter()).any(|r| r.metrics.contains_key(COLOUR_COLUMN.1));
        if every || (c.verdict == Verdict::Fail && l.cases.len() < LISTED_CASES) {
            l.cases.push(c);
        }
    }
    l.left_out = model.cases.len() - l.cases.len();
    l
}

/// The whole summary: table, legend, overall line, basis and report paths.
/// A run of more than [`LISTED_CASES`] cases lists its failing cases only
/// (at most that many), unless `all`.
pub fn summary(model: &Results, out: &Path, all: bool) -> String {
    let Listed {
        cases,
        left_out,
        id_w,
        roi_w,
        detected: any_detected,
        coloured,
    } = listed(model, all);
    let id_w = id_w + usize::from(any_detected);
    let mut s = String::new();
    let _ = write!(s, "{:<id_w$}  {:<7}  {:<roi_w$}", "case", "verdict", "roi");
    // The visibility column appears with `[display]` only, so a plan
    // without a monitor prints the table it always did.
    let visibility = model.display.is_some().then_some(VISIBILITY_COLUMN);
    let colour = coloured.then_some(COLOUR_COLUMN);
    let columns: Vec<(&str, &str, usize)> = COLUMNS
        .into_iter()
        .chain(visibility)
        .chain(colour)
        .collect();
    for (h, _, _) in &columns {
        let _ = write!(s, "  {h:>9}");
    }
    s.push_str("  criterion\n");
    for c in cases.iter().map(|c| c.as_ref()) {
        let roi = c.worst_roi();
        let _ = write!(
            s,
            "{:<id_w$}  {:<7}  {:<roi_w$}",
            format!("{}{}", c.id, if detected(c) { "*" } else { "" }),
            c.verdict.as_str(),
            roi.map_or("-", |r| r.name.as_str())
        );
        for &(_, name, digits) in &columns {
            let v = roi.map_or("n/a".to_string(), |r| cell(r, name, digits));
            let _ = write!(s, "  {v:>9}");
        }
        let _ = writeln!(s, "  {}", criterion(c, roi));
    }
    if left_out > 0 {
        let what = if cases.is_empty() {
            "cases"
        } else {
            "more cases"
        };
        // Failing cases beyond the first LISTED_CASES are among them; say
        // so, or a reader takes the listed failures for all of them.
        let failing = model.counts.fail.saturating_sub(cases.len());
        let of_which = match failing {
            0 => String::new(),
            n => format!(", {n} of them failing"),
        };
        let _ = writeln!(
            s,
            "({left_out} {what} not listed{of_which}: every case is in summary.csv and the report; --all-cases lists them here)"
        );
    }
    let _ = writeln!(s, "{LEGEND}");
    if visibility.is_some() {
        let _ = writeln!(s, "{VISIBILITY_LEGEND}");
    }
    if coloured {
        let _ = writeln!(s, "{COLOUR_LEGEND}");
    }
    if model.cases.iter().any(|c| detected(&c)) {
        let _ = writeln!(
            s,
            "* segments detected from the luma; the report shows where (trace charts, capture text)"
        );
    }
    let _ = writeln!(s, "\n{}", overall_line(model));
    let _ = writeln!(s, "basis:   {}", model.method.verdict_basis);
    let _ = writeln!(
        s,
        "report:  {}\n         {}",
        out.join("report.html").display(),
        if super::WRITES_PDF {
            out.join("report.pdf").display().to_string()
        } else {
            "no report.pdf: this build has no PDF (build with the default features)".to_string()
        }
    );
    s
}
