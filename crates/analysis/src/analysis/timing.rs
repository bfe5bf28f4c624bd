//! A case's frame timing, from the frames' own start times.
//!
//! A capture (video container timestamps, a sidecar, `[capture]
//! frame-rate-fps`) or a rig gives each frame a start time `t_i`, often
//! rounded to a time base: Matroska's default is 1 ms, and a 29.97 fps
//! capture then has intervals of 33 and 34 ms. The frame period `P` is
//! fitted so that this rounding never accumulates:
//!
//! 1. Slots: frame 0 sits in slot `k_0 = 0`, and each interval `g_i =
//!    t_{i+1} - t_i` spans `max(1, round(g_i / P))` slots, so `k_{i+1} =
//!    k_i + max(1, round(g_i / P))`. Each interval is judged on its own
//!    (never `round((t_i - t_0) / P)`, where a period off by 1 % drifts a
//!    slot in 100 frames); a dropped frame is an interval of about `2 P`,
//!    two of about `3 P`, and so on.
//! 2. Fit: `P` is the least-squares slope of `t_i` over `k_i`, with
//!    intercept `a`. It starts from the median interval and is refitted
//!    with the slots it gives, until the slots no longer change (at most
//!    [`MAX_REFITS`] times).
//! 3. Resolution `q`: the coarsest of 1 ms, 0.1 ms, 1/90000 s, 10 us, 1 us
//!    and the container's time base that every `t_i - t_0` is a whole
//!    multiple of (within [`QUANTUM_TOLERANCE`] of `q`); none when no
//!    candidate fits (then `q = 0` below).
//! 4. Uncertainty: with residuals `r_i = t_i - a - P k_i`, `N` frames and
//!    `S = sum (k_i - mean k)^2`, the standard error of the slope is `s =
//!    sqrt(sum r_i^2 / (N - 2) / S)` (0 for 2 frames). Rounding each end
//!    of the span to `q` errs by up to `q / 2` (uniform: `q / sqrt 12`)
//!    independently, which alone moves a slope by `q / (sqrt 6 K)` over
//!    `K = k_{N-1}` slots; the period's one-sigma uncertainty is
//!    `sigma_P = sqrt(s^2 + (q / (sqrt 6 K))^2)`, and the rate's is
//!    `sigma_P / P^2`.
//! 5. Stated rate: when the container states a rate `num / den` and
//!    `|P - den / num| <= 3 sigma_P + q / K`, the period is `den / num`
//!    exactly, and the intercept is refitted with it (`a = mean t - P mean k`).
//! 6. Slot times: when `q > 0` and every residual of the final line is
//!    within `q` (`|r_i| <= q`), the times are a constant rate rounded to
//!    the time base, and the analyses use the slot times `a + P k_i`
//!    instead of the rounded times (a 0.5 ms rounding is 0.075 cycles of a
//!    151 Hz LED). Otherwise they use the times as measured, so that drops
//!    and a variable frame rate are folded where they really fell.
//!
//! Dropped frames are the empty slots, `K + 1 - N`. The timing is regular
//! when `k_i = i` for every frame and every interval is within
//! [`IRREGULAR_INTERVAL`] of `P`. The spectrum of a trace is an FFT when the
//! timing is regular, and otherwise a direct Fourier sum over the times
//! the analyses use ([`dominant_frequency_at_times_hz`]), with the same
//! window, padding and refinement.

pub use ledflicker_results::analysis::timing::FrameTiming;

use super::apparent::SpectrumError;
use ledflicker_plan::trace::Ratio;

/// An interval further than this fraction from the frame period makes
/// the timing irregular (a drop, a doubled frame, a variable frame rate).
pub const IRREGULAR_INTERVAL: f64 = 0.25;

/// Longest trace (frames) the direct Fourier sum of an irregular capture
/// takes; longer irregular traces use their first this many frames.
pub const MAX_DIRECT_FRAMES: usize = 20_000;

/// Most refits of the period with the slots the previous fit gave.
pub const MAX_REFITS: usize = 10;

/// Candidate resolutions of frame times, seconds, besides a container's
/// time base: a millisecond (Matroska, many loggers), a tenth of one,
/// MPEG's 90 kHz clock, 10 us and a microsecond (ffprobe's `pts_time`).
pub const QUANTA_S: [f64; 5] = [1e-3, 1e-4, 1.0 / 90_000.0, 1e-5, 1e-6];

