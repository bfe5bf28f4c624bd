//! Fine maps: the worst case over PWM phase of FDI (2018) and Percent
//! Flicker over the whole frequency x duty plane for one camera, computed
//! analytically with [`Shutter::phase_envelopes`] (exact, `4 * rows`
//! corners per cell; a frequency's duties at once, each cell the same
//! double as [`Shutter::phase_envelope`] gives), in parallel over
//! frequencies. Each cell is computed independently, so the map does not
//! depend on the thread count.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use ledflicker_metrics::metrics::flicker::{fdi_2018, percent_flicker};
use ledflicker_physics::Shutter;

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

/// Computes the map for `shutter` and the ROI `rows` under `luma`.
pub fn compute(
    shutter: &Shutter,
    rows: std::ops::Range<u32>,
    luma: LumaModel,
    frequency: Axis,
    duty: Axis,
) -> FineMap {
    let cells: Vec<(Option<f64>, Option<f64>)> = (0..frequency.count)
        .into_par_iter()
        .flat_map_iter(|i| {
            let f = frequency.at(i);
            let duties: Vec<f64> = (0..duty.count)
                .map(|j| duty.at(j).clamp(f64::MIN_POSITIVE, 1.0))
                .collect();
            // A row's envelopes at once; a cell whose drive is invalid (a
            // NaN duty or frequency) gets none, as before.
            shutter
                .phase_envelopes_checked(f, &duties, rows.clone())
                .into_iter()
                .map(move |envelope| match envelope {
                    Some((lo, hi)) => {
                        let (lo, hi) = (luma.luma(lo), luma.luma(hi));
                        (
                            fdi_2018(lo, Some(luma.off_dn)).value,
                            percent_flicker(lo, hi).value,
                        )
                    }
                    None => (None, None),
                })
        })
        .collect();
    let (fdi_worst, pf_worst) = cells.into_iter().unzip();
    FineMap {
        frequency,
        duty,
        fdi_worst,
        pf_worst,
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_physics::{PwmDrive, ShutterModel};

    #[test]
    fn map_cells_equal_the_envelope_and_bound_a_phase_sweep() {
        let shutter = Shutter {
            model: ShutterModel::Rolling {
                line_time_s: 14.565e-6,
            },
            exposure_s: 0.005,
            fps: 30.0,
        };
        let luma = LumaModel {
            off_dn: 20.0,
            led_peak_dn: 200.0,
            full_scale_dn: 255.0,
        };
        let fa = Axis {
            start: 50.0,
            step: 37.0,
            count: 12,
        };
        let da = Axis {
            start: 0.05,
            step: 0.1,
            count: 10,
        };
        let map = compute(&shutter, 399..401, luma, fa, da);
        for i in 0..fa.count {
            for j in 0..da.count {
                let (f, d) = (fa.at(i), da.at(j));
                // Brute force over 2000 phases (a lower bound on the worst case).
                let mut lo = f64::INFINITY;
                for p in 0..2000 {
                    let pwm = PwmDrive::new(f, d, p as f64 / 2000.0 / f).unwrap();
                    lo = lo.min(luma.luma(shutter.frame_on_fraction(&pwm, 0, 399..401)));
                }
                let fdi_sweep = (lo - 20.0) / 20.0;
                let fdi = map.fdi_worst[i * da.count + j].unwrap();
                // The row-at-once envelope is the single cell's, bit for bit.
                let pwm = PwmDrive::new(f, d, 0.0).unwrap();
                let (elo, ehi) = shutter.phase_envelope(&pwm, 399..401);
                let (elo, ehi) = (luma.luma(elo), luma.luma(ehi));
                let pf = map.pf_worst[i * da.count + j].unwrap();
                assert_eq!(
                    fdi.to_bits(),
                    fdi_2018(elo, Some(20.0)).value.unwrap().to_bits()
                );
                assert_eq!(
                    pf.to_bits(),
                    percent_flicker(elo, ehi).value.unwrap().to_bits()
                );
                let tol = 200.0 / 20.0 * 2.0 / (0.005 * f) / 2000.0 + 1e-9;
                assert!(
                    fdi <= fdi_sweep + 1e-9 && fdi_sweep - fdi <= tol,
                    "f={f} d={d}: {fdi} vs {fdi_sweep}"
                );
            }
        }
    }

    #[test]
    fn eq1_sets_where_the_map_loses_the_led() {
        // Global shutter, 5 ms: the LED can vanish (FDI 0) exactly where
        // T < (1 - D) / f (Deegan 2018 Eq. 1).
        let shutter = Shutter {
            model: ShutterModel::Global,
            exposure_s: 0.005,
            fps: 30.0,
        };
        let luma = LumaModel {
            off_dn: 20.0,
            led_peak_dn: 200.0,
            full_scale_dn: 1e9,
        };
        let fa = Axis {
            start: 50.0,
            step: 1.0,
            count: 451,
        };
        let da = Axis {
            start: 0.01,
            step: 0.01,
            count: 100,
        };
        let map = compute(&shutter, 0..1, luma, fa, da);
        for i in 0..fa.count {
            for j in 0..da.count {
                let (f, d) = (fa.at(i), da.at(j));
                let margin = 0.005 - (1.0 - d) / f;
                if margin.abs() < 1e-9 {
                    continue;
                }
                let lost = map.fdi_worst[i * da.count + j].unwrap() < 1e-9;
                assert_eq!(lost, margin < 0.0, "f={f} d={d}");
            }
        }
        let s = map.summary(Some(0.1));
        assert!(s.fdi_fail_fraction.unwrap() > 0.0);
        assert_eq!(s.cells, 45_100);
    }
}
