//! Fine maps: worst-phase FDI and Percent Flicker over a frequency x duty
//! grid, and what a map says against an FDI threshold.

use serde::{Deserialize, Serialize};

/// A linear camera response for one light level: ROI luma is
/// `min(off_dn + led_peak_dn * s, full_scale_dn)` for an ON fraction `s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LumaModel {
    /// Luma with the LED off (background and black level), DN (>= 0).
    pub off_dn: f64,
    /// Luma added by the LED ON for the whole exposure, DN (>= 0).
    pub led_peak_dn: f64,
    /// Clipping level, DN.
    pub full_scale_dn: f64,
}

impl LumaModel {
    /// Luma for an ON fraction `s` in 0..=1.
    pub fn luma(&self, s: f64) -> f64 {
        (self.off_dn + self.led_peak_dn * s).min(self.full_scale_dn)
    }
}

/// An evenly spaced axis: `start + i * step` for `i` in `0..count`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Axis {
    /// First value.
    pub start: f64,
    /// Step (> 0).
    pub step: f64,
    /// Number of values (>= 1).
    pub count: usize,
}

impl Axis {
    /// Value `i`, computed by index (never by accumulation).
    pub fn at(&self, i: usize) -> f64 {
        self.start + i as f64 * self.step
    }
    /// Last value.
    pub fn end(&self) -> f64 {
        self.at(self.count.saturating_sub(1))
    }
}

/// Worst-phase FDI and Percent Flicker over a frequency x duty grid.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FineMap {
    /// Frequencies, Hz.
    pub frequency: Axis,
    /// Duty cycles, 0..=1.
    pub duty: Axis,
    /// Worst-phase FDI (2018) of cell `(i, j)` at `i * duty.count + j`;
    /// `None` where undefined (dark OFF reference).
    pub fdi_worst: Vec<Option<f64>>,
    /// Worst-phase Percent Flicker, same layout; `None` where undefined.
    pub pf_worst: Vec<Option<f64>>,
}

/// What a fine map says, for results.json.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FineMapSummary {
    /// Frequency axis, Hz.
    pub frequency_hz: Axis,
    /// Duty axis, 0..=1.
    pub duty: Axis,
    /// Number of cells.
    pub cells: usize,
    /// FDI threshold used, if the plan has one.
    pub fdi_2018_min: Option<f64>,
    /// Fraction of cells (0..=1) whose worst-phase FDI is below the
    /// threshold (undefined counts as below); `None` without a threshold.
    pub fdi_fail_fraction: Option<f64>,
    /// Lowest frequency from which every cell up to the top of the map meets
    /// the FDI threshold, Hz; `None` if none does or there is no threshold.
    pub fdi_safe_from_hz: Option<f64>,
    /// Largest worst-phase Percent Flicker in the map.
    pub percent_flicker_worst_max: Option<f64>,
}

impl FineMap {
    /// Summary against an FDI threshold.
    pub fn summary(&self, fdi_min: Option<f64>) -> FineMapSummary {
        let nd = self.duty.count;
        let fails = |k: usize, t: f64| {
            self.fdi_worst[k]
                .is_none_or(|v| v < t - ledflicker_metrics::metrics::verdict::VERDICT_TOLERANCE)
        };
        let fdi_fail_fraction = fdi_min.map(|t| {
            (0..self.fdi_worst.len()).filter(|&k| fails(k, t)).count() as f64
                / self.fdi_worst.len().max(1) as f64
        });
        let fdi_safe_from_hz = fdi_min.and_then(|t| {
            let mut from = None;
            for i in (0..self.frequency.count).rev() {
                if (0..nd).any(|j| fails(i * nd + j, t)) {
                    break;
                }
                from = Some(self.frequency.at(i));
            }
            from
        });
        FineMapSummary {
            frequency_hz: self.frequency,
            duty: self.duty,
            cells: self.fdi_worst.len(),
            fdi_2018_min: fdi_min,
            fdi_fail_fraction,
            fdi_safe_from_hz,
            percent_flicker_worst_max: self.pf_worst.iter().flatten().copied().reduce(f64::max),
        }
    }
}
