//! The exact closed form over many frames at once: the hot loop of the
//! simulator, the fine maps and the bench.
//!
//! [`Shutter::frame_on_fractions`] returns, bit for bit, what
//! [`Shutter::frame_on_fraction`] returns frame by frame, but faster:
//!
//! - **No `fmod` per frame.** Frame `k` starts `(k * f mod fps) / fps`
//!   PWM cycles after a rising edge. When every `k * f` of the range is an
//!   exact double (an integer frequency, say), the remainder steps from frame
//!   to frame by one add or one subtract, and each step is exact: every value
//!   it takes is a multiple of the unit in the last place of `fps` below
//!   `fps`, so it is representable and IEEE arithmetic returns it unrounded.
//!   That is the same remainder that `fmod(k * f, fps)` returns. When the
//!   condition does not hold, the exact per-frame `fmod` is used instead.
//! - **A loop the compiler vectorises.** The remainders of a chunk of frames
//!   are stepped first (a short serial chain), then each ROI row is
//!   integrated over the whole chunk in a branch-free loop: `floor` is the
//!   `2^52` rounding trick, which is exact for the non-negative arguments
//!   met here and needs no library call, so the loop runs two frames per
//!   instruction on plain x86-64 (SSE2).

use std::ops::Range;

use super::pwm::{PwmDrive, wrap_unit};
use super::shutter::Shutter;

/// Frames per chunk: large enough to amortise the per-row set-up, small
/// enough that the chunk's buffers stay in the L1 cache.
const CHUNK: usize = 256;

/// 2^52: adding and subtracting it rounds a double in `[0, 2^51)` to the
/// nearest integer.
const TWO_POW_52: f64 = 4_503_599_627_370_496.0;

/// Largest argument for which [`floor_nonneg`] is exact.
const FLOOR_LIMIT: f64 = 2_251_799_813_685_248.0; // 2^51

/// `x.floor()` for `0 <= x < 2^51`, without a library call.
#[inline(always)]
fn floor_nonneg(x: f64) -> f64 {
    let nearest = (x + TWO_POW_52) - TWO_POW_52;
    if nearest > x { nearest - 1.0 } else { nearest }
}

/// [`wrap_unit`] for `0 <= x < 2^51`.
#[inline(always)]
fn wrap_nonneg(x: f64) -> f64 {
    let w = x - floor_nonneg(x);
    if w >= 1.0 { 0.0 } else { w }
}

/// [`super::pwm::on_cycles`] for `0 <= u < 2^51`.
#[inline(always)]
fn on_cycles_nonneg(u: f64, duty: f64) -> f64 {
    let n = floor_nonneg(u);
    let part = u - n;
    n * duty + if part < duty { part } else { duty }
}

/// [`super::pwm::on_fraction`] for `0 <= phase < 2`, `duty < 1` and
/// `phase + width < 2^51`.
#[inline(always)]
fn on_fraction_nonneg(phase: f64, width: f64, duty: f64) -> f64 {
    let on = on_cycles_nonneg(phase + width, duty) - on_cycles_nonneg(phase, duty);
    let v = on / width;
    let v = if v > 0.0 { v } else { 0.0 };
    if v < 1.0 { v } else { 1.0 }
}

/// The lowest set bit of a finite, non-zero double, as a power of two.
fn lowest_bit(x: f64) -> f64 {
    let bits = x.abs().to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i32;
    let mantissa = bits & ((1u64 << 52) - 1);
    // Subnormals have no implicit bit and the exponent of the smallest normal.
    let (significand, exp) = if exponent == 0 {
        (mantissa, -1074)
    } else {
        (mantissa | (1u64 << 52), exponent - 1075)
    };
    2f64.powi(exp + significand.trailing_zeros() as i32)
}

/// The unit in the last place of a positive normal double.
fn ulp(x: f64) -> f64 {
    let exponent = ((x.to_bits() >> 52) & 0x7ff) as i32;
    2f64.powi(exponent - 1075)
}

/// Steps `k * f mod fps` from frame to frame, exactly, or says it cannot.
#[derive(Debug, Clone, Copy)]
struct RemainderStep {
    /// `f mod fps`, added when no wrap occurs.
    add: f64,
    /// `fps - add`, subtracted when a wrap occurs.
    sub: f64,
}

impl RemainderStep {
    /// The exact step for frames `frames` of a drive at `f` Hz and `fps`, if
    /// every `k * f` of the range is an exact double and every remainder is a
    /// multiple of `ulp(fps)` (then every step is exact; see the module doc).
    fn exact(f: f64, fps: f64, frames: &Range<u64>) -> Option<Self> {
        if !(f.is_finite() && f > 0.0 && fps.is_normal() && fps > 0.0) {
            return None;
        }
        // k * f is exact while k * (odd part of f's significand) < 2^53.
        let odd = f / lowest_bit(f);
        if frames.end as f64 * odd >= 2f64.powi(53) {
            return None;
        }
        if lowest_bit(f) < ulp(fps) {
            return None;
        }
        let add = f % fps;
        Some(Self {
            add,
            sub: fps - add,
        })
    }

    #[inline(always)]
    fn next(self, rem: f64) -> f64 {
        if rem >= self.sub {
            rem - self.sub
        } else {
            rem + self.add
        }
    }
}

