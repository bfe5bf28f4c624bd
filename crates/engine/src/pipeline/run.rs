//! The run stage: every case of a plan into the case store as it
//! finishes, then the finished store, which the report stage reads back in
//! case order ([`super::report`]). A resumed run first judges each stored
//! case again from its data, then runs only the cases not stored.

use std::path::Path;

use ledflicker_core::backend::{Backend, PlanBackend};
use ledflicker_core::model::InputFile;
use ledflicker_core::plan::{self, Plan};
use ledflicker_core::runner::{self, CaseResult, RunError, RunEvent};

use crate::store::{Encoded, RunKey, Store, StoreError, StoredCases};

/// What the run stage runs and where.
pub struct RunCases<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Its backend, built and checked.
    pub backend: &'a PlanBackend,
    /// The run's inputs (the plan and the files it names), whose hash
    /// keys the store: a resumed run must have the same.
    pub inputs: &'a [InputFile],
    /// The staging directory of the new report
    /// ([`ledflicker_core::outdir::Generation::path`]).
    pub dir: &'a Path,
    /// Worker threads; `None`: one per core. Results do not depend on it.
    pub threads: Option<usize>,
    /// Continue the store that an earlier run of the plan left in `dir`.
    pub resume: bool,
}

/// What the run stage tells its caller while it works.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunProgress {
    /// A resumed store was read and its cases judged again.
    Resumed {
        /// Cases kept from the store.
        kept: usize,
        /// Cases in the plan.
        total: usize,
    },
    /// The cases start to run.
    Started {
        /// Cases in the plan.
        total: usize,
        /// Of them, already stored (a resumed run).
        done: usize,
    },
    /// One more case is stored.
    CaseFinished,
    /// The cases' run has ended; the store is being finished.
    Finished,
}

/// Why the run stage stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunStageError {
    /// The case store could not be created, resumed, written or finished.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A case could not be run, or a signal stopped the run.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The cases' run failed, for `source`.
    #[error("run of plan `{plan}` failed")]
    Cases {
        /// The plan's id.
        plan: String,
        /// Why.
        #[source]
        source: Box<RunStageError>,
    },
}

impl RunStageError {
    /// Why another `--resume` of the same store would fail the same way:
    /// the store is another run's, or holds a case that cannot be read.
    pub fn store_refused(&self) -> Option<&StoreError> {
        match self {
            RunStageError::Store(e @ (StoreError::Mismatch { .. } | StoreError::Record { .. })) => {
                Some(e)
            }
            RunStageError::Store(_) | RunStageError::Run(_) => None,
            RunStageError::Cases { source, .. } => source.store_refused(),
        }
    }
}

/// A stopped run stage, and whether its store holds cases worth resuming.
#[derive(Debug)]
pub struct Stopped {
    /// Why it stopped.
    pub error: RunStageError,
    /// The store holds cases (stored now or kept from the resumed run):
    /// keep the staging directory for `--resume`.
    pub stored: bool,
}

impl From<StoreError> for Stopped {
    fn from(e: StoreError) -> Self {
        Stopped {
            error: e.into(),
            stored: false,
        }
    }
}

/// The key of a run's store: a resumed run must be of the same plan,
/// inputs, tool, backend and case count.
pub fn run_key(
    plan: &Plan,
    backend: &PlanBackend,
    inputs: &[InputFile],
    case_count: usize,
) -> RunKey {
    RunKey {
        plan_id: plan.id.clone(),
        plan_hash: crate::shard::record::plan_hash(inputs),
        tool: crate::shard::write::tool(),
        backend: backend.id().to_string(),
        case_count,
    }
}

/// Runs every case into the store in `run.dir` (resumed: only the cases
/// not stored yet) and gives the finished store. A resumed run that stops
/// keeps its store whatever the cause.
pub fn run_cases(
    run: &RunCases<'_>,
    on_progress: &(dyn Fn(RunProgress) + Sync),
) -> Result<StoredCases, Stopped> {
    stage(run, on_progress).map_err(|mut stopped| {
        stopped.stored |= run.resume;
        stopped
    })
}

fn stage(
    run: &RunCases<'_>,
    on_progress: &(dyn Fn(RunProgress) + Sync),
) -> Result<StoredCases, Stopped> {
    let plan = run.plan;
    let cases = plan::expand_cases(plan);
    let key = run_key(plan, run.backend, run.inputs, cases.len());
    let (mut store, done) = if run.resume {
        let _t = ledflicker_core::timings::span("resume: partial store opened");
        Store::resume(run.dir, &key)?
    } else {
        (Store::create(run.dir, &key)?, Default::default())
    };
    if run.resume {
        // The stored cases are data: each is checked as the plan's own case
        // at its position and judged again from its acquisition.
        let judge = |idx: usize, stored: CaseResult| {
            crate::shard::check::stored_case(plan, &cases, idx, stored)
        };
        let t = ledflicker_core::timings::span("resume: stored cases judged again");
        let kept = store.rejudge(&judge)?;
        drop(t);
        on_progress(RunProgress::Resumed {
            kept,
            total: cases.len(),
        });
    }
    let (positions, todo): (Vec<usize>, Vec<_>) = cases
        .iter()
        .enumerate()
        .filter(|(i, _)| !done.contains(i))
        .map(|(i, c)| (i, c.clone()))
        .unzip();
    on_progress(RunProgress::Started {
        total: cases.len(),
        done: done.len(),
    });
    let on_event = |ev: RunEvent<'_>| {
        if let RunEvent::CaseFinished { .. } = ev {
            on_progress(RunProgress::CaseFinished);
        }
    };
    let options = runner::RunOptions {
        threads: run.threads,
        sample_frames: true,
    };
    let t = ledflicker_core::timings::span("run cases");
    let mut sink = Storing {
        stored: !done.is_empty(),
        store,
        positions,
    };
    let ran = runner::run_streaming(plan, &todo, run.backend, options, &on_event, &mut sink);
    drop(t);
    on_progress(RunProgress::Finished);
    let Storing { store, stored, .. } = sink;
    if let Err(e) = ran {
        return Err(Stopped {
            error: RunStageError::Cases {
                plan: plan.id.clone(),
                source: Box::new(e),
            },
            stored: stored && store.close().is_ok(),
        });
    }
    let _t = ledflicker_core::timings::span("case store finished");
    let path = store.finish()?;
    Ok(StoredCases::open(&path)?)
}

/// The run's sink: each case into the store, under its position in the plan.
struct Storing {
    store: Store,
    /// Plan position of each case run, by its position in the run.
    positions: Vec<usize>,
    /// Whether the store holds a case.
    stored: bool,
}

impl runner::CaseSink for Storing {
    type Error = RunStageError;
    type Item = Encoded;

    fn prepare(result: CaseResult) -> Encoded {
        Encoded::new(result)
    }

    fn put(&mut self, position: usize, case: Encoded) -> Result<(), RunStageError> {
        self.store.put_encoded(self.positions[position], case)?;
        self.stored = true;
        Ok(())
    }

    fn idle(&mut self) -> Result<(), RunStageError> {
        Ok(self.store.flush()?)
    }
}
