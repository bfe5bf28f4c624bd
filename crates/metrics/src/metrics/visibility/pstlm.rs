//! The short-term flicker indicator PstLM of a light source's own
//! waveform: the light flickermeter of IEC TR 61547-1:2015, which is the
//! flickermeter of IEC 61000-4-15 fed with the light instead of the mains
//! voltage, its lamp model taken out. A light-source figure next to the
//! SVM ([`super::svm`]): flicker seen directly (below about 80 Hz), where
//! the SVM is the stroboscopic effect (docs/visibility.md, section 5).
//!
//! The chain, each filter discretised by the bilinear transform:
//! 1. the light over its mean, minus 1 (relative fluctuation);
//! 2. the eye: a first-order high-pass at 0.05 Hz, a 6th-order Butterworth
//!    low-pass at 35 Hz (both IEC 61000-4-15 block 3) and the weighting
//!    filter of IEC TR 61547-1 (the block-3 weighting filter of IEC
//!    61000-4-15 without its 60 W incandescent lamp);
//! 3. the brain: squaring and a first-order sliding mean of 300 ms, scaled
//!    so that a sinusoidal fluctuation of 0.63 % peak to peak at 8.8 Hz
//!    peaks at an instantaneous flicker sensation `P_inst` of 1;
//! 4. statistics over `P_inst`: `PstLM = sqrt(0.0314 P0.1 + 0.0525 P1s +
//!    0.0657 P3s + 0.28 P10s + 0.08 P50s)` with the smoothed percentiles
//!    of IEC 61000-4-15. 1 is the threshold of irritability IEC
//!    61000-4-15 calibrates its Pst to.

use crate::fft::Complex;
use std::f64::consts::PI;

/// The filters' settling time left out of the statistics, s: the 0.05 Hz
/// high-pass's time constant is 3.2 s, and the relative fluctuation starts
/// at zero mean, so its transient has died away after 10 s.
pub const SETTLE_S: f64 = 10.0;

/// Shortest record, s: the settling time and 10 s of statistics.
pub const MIN_DURATION_S: f64 = 20.0;

/// Slowest sampling the chain is defined for, Hz: its low-pass stops at
/// 35 Hz, and the bilinear transform bends the filters' frequency axis by
/// under 0.4 % up to 35 Hz from 2 kHz up.
pub const MIN_SAMPLE_RATE_HZ: f64 = 2000.0;

/// Peak-to-peak relative fluctuation of the 8.8 Hz sine that gives
/// `P_inst` = 1 at its peak (W. Mombauer, "Calculating a new reference
/// point for the IEC-flickermeter", ETEP 8(6), 1998; the reference point
/// the Aalto light flickermeter uses).
pub const REFERENCE_FLUCTUATION: f64 = 0.0063;

/// Frequency of the reference sine, Hz (IEC 61000-4-15).
pub const REFERENCE_FREQUENCY_HZ: f64 = 8.8;

/// Weighting filter of IEC TR 61547-1 (Annex A), `N(s) / D(s)`, the
/// coefficients of `s^4 .. s^0` as the TR prints them (its `s^3`
/// numerator coefficient read as 44.758: the printed "44 758" is a
/// misprint, 1000 times the value the filter's response needs).
const WEIGHTING_NUMERATOR: [f64; 5] = [0.041661, 44.758, 2715.6, 29839.0, 0.0];
const WEIGHTING_DENOMINATOR: [f64; 5] = [1.0, 196.32, 11781.0, 534820.0, 3_505_380.0];

/// IEC 61000-4-15 weighting-filter frequencies, Hz, whose factors the TR's
/// filter keeps: the zero `omega2` and the real poles `omega3`, `omega4`;
/// where the search for those roots of the TR's coefficients starts.
const OMEGA2_HZ: f64 = 2.27979;
const OMEGA3_HZ: f64 = 1.22535;
const OMEGA4_HZ: f64 = 21.9;

