//! From a run's case results to a finished report directory: the analysis,
//! report and sign-off stages, written once for every command that makes a
//! report (`plan` after its run, `merge` after reading the shards back).
//!
//! ```text
//! load_plan ──▶ Plan                 (found, validated, captures probed)
//! begin_output ──▶ Generation        (refusals before any work)
//! run_cases ──▶ StoredCases         (the run stage; or shard::merge::gather)
//!   (run_plan: run_cases then report, for `plan` and the Python package)
//! report(Run, Generation, ReportOptions, on_progress)
//!   model::assemble ─▶ report::write_report ─▶ signoff::sign
//!   ─▶ Generation::commit ─▶ golden comparison ─▶ Outcome
//! ```
//!
//! Nothing here prints: progress goes to a callback, and the [`Outcome`]
//! holds what the command shows (summary, signature, drift, a warning) and
//! the [`Status`] it maps to an exit code. The same inputs give the same
//! bytes on disk whichever command calls, which is why a merged report is
//! byte for byte that of a single run.

mod plan_run;
mod run;

pub use plan_run::{PlanRun, PlanRunError, StoppedRun, run_plan};
pub use run::{RunCases, RunProgress, RunStageError, Stopped, run_cases, run_key};

use std::path::{Path, PathBuf};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

use ledflicker_core::interrupt::Interrupted;
use ledflicker_core::metrics::Verdict;
use ledflicker_core::model::{Detail, InputFile, Results};
use ledflicker_core::outdir::{Generation, OutDirError};
use ledflicker_core::plan::Plan;
use ledflicker_core::runner::CaseSource;
use ledflicker_report::golden::{Comparison, Tolerances};
use ledflicker_report::{self as report, ReportError, WriteOptions};
#[cfg(feature = "signoff")]
use ledflicker_signoff::SignoffError;

