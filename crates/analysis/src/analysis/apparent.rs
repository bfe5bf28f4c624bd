//! Apparent (beat) frequency of the flicker a video shows.
//!
//! A camera samples the PWM once per frame, so the video shows the PWM
//! frequency aliased to the frame rate (docs/metrics.md, section 10):
//! `f_a = |f - fps * round(f / fps)|`, in `[0, fps / 2]`. Phase-locked
//! drives (`f = k * fps`) give 0: every frame sees the same phase. The
//! spectrum of a trace gives the same number from the data alone, which is
//! what a captured video offers.

use ledflicker_metrics::fft::{self, Complex};
pub use ledflicker_results::analysis::apparent::{ApparentMethod, Beat, SpectrumError};

/// Apparent frequency in Hz (`0..=fps/2`) of a PWM at `frequency_hz` seen at
/// `fps` frames per second: `|f - fps * round(f / fps)|`.
///
/// Plans state frequencies and frame rates as decimals (90.8 Hz, 29.97
/// fps), and the hazard bands have decimal edges (0.8 Hz), so the
/// reduction is done on those decimals exactly ([`decimal_remainder`]):
/// 90.8 Hz at 30 fps gives the `f64` nearest 0.8, as 30.8 and 150.8 Hz do,
/// not 0.79999999999999716. `f = k * fps` gives 0 exactly (59.94 Hz at
/// 29.97 fps). Values with more digits than an exact integer form holds
/// (a frame rate measured from timestamps, say) use the IEEE remainder.
pub fn apparent_frequency_hz(frequency_hz: f64, fps: f64) -> f64 {
    if let Some(r) = decimal_remainder(frequency_hz, fps) {
        return r.nearest_alias();
    }
    let r = frequency_hz.rem_euclid(fps);
    r.min(fps - r).max(0.0)
}

/// Signed phase advance per frame in PWM cycles, `f / fps - round(f / fps)`,
/// in `[-0.5, 0.5]`; exact for phase-locked drives (and computed on the
/// decimals, as [`apparent_frequency_hz`] is).
pub fn phase_step_cycles(frequency_hz: f64, fps: f64) -> f64 {
    if let Some(r) = decimal_remainder(frequency_hz, fps) {
        return r.signed_step();
    }
    let r = frequency_hz.rem_euclid(fps) / fps;
    if r > 0.5 { r - 1.0 } else { r }
}

/// `f mod fps` on the shortest decimals that print as `f` and `fps`: both
/// scaled by one power of ten to integers, reduced exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct DecimalRemainder {
    /// `f mod fps`, scaled: in `[0, fps_scaled)`.
    rem: i128,
    /// `fps`, scaled (> 0).
    fps: i128,
    /// The scale: the values are these integers times `10^exp`.
    exp: i32,
}

/// Largest integer an `f64` holds exactly (2^53).
const EXACT_INT: i128 = 1 << 53;

impl DecimalRemainder {
    /// `10^exp * n` as the `f64` nearest the exact decimal, when one
    /// rounding gives it (`n` and `10^|exp|` exact in an `f64`).
    fn scaled(&self, n: i128) -> Option<f64> {
        if n.abs() > EXACT_INT || !(-22..=22).contains(&self.exp) {
            return None;
        }
        let p = 10f64.powi(self.exp.abs());
        Some(if self.exp < 0 {
            n as f64 / p
        } else {
            n as f64 * p
        })
    }

    fn nearest_alias(&self) -> f64 {
        let d = self.rem.min(self.fps - self.rem);
        self.scaled(d)
            .unwrap_or_else(|| (d as f64) * 10f64.powi(self.exp))
    }

    fn signed_step(&self) -> f64 {
        let r = if 2 * self.rem > self.fps {
            self.rem - self.fps
        } else {
            self.rem
        };
        // One rounding when both are exact in an f64 (below 2^53).
        r as f64 / self.fps as f64
    }
}

/// The shortest decimal that prints as `x` (> 0, finite), as `(m, e)`
/// with `x = m * 10^e`; `None` when `m` would not fit.
fn decimal_of(x: f64) -> Option<(i128, i32)> {
    if !(x.is_finite() && x > 0.0) {
        return None;
    }
    // `{:e}` prints the shortest digits that read back as `x`.
    let text = format!("{x:e}");
    let (mantissa, exp) = text.split_once('e')?;
    let exp: i32 = exp.parse().ok()?;
    let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let digits = format!("{int}{frac}");
    let m: i128 = digits.parse().ok()?;
    Some((m, exp - i32::try_from(frac.len()).ok()?))
}

