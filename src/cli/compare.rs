//! `ledflicker compare A B`: two recorded runs side by side, through
//! [`crate::campaign::compare`]; prints the regressions first, then the
//! verdict flips, writes JUnit XML for a CI with `--junit`, and the
//! comparison report (HTML, and PDF with the `pdf` feature) with
//! `--report`.

use super::output::out;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use clap::Args;

use super::campaign::DbArg;
use super::{ExitCode, Failure, UsageError};
use crate::campaign::compare::{
    Comparability, Comparison, GateOptions, PoolMethod, compare as compare_runs,
};
use crate::campaign::query::{self, Filter, RunRow};
use crate::campaign::{CampaignError, Database};
use crate::report::export::ComparisonJunit;

/// `ledflicker compare` arguments.
#[derive(Args, Debug)]
pub(super) struct CompareArgs {
    /// The baseline: a run id (`ledflicker history`) or a recorded report
    /// directory; with --latest, by default the newest run of the
    /// firmware recorded before B's on the same camera and plan.
    a: Option<String>,
    /// The run compared with it (as A); with --latest, not given.
    b: Option<String>,
    /// B is the newest run of --camera, --firmware and --plan; A is the
    /// newest run of the previous firmware (or --baseline-firmware) on
    /// B's camera and plan.
    #[arg(long)]
    latest: bool,
    /// With --latest: the camera (`[dut] model`).
    #[arg(long, requires = "latest")]
    camera: Option<String>,
    /// With --latest: the firmware.
    #[arg(long, requires = "latest")]
    firmware: Option<String>,
    /// With --latest: the plan id.
    #[arg(long, requires = "latest")]
    plan: Option<String>,
    /// With --latest: the baseline is the newest run of this firmware
    /// (instead of the firmware recorded before B's).
    #[arg(long, requires = "latest", value_name = "FIRMWARE")]
    baseline_firmware: Option<String>,
    /// Compare runs whose tests differ (a limit, the grid, the sequence,
    /// an ROI, ...): the differences are listed, and verdict flips caused
    /// by a changed limit are named as such. Without it such runs are not
    /// comparable (exit 5).
    #[arg(long)]
    accept_changes: bool,
    /// The smallest change towards worse of a metric that can be a
    /// regression, in its units, e.g. `percent_flicker=0.5`; repeatable
    /// [default: 1 % of the KPI's limit].
    #[arg(long, value_name = "METRIC=VALUE")]
    min_change: Vec<String>,
    /// Write the comparison as JUnit XML, one test case per case, failed
    /// where a KPI regressed, and a test case `set-up`, failed when the
    /// runs are not comparable.
    #[arg(long, value_name = "FILE")]
    junit: Option<PathBuf>,
    /// Write the comparison report into DIR: comparison.html, comparison.pdf
    /// and junit.xml. DIR is new, empty, or a comparison report written
    /// before (replaced whole); never a run's report directory.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Date the comparison report carries, YYYY-MM-DD [default:
    /// $SOURCE_DATE_EPOCH, else today].
    #[arg(long, requires = "report")]
    date: Option<String>,
    #[command(flatten)]
    db: DbArg,
}

/// Compares the runs; exit 1 when a KPI regressed beyond its noise, 5 when
/// the runs are not comparable.
pub(super) fn compare(a: CompareArgs) -> Result<ExitCode, Failure> {
    let opts = GateOptions {
        min_change: min_changes(&a.min_change)?,
        accept_changes: a.accept_changes,
        ..GateOptions::default()
    };
    let db = Database::open_existing(&a.db.location()?)?;
    let (id_a, id_b, why) = pick(&db, &a)?;
    let run_a = query::load_run(&db, id_a)?;
    let run_b = query::load_run(&db, id_b)?;
    let repeats = query::repeats(&db, &run_a.run, &run_b.run)?;
    let date = match &a.report {
        Some(_) => Some(super::args::report_date(a.date.as_deref())?),
        None => None,
    };
    let c = compare_runs(&run_a, &run_b, &repeats, &opts);
    out!("{}", text(&c, &why))?;
    let xml = junit(&c).map_err(|e| Failure::Internal(format!("junit.xml: {e}")))?;
    if let Some(path) = &a.junit {
        std::fs::write(path, &xml)
            .map_err(|e| UsageError(format!("cannot write `{}`: {e}", path.display())))?;
    }
    if let (Some(dir), Some(date)) = (&a.report, date) {
        let view = crate::campaign::view::view(&c, &run_b, &date);
        let written = super::compare_report::write(dir, &view, &xml)?;
        eprintln!(
            "comparison report: {} in `{}`",
            written.join(", "),
            dir.display()
        );
    }
    Ok(if !c.is_comparable() {
        ExitCode::NotComparable
    } else if c.regressed_cases().is_empty() {
        ExitCode::Pass
    } else {
        ExitCode::Fail
    })
}

