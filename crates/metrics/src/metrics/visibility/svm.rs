//! The stroboscopic visibility measure (SVM) of a light source's own
//! waveform, as the eye sees the light directly: CIE TN 006:2016, "Visual
//! aspects of time-modulated lighting systems", after Perz et al. (2015).
//! A light-source figure, like the IEEE 1789 ones, not a figure of the
//! camera or the monitor (docs/visibility.md, section 5).
//!
//! The waveform's Fourier components `C_m` (amplitude over the mean) at
//! `f_m` up to 2 kHz, each over the threshold modulation `T(f_m)` of the
//! stroboscopic effect, pooled by a Minkowski sum with exponent 3.7:
//! `SVM = (sum_m (C_m / T(f_m))^3.7)^(1/3.7)`; 1 is the threshold.

use crate::fft::{self, Complex};

use super::POOLING_EXPONENT;

/// Highest frequency of a component the SVM sums, Hz (CIE TN 006:2016).
pub const MAX_FREQUENCY_HZ: f64 = 2000.0;

/// Slowest sampling that holds every component the SVM sums, Hz.
pub const MIN_SAMPLE_RATE_HZ: f64 = 2.0 * MAX_FREQUENCY_HZ;

/// Slope of the threshold curve's logistic term, 1/Hz (CIE TN 006:2016).
const THRESHOLD_SLOPE_PER_HZ: f64 = 0.00518;
/// Midpoint of the threshold curve's logistic term, Hz (CIE TN 006:2016).
const THRESHOLD_MIDPOINT_HZ: f64 = 306.6;

/// Threshold modulation of the stroboscopic effect at `f_hz` (> 0) for the
/// standard observer (CIE TN 006:2016):
/// `T(f) = 1 / (1 + e^(-a (f - b))) + 20 e^(-f / 10)`, `a = 0.00518 /Hz`,
/// `b = 306.6 Hz`. Lowest, about 0.24, near 80 Hz; 1 far above 1 kHz.
pub fn threshold(f_hz: f64) -> f64 {
    1.0 / (1.0 + (-THRESHOLD_SLOPE_PER_HZ * (f_hz - THRESHOLD_MIDPOINT_HZ)).exp())
        + 20.0 * (-f_hz / 10.0).exp()
}

/// The SVM of Fourier components `(f, C)`: relative amplitude `C >= 0`
/// (amplitude over the mean) at `f` Hz. Components at 0 Hz or above
/// [`MAX_FREQUENCY_HZ`] are left out; one at it within rounding (1e-9,
/// relative) is in, so that a harmonic at 2 kHz stays in when the
/// sampling rate is measured from time stamps, one ulp off.
pub fn of_components(components: impl IntoIterator<Item = (f64, f64)>) -> f64 {
    components
        .into_iter()
        .filter(|&(f, _)| f > 0.0 && f <= MAX_FREQUENCY_HZ * (1.0 + 1e-9))
        .map(|(f, c)| (c / threshold(f)).powf(POOLING_EXPONENT))
        .sum::<f64>()
        .powf(1.0 / POOLING_EXPONENT)
}

/// The SVM of a PWM light, on for `duty` (0..=1) of each period of
/// `frequency_hz` (> 0), off (zero) otherwise: its harmonics `k f` have
/// `C_k = 2 |sin(pi k D)| / (pi k D)`, exactly.
pub fn of_pwm(frequency_hz: f64, duty: f64) -> f64 {
    let harmonics = (MAX_FREQUENCY_HZ / frequency_hz).floor() as usize;
    of_components((1..=harmonics).map(|k| {
        let x = std::f64::consts::PI * k as f64 * duty;
        (k as f64 * frequency_hz, 2.0 * x.sin().abs() / x)
    }))
}

/// Why a sampled waveform has no SVM.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SvmError {
    /// Fewer than two samples.
    #[error("the waveform has {0} samples; the SVM needs at least 2")]
    TooShort(usize),
    /// A sample is NaN or infinite.
    #[error("sample {0} of the waveform is not a finite number")]
    NotFinite(usize),
    /// The sampling misses components the SVM sums.
    #[error(
        "the waveform is sampled at {0} Hz, below the {MIN_SAMPLE_RATE_HZ} Hz that hold the components up to {MAX_FREQUENCY_HZ} Hz the SVM sums\n    hint: sample the light at 4 kHz or faster"
    )]
    SlowSampling(f64),
    /// The mean is zero or negative: no light to modulate.
    #[error(
        "the waveform's mean is {0}, not positive; the SVM is relative to the mean light\n    hint: give the light's level, with 0 for dark (an offset subtracted)"
    )]
    NoLight(f64),
}

