//! A light source's own flicker, from its sampled waveform (a photodiode
//! or an oscilloscope record; `ledflicker light`, docs/light.md): the
//! fundamental frequency, Percent Flicker and the IES Flicker Index, the
//! IEEE 1789-2015 risk region ([`super::drive`]), the stroboscopic
//! visibility measure (CIE TN 006:2016) and PstLM (IEC TR 61547-1)
//! ([`crate::metrics::visibility`]). Undefined figures are `None` with
//! the reason: the output never shows NaN.

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use serde::Serialize;

use super::drive::{Ieee1789Region, low_risk_limit_percent, noel_limit_percent, region};
use crate::metrics::visibility::{pstlm, svm};

/// The version of the JSON form of [`LightFigures`] (`light --json`).
pub const FORMAT: &str = "ledflicker.light/1";

/// Fewest periods of the fundamental the record must hold for a
/// frequency to be given: one period cannot be told from a slow drift.
pub const MIN_PERIODS: f64 = 2.0;

/// A record this close to a whole number of periods of its estimated
/// fundamental, in periods, is taken as whole. On a record of a few
/// periods the estimate is off by a few hundredths of a period (the
/// Hann window's leakage from the negative frequency: 0.04 on the lamp
/// records of three 120 Hz periods in tests/data/lamps), which would
/// otherwise drop the last period.
pub const WHOLE_PERIOD_SLACK: f64 = 0.1;

/// A figure, or why it has none.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Figure {
    /// The value (finite); `None` when undefined.
    pub value: Option<f64>,
    /// Why `value` is `None`.
    pub reason: Option<String>,
}

impl Figure {
    fn of(result: Result<f64, String>) -> Figure {
        match result {
            Ok(v) => Figure {
                value: Some(v),
                reason: None,
            },
            Err(reason) => Figure {
                value: None,
                reason: Some(reason),
            },
        }
    }
}

/// The IEEE 1789-2015 figures at the waveform's fundamental.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Ieee1789 {
    /// The region; `None` when the fundamental is undefined and the light
    /// is not steady.
    pub region: Option<Ieee1789Region>,
    /// Low-risk modulation limit at the fundamental, %; `None` when exempt
    /// (above 1250 Hz) or undefined.
    pub low_risk_max_percent: Option<f64>,
    /// No-observable-effect limit at the fundamental, %; `None` when
    /// exempt (above 3 kHz) or undefined.
    pub noel_max_percent: Option<f64>,
    /// Why `region` is `None`.
    pub reason: Option<String>,
}

/// PstLM and the largest instantaneous flicker sensation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PstFigure {
    /// PstLM (>= 0; 1 = the threshold of irritability); `None` when
    /// undefined.
    pub value: Option<f64>,
    /// Largest `P_inst` after the filters settle.
    pub p_inst_max: Option<f64>,
    /// Why `value` is `None`.
    pub reason: Option<String>,
}

/// Everything `light` says of one waveform; its JSON is [`FORMAT`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LightFigures {
    /// Samples in the record (>= 8).
    pub samples: usize,
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
    /// Length of the record, `samples / rate`, s.
    pub duration_s: f64,
    /// Mean, lowest and highest level, in the file's unit.
    pub mean: f64,
    /// Lowest level.
    pub min: f64,
    /// Highest level.
    pub max: f64,
    /// Frequency of the strongest fluctuation, Hz; `None` for a steady
    /// light or a record of under [`MIN_PERIODS`] of it.
    pub fundamental_hz: Figure,
    /// Whole periods of the fundamental analysed for Percent Flicker, the
    /// Flicker Index and the SVM (the whole record when it has none).
    pub analysed_periods: Option<u64>,
    /// Samples analysed for them: the first `analysed_samples` of the record.
    pub analysed_samples: usize,
    /// Percent Flicker (IEEE 1789 modulation %), `100 (max - min) / (max + min)`.
    pub percent_flicker: f64,
    /// IES Flicker Index, 0..=1: the area above the mean over the total.
    pub flicker_index: f64,
    /// IEEE 1789-2015 region and limits at the fundamental.
    pub ieee1789: Ieee1789,
    /// Stroboscopic visibility measure (CIE TN 006:2016; 1 = threshold).
    pub svm: Figure,
    /// PstLM (IEC TR 61547-1) of the whole record.
    pub pst_lm: PstFigure,
}