/// `--min-change METRIC=VALUE`s: a finite value >= 0 per metric.
fn min_changes(given: &[String]) -> Result<BTreeMap<String, f64>, Failure> {
    let mut out = BTreeMap::new();
    for g in given {
        let parsed = g
            .split_once('=')
            .and_then(|(m, v)| Some((m.trim(), v.trim().parse::<f64>().ok()?)))
            .filter(|(m, v)| !m.is_empty() && v.is_finite() && *v >= 0.0);
        let Some((metric, value)) = parsed else {
            return Err(UsageError(format!(
                "--min-change `{g}`: expected METRIC=VALUE with a value >= 0, e.g. percent_flicker=0.5"
            ))
            .into());
        };
        out.insert(metric.to_string(), value);
    }
    Ok(out)
}

/// The run ids of A and B, and why they were picked (with --latest).
fn pick(db: &Database, a: &CompareArgs) -> Result<(i64, i64, Vec<String>), Failure> {
    if !a.latest {
        let (Some(x), Some(y)) = (&a.a, &a.b) else {
            return Err(UsageError(
                "compare needs two runs A and B, or --latest\n    hint: `ledflicker history` lists the runs".to_string(),
            )
            .into());
        };
        return Ok((resolve(db, x)?, resolve(db, y)?, Vec::new()));
    }
    if a.b.is_some() {
        return Err(UsageError("with --latest, give at most the baseline A".to_string()).into());
    }
    let filter = Filter {
        camera: a.camera.clone(),
        firmware: a.firmware.clone(),
        plan: a.plan.clone(),
        ..Filter::default()
    };
    let runs = query::history(db, &filter)?;
    let b = runs.last().ok_or_else(|| {
        CampaignError::Input("--latest: no run matches --camera, --firmware and --plan\n    hint: `ledflicker history` lists the runs".to_string())
    })?;
    let mut why = vec![format!(
        "B: run {}, the newest run of{}",
        b.id,
        describe(&filter)
    )];
    let base = match &a.a {
        Some(x) => {
            let id = resolve(db, x)?;
            why.push(format!("A: run {id}, as given"));
            id
        }
        None => {
            let (id, reason) = baseline(db, b, a.baseline_firmware.as_deref())?;
            why.push(format!("A: run {id}, {reason}"));
            id
        }
    };
    Ok((base, b.id, why))
}

fn describe(f: &Filter) -> String {
    let mut s = String::new();
    for (what, v) in [
        ("camera", &f.camera),
        ("firmware", &f.firmware),
        ("plan", &f.plan),
    ] {
        if let Some(v) = v {
            s.push_str(&format!(" {what} `{v}`"));
        }
    }
    if s.is_empty() {
        s.push_str(" any camera, firmware and plan");
    }
    s
}