/// The SVM of `samples` (the light's level, 0 = dark) taken at `rate_hz`.
///
/// The record is taken as one period of a periodic light, as the Fourier
/// series of CIE TN 006 defines the components: component `k` is at
/// `k rate / N` with `C_k = 2 |X_k| / (N mean)`, `X` the discrete Fourier
/// transform (rectangular window). A record of whole periods of the light
/// gives the light's own spectrum; a record cut mid-period spreads each
/// component over its neighbours.
pub fn of_samples(samples: &[f64], rate_hz: f64) -> Result<f64, SvmError> {
    components(samples, rate_hz).map(of_components)
}

/// The components [`of_samples`] sums: `(k rate / N, C_k)` for
/// `k = 1 .. ceil(N / 2) - 1`, each `C_k = 2 |X_k| / (N mean)`.
pub fn components(samples: &[f64], rate_hz: f64) -> Result<Vec<(f64, f64)>, SvmError> {
    let n = samples.len();
    if n < 2 {
        return Err(SvmError::TooShort(n));
    }
    if let Some(i) = samples.iter().position(|x| !x.is_finite()) {
        return Err(SvmError::NotFinite(i));
    }
    if !rate_hz.is_finite() || rate_hz < MIN_SAMPLE_RATE_HZ {
        return Err(SvmError::SlowSampling(rate_hz));
    }
    let mean = samples.iter().sum::<f64>() / n as f64;
    // The samples are finite, so the mean is too.
    if mean <= 0.0 {
        return Err(SvmError::NoLight(mean));
    }
    let mut buffer: Vec<Complex<f64>> = samples.iter().map(|&x| Complex::new(x, 0.0)).collect();
    fft::forward(&mut buffer);
    // Components below the Nyquist bin only: at `2k = N` the transform
    // holds the cosine alone, and `rate >= 4 kHz` puts it at or above the
    // 2 kHz the SVM stops at.
    Ok((1..n.div_ceil(2))
        .map(|k| {
            (
                k as f64 * rate_hz / n as f64,
                2.0 * buffer[k].norm() / (n as f64 * mean),
            )
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_light_has_no_stroboscopic_visibility() {
        // The FFT's rounding leaves about 1e-16 on each component.
        assert!(of_samples(&[3.0; 1000], 10_000.0).is_ok_and(|v| v < 1e-12));
        assert!(of_pwm(300.0, 1.0) < 1e-12);
    }

    #[test]
    fn a_sine_gives_its_modulation_over_the_threshold() {
        // 100 Hz, modulation 0.5, sampled over 4 whole periods.
        let rate = 20_000.0;
        let x: Vec<f64> = (0..800)
            .map(|i| 1.0 + 0.5 * (2.0 * std::f64::consts::PI * 100.0 * i as f64 / rate).sin())
            .collect();
        let svm = of_samples(&x, rate).unwrap();
        assert!((svm - 0.5 / threshold(100.0)).abs() < 1e-9, "{svm}");
    }

    #[test]
    fn the_threshold_is_lowest_near_80_hz_and_one_far_above() {
        let lowest = (20..2000)
            .map(|f| (f, threshold(f64::from(f))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!((60..140).contains(&lowest.0), "{lowest:?}");
        assert!((threshold(2000.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn bad_waveforms_are_named() {
        assert_eq!(of_samples(&[1.0], 1e4), Err(SvmError::TooShort(1)));
        assert_eq!(
            of_samples(&[1.0, f64::NAN], 1e4),
            Err(SvmError::NotFinite(1))
        );
        let slow = of_samples(&[1.0, 2.0], 1000.0).unwrap_err().to_string();
        assert!(slow.contains("1000 Hz") && slow.contains("hint"), "{slow}");
        assert!(matches!(
            of_samples(&[-1.0, 0.5], 1e4),
            Err(SvmError::NoLight(_))
        ));
    }
}