/// How far from a whole multiple of a quantum `q` a time may be, as a
/// fraction of `q`, and still be on its grid: above the rounding of a
/// decimal written time (`0.033` is not exactly 33 ms in binary), far below
/// any real offset.
pub const QUANTUM_TOLERANCE: f64 = 1e-6;

/// Bins of the direct Fourier sum between exactly computed phasors; the
/// phasors in between are rotated from them.
const ANCHOR_BINS: usize = 32;

/// What a source says about its frame times besides the times.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TimeSource {
    /// The container's time base, seconds, when the times are its timestamps.
    pub time_base_s: Option<Ratio>,
    /// The frame rate the container states, frames/s.
    pub stated_fps: Option<Ratio>,
}

/// A line `t = a + P k` through (slot, time).
#[derive(Debug, Clone, Copy)]
struct Line {
    intercept_s: f64,
    period_s: f64,
}

/// The timing of frames starting at `times_s` (strictly rising), from
/// `source`'s time base and stated rate, or `None` for fewer than 2 frames
/// or times that do not rise.
pub fn from_times(times_s: &[f64], source: &TimeSource) -> Option<FrameTiming> {
    let n = times_s.len();
    if n < 2 {
        return None;
    }
    let gaps: Vec<f64> = times_s.windows(2).map(|w| w[1] - w[0]).collect();
    if gaps.iter().any(|g| !(g.is_finite() && *g > 0.0)) {
        return None;
    }
    let mut slots = slots_of(&gaps, median(&mut gaps.clone()));
    let mut line = fit(&slots, times_s);
    for _ in 0..MAX_REFITS {
        let next = slots_of(&gaps, line.period_s);
        if next == slots {
            break;
        }
        slots = next;
        line = fit(&slots, times_s);
    }
    let k_last = slots[n - 1] as f64;
    let q = resolution_s(times_s, source.time_base_s);
    let q0 = q.unwrap_or(0.0);
    let residuals = |l: Line| -> Vec<f64> {
        slots
            .iter()
            .zip(times_s)
            .map(|(&k, &t)| t - l.intercept_s - l.period_s * k as f64)
            .collect()
    };
    let sum_sq: f64 = residuals(line).iter().map(|r| r * r).sum();
    let kbar = slots.iter().map(|&k| k as f64).sum::<f64>() / n as f64;
    let sxx: f64 = slots.iter().map(|&k| (k as f64 - kbar).powi(2)).sum();
    let standard_error = if n > 2 {
        (sum_sq / (n - 2) as f64 / sxx).sqrt()
    } else {
        0.0
    };
    let sigma_p = standard_error.hypot(q0 / (6f64.sqrt() * k_last));
    let stated = source.stated_fps.filter(|r| {
        let p = r.den as f64 / r.num as f64;
        (line.period_s - p).abs() <= 3.0 * sigma_p + q0 / k_last
    });
    if let Some(r) = stated {
        let period_s = r.den as f64 / r.num as f64;
        let t0 = times_s[0];
        let tbar = t0 + times_s.iter().map(|t| t - t0).sum::<f64>() / n as f64;
        line = Line {
            intercept_s: tbar - period_s * kbar,
            period_s,
        };
    }
    let max_residual_s = residuals(line).iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let slot_times = q.is_some_and(|q| max_residual_s <= q);
    let used: Vec<f64> = if slot_times {
        slots
            .iter()
            .map(|&k| line.intercept_s + line.period_s * k as f64)
            .collect()
    } else {
        times_s.to_vec()
    };
    let p = line.period_s;
    let consecutive = slots.iter().enumerate().all(|(i, &k)| k == i as u64);
    let within = gaps
        .iter()
        .all(|g| (g / p - 1.0).abs() <= IRREGULAR_INTERVAL);
    Some(FrameTiming {
        fps: stated.map_or(1.0 / p, Ratio::value),
        fps_uncertainty: sigma_p / (p * p),
        resolution_s: q,
        stated_fps: source.stated_fps,
        stated_rate_used: stated.is_some(),
        slot_times,
        max_residual_s,
        regular: consecutive && within,
        dropped_frames: slots[n - 1] + 1 - n as u64,
        capture_s: used[n - 1] - used[0] + p,
        times_s: used,
    })
}

