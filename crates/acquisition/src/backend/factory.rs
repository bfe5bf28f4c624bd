//! The one place a plan's backend is built: the simulator, the captured
//! frames (read up front) or the lab rig's command, as the plan's
//! `[dut] backend` says. Every command that runs cases (`plan`, a shard of
//! it, `bench`) gets its backend here.

use super::captured::Captured;
use super::command::CommandRig;
use super::sim::Simulator;
use super::{Acquisition, Backend, BackendError, RenderedFrame};
use crate::capture::CaptureError;
use ledflicker_plan::plan::{BackendKind, Plan, TestCase};

/// The backend of a plan, one of the built-in three.
pub enum PlanBackend {
    /// `backend = "simulator"`.
    Simulator(Simulator),
    /// `backend = "captured"`: every case's capture, read.
    Captured(Captured),
    /// `backend = "command"`: a lab rig run once per case.
    Command(CommandRig),
}

/// A plan's backend could not be built.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A capture of a captured plan could not be read.
    #[error("cannot read the captures of plan `{plan}`")]
    Captures {
        /// Plan id.
        plan: String,
        /// Why.
        #[source]
        source: CaptureError,
    },
    /// The user stopped the run (Ctrl-C, SIGTERM) while the captures were
    /// read; the signal is the source, so that the exit code is its own.
    #[error("reading the captures of plan `{plan}` was stopped (at `{}`)", capture.display())]
    Interrupted {
        /// Plan id.
        plan: String,
        /// The capture being read.
        capture: std::path::PathBuf,
        /// The signal.
        #[source]
        source: crate::interrupt::Interrupted,
    },
    /// A command plan without a `[capture] command` (input error).
    #[error("the plan has no [capture] command")]
    NoCommand,
}

/// The backend `plan` names. A captured plan's captures are read now, in
/// parallel; with `only`, just the captures of those cases (a shard's).
pub fn for_plan(plan: &Plan, only: Option<&[TestCase]>) -> Result<PlanBackend, SetupError> {
    Ok(match plan.dut.backend {
        BackendKind::Simulator => PlanBackend::Simulator(Simulator::new(plan)),
        BackendKind::Captured => {
            let _t = crate::timings::span("read captures (decode and ROI means)");
            let loaded = match only {
                Some(cases) => {
                    let mut own = plan.clone();
                    if let Some(c) = &mut own.capture {
                        c.cases.retain(|k| cases.iter().any(|m| m.id == k.id));
                    }
                    Captured::load(&own)
                }
                None => Captured::load(plan),
            };
            PlanBackend::Captured(loaded.map_err(|source| match source {
                CaptureError::Interrupted { path, source } => SetupError::Interrupted {
                    plan: plan.id.clone(),
                    capture: path,
                    source,
                },
                source => SetupError::Captures {
                    plan: plan.id.clone(),
                    source,
                },
            })?)
        }
        BackendKind::Command => {
            PlanBackend::Command(CommandRig::new(plan).ok_or(SetupError::NoCommand)?)
        }
    })
}

impl PlanBackend {
    fn inner(&self) -> &dyn Backend {
        match self {
            Self::Simulator(b) => b,
            Self::Captured(b) => b,
            Self::Command(b) => b,
        }
    }
}

impl Backend for PlanBackend {
    fn id(&self) -> &str {
        self.inner().id()
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        self.inner().acquire(case)
    }

    fn render_frame(
        &self,
        case: &TestCase,
        frame: u64,
    ) -> Option<Result<RenderedFrame, BackendError>> {
        self.inner().render_frame(case, frame)
    }

    fn cases_at_once(&self) -> Option<usize> {
        self.inner().cases_at_once()
    }

    fn render_frames(
        &self,
        case: &TestCase,
        frames: &[u64],
    ) -> Vec<Option<Result<RenderedFrame, BackendError>>> {
        self.inner().render_frames(case, frames)
    }
}