/// The fundamental frequency of `x` (at `rate_hz`), Hz, to a small
/// fraction of the record's resolution: the largest component of the
/// Hann-windowed spectrum, or the lowest component of a harmonic series
/// it belongs to (a narrow pulse's; [`lowest_harmonic_series`]), placed
/// between bins by its larger neighbour. `Err` for a steady light or a record of
/// under [`MIN_PERIODS`] periods.
pub fn fundamental(x: &[f64], rate_hz: f64) -> Result<f64, String> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
            Complex::new((v - mean) * w, 0.0)
        })
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let mag: Vec<f64> = buf[..n / 2 + 1].iter().map(|c| c.norm()).collect();
    let Some((k, &peak)) = mag
        .iter()
        .enumerate()
        .skip(1)
        .max_by(|a, b| a.1.total_cmp(b.1))
    else {
        return Err("the record is too short for a spectrum".to_string());
    };
    // The FFT of a constant leaves rounding of about 1e-16 of the mean.
    if peak <= 1e-12 * mean.abs() * n as f64 {
        return Err("a steady light: no fluctuation".to_string());
    }
    let k = lowest_harmonic_series(&mag, k);
    let peak = mag[k];
    // Grandke's interpolation for the Hann window (IEEE Trans. Instrum.
    // Meas. 32(2), 1983): a sinusoid `d` bins above bin `k` gives the
    // neighbour on its side `a = (1 + d) / (2 - d)` of the peak, so
    // `d = (2a - 1) / (a + 1)`, exact but for the leakage of other
    // components.
    let side = |j: usize| mag.get(j).copied().unwrap_or(0.0) / peak;
    let (up, down) = (side(k + 1), side(k - 1));
    let offset = if up >= down {
        (2.0 * up - 1.0) / (up + 1.0)
    } else {
        -(2.0 * down - 1.0) / (down + 1.0)
    };
    let f = (k as f64 + offset) * rate_hz / n as f64;
    let periods = f * n as f64 / rate_hz;
    if periods < MIN_PERIODS {
        return Err(format!(
            "the record ({:.4} s) holds {periods:.2} periods of its strongest fluctuation (about {f:.4} Hz), under {MIN_PERIODS}; record a longer waveform",
            n as f64 / rate_hz
        ));
    }
    Ok(f)
}

/// Most subharmonics of the strongest component [`fundamental`] tries.
/// A PWM light's harmonics `k` hold `|sin(pi k D)| / (pi k D)` of twice
/// its mean: at 1 % duty the first 30 are within 15 % of the first (the
/// Hann window's scalloping), so the strongest may be any of them.
const MAX_SUBHARMONIC: usize = 64;

/// The bin of the fundamental of the spectrum `mag` (magnitudes) whose
/// strongest component is at bin `k`: the lowest `k / j` (at least bin 2)
/// whose every multiple up to `k` holds at least half the strongest's
/// magnitude, the harmonic series of a pulsed light; `k` itself when none
/// does. A slow drift has no such series, and stays out.
fn lowest_harmonic_series(mag: &[f64], k: usize) -> usize {
    let peak = mag[k];
    // The largest bin within one bin of `c`, the Hann window's main lobe.
    let near = |c: f64| {
        let c = c.round() as usize;
        (c.saturating_sub(1).max(1)..=(c + 1).min(mag.len() - 1))
            .max_by(|&a, &b| mag[a].total_cmp(&mag[b]))
            .unwrap_or(c)
    };
    for j in (2..=(k / 2).min(MAX_SUBHARMONIC)).rev() {
        let base = k as f64 / j as f64;
        if (1..j).all(|i| mag[near(base * i as f64)] >= 0.5 * peak) {
            return near(base);
        }
    }
    k
}

/// Percent Flicker and the IES Flicker Index of `x` (not all zero):
/// `100 (max - min) / (max + min)`, and `sum max(x - mean, 0) / sum x`.
fn flicker(x: &[f64]) -> (f64, f64) {
    let (min, max) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let total: f64 = x.iter().sum();
    let above: f64 = x.iter().map(|&v| (v - mean).max(0.0)).sum();
    (100.0 * (max - min) / (max + min), above / total)
}

/// Levels above this are scaled before the analysis: a sum of a million
/// squares of them stays far below f64::MAX.
const HUGE: f64 = 1e100;

