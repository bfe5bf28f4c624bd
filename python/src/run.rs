//! `run_plan` and `read_report`: a plan run into a report directory through
//! the library's one run path ([`pipeline::run_plan`], which the command
//! line's `plan` calls too), and a report directory read back.
//!
//! The engine works on a thread of its own without the GIL; the caller's
//! thread waits for its progress, hands it to the Python callback, and
//! looks for Ctrl-C (Python's own SIGINT handler, [`Python::check_signals`])
//! every [`POLL`]. Ctrl-C asks the engine to stop as the command line's
//! handler would ([`interrupt::request`]); the engine stops between cases
//! and leaves the old report as it was, then `KeyboardInterrupt` is raised.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

use ledflicker::campaign::record::{Provenance, Signature, Source};
use ledflicker::campaign::{self, Database, Location};
use ledflicker::cli::{
    ExitCode, Failure, LimitArgs, check_database_outside, collect_inputs, report_date,
};
use ledflicker::error::UsageError;
use ledflicker::interrupt;
use ledflicker::model::Detail;
use ledflicker::pipeline::{self, PlanRun, PlanRunError, Progress, ReportOptions, RunProgress};
use ledflicker::plan::PlanError;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use crate::errors;

/// How often the waiting thread looks for Ctrl-C and progress.
const POLL: Duration = Duration::from_millis(50);

/// What the engine tells the waiting thread.
enum Event {
    Run(RunProgress),
    Report(Progress),
}

/// A run as asked for from Python.
struct Request {
    plan: String,
    out: Option<PathBuf>,
    threads: Option<usize>,
    date: Option<String>,
    force: bool,
    detail: Detail,
    db: Record,
}

/// Where a run is recorded: `db=None` (or False) nowhere, `db=True` where
/// `ledflicker plan` records it, `db=PATH` in that database.
enum Record {
    Nowhere,
    Default,
    At(PathBuf),
}

impl Record {
    /// The database, found as the command line finds it: `At` as `--db`,
    /// `Default` as `plan` without `--db` ($LEDFLICKER_DB, else the data
    /// directory's). Asked for and not found is an error before the run.
    fn locate(&self) -> Result<Option<Location>, Failure> {
        let env = |k: &str| std::env::var(k).ok();
        match self {
            Record::Nowhere => Ok(None),
            Record::At(db) => Ok(campaign::locate(Some(db), false, &env)),
            Record::Default => match campaign::locate(None, false, &env) {
                Some(at) => Ok(Some(at)),
                None => Err(UsageError(
                    "no results database: HOME, XDG_DATA_HOME and LEDFLICKER_DB are unset\n    hint: pass db=PATH".into(),
                )
                .into()),
            },
        }
    }
}

/// A finished run, as handed to Python.
struct Done {
    results_json: String,
    dir: PathBuf,
    status: &'static str,
    exit_code: i32,
    warnings: String,
    run_id: Option<i64>,
}

/// A plan given as TOML text is written to a file of its own, which the
/// run reads (and hashes) as it would a plan file; the folder lives as
/// long as the run.
fn plan_source(plan: &str) -> Result<(Option<tempfile::TempDir>, String), Failure> {
    if !plan.contains('\n') {
        return Ok((None, plan.to_string()));
    }
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("plan.toml");
    std::fs::write(&path, plan)?;
    Ok((Some(dir), path.display().to_string()))
}

/// What the errors of a plan given as TOML text call it: the file it was
/// written to is the package's own, and means nothing to the caller.
const PLAN_TEXT: &str = "<plan text>";

/// `e` naming the plan [`PLAN_TEXT`] rather than the file it was written to.
fn named_as_text(e: PlanError) -> PlanError {
    let path = PathBuf::from(PLAN_TEXT);
    match e {
        PlanError::Read { source, .. } => PlanError::Read { path, source },
        PlanError::Syntax { message, .. } => PlanError::Syntax { path, message },
        PlanError::Invalid { diagnostics, .. } => PlanError::Invalid { path, diagnostics },
        e @ PlanError::NotFound { .. } => e,
    }
}

