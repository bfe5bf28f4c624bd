//! Banding of a rolling shutter: of the PWM condition and of a frame shown.

use serde::{Deserialize, Serialize};

/// Row contrast below which a frame's LED rows count as even (no bands), %.
pub const NO_BANDS_CONTRAST_PERCENT: f64 = 1.0;

/// Banding of one PWM condition on a rolling shutter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Banding {
    /// Rows between successive bands, `1 / (f * t_line)`.
    pub band_period_rows: f64,
    /// Band periods per frame height.
    pub bands_per_frame: f64,
    /// Michelson contrast x 100 of the LED-only row profile of frame 0,
    /// 0..=100; `None` when no row sees light.
    pub band_contrast_percent: Option<f64>,
    /// Band motion in rows per frame (positive: down the frame), the
    /// smallest of the aliases `-(f/fps - round(f/fps)) * period`.
    pub band_velocity_rows_per_frame: f64,
    /// PWM frequency estimated from the band spacing of frame 0 and the
    /// line time, Hz; `None` with `estimate_note` when it cannot be.
    pub estimated_frequency_hz: Option<f64>,
    /// Why there is no estimate, if there is none.
    pub estimate_note: Option<String>,
}

/// Row analysis of a frame: the mean luma of each row over some columns,
/// between the first and the last row the LED lights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameBanding {
    /// First and last lit row (inclusive).
    pub lit_rows: (u32, u32),
    /// Michelson contrast x 100 of the row means over the lit rows.
    pub row_contrast_percent: f64,
    /// Mean spacing of the bands over the lit rows, rows; `None` when the
    /// lit rows hold fewer than two band periods or show no bands.
    pub band_period_rows: Option<f64>,
}
