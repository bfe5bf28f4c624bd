//! The sources of an LED's light in the simulator: the LED as a whole,
//! or each of its dies (`[[scene.led-die]]`) on its own PWM waveform, and
//! the exact integrals and worst case over phase of their mixed light
//! (docs/visibility.md, section 6).

use ledflicker_physics::pwm::{on_fraction, wrap_unit};
use ledflicker_physics::{PwmDrive, Shutter, ShutterModel};
use ledflicker_plan::plan::Roi;
use ledflicker_plan::plan::colour::ColourConfig;

/// One source of the LED's light: the whole LED, or one of its dies
/// (`[[scene.led-die]]`), each on its own PWM waveform.
#[derive(Debug, Clone, Copy)]
pub(super) struct Emitter {
    /// Its PWM: the case's frequency, its own duty and rising edge.
    pub(super) drive: PwmDrive,
    /// Its rising edge after the LED's common one, cycles.
    pub(super) lag_cycles: f64,
    /// Its share of the LED's luminance while ON (the shares sum to 1).
    pub(super) share: f64,
    /// Its camera RGB per cd/m^2 of its own luminance.
    pub(super) rgb: [f64; 3],
}

/// The sources of the LED's light for the case's drive `pwm`: the LED
/// itself, or each of `colour`'s dies at the case's duty times its own
/// and its rising edge its phase after the common one.
pub(super) fn emitters(colour: Option<&ColourConfig>, pwm: &PwmDrive) -> Vec<Emitter> {
    match colour.filter(|c| !c.dies.is_empty()) {
        None => vec![Emitter {
            drive: *pwm,
            lag_cycles: 0.0,
            share: 1.0,
            rgb: colour.map_or([0.0; 3], |c| c.led_rgb),
        }],
        Some(c) => c
            .dies
            .iter()
            .map(|d| {
                let f = pwm.frequency_hz();
                let duty = (pwm.duty() * d.duty).max(f64::MIN_POSITIVE);
                // A valid drive's frequency with a duty in (0, 1] and a
                // finite rise is valid; fall back rather than panic.
                let drive =
                    PwmDrive::new(f, duty, pwm.first_rise_s() + d.phase_cycles / f).unwrap_or(*pwm);
                Emitter {
                    drive,
                    lag_cycles: d.phase_cycles,
                    share: d.share,
                    rgb: d.rgb,
                }
            })
            .collect(),
    }
}

/// The LED's light as a fraction of its all-ON luminance when it shines
/// steadily at its PWM average (the ON segment): each source's share times
/// its duty.
pub(super) fn steady_fraction(emitters: &[Emitter]) -> f64 {
    emitters
        .iter()
        .fold(0.0, |sum, e| sum + e.share * e.drive.duty())
}

/// `sum_j weight(source j) x fraction(j)`, summed from 0 in the sources'
/// order: for the LED alone, `weight x fraction` exactly.
pub(super) fn weighted(
    emitters: &[Emitter],
    fraction: impl Fn(usize) -> f64,
    weight: impl Fn(&Emitter) -> f64,
) -> f64 {
    emitters
        .iter()
        .enumerate()
        .fold(0.0, |sum, (j, e)| sum + weight(e) * fraction(j))
}

/// Each PWM frame's ON fraction of each source over the ROI rows, for an
/// exposure starting `offset_s` after the frame's: `[source][frame]`.
pub(super) fn mixed_on_fractions(
    shutter: &Shutter,
    emitters: &[Emitter],
    frames: std::ops::Range<u64>,
    roi: &Roi,
    offset_s: f64,
) -> Vec<Vec<f64>> {
    emitters
        .iter()
        .map(|e| {
            // A later exposure sees the edges earlier: the same drive with
            // its first rise moved back by the offset (finite inputs to a
            // drive that was valid stay valid).
            let shifted = if offset_s == 0.0 {
                e.drive
            } else {
                PwmDrive::new(
                    e.drive.frequency_hz(),
                    e.drive.duty(),
                    e.drive.first_rise_s() - offset_s,
                )
                .unwrap_or(e.drive)
            };
            let mut on = Vec::new();
            shutter.frame_on_fractions(&shifted, frames.clone(), roi.rows(), &mut on);
            on
        })
        .collect()
}

