//! What the apparent flicker looks like to a driver.

use serde::{Deserialize, Serialize};

/// What the apparent flicker looks like to a driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HazardClass {
    /// No visible modulation, or phase locked (a constant level).
    Steady,
    /// Visible, slower than 0.8 Hz: a slow pulsing of brightness.
    SlowDrift,
    /// 0.8 Hz to below 1.0 Hz (MUTCD 4D.30: 50-60 flashes per minute).
    TrafficSignalLike,
    /// 1.0 to 2.0 Hz (UN R6/R48: 90 +/- 30 flashes per minute).
    TurnIndicatorLike,
    /// Above 2.0 up to 4.0 Hz (SAE J845: 1-4 Hz; 1-2 Hz is classed as a turn
    /// indicator, and listed as beacon-like in the matches).
    BeaconLike,
    /// Visible flicker outside the named bands (4-10 Hz, above 25 Hz).
    Flicker,
    /// 10 to 25 Hz, around the peak of flicker sensitivity (~15 Hz).
    PeakAnnoyance,
}

impl HazardClass {
    /// Kebab-case name, as in results.json.
    pub fn as_str(self) -> &'static str {
        match self {
            HazardClass::Steady => "steady",
            HazardClass::SlowDrift => "slow-drift",
            HazardClass::TrafficSignalLike => "traffic-signal-like",
            HazardClass::TurnIndicatorLike => "turn-indicator-like",
            HazardClass::BeaconLike => "beacon-like",
            HazardClass::Flicker => "flicker",
            HazardClass::PeakAnnoyance => "peak-annoyance",
        }
    }
}
