//! The worst case over PWM phase, computed exactly: the kernel behind
//! [`Shutter::phase_envelope`], which the fine maps and the exposure
//! advice call once per grid cell (hundreds of thousands of times per plan).
//!
//! The ROI mean ON fraction is piecewise linear in the PWM's start phase,
//! with corners where a row's exposure start or end crosses a rising or a
//! falling edge, so its extremes lie at those corners: `4 * rows` of them,
//! each a mean over the rows.
//!
//! The kernel takes the rows' phase offsets in a slice (on the stack for up
//! to [`STACK_ROWS`] rows: no allocation per cell) and does the arithmetic
//! of the closed form ([`on_fraction`], [`wrap_unit`]) in the same order as
//! the textbook loop, so its results are the same doubles. Two copies are
//! compiled: on a CPU with AVX2 (checked at run time, as in
//! [`super::batch`]) every `floor` is one `vroundsd` instruction; elsewhere
//! (plain x86-64) it is a library call. `floor` is exact either way and no
//! copy enables FMA (Rust never fuses `a * b + c` on its own), so both
//! return the same bits.

use std::ops::Range;

use super::pwm::{PwmDrive, on_fraction, wrap_unit};
use super::shutter::Shutter;

/// Distinct ROI rows whose phase offsets are held on the stack; a taller
/// ROI of a rolling shutter takes one allocation per call.
pub const STACK_ROWS: usize = 8;

/// Lowest and highest ROI-mean ON fraction over every start phase, for rows
/// whose exposures start `offsets` cycles (each in `[0, 1)`) after row 0's,
/// an exposure `width` cycles long (> 0) and `duty` in `(0, 1)`.
/// `(inf, -inf)` when `offsets` is empty.
#[inline(always)]
fn corner_extremes(offsets: &[f64], width: f64, duty: f64) -> (f64, f64) {
    let mean_at = |phase0: f64| -> f64 {
        offsets
            .iter()
            .map(|&o| on_fraction(wrap_unit(phase0 + o), width, duty))
            .sum::<f64>()
            / offsets.len() as f64
    };
    let corners = [0.0, duty, -width, duty - width];
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &o in offsets {
        for &c in &corners {
            let v = mean_at(wrap_unit(c - o));
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (lo, hi)
}

/// [`corner_extremes`] with `floor` a library call (plain x86-64).
fn extremes_portable(offsets: &[f64], width: f64, duty: f64) -> (f64, f64) {
    corner_extremes(offsets, width, duty)
}

/// [`corner_extremes`] compiled for AVX2: `floor` is one instruction. FMA
/// stays off, so every product and sum is rounded as in the portable copy.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn extremes_avx2(offsets: &[f64], width: f64, duty: f64) -> (f64, f64) {
    corner_extremes(offsets, width, duty)
}

/// [`corner_extremes`] with the fastest copy this CPU runs.
fn extremes_dispatch(offsets: &[f64], width: f64, duty: f64) -> (f64, f64) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: `extremes_avx2` needs AVX2 and nothing else, and the CPU
        // has just been checked to support it.
        return unsafe { extremes_avx2(offsets, width, duty) };
    }
    extremes_portable(offsets, width, duty)
}

/// Duties per chunk of [`Shutter::phase_envelopes`]: the chunk's arrays
/// stay in the L1 cache.
const CHUNK: usize = 64;