/// Why a waveform has no PstLM.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PstError {
    /// The record is shorter than [`MIN_DURATION_S`].
    #[error(
        "the waveform lasts {0:.3} s; PstLM needs at least {MIN_DURATION_S} s ({SETTLE_S} s for the filters to settle)\n    hint: record the light for 20 s or more (IEC 61000-4-15 takes 10 minutes)"
    )]
    TooShort(f64),
    /// A sample is NaN or infinite.
    #[error("sample {0} of the waveform is not a finite number")]
    NotFinite(usize),
    /// The sampling is too slow (or not a finite positive rate).
    #[error(
        "the waveform is sampled at {0} Hz, below the {MIN_SAMPLE_RATE_HZ} Hz the flickermeter's filters are defined for\n    hint: sample the light at 2 kHz or faster"
    )]
    SlowSampling(f64),
    /// The mean is zero or negative: no light to fluctuate.
    #[error(
        "the waveform's mean is {0}, not positive; PstLM is relative to the mean light\n    hint: give the light's level, with 0 for dark (an offset subtracted)"
    )]
    NoLight(f64),
}

/// The light flickermeter's result for one record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PstLm {
    /// The short-term flicker indicator (>= 0; 1 = the threshold).
    pub pst: f64,
    /// Largest instantaneous flicker sensation after settling (>= 0).
    pub p_inst_max: f64,
}

/// A digital filter section `b(z) / a(z)` of order 1 or 2, direct form II
/// transposed (`a[0]` = 1).
#[derive(Debug, Clone, Copy)]
struct Section {
    b: [f64; 3],
    a: [f64; 3],
}

impl Section {
    /// The bilinear transform `s = 2 fs (1 - z^-1) / (1 + z^-1)` of
    /// `num(s) / den(s)`, coefficients in ascending powers of `s`, degree
    /// at most 2 (a first-order section when both have `[2] == 0`).
    fn bilinear(num: [f64; 3], den: [f64; 3], rate_hz: f64) -> Section {
        let k = 2.0 * rate_hz;
        let map = |p: [f64; 3]| {
            if num[2] == 0.0 && den[2] == 0.0 {
                [p[0] + p[1] * k, p[0] - p[1] * k, 0.0]
            } else {
                [
                    p[0] + p[1] * k + p[2] * k * k,
                    2.0 * p[0] - 2.0 * p[2] * k * k,
                    p[0] - p[1] * k + p[2] * k * k,
                ]
            }
        };
        let (b, a) = (map(num), map(den));
        Section {
            b: b.map(|x| x / a[0]),
            a: a.map(|x| x / a[0]),
        }
    }

    /// Filters `x` in place from rest.
    fn run(&self, x: &mut [f64]) {
        let (mut s1, mut s2) = (0.0, 0.0);
        for v in x.iter_mut() {
            let y = self.b[0] * *v + s1;
            s1 = self.b[1] * *v - self.a[1] * y + s2;
            s2 = self.b[2] * *v - self.a[2] * y;
            *v = y;
        }
    }

    /// Magnitude of the response at `f_hz`.
    fn gain(&self, f_hz: f64, rate_hz: f64) -> f64 {
        let z1 = Complex::from_polar(1.0, -2.0 * PI * f_hz / rate_hz);
        let poly = |c: [f64; 3]| Complex::new(c[0], 0.0) + z1 * c[1] + z1 * z1 * c[2];
        (poly(self.b) / poly(self.a)).norm()
    }
}

/// The weighting filter factored: two sections' numerators and
/// denominators in `s` (ascending powers), the real roots next to IEC
/// 61000-4-15's `omega2`, `omega3`, `omega4` (rad/s, negative) and the
/// largest remainder of the divisions relative to the coefficients.
struct Weighting {
    numerators: [[f64; 3]; 2],
    denominators: [[f64; 3]; 2],
    // The filter needs the sections only; the tests hold the roots and
    // the remainder to the published figures.
    #[cfg_attr(not(test), allow(dead_code))]
    roots: [f64; 3],
    #[cfg_attr(not(test), allow(dead_code))]
    remainder: f64,
}

