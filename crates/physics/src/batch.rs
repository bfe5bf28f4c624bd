//! The exact closed form over many frames at once: the hot loop of the
//! simulator, the fine maps and the bench.
//!
//! [`Shutter::frame_on_fractions`] returns, bit for bit, what
//! [`Shutter::frame_on_fraction`] returns frame by frame, but faster:
//!
//! - **No `fmod` per frame.** Frame `k` starts `(k * f mod fps) / fps`
//!   PWM cycles after a rising edge. When every `k * f` of the range is an
//!   exact double (an integer frequency, say), the remainder of frame
//!   `k + s` follows from that of frame `k` by one add or one subtract, and
//!   each step is exact: every value it takes is a multiple of the unit in
//!   the last place of `fps` below `fps`, so it is representable and IEEE
//!   arithmetic returns it unrounded. That is the same remainder that
//!   `fmod(k * f, fps)` returns. The step `s` is [`LANES`] frames, so that
//!   [`LANES`] independent chains run side by side in vector registers
//!   instead of one serial chain. When the condition does not hold, the
//!   exact per-frame `fmod` is used instead.
//! - **A loop the compiler vectorises.** The phases of a chunk of frames
//!   are stepped first, then each ROI row is integrated over the whole
//!   chunk in a branch-free loop, added in row order into the output.
//! - **Two copies of that loop.** On a CPU with AVX2 (checked at run time)
//!   the loop runs four frames per instruction and `floor` is one
//!   `vroundpd`. Elsewhere (plain x86-64, SSE2) `floor` is the `2^52`
//!   rounding trick, which is exact for the non-negative arguments met here
//!   and needs no library call, and the loop runs two frames per
//!   instruction. Both floors are exact, so both copies return the same
//!   bits. Neither copy enables FMA, and Rust never fuses `a * b + c` on its
//!   own, so every product and sum is rounded as in the scalar code.
//! - **Less work per integral than the scalar form.** A phase in `[0, 1)`
//!   has `floor(phase) = 0`, so the ON time before it is just
//!   `min(phase, duty)` (the scalar form computes `0 * duty + min(..)`,
//!   the same double); and the mean over `n` rows multiplies by `1 / n`
//!   when `n` is a power of two, which rounds exactly as dividing by `n`.

use std::ops::Range;

use super::pwm::{PwmDrive, wrap_unit};
use super::remainder::rem;
use super::shutter::Shutter;

/// Frames per chunk: large enough to amortise the per-row set-up, small
/// enough that the chunk's phases stay in the L1 cache. A multiple of
/// [`LANES`].
const CHUNK: usize = 256;

/// Independent remainder chains, one per frame of a group of `LANES`
/// consecutive frames; each steps `LANES` frames at a time. A power of two,
/// so that `LANES * f` is exact.
const LANES: usize = 8;

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

/// `x.floor()` as one instruction, for the AVX2 copy of the loop.
#[inline(always)]
fn floor_native(x: f64) -> f64 {
    x.floor()
}

/// [`super::pwm::on_fraction`] for `0 <= phase < 1`, `duty < 1` and
/// `phase + width < 2^51`, given an exact `floor` for that range.
///
/// The ON time before `phase` is `min(phase, duty)`: the scalar form's
/// `floor(phase) * duty + min(phase - floor(phase), duty)` with
/// `floor(phase) = 0`, which is `+0.0 + min(phase, duty)`, the same double.
#[inline(always)]
fn on_fraction_unit(floor: impl Fn(f64) -> f64, phase: f64, width: f64, duty: f64) -> f64 {
    let end = phase + width;
    let n = floor(end);
    let part = end - n;
    let on_end = n * duty + if part < duty { part } else { duty };
    let on_start = if phase < duty { phase } else { duty };
    let v = (on_end - on_start) / width;
    let v = if v > 0.0 { v } else { 0.0 };
    if v < 1.0 { v } else { 1.0 }
}

