//! A plan's whole run once its output is begun and its backend built: the
//! run stage ([`super::run_cases`]) into the new generation, then the
//! report stage ([`super::report`]). `ledflicker plan` and the Python
//! package call this one function, so a report is the same whoever asks.

use std::path::PathBuf;

use ledflicker_core::backend::{Backend, PlanBackend};
use ledflicker_core::model::InputFile;
use ledflicker_core::outdir::Generation;
use ledflicker_core::plan::Plan;
use ledflicker_core::runner::CaseSource;

use super::{Outcome, PipelineError, Progress, ReportOptions, Run, RunCases, RunProgress, Stopped};

/// What [`run_plan`] runs, and how its report is written.
pub struct PlanRun<'a> {
    /// The plan, loaded and validated ([`super::load_plan`]).
    pub plan: &'a Plan,
    /// Its backend, built and checked ([`ledflicker_core::backend::for_plan`]).
    pub backend: &'a PlanBackend,
    /// The run's input files, hashed ([`ledflicker_core::inputs::collect`]).
    pub inputs: Vec<InputFile>,
    /// Worker threads; `None`: one per core. Results do not depend on it.
    pub threads: Option<usize>,
    /// Continue the store an interrupted run left in the generation
    /// ([`super::resume_output`]).
    pub resume: bool,
    /// How the report is written; its `resume_hint` is replaced by
    /// [`PlanRun::resume_hint`] when that is set.
    pub options: ReportOptions,
    /// Given the number of cases stored, the hint a stop in the report
    /// stage prints; `None`: such a stop removes the staging directory.
    pub resume_hint: Option<&'a dyn Fn(usize) -> String>,
}

/// A run stage that stopped, and the generation it ran in, handed back
/// so that the caller may keep its store for a resumed run (dropped, it
/// is removed).
#[derive(Debug)]
pub struct StoppedRun {
    /// Why, and whether the store holds cases.
    pub stopped: Stopped,
    /// The new generation, not committed.
    pub generation: Generation,
}

impl StoppedRun {
    /// Keeps the generation's case store for a resumed run when it holds
    /// cases (else the generation is dropped, which removes it): why the
    /// run stopped, and where its cases are kept.
    pub fn keep_for_resume(self) -> (super::RunStageError, Option<PathBuf>) {
        let kept = self
            .stopped
            .stored
            .then(|| self.generation.keep_for_resume());
        (self.stopped.error, kept)
    }
}

/// Why [`run_plan`] gave no report.
#[derive(Debug)]
pub enum PlanRunError {
    /// The run stage stopped.
    Stopped(Box<StoppedRun>),
    /// The report stage failed; the old report is as it was.
    Report(PipelineError),
}

/// Runs every case of `run.plan` into `generation`'s case store, then
/// analyses, writes, signs and swaps the report in. `on_run` hears the run
/// stage, `on_report` the report stage; both may be called from worker
/// threads.
pub fn run_plan(
    run: PlanRun<'_>,
    generation: Generation,
    on_run: &(dyn Fn(RunProgress) + Sync),
    on_report: &(dyn Fn(Progress) + Sync),
) -> Result<Outcome, PlanRunError> {
    let cases = RunCases {
        plan: run.plan,
        backend: run.backend,
        inputs: &run.inputs,
        dir: generation.path(),
        threads: run.threads,
        resume: run.resume,
    };
    let stored = match super::run_cases(&cases, on_run) {
        Ok(stored) => stored,
        Err(stopped) => {
            return Err(PlanRunError::Stopped(Box::new(StoppedRun {
                stopped,
                generation,
            })));
        }
    };
    let mut options = run.options;
    if let Some(hint) = run.resume_hint {
        options.resume_hint = Some(hint(stored.len()));
    }
    let report = Run {
        plan: run.plan,
        backend_id: run.backend.id(),
        results: &stored,
        inputs: run.inputs,
    };
    super::report(report, generation, options, on_report).map_err(PlanRunError::Report)
}
