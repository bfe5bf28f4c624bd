//! Flicker of the PWM drive itself against IEEE 1789-2015.

use serde::{Deserialize, Serialize};

/// IEEE 1789-2015 region of a light source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Ieee1789Region {
    /// Within the no-observable-effect limit (Recommended Practice 2).
    NoObservableEffect,
    /// Within the low-risk limit (Recommended Practice 1), not NOEL.
    LowRisk,
    /// Above the low-risk limit.
    ElevatedRisk,
}

/// Flicker of the PWM drive itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriveFlicker {
    /// Percent Flicker (modulation %) of the drive, 0..=100.
    pub percent_flicker: f64,
    /// IES Flicker Index, 0..=1.
    pub flicker_index: f64,
    /// IEEE 1789 low-risk modulation limit at this frequency, %; `None`
    /// above 1250 Hz (exempt).
    pub ieee1789_low_risk_max_percent: Option<f64>,
    /// IEEE 1789 NOEL modulation limit at this frequency, %; `None` above
    /// 3 kHz (exempt).
    pub ieee1789_noel_max_percent: Option<f64>,
    /// The region the drive falls in.
    pub ieee1789_region: Ieee1789Region,
    /// Stroboscopic visibility measure of the drive (CIE TN 006:2016; 1 =
    /// at threshold), exact from its harmonics (`svm::of_pwm`); `None`
    /// when the frequency or the duty is unknown.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub svm: Option<f64>,
}