fn detail(text: &str) -> Option<Detail> {
    match text {
        "summary" => Some(Detail::Summary),
        "standard" => Some(Detail::Standard),
        "full" => Some(Detail::Full),
        _ => None,
    }
}

/// The run itself, on the engine's thread: what `ledflicker plan` does,
/// without its terminal output.
fn execute(req: &Request, send: &(dyn Fn(Event) + Sync)) -> Result<Done, Failure> {
    let (text_dir, arg) = plan_source(&req.plan)?;
    let limits = LimitArgs::default().limits(matches!(req.detail, Detail::Full));
    let plan = match pipeline::load_plan(&arg, limits) {
        Ok(plan) => plan,
        Err(pipeline::LoadError::Plan(e)) if text_dir.is_some() => {
            return Err(Failure::Plan(named_as_text(e)));
        }
        Err(e) => return Err(e.into()),
    };
    let mut warnings = plan.warnings_text();
    let date = report_date(req.date.as_deref())?;
    if req.threads == Some(0) {
        return Err(UsageError("threads must be at least 1".into()).into());
    }
    let out = req
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports").join(&plan.id));
    // As `plan` refuses them, before any time goes into the run.
    let database = req.db.locate()?;
    if let Some(at) = &database {
        check_database_outside(at, &out)?;
    }
    let generation = pipeline::begin_output(&out, req.force)?;
    let backend = ledflicker::backend::for_plan(&plan, None)?;
    let inputs = collect_inputs(&plan)?;
    let run = PlanRun {
        plan: &plan,
        backend: &backend,
        inputs,
        threads: req.threads,
        resume: false,
        options: ReportOptions {
            date,
            force: req.force,
            detail: req.detail,
            signing: None,
            golden: None,
            resume_hint: None,
        },
        resume_hint: None,
    };
    let outcome = pipeline::run_plan(run, generation, &|p| send(Event::Run(p)), &|p| {
        send(Event::Report(p))
    })
    .map_err(|e| match e {
        PlanRunError::Stopped(run) => Failure::from(run.stopped.error),
        PlanRunError::Report(e) => Failure::from(e),
    })?;
    if let Some(w) = &outcome.warning {
        warnings.push_str(w);
        warnings.push('\n');
    }
    let run_id = match database {
        Some(at) => match record(&at, &outcome.model, &outcome.dir) {
            Ok(id) => Some(id),
            Err(e) => {
                warnings.push_str(&format!(
                    "the run was not recorded in the results database: {}\n",
                    e.message()
                ));
                None
            }
        },
        None => None,
    };
    let (status, exit_code) = match outcome.status() {
        pipeline::Status::Pass => ("pass", ExitCode::Pass),
        pipeline::Status::Fail => ("fail", ExitCode::Fail),
        pipeline::Status::NotJudged => ("not-judged", ExitCode::NotJudged),
    };
    // The file as written: results.json carries the report's own section
    // (date, detail, inputs) beside the model.
    let results_json = std::fs::read_to_string(outcome.dir.join("results.json"))?;
    Ok(Done {
        results_json,
        dir: outcome.dir,
        status,
        exit_code: exit_code.code(),
        warnings,
        run_id,
    })
}

/// Records a finished report in the database `at`, as `plan` does.
fn record(at: &Location, model: &ledflicker::model::Results, dir: &Path) -> Result<i64, Failure> {
    let mut database = Database::open(at)?;
    let provenance = Provenance {
        source: Source::Plan,
        signer: None,
        signature: Signature::Unsigned,
    };
    Ok(campaign::record::record(
        &mut database,
        model,
        dir,
        &provenance,
    )?)
}

/// Counts of the run, for the progress callback.
#[derive(Default)]
struct Counts {
    done: usize,
    total: usize,
}

