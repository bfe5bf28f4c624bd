//! Backends: where a case's frames come from.
//!
//! The runner hands each [`TestCase`] to a [`Backend`] and gets back an
//! [`Acquisition`]: per-frame timing and segment labels, and the mean luma of
//! every ROI in every frame. The built-in simulator is [`sim::Simulator`];
//! captured data and lab rigs plug in through the same trait, and
//! [`for_plan`] builds the one a plan names.

pub mod aravis;
pub mod captured;
pub mod command;
pub mod factory;
pub mod rig;
pub mod scpi;
pub mod segments;
pub mod sim;

pub use factory::{PlanBackend, SetupError, for_plan};

use ledflicker_plan::plan::TestCase;
pub use ledflicker_plan::trace::{Acquisition, FrameInfo, RenderedFrame, RoiTrace};

/// A backend failed to acquire a case.
#[derive(Debug, thiserror::Error)]
#[error("backend `{backend}` failed on case `{case}`: {message}")]
pub struct BackendError {
    /// Backend id.
    pub backend: String,
    /// Case id.
    pub case: String,
    /// What went wrong.
    pub message: String,
}

/// A source of frames for test cases: a camera simulator or captured data.
pub trait Backend: Send + Sync {
    /// Stable id used in reports, e.g. "sim-ideal".
    fn id(&self) -> &str;
    /// Frames and ROI traces for `case`.
    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError>;
    /// A full picture of frame `frame` of `case`, for the report, when the
    /// backend can make one. Traces never need it: only asked for pictures.
    fn render_frame(
        &self,
        _case: &TestCase,
        _frame: u64,
    ) -> Option<Result<RenderedFrame, BackendError>> {
        None
    }
    /// How many cases are worth running at once when the run sets no thread
    /// count; `None`: one per core. A backend whose cases wait on other
    /// processes (a video's frames sought by FFmpeg) says more, so that the
    /// cores are busy while a case waits.
    fn cases_at_once(&self) -> Option<usize> {
        None
    }
    /// [`Backend::render_frame`] for each of `frames` of `case`, in that
    /// order, in parallel. A backend that reads several frames of a case
    /// more cheaply together (a video, seeking in one process) does so.
    fn render_frames(
        &self,
        case: &TestCase,
        frames: &[u64],
    ) -> Vec<Option<Result<RenderedFrame, BackendError>>> {
        use rayon::prelude::*;
        frames
            .par_iter()
            .map(|&frame| self.render_frame(case, frame))
            .collect()
    }
}
