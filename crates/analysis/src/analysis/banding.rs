//! Banding of a rolling shutter (Deegan 2018 section 2; docs/metrics.md,
//! section 10): under a diffusely lit PWM scene each row integrates its own
//! slice of the waveform, so a frame shows bands `1 / (f * t_line)` rows
//! apart that roll from frame to frame.
//!
//! The one banding analysis of a row profile: its row contrast and its band
//! period, by the band estimator of `linetime`, `bands` and `calibrate`
//! ([`crate::calibrate::bands`]). It serves the case KPIs ([`banding`]: rows
//! rendered with the exact closed-form integral, LED light only, no
//! background, so the largest contrast the bands can have) and the row
//! analysis of a case's sample frame ([`frame_banding`]).

use super::apparent::phase_step_cycles;
use crate::calibrate::bands::{band_period_rows, estimate_profile};
use ledflicker_physics::{PwmDrive, Shutter, ShutterModel};
use ledflicker_plan::trace::RenderedFrame;
pub use ledflicker_results::analysis::banding::{Banding, FrameBanding, NO_BANDS_CONTRAST_PERCENT};

/// LED-only ON fraction of every row `rows` of frame `frame`, exact.
pub fn row_profile(shutter: &Shutter, pwm: &PwmDrive, frame: u64, rows: u32) -> Vec<f64> {
    (0..rows)
        .map(|r| shutter.frame_on_fraction(pwm, frame, r..r + 1))
        .collect()
}

/// Lowest and highest value of a row profile, NaN rows left out
/// (`(+inf, -inf)` when no row is left).
fn extremes(profile: &[f64]) -> (f64, f64) {
    profile
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        })
}

/// Michelson contrast x 100 of a row profile's extremes `(lo, hi)`, 0..=100
/// for non-negative rows; `None` when no row sees light (`hi + lo <= 0`).
fn contrast_percent((lo, hi): (f64, f64)) -> Option<f64> {
    (hi + lo > 0.0).then(|| 100.0 * (hi - lo) / (hi + lo))
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
    let period = band_period_rows(f, line_time_s);
    let profile = row_profile(shutter, pwm, 0, sensor_rows);
    let band_contrast_percent = contrast_percent(extremes(&profile));
    let (estimated_frequency_hz, estimate_note) = match estimate_profile(&profile) {
        Ok(e) => (Some(e.frequency_hz(line_time_s).0), None),
        Err(e) => (None, Some(e.to_string())),
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

/// Row means of `frame` over the pixel columns `columns` (clipped to the
/// frame); empty when none is left.
pub fn frame_row_means(frame: &RenderedFrame, columns: std::ops::Range<u32>) -> Vec<f64> {
    let w = frame.width;
    let (x0, x1) = (columns.start.min(w), columns.end.min(w));
    if x1 <= x0 {
        return Vec::new();
    }
    (0..frame.height)
        .map(|y| {
            // Pixel by pixel, left to right: the same sum as over a slice.
            let mut sum = 0.0;
            frame.for_each_in_row(y, (x0, x1), |_, v| sum += v);
            sum / f64::from(x1 - x0)
        })
        .collect()
}

/// Banding of `frame` in the pixel columns `columns` (an LED's): the lit
/// rows, their contrast and, from [`NO_BANDS_CONTRAST_PERCENT`] up, their
/// band period; `None` when no row differs from the darkest.
pub fn frame_banding(frame: &RenderedFrame, columns: std::ops::Range<u32>) -> Option<FrameBanding> {
    let profile = frame_row_means(frame, columns);
    let (lo, hi) = extremes(&profile);
    if hi - lo <= 1e-9 || hi.is_nan() || lo.is_nan() {
        return None;
    }
    // Lit: more than 5 % of the way from the darkest row to the brightest.
    let lit = |v: &f64| *v > lo + 0.05 * (hi - lo);
    let first = profile.iter().position(lit)?;
    let last = profile.iter().rposition(lit)?;
    let span = &profile[first..=last];
    let row_contrast_percent = contrast_percent(extremes(span)).unwrap_or(0.0);
    let band_period_rows = (row_contrast_percent >= NO_BANDS_CONTRAST_PERCENT)
        .then(|| estimate_profile(span).ok().map(|e| e.period_rows))
        .flatten();
    Some(FrameBanding {
        lit_rows: (first as u32, last as u32),
        row_contrast_percent,
        band_period_rows,
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

    #[test]
    fn a_frame_of_the_exact_rows_gives_the_kpis_band_period_and_contrast() {
        // The case KPIs and the sample frame's row analysis are one
        // analysis: on a frame whose rows are the exact LED-only profile
        // (a bright panel over a dark background column), they agree.
        let s = rolling(14.565e-6, 30.0);
        let pwm = PwmDrive::new(1000.0, 0.3, 0.0).unwrap();
        let kpi = banding(&s, &pwm, 800).unwrap();
        let rows = row_profile(&s, &pwm, 0, 800);
        let (w, h) = (8, 800);
        let luma: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if x < 6 { 10.0 + 200.0 * rows[y] } else { 0.0 }
            })
            .collect();
        let frame = RenderedFrame::from_pixels(0, w as u32, h as u32, &luma, 255.0);
        let b = frame_banding(&frame, 0..6).unwrap();
        let p = b.band_period_rows.expect("a band period");
        let p_kpi = 1.0 / (kpi.estimated_frequency_hz.unwrap() * 14.565e-6);
        assert!((p - p_kpi).abs() < 1e-3 * p_kpi, "{p} vs {p_kpi}");
        assert!((p - kpi.band_period_rows).abs() < 1e-3 * p, "{p}");
        // 10 DN of the panel's own at the darkest row: (210 - 10) / 220.
        let want = 100.0 * 200.0 / 220.0;
        assert!(
            (b.row_contrast_percent - want).abs() < 1e-6,
            "{}",
            b.row_contrast_percent
        );
        assert!((kpi.band_contrast_percent.unwrap() - 100.0).abs() < 1e-9);
        // Columns past the frame are clipped; none left gives no analysis.
        assert_eq!(frame_row_means(&frame, 6..100).len(), h);
        assert_eq!(frame_banding(&frame, 8..100), None);
    }
}
