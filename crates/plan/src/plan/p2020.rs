//! `[p2020]` settings: the parameters of the IEEE P2020 KPIs as a plan
//! gives them. The KPIs themselves are computed in `metrics::p2020`, which
//! takes these types from here.

use serde::{Deserialize, Serialize};

/// The level MMP compares each frame with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MmpReference {
    /// Mean of the PWM segment, as the P2020 reference code does.
    PwmMean,
    /// Mean of the steady-ON segment (luminance matched to the PWM average).
    OnLevel,
}

/// Parameters of the P2020 KPIs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct P2020Options {
    /// FDI contrast threshold (the reference code uses 0.1).
    pub contrast_threshold: f64,
    /// MMP half-band as a fraction of the reference level (reference: 0.1).
    pub mmp_delta: f64,
    /// MMP reference level.
    pub mmp_reference: MmpReference,
}

impl Default for P2020Options {
    fn default() -> Self {
        Self {
            contrast_threshold: 0.1,
            mmp_delta: 0.1,
            mmp_reference: MmpReference::PwmMean,
        }
    }
}
