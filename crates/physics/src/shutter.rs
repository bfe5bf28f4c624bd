//! Global and rolling shutters: when each row of each frame is exposed, and
//! how much LED light the ROI rows collect.
//!
//! Frame `k` starts at `k / fps` (never a running sum). Row `r` of a rolling
//! shutter starts `r * line_time` later than row 0. Only the ROI rows are
//! integrated: a metric on a 2-row ROI needs two integrals per frame, not a
//! rendered picture.

use std::ops::Range;

use super::pwm::{PwmDrive, on_fraction};

/// How the rows of a frame are exposed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShutterModel {
    /// Every row starts its exposure at the same instant.
    Global,
    /// Row `r` starts `r * line_time_s` after row 0.
    Rolling {
        /// Line time in seconds (>= 0).
        line_time_s: f64,
    },
}

/// Exposure timing of a camera: shutter model, exposure time and frame rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shutter {
    /// Global or rolling.
    pub model: ShutterModel,
    /// Exposure time of each row in seconds (> 0).
    pub exposure_s: f64,
    /// Frame rate in frames per second (> 0).
    pub fps: f64,
}

impl Shutter {
    /// Offset of row `row`'s exposure start from row 0, in seconds.
    pub fn row_offset_s(&self, row: u32) -> f64 {
        match self.model {
            ShutterModel::Global => 0.0,
            ShutterModel::Rolling { line_time_s } => row as f64 * line_time_s,
        }
    }

    /// The rows whose exposures differ; a global shutter integrates one row
    /// for the whole ROI because every row sees the same light.
    pub(crate) fn distinct_rows(&self, rows: Range<u32>) -> Range<u32> {
        match self.model {
            ShutterModel::Global => rows.start..rows.start + 1,
            ShutterModel::Rolling { line_time_s: 0.0 } => rows.start..rows.start + 1,
            ShutterModel::Rolling { .. } => rows,
        }
    }

    /// Mean fraction (0..=1) of the exposure during which the LED was ON,
    /// averaged over the ROI rows `rows` (start inclusive, end exclusive,
    /// non-empty), for frame `frame`.
    pub fn frame_on_fraction(&self, pwm: &PwmDrive, frame: u64, rows: Range<u32>) -> f64 {
        let width = self.exposure_s * pwm.frequency_hz();
        let rows = self.distinct_rows(rows);
        let n = rows.len() as f64;
        let sum: f64 = rows
            .map(|r| {
                let phase = pwm.phase_at(frame, self.fps, self.row_offset_s(r));
                on_fraction(phase, width, pwm.duty())
            })
            .sum();
        sum / n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rolling(line_time_s: f64) -> Shutter {
        Shutter {
            model: ShutterModel::Rolling { line_time_s },
            exposure_s: 0.0037,
            fps: 30.0,
        }
    }

    #[test]
    fn rolling_shutter_with_zero_line_time_matches_global() {
        let global = Shutter {
            model: ShutterModel::Global,
            ..rolling(0.0)
        };
        for &(f, d, delay) in &[(100.0, 0.2, 0.0), (437.0, 0.65, 0.0011), (60.0, 0.05, 0.3)] {
            let pwm = PwmDrive::new(f, d, delay).unwrap();
            for frame in 0..200 {
                let a = rolling(0.0).frame_on_fraction(&pwm, frame, 10..30);
                let b = global.frame_on_fraction(&pwm, frame, 10..30);
                assert!((a - b).abs() < 1e-15, "f={f} frame={frame}: {a} vs {b}");
            }
            assert_eq!(
                rolling(0.0).phase_envelope(&pwm, 10..30),
                global.phase_envelope(&pwm, 10..30)
            );
        }
    }

    #[test]
    fn exposure_of_whole_periods_gives_no_modulation() {
        for &(f, k) in &[(100.0, 1.0), (250.0, 3.0), (1000.0, 11.0)] {
            for &model in &[
                ShutterModel::Global,
                ShutterModel::Rolling {
                    line_time_s: 14.565e-6,
                },
            ] {
                let shutter = Shutter {
                    model,
                    exposure_s: k / f,
                    fps: 29.97,
                };
                let pwm = PwmDrive::new(f, 0.35, 0.000_123).unwrap();
                let (lo, hi) = shutter.phase_envelope(&pwm, 0..2);
                assert!((hi - lo).abs() < 1e-12, "f={f} k={k}: {lo}..{hi}");
                for frame in 0..100 {
                    let v = shutter.frame_on_fraction(&pwm, frame, 0..2);
                    assert!((v - 0.35).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn phase_envelope_bounds_a_dense_phase_sweep_and_is_attained() {
        let shutter = rolling(20e-6);
        for &(f, d) in &[(90.0, 0.1), (150.0, 0.2), (613.0, 0.7), (1000.0, 0.05)] {
            let (lo, hi) = shutter.phase_envelope(&PwmDrive::new(f, d, 0.0).unwrap(), 0..7);
            let mut slo = f64::INFINITY;
            let mut shi = f64::NEG_INFINITY;
            for i in 0..20_000 {
                let delay = i as f64 / 20_000.0 / f;
                let pwm = PwmDrive::new(f, d, delay).unwrap();
                let v = shutter.frame_on_fraction(&pwm, 0, 0..7);
                slo = slo.min(v);
                shi = shi.max(v);
            }
            assert!(
                lo <= slo + 1e-12 && hi >= shi - 1e-12,
                "envelope not a bound"
            );
            // The sweep's step is 1/20000 cycle; the mean's slope is at most
            // 2 / width per cycle, so the sweep comes within that of the corners.
            let tol = 2.0 / (shutter.exposure_s * f) / 20_000.0 + 1e-12;
            assert!(
                slo - lo <= tol && hi - shi <= tol,
                "f={f}: {lo}..{hi} vs {slo}..{shi}"
            );
        }
    }
}