/// The slot of each frame: 0 for the first, then each interval of `gaps`
/// spans `max(1, round(g / period_s))` slots.
fn slots_of(gaps: &[f64], period_s: f64) -> Vec<u64> {
    let mut k = 0u64;
    let mut slots = Vec::with_capacity(gaps.len() + 1);
    slots.push(0);
    for g in gaps {
        k += ((g / period_s).round() as u64).max(1);
        slots.push(k);
    }
    slots
}

/// The least-squares line of `times_s` over `slots` (slots strictly rising).
fn fit(slots: &[u64], times_s: &[f64]) -> Line {
    let n = times_s.len() as f64;
    let t0 = times_s[0];
    let kbar = slots.iter().map(|&k| k as f64).sum::<f64>() / n;
    let tbar = times_s.iter().map(|t| t - t0).sum::<f64>() / n;
    let (sxy, sxx) = slots
        .iter()
        .zip(times_s)
        .fold((0.0, 0.0), |(a, b), (&k, &t)| {
            let dk = k as f64 - kbar;
            (a + dk * (t - t0 - tbar), b + dk * dk)
        });
    let period_s = sxy / sxx;
    Line {
        intercept_s: t0 + tbar - period_s * kbar,
        period_s,
    }
}

/// The coarsest of [`QUANTA_S`] and `time_base_s` that every `t_i - t_0`
/// is a whole multiple of, within [`QUANTUM_TOLERANCE`] of it plus the
/// doubles' own rounding of the times.
fn resolution_s(times_s: &[f64], time_base_s: Option<Ratio>) -> Option<f64> {
    let mut candidates: Vec<f64> = QUANTA_S
        .iter()
        .copied()
        .chain(time_base_s.map(Ratio::value))
        .collect();
    candidates.sort_by(|a, b| b.total_cmp(a));
    let t0 = times_s[0];
    let largest = times_s.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    candidates.into_iter().find(|&q| {
        let tolerance = QUANTUM_TOLERANCE + 8.0 * f64::EPSILON * largest / q;
        times_s.iter().all(|&t| {
            let x = (t - t0) / q;
            (x - x.round()).abs() <= tolerance
        })
    })
}

fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// Dominant frequency in Hz of a trace sampled at irregular `times_s`: the
/// largest magnitude of the Hann-windowed (over time) direct Fourier sum
/// `|sum_i w(t_i) (x_i - mean) exp(-2 pi i nu t_i)|` on a grid of step
/// `1 / (8 T)` (`T` the span of the times) from `1.5 / T` to `fps / 2`,
/// refined by a parabola through the peak and its neighbours, as
/// [`super::apparent::dominant_frequency_hz`] does for regular samples.
pub fn dominant_frequency_at_times_hz(
    times_s: &[f64],
    x: &[f64],
    fps: f64,
) -> Result<f64, SpectrumError> {
    let n = x.len().min(times_s.len()).min(MAX_DIRECT_FRAMES);
    if n < 4 {
        return Err(SpectrumError::TooShort(n));
    }
    let (t, x) = (&times_s[..n], &x[..n]);
    let mean = x.iter().sum::<f64>() / n as f64;
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let scale = mean.abs().max(1.0);
    if hi - lo <= super::apparent::FLAT_RELATIVE * scale {
        return Err(SpectrumError::Flat((hi - lo) / scale));
    }
    let span = t[n - 1] - t[0];
    let two_pi = 2.0 * std::f64::consts::PI;
    let weighted: Vec<(f64, f64)> = t
        .iter()
        .zip(x)
        .map(|(&ti, &v)| {
            let w = 0.5 - 0.5 * (two_pi * (ti - t[0]) / span).cos();
            (ti - t[0], w * (v - mean))
        })
        .collect();
    let step = 1.0 / (8.0 * span);
    let count = ((fps / 2.0) / step).floor() as usize + 1;
    let mag = direct_magnitudes(&weighted, step, count);
    let min_hz = 1.5 / span;
    let first = ((min_hz / step).ceil() as usize).clamp(1, count - 1);
    super::apparent::spectrum_peak_hz(&mag, first, step, min_hz, fps)
}