/// [`wrap_unit`] for `0 <= x < 2^51`: `x - floor(x)`. For such `x` the
/// subtraction is exact (for `x >= 1`, `floor(x) <= x < 2 * floor(x)`), so
/// the result is below 1 and [`wrap_unit`]'s correction never applies.
#[inline(always)]
fn wrap_nonneg(floor: impl Fn(f64) -> f64, x: f64) -> f64 {
    x - floor(x)
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

/// Steps `k * f mod fps` from frame `k` to frame `k + stride`, exactly, or
/// says it cannot.
#[derive(Debug, Clone, Copy)]
struct RemainderStep {
    /// `stride * f mod fps`, added when no wrap occurs.
    add: f64,
    /// `fps - add`, subtracted when a wrap occurs.
    sub: f64,
}

impl RemainderStep {
    /// The exact step of `stride` frames (a power of two) for frames
    /// `frames` of a drive at `f` Hz and `fps`, if every `k * f` of the
    /// range is an exact double and every remainder is a multiple of
    /// `ulp(fps)` (then every step is exact; see the module doc).
    fn exact(f: f64, fps: f64, frames: &Range<u64>, stride: u64) -> Option<Self> {
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
        // A power-of-two multiple is exact unless it overflows.
        let stride_f = stride as f64 * f;
        if !stride.is_power_of_two() || !stride_f.is_finite() {
            return None;
        }
        let add = stride_f % fps;
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

/// One call of [`Shutter::frame_on_fractions`] on the fast path: the drive,
/// the rows and what is fixed per call.
struct Batch<'a> {
    shutter: &'a Shutter,
    pwm: &'a PwmDrive,
    /// The distinct ROI rows, in order.
    rows: Range<u32>,
    /// Exposure width in PWM cycles, `0 < width < 2^51 - 2`.
    width: f64,
    /// Duty cycle, below 1.
    duty: f64,
    /// The exact remainder step of [`LANES`] frames, if there is one.
    step: Option<RemainderStep>,
}

impl Batch<'_> {
    /// The phase, in cycles from a rising edge, of row `row`'s offset: the
    /// same `wrap_unit((offset - first_rise) * f)` that
    /// [`PwmDrive::phase_at`] adds.
    fn row_rest(&self, row: u32) -> f64 {
        let f = self.pwm.frequency_hz();
        wrap_unit((self.shutter.row_offset_s(row) - self.pwm.first_rise_s()) * f)
    }

    /// `(k * f mod fps) / fps` for `k = first..first + whole.len()`, into
    /// `whole`. `chains` holds the remainders of frames `first..first +
    /// LANES` on entry and those of the frames after `whole` on return
    /// (stepped path only).
    #[inline(always)]
    fn cycle_phases(&self, first: u64, whole: &mut [f64], chains: &mut [f64; LANES]) {
        let f = self.pwm.frequency_hz();
        let fps = self.shutter.fps;
        match self.step {
            Some(step) => {
                for group in whole.chunks_mut(LANES) {
                    for (w, &rem) in group.iter_mut().zip(chains.iter()) {
                        *w = rem / fps;
                    }
                    for rem in chains.iter_mut() {
                        *rem = step.next(*rem);
                    }
                }
            }
            None => {
                for (i, w) in whole.iter_mut().enumerate() {
                    *w = rem((first + i as u64) as f64 * f, fps) / fps;
                }
            }
        }
    }

    /// Fills `out` with the ON fractions of frames `start..start +
    /// out.len()`, using `floor` (exact on `[0, 2^51)`) for every floor in
    /// the loop.
    #[inline(always)]
    fn fill(&self, floor: impl Fn(f64) -> f64 + Copy, start: u64, out: &mut [f64]) {
        let f = self.pwm.frequency_hz();
        let fps = self.shutter.fps;
        let mut chains = [0.0; LANES];
        for (j, chain) in chains.iter_mut().enumerate() {
            // Frames past the range are stepped but never read.
            *chain = rem((start + j as u64) as f64 * f, fps);
        }
        let mut whole = [0.0f64; CHUNK];
        for (c, acc) in out.chunks_mut(CHUNK).enumerate() {
            let whole = &mut whole[..acc.len()];
            self.cycle_phases(start + (c * CHUNK) as u64, whole, &mut chains);
            let mut rows = self.rows.clone();
            if let Some(row) = rows.next() {
                self.integrate_row(floor, whole, row, acc, false);
            }
            for row in rows {
                self.integrate_row(floor, whole, row, acc, true);
            }
            mean_of_rows(acc, self.rows.len());
        }
    }

    /// The ON fraction of row `row` for each frame phase in `whole`, stored
    /// into `acc` (the first row) or added to it (the next rows, in row
    /// order, as the scalar sum adds them). Storing equals adding to 0.0:
    /// the fraction is never -0.0.
    #[inline(always)]
    fn integrate_row(
        &self,
        floor: impl Fn(f64) -> f64 + Copy,
        whole: &[f64],
        row: u32,
        acc: &mut [f64],
        add: bool,
    ) {
        let rest = self.row_rest(row);
        let (width, duty) = (self.width, self.duty);
        let fraction = |w: f64| on_fraction_unit(floor, wrap_nonneg(floor, w + rest), width, duty);
        if add {
            acc.iter_mut()
                .zip(whole)
                .for_each(|(a, &w)| *a += fraction(w));
        } else {
            acc.iter_mut()
                .zip(whole)
                .for_each(|(a, &w)| *a = fraction(w));
        }
    }

    /// [`Batch::fill`] with the portable floor: SSE2 on plain x86-64.
    fn fill_portable(&self, start: u64, out: &mut [f64]) {
        self.fill(floor_nonneg, start, out);
    }

    /// [`Batch::fill`] compiled for AVX2: four frames per instruction and a
    /// one-instruction floor. FMA stays off, so every product and sum is
    /// rounded as in the portable copy.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn fill_avx2(&self, start: u64, out: &mut [f64]) {
        self.fill(floor_native, start, out);
    }

    /// [`Batch::fill`] with the fastest copy this CPU runs.
    fn fill_dispatch(&self, start: u64, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: `fill_avx2` needs AVX2 and nothing else, and the CPU
            // has just been checked to support it.
            unsafe { self.fill_avx2(start, out) };
            return;
        }
        self.fill_portable(start, out);
    }
}

