//! `ledflicker trend`: one KPI over the recorded runs, per case and ROI,
//! as a table, JSON or an SVG chart (docs/campaigns.md).

use std::path::PathBuf;

use clap::Args;

use super::campaign::DbArg;
use super::output::{out, outln};
use super::{ExitCode, Failure, UsageError};
use crate::campaign::Database;
use crate::campaign::query::{self, Filter, TrendPoint};

/// `ledflicker trend` arguments.
#[derive(Args, Debug)]
pub(super) struct TrendArgs {
    /// The KPI, as results.json names it (e.g. fdi_2018_worst_phase,
    /// percent_flicker).
    #[arg(long, value_name = "METRIC")]
    kpi: String,
    /// Only this case id.
    #[arg(long)]
    case: Option<String>,
    /// Only this ROI.
    #[arg(long)]
    roi: Option<String>,
    /// Only runs of this camera (`[dut] model`).
    #[arg(long)]
    camera: Option<String>,
    /// Only runs of this firmware.
    #[arg(long)]
    firmware: Option<String>,
    /// Only runs of this plan id.
    #[arg(long)]
    plan: Option<String>,
    /// Print the values as a JSON array.
    #[arg(long)]
    json: bool,
    /// Also draw the KPI over the runs, one line per case and ROI, as SVG.
    #[arg(long, value_name = "FILE")]
    svg: Option<PathBuf>,
    #[command(flatten)]
    db: DbArg,
}

/// Why `trend` has nothing to show: a KPI the database does not know
/// (with the nearest name, and every name), or no value in the runs
/// the filters select.
fn no_values(kpi: &str, names: &[String]) -> String {
    if names.iter().any(|n| n == kpi) {
        return format!(
            "no value of `{kpi}` in the runs selected\n    hint: check the filters against `ledflicker history`"
        );
    }
    // Names compared without case and underscores first (fdi2018 is
    // fdi_2018), then by edit distance.
    let plain = |s: &str| s.to_lowercase().replace(['_', '-'], "");
    let nearest = names
        .iter()
        .map(|n| {
            let d = if plain(n) == plain(kpi) {
                0
            } else {
                strsim::levenshtein(&plain(n), &plain(kpi))
            };
            (d, n)
        })
        .filter(|(d, _)| *d <= 3)
        .min();
    let mean = nearest.map_or(String::new(), |(_, n)| format!("did you mean `{n}`? "));
    format!(
        "no KPI `{kpi}` in the results database\n    hint: {mean}the database holds: {}",
        names.join(", ")
    )
}

/// Prints the KPI's values over the runs, oldest first.
pub(super) fn trend(a: TrendArgs) -> Result<ExitCode, Failure> {
    let db = Database::open_existing(&a.db.location()?)?;
    let filter = Filter {
        camera: a.camera.clone(),
        firmware: a.firmware.clone(),
        plan: a.plan.clone(),
        ..Filter::default()
    };
    let points = query::trend(&db, &filter, &a.kpi, a.case.as_deref(), a.roi.as_deref())?;
    if points.is_empty() {
        let names = query::metric_names(&db)?;
        return Err(UsageError(no_values(&a.kpi, &names)).into());
    }
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&points)?)?;
    } else {
        out!("{}", table(&points))?;
    }
    if let Some(path) = &a.svg {
        let svg = chart(&a.kpi, &points)?;
        crate::util::write_atomic(path, svg.as_bytes())
            .map_err(|e| UsageError(format!("cannot write `{}`: {e}", path.display())))?;
    }
    Ok(ExitCode::Pass)
}

fn table(points: &[TrendPoint]) -> String {
    let mut rows = vec![
        [
            "run", "date", "plan", "camera", "firmware", "case", "roi", "value",
        ]
        .map(str::to_string),
    ];
    rows.extend(points.iter().map(|p| {
        [
            p.run.to_string(),
            p.date.clone(),
            p.plan.clone(),
            p.camera.clone(),
            p.firmware.clone(),
            p.case.clone(),
            p.roi.clone(),
            p.value
                .map_or_else(|| "-".to_string(), |v| format!("{v:.4}")),
        ]
    }));
    let mut widths = [0usize; 8];
    for r in &rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let mut text = String::new();
    for r in &rows {
        let line: Vec<String> = r
            .iter()
            .zip(widths)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        text.push_str(line.join("  ").trim_end());
        text.push('\n');
    }
    text
}

/// The KPI over the runs, one line per case and ROI.
fn chart(kpi: &str, points: &[TrendPoint]) -> Result<String, Failure> {
    let mut runs: Vec<(i64, String)> = Vec::new();
    let mut series: Vec<(String, Vec<Option<f64>>)> = Vec::new();
    for p in points {
        if runs.last().is_none_or(|r| r.0 != p.run) {
            runs.push((p.run, p.firmware.clone()));
        }
    }
    for p in points {
        let name = format!("{} {}", p.case, p.roi);
        let at = match series.iter().position(|s| s.0 == name) {
            Some(at) => at,
            None => {
                series.push((name, vec![None; runs.len()]));
                series.len() - 1
            }
        };
        if let Some(i) = runs.iter().position(|r| r.0 == p.run) {
            series[at].1[i] = p.value;
        }
    }
    let labels: Vec<String> = runs.into_iter().map(|r| r.1).collect();
    let name = crate::model::human_name(kpi);
    // Each limit the KPI was judged against, once (a plan may have moved
    // it between runs).
    let mut limits: Vec<(f64, String)> = Vec::new();
    for (op, threshold) in points.iter().filter_map(|p| p.limit.as_ref()) {
        if !limits.iter().any(|l| l.0 == *threshold) {
            limits.push((*threshold, format!("limit {op} {threshold}")));
        }
    }
    crate::report::charts::trend_svg(
        &format!("{name} over the runs"),
        ("firmware, oldest run first", name),
        &labels,
        &series,
        &limits,
    )
    .map_err(|e| crate::report::ReportError::from(e).into())
}
