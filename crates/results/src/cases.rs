//! The record of one finished case, as the runner makes it, the case
//! store and shards keep it, and the report stage reads it back.

use ledflicker_metrics::metrics::p2020::P2020Metrics;
use ledflicker_metrics::metrics::{Check, RoiMetrics, Verdict};
use ledflicker_plan::plan::TestCase;
use ledflicker_plan::trace::{Acquisition, RenderedFrame};

/// Everything known about one finished case. Serialisable so that a
/// shard can hand it to `ledflicker merge` unchanged (`ledflicker_engine::shard`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CaseResult {
    /// The condition tested.
    pub case: TestCase,
    /// Frames and traces from the backend.
    pub acquisition: Acquisition,
    /// Metrics per plan ROI, in plan order.
    pub metrics: Vec<RoiMetrics>,
    /// Verdict of the case.
    pub verdict: Verdict,
    /// Every threshold check made.
    pub checks: Vec<Check>,
    /// Why the case is informational, when it is.
    pub not_judged: Option<String>,
    /// Limits that could not apply to this case, and why.
    pub not_checked: Vec<String>,
    /// A picture of the frame with the lowest LED-ROI luma in the PWM
    /// segment, when one was asked for and the backend can render it.
    pub sample_frame: Option<RenderedFrame>,
    /// IEEE P2020 KPIs per plan ROI, in plan order.
    pub p2020: Vec<P2020Metrics>,
    /// A picture of the capture's frame where the lamp is lit
    /// (`CaptureSummary::lit_frame`), for the ROI set-up figure, when the
    /// sample frame was asked for and the backend can render it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lit_frame: Option<RenderedFrame>,
}

/// Why a run's stored cases could not be read back.
pub type CaseReadError = Box<dyn std::error::Error + Send + Sync>;

/// A run's case results in case order, for the stages after the run: held
/// in memory, or read back from the case store a chunk at a time, so that
/// the analyses and the report of a large run never hold every case.
pub trait CaseSource: Sync {
    /// Number of cases.
    fn len(&self) -> usize;
    /// Whether there is no case.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The cases at `range` of the run's cases, in order.
    fn read(&self, range: std::ops::Range<usize>) -> Result<Vec<CaseResult>, CaseReadError>;
}

impl std::fmt::Debug for dyn CaseSource + '_ {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CaseSource({} cases)", self.len())
    }
}

/// A run's cases in memory (a slice behind a reference, as a source must
/// be sized to be used as `&dyn CaseSource`).
impl CaseSource for &[CaseResult] {
    fn len(&self) -> usize {
        <[CaseResult]>::len(self)
    }

    fn read(&self, range: std::ops::Range<usize>) -> Result<Vec<CaseResult>, CaseReadError> {
        self.get(range.clone())
            .map(<[CaseResult]>::to_vec)
            .ok_or_else(|| format!("cases {range:?} of {} asked for", self.len()).into())
    }
}

/// A run's cases in memory.
impl CaseSource for Vec<CaseResult> {
    fn len(&self) -> usize {
        Vec::len(self)
    }

    fn read(&self, range: std::ops::Range<usize>) -> Result<Vec<CaseResult>, CaseReadError> {
        self.as_slice().read(range)
    }
}

/// Cases read and handled at a time by [`for_each_chunk`]: enough for
/// every core, few enough that a chunk's memory is small.
pub const CHUNK: usize = 256;

/// Calls `f` with each [`CHUNK`] of `source`'s cases in order, with the
/// position of its first case.
pub fn for_each_chunk<E: From<CaseReadError>>(
    source: &dyn CaseSource,
    mut f: impl FnMut(usize, Vec<CaseResult>) -> Result<(), E>,
) -> Result<(), E> {
    let mut start = 0;
    while start < source.len() {
        let end = (start + CHUNK).min(source.len());
        f(start, source.read(start..end)?)?;
        start = end;
    }
    Ok(())
}
