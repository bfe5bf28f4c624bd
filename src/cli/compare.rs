//! `ledflicker compare A B`: two recorded runs side by side, through
//! [`crate::campaign::compare`]; prints the regressions first, then the
//! verdict flips, writes JUnit XML for a CI with `--junit`, and the
//! comparison report (HTML, and PDF with the `pdf` feature) with
//! `--report`.

use super::output::out;
use std::path::{Path, PathBuf};

use clap::Args;

use super::campaign::DbArg;
use super::{EXIT_FAIL, EXIT_PASS, Failure, UsageError};
use crate::campaign::compare::{ALPHA, Comparison, compare as compare_runs};
use crate::campaign::query::{self, Filter};
use crate::campaign::{CampaignError, Database};

/// `ledflicker compare` arguments.
#[derive(Args, Debug)]
pub(super) struct CompareArgs {
    /// The baseline: a run id (`ledflicker history`) or a recorded report
    /// directory; with --latest, by default the run recorded before B of
    /// the same plan and camera.
    a: Option<String>,
    /// The run compared with it (as A); with --latest, not given.
    b: Option<String>,
    /// B is the newest run of --camera, --firmware and --plan.
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
    /// Write the comparison as JUnit XML, one test case per case, failed
    /// where a KPI regressed.
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

/// Compares the runs; exit 1 when a KPI regressed beyond its noise.
pub(super) fn compare(a: CompareArgs) -> Result<i32, Failure> {
    let db = Database::open_existing(&a.db.location()?)?;
    let (id_a, id_b) = pick(&db, &a)?;
    let mut run_a = query::load_run(&db, id_a)?;
    run_a.repeats = query::repeat_spread(&db, &run_a.run, id_b)?;
    let run_b = query::load_run(&db, id_b)?;
    if run_a.run.plan_id != run_b.run.plan_id {
        eprintln!(
            "warning: run {id_a} is of plan `{}`, run {id_b} of plan `{}`: only cases of the same id are compared",
            run_a.run.plan_id, run_b.run.plan_id
        );
    }
    let date = match &a.report {
        Some(_) => Some(super::args::report_date(a.date.as_deref())?),
        None => None,
    };
    let c = compare_runs(&run_a, &run_b, ALPHA);
    out!("{}", text(&c))?;
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
    Ok(if c.regressed_cases().is_empty() {
        EXIT_PASS
    } else {
        EXIT_FAIL
    })
}

/// The run ids of A and B.
fn pick(db: &Database, a: &CompareArgs) -> Result<(i64, i64), Failure> {
    if !a.latest {
        let (Some(x), Some(y)) = (&a.a, &a.b) else {
            return Err(UsageError(
                "compare needs two runs A and B, or --latest\n    hint: `ledflicker history` lists the runs".to_string(),
            )
            .into());
        };
        return Ok((resolve(db, x)?, resolve(db, y)?));
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
    let base = match &a.a {
        Some(x) => resolve(db, x)?,
        None => {
            let same = Filter {
                camera: Some(b.model.clone()),
                plan: Some(b.plan_id.clone()),
                ..Filter::default()
            };
            query::history(db, &same)?
                .iter()
                .rev()
                .find(|r| r.id < b.id)
                .map(|r| r.id)
                .ok_or_else(|| {
                    CampaignError::Input(format!(
                        "--latest: run {} has no earlier run of plan `{}` and camera `{}` to compare with\n    hint: give the baseline A",
                        b.id, b.plan_id, b.model
                    ))
                })?
        }
    };
    Ok((base, b.id))
}

/// A run id, or the newest run recorded of a report directory.
fn resolve(db: &Database, spec: &str) -> Result<i64, Failure> {
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

/// The comparison as text: header, regressions, flips, verdict.
fn text(c: &Comparison) -> String {
    let mut s = format!(
        "A: run {} ({} {} firmware {}, {})\nB: run {} ({} {} firmware {}, {})\n",
        c.a.id,
        c.a.plan_id,
        c.a.model,
        c.a.firmware,
        c.a.date,
        c.b.id,
        c.b.plan_id,
        c.b.model,
        c.b.firmware,
        c.b.date
    );
    s.push_str(&format!(
        "{} KPIs compared, {} gated by a check; gate: a change towards worse beyond {:.2} standard deviations of its noise, or a metric's pooled change beyond {:.2} (false-alarm rate at most {:.0} % per comparison)\n",
        c.kpis.len(),
        c.gated(),
        c.k,
        c.k_pooled,
        ALPHA * 100.0
    ));
    if c.from_repeats.0 > 0 {
        s.push_str(&format!(
            "noise of {} KPIs from their spread over up to {} repeated runs of A's plan, camera, serial and firmware\n",
            c.from_repeats.0, c.from_repeats.1
        ));
    }
    for (metric, score, n) in &c.pooled {
        let verdict = if *score > c.k_pooled {
            "REGRESSED"
        } else {
            "within noise"
        };
        s.push_str(&format!(
            "{metric} over {n} cases: pooled change towards worse {score:.2} sd (gate {:.2}): {verdict}\n",
            c.k_pooled
        ));
    }
    let regressed: Vec<_> = c.kpis.iter().filter(|k| k.regressed).collect();
    if !regressed.is_empty() {
        s.push_str("REGRESSED:\n");
        for k in regressed {
            s.push_str(&format!(
                "  {} {} {}: {} -> {} (change {}, noise sd {}{})\n",
                k.case,
                k.roi,
                k.metric,
                value(k.a),
                value(k.b),
                value(k.delta()),
                value(k.sigma),
                k.z().map_or(String::new(), |z| format!(", {z:.1} sd"))
            ));
        }
    }
    for f in &c.flips {
        s.push_str(&format!(
            "verdict flip: {} {} -> {}\n",
            f.case, f.from, f.to
        ));
    }
    for u in &c.unmatched {
        s.push_str(&format!("only in one run: {u}\n"));
    }
    let cases = c.regressed_cases();
    if cases.is_empty() {
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

/// JUnit XML: one suite, one test case per case compared, failed with its
/// regressed KPIs.
fn junit(c: &Comparison) -> Result<String, quick_junit::SerializeError> {
    use quick_junit::{NonSuccessKind, Report, TestCase, TestCaseStatus, TestSuite};
    let mut suite = TestSuite::new(format!("ledflicker compare {} {}", c.a.id, c.b.id));
    let mut order: Vec<&str> = Vec::new();
    for k in &c.kpis {
        if order.last() != Some(&k.case.as_str()) {
            order.push(&k.case);
        }
    }
    for case in order {
        let bad: Vec<String> = c
            .kpis
            .iter()
            .filter(|k| k.case == case && k.regressed)
            .map(|k| {
                format!(
                    "{} {}: {} -> {} (noise sd {})",
                    k.roi,
                    k.metric,
                    value(k.a),
                    value(k.b),
                    value(k.sigma)
                )
            })
            .collect();
        let status = if bad.is_empty() {
            TestCaseStatus::success()
        } else {
            let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
            s.set_message(format!("regressed: {}", bad.join("; ")));
            s
        };
        suite.add_test_case(TestCase::new(case, status));
    }
    let mut report = Report::new("ledflicker compare");
    report.add_test_suite(suite);
    report.to_string()
}