/// The baseline of B under --latest: the newest run, on B's camera and
/// plan, of `firmware`, or else of the firmware first recorded before
/// B's firmware was (the previous firmware, in recorded order).
fn baseline(db: &Database, b: &RunRow, firmware: Option<&str>) -> Result<(i64, String), Failure> {
    let same = Filter {
        camera: Some(b.model.clone()),
        plan: Some(b.plan_id.clone()),
        ..Filter::default()
    };
    let runs = query::history(db, &same)?;
    let (firmware, reason) = match firmware {
        Some(f) => (f.to_string(), "as --baseline-firmware".to_string()),
        None => {
            // Each firmware with the id of its first run, in that order.
            let mut first: Vec<(&str, i64)> = Vec::new();
            for r in &runs {
                if !first.iter().any(|(f, _)| *f == r.firmware) {
                    first.push((&r.firmware, r.id));
                }
            }
            let at = first
                .iter()
                .position(|(f, _)| *f == b.firmware)
                .unwrap_or(0);
            let Some((previous, _)) = at.checked_sub(1).map(|i| first[i]) else {
                return Err(CampaignError::Input(format!(
                    "--latest: firmware `{}` is the first recorded on camera `{}` and plan `{}`: there is no earlier firmware to compare with\n    hint: give the baseline A, or --baseline-firmware",
                    b.firmware, b.model, b.plan_id
                ))
                .into());
            };
            (
                previous.to_string(),
                format!("the firmware recorded before `{}`", b.firmware),
            )
        }
    };
    let of = |r: &&RunRow| r.firmware == firmware && r.id != b.id;
    // The newest recorded before B; else the newest at all.
    let pick = runs
        .iter()
        .rev()
        .filter(of)
        .find(|r| r.id < b.id)
        .or_else(|| runs.iter().rev().find(of))
        .ok_or_else(|| {
            CampaignError::Input(format!(
                "--latest: no run of firmware `{firmware}` on camera `{}` and plan `{}`\n    hint: `ledflicker history --camera ... --plan ...` lists the firmwares recorded",
                b.model, b.plan_id
            ))
        })?;
    Ok((
        pick.id,
        format!("the newest run of firmware `{firmware}` ({reason}) on the same camera and plan"),
    ))
}

/// A run id, or the newest run recorded of a report directory.
/// A run id, or the id of the recorded report directory `spec`.
pub fn resolve(db: &Database, spec: &str) -> Result<i64, Failure> {
    if let Ok(id) = spec.parse::<i64>() {
        return Ok(id);
    }
    let dir = Path::new(spec);
    if !dir.is_dir() {
        return Err(UsageError(format!(
            "`{spec}` is neither a run id nor a report directory\n    hint: `ledflicker history` lists the runs"
        ))
        .into());
    }
    query::run_of_dir(db, dir)?.ok_or_else(|| {
        UsageError(format!(
            "the report directory `{spec}` is not recorded in `{}`\n    hint: record it with `ledflicker import {spec}`",
            db.path().display()
        ))
        .into()
    })
}

fn value(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.4}"))
}

/// A run in one line: plan, camera, firmware, what was run, date.
fn run_line(side: &str, r: &RunRow) -> String {
    let as_run = r
        .setup
        .as_ref()
        .and_then(|s| s.device_label())
        .map_or(String::new(), |l| format!("; as run: {l}"));
    format!(
        "{side}: run {} ({} {} firmware {}{as_run}, {})\n",
        r.id, r.plan_id, r.model, r.firmware, r.date
    )
}

/// The comparison as text: the runs, what differs, the gate, then the
/// regressions, flips and verdict.
/// What `compare` prints: the runs, then the regressions with the reasons
/// behind them, then the verdict flips.
pub fn text(c: &Comparison, why: &[String]) -> String {
    let mut s = run_line("A", &c.a) + &run_line("B", &c.b);
    for w in why {
        s.push_str(&format!("picked {w}\n"));
    }
    if c.differences.is_empty() {
        if c.a.setup.is_some() && c.b.setup.is_some() {
            s.push_str("set-up: the same test, device and inputs\n");
        }
    } else {
        s.push_str("set-up differences (A -> B):\n");
        for d in &c.differences {
            s.push_str(&format!("  {d}\n"));
        }
    }
    if c.comparability == Comparability::Accepted {
        s.push_str("the tests differ; compared as --accept-changes asks\n");
    }
    if c.gated() == 0 {
        s.push_str(&format!(
            "{} KPIs compared, none gated by a check\n",
            c.kpis.len()
        ));
    } else {
        s.push_str(&format!(
        "{} KPIs compared, {} gated by a check; gate: a change towards worse beyond its floor and beyond {} standard deviations of its run-to-run noise, or a metric's pooled change beyond its gate (false-alarm rate at most {:.0} % per comparison)\n",
        c.kpis.len(),
        c.gated(),
        c.gate_words(),
        crate::campaign::compare::ALPHA * 100.0
    ));
    }
    s.push_str(&noise_line(c));
    for p in &c.pooled {
        let verdict = if p.regressed {
            "REGRESSED"
        } else {
            "within noise"
        };
        let how = match p.method {
            PoolMethod::RunSums(df) => format!("per-run sums over repeats, {df} df"),
            PoolMethod::MeanZ => "mean of the cases' changes".to_string(),
        };
        s.push_str(&format!(
            "{} over {} cases: pooled change towards worse {:.2} sd (gate {:.2}, {how}): {verdict}\n",
            p.metric, p.n, p.score, p.gate
        ));
    }
    let regressed: Vec<_> = c.kpis.iter().filter(|k| k.regressed).collect();
    if !regressed.is_empty() {
        s.push_str("REGRESSED:\n");
        for k in regressed {
            s.push_str(&format!(
                "  {} {} {}: {} -> {} (change {}, noise sd {}{}{})\n",
                k.case,
                k.roi,
                k.metric,
                value(k.a),
                value(k.b),
                value(k.delta()),
                value(k.sigma),
                k.z().map_or(String::new(), |z| format!(", {z:.1} sd")),
                if k.by_pool {
                    "; named with its metric's pooled change"
                } else {
                    ""
                }
            ));
        }
    }
    for f in &c.flips {
        s.push_str(&format!(
            "verdict flip: {} {} -> {} ({})\n",
            f.case,
            f.from,
            f.to,
            f.cause.describe()
        ));
    }
    for u in &c.unmatched {
        s.push_str(&format!("only in one run: {u}\n"));
    }
    let cases = c.regressed_cases();
    if let Comparability::Not { why, hint } = &c.comparability {
        s.push_str(&format!("NOT COMPARABLE: {why}\n    hint: {hint}\n"));
    } else if cases.is_empty() {
        s.push_str("no regression\n");
    } else {
        s.push_str(&format!(
            "REGRESSION in {} case(s): {}\n",
            cases.len(),
            cases.join(", ")
        ));
    }
    s
}