/// A real root of `p` (descending powers) by Newton's method from
/// `guess`, and `p` divided by `(s - root)`: the quotient's descending
/// coefficients and the remainder (zero at an exact root).
fn deflate(p: &[f64], guess: f64) -> (f64, Vec<f64>, f64) {
    let horner = |x: f64| {
        let mut value = 0.0;
        let mut slope = 0.0;
        for &c in p {
            slope = slope * x + value;
            value = value * x + c;
        }
        (value, slope)
    };
    let mut root = guess;
    for _ in 0..50 {
        let (value, slope) = horner(root);
        if slope == 0.0 {
            break;
        }
        root -= value / slope;
    }
    let mut quotient = Vec::with_capacity(p.len() - 1);
    let mut carry = 0.0;
    for &c in &p[..p.len() - 1] {
        carry = carry * root + c;
        quotient.push(carry);
    }
    let remainder = carry * root + p[p.len() - 1];
    (root, quotient, remainder)
}

/// The TR's weighting filter, exactly as its coefficients give it, as two
/// second-order sections in `s` (ascending powers): the factors of IEC
/// 61000-4-15's filter `s (s + omega2) / ((s + omega3)(s + omega4))`, the
/// real roots found next to their published frequencies, and what the
/// TR's coefficients leave over them: the eye's resonance (poles near
/// 4.1 +- 8.2i Hz) over the two zeros that take out the lamp (near 7.9 and
/// 161 Hz).
fn weighting_sections() -> Weighting {
    let w = |hz: f64| -2.0 * PI * hz;
    // The numerator's s^0 coefficient is 0: the factor s.
    let (r2, lamp, rem2) = deflate(&WEIGHTING_NUMERATOR[..4], w(OMEGA2_HZ));
    let (r3, cubic, rem3) = deflate(&WEIGHTING_DENOMINATOR, w(OMEGA3_HZ));
    let (r4, eye, rem4) = deflate(&cubic, w(OMEGA4_HZ));
    let remainder = (rem2.abs() / WEIGHTING_NUMERATOR[3])
        .max(rem3.abs() / WEIGHTING_DENOMINATOR[4])
        .max(rem4.abs() / WEIGHTING_DENOMINATOR[4]);
    Weighting {
        numerators: [[lamp[2], lamp[1], lamp[0]], [0.0, -r2, 1.0]],
        denominators: [[eye[2], eye[1], eye[0]], [r3 * r4, -(r3 + r4), 1.0]],
        roots: [r2, r3, r4],
        remainder,
    }
}

/// The eye's filters at `rate_hz`: high-pass, Butterworth, weighting.
fn eye(rate_hz: f64) -> Vec<Section> {
    let tau_hp = 1.0 / (2.0 * PI * 0.05);
    let mut sections = vec![Section::bilinear(
        [0.0, tau_hp, 0.0],
        [1.0, tau_hp, 0.0],
        rate_hz,
    )];
    // 6th-order Butterworth: pole pairs with damping 2 sin((2k - 1) pi / 12).
    let w0 = 2.0 * PI * 35.0;
    for k in 1..=3 {
        let damping = 2.0 * ((2 * k - 1) as f64 * PI / 12.0).sin();
        sections.push(Section::bilinear(
            [1.0, 0.0, 0.0],
            [1.0, damping / w0, 1.0 / (w0 * w0)],
            rate_hz,
        ));
    }
    let weighting = weighting_sections();
    for (n, d) in weighting.numerators.into_iter().zip(weighting.denominators) {
        sections.push(Section::bilinear(n, d, rate_hz));
    }
    sections
}

/// The 300 ms sliding mean (first-order low-pass) of IEC 61000-4-15.
fn sliding_mean(rate_hz: f64) -> Section {
    Section::bilinear([1.0, 0.0, 0.0], [1.0, 0.3, 0.0], rate_hz)
}

