//! A case's frame timing, from the frames' own start times.
//!
//! A capture (video container timestamps, a sidecar, `[capture]
//! frame-rate-fps`) or a rig gives each frame a start time `t_i`. The frame
//! rate is the slope of those times over frame slots: with `m` the median
//! interval, frame `i` sits in slot `k_i = round((t_i - t_0) / m)`, and the
//! frame period is the least-squares slope of `t_i` over `k_i`. A dropped
//! frame leaves a slot empty and does not bias the rate. The phase fold and
//! the phase coverage use the times themselves (`frac(t_i f)`), so drops and
//! a variable frame rate are folded where they really fell.
//!
//! The spectrum of a trace is an FFT when the frames sit in consecutive
//! slots (a regular capture), and otherwise a direct Fourier sum over the
//! real times ([`dominant_frequency_at_times_hz`]), with the same window,
//! padding and refinement.

use serde::{Deserialize, Serialize};

use super::apparent::SpectrumError;

/// An interval further than this fraction from the median interval makes
/// the timing irregular (a drop, a doubled frame, a variable frame rate).
pub const IRREGULAR_INTERVAL: f64 = 0.25;

/// Longest trace (frames) the direct Fourier sum of an irregular capture
/// takes; longer irregular traces use their first this many frames.
pub const MAX_DIRECT_FRAMES: usize = 20_000;

/// Bins of the direct Fourier sum between exactly computed phasors; the
/// phasors in between are rotated from them.
const ANCHOR_BINS: usize = 32;

/// Frame timing of a trace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameTiming {
    /// Start of each frame, seconds.
    #[serde(skip)]
    pub times_s: Vec<f64>,
    /// Frame rate from the times (least-squares slope over frame slots), /s.
    pub fps: f64,
    /// Every frame in its own consecutive slot, every interval within
    /// [`IRREGULAR_INTERVAL`] of the median.
    pub regular: bool,
    /// Empty slots between the first and last frame (dropped frames).
    pub dropped_frames: u64,
    /// First to last frame start plus one frame period, seconds.
    pub capture_s: f64,
}

/// The timing of frames starting at `times_s` (strictly rising), or `None`
/// for fewer than 2 frames or times that do not rise.
pub fn from_times(times_s: &[f64]) -> Option<FrameTiming> {
    let n = times_s.len();
    if n < 2 {
        return None;
    }
    let gaps: Vec<f64> = times_s.windows(2).map(|w| w[1] - w[0]).collect();
    if gaps.iter().any(|g| !(g.is_finite() && *g > 0.0)) {
        return None;
    }
    let t0 = times_s[0];
    let m = median(&mut gaps.clone());
    let within = gaps
        .iter()
        .all(|g| (g / m - 1.0).abs() <= IRREGULAR_INTERVAL);
    let slots: Vec<f64> = times_s.iter().map(|t| ((t - t0) / m).round()).collect();
    let consecutive = slots.iter().enumerate().all(|(i, &k)| k == i as f64);
    let (kbar, tbar) = (
        slots.iter().sum::<f64>() / n as f64,
        times_s.iter().sum::<f64>() / n as f64,
    );
    let (sxy, sxx) = slots
        .iter()
        .zip(times_s)
        .fold((0.0, 0.0), |(a, b), (&k, &t)| {
            (a + (k - kbar) * (t - tbar), b + (k - kbar) * (k - kbar))
        });
    let period = if sxx > 0.0 { sxy / sxx } else { m };
    let last_slot = slots[n - 1];
    Some(FrameTiming {
        times_s: times_s.to_vec(),
        fps: 1.0 / period,
        regular: consecutive && within,
        dropped_frames: (last_slot + 1.0 - n as f64).max(0.0) as u64,
        capture_s: times_s[n - 1] - t0 + period,
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
        let ft = from_times(&t).unwrap();
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
        let ft = from_times(&dropped).unwrap();
        assert!((ft.fps - 30000.0 / 1001.0).abs() < 1e-9);
        assert!(!ft.regular);
        assert_eq!(ft.dropped_frames, 4);
        assert!(from_times(&[0.0]).is_none());
        assert!(from_times(&[0.0, 0.0, 1.0]).is_none());
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