/// Divides each sum of `rows` row integrals by `rows`, rounding as `sum /
/// rows` does: for a power of two, `1 / rows` is exact and multiplying by
/// it rounds the same exact quotient.
#[inline(always)]
fn mean_of_rows(acc: &mut [f64], rows: usize) {
    let n = rows as f64;
    if rows == 1 {
        // x / 1 == x for every double.
    } else if rows.is_power_of_two() {
        let inv = 1.0 / n;
        acc.iter_mut().for_each(|a| *a *= inv);
    } else {
        acc.iter_mut().for_each(|a| *a /= n);
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
        if duty >= 1.0 || !(width > 0.0 && width + 2.0 < FLOOR_LIMIT) || rows.is_empty() {
            out.extend(frames.map(|k| self.frame_on_fraction(pwm, k, rows.clone())));
            return;
        }
        let batch = Batch {
            shutter: self,
            pwm,
            rows: self.distinct_rows(rows),
            width,
            duty,
            step: RemainderStep::exact(f, self.fps, &frames, LANES as u64),
        };
        let first = out.len();
        out.resize(
            first + frames.end.saturating_sub(frames.start) as usize,
            0.0,
        );
        batch.fill_dispatch(frames.start, &mut out[first..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pwm::on_fraction;
    use crate::sensor::Rng;
    use crate::shutter::ShutterModel;

    #[test]
    fn floor_trick_matches_floor_on_awkward_values() {
        let mut xs = vec![0.0, 0.5, 1.0, 1.5, 2.5, 0.999_999_999_999_999_9, 1e15 + 0.5];
        xs.extend((0..1000).map(|i| i as f64 * 0.1 + 1e-17));
        xs.push(f64::from_bits(1.0f64.to_bits() - 1));
        for x in xs {
            assert_eq!(floor_nonneg(x).to_bits(), x.floor().to_bits(), "x = {x}");
            assert_eq!(
                wrap_nonneg(floor_nonneg, x).to_bits(),
                wrap_unit(x).to_bits()
            );
        }
    }

    #[test]
    fn kernel_matches_the_scalar_closed_form_bit_for_bit() {
        let mut rng = Rng::new(7);
        let mut phases: Vec<f64> = (0..100_000).map(|_| rng.uniform()).collect();
        // Edges: a phase of 0, just below 1, and on the falling edge.
        phases.extend([0.0, f64::from_bits(1.0f64.to_bits() - 1), 0.25]);
        for phase in phases {
            let width = rng.uniform() * 50.0 + 1e-9;
            let duty = if phase == 0.25 {
                0.25
            } else {
                rng.uniform().max(1e-6)
            };
            let want = on_fraction(phase, width, duty).to_bits();
            let msg = format!("phase {phase} width {width} duty {duty}");
            assert_eq!(
                on_fraction_unit(floor_nonneg, phase, width, duty).to_bits(),
                want,
                "{msg}"
            );
            assert_eq!(
                on_fraction_unit(floor_native, phase, width, duty).to_bits(),
                want,
                "{msg}"
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
            for stride in [1, LANES as u64] {
                let step = RemainderStep::exact(f, fps, &frames, stride).expect("exact");
                // One chain per residue of k mod stride.
                for lane in 0..stride {
                    let mut rem = (lane as f64 * f) % fps;
                    for k in frames.clone().skip(lane as usize).step_by(stride as usize) {
                        assert_eq!(rem, (k as f64 * f) % fps, "f={f} fps={fps} k={k}");
                        rem = step.next(rem);
                    }
                }
            }
        }
        // Non-representable products: refuse rather than drift.
        assert!(RemainderStep::exact(0.1, 30.0, &(0..10), 8).is_none());
        assert!(RemainderStep::exact(151.37, 29.97, &(0..u64::MAX / 2), 8).is_none());
        // A stride that is not a power of two, or whose product overflows.
        assert!(RemainderStep::exact(100.0, 30.0, &(0..10), 3).is_none());
        assert!(RemainderStep::exact(f64::MAX / 2.0, 30.0, &(0..1), 8).is_none());
    }

    /// Runs `fill` through both copies of the loop that this CPU can run.
    fn both_copies(shutter: &Shutter, pwm: &PwmDrive, frames: Range<u64>, rows: Range<u32>) {
        let mut via_dispatch = Vec::new();
        shutter.frame_on_fractions(pwm, frames.clone(), rows.clone(), &mut via_dispatch);
        let batch = Batch {
            shutter,
            pwm,
            rows: shutter.distinct_rows(rows.clone()),
            width: shutter.exposure_s * pwm.frequency_hz(),
            duty: pwm.duty(),
            step: RemainderStep::exact(pwm.frequency_hz(), shutter.fps, &frames, LANES as u64),
        };
        let mut portable = vec![0.0; frames.clone().count()];
        batch.fill_portable(frames.start, &mut portable);
        for (k, (a, b)) in frames.zip(via_dispatch.iter().zip(&portable)) {
            assert_eq!(a.to_bits(), b.to_bits(), "frame {k}");
        }
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
            // 1 to 4 rows: the mean divides, multiplies by 1/2 or 1/4, or
            // does nothing.
            let rows = 399..400 + (case as u32 / 5) % 4;
            // Frame counts around the chunk and lane sizes.
            let len = [700, 0, 1, 7, 9, 255, 257][case % 7];
            let frames = first..first + len;
            let mut got = vec![-1.0];
            shutter.frame_on_fractions(&pwm, frames.clone(), rows.clone(), &mut got);
            assert_eq!(got.len(), 1 + len as usize);
            assert_eq!(got[0], -1.0, "appends, keeps what was there");
            for (k, v) in frames.clone().zip(&got[1..]) {
                let want = shutter.frame_on_fraction(&pwm, k, rows.clone());
                assert_eq!(v.to_bits(), want.to_bits(), "case {case} frame {k}");
            }
            if duty < 1.0 {
                both_copies(&shutter, &pwm, frames, rows);
            }
        }
    }

    #[test]
    fn the_bench_grid_is_bit_identical_on_both_copies() {
        let shutter = Shutter {
            model: ShutterModel::Rolling {
                line_time_s: 14.565e-6,
            },
            exposure_s: 5e-3,
            fps: 30.0,
        };
        for f in [50.0, 60.0, 75.0, 90.0, 100.0, 120.0, 150.0, 200.0, 1000.0] {
            for d in [0.05, 0.5, 0.8] {
                let pwm = PwmDrive::new(f, d, 1.234e-4).unwrap();
                let mut got = Vec::new();
                shutter.frame_on_fractions(&pwm, 0..1920, 399..401, &mut got);
                for (k, v) in got.iter().enumerate() {
                    let want = shutter.frame_on_fraction(&pwm, k as u64, 399..401);
                    assert_eq!(v.to_bits(), want.to_bits(), "f {f} D {d} frame {k}");
                }
                both_copies(&shutter, &pwm, 0..1920, 399..401);
            }
        }
    }
}