/// Why a plan could not be loaded ([`load_plan`]).
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// Not found, or invalid (every error located by line).
    #[error(transparent)]
    Plan(#[from] ledflicker_core::plan::PlanError),
    /// A signal stopped a capture's probe.
    #[error(transparent)]
    Interrupted(#[from] Interrupted),
    /// The light source's address in the environment is malformed.
    #[error(transparent)]
    Address(#[from] ledflicker_core::error::UsageError),
}

/// Finds and validates a plan (a file, or the name of a built-in one) for
/// `plan`, `validate` and `rig`: a captured plan's ROIs are checked
/// against each capture's frame size (read from its header), its work
/// estimate against `limits`, and the light source takes its address from
/// the environment when set. The plausibility warnings are the plan's
/// own (`Plan::warnings_text`), for the caller to print.
pub fn load_plan(
    arg: &str,
    limits: ledflicker_core::plan::ResourceLimits,
) -> Result<Plan, LoadError> {
    // With the handler installed, Ctrl-C during a probe stops its ffprobe
    // (in a process group of its own, which the terminal's signal does not
    // reach) rather than end ledflicker and leave ffprobe behind.
    ledflicker_core::interrupt::install();
    let mut plan = ledflicker_core::plan::find_and_load_with(
        arg,
        &ledflicker_core::capture::frame_size,
        limits,
    )?;
    ledflicker_core::interrupt::check()?;
    let address = std::env::var(ledflicker_core::plan::source::ADDRESS_ENV);
    if let (Some(source), Ok(address)) = (plan.source.as_mut(), address) {
        source
            .set_address(&address)
            .map_err(ledflicker_core::error::UsageError)?;
    }
    Ok(plan)
}

/// Why the report stage failed. Each variant names what was being done;
/// the command maps it to an exit code through its cause (`cli::Failure`).
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A signal stopped it; the old report is as it was.
    #[error(transparent)]
    Interrupted(#[from] Interrupted),
    /// The new generation could not replace the old report.
    #[error(transparent)]
    OutDir(#[from] OutDirError),
    /// The stored results of `--golden` could not be read.
    #[error("cannot read the golden results `{}`", path.display())]
    Golden {
        /// The file given.
        path: PathBuf,
        /// Why.
        #[source]
        source: ReportError,
    },
    /// The report's files could not be written.
    #[error("cannot write the report to `{}`", out.display())]
    Write {
        /// The output directory.
        out: PathBuf,
        /// Why.
        #[source]
        source: ReportError,
    },
    /// The new report could not be signed.
    #[cfg(feature = "signoff")]
    #[error("cannot sign `{}`", out.display())]
    Sign {
        /// The output directory.
        out: PathBuf,
        /// Why.
        #[source]
        source: SignoffError,
    },
}

/// How often [`Progress::Pictures`] is sent while the report is written.
const PICTURES_TICK: Duration = Duration::from_millis(100);

/// Refuses before any time is spent on the run (a signed report without
/// `force`, a directory ledflicker did not write, an unwritable place),
/// then starts the new generation of `out` and installs the signal
/// handler, so that Ctrl-C from here on leaves the old report as it was.
pub fn begin_output(out: &Path, force: bool) -> Result<Generation, OutDirError> {
    ledflicker_core::outdir::check_overwrite(out, force)?;
    let generation = Generation::begin(out)?;
    ledflicker_core::interrupt::install();
    Ok(generation)
}

/// [`begin_output`] for `plan --resume`: the new generation starts from
/// the staging directory the interrupted run left, with only its case
/// store kept.
pub fn resume_output(out: &Path, force: bool) -> Result<Generation, OutDirError> {
    ledflicker_core::outdir::check_overwrite(out, force)?;
    let generation = Generation::resume(
        out,
        &[
            crate::store::PARTIAL,
            crate::store::PARTIAL_WAL,
            crate::store::PARTIAL_SHM,
            // A run stopped in its report stage: its finished store.
            crate::store::FILE,
        ],
    )?;
    ledflicker_core::interrupt::install();
    Ok(generation)
}

/// A finished run: what the report is made from.
#[derive(Debug)]
pub struct Run<'a> {
    /// The plan the cases came from.
    pub plan: &'a Plan,
    /// The backend's id ([`ledflicker_core::backend::Backend::id`]), as results.json shows it.
    pub backend_id: &'a str,
    /// Every case's result, in case order, sample frames rendered: in
    /// memory, or read back from the run's case store.
    pub results: &'a dyn CaseSource,
    /// The run's input files, hashed ([`ledflicker_core::inputs::collect`]).
    pub inputs: Vec<InputFile>,
}

/// How the report is written.
pub struct ReportOptions {
    /// Report date, `YYYY-MM-DD`.
    pub date: String,
    /// Replace a signed report in the output directory.
    pub force: bool,
    /// How much of each case the report shows.
    pub detail: Detail,
    /// Sign the report before it replaces the old one.
    pub signing: Option<Signing>,
    /// Compare the model with stored results.
    pub golden: Option<Golden>,
    /// When set, a stop in this stage keeps the run's finished case store
    /// in the staging directory for `plan --resume` and prints this hint;
    /// otherwise the staging directory is removed.
    pub resume_hint: Option<String>,
}

/// Who signs the report, with what key, and when; the key was loaded and
/// checked before the run, so that a bad key fails before the work.
#[cfg(feature = "signoff")]
pub struct Signing {
    /// "Name, Role".
    pub signer: String,
    /// Key and certificate.
    pub key: ledflicker_signoff::SignerKey,
    /// Key files, which must lie outside the report directory.
    pub key_files: Vec<PathBuf>,
    /// Signing time in the signatures, Unix seconds.
    pub time_unix_s: u64,
}

/// A build without the `signoff` feature never signs: no value exists.
#[cfg(not(feature = "signoff"))]
pub enum Signing {}

/// Stored results to compare the run with, read before the run so that a
/// bad file fails before the work.
#[derive(Debug)]
pub struct Golden {
    results: Results,
    tolerances: Tolerances,
}

impl Golden {
    /// Reads the stored results.json at `path`.
    pub fn load(path: &Path, tolerances: Tolerances) -> Result<Golden, PipelineError> {
        let results = report::golden::load(path).map_err(|source| PipelineError::Golden {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(Golden {
            results,
            tolerances,
        })
    }
}

/// How far [`report`] has got, for a progress line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// The analysis stage (the results model) starts on this many cases.
    Analysing {
        /// Cases analysed.
        cases: usize,
    },
    /// The report's files are being written: charts, report.html, report.pdf.
    Writing,
    /// While writing, about every 100 ms: pictures drawn of those planned
    /// so far (`planned` grows while the writers find more to draw).
    Pictures {
        /// Pictures drawn.
        drawn: usize,
        /// Pictures planned.
        planned: usize,
    },
    /// Written (and signed): only the swap into the output directory is left.
    Written,
}

/// Who signed, for the command's message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SignedBy {
    /// "Name, Role", trimmed.
    pub signer: String,
    /// SHA-256 of the signer's certificate.
    pub fingerprint: String,
}

/// What the whole run comes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Every judged case passed, at least one was judged, and no drift.
    Pass,
    /// Some case failed, or the golden comparison found drift beyond tolerance.
    Fail,
    /// No case was judged (every case informational).
    NotJudged,
}

/// A report written into its output directory.
#[derive(Debug)]
pub struct Outcome {
    /// The results model the report shows (results.json).
    pub model: Results,
    /// The output directory now holding the report.
    pub dir: PathBuf,
    /// Cases in the report.
    pub cases: usize,
    /// The signature, when the report was signed.
    pub signed: Option<SignedBy>,
    /// The drift from the golden results, when compared.
    pub golden: Option<Comparison>,
    /// A warning for the user from the swap ([`ledflicker_core::outdir::Committed::warning`]).
    pub warning: Option<String>,
}

impl Outcome {
    /// The run's status: the plan's verdict, failed too by golden drift.
    pub fn status(&self) -> Status {
        let drift = self.golden.as_ref().is_some_and(|c| !c.ok());
        match self.model.verdict {
            Verdict::Fail => Status::Fail,
            _ if drift => Status::Fail,
            Verdict::Info => Status::NotJudged,
            Verdict::Pass => Status::Pass,
        }
    }
}

/// The analysis, report and sign-off stages of `run`: the results model,
/// every report file into `generation`, the signature, then the swap that
/// replaces the old report in one step (or, on an error or a stop, leaves
/// it as it was), and the golden comparison. `on_progress` is called from
/// this thread and from a ticker thread while the files are written.
pub fn report(
    run: Run<'_>,
    generation: Generation,
    mut options: ReportOptions,
    on_progress: &(dyn Fn(Progress) + Sync),
) -> Result<Outcome, PipelineError> {
    let hint = options.resume_hint.take();
    let cases = run.results.len();
    let written = write_stage(run, &generation, &mut options, hint.clone(), on_progress);
    let (model, signed) = match written {
        Ok(done) => done,
        Err(e) => {
            // A stop in this stage keeps the finished case store, so that
            // `--resume` goes straight to the report.
            if ledflicker_core::interrupt::requested().is_some()
                && let Some(hint) = hint
                && generation.path().join(crate::store::FILE).is_file()
            {
                ledflicker_core::interrupt::prune(generation.path(), crate::store::FILE);
                generation.keep_for_resume();
                eprintln!("{hint}");
            }
            return Err(e);
        }
    };
    let dir = generation.out().to_path_buf();
    let warning = generation.commit()?.warning();
    let golden = options
        .golden
        .map(|g| report::golden::compare(&g.results, &model, &g.tolerances));
    Ok(Outcome {
        model,
        dir,
        cases,
        signed,
        golden,
        warning,
    })
}

/// The report stage up to the swap: the model, the files, the signature.
fn write_stage(
    run: Run<'_>,
    generation: &Generation,
    options: &mut ReportOptions,
    hint: Option<String>,
    on_progress: &(dyn Fn(Progress) + Sync),
) -> Result<(Results, Option<SignedBy>), PipelineError> {
    // Ctrl-C acts within a fraction of a second in the analyses and the
    // PDF layout too, where no loop of ours looks at it.
    let keep = hint.map(|h| (crate::store::FILE, h));
    let prompt = ledflicker_core::interrupt::Prompt::start(generation.path().to_path_buf(), keep);
    on_progress(Progress::Analysing {
        cases: run.results.len(),
    });
    let t = ledflicker_core::timings::span("report model (analyses)");
    let mut model = ledflicker_core::model::assemble_from(
        run.plan,
        run.backend_id,
        run.results,
        options.detail,
    )
    .map_err(|e| PipelineError::Write {
        out: generation.out().to_path_buf(),
        source: e.into(),
    })?;
    ledflicker_core::model::listing::drop_undrawn(&mut model, options.detail);
    // The cases read back for the analyses are freed on the workers' threads.
    ledflicker_core::util::release_free_memory();
    drop(t);
    ledflicker_core::interrupt::check()?;
    let t = ledflicker_core::timings::span("write report");
    let write = WriteOptions {
        date: options.date.clone(),
        force: options.force,
        signatories: Vec::new(),
        inputs: run.inputs,
        detail: options.detail,
        reuse_from: generation.previous().map(Path::to_path_buf),
        profile: run.plan.report.clone(),
    };
    let model = write_files(generation, model, run.results, write, on_progress)?;
    drop(t);
    drop(prompt);
    // The marker goes in before the signature, so that the signature covers it.
    generation.write_marker()?;
    let signed = match options.signing.take() {
        Some(s) => Some(sign(generation, &options.date, s)?),
        None => None,
    };
    on_progress(Progress::Written);
    ledflicker_core::interrupt::check()?;
    Ok((model, signed))
}

/// The report's files into the new generation, with [`Progress::Pictures`]
/// ticks meanwhile: the PDF layout is most of this stage, so a progress
/// line can say what it waits on.
fn write_files(
    generation: &Generation,
    model: Results,
    results: &dyn CaseSource,
    write: WriteOptions,
    on_progress: &(dyn Fn(Progress) + Sync),
) -> Result<Results, PipelineError> {
    report::progress::reset();
    on_progress(Progress::Writing);
    let (written, waiting) = channel::<()>();
    std::thread::scope(|scope| {
        scope.spawn(move || {
            while let Err(RecvTimeoutError::Timeout) = waiting.recv_timeout(PICTURES_TICK) {
                let (drawn, planned) = report::progress::pictures();
                on_progress(Progress::Pictures { drawn, planned });
            }
        });
        let done = report::write_report(generation.path(), model, results, &write);
        drop(written);
        done
    })
    .map_err(|source| PipelineError::Write {
        out: generation.out().to_path_buf(),
        source,
    })
}

/// Signs the new generation (report.pdf and manifest.txt).
#[cfg(feature = "signoff")]
fn sign(generation: &Generation, date: &str, s: Signing) -> Result<SignedBy, PipelineError> {
    let done = ledflicker_signoff::sign(
        generation.path(),
        &ledflicker_signoff::SignRequest {
            signer: &s.signer,
            date,
            time_unix_s: s.time_unix_s,
            key: &s.key,
            key_files: s.key_files,
        },
    )
    .map_err(|source| PipelineError::Sign {
        out: generation.out().to_path_buf(),
        source,
    })?;
    Ok(SignedBy {
        signer: s.signer.trim().to_string(),
        fingerprint: done.fingerprint,
    })
}

#[cfg(not(feature = "signoff"))]
fn sign(_: &Generation, _: &str, s: Signing) -> Result<SignedBy, PipelineError> {
    match s {}
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The small fixture plan (tests/fixtures/plans/base.toml) and its
    /// case results on the simulator.
    fn small_run() -> (Plan, Vec<ledflicker_core::model::CaseResult>) {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/plans/base.toml");
        let plan = ledflicker_core::plan::load(&path).unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let simulator = ledflicker_core::backend::sim::Simulator::new(&plan);
        let results =
            ledflicker_core::runner::run(&plan, &cases, &simulator, Some(2), &|_| {}).unwrap();
        (plan, results)
    }

    fn options() -> ReportOptions {
        ReportOptions {
            date: "2026-01-01".to_string(),
            force: false,
            detail: Detail::default(),
            signing: None,
            golden: None,
            resume_hint: None,
        }
    }

    #[test]
    fn the_report_lands_in_out_and_progress_comes_in_stage_order() {
        let (plan, results) = small_run();
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("report");
        let generation = begin_output(&out, false).unwrap();
        let seen = std::sync::Mutex::new(Vec::new());
        let outcome = report(
            Run {
                plan: &plan,
                backend_id: "sim-ideal",
                results: &results,
                inputs: Vec::new(),
            },
            generation,
            options(),
            &|p| seen.lock().unwrap().push(p),
        )
        .unwrap();
        assert_eq!(outcome.dir, out);
        assert_eq!(outcome.cases, results.len());
        assert_eq!(outcome.model.cases.len(), results.len());
        assert!(outcome.signed.is_none() && outcome.golden.is_none());
        for file in ["results.json", "report.html", "junit.xml", "summary.csv"] {
            assert!(out.join(file).is_file(), "{file} not written");
        }
        let written = report::golden::load(&out.join("results.json")).unwrap();
        assert_eq!(written.verdict, outcome.model.verdict);
        assert_eq!(written.cases.len(), results.len());
        let seen = seen.into_inner().unwrap();
        assert_eq!(
            seen[..2],
            [
                Progress::Analysing {
                    cases: results.len()
                },
                Progress::Writing
            ]
        );
        assert_eq!(seen.last(), Some(&Progress::Written));
        let middle = &seen[2..seen.len() - 1];
        assert!(
            middle
                .iter()
                .all(|p| matches!(p, Progress::Pictures { drawn, planned } if drawn <= planned)),
            "{middle:?}"
        );
    }

    #[test]
    fn golden_drift_fails_the_run_and_no_judged_case_is_not_judged() {
        let (plan, results) = small_run();
        let model = ledflicker_core::model::assemble(&plan, "sim-ideal", &results);
        let mut outcome = Outcome {
            model,
            dir: PathBuf::from("out"),
            cases: results.len(),
            signed: None,
            golden: None,
            warning: None,
        };
        outcome.model.verdict = Verdict::Pass;
        assert_eq!(outcome.status(), Status::Pass);
        outcome.golden = Some(Comparison::default());
        assert_eq!(outcome.status(), Status::Pass, "no drift");
        outcome.golden = Some(Comparison {
            missing: vec!["case-0".to_string()],
            ..Comparison::default()
        });
        assert_eq!(outcome.status(), Status::Fail, "drift");
        outcome.model.verdict = Verdict::Info;
        assert_eq!(outcome.status(), Status::Fail, "drift beats not judged");
        outcome.golden = None;
        assert_eq!(outcome.status(), Status::NotJudged);
        outcome.model.verdict = Verdict::Fail;
        assert_eq!(outcome.status(), Status::Fail);
    }
}