/// [`corner_extremes`] of the duties `duties` (at most [`CHUNK`]) at once,
/// into `lo` and `hi`: the same operations in the same order for each duty,
/// arranged so that the innermost loops run over the duties and the
/// compiler vectorises them (four duties per instruction with AVX2).
///
/// `corner_extremes` sums with `Iterator::sum`, which starts from a zero;
/// the first ON fraction is never `-0.0`, so adding it to either zero
/// gives it back, and starting from it is the same double.
#[inline(always)]
fn chunk_extremes(offsets: &[f64], width: f64, duties: &[f64], lo: &mut [f64], hi: &mut [f64]) {
    let len = duties.len();
    let (lo, hi) = (&mut lo[..len], &mut hi[..len]);
    lo.fill(f64::INFINITY);
    hi.fill(f64::NEG_INFINITY);
    let n = offsets.len() as f64;
    let mut phase0 = [0.0; CHUNK];
    let mut sum = [0.0; CHUNK];
    let (phase0, sum) = (&mut phase0[..len], &mut sum[..len]);
    for &o in offsets {
        for corner in 0..4 {
            let c = |d: f64| match corner {
                0 => 0.0,
                1 => d,
                2 => -width,
                _ => d - width,
            };
            for (p, &d) in phase0.iter_mut().zip(duties) {
                *p = wrap_unit(c(d) - o);
            }
            let fraction = |p: f64, o2: f64, d: f64| on_fraction(wrap_unit(p + o2), width, d);
            let (first, rest) = offsets.split_first().expect("offsets is not empty");
            for ((s, &p), &d) in sum.iter_mut().zip(&*phase0).zip(duties) {
                *s = fraction(p, *first, d);
            }
            for &o2 in rest {
                for ((s, &p), &d) in sum.iter_mut().zip(&*phase0).zip(duties) {
                    *s += fraction(p, o2, d);
                }
            }
            for ((l, h), &s) in lo.iter_mut().zip(hi.iter_mut()).zip(&*sum) {
                let v = s / n;
                *l = l.min(v);
                *h = h.max(v);
            }
        }
    }
}

/// [`chunk_extremes`] with the portable floor (a library call per value).
fn chunk_portable(offsets: &[f64], width: f64, duties: &[f64], lo: &mut [f64], hi: &mut [f64]) {
    chunk_extremes(offsets, width, duties, lo, hi);
}

/// [`chunk_extremes`] compiled for AVX2: four duties per instruction and a
/// one-instruction floor; no FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn chunk_avx2(offsets: &[f64], width: f64, duties: &[f64], lo: &mut [f64], hi: &mut [f64]) {
    chunk_extremes(offsets, width, duties, lo, hi);
}

/// [`chunk_extremes`] with the fastest copy this CPU runs.
fn chunk_dispatch(offsets: &[f64], width: f64, duties: &[f64], lo: &mut [f64], hi: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: `chunk_avx2` needs AVX2 and nothing else, and the CPU
        // has just been checked to support it.
        unsafe { chunk_avx2(offsets, width, duties, lo, hi) };
        return;
    }
    chunk_portable(offsets, width, duties, lo, hi);
}

/// The kernel copy that [`Shutter::phase_envelopes_with`] runs.
type ChunkKernel = fn(&[f64], f64, &[f64], &mut [f64], &mut [f64]);

impl Shutter {
    /// Lowest and highest ROI-mean ON fraction over every possible start
    /// phase of the PWM relative to the frame clock: the worst case that a
    /// capture of unknown phase can show, computed exactly.
    ///
    /// The ROI mean is piecewise linear in the phase, with corners where a
    /// row's exposure start or end crosses a rising or falling edge, so its
    /// extremes lie at those corners. There are `4 * rows` of them
    /// (distinct rows: one for a global shutter).
    pub fn phase_envelope(&self, pwm: &PwmDrive, rows: Range<u32>) -> (f64, f64) {
        self.phase_envelope_with(pwm, rows, extremes_dispatch)
    }

    /// [`Shutter::phase_envelope`] of a drive at `frequency_hz` for each
    /// duty of `duties`, in order, into `out` (same length): the same
    /// doubles, computed several duties at a time. The phase of the drive
    /// does not enter, so the drives need not be built.
    ///
    /// `frequency_hz` must be finite and positive and each duty in `(0, 1]`
    /// (what [`PwmDrive::new`] accepts); other values give unspecified
    /// (but never panicking) results.
    pub fn phase_envelopes(
        &self,
        frequency_hz: f64,
        duties: &[f64],
        rows: Range<u32>,
        out: &mut [(f64, f64)],
    ) {
        self.phase_envelopes_with(frequency_hz, duties, rows, out, chunk_dispatch);
    }