/// The instantaneous flicker sensation `P_inst` of every sample of
/// `samples` (the light's level, 0 = dark) taken at `rate_hz`, from rest
/// (the first [`SETTLE_S`] seconds hold the filters' transient).
pub fn instantaneous(samples: &[f64], rate_hz: f64) -> Result<Vec<f64>, PstError> {
    if !rate_hz.is_finite() || rate_hz < MIN_SAMPLE_RATE_HZ {
        return Err(PstError::SlowSampling(rate_hz));
    }
    let duration = samples.len() as f64 / rate_hz;
    if duration < MIN_DURATION_S {
        return Err(PstError::TooShort(duration));
    }
    if let Some(i) = samples.iter().position(|x| !x.is_finite()) {
        return Err(PstError::NotFinite(i));
    }
    let mean = samples.iter().sum::<f64>() / samples.len() as f64;
    if mean <= 0.0 {
        return Err(PstError::NoLight(mean));
    }
    let mut x: Vec<f64> = samples.iter().map(|v| v / mean - 1.0).collect();
    let eye = eye(rate_hz);
    for s in &eye {
        s.run(&mut x);
    }
    let brain = sliding_mean(rate_hz);
    // A sine of amplitude A after the eye squares to A^2/2 (1 - cos 2wt);
    // the sliding mean keeps the mean and |LP(2w)| of the ripple, so the
    // peak is A^2/2 (1 + |LP(2w)|): the reference sine's peak is set to 1.
    let f = REFERENCE_FREQUENCY_HZ;
    let amplitude =
        REFERENCE_FLUCTUATION / 2.0 * eye.iter().map(|s| s.gain(f, rate_hz)).product::<f64>();
    let peak = amplitude * amplitude / 2.0 * (1.0 + brain.gain(2.0 * f, rate_hz));
    for v in x.iter_mut() {
        *v = *v * *v / peak;
    }
    brain.run(&mut x);
    Ok(x)
}