/// Where the gate's noise came from, in one line.
fn noise_line(c: &Comparison) -> String {
    let n = c.noise_counts();
    let (repeats, trace, noiseless, unknown) = (n.repeats, n.trace, n.noiseless, n.unknown);
    let mut parts = Vec::new();
    if repeats > 0 {
        let (runs, df) = c.repeats_in_words();
        parts.push(format!(
            "{repeats} from the spread over repeated runs ({runs}; {df} degrees of freedom, Student's t)"
        ));
    }
    if trace > 0 {
        let why = if c.repeats.0 + c.repeats.1 == 0 {
            "no repeated runs in the database".to_string()
        } else {
            format!(
                "the database's {} other runs of these tests give fewer than the {} degrees of freedom the spread needs",
                c.repeats.0 + c.repeats.1,
                crate::campaign::compare::MIN_REPEAT_DF
            )
        };
        parts.push(format!(
            "{trace} from the runs' traces times {} ({why})",
            crate::campaign::compare::TRACE_INFLATION
        ));
    }
    if noiseless > 0 {
        parts.push(format!(
            "{noiseless} noiseless (sigma 0: every change beyond its floor counts)"
        ));
    }
    if unknown > 0 {
        parts.push(format!(
            "{unknown} unknown (a trace was unreadable): any change beyond the floor counts"
        ));
    }
    if parts.is_empty() {
        return String::new();
    }
    format!("noise of the gated KPIs: {}\n", parts.join("; "))
}

/// JUnit XML (`report::export::comparison_junit_xml`): one test case per
/// case compared, failed with its regressed KPIs.
fn junit(c: &Comparison) -> Result<String, quick_junit::SerializeError> {
    let mut order: Vec<&str> = Vec::new();
    for k in &c.kpis {
        if order.last() != Some(&k.case.as_str()) {
            order.push(&k.case);
        }
    }
    let cases = order
        .into_iter()
        .map(|case| {
            let bad: Vec<String> = c
                .kpis
                .iter()
                .filter(|k| k.case == case && k.regressed)
                .map(|k| {
                    format!(
                        "{} {}: {} -> {} (noise sd {}{})",
                        k.roi,
                        k.metric,
                        value(k.a),
                        value(k.b),
                        value(k.sigma),
                        if k.by_pool {
                            "; named with its metric's pooled change"
                        } else {
                            ""
                        }
                    )
                })
                .collect();
            (case.to_string(), bad)
        })
        .collect();
    crate::report::export::comparison_junit_xml(&ComparisonJunit {
        suite: format!("ledflicker compare {} {}", c.a.id, c.b.id),
        differences: c.differences.iter().map(ToString::to_string).collect(),
        not_comparable: match &c.comparability {
            Comparability::Not { why, .. } => Some(why.clone()),
            _ => None,
        },
        cases,
    })
}
