//! Rolling-shutter line time from one frame of a diffusely lit PWM scene.
//!
//! A rolling shutter starts each row one line time after the previous one,
//! so a light flickering at `f` Hz paints horizontal bands with a period of
//! `1 / (f * t_line)` rows (DESIGN.md section 1). The estimate:
//! 1. the mean luma (BT.601) of every row;
//! 2. a quadratic fit is removed (vignetting, uneven lighting);
//! 3. a periodogram over band periods of 4 rows to a third of the frame
//!    finds the strongest period (Hann window against leakage);
//! 4. a golden-section search refines it by maximising the power of a
//!    least-squares sine fit;
//! 5. `t_line = 1 / (f * period)`.

use std::f64::consts::PI;

/// A line-time estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineTime {
    /// Line time, seconds.
    pub line_time_s: f64,
    /// Band period, rows per PWM period.
    pub band_period_rows: f64,
    /// Share of the detrended row-profile variance explained by the sine at
    /// the band frequency, 0..1 (a rough quality figure).
    pub fit_quality: f64,
    /// Rows in the profile.
    pub rows: usize,
}

/// Why no estimate could be made.
#[derive(Debug, thiserror::Error)]
pub enum LineTimeError {
    /// The image could not be read.
    #[error("cannot read image `{path}`: {message}")]
    Read {
        /// Path.
        path: String,
        /// Cause.
        message: String,
    },
    /// The image has too few rows or no banding.
    #[error("{0}")]
    NoBands(String),
}

/// Mean BT.601 luma of each row of the image at `path`.
pub fn row_profile(path: &std::path::Path) -> Result<Vec<f64>, LineTimeError> {
    let img = image::open(path).map_err(|e| LineTimeError::Read {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let rgb = img.to_rgb32f();
    let (w, h) = rgb.dimensions();
    Ok((0..h)
        .map(|y| {
            (0..w)
                .map(|x| {
                    let p = rgb.get_pixel(x, y).0;
                    0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64
                })
                .sum::<f64>()
                / w as f64
        })
        .collect())
}

/// Removes the least-squares quadratic in the row index.
fn detrend(y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let t: Vec<f64> = (0..n)
        .map(|i| 2.0 * i as f64 / (n - 1) as f64 - 1.0)
        .collect();
    // Legendre-like orthogonalisation of 1, t, t^2 on the samples.
    let mut basis: Vec<Vec<f64>> = vec![vec![1.0; n], t.clone(), t.iter().map(|x| x * x).collect()];
    for i in 0..basis.len() {
        for j in 0..i {
            let (a, b) = (basis[i].clone(), &basis[j]);
            let proj = dot(&a, b) / dot(b, b);
            basis[i] = a.iter().zip(b).map(|(x, y)| x - proj * y).collect();
        }
    }
    let mut r = y.to_vec();
    for b in &basis {
        let proj = dot(&r, b) / dot(b, b);
        for (ri, bi) in r.iter_mut().zip(b) {
            *ri -= proj * bi;
        }
    }
    r
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Power of the sine at `freq` (cycles per row) in `r`, least squares.
fn sine_power(r: &[f64], freq: f64, window: Option<&[f64]>) -> f64 {
    let (mut cc, mut ss, mut cs, mut yc, mut ys) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, &v) in r.iter().enumerate() {
        let w = window.map_or(1.0, |w| w[i]);
        let (s, c) = (2.0 * PI * freq * i as f64).sin_cos();
        let v = v * w;
        let (c, s) = (c * w, s * w);
        cc += c * c;
        ss += s * s;
        cs += c * s;
        yc += v * c;
        ys += v * s;
    }
    let det = cc * ss - cs * cs;
    if det.abs() < 1e-12 {
        return 0.0;
    }
    let a = (yc * ss - ys * cs) / det;
    let b = (ys * cc - yc * cs) / det;
    a * yc + b * ys
}

/// Estimates the line time from a row profile and the PWM frequency (Hz).
pub fn estimate(profile: &[f64], frequency_hz: f64) -> Result<LineTime, LineTimeError> {
    let n = profile.len();
    if n < 16 {
        return Err(LineTimeError::NoBands(format!(
            "the image has {n} rows; at least 16 are needed"
        )));
    }
    let r = detrend(profile);
    let total: f64 = dot(&r, &r);
    if total <= 1e-12 * n as f64 {
        return Err(LineTimeError::NoBands(
            "the rows are uniform: no banding to measure\n    hint: use a frame of a diffusely lit PWM scene, exposure shorter than the PWM period".to_string(),
        ));
    }
    let hann: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / (n - 1) as f64).cos())
        .collect();
    // Coarse grid: from 3 bands per frame to a 4-row period.
    let (f_lo, f_hi) = (3.0 / n as f64, 0.25);
    let step = 0.1 / n as f64;
    let steps = ((f_hi - f_lo) / step) as usize;
    let mut best = (0.0, f_lo);
    for k in 0..=steps {
        let f = f_lo + k as f64 * step;
        let p = sine_power(&r, f, Some(&hann));
        if p > best.0 {
            best = (p, f);
        }
    }
    // Golden-section refinement on the unwindowed fit.
    let (mut a, mut b) = ((best.1 - step).max(f_lo), (best.1 + step).min(f_hi));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..60 {
        let c = b - g * (b - a);
        let d = a + g * (b - a);
        if sine_power(&r, c, None) > sine_power(&r, d, None) {
            b = d;
        } else {
            a = c;
        }
    }
    let f = 0.5 * (a + b);
    let quality = (sine_power(&r, f, None) / total).clamp(0.0, 1.0);
    let period = 1.0 / f;
    Ok(LineTime {
        line_time_s: 1.0 / (frequency_hz * period),
        band_period_rows: period,
        fit_quality: quality,
        rows: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_wave_bands_give_back_the_line_time() {
        // 1000 Hz, 50 % duty, 14.565 us per row, short exposure, vignetting.
        let (f, t_line) = (1000.0, 14.565e-6);
        let profile: Vec<f64> = (0..1080)
            .map(|row| {
                let phase = (row as f64 * t_line * f).fract();
                let x = row as f64 / 1080.0 - 0.5;
                (if phase < 0.5 { 200.0 } else { 20.0 }) * (1.0 - 0.3 * x * x)
            })
            .collect();
        let e = estimate(&profile, f).unwrap();
        assert!((e.line_time_s / t_line - 1.0).abs() < 1e-3, "{e:?}");
        assert!((e.band_period_rows - 68.66).abs() < 0.1, "{e:?}");
    }

    #[test]
    fn uniform_frame_is_an_error_not_a_number() {
        assert!(estimate(&[5.0; 100], 1000.0).is_err());
    }
}
