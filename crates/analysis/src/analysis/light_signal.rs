//! A light's record made ready for its figures (`ledflicker light`,
//! docs/light.md): the band limit of the figures read off extremes and
//! areas, the fundamental's period measured on the waveform itself, and
//! the components the SVM sums when the record is not one periodic light.

use ledflicker_metrics::fft::{self, Complex};

/// The band limit of Percent Flicker and the Flicker Index unless given:
/// an oscilloscope's noise reaches its full bandwidth (MHz), and read off
/// the record's extremes it inflates Percent Flicker (a CFL: 19.5 % raw,
/// 9 % limited to 2 to 10 kHz). 10 kHz passes the IEEE 1789 range (up to
/// 3 kHz) at 94 % or more and keeps a pulse of 0.1 ms at its full height.
pub const DEFAULT_BANDWIDTH_HZ: f64 = 10_000.0;

/// The filter is applied when the record is sampled at least this many
/// times its band limit; below, its kernel would be under a sample wide,
/// and the sampling itself is the record's band limit.
const MIN_RATE_PER_BANDWIDTH: f64 = 4.0;

/// The record low-passed to `bandwidth_hz` (-3 dB there) by a Gaussian
/// kernel, zero phase, its ends mirrored; `None` when `rate_hz` is under
/// [`MIN_RATE_PER_BANDWIDTH`] times the band limit (nothing to filter).
///
/// A Gaussian: its kernel is positive, so the result stays within the
/// record's own range (a band limit must not add overshoot, which would
/// raise Percent Flicker), and it has no ringing. Its response is
/// `exp(-(ln 2 / 2) (f / B)^2)`: the kernel's standard deviation is
/// `sqrt(ln 2) / (2 pi B)`.
pub fn band_limited(x: &[f64], rate_hz: f64, bandwidth_hz: f64) -> Option<Vec<f64>> {
    if bandwidth_hz.is_nan()
        || bandwidth_hz <= 0.0
        || rate_hz < MIN_RATE_PER_BANDWIDTH * bandwidth_hz
    {
        return None;
    }
    let sigma = 2f64.ln().sqrt() / (2.0 * std::f64::consts::PI * bandwidth_hz) * rate_hz;
    let half = (4.0 * sigma).ceil() as usize;
    let kernel: Vec<f64> = {
        let k: Vec<f64> = (0..=2 * half)
            .map(|i| {
                let d = i as f64 - half as f64;
                (-0.5 * (d / sigma).powi(2)).exp()
            })
            .collect();
        let sum: f64 = k.iter().sum();
        k.into_iter().map(|v| v / sum).collect()
    };
    // Mirrored ends (`x[1]`, `x[2]` ... before `x[0]`), so that the edges
    // see the record's own levels, not zeros or its other end.
    let n = x.len();
    let at = |i: isize| -> f64 {
        let period = 2 * (n as isize - 1).max(1);
        let mut j = i.rem_euclid(period);
        if j >= n as isize {
            j = period - j;
        }
        x[j as usize]
    };
    let padded: Vec<f64> = (-(half as isize)..(n + half) as isize).map(at).collect();
    // The FFT's rounding may step a hair outside the record's range (a
    // dark of exactly 0 read as -1e-17): the kernel is positive, so the
    // range is the exact result's.
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let filtered: Vec<f64> = if kernel.len() <= 256 {
        (0..n)
            .map(|i| {
                padded[i..i + kernel.len()]
                    .iter()
                    .zip(&kernel)
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect()
    } else {
        convolve_fft(&padded, &kernel, n)
    };
    Some(filtered.into_iter().map(|v| v.clamp(lo, hi)).collect())
}

/// The first `n` outputs of the valid part of `padded * kernel`, by FFT.
fn convolve_fft(padded: &[f64], kernel: &[f64], n: usize) -> Vec<f64> {
    let size = (padded.len() + kernel.len()).next_power_of_two();
    let spread = |v: &[f64]| {
        let mut b = vec![Complex::new(0.0, 0.0); size];
        for (o, &x) in b.iter_mut().zip(v) {
            o.re = x;
        }
        b
    };
    let (mut a, mut k) = (spread(padded), spread(kernel));
    fft::forward(&mut a);
    fft::forward(&mut k);
    for (p, q) in a.iter_mut().zip(&k) {
        *p *= q;
    }
    fft::inverse(&mut a);
    let last = kernel.len() - 1;
    (0..n).map(|i| a[i + last].re / size as f64).collect()
}

/// Most samples of overlap one lag's match is computed over.
const MATCH_SAMPLES: usize = 1 << 16;

/// The fundamental's period measured on the waveform ([`measured_period`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The period, samples.
    pub period: f64,
    /// The lag of the last stage, samples (`k` periods).
    pub lag: f64,
    /// The lag's uncertainty, samples: half a sample, or three standard
    /// errors of the lag from the residual at the match, whichever is
    /// larger (noise makes the match's minimum wander).
    pub lag_uncertainty: f64,
}

/// The fundamental's period, in samples, measured on the waveform: the lag
/// at which the record best matches itself shifted (least squared
/// difference, placed between samples by a parabola), first near one
/// period of the spectral estimate `period0`, then near 2, 4, 8 ... of
/// them while two periods still overlap, each stage within 3 samples of
/// the last stage's multiple. A best lag on the edge of a stage's range is
/// no minimum (a second light or a band limit pulls the match off the
/// period): the stage before stands, and with no stage standing `None`
/// (the spectral estimate stands).
pub fn measured_period(x: &[f64], period0: f64) -> Option<Measured> {
    let n = x.len();
    // Every lag of a stage is compared over the same `m` samples, so that
    // the differences are comparable to the last bit.
    let diff =
        |lag: usize, m: usize| -> f64 { (0..m).map(|i| (x[i + lag] - x[i]).powi(2)).sum::<f64>() };
    // The lag of least difference within `lo..=hi`, between samples, and
    // its standard error; `None` when the least is at either end.
    let best = |lo: usize, hi: usize| -> Option<(f64, f64)> {
        let hi = hi.min(n.saturating_sub(3));
        if lo < 2 || lo >= hi {
            return None;
        }
        let m = (n - (hi + 1)).min(MATCH_SAMPLES);
        let d: Vec<f64> = (lo..=hi).map(|lag| diff(lag, m)).collect();
        let i = (0..d.len()).min_by(|&a, &b| d[a].total_cmp(&d[b]))?;
        if i == 0 || i == d.len() - 1 {
            return None;
        }
        let (a, b, c) = (d[i - 1], d[i], d[i + 1]);
        let curve = a - 2.0 * b + c;
        let shift = if curve > 0.0 {
            (0.5 * (a - c) / curve).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        let lag = lo + i;
        // The shift `delta` that best explains the residual `r_i =
        // x[i + L] - x[i]` by the slope `g_i` has the standard error
        // `sqrt((sum r^2 / m) / sum g^2)`.
        let slope: f64 = (0..m.min(n - lag - 1))
            .map(|j| (0.5 * (x[j + lag + 1] - x[j + lag - 1])).powi(2))
            .sum();
        let se = if slope > 0.0 {
            (b / m as f64 / slope).sqrt()
        } else {
            0.0
        };
        Some((lag as f64 + shift, se))
    };
    let width = (0.03 * period0).ceil() as usize + 2;
    let centre = period0.round() as usize;
    let (first, se) = best(centre.saturating_sub(width), centre + width)?;
    let mut out = Measured {
        period: first,
        lag: first,
        lag_uncertainty: (3.0 * se).max(0.5),
    };
    let mut k = 1usize;
    // Two periods of overlap at least, so that every stage compares a
    // period with a period.
    while (2 * k) as f64 * out.period + 2.0 * out.period <= n as f64 {
        let guess = (2.0 * k as f64 * out.period).round() as usize;
        let Some((lag, se)) = best(guess.saturating_sub(3), guess + 3) else {
            break;
        };
        k *= 2;
        out = Measured {
            period: lag / k as f64,
            lag,
            lag_uncertainty: (3.0 * se).max(0.5),
        };
    }
    Some(out)
}

/// The components the SVM sums of the record `x` (at `rate_hz`, mean
/// `mean` > 0) when it is not one periodic light (two lamps, mains ripple
/// under a PWM): the Hann-windowed spectrum's peaks, each component the
/// power of its peak's main lobe (the bins from the peak down to the next
/// rise on each side, at most 2 bins), at the peak's bin frequency. A
/// component between bins keeps its power, where the rectangular window's
/// bins would spread it over many small terms and the pooling's exponent
/// (3.7) would lose it.
pub fn lobe_components(x: &[f64], rate_hz: f64, mean: f64) -> Vec<(f64, f64)> {
    let n = x.len();
    let w = |i: usize| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| Complex::new((v - mean) * w(i), 0.0))
        .collect();
    fft::forward(&mut buf);
    let half = n.div_ceil(2);
    let power: Vec<f64> = buf[..half].iter().map(|c| c.norm_sqr()).collect();
    let window_power: f64 = (0..n).map(|i| w(i).powi(2)).sum();
    let mut out = Vec::new();
    for k in 1..half {
        let left = power[k - 1];
        let right = power.get(k + 1).copied().unwrap_or(0.0);
        // A peak; a flat top counts once, at its first bin.
        if !(power[k] > left && power[k] >= right) || power[k] == 0.0 {
            continue;
        }
        let mut total = power[k];
        for step in [-1isize, 1] {
            let mut prev = power[k];
            for d in 1..=2isize {
                let j = k as isize + step * d;
                if j < 1 || j as usize >= half || power[j as usize] >= prev {
                    break;
                }
                prev = power[j as usize];
                total += prev;
            }
        }
        // A sinusoid of amplitude `a` gives `sum |X|^2 = a^2 (sum w^2) n / 4`
        // over its lobe (both halves of the spectrum, n/2 each).
        let amplitude = (4.0 * total / (window_power * n as f64)).sqrt();
        out.push((k as f64 * rate_hz / n as f64, amplitude / mean));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn the_band_limit_keeps_the_range_and_passes_a_slow_tone() {
        let rate = 100_000.0;
        let x: Vec<f64> = (0..20_000)
            .map(|i| f64::from(u8::from(i % 1000 < 300)))
            .collect();
        let y = band_limited(&x, rate, 10_000.0).unwrap();
        assert!(y.iter().all(|&v| (-1e-12..=1.0 + 1e-12).contains(&v)));
        // A 0.3 ms pulse keeps its height; the mean is kept.
        let peak = y.iter().cloned().fold(0.0, f64::max);
        assert!((peak - 1.0).abs() < 1e-9, "{peak}");
        let (mx, my) = (x.iter().sum::<f64>(), y.iter().sum::<f64>());
        assert!((mx - my).abs() < 1e-9 * mx);
        // A 1 kHz sine is passed at exp(-(ln 2 / 2) 0.01).
        let s: Vec<f64> = (0..50_000)
            .map(|i| 1.0 + 0.5 * (2.0 * PI * 1000.0 * i as f64 / rate).sin())
            .collect();
        let t = band_limited(&s, rate, 10_000.0).unwrap();
        let amp = t[10_000..40_000].iter().cloned().fold(0.0, f64::max) - 1.0;
        let want = 0.5 * (-(2f64.ln() / 2.0) * 0.01).exp();
        assert!((amp - want).abs() < 1e-4, "{amp} {want}");
        // The FFT path for a wide kernel agrees with the direct one.
        let wide = band_limited(&x, rate, 500.0).unwrap();
        assert!(wide.iter().all(|v| v.is_finite()));
        assert!(band_limited(&x, 30_000.0, 10_000.0).is_none());
    }

    #[test]
    fn the_period_is_measured_to_a_fraction_of_a_sample() {
        // 119.93 Hz at 100 kHz: 833.82 samples a period, 3.9 periods.
        let rate = 100_000.0;
        let f = 119.93;
        let x: Vec<f64> = (0..3252)
            .map(|i| {
                let t = i as f64 / rate;
                1.0 + 0.1 * (2.0 * PI * f * t).sin() + 0.04 * (4.0 * PI * f * t + 0.3).sin()
            })
            .collect();
        let m = measured_period(&x, rate / 121.0).unwrap();
        assert!((m.period - rate / f).abs() < 0.05, "{m:?}");
    }

    #[test]
    fn a_tone_between_bins_keeps_its_power_in_its_lobe() {
        let rate = 20_000.0;
        let x: Vec<f64> = (0..20_000)
            .map(|i| 1.0 + 0.3 * (2.0 * PI * 100.37 * i as f64 / rate).sin())
            .collect();
        let c = lobe_components(&x, rate, 1.0);
        let (f, m) = c
            .iter()
            .cloned()
            .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        assert!((f - 100.0).abs() <= 1.0, "{f}");
        assert!((m - 0.3).abs() < 0.3 * 2e-3, "{m}");
    }
}