/// One progress event as a dict: `stage` ("run" or "report"), `event`,
/// and the cases `done` of `total` (pictures drawn of planned while the
/// report is written).
fn event_dict<'py>(py: Python<'py>, e: Event, c: &mut Counts) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (stage, event) = match e {
        Event::Run(RunProgress::Resumed { kept, total }) => {
            (c.done, c.total) = (kept, total);
            ("run", "resumed")
        }
        Event::Run(RunProgress::Started { total, done }) => {
            (c.done, c.total) = (done, total);
            ("run", "started")
        }
        Event::Run(RunProgress::CaseFinished) => {
            c.done += 1;
            ("run", "case-finished")
        }
        Event::Run(RunProgress::Finished) => ("run", "finished"),
        Event::Report(Progress::Analysing { cases }) => {
            (c.done, c.total) = (0, cases);
            ("report", "analysing")
        }
        Event::Report(Progress::Writing) => ("report", "writing"),
        Event::Report(Progress::Pictures { drawn, planned }) => {
            (c.done, c.total) = (drawn, planned);
            ("report", "pictures")
        }
        Event::Report(Progress::Written) => ("report", "written"),
    };
    d.set_item("stage", stage)?;
    d.set_item("event", event)?;
    d.set_item("done", c.done)?;
    d.set_item("total", c.total)?;
    Ok(d)
}

/// Runs a plan into its report directory; see `ledflicker.run` in
/// python/ledflicker/__init__.py for the arguments.
#[pyfunction]
#[pyo3(signature = (plan, out=None, threads=None, date=None, db=None, force=false, detail="standard", progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn run_plan<'py>(
    py: Python<'py>,
    plan: String,
    out: Option<PathBuf>,
    threads: Option<i64>,
    date: Option<String>,
    db: Option<Bound<'py, PyAny>>,
    force: bool,
    detail: &str,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    // Taken as a signed number, so that a negative count is refused in the
    // command line's words rather than by Python's conversion.
    let threads = match threads.map(usize::try_from) {
        None => None,
        Some(Ok(n)) => Some(n),
        Some(Err(_)) => {
            return Err(errors::usage(py, "threads must be at least 1".to_string()));
        }
    };
    let db = match db {
        None => Record::Nowhere,
        Some(b) => match b.cast::<PyBool>() {
            Ok(flag) if flag.is_true() => Record::Default,
            Ok(_) => Record::Nowhere,
            Err(_) => Record::At(b.extract::<PathBuf>().map_err(|_| {
                PyTypeError::new_err(
                    "db: a path, a postgres:// URL, True (the command line's default database) or None",
                )
            })?),
        },
    };
    let Some(detail) = self::detail(detail) else {
        return Err(errors::usage(
            py,
            format!("detail `{detail}` is not one of `summary`, `standard`, `full`"),
        ));
    };
    let req = Request {
        plan,
        out,
        threads,
        date,
        force,
        detail,
        db,
    };
    interrupt::clear();
    let mut stop: Option<PyErr> = None;
    let (result, failed_callback) = wait(py, req, progress.as_ref(), &mut stop)?;
    // Ctrl-C (here, or in the callback as KeyboardInterrupt) or the
    // callback's own exception: raised, with what the engine said as it
    // stopped for its cause.
    if let Some(raised) = failed_callback.or(stop) {
        if let Err(f) = result {
            raised.set_cause(py, Some(errors::to_py(py, f)));
        }
        return Err(raised);
    }
    let done = result.map_err(|f| errors::to_py(py, f))?;
    let d = PyDict::new(py);
    d.set_item("results_json", done.results_json)?;
    d.set_item("dir", done.dir)?;
    d.set_item("status", done.status)?;
    d.set_item("exit_code", done.exit_code)?;
    d.set_item("warnings", done.warnings)?;
    d.set_item("run_id", done.run_id)?;
    Ok(d)
}