/// `|sum_i v_i exp(-2 pi i k step t_i)|` for every bin `k < count`, of the
/// frames `(t_i, v_i)`. For each frame the phasors of the bins are exact
/// every [`ANCHOR_BINS`] bins and rotated by the bin step in between (a
/// drift of a few units in the 15th digit); each bin sums the frames in
/// frame order.
///
/// The rotation is a chain of dependent multiplications, so frames are
/// taken [`FRAME_LANES`] at a time with one chain each: the chains overlap
/// in the CPU, and every bin still adds the frames' terms in frame order,
/// so the sums are the same to the bit as one frame at a time.
fn direct_magnitudes(frames: &[(f64, f64)], step: f64, count: usize) -> Vec<f64> {
    let (mut re, mut im) = (vec![0.0; count], vec![0.0; count]);
    let mut groups = frames.chunks_exact(FRAME_LANES);
    for group in &mut groups {
        let group: &[(f64, f64); FRAME_LANES] = group.try_into().expect("chunk of FRAME_LANES");
        accumulate_frames(group, step, &mut re, &mut im);
    }
    for frame in groups.remainder() {
        accumulate_frames(std::slice::from_ref(frame), step, &mut re, &mut im);
    }
    re.iter().zip(&im).map(|(r, i)| r.hypot(*i)).collect()
}

/// Frames rotated together by [`direct_magnitudes`].
const FRAME_LANES: usize = 4;

