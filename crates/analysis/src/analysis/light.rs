//! A light source's own flicker, from its sampled waveform (a photodiode
//! or an oscilloscope record; `ledflicker light`, docs/light.md): the
//! fundamental frequency, Percent Flicker and the IES Flicker Index, the
//! IEEE 1789-2015 risk region ([`super::drive`]), the stroboscopic
//! visibility measure (CIE TN 006:2016) and PstLM (IEC TR 61547-1)
//! ([`ledflicker_metrics::metrics::visibility`]). Undefined figures are `None` with
//! the reason: the output never shows NaN.

use ledflicker_metrics::fft::{self, Complex};
use serde::Serialize;

use super::drive::{Ieee1789Region, low_risk_limit_percent, noel_limit_percent, region};
pub use super::light_signal::DEFAULT_BANDWIDTH_HZ;
use super::light_signal::{band_limited, lobe_components, measured_period};
use ledflicker_metrics::metrics::visibility::{pstlm, svm};

/// The version of the JSON form of [`LightFigures`] (`light --json`).
pub const FORMAT: &str = "ledflicker.light/2";

/// Fewest periods of the fundamental the record must hold for a
/// frequency to be given: one period cannot be told from a slow drift.
pub const MIN_PERIODS: f64 = 2.0;

/// Share of the analysed window's fluctuation (its power) outside the
/// fundamental's harmonics above which the SVM is taken from the spectrum's
/// peaks ([`lobe_components`]) rather than the window's Fourier series:
/// the record then holds components of another period (a second lamp,
/// mains ripple under a PWM), which whole periods of the fundamental cut
/// mid-period.
pub const INHARMONIC_SHARE: f64 = 0.01;

/// What `light` was asked for beyond the record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightOptions {
    /// Band limit of Percent Flicker and the Flicker Index, Hz; `None`
    /// for the raw samples.
    pub bandwidth_hz: Option<f64>,
}

impl Default for LightOptions {
    fn default() -> Self {
        LightOptions {
            bandwidth_hz: Some(DEFAULT_BANDWIDTH_HZ),
        }
    }
}

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
    /// How closely the fundamental is known, Hz: the period is measured
    /// to half a sample over the periods matched at once.
    pub fundamental_resolution_hz: Option<f64>,
    /// The band limit Percent Flicker and the Flicker Index were read
    /// with, Hz; `None` for the raw samples (none asked for, or a record
    /// sampled under four times the limit, whose sampling limits it).
    pub bandwidth_hz: Option<f64>,
    /// Samples of the analysed window below 0 (a scope's offset and
    /// noise around dark) that Percent Flicker and the Flicker Index read
    /// as 0: a light is never negative.
    pub read_as_dark: usize,
    /// Whole periods of the fundamental analysed for Percent Flicker, the
    /// Flicker Index and the SVM (the whole record when it has none).
    pub analysed_periods: Option<u64>,
    /// Samples analysed for them: the first `analysed_samples` of the record.
    pub analysed_samples: usize,
    /// Percent Flicker (IEEE 1789 modulation %), `100 (max - min) / (max + min)`.
    pub percent_flicker: f64,
    /// IES Flicker Index, 0..=1: the area above the mean over the total.
    pub flicker_index: f64,
    /// Percent Flicker of the raw samples of the same window (levels below
    /// 0 read as 0): the same as `percent_flicker` without a band limit.
    pub percent_flicker_raw: f64,
    /// IEEE 1789-2015 region and limits at the fundamental.
    pub ieee1789: Ieee1789,
    /// Stroboscopic visibility measure (CIE TN 006:2016; 1 = threshold).
    pub svm: Figure,
    /// How the SVM's components were taken: `fourier-series` (the
    /// analysed whole periods as one period of the light) or
    /// `spectral-peaks` (a record holding components of another period;
    /// [`INHARMONIC_SHARE`]); `None` without an SVM.
    pub svm_components: Option<&'static str>,
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
    fft::forward(&mut buf);
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
    if max + min <= 0.0 {
        return (0.0, 0.0);
    }
    (100.0 * (max - min) / (max + min), above / total)
}

/// Levels above this are scaled before the analysis: a sum of a million
/// squares of them stays far below f64::MAX.
const HUGE: f64 = 1e100;