/// The engine on its thread, and this thread waiting for it: progress to
/// the callback, Ctrl-C (into `stop`) to the engine. Gives the engine's
/// result and the callback's exception, if it raised one (which stops
/// the run too).
fn wait(
    py: Python<'_>,
    req: Request,
    progress: Option<&Bound<'_, PyAny>>,
    stop: &mut Option<PyErr>,
) -> PyResult<(Result<Done, Failure>, Option<PyErr>)> {
    let (tx, mut rx) = mpsc::channel::<Event>();
    let mut counts = Counts::default();
    let mut failed: Option<PyErr> = None;
    let joined = std::thread::scope(|s| {
        let worker = s.spawn(move || {
            let send = move |e: Event| {
                // The waiting thread is gone only when this run is over.
                let _ = tx.send(e);
            };
            execute(&req, &send)
        });
        loop {
            let (back, got) = py.detach(move || {
                let got = rx.recv_timeout(POLL);
                (rx, got)
            });
            rx = back;
            match got {
                Ok(event) => {
                    if let (Some(cb), None) = (progress, &failed) {
                        let called = event_dict(py, event, &mut counts)
                            .and_then(|d| cb.call1((d,)).map(drop));
                        if let Err(e) = called {
                            interrupt::request(libc::SIGINT);
                            failed = Some(e);
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if stop.is_none()
                && let Err(e) = py.check_signals()
            {
                interrupt::request(libc::SIGINT);
                *stop = Some(e);
            }
        }
        worker.join()
    });
    let result = joined.unwrap_or_else(|_| {
        Err(Failure::Internal(
            "the engine's thread panicked; no new report was written".into(),
        ))
    });
    Ok((result, failed))
}

/// Reads a report directory: its results.json, checked as `import` checks
/// it (the verdicts must follow from the values and limits), and, when
/// the report is signed, its files and signature as `verify` checks them.
/// Gives the results as JSON text and the signature's state.
#[pyfunction]
pub fn read_report(py: Python<'_>, dir: PathBuf) -> PyResult<(String, &'static str)> {
    let read = py.detach(|| read_checked(&dir));
    read.map_err(|f| errors::to_py(py, f))
}

fn read_checked(dir: &Path) -> Result<(String, &'static str), Failure> {
    let path = dir.join("results.json");
    let text = ledflicker::util::read_input_to_string(&path).map_err(|e| {
        UsageError(format!(
            "cannot read `{}`: {e}\n    hint: pass a report directory written by `ledflicker plan` or `merge`",
            path.display()
        ))
    })?;
    let results = ledflicker::model::read_results(&text)
        .map_err(|e| UsageError(format!("`{}`: {e}", path.display())))?;
    campaign::rejudge::refuse_edited(
        dir,
        &results,
        "",
        "read the report as ledflicker wrote it, or run the plan again",
    )?;
    let signature = signature(dir)?;
    Ok((text, signature))
}

use ledflicker::outdir::SIGNOFF_FILE as SIGNATURE_FILE;

/// `unsigned`, or `intact` when `verify` finds every file and signature
/// as signed; a broken one is an error.
#[cfg(feature = "signoff")]
fn signature(dir: &Path) -> Result<&'static str, Failure> {
    if !dir.join(SIGNATURE_FILE).is_file() {
        return Ok("unsigned");
    }
    let v = ledflicker::signoff::verify(dir, &[], None)?;
    if v.ok() {
        return Ok("intact");
    }
    Err(UsageError(format!(
        "`{}`: a hash or signature does not match what was signed\n    hint: `ledflicker verify {}` lists what changed",
        dir.display(),
        dir.display()
    ))
    .into())
}

/// A build without the sign-off cannot check a signed report, so it
/// reads none.
#[cfg(not(feature = "signoff"))]
fn signature(dir: &Path) -> Result<&'static str, Failure> {
    if !dir.join(SIGNATURE_FILE).is_file() {
        return Ok("unsigned");
    }
    Err(UsageError(format!(
        "`{}` is signed, and this build has no sign-off to verify it\n    hint: build the package with its default features",
        dir.display()
    ))
    .into())
}