/// PstLM of `samples` (the light's level, 0 = dark; at least
/// [`MIN_DURATION_S`] at [`MIN_SAMPLE_RATE_HZ`] or faster).
///
/// The percentiles are of `P_inst` after [`SETTLE_S`], exact (sorted
/// samples, linearly interpolated) where a meter classifies into bins:
/// `Px` is the level exceeded `x` % of the time, smoothed as IEC
/// 61000-4-15 does: `P1s = (P0.7 + P1 + P1.5) / 3`, `P3s = (P2.2 + P3 +
/// P4) / 3`, `P10s = (P6 + P8 + P10 + P13 + P17) / 5`, `P50s = (P30 + P50 +
/// P80) / 3`.
pub fn of_samples(samples: &[f64], rate_hz: f64) -> Result<PstLm, PstError> {
    let p_inst = instantaneous(samples, rate_hz)?;
    let settle = ((SETTLE_S * rate_hz).round() as usize).min(p_inst.len() - 1);
    let mut sorted = p_inst[settle..].to_vec();
    sorted.sort_by(f64::total_cmp);
    let exceeded = |percent: f64| {
        let position = (1.0 - percent / 100.0) * (sorted.len() - 1) as f64;
        let i = position.floor() as usize;
        let above = sorted[(i + 1).min(sorted.len() - 1)];
        sorted[i] + (position - i as f64) * (above - sorted[i])
    };
    let mean = |ps: &[f64]| ps.iter().map(|&p| exceeded(p)).sum::<f64>() / ps.len() as f64;
    let sum = 0.0314 * exceeded(0.1)
        + 0.0525 * mean(&[0.7, 1.0, 1.5])
        + 0.0657 * mean(&[2.2, 3.0, 4.0])
        + 0.28 * mean(&[6.0, 8.0, 10.0, 13.0, 17.0])
        + 0.08 * mean(&[30.0, 50.0, 80.0]);
    Ok(PstLm {
        // The squares are never negative; the bilinear filters' rounding
        // cannot take a sum of them below zero.
        pst: sum.max(0.0).sqrt(),
        p_inst_max: sorted[sorted.len() - 1],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(f: f64, fluctuation: f64, rate: f64, seconds: f64) -> Vec<f64> {
        (0..(seconds * rate) as usize)
            .map(|i| 1.0 + fluctuation / 2.0 * (2.0 * PI * f * i as f64 / rate).sin())
            .collect()
    }

    #[test]
    fn the_weighting_filter_factors_as_iec_61000_4_15_without_its_lamp() {
        let Weighting {
            numerators,
            denominators,
            roots,
            remainder,
        } = weighting_sections();
        assert!(remainder < 1e-12, "{remainder}");
        // IEC 61000-4-15's omega2, omega3 and omega4 to the TR's 5
        // significant digits.
        for (root, hz) in roots.iter().zip([OMEGA2_HZ, OMEGA3_HZ, OMEGA4_HZ]) {
            assert!((-root / (2.0 * PI) / hz - 1.0).abs() < 1e-4, "{root} {hz}");
        }
        // The eye's resonance: IEC 61000-4-15's lambda = 2 pi 4.05981 and
        // omega1 = 2 pi 9.15494 rad/s.
        let d = denominators[0];
        let (lambda, omega1) = (d[1] / d[2] / 2.0, (d[0] / d[2]).sqrt());
        assert!((lambda / (2.0 * PI) - 4.05981).abs() < 2e-3, "{lambda}");
        assert!((omega1 / (2.0 * PI) - 9.15494).abs() < 2e-3, "{omega1}");
        // The lamp's poles, now zeros: two real ones, near 7.9 and 161 Hz.
        let n = numerators[0];
        let disc = n[1] * n[1] - 4.0 * n[2] * n[0];
        assert!(disc > 0.0);
        let roots = [
            (n[1] - disc.sqrt()) / (2.0 * n[2]) / (2.0 * PI),
            (n[1] + disc.sqrt()) / (2.0 * n[2]) / (2.0 * PI),
        ];
        assert!(
            (roots[0] - 7.87).abs() < 0.01 && (roots[1] - 160.8).abs() < 0.1,
            "{roots:?}"
        );
    }

    #[test]
    fn the_reference_sine_peaks_at_one_at_every_sampling_rate() {
        for rate in [2000.0, 4000.0, 10_000.0] {
            let p = of_samples(&sine(8.8, REFERENCE_FLUCTUATION, rate, 30.0), rate).unwrap();
            assert!((p.p_inst_max - 1.0).abs() < 1e-3, "{rate}: {p:?}");
        }
    }

    #[test]
    fn a_steady_light_does_not_flicker_and_pst_grows_with_the_fluctuation() {
        let steady = of_samples(&vec![5.0; 40_000], 2000.0).unwrap();
        assert!(
            steady.pst < 1e-12 && steady.p_inst_max < 1e-20,
            "{steady:?}"
        );
        // P_inst goes with the square of the fluctuation, Pst with it.
        let one = of_samples(&sine(5.0, 0.01, 2000.0, 25.0), 2000.0).unwrap();
        let three = of_samples(&sine(5.0, 0.03, 2000.0, 25.0), 2000.0).unwrap();
        assert!(
            (three.pst / one.pst - 3.0).abs() < 1e-6,
            "{one:?} {three:?}"
        );
    }

    #[test]
    fn a_pwm_light_at_90_hz_or_faster_is_not_seen_to_flicker() {
        // Whole samples per period and per pulse: a pulse one sample
        // longer now and then would be a slow fluctuation of its own.
        // 90 Hz at 10 % duty, 100 and 120 Hz at 50 %, 200 Hz at 10 %, 400
        // Hz at 20 %: PstLM 0.30, 0.096, 0.029, 0.0016, 3e-5.
        let rate = 18_000.0;
        let mut previous = f64::INFINITY;
        for (period, on) in [(200, 20), (180, 90), (150, 75), (90, 9), (45, 9)] {
            let x: Vec<f64> = (0..(21.0 * rate) as usize)
                .map(|i| f64::from(u8::from(i % period < on)))
                .collect();
            let p = of_samples(&x, rate).unwrap();
            assert!(p.pst < 0.5 && p.pst < previous, "{period} samples: {p:?}");
            previous = p.pst;
        }
    }

    #[test]
    fn bad_waveforms_are_named() {
        let short = of_samples(&[1.0; 100], 2000.0).unwrap_err().to_string();
        assert!(
            short.contains("0.050 s") && short.contains("hint"),
            "{short}"
        );
        let mut x = vec![1.0; 40_000];
        x[7] = f64::NAN;
        assert_eq!(of_samples(&x, 2000.0), Err(PstError::NotFinite(7)));
        assert!(matches!(
            of_samples(&[1.0; 40_000], 1000.0),
            Err(PstError::SlowSampling(_))
        ));
        assert!(matches!(
            of_samples(&[0.0; 40_000], 2000.0),
            Err(PstError::NoLight(_))
        ));
    }
}