/// Adds the terms of `frames` (in their order) to every bin of `re`, `im`.
fn accumulate_frames(frames: &[(f64, f64)], step: f64, re: &mut [f64], im: &mut [f64]) {
    let two_pi = 2.0 * std::f64::consts::PI;
    let lanes = frames.len();
    let mut rot = [(0.0, 0.0); FRAME_LANES];
    for (r, &(ti, _)) in rot.iter_mut().zip(frames) {
        *r = (two_pi * step * ti).sin_cos();
    }
    for start in (0..re.len()).step_by(ANCHOR_BINS) {
        let mut sc = [(0.0, 0.0); FRAME_LANES];
        for (p, &(ti, _)) in sc.iter_mut().zip(frames) {
            *p = (two_pi * (start as f64 * step) * ti).sin_cos();
        }
        let end = (start + ANCHOR_BINS).min(re.len());
        for (r, i) in re[start..end].iter_mut().zip(&mut im[start..end]) {
            for f in 0..lanes {
                let ((s, c), (ws, wc), v) = (sc[f], rot[f], frames[f].1);
                *r += v * c;
                *i -= v * s;
                sc[f] = (s * wc + c * ws, c * wc - s * ws);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_and_drops_come_from_the_times() {
        let p = 1001.0 / 30000.0;
        let t: Vec<f64> = (0..300).map(|i| i as f64 * p).collect();
        let ft = from_times(&t, &TimeSource::default()).unwrap();
        assert!((ft.fps - 30000.0 / 1001.0).abs() < 1e-9, "{}", ft.fps);
        assert!(ft.regular && ft.dropped_frames == 0);
        assert!((ft.capture_s - 300.0 * p).abs() < 1e-9);
        // Drop frames 100 and 200..203: the rate stays, the drops are counted.
        let dropped: Vec<f64> = t
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 100 && !(200..203).contains(i))
            .map(|(_, &x)| x)
            .collect();
        let ft = from_times(&dropped, &TimeSource::default()).unwrap();
        assert!((ft.fps - 30000.0 / 1001.0).abs() < 1e-9);
        assert!(!ft.regular);
        assert_eq!(ft.dropped_frames, 4);
        assert!(from_times(&[0.0], &TimeSource::default()).is_none());
        assert!(from_times(&[0.0, 0.0, 1.0], &TimeSource::default()).is_none());
    }

    /// The times of the frames in `slots` of a constant `num / den` fps
    /// capture, rounded to the nearest tick of a `1 / ticks_per_s` time
    /// base in integers, as a muxer rounds them: `round(k den ticks / num)`.
    fn rounded_ticks(slots: &[u64], (num, den): (u64, u64), ticks_per_s: u64) -> Vec<u64> {
        slots
            .iter()
            .map(|&k| (2 * k * den * ticks_per_s + num) / (2 * num))
            .collect()
    }

    /// 29.97, 59.94 and 25 fps with 1 ms and 1/90000 s time bases, with
    /// and without drops, with and without the container's time base and
    /// stated rate: the true rate within its stated one-sigma uncertainty
    /// (the stated rate exactly when given), the drops counted exactly,
    /// the resolution found, and the analyses on the true frame times.
    #[test]
    fn rounded_times_give_the_true_rate_drops_and_resolution() {
        let drops: [&[u64]; 2] = [&[], &[50, 120, 121, 122, 250]];
        for (num, den) in [(30000u64, 1001u64), (60000, 1001), (25, 1)] {
            for ticks_per_s in [1000u64, 90_000] {
                for dropped in drops {
                    let slots: Vec<u64> = (0..300).filter(|k| !dropped.contains(k)).collect();
                    let ticks = rounded_ticks(&slots, (num, den), ticks_per_s);
                    let times: Vec<f64> = ticks
                        .iter()
                        .map(|&t| t as f64 / ticks_per_s as f64)
                        .collect();
                    // The coarsest grid the ticks lie on: whole milliseconds
                    // (25 fps at 90 kHz is 3600 ticks a frame), else the tick.
                    let per_ms = ticks_per_s / 1000;
                    let q = if ticks.iter().all(|t| t % per_ms == 0) {
                        1e-3
                    } else {
                        1.0 / ticks_per_s as f64
                    };
                    let truth = num as f64 / den as f64;
                    for (time_base_s, stated_fps) in [
                        (None, None),
                        (Ratio::new(1, ticks_per_s), None),
                        (Ratio::new(1, ticks_per_s), Ratio::new(num, den)),
                    ] {
                        let case = format!(
                            "{num}/{den} fps, 1/{ticks_per_s} s, drops {dropped:?}, time base {time_base_s:?}, stated {stated_fps:?}"
                        );
                        let source = TimeSource {
                            time_base_s,
                            stated_fps,
                        };
                        let ft = from_times(&times, &source).unwrap();
                        assert!(
                            (ft.fps - truth).abs() <= ft.fps_uncertainty,
                            "{case}: {} +/- {} fps",
                            ft.fps,
                            ft.fps_uncertainty
                        );
                        // One sigma is a few thousandths of a frame per second.
                        assert!(ft.fps_uncertainty < 0.01 * truth / 30.0, "{case}");
                        assert_eq!(ft.dropped_frames, dropped.len() as u64, "{case}");
                        assert_eq!(ft.regular, dropped.is_empty(), "{case}");
                        assert_eq!(ft.resolution_s, Some(q), "{case}");
                        assert_eq!(ft.stated_rate_used, stated_fps.is_some(), "{case}");
                        if stated_fps.is_some() {
                            assert_eq!(ft.fps, truth, "{case}");
                        }
                        // The analyses use the slot times: the true times up
                        // to one offset, far below the rounding.
                        assert!(ft.slot_times, "{case}");
                        let offset = ft.times_s[0];
                        for (&k, &t) in slots.iter().zip(&ft.times_s) {
                            let exact = k as f64 * den as f64 / num as f64;
                            assert!((t - offset - exact).abs() < q / 20.0, "{case}: slot {k}");
                        }
                        let span = 300.0 * den as f64 / num as f64;
                        assert!((ft.capture_s - span).abs() < q, "{case}");
                    }
                }
            }
        }
    }

    /// Millisecond times of a logger's clock (Unix time, 1.7e9 s) fit as
    /// the same times from zero do.
    #[test]
    fn times_far_from_zero_fit_as_times_from_zero() {
        let slots: Vec<u64> = (0..300).filter(|k| *k != 77).collect();
        let ms = rounded_ticks(&slots, (30000, 1001), 1000);
        let from_zero: Vec<f64> = ms.iter().map(|&t| t as f64 / 1000.0).collect();
        let unix: Vec<f64> = ms
            .iter()
            .map(|&t| (1_700_000_000_000 + t) as f64 / 1000.0)
            .collect();
        let (a, b) = (
            from_times(&from_zero, &TimeSource::default()).unwrap(),
            from_times(&unix, &TimeSource::default()).unwrap(),
        );
        assert_eq!((b.resolution_s, b.dropped_frames), (Some(1e-3), 1));
        assert!((a.fps - b.fps).abs() < 1e-6 && b.slot_times, "{a:?} {b:?}");
        assert!((b.fps - 30000.0 / 1001.0).abs() <= b.fps_uncertainty);
    }

    /// A stated rate the times do not agree with is not used; times with
    /// real jitter are used as measured.
    #[test]
    fn a_stated_rate_must_agree_with_the_times() {
        let t: Vec<f64> = (0..200)
            .map(|i| i as f64 * 0.04 + 1e-6 * ((i * 37 % 101) as f64 - 50.0))
            .collect();
        let source = TimeSource {
            time_base_s: Ratio::new(1, 1_000_000),
            stated_fps: Ratio::new(30000, 1001),
        };
        let ft = from_times(&t, &source).unwrap();
        assert!(!ft.stated_rate_used);
        assert!((ft.fps - 25.0).abs() < 3.0 * ft.fps_uncertainty, "{ft:?}");
        assert_eq!(ft.resolution_s, Some(1e-6));
        assert!(!ft.slot_times);
        assert_eq!(ft.times_s, t);
    }

    /// A sine at irregular times: the direct sum finds it within a tenth of
    /// a resolution bin; the FFT on the frame numbers would not.
    #[test]
    fn irregular_spectrum_finds_a_sine_at_its_real_times() {
        let fps = 30.0;
        let t: Vec<f64> = (0..900)
            .filter(|i| i % 7 != 3)
            .map(|i| i as f64 / fps + 0.002 * ((i * 37 % 11) as f64 - 5.0) / 5.0)
            .collect();
        let nu = 1.15;
        let x: Vec<f64> = t
            .iter()
            .map(|&ti| 100.0 + 10.0 * (2.0 * std::f64::consts::PI * nu * ti).sin())
            .collect();
        let got = dominant_frequency_at_times_hz(&t, &x, fps).unwrap();
        assert!((got - nu).abs() < 0.1 / 30.0, "{got}");
        assert!(matches!(
            dominant_frequency_at_times_hz(&t, &vec![5.0; t.len()], fps),
            Err(SpectrumError::Flat(_))
        ));
    }

    /// Frames taken [`FRAME_LANES`] at a time give the same bits as one
    /// frame at a time (the sum in frame order of the same terms).
    #[test]
    fn interleaved_frames_sum_to_the_same_bits() {
        let one_at_a_time = |frames: &[(f64, f64)], step: f64, count: usize| {
            let (mut re, mut im) = (vec![0.0; count], vec![0.0; count]);
            for f in frames {
                accumulate_frames(std::slice::from_ref(f), step, &mut re, &mut im);
            }
            re.iter()
                .zip(&im)
                .map(|(r, i)| r.hypot(*i))
                .collect::<Vec<f64>>()
        };
        for n in [1, 3, 4, 5, 9, 402] {
            let frames: Vec<(f64, f64)> = (0..n)
                .map(|i| {
                    (
                        i as f64 / 29.97 + 1e-4 * (i % 5) as f64,
                        ((i * 7919) % 211) as f64 - 105.0,
                    )
                })
                .collect();
            let (step, count) = (1.0 / (8.0 * 13.4), 1611);
            let a = direct_magnitudes(&frames, step, count);
            let b = one_at_a_time(&frames, step, count);
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                "n={n}"
            );
        }
    }

    /// The rotated phasors give every bin's magnitude as the exact sine and
    /// cosine of each bin do, to 1e-12 of the largest.
    #[test]
    fn rotated_phasors_match_the_exact_sum() {
        let frames: Vec<(f64, f64)> = (0..700)
            .filter(|i| i % 9 != 4)
            .map(|i| {
                let t = i as f64 / 29.97 + 1e-4 * (i % 5) as f64;
                (t, ((i * 7919) % 211) as f64 - 105.0)
            })
            .collect();
        let (step, count) = (1.0 / (8.0 * 23.4), 2805);
        let fast = direct_magnitudes(&frames, step, count);
        let two_pi = 2.0 * std::f64::consts::PI;
        let exact: Vec<f64> = (0..count)
            .map(|k| {
                let nu = k as f64 * step;
                let (re, im) = frames.iter().fold((0.0, 0.0), |(re, im), &(t, v)| {
                    let (s, c) = (two_pi * nu * t).sin_cos();
                    (re + v * c, im - v * s)
                });
                re.hypot(im)
            })
            .collect();
        let top = exact.iter().fold(0.0f64, |a, &b| a.max(b));
        for (k, (a, b)) in fast.iter().zip(&exact).enumerate() {
            assert!((a - b).abs() <= 1e-12 * top, "bin {k}: {a} vs {b}");
        }
    }
}
