//! Fine maps: the worst case over PWM phase of FDI (2018) and Percent
//! Flicker over the whole frequency x duty plane for one camera, computed
//! analytically with [`Shutter::phase_envelopes`] (exact, `4 * rows`
//! corners per cell; a frequency's duties at once, each cell the same
//! double as [`Shutter::phase_envelope`] gives), in parallel over
//! frequencies. Each cell is computed independently, so the map does not
//! depend on the thread count.

pub use ledflicker_results::analysis::finemap::{Axis, FineMap, FineMapSummary, LumaModel};
use rayon::prelude::*;

use ledflicker_metrics::metrics::flicker::{fdi_2018, percent_flicker};
use ledflicker_physics::Shutter;

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