/// The figures of the waveform `x` (the light's level, each finite and
/// >= 0, at least 8 samples, not all zero) sampled at `rate_hz` (> 0).
pub fn analyse(x: &[f64], rate_hz: f64) -> LightFigures {
    // Finite values near f64::MAX overflow the sums and squares below
    // (a mean of +inf, a fundamental of NaN). Every figure but the
    // levels is a ratio, so such a record is scaled by a power of two
    // (exactly), and its levels scaled back.
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if peak > HUGE {
        let scale = 2f64.powi(peak.log2().floor() as i32);
        let scaled: Vec<f64> = x.iter().map(|v| v / scale).collect();
        let mut f = analyse(&scaled, rate_hz);
        f.mean *= scale;
        f.min *= scale;
        f.max *= scale;
        return f;
    }
    let n = x.len();
    let fundamental = fundamental(x, rate_hz);
    // Whole periods, so that the record is one period of the light as the
    // SVM's Fourier series takes it, and the Flicker Index's areas are a
    // whole number of periods'.
    let (periods, used) = match fundamental {
        Ok(f) => {
            let periods = (n as f64 * f / rate_hz + WHOLE_PERIOD_SLACK).floor();
            let used = ((periods * rate_hz / f).round() as usize).clamp(2, n);
            (Some(periods as u64), used)
        }
        Err(_) => (None, n),
    };
    let whole = &x[..used];
    let (percent_flicker, flicker_index) = flicker(whole);
    let ieee1789 = match (&fundamental, percent_flicker) {
        (Ok(f), pf) => Ieee1789 {
            region: Some(region(*f, pf)),
            low_risk_max_percent: low_risk_limit_percent(*f),
            noel_max_percent: noel_limit_percent(*f),
            reason: None,
        },
        // No modulation is within every limit, at any frequency.
        (Err(_), 0.0) => Ieee1789 {
            region: Some(Ieee1789Region::NoObservableEffect),
            low_risk_max_percent: None,
            noel_max_percent: None,
            reason: None,
        },
        (Err(why), _) => Ieee1789 {
            region: None,
            low_risk_max_percent: None,
            noel_max_percent: None,
            reason: Some(format!("no fundamental frequency: {why}")),
        },
    };
    let pst = pstlm::of_samples(x, rate_hz);
    let (min, max) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    LightFigures {
        samples: n,
        sample_rate_hz: rate_hz,
        duration_s: n as f64 / rate_hz,
        mean: x.iter().sum::<f64>() / n as f64,
        min,
        max,
        fundamental_hz: Figure::of(fundamental),
        analysed_periods: periods,
        analysed_samples: used,
        percent_flicker,
        flicker_index,
        ieee1789,
        svm: Figure::of(svm::of_samples(whole, rate_hz).map_err(|e| e.to_string())),
        pst_lm: match pst {
            Ok(p) => PstFigure {
                value: Some(p.pst),
                p_inst_max: Some(p.p_inst_max),
                reason: None,
            },
            Err(e) => PstFigure {
                value: None,
                p_inst_max: None,
                reason: Some(e.to_string()),
            },
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn levels_near_the_largest_double_give_the_figures_of_the_same_light_scaled() {
        let x = square(0.3, 40, 10, 0);
        let big: Vec<f64> = x.iter().map(|v| v * 1.5e308).collect();
        let (a, b) = (analyse(&x, 4000.0), analyse(&big, 4000.0));
        // The same light, to the rounding of multiplying by 1.5e308.
        let close = |p: f64, q: f64| (p - q).abs() <= 1e-12 * p.abs().max(1.0);
        assert!(close(b.percent_flicker, a.percent_flicker));
        assert!(close(b.flicker_index, a.flicker_index));
        assert!(close(
            b.fundamental_hz.value.unwrap(),
            a.fundamental_hz.value.unwrap()
        ));
        assert_eq!(b.ieee1789.region, a.ieee1789.region);
        assert!(b.max.is_finite() && (b.max / 1.5e308 - a.max).abs() < 1e-12);
        assert!(b.mean.is_finite());
    }

    /// A PWM light of `duty`, `samples_per_period` samples a period, over
    /// `periods` periods and `extra` samples more.
    fn square(duty: f64, samples_per_period: usize, periods: usize, extra: usize) -> Vec<f64> {
        (0..samples_per_period * periods + extra)
            .map(|i| {
                let phase = (i % samples_per_period) as f64 / samples_per_period as f64;
                f64::from(u8::from(phase < duty))
            })
            .collect()
    }

    #[test]
    fn a_square_wave_has_full_modulation_and_a_flicker_index_of_one_minus_its_duty() {
        // 100 Hz at 20 kHz: 200 samples a period, duties on whole samples;
        // a record cut 37 samples into a period is analysed over whole ones.
        for duty in [0.05, 0.2, 0.5, 0.8] {
            let fig = analyse(&square(duty, 200, 30, 37), 20_000.0);
            let f = fig.fundamental_hz.value.unwrap();
            assert!((f - 100.0).abs() < 0.05, "D={duty}: {f} Hz");
            assert_eq!(
                (fig.analysed_periods, fig.analysed_samples),
                (Some(30), 6000)
            );
            assert!((fig.percent_flicker - 100.0).abs() < 1e-12);
            assert!(
                (fig.flicker_index - (1.0 - duty)).abs() < 1e-12,
                "D={duty}: {}",
                fig.flicker_index
            );
            assert_eq!(fig.ieee1789.region, Some(Ieee1789Region::ElevatedRisk));
            assert!((fig.ieee1789.low_risk_max_percent.unwrap() - 8.0).abs() < 0.08 * 0.05);
        }
    }

    #[test]
    fn a_sine_of_modulation_m_has_percent_flicker_100_m() {
        // 120 Hz at 48 kHz: the crests fall on samples.
        for m in [0.02, 0.3, 1.0] {
            let x: Vec<f64> = (0..48_000 / 4)
                .map(|i| 1.0 + m * (2.0 * PI * 120.0 * i as f64 / 48_000.0).sin())
                .collect();
            let fig = analyse(&x, 48_000.0);
            assert!(
                (fig.percent_flicker - 100.0 * m).abs() < 1e-9,
                "{m}: {}",
                fig.percent_flicker
            );
            assert!((fig.fundamental_hz.value.unwrap() - 120.0).abs() < 1e-6);
            // The Flicker Index of a sine: the area of a half-wave over the
            // whole, m / pi (the sum over 400 samples a period is 2e-5
            // below the integral).
            assert!(
                (fig.flicker_index - m / PI).abs() < 1e-4 * m,
                "{}",
                fig.flicker_index
            );
            let svm = fig.svm.value.unwrap();
            assert!((svm - m / svm::threshold(120.0)).abs() < 1e-9, "{svm}");
        }
    }

    #[test]
    fn a_narrow_pulse_is_found_at_its_own_rate_not_a_harmonic() {
        // At 1 to 5 % duty the first harmonics are as strong as the
        // fundamental; a record cut mid-period leaks unevenly.
        for (duty, per) in [(0.05, 1000), (0.02, 1000), (0.01, 500)] {
            let x = square(duty, per, 20, 437);
            let f = fundamental(&x, 100_000.0).unwrap();
            let want = 100_000.0 / per as f64;
            assert!(
                (f - want).abs() < 1e-3 * want,
                "D={duty}: {f} Hz, not {want}"
            );
        }
        // A ripple over a slow drift of comparable size keeps its own rate.
        let rate = 10_000.0;
        let x: Vec<f64> = (0..100_000)
            .map(|i| {
                let t = i as f64 / rate;
                5.0 + 0.3 * (2.0 * PI * 0.3 * t).sin() + 0.5 * (2.0 * PI * 120.0 * t).sin()
            })
            .collect();
        let f = fundamental(&x, rate).unwrap();
        assert!((f - 120.0).abs() < 1e-3, "{f}");
    }

    #[test]
    fn the_fundamental_is_found_between_bins() {
        // 0.2 s of 101.3 Hz: 20.26 periods, the peak between two bins.
        let rate = 10_000.0;
        let x: Vec<f64> = (0..2000)
            .map(|i| 2.0 + (2.0 * PI * 101.3 * i as f64 / rate).sin())
            .collect();
        let f = fundamental(&x, rate).unwrap();
        assert!((f - 101.3).abs() < 0.05, "{f}");
    }

    #[test]
    fn a_steady_or_too_short_record_has_no_fundamental_and_says_why() {
        let steady = analyse(&[3.0; 100], 10_000.0);
        assert_eq!(steady.fundamental_hz.value, None);
        assert!(
            steady
                .fundamental_hz
                .reason
                .as_deref()
                .unwrap()
                .contains("steady")
        );
        assert_eq!(
            steady.ieee1789.region,
            Some(Ieee1789Region::NoObservableEffect)
        );
        assert_eq!((steady.percent_flicker, steady.flicker_index), (0.0, 0.0));
        // One period and a half of a sine.
        let x: Vec<f64> = (0..150)
            .map(|i| 1.0 + 0.5 * (2.0 * PI * i as f64 / 100.0).sin())
            .collect();
        let short = analyse(&x, 10_000.0);
        assert!(
            short
                .fundamental_hz
                .reason
                .as_deref()
                .unwrap()
                .contains("under 2"),
            "{:?}",
            short.fundamental_hz
        );
        assert_eq!(short.ieee1789.region, None);
        assert!(short.ieee1789.reason.is_some());
        let pst = short.pst_lm.reason.unwrap();
        assert!(pst.contains("at least 20 s"), "{pst}");
        // Sampled at 2 kHz: no SVM, and why.
        let slow = analyse(&square(0.5, 20, 10, 0), 2000.0);
        assert!(slow.svm.reason.unwrap().contains("2000 Hz"));
    }
}