    /// [`Shutter::phase_envelope`] of the drive `PwmDrive::new(frequency_hz,
    /// duty, _)` for each duty of `duties`, in order; `None` where
    /// [`PwmDrive::new`] refuses the drive (e.g. a NaN duty). The values are
    /// [`Shutter::phase_envelopes`]'s: the same doubles, a row at a time.
    pub fn phase_envelopes_checked(
        &self,
        frequency_hz: f64,
        duties: &[f64],
        rows: Range<u32>,
    ) -> Vec<Option<(f64, f64)>> {
        let valid: Vec<bool> = duties
            .iter()
            .map(|&d| PwmDrive::new(frequency_hz, d, 0.0).is_ok())
            .collect();
        let mut envelopes = vec![(0.0, 0.0); duties.len()];
        if valid.iter().any(|&ok| ok) {
            // Refused duties are computed as 1 (cheap) and dropped below.
            let safe: Vec<f64> = duties
                .iter()
                .zip(&valid)
                .map(|(&d, &ok)| if ok { d } else { 1.0 })
                .collect();
            self.phase_envelopes(frequency_hz, &safe, rows, &mut envelopes);
        }
        envelopes
            .into_iter()
            .zip(valid)
            .map(|(e, ok)| ok.then_some(e))
            .collect()
    }