/// Lowest and highest share-weighted ON fraction of several sources at
/// one frequency (an LED's dies), mean over the ROI rows `rows`, over
/// every phase of the common PWM: each source's ON fraction is piecewise
/// linear in the phase with corners where an exposure edge meets one of
/// its PWM edges, so the sum's extremes are at the union of those corners.
pub(super) fn mixed_envelope(
    shutter: &Shutter,
    emitters: &[Emitter],
    rows: std::ops::Range<u32>,
) -> (f64, f64) {
    let Some(first) = emitters.first() else {
        return (0.0, 0.0);
    };
    let f = first.drive.frequency_hz();
    let width = shutter.exposure_s * f;
    let rows: Vec<u32> = match shutter.model {
        ShutterModel::Global | ShutterModel::Rolling { line_time_s: 0.0 } => vec![rows.start],
        ShutterModel::Rolling { .. } => rows.collect(),
    };
    let offsets: Vec<f64> = rows
        .iter()
        .map(|&r| wrap_unit(shutter.row_offset_s(r) * f))
        .collect();
    let n = offsets.len() as f64;
    // `phi`: the phase of row 0's exposure start after the common rise.
    let light = |phi: f64| {
        emitters.iter().fold(0.0, |sum, e| {
            let d = e.drive.duty();
            let rows: f64 = offsets
                .iter()
                .map(|o| on_fraction(wrap_unit(phi + o - e.lag_cycles), width, d))
                .sum();
            sum + e.share * rows / n
        })
    };
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for e in emitters {
        let d = e.drive.duty();
        for o in &offsets {
            for c in [0.0, d, -width, d - width] {
                let v = light(wrap_unit(c + e.lag_cycles - o));
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_physics::sensor::Rng;

    /// The dies' worst case over phase bounds a dense sweep of phases,
    /// each computed by the shutter's own per-frame integral of each die's
    /// drive, and the sweep comes within its step of both ends: global and
    /// rolling shutters, dies overlapping or not.
    #[test]
    fn the_dies_envelope_bounds_a_dense_phase_sweep_and_is_attained() {
        let mut rng = Rng::new(49);
        for case in 0..40 {
            let f = 90.0 + rng.uniform() * 900.0;
            let shutter = Shutter {
                model: if case % 2 == 0 {
                    ShutterModel::Global
                } else {
                    ShutterModel::Rolling {
                        line_time_s: 20e-6 + rng.uniform() * 40e-6,
                    }
                },
                exposure_s: 2e-4 + rng.uniform() * 4e-3,
                fps: 30.0,
            };
            let n = 2 + case % 3;
            let shares: Vec<f64> = (0..n).map(|_| 0.1 + rng.uniform()).collect();
            let total: f64 = shares.iter().sum();
            let dies: Vec<Emitter> = shares
                .iter()
                .map(|s| {
                    let duty = 0.05 + 0.9 * rng.uniform();
                    let lag = rng.uniform();
                    Emitter {
                        drive: PwmDrive::new(f, duty, lag / f).unwrap(),
                        lag_cycles: lag,
                        share: s / total,
                        rgb: [0.0; 3],
                    }
                })
                .collect();
            let rows = 10..26;
            let (lo, hi) = mixed_envelope(&shutter, &dies, rows.clone());
            // Row 0 of frame 0 at phase `phi` after the common rise: the
            // common rise at -phi / f, each die's its lag later.
            let light = |phi: f64| {
                dies.iter()
                    .map(|e| {
                        let drive =
                            PwmDrive::new(f, e.drive.duty(), (e.lag_cycles - phi) / f).unwrap();
                        e.share * shutter.frame_on_fraction(&drive, 0, rows.clone())
                    })
                    .sum::<f64>()
            };
            let steps = 20_000;
            let (mut seen_lo, mut seen_hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for i in 0..steps {
                let v = light(i as f64 / steps as f64);
                assert!(
                    v >= lo - 1e-12 && v <= hi + 1e-12,
                    "case {case}: {v} outside [{lo}, {hi}]"
                );
                seen_lo = seen_lo.min(v);
                seen_hi = seen_hi.max(v);
            }
            // Each die's ON fraction changes by at most 1 / width per cycle
            // of phase; the sweep's step is 1 / steps cycles.
            let width = shutter.exposure_s * f;
            let slack = 1.0 / (width * steps as f64);
            assert!(seen_lo - lo <= slack, "case {case}: {seen_lo} vs {lo}");
            assert!(hi - seen_hi <= slack, "case {case}: {seen_hi} vs {hi}");
        }
    }
}