/// `f mod fps` exactly on their decimals (see [`DecimalRemainder`]);
/// `None` when either is not positive and finite or the scaled integers
/// would overflow.
fn decimal_remainder(f: f64, fps: f64) -> Option<DecimalRemainder> {
    let ((mf, ef), (mr, er)) = (decimal_of(f)?, decimal_of(fps)?);
    let exp = ef.min(er);
    let scale = |m: i128, e: i32| -> Option<i128> {
        m.checked_mul(10i128.checked_pow(u32::try_from(e - exp).ok()?)?)
    };
    let (f, fps) = (scale(mf, ef)?, scale(mr, er)?);
    Some(DecimalRemainder {
        rem: f.rem_euclid(fps),
        fps,
        exp,
    })
}

/// The beat of a PWM at `frequency_hz` seen at `fps` for `capture_s` seconds.
pub fn beat(frequency_hz: f64, fps: f64, capture_s: f64) -> Beat {
    let fa = apparent_frequency_hz(frequency_hz, fps);
    let period_s = (fa > 0.0).then(|| 1.0 / fa);
    let longer = period_s.is_none_or(|p| p > capture_s);
    let note = match period_s {
        None => format!(
            "phase locked: {frequency_hz} Hz is a multiple of {fps} fps, so every frame sees the same PWM phase and the video shows a constant level that depends only on the start phase"
        ),
        Some(p) if longer => format!(
            "near phase lock: the beat period {p:.3} s is longer than the {capture_s:.3} s capture, which shows only part of one beat"
        ),
        Some(p) => format!(
            "the video flickers at {fa:.4} Hz (one beat every {p:.4} s, {:.1} beats in the capture)",
            capture_s / p
        ),
    };
    Beat {
        apparent_frequency_hz: fa,
        method: ApparentMethod::FrameTimes,
        frame_rate_fps: fps,
        resolution_hz: None,
        period_s,
        capture_s,
        longer_than_capture: longer,
        note,
    }
}

/// The beat of a trace whose PWM frequency is unknown, from its spectrum
/// `measured` (at `fps` frames/s, over `capture_s` seconds, one bin
/// `resolution_hz`).
pub fn beat_from_spectrum(
    measured: &Result<f64, SpectrumError>,
    fps: f64,
    capture_s: f64,
    resolution_hz: f64,
) -> Beat {
    let (fa, note) = match measured {
        Ok(fa) => {
            let p = 1.0 / fa;
            (
                *fa,
                format!(
                    "the PWM frequency is unknown: measured from the LED trace's spectrum, the video flickers at {fa:.4} Hz (resolution {resolution_hz:.4} Hz, peak refined between bins; one beat every {p:.4} s, {:.1} beats in the capture at {fps:.4} fps); the strongest component is taken as the beat, though it can be an aliased PWM harmonic",
                    capture_s / p
                ),
            )
        }
        Err(e) => (
            0.0,
            format!("the PWM frequency is unknown and the LED trace's spectrum gives no beat: {e}"),
        ),
    };
    let period_s = (fa > 0.0).then(|| 1.0 / fa);
    Beat {
        apparent_frequency_hz: fa,
        method: ApparentMethod::Spectrum,
        frame_rate_fps: fps,
        resolution_hz: Some(resolution_hz),
        period_s,
        capture_s,
        longer_than_capture: period_s.is_none_or(|p| p > capture_s),
        note,
    }
}

/// Peak-to-peak below this fraction of the mean (or of 1 when the mean is
/// 0) counts as a constant trace: floating-point noise of the closed form
/// is ~1e-15.
pub const FLAT_RELATIVE: f64 = 1e-9;