impl Shutter {
    /// [`Shutter::frame_on_fraction`] of every frame in `frames`, appended to
    /// `out` in frame order. The values are bit-identical to the per-frame
    /// call; only the time differs.
    pub fn frame_on_fractions(
        &self,
        pwm: &PwmDrive,
        frames: Range<u64>,
        rows: Range<u32>,
        out: &mut Vec<f64>,
    ) {
        let f = pwm.frequency_hz();
        let duty = pwm.duty();
        let width = self.exposure_s * f;
        if duty >= 1.0 || !(width > 0.0 && width + 2.0 < FLOOR_LIMIT) {
            out.extend(frames.map(|k| self.frame_on_fraction(pwm, k, rows.clone())));
            return;
        }
        // The same per-row offset that PwmDrive::phase_at adds.
        let rests: Vec<f64> = self
            .distinct_rows(rows)
            .map(|r| wrap_unit((self.row_offset_s(r) - pwm.first_rise_s()) * f))
            .collect();
        let n = rests.len() as f64;
        let fps = self.fps;
        let step = RemainderStep::exact(f, fps, &frames);
        out.reserve(frames.end.saturating_sub(frames.start) as usize);

        let mut whole = [0.0f64; CHUNK];
        let mut acc = [0.0f64; CHUNK];
        let mut start = frames.start;
        let mut rem = (start as f64 * f) % fps;
        while start < frames.end {
            let len = ((frames.end - start) as usize).min(CHUNK);
            match step {
                Some(step) => {
                    for w in whole[..len].iter_mut() {
                        *w = rem;
                        rem = step.next(rem);
                    }
                }
                None => {
                    for (i, w) in whole[..len].iter_mut().enumerate() {
                        *w = ((start + i as u64) as f64 * f) % fps;
                    }
                }
            }
            for w in whole[..len].iter_mut() {
                *w /= fps;
            }
            acc[..len].fill(0.0);
            for &rest in &rests {
                for (a, &w) in acc[..len].iter_mut().zip(&whole[..len]) {
                    let phase = wrap_nonneg(w + rest);
                    *a += on_fraction_nonneg(phase, width, duty);
                }
            }
            out.extend(acc[..len].iter().map(|&a| a / n));
            start += len as u64;
        }
    }
}

/// [`super::pwm::on_fraction`] through the batch kernel, for tests.
#[cfg(test)]
fn kernel_on_fraction(phase: f64, width: f64, duty: f64) -> f64 {
    on_fraction_nonneg(phase, width, duty)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::pwm::on_fraction;
    use crate::physics::sensor::Rng;
    use crate::physics::shutter::ShutterModel;

    #[test]
    fn floor_trick_matches_floor_on_awkward_values() {
        let mut xs = vec![0.0, 0.5, 1.0, 1.5, 2.5, 0.999_999_999_999_999_9, 1e15 + 0.5];
        xs.extend((0..1000).map(|i| i as f64 * 0.1 + 1e-17));
        xs.push(f64::from_bits(1.0f64.to_bits() - 1));
        for x in xs {
            assert_eq!(floor_nonneg(x).to_bits(), x.floor().to_bits(), "x = {x}");
        }
    }

    #[test]
    fn kernel_matches_the_scalar_closed_form_bit_for_bit() {
        let mut rng = Rng::new(7);
        for _ in 0..100_000 {
            let phase = rng.uniform() * 1.999;
            let width = rng.uniform() * 50.0 + 1e-9;
            let duty = rng.uniform().max(1e-6);
            assert_eq!(
                kernel_on_fraction(phase, width, duty).to_bits(),
                on_fraction(phase, width, duty).to_bits(),
                "phase {phase} width {width} duty {duty}"
            );
        }
    }

    #[test]
    fn remainder_stepping_equals_fmod_where_it_claims_exactness() {
        for &(f, fps) in &[
            (151.0, 29.97),
            (90.0, 30.0),
            (1000.0, 59.94),
            (150.5, 29.97),
            (613.25, 24.0),
        ] {
            let frames = 0..100_000u64;
            let step = RemainderStep::exact(f, fps, &frames).expect("exact for these");
            let mut rem = 0.0;
            for k in frames {
                assert_eq!(rem, (k as f64 * f) % fps, "f={f} fps={fps} k={k}");
                rem = step.next(rem);
            }
        }
        // Non-representable products: refuse rather than drift.
        assert!(RemainderStep::exact(0.1, 30.0, &(0..10)).is_none());
        assert!(RemainderStep::exact(151.37, 29.97, &(0..u64::MAX / 2)).is_none());
    }

    #[test]
    fn batch_equals_frame_by_frame_bit_for_bit() {
        let mut rng = Rng::new(2016);
        for case in 0..300 {
            let f = match case % 3 {
                0 => (50.0 + rng.uniform() * 1950.0).round(),
                1 => 50.0 + rng.uniform() * 1950.0,
                _ => 30.0 * (1 + case % 7) as f64,
            };
            let duty = match case % 5 {
                0 => 1.0,
                _ => 0.01 + rng.uniform() * 0.98,
            };
            let model = if case % 2 == 0 {
                ShutterModel::Global
            } else {
                ShutterModel::Rolling {
                    line_time_s: 14.565e-6,
                }
            };
            let shutter = Shutter {
                model,
                exposure_s: 1e-5 + rng.uniform() * 0.03,
                fps: [30.0, 29.97, 60.0, 25.0][case % 4],
            };
            let pwm = PwmDrive::new(f, duty, rng.uniform() * 0.01 - 0.005).unwrap();
            let first = (case as u64 % 4) * 977;
            let frames = first..first + 700;
            let mut got = Vec::new();
            shutter.frame_on_fractions(&pwm, frames.clone(), 399..402, &mut got);
            assert_eq!(got.len(), 700);
            for (k, v) in frames.zip(&got) {
                let want = shutter.frame_on_fraction(&pwm, k, 399..402);
                assert_eq!(v.to_bits(), want.to_bits(), "case {case} frame {k}");
            }
        }
    }
}
