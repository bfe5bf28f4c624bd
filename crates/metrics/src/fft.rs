//! Fast Fourier transforms of `f64` samples, for every crate of ledflicker.
//!
//! rustfft's planner is generic, and each crate that names
//! `FftPlanner<f64>` compiles the whole of it (every algorithm and
//! butterfly) again: about 380,000 lines of LLVM IR a crate. These
//! functions are not generic, so that code is compiled here once and
//! other crates only call it.

use std::cell::RefCell;

pub use rustfft::num_complex::Complex;
use rustfft::{FftDirection, FftPlanner};

thread_local! {
    /// One planner a thread: it keeps the plan of each length, so a length
    /// is planned once. The plan of a length does not depend on what was
    /// planned before, so the numbers do not depend on the thread either.
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
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
    let fft = PLANNER.with(|p| p.borrow_mut().plan_fft(buf.len(), direction));
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

    #[test]
    fn an_empty_buffer_is_left_alone() {
        forward(&mut []);
        inverse(&mut []);
    }
}
