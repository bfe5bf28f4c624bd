//! Fast Fourier transforms of `f64` samples, for every crate of ledflicker.
//!
//! rustfft's planner is generic, and each crate that names
//! `FftPlanner<f64>` compiles the whole of it (every algorithm and
//! butterfly) again: about 400,000 lines of LLVM IR a crate. These
//! functions are not generic, so that code is compiled here once and
//! other crates only call it.

use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::Arc;

pub use rustfft::num_complex::Complex;
use rustfft::{Fft, FftDirection, FftPlanner};

/// Planned FFTs by length and direction (`true` forward).
type Plans = HashMap<(usize, bool), Arc<dyn Fft<f64>>>;

/// Which plans a thread keeps, and how many: the analyses transform a few
/// lengths over and over (a case's trace or a frame's row profiles, padded
/// to a power of two), while a length of its own per record (the `light`
/// command, the Python package on any array) must not hold memory: a plan
/// of a few 10^5 points of no simple form is about 15 MB. So a plan is
/// kept for a length up to 2^16, or a power of two up to 2^20 (the
/// padded lengths, a plan of 2^20 points about 16 MB of twiddles), and a
/// thread keeps at most 16.
const KEPT_LEN_MAX: usize = 1 << 16;
const KEPT_POWER_OF_TWO_MAX: usize = 1 << 20;
const KEPT_PLANS_MAX: usize = 16;

thread_local! {
    /// The FFTs this thread has planned and kept, by length and direction.
    /// Each is planned by a new planner: rustfft's SIMD planner builds a
    /// length from the smaller lengths it planned before, so one
    /// long-lived planner would make a transform's last bits depend on
    /// what the thread transformed earlier (a length of 4,320 after one of
    /// 1,080 differs in about 1e-12), and so on the thread a case ran on.
    static PLANS: RefCell<Plans> = RefCell::new(HashMap::new());
}

/// The forward transform of `buf` in place, unnormalised:
/// `X[k] = sum_n x[n] exp(-2 pi i k n / N)` with `N = buf.len()`.
pub fn forward(buf: &mut [Complex<f64>]) {
    transform(buf, FftDirection::Forward);
}

/// The inverse transform of `buf` in place, unnormalised (no `1 / N`):
/// `x[n] = sum_k X[k] exp(2 pi i k n / N)` with `N = buf.len()`.
pub fn inverse(buf: &mut [Complex<f64>]) {
    transform(buf, FftDirection::Inverse);
}

fn transform(buf: &mut [Complex<f64>], direction: FftDirection) {
    if buf.is_empty() {
        return;
    }
    let len = buf.len();
    let plan = || FftPlanner::new().plan_fft(len, direction);
    let kept = len <= KEPT_LEN_MAX || (len.is_power_of_two() && len <= KEPT_POWER_OF_TWO_MAX);
    let fft = if kept {
        PLANS.with(|plans| {
            let mut plans = plans.borrow_mut();
            let key = (len, direction == FftDirection::Forward);
            if !plans.contains_key(&key) && plans.len() >= KEPT_PLANS_MAX {
                plans.clear();
            }
            Arc::clone(plans.entry(key).or_insert_with(plan))
        })
    } else {
        plan()
    };
    fft.process(buf);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The transforms against the sums that define them, at a power of two
    /// and at lengths rustfft plans differently (a prime, a product).
    #[test]
    fn forward_and_inverse_match_the_direct_sums() {
        for n in [1usize, 2, 7, 12, 16, 97] {
            let x: Vec<Complex<f64>> = (0..n)
                .map(|i| Complex::new((i as f64 * 0.37).sin() + 0.5, (i as f64 * 1.3).cos()))
                .collect();
            let direct = |sign: f64| -> Vec<Complex<f64>> {
                (0..n)
                    .map(|k| {
                        x.iter()
                            .enumerate()
                            .fold(Complex::new(0.0, 0.0), |acc, (j, v)| {
                                let a =
                                    sign * 2.0 * std::f64::consts::PI * (k * j) as f64 / n as f64;
                                acc + v * Complex::from_polar(1.0, a)
                            })
                    })
                    .collect()
            };
            let (mut f, mut i) = (x.clone(), x.clone());
            forward(&mut f);
            inverse(&mut i);
            for (got, want) in f.iter().zip(direct(-1.0)).chain(i.iter().zip(direct(1.0))) {
                assert!(
                    (got - want).norm() <= 1e-9 * n as f64,
                    "n={n}: {got} vs {want}"
                );
            }
        }
    }

    /// A length's transform is the same bits whatever the thread planned
    /// before it: 4,320 planned after 1,080 (which rustfft's own planner
    /// would build on) against 4,320 on a thread that planned nothing.
    #[test]
    fn a_transform_does_not_depend_on_what_was_planned_before() {
        let signal = |n: usize| -> Vec<Complex<f64>> {
            (0..n)
                .map(|i| Complex::new((i as f64 * 0.013).sin() + (i as f64 * 0.7).cos(), 0.0))
                .collect()
        };
        let fresh = std::thread::spawn(move || {
            let mut x = signal(4320);
            forward(&mut x);
            x
        })
        .join()
        .unwrap();
        let after = std::thread::spawn(move || {
            forward(&mut signal(1080));
            let mut x = signal(4320);
            forward(&mut x);
            x
        })
        .join()
        .unwrap();
        let mut direct = signal(4320);
        FftPlanner::new()
            .plan_fft_forward(4320)
            .process(&mut direct);
        for ((a, b), c) in fresh.iter().zip(&after).zip(&direct) {
            assert_eq!(
                (a.re.to_bits(), a.im.to_bits()),
                (b.re.to_bits(), b.im.to_bits())
            );
            assert_eq!(
                (a.re.to_bits(), a.im.to_bits()),
                (c.re.to_bits(), c.im.to_bits())
            );
        }
    }

    /// Lengths past what is kept, and more lengths than are kept, give the
    /// bits of a new planner's transform, and the thread keeps at most
    /// [`KEPT_PLANS_MAX`] plans.
    #[test]
    fn plans_not_kept_give_the_same_bits_and_the_kept_ones_are_bounded() {
        let lengths = (0..40)
            .map(|k| 1000 + 37 * k)
            .chain([KEPT_LEN_MAX + 1, 70_000, 1 << 17]);
        for n in lengths {
            let x: Vec<Complex<f64>> = (0..n)
                .map(|i| Complex::new((i as f64 * 0.01).sin(), 0.0))
                .collect();
            let (mut a, mut b) = (x.clone(), x);
            forward(&mut a);
            FftPlanner::new().plan_fft_forward(n).process(&mut b);
            assert!(a.iter().zip(&b).all(|(p, q)| p == q), "n = {n}");
            assert!(PLANS.with(|p| p.borrow().len()) <= KEPT_PLANS_MAX);
        }
    }

    #[test]
    fn an_empty_buffer_is_left_alone() {
        forward(&mut []);
        inverse(&mut []);
    }
}