/// The figures of the waveform `x` (the light's level, each finite, at
/// least 8 samples, with a positive mean) sampled at `rate_hz` (> 0).
pub fn analyse(x: &[f64], rate_hz: f64, options: &LightOptions) -> LightFigures {
    // Finite values near f64::MAX overflow the sums and squares below
    // (a mean of +inf, a fundamental of NaN). Every figure but the
    // levels is a ratio, so such a record is scaled by a power of two
    // (exactly), and its levels scaled back.
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if peak > HUGE {
        let scale = 2f64.powi(peak.log2().floor() as i32);
        let scaled: Vec<f64> = x.iter().map(|v| v / scale).collect();
        let mut f = analyse(&scaled, rate_hz, options);
        f.mean *= scale;
        f.min *= scale;
        f.max *= scale;
        return f;
    }
    let n = x.len();
    // Percent Flicker and the Flicker Index read extremes and areas, which
    // a scope's noise inflates: they are read on the band-limited record,
    // and so is the period, which the noise would blur.
    let limited = options
        .bandwidth_hz
        .and_then(|b| band_limited(x, rate_hz, b).map(|y| (b, y)));
    let levels = limited.as_ref().map_or(x, |(_, y)| y.as_slice());
    let period = Period::of(
        x,
        limited.as_ref().map(|(b, y)| (*b, y.as_slice())),
        rate_hz,
    );
    let used = period.whole.map_or(n, |(_, used)| used);
    let read_as_dark = levels[..used].iter().filter(|&&v| v < 0.0).count();
    let window: Vec<f64> = levels[..used].iter().map(|&v| v.max(0.0)).collect();
    let (percent_flicker, flicker_index) = flicker(&window);
    let raw: Vec<f64> = x[..used].iter().map(|&v| v.max(0.0)).collect();
    let percent_flicker_raw = flicker(&raw).0;
    let ieee1789 = ieee1789(&period, percent_flicker);
    let (svm, svm_components) = svm_of(x, rate_hz, &period);
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
        fundamental_hz: Figure::of(period.frequency.clone()),
        fundamental_resolution_hz: period.resolution_hz,
        bandwidth_hz: limited.as_ref().map(|(b, _)| *b),
        read_as_dark,
        analysed_periods: period.whole.map(|(p, _)| p),
        analysed_samples: used,
        percent_flicker,
        flicker_index,
        percent_flicker_raw,
        ieee1789,
        svm,
        svm_components,
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

/// The fundamental of a record and the whole periods of it the record holds.
struct Period {
    /// The frequency, Hz, or why there is none.
    frequency: Result<f64, String>,
    /// Its resolution, Hz.
    resolution_hz: Option<f64>,
    /// Whole periods and the samples they span: the most periods `P` with
    /// `P T <= n + 0.5` samples (a record a fraction of a sample short of
    /// them holds them; one a tenth of a period short does not).
    whole: Option<(u64, usize)>,
    /// Whether the record was too short for a fundamental (not steady).
    too_short: bool,
}

impl Period {
    /// The period of the record `x`, measured on its band-limited
    /// version `limited` (the band limit and the levels) when the limit is
    /// at least [`PERIOD_BAND_MARGIN`] times the fundamental, else on `x`.
    fn of(x: &[f64], limited: Option<(f64, &[f64])>, rate_hz: f64) -> Period {
        let n = x.len();
        let estimate = match fundamental(x, rate_hz) {
            Ok(f) => f,
            Err(why) => {
                return Period {
                    too_short: !why.contains("steady"),
                    frequency: Err(why),
                    resolution_hz: None,
                    whole: None,
                };
            }
        };
        let levels = match limited {
            Some((b, y)) if b >= PERIOD_BAND_MARGIN * estimate => y,
            _ => x,
        };
        // The spectral estimate is off by a few hundredths of a period on
        // a record of a few periods (the Hann window's leakage from the
        // negative frequency); the period is measured on the waveform.
        // Where no match stands, the estimate does, known to half a bin.
        let (t, resolution) = match measured_period(levels, rate_hz / estimate) {
            Some(m) => {
                let f = rate_hz / m.period;
                (m.period, f * m.lag_uncertainty / m.lag)
            }
            None => (rate_hz / estimate, 0.5 * rate_hz / n as f64),
        };
        let f = rate_hz / t;
        let periods = ((n as f64 + 0.5) / t).floor();
        if periods < MIN_PERIODS {
            return Period {
                frequency: Err(format!(
                    "the record ({:.4} s) holds {:.2} periods of its strongest fluctuation (about {f:.4} Hz), under {MIN_PERIODS}; record a longer waveform",
                    n as f64 / rate_hz,
                    n as f64 / t
                )),
                resolution_hz: None,
                whole: None,
                too_short: true,
            };
        }
        let used = ((periods * t).round() as usize).clamp(2, n);
        Period {
            frequency: Ok(f),
            resolution_hz: Some(resolution),
            whole: Some((periods as u64, used)),
            too_short: false,
        }
    }
}

/// The band limit must be at least this many times the fundamental for
/// the period to be measured on the band-limited record: a limit nearer
/// the fundamental would round the waveform the match reads.
const PERIOD_BAND_MARGIN: f64 = 10.0;

/// Half-width of the band around 90 Hz judged at 90 Hz, as a share of it:
/// on a few noisy periods the fundamental is off by up to about 0.6 %
/// (measured: 5 % modulation, 5 mV of noise, 3.6 periods at 50 kHz).
pub const AT_90_HZ_SHARE: f64 = 0.01;

/// The IEEE 1789-2015 region at the fundamental. Its limits jump at
/// 90 Hz (2.25 % below, 7.2 % from there): a fundamental within its
/// resolution of 90 Hz, or within [`AT_90_HZ_SHARE`] of it, is taken as
/// 90 Hz, the range the boundary belongs to, so that the region does not
/// flip on the estimate's error.
fn ieee1789(period: &Period, percent_flicker: f64) -> Ieee1789 {
    match (&period.frequency, percent_flicker) {
        (Ok(f), pf) => {
            let within = period
                .resolution_hz
                .unwrap_or(0.0)
                .max(AT_90_HZ_SHARE * 90.0);
            let at = if (f - 90.0).abs() <= within { 90.0 } else { *f };
            Ieee1789 {
                region: Some(region(at, pf)),
                low_risk_max_percent: low_risk_limit_percent(at),
                noel_max_percent: noel_limit_percent(at),
                reason: None,
            }
        }
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
    }
}

/// The SVM of the record's analysed window, and how its components were
/// taken. A record of under two periods has none: its Fourier series
/// would be of a fragment, not of the light.
fn svm_of(x: &[f64], rate_hz: f64, period: &Period) -> (Figure, Option<&'static str>) {
    if period.too_short {
        let why = period.frequency.clone().err().unwrap_or_default();
        return (
            Figure::of(Err(format!(
                "the record is too short for the light's spectrum: {why}"
            ))),
            None,
        );
    }
    let (whole, periods) = match period.whole {
        Some((p, used)) => (&x[..used], p as usize),
        None => (x, 0),
    };
    let components = match svm::components(whole, rate_hz) {
        Ok(c) => c,
        Err(e) => return (Figure::of(Err(e.to_string())), None),
    };
    if periods < 3 || inharmonic_share(&components, periods) <= INHARMONIC_SHARE {
        return (
            Figure::of(Ok(svm::of_components(components))),
            Some("fourier-series"),
        );
    }
    let mean = whole.iter().sum::<f64>() / whole.len() as f64;
    (
        Figure::of(Ok(svm::of_components(lobe_components(
            whole, rate_hz, mean,
        )))),
        Some("spectral-peaks"),
    )
}

/// The share of the fluctuation power up to the SVM's 2 kHz, in the
/// window's Fourier `components` (bin `k` is the `k`-th, from 1), that
/// lies in bins that are not harmonics of its fundamental (`periods` whole
/// periods): a scope's broadband noise above 2 kHz is no other light.
fn inharmonic_share(components: &[(f64, f64)], periods: usize) -> f64 {
    let (mut all, mut off) = (0.0, 0.0);
    for (k, &(f, c)) in (1..).zip(components) {
        if f > svm::MAX_FREQUENCY_HZ {
            break;
        }
        all += c * c;
        if k % periods != 0 {
            off += c * c;
        }
    }
    if all > 0.0 { off / all } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const RAW: LightOptions = LightOptions { bandwidth_hz: None };

    #[test]
    fn levels_near_the_largest_double_give_the_figures_of_the_same_light_scaled() {
        let x = square(0.3, 40, 10, 0);
        let big: Vec<f64> = x.iter().map(|v| v * 1.5e308).collect();
        let (a, b) = (analyse(&x, 4000.0, &RAW), analyse(&big, 4000.0, &RAW));
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
            let fig = analyse(&square(duty, 200, 30, 37), 20_000.0, &RAW);
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
            let fig = analyse(&x, 48_000.0, &RAW);
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
        let steady = analyse(&[3.0; 100], 10_000.0, &RAW);
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
        let short = analyse(&x, 10_000.0, &RAW);
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
        let slow = analyse(&square(0.5, 20, 10, 0), 2000.0, &RAW);
        assert!(slow.svm.reason.unwrap().contains("2000 Hz"));
    }
}