/// Dominant frequency in Hz of a uniformly sampled trace (`fps` samples per
/// second), from the largest bin of its Hann-windowed, 8x zero-padded FFT,
/// refined by a parabola through the bin and its neighbours.
///
/// This is the strongest component, which is usually the apparent
/// frequency `f_a` but can be an aliased harmonic `k f` folded to the frame
/// rate (see [`aliased_harmonic`]). Accuracy: better than one bin,
/// `fps / x.len()`. Components below
/// `1.5 * fps / x.len()` are not resolved (the window's main lobe meets DC)
/// and give [`SpectrumError::Unresolved`].
pub fn dominant_frequency_hz(x: &[f64], fps: f64) -> Result<f64, SpectrumError> {
    let n = x.len();
    if n < 4 {
        return Err(SpectrumError::TooShort(n));
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let scale = mean.abs().max(1.0);
    if hi - lo <= FLAT_RELATIVE * scale {
        return Err(SpectrumError::Flat((hi - lo) / scale));
    }
    let len = (8 * n).next_power_of_two();
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            // Hann window.
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
            Complex::new((v - mean) * w, 0.0)
        })
        .chain(std::iter::repeat(Complex::new(0.0, 0.0)))
        .take(len)
        .collect();
    fft::forward(&mut buf);
    let mag: Vec<f64> = buf[..=len / 2].iter().map(|c| c.norm()).collect();
    let bin_hz = fps / len as f64;
    // Skip the main lobe around DC: below 1.5 resolution bins of the data.
    let min_hz = 1.5 * fps / n as f64;
    let first = ((min_hz / bin_hz).ceil() as usize).max(1);
    spectrum_peak_hz(&mag, first, bin_hz, min_hz, fps)
}

