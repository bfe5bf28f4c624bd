//! Banding KPIs of a rolling shutter (Deegan 2018 section 2; docs/metrics.md,
//! section 10): under a diffusely lit PWM scene each row integrates its own
//! slice of the waveform, so a frame shows bands `1 / (f * t_line)` rows
//! apart that roll from frame to frame.
//!
//! Rows are rendered with the exact closed-form integral, LED light only
//! (no background): the largest contrast the bands can have.

use serde::{Deserialize, Serialize};

use super::apparent::phase_step_cycles;
use crate::physics::{PwmDrive, Shutter, ShutterModel};

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

/// LED-only ON fraction of every row `rows` of frame `frame`, exact.
pub fn row_profile(shutter: &Shutter, pwm: &PwmDrive, frame: u64, rows: u32) -> Vec<f64> {
    (0..rows)
        .map(|r| shutter.frame_on_fraction(pwm, frame, r..r + 1))
        .collect()
}

/// Band period in rows of a row profile, by the band estimator shared with
/// `linetime`, `bands` and `calibrate` ([`crate::calibrate::bands`]): the
/// fundamental of the periodic fit, refined below a row. An error says why
/// there is no confident estimate (e.g. fewer than 3 bands).
pub fn band_period_from_profile(profile: &[f64]) -> Result<f64, String> {
    crate::calibrate::bands::estimate_profile(profile)
        .map(|e| e.period_rows)
        .map_err(|e| e.to_string())
}

/// Banding KPIs; `None` for a global shutter or a zero line time.
pub fn banding(shutter: &Shutter, pwm: &PwmDrive, sensor_rows: u32) -> Option<Banding> {
    let ShutterModel::Rolling { line_time_s } = shutter.model else {
        return None;
    };
    if line_time_s <= 0.0 {
        return None;
    }
    let f = pwm.frequency_hz();
    let period = 1.0 / (f * line_time_s);
    let profile = row_profile(shutter, pwm, 0, sensor_rows);
    let (lo, hi) = profile
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let band_contrast_percent = (hi + lo > 0.0).then(|| 100.0 * (hi - lo) / (hi + lo));
    let (estimated_frequency_hz, estimate_note) = match band_period_from_profile(&profile) {
        Ok(p) => (Some(1.0 / (p * line_time_s)), None),
        Err(e) => (None, Some(e)),
    };
    Some(Banding {
        band_period_rows: period,
        bands_per_frame: sensor_rows as f64 / period,
        band_contrast_percent,
        band_velocity_rows_per_frame: -phase_step_cycles(f, shutter.fps) * period + 0.0,
        estimated_frequency_hz,
        estimate_note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rolling(line_time_s: f64, fps: f64) -> Shutter {
        Shutter {
            model: ShutterModel::Rolling { line_time_s },
            exposure_s: 1.0 / 16000.0,
            fps,
        }
    }

    #[test]
    fn bands_move_by_the_predicted_rows_per_frame() {
        // 1 kHz, 10 us lines: 100-row bands; 32 fps: a quarter cycle per frame.
        let s = rolling(10e-6, 32.0);
        let pwm = PwmDrive::new(1000.0, 0.5, 0.0).unwrap();
        let b = banding(&s, &pwm, 800).unwrap();
        assert!((b.band_period_rows - 100.0).abs() < 1e-9);
        assert!((b.band_velocity_rows_per_frame + 25.0).abs() < 1e-9);
        let f0 = row_profile(&s, &pwm, 0, 800);
        let f1 = row_profile(&s, &pwm, 1, 800);
        // Frame 1's row r shows what frame 0's row r + 25 showed: bands
        // moved up 25 rows.
        for r in 0..700 {
            assert!((f1[r] - f0[r + 25]).abs() < 1e-6, "row {r}");
        }
    }

    #[test]
    fn frequency_is_recovered_from_the_band_spacing() {
        // The gyroflow sample camera: 14.565 us per line
        // (reference-data/gyroflow-rs-banding/SOURCE.md).
        // 250 Hz gives 3.9 bands in 1080 rows (the estimator needs 3).
        for (f, d) in [(1000.0, 0.5), (613.0, 0.2), (2400.0, 0.1), (250.0, 0.7)] {
            let s = rolling(14.565e-6, 30.0);
            let pwm = PwmDrive::new(f, d, 0.0).unwrap();
            let b = banding(&s, &pwm, 1080).unwrap();
            let got = b.estimated_frequency_hz.unwrap();
            assert!((got - f).abs() / f < 2e-3, "f={f}: {got}");
            assert!(b.band_contrast_percent.unwrap() > 10.0);
        }
    }

    #[test]
    fn a_faint_ripple_under_a_long_exposure_gives_the_fundamental() {
        // The daylight plan's camera: 11.111 ms exposure, 11.111 PWM periods
        // at 1 kHz, so the bands are a 1 % trapezoid ripple. At 50 % duty
        // the even harmonics vanish and a sub-harmonic (7 periods, 481
        // rows) once won the periodogram; the exact check must undo it.
        let s = Shutter {
            exposure_s: 11.111e-3,
            ..rolling(14.565e-6, 30.0)
        };
        for d in [0.05, 0.2, 0.5] {
            let pwm = PwmDrive::new(1000.0, d, 0.0).unwrap();
            let b = banding(&s, &pwm, 800).unwrap();
            let got = b.estimated_frequency_hz.expect("an estimate");
            assert!((got - 1000.0).abs() < 0.5, "d={d}: {got}");
        }
        // Full duty: no ripple at all.
        let b = banding(&s, &PwmDrive::new(1000.0, 1.0, 0.0).unwrap(), 800).unwrap();
        assert_eq!(b.estimated_frequency_hz, None);
        assert!(b.estimate_note.unwrap().contains("flat"));
    }

    #[test]
    fn too_few_bands_or_global_shutter_give_no_estimate() {
        let s = rolling(14.565e-6, 30.0);
        // 50 Hz: 1373-row period, less than one band in 800 rows.
        let b = banding(&s, &PwmDrive::new(50.0, 0.5, 0.0).unwrap(), 800).unwrap();
        assert_eq!(b.estimated_frequency_hz, None);
        assert!(b.estimate_note.is_some());
        let g = Shutter {
            model: ShutterModel::Global,
            ..s
        };
        assert!(banding(&g, &PwmDrive::new(500.0, 0.5, 0.0).unwrap(), 800).is_none());
    }
}
