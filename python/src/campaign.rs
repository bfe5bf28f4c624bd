//! The results database from Python: `history` (the runs as
//! `ledflicker history --json` lists them) and `compare` (the gate's
//! decisions on two recorded runs, with the reasons `ledflicker compare`
//! prints).

use std::collections::BTreeMap;
use std::path::PathBuf;

use ledflicker::campaign::compare::{Comparability, Comparison, GateOptions, Source, compare};
use ledflicker::campaign::query::{self, Filter};
use ledflicker::campaign::{self, Database, Location};
use ledflicker::cli::{ExitCode, Failure};
use ledflicker::error::UsageError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::errors;

/// The database at `db` (a file or a `postgres://` URL), or, for None,
/// the one the command line reads without `--db` ($LEDFLICKER_DB, else
/// the data directory's); it must exist.
fn open(db: Option<&std::path::Path>) -> Result<Database, Failure> {
    match campaign::locate(db, false, &|k| std::env::var(k).ok()) {
        Some(Location::Off) | None => Err(UsageError(
            "no results database: HOME, XDG_DATA_HOME and LEDFLICKER_DB are unset\n    hint: pass db=PATH".into(),
        )
        .into()),
        Some(at) => Ok(Database::open_existing(&at)?),
    }
}

/// The runs the filters select, oldest first, as JSON text (the array of
/// `ledflicker history --json`).
#[pyfunction]
#[pyo3(signature = (db, camera=None, serial=None, firmware=None, plan=None, since=None, until=None, verdict=None))]
#[allow(clippy::too_many_arguments)]
pub fn history_json(
    py: Python<'_>,
    db: Option<PathBuf>,
    camera: Option<String>,
    serial: Option<String>,
    firmware: Option<String>,
    plan: Option<String>,
    since: Option<String>,
    until: Option<String>,
    verdict: Option<String>,
) -> PyResult<String> {
    let filter = Filter {
        camera,
        serial,
        firmware,
        plan,
        since,
        until,
        verdict,
    };
    let listed = py.detach(|| -> Result<String, Failure> {
        for (name, d) in [("since", &filter.since), ("until", &filter.until)] {
            if let Some(d) = d
                .as_deref()
                .filter(|d| !ledflicker::util::is_calendar_date(d))
            {
                return Err(UsageError(format!(
                    "{name} `{d}` is not a date YYYY-MM-DD (e.g. 2026-11-23)"
                ))
                .into());
            }
        }
        if let Some(v) = filter
            .verdict
            .as_deref()
            .filter(|v| !["pass", "fail", "info"].contains(v))
        {
            return Err(
                UsageError(format!("verdict `{v}` is not `pass`, `fail` or `info`")).into(),
            );
        }
        let runs = query::history(&open(db.as_deref())?, &filter)?;
        Ok(serde_json::to_string(&runs)?)
    });
    listed.map_err(|f| errors::to_py(py, f))
}

/// Compares the recorded runs `a` and `b` (run ids or recorded report
/// directories) with the noise-aware gate: a dict of the runs (as
/// `history` lists them), whether they are comparable (and why not),
/// every KPI with its change, sigma, gate and decision, the regressed
/// cases, and `text`, what `ledflicker compare` prints.
#[pyfunction]
#[pyo3(signature = (db, a, b, accept_changes=false, min_change=None))]
pub fn compare_runs<'py>(
    py: Python<'py>,
    db: Option<PathBuf>,
    a: String,
    b: String,
    accept_changes: bool,
    min_change: Option<BTreeMap<String, f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let min_change = min_change.unwrap_or_default();
    if let Some((m, v)) = min_change
        .iter()
        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
    {
        return Err(errors::usage(
            py,
            format!("min_change {m}={v}: the value must be >= 0"),
        ));
    }
    let opts = GateOptions {
        min_change,
        accept_changes,
        ..GateOptions::default()
    };
    let compared = py.detach(|| -> Result<(Comparison, String, String), Failure> {
        let db = open(db.as_deref())?;
        let (id_a, id_b) = (
            ledflicker::cli::compare::resolve(&db, &a)?,
            ledflicker::cli::compare::resolve(&db, &b)?,
        );
        let run_a = query::load_run(&db, id_a)?;
        let run_b = query::load_run(&db, id_b)?;
        let repeats = query::repeats(&db, &run_a.run, &run_b.run)?;
        let c = compare(&run_a, &run_b, &repeats, &opts);
        let runs = serde_json::to_string(&[&c.a, &c.b])?;
        let text = ledflicker::cli::compare::text(&c, &[]);
        Ok((c, runs, text))
    });
    let (c, runs, text) = compared.map_err(|f| errors::to_py(py, f))?;
    comparison_dict(py, &c, runs, text)
}

fn comparison_dict<'py>(
    py: Python<'py>,
    c: &Comparison,
    runs: String,
    text: String,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("runs_json", runs)?;
    d.set_item("comparable", c.is_comparable())?;
    let (why, hint) = match &c.comparability {
        Comparability::Not { why, hint } => (Some(why.clone()), Some(hint.clone())),
        _ => (None, None),
    };
    d.set_item("why", why)?;
    d.set_item("hint", hint)?;
    d.set_item("regressed_cases", c.regressed_cases())?;
    d.set_item("unmatched", &c.unmatched)?;
    let kpis = PyList::empty(py);
    for k in &c.kpis {
        let row = PyDict::new(py);
        row.set_item("case", &k.case)?;
        row.set_item("roi", &k.roi)?;
        row.set_item("metric", &k.metric)?;
        row.set_item("a", k.a)?;
        row.set_item("b", k.b)?;
        row.set_item("delta", k.delta())?;
        row.set_item("sigma", k.sigma)?;
        row.set_item("z", k.z())?;
        row.set_item("gate", k.k)?;
        row.set_item("floor", k.floor)?;
        let source = match k.source {
            Source::Repeats(..) => "repeats",
            Source::Trace => "trace",
            Source::Unknown => "unknown",
        };
        row.set_item("sigma_from", source)?;
        row.set_item("gated", k.worse != 0)?;
        row.set_item("regressed", k.regressed)?;
        row.set_item("by_pool", k.by_pool)?;
        kpis.append(row)?;
    }
    d.set_item("kpis", kpis)?;
    let code = if !c.is_comparable() {
        ExitCode::NotComparable
    } else if c.regressed_cases().is_empty() {
        ExitCode::Pass
    } else {
        ExitCode::Fail
    };
    d.set_item("exit_code", code.code())?;
    d.set_item("text", text)?;
    Ok(d)
}