/// The frequency of the largest magnitude at or above bin `first` of a
/// spectrum sampled every `bin_hz`, refined by a parabola through the peak
/// and its neighbours; `Unresolved(min_hz)` when the peak is the first
/// allowed bin and the DC lobe's skirt below it is higher (a slow drift).
pub(super) fn spectrum_peak_hz(
    mag: &[f64],
    first: usize,
    bin_hz: f64,
    min_hz: f64,
    fps: f64,
) -> Result<f64, SpectrumError> {
    let (k, _) = mag.iter().enumerate().skip(first.min(mag.len() - 1)).fold(
        (0usize, f64::NEG_INFINITY),
        |(bk, bm), (i, &m)| {
            if m > bm { (i, m) } else { (bk, bm) }
        },
    );
    // A trace whose power sits at DC (a slow drift) peaks at the first
    // allowed bin, where the DC lobe's skirt is highest.
    let dc_skirt = mag[..first.min(mag.len())]
        .iter()
        .copied()
        .fold(0.0, f64::max);
    if k == first && dc_skirt > mag[k] {
        return Err(SpectrumError::Unresolved(min_hz));
    }
    let offset = if k > 0 && k + 1 < mag.len() {
        let (a, b, c) = (mag[k - 1], mag[k], mag[k + 1]);
        let d = a - 2.0 * b + c;
        if d < 0.0 {
            (0.5 * (a - c) / d).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    } else {
        0.0
    };
    Ok(((k as f64 + offset) * bin_hz).clamp(0.0, fps / 2.0))
}

/// The PWM harmonic `k` in `1..=8` whose alias `|k f - fps round(k f / fps)|`
/// lies within `tolerance_hz` of `measured_hz` (the lowest such `k`).
pub fn aliased_harmonic(
    measured_hz: f64,
    frequency_hz: f64,
    fps: f64,
    tolerance_hz: f64,
) -> Option<u32> {
    (1..=8u32).find(|&k| {
        (apparent_frequency_hz(k as f64 * frequency_hz, fps) - measured_hz).abs() <= tolerance_hz
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_physics::{PwmDrive, Shutter, ShutterModel};

    #[test]
    fn formula_gives_zero_at_phase_lock_and_folds_to_nyquist() {
        assert_eq!(apparent_frequency_hz(90.0, 30.0), 0.0);
        assert_eq!(apparent_frequency_hz(59.94, 29.97), 0.0);
        assert!((apparent_frequency_hz(50.0, 30.0) - 10.0).abs() < 1e-12);
        assert!((apparent_frequency_hz(45.0, 30.0) - 15.0).abs() < 1e-12);
        assert!((apparent_frequency_hz(91.0, 30.0) - 1.0).abs() < 1e-12);
        assert!((apparent_frequency_hz(1001.0, 30.0) - 11.0).abs() < 1e-12);
        assert!((phase_step_cycles(89.0, 30.0) + 1.0 / 30.0).abs() < 1e-12);
    }

    #[test]
    fn decimal_frequencies_alias_to_the_decimal_they_state() {
        // 90.8, 30.8 and 150.8 Hz at 30 fps all beat at 0.8 Hz: the same
        // f64, so the same hazard band (0.8 Hz is its lower edge).
        for f in [30.8, 90.8, 150.8, 1500.8] {
            assert_eq!(apparent_frequency_hz(f, 30.0), 0.8, "{f} Hz");
        }
        assert_eq!(apparent_frequency_hz(30.97, 29.97), 1.0);
        assert_eq!(apparent_frequency_hz(119.88, 29.97), 0.0);
        assert_eq!(apparent_frequency_hz(60.1, 60.0), 0.1);
        assert_eq!(phase_step_cycles(90.8, 30.0), 0.8 / 30.0);
        assert_eq!(phase_step_cycles(89.2, 30.0), -(0.8 / 30.0));
        assert_eq!(decimal_of(1e-7), Some((1, -7)));
        assert_eq!(decimal_of(29.97), Some((2997, -2)));
        assert_eq!(decimal_of(1.5e300), Some((15, 299)));
        // Too many digits for one integer form: the IEEE remainder.
        let fps = 30000.0 / 1001.0;
        assert!((apparent_frequency_hz(151.0, fps) - (151.0 - 5.0 * fps)).abs() < 1e-12);
        assert!(apparent_frequency_hz(1e300, 30.0).is_finite());
    }

    /// Brute force: the alias of f nearest to 0 among f - k fps, all k.
    #[test]
    fn formula_matches_a_brute_force_search_over_aliases() {
        for i in 0..500 {
            let f = 50.0 + i as f64 * 3.7;
            for fps in [25.0, 29.97, 30.0, 60.0] {
                let brute = (0..200)
                    .map(|k| (f - k as f64 * fps).abs())
                    .fold(f64::INFINITY, f64::min);
                let got = apparent_frequency_hz(f, fps);
                assert!(
                    (got - brute).abs() < 1e-9,
                    "f={f} fps={fps}: {got} vs {brute}"
                );
            }
        }
    }

    #[test]
    fn beat_longer_than_the_capture_says_so() {
        let b = beat(90.01, 30.0, 60.0);
        assert!(b.longer_than_capture, "{b:?}");
        assert!(b.note.contains("near phase lock"));
        let b = beat(90.0, 30.0, 60.0);
        assert_eq!(b.period_s, None);
        assert!(b.longer_than_capture && b.note.contains("phase locked"));
        let b = beat(100.0, 30.0, 60.0);
        assert!(!b.longer_than_capture);
        assert!((b.period_s.unwrap() - 0.1).abs() < 1e-12);
    }

    /// The spectrum of simulated traces agrees with the formula to a bin.
    #[test]
    fn spectrum_of_simulated_traces_matches_the_formula() {
        let fps = 30.0;
        let n = 1800;
        let shutter = Shutter {
            model: ShutterModel::Global,
            exposure_s: 0.004,
            fps,
        };
        let mut checked = 0;
        let mut fundamental = 0;
        for i in 0..60 {
            let f = 93.0 + i as f64 * 31.3;
            let fa = apparent_frequency_hz(f, fps);
            if fa < 0.2 {
                continue;
            }
            for duty in [0.1, 0.5, 0.8] {
                let pwm = PwmDrive::new(f, duty, 0.0).unwrap();
                let x: Vec<f64> = (0..n)
                    .map(|k| shutter.frame_on_fraction(&pwm, k, 0..1))
                    .collect();
                match dominant_frequency_hz(&x, fps) {
                    Ok(got) => {
                        // The strongest component is f_a, or an aliased
                        // harmonic of the PWM when few phases are visited.
                        let k = aliased_harmonic(got, f, fps, fps / n as f64);
                        assert!(
                            k.is_some(),
                            "f={f} D={duty}: spectrum {got} vs formula {fa}"
                        );
                        if k == Some(1) {
                            fundamental += 1;
                        }
                        checked += 1;
                    }
                    Err(SpectrumError::Flat(_)) => {}
                    Err(e) => panic!("f={f} D={duty}: {e}"),
                }
            }
        }
        assert!(checked > 100, "only {checked} traces checked");
        assert!(
            fundamental * 10 >= checked * 9,
            "{fundamental} of {checked} at the fundamental"
        );
    }

    #[test]
    fn constant_and_too_slow_traces_give_reasons() {
        assert!(matches!(
            dominant_frequency_hz(&[3.0; 100], 30.0),
            Err(SpectrumError::Flat(_))
        ));
        // Half a cycle of a very slow sine: the beat is longer than the capture.
        let x: Vec<f64> = (0..300)
            .map(|i| (std::f64::consts::PI * i as f64 / 600.0).sin())
            .collect();
        assert!(matches!(
            dominant_frequency_hz(&x, 30.0),
            Err(SpectrumError::Unresolved(_))
        ));
        assert!(matches!(
            dominant_frequency_hz(&[1.0, 2.0], 30.0),
            Err(SpectrumError::TooShort(2))
        ));
    }
}