    /// [`Shutter::phase_envelopes`] through the kernel copy `kernel`.
    fn phase_envelopes_with(
        &self,
        frequency_hz: f64,
        duties: &[f64],
        rows: Range<u32>,
        out: &mut [(f64, f64)],
        kernel: ChunkKernel,
    ) {
        assert_eq!(duties.len(), out.len(), "one envelope per duty");
        let f = frequency_hz;
        let width = self.exposure_s * f;
        let rows = self.distinct_rows(rows);
        if rows.is_empty() {
            for (e, &d) in out.iter_mut().zip(duties) {
                *e = if d >= 1.0 {
                    (1.0, 1.0)
                } else {
                    (f64::INFINITY, f64::NEG_INFINITY)
                };
            }
            return;
        }
        let offset = |r: u32| wrap_unit(self.row_offset_s(r) * f);
        let mut stack = [0.0; STACK_ROWS];
        let heap: Vec<f64>;
        let offsets: &[f64] = if rows.len() <= STACK_ROWS {
            let n = rows.len();
            for (o, r) in stack.iter_mut().zip(rows) {
                *o = offset(r);
            }
            &stack[..n]
        } else {
            heap = rows.map(offset).collect();
            &heap
        };
        let (mut lo, mut hi) = ([0.0; CHUNK], [0.0; CHUNK]);
        for (ds, es) in duties.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
            kernel(offsets, width, ds, &mut lo, &mut hi);
            for (((e, &d), &l), &h) in es.iter_mut().zip(ds).zip(&lo).zip(&hi) {
                // A duty of 1 never flickers: the single envelope's shortcut.
                *e = if d >= 1.0 { (1.0, 1.0) } else { (l, h) };
            }
        }
    }

    /// The start phase (cycles in `[0, 1)`, of row 0's exposure from a
    /// rising edge, as [`PwmDrive::phase_at`] gives it for offset 0) at
    /// which the ROI-mean ON fraction is lowest: where
    /// [`Shutter::phase_envelope`]'s low end is attained, the first such
    /// corner when several tie. A duty of 1 never dims, so 0.
    ///
    /// Not a kernel: the report asks for it once per failing case, to show
    /// the trace and the frame at that phase.
    pub fn darkest_phase(&self, pwm: &PwmDrive, rows: Range<u32>) -> f64 {
        let duty = pwm.duty();
        if duty >= 1.0 {
            return 0.0;
        }
        let f = pwm.frequency_hz();
        let width = self.exposure_s * f;
        let offsets: Vec<f64> = self
            .distinct_rows(rows)
            .map(|r| wrap_unit(self.row_offset_s(r) * f))
            .collect();
        let mean_at = |phase0: f64| -> f64 {
            offsets
                .iter()
                .map(|&o| on_fraction(wrap_unit(phase0 + o), width, duty))
                .sum::<f64>()
                / offsets.len() as f64
        };
        // The corners of `corner_extremes`, in its order.
        let corners = [0.0, duty, -width, duty - width];
        let mut best = (f64::INFINITY, 0.0);
        for &o in &offsets {
            for &c in &corners {
                let phase = wrap_unit(c - o);
                let v = mean_at(phase);
                if v < best.0 {
                    best = (v, phase);
                }
            }
        }
        best.1
    }

    /// [`Shutter::phase_envelope`] through the kernel copy `extremes`.
    #[inline(always)]
    fn phase_envelope_with(
        &self,
        pwm: &PwmDrive,
        rows: Range<u32>,
        extremes: fn(&[f64], f64, f64) -> (f64, f64),
    ) -> (f64, f64) {
        let duty = pwm.duty();
        if duty >= 1.0 {
            return (1.0, 1.0);
        }
        let f = pwm.frequency_hz();
        let width = self.exposure_s * f;
        let rows = self.distinct_rows(rows);
        let offset = |r: u32| wrap_unit(self.row_offset_s(r) * f);
        if rows.len() <= STACK_ROWS {
            let mut offsets = [0.0; STACK_ROWS];
            let n = rows.len();
            for (o, r) in offsets.iter_mut().zip(rows) {
                *o = offset(r);
            }
            extremes(&offsets[..n], width, duty)
        } else {
            let offsets: Vec<f64> = rows.map(offset).collect();
            extremes(&offsets, width, duty)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::Rng;
    use crate::shutter::ShutterModel;

    #[test]
    fn darkest_phase_attains_the_envelope_low_end() {
        let mut rng = Rng::new(5);
        for case in 0..200 {
            let f = 50.0 + rng.uniform() * 950.0;
            let duty = 0.01 + rng.uniform() * 0.98;
            let shutter = Shutter {
                model: if case % 2 == 0 {
                    ShutterModel::Global
                } else {
                    ShutterModel::Rolling {
                        line_time_s: 14.565e-6,
                    }
                },
                exposure_s: 1e-4 + rng.uniform() * 0.02,
                fps: 30.0,
            };
            let pwm = PwmDrive::new(f, duty, 0.0).unwrap();
            let rows = 399..401 + case % 3;
            let phase = shutter.darkest_phase(&pwm, rows.clone());
            assert!((0.0..1.0).contains(&phase), "case {case}: {phase}");
            // A drive whose first rise puts frame 0's row 0 at that phase.
            let at = PwmDrive::new(f, duty, -phase / f).unwrap();
            let got = shutter.frame_on_fraction(&at, 0, rows.clone());
            let (lo, _) = shutter.phase_envelope(&pwm, rows);
            assert!((got - lo).abs() < 1e-9, "case {case}: {got} vs {lo}");
        }
    }

    /// The envelope as first written (before this kernel): offsets in a
    /// `Vec`, the same closed form. The kernel must return its bits.
    fn reference(shutter: &Shutter, pwm: &PwmDrive, rows: Range<u32>) -> (f64, f64) {
        let duty = pwm.duty();
        if duty >= 1.0 {
            return (1.0, 1.0);
        }
        let f = pwm.frequency_hz();
        let width = shutter.exposure_s * f;
        let rows = shutter.distinct_rows(rows);
        let offsets: Vec<f64> = rows
            .map(|r| wrap_unit(shutter.row_offset_s(r) * f))
            .collect();
        let mean_at = |phase0: f64| -> f64 {
            offsets
                .iter()
                .map(|&o| on_fraction(wrap_unit(phase0 + o), width, duty))
                .sum::<f64>()
                / offsets.len() as f64
        };
        let corners = [0.0, duty, -width, duty - width];
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for &o in &offsets {
            for &c in &corners {
                let v = mean_at(wrap_unit(c - o));
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }

    fn bits((lo, hi): (f64, f64)) -> (u64, u64) {
        (lo.to_bits(), hi.to_bits())
    }

    #[test]
    fn envelopes_of_a_duty_row_equal_the_single_envelope_bit_for_bit() {
        let mut rng = Rng::new(2018);
        for case in 0..400 {
            let f = match case % 3 {
                0 => (50.0 + rng.uniform() * 1950.0).round(),
                1 => 50.0 + rng.uniform() * 1950.0,
                _ => 30.0 * (1 + case % 7) as f64,
            };
            let model = match case % 3 {
                0 => ShutterModel::Global,
                _ => ShutterModel::Rolling {
                    line_time_s: 14.565e-6 * (1.0 + rng.uniform()),
                },
            };
            let exposure_s = match case % 4 {
                0 => (1 + case % 3) as f64 / f,
                _ => 1e-6 + rng.uniform() * 0.03,
            };
            let shutter = Shutter {
                model,
                exposure_s,
                fps: 30.0,
            };
            // Around the chunk size; a fine map's duty axis (with 1.0 at its
            // end), the Eq. 1 boundary duty for this exposure, and tiny ones.
            let len = [0, 1, 3, 63, 64, 65, 100, 130][case % 8];
            let mut duties: Vec<f64> = (0..len)
                .map(|j| (0.01 + j as f64 * 0.01).min(1.0))
                .collect();
            if len > 2 {
                duties[1] = (1.0 - exposure_s * f).clamp(f64::MIN_POSITIVE, 1.0);
                duties[2] = f64::MIN_POSITIVE;
            }
            let rows = 399..399 + (case as u32 / 8) % 11;
            let mut got = vec![(0.0, 0.0); len];
            let mut portable = vec![(0.0, 0.0); len];
            shutter.phase_envelopes(f, &duties, rows.clone(), &mut got);
            shutter.phase_envelopes_with(f, &duties, rows.clone(), &mut portable, chunk_portable);
            for (j, &d) in duties.iter().enumerate() {
                let pwm = PwmDrive::new(f, d, 0.0).unwrap();
                let want = bits(reference(&shutter, &pwm, rows.clone()));
                let msg = format!("case {case}: f {f} D {d} T {exposure_s} rows {rows:?}");
                assert_eq!(bits(got[j]), want, "{msg}");
                assert_eq!(bits(portable[j]), want, "{msg}");
            }
        }
    }

    #[test]
    fn both_kernel_copies_return_the_reference_bits() {
        let mut rng = Rng::new(1789);
        for case in 0..3000 {
            let f = match case % 3 {
                0 => (50.0 + rng.uniform() * 1950.0).round(),
                1 => 50.0 + rng.uniform() * 1950.0,
                _ => 30.0 * (1 + case % 7) as f64,
            };
            // Whole periods, the Eq. 1 boundary (1 - D) / f, and anything.
            let duty = match case % 11 {
                0 => 1.0,
                1 => 0.25,
                _ => 0.001 + rng.uniform() * 0.998,
            };
            let exposure_s = match case % 5 {
                0 => (1 + case % 4) as f64 / f,
                1 => (1.0 - duty) / f,
                _ => 1e-6 + rng.uniform() * 0.03,
            };
            let model = match case % 4 {
                0 => ShutterModel::Global,
                1 => ShutterModel::Rolling { line_time_s: 0.0 },
                _ => ShutterModel::Rolling {
                    line_time_s: 14.565e-6 * (1.0 + rng.uniform()),
                },
            };
            let shutter = Shutter {
                model,
                exposure_s,
                fps: 30.0,
            };
            let pwm = PwmDrive::new(f, duty, 0.0).unwrap();
            // 0 to 12 rows: empty, on the stack, and past it on the heap.
            let start = 399 + case as u32 % 5;
            let rows = start..start + (case as u32 / 3) % 13;
            let want = bits(reference(&shutter, &pwm, rows.clone()));
            let msg = format!("case {case}: f {f} D {duty} T {exposure_s} rows {rows:?}");
            assert_eq!(
                bits(shutter.phase_envelope(&pwm, rows.clone())),
                want,
                "{msg}"
            );
            let portable = shutter.phase_envelope_with(&pwm, rows.clone(), extremes_portable);
            assert_eq!(bits(portable), want, "{msg}");
        }
    }
}
