//! What the analyses beyond the paper find for a case and a plan, as
//! results.json carries it: the apparent frequency and its hazard class,
//! the drive against IEEE 1789, phase coverage, banding, frame timing and
//! the fine maps. The analyses themselves are in `ledflicker-analysis`.

pub mod apparent;
pub mod banding;
pub mod drive;
pub mod finemap;
pub mod hazard;
pub mod phase_fold;
pub mod timing;

use serde::{Deserialize, Serialize};

pub use apparent::{ApparentMethod, Beat};
pub use banding::{Banding, FrameBanding};
pub use drive::DriveFlicker;
pub use hazard::HazardClass;
pub use phase_fold::PhaseCoverage;
pub use timing::FrameTiming;

/// [`RoiAnalysis::spectrum`] of a model read back from results.json.
fn spectrum_not_stored() -> Result<f64, apparent::SpectrumError> {
    Err(apparent::SpectrumError::TooShort(0))
}

/// The analysis of one ROI trace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoiAnalysis {
    /// Dominant frequency of the PWM-segment trace's spectrum, Hz; `None`
    /// with `spectrum_reason` when there is none.
    pub apparent_frequency_spectrum_hz: Option<f64>,
    /// Why the spectrum gave no frequency, or why it differs from `f_a`.
    pub spectrum_reason: Option<String>,
    /// The apparent frequency the hazard class is judged on, Hz.
    pub apparent_frequency_hz: f64,
    /// Where `apparent_frequency_hz` came from.
    pub apparent_method: ApparentMethod,
    /// What the flicker looks like (from the apparent frequency and the
    /// trace's Percent Flicker).
    pub hazard_class: HazardClass,
    /// Every named band the apparent frequency falls in (when visible).
    pub hazard_matches: Vec<HazardClass>,
    /// Phase coverage of the capture.
    pub phase_coverage: PhaseCoverage,
    /// Per-bin (min, max) luma of the folded trace, for the chart.
    #[serde(skip)]
    pub folded_bins: Vec<Option<(f64, f64)>>,
    /// Exact (min, max) luma over phase, when known, for the chart.
    #[serde(skip)]
    pub envelope: Option<(f64, f64)>,
    /// The dominant frequency of the spectrum, or why there is none (not
    /// in results.json, which holds it as `apparent_frequency_spectrum_hz`
    /// and `spectrum_reason`).
    #[serde(skip, default = "spectrum_not_stored")]
    pub spectrum: Result<f64, apparent::SpectrumError>,
}

/// A fine map for one light level, as reported.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FineMapInfo {
    /// Illuminance, lux.
    pub light_lux: f64,
    /// The LED ROI the map is for.
    pub roi: String,
    /// The luma model used.
    pub luma: finemap::LumaModel,
    /// What the map says.
    pub summary: finemap::FineMapSummary,
    /// The map itself (not serialised: 2 x 195 100 numbers).
    #[serde(skip)]
    pub map: finemap::FineMap,
}
