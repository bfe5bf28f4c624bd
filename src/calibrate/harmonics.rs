//! The harmonic columns of the band estimator's design and their products
//! with the row profiles (`A^T y`), column by column: with the Gram matrix
//! in closed form ([`super::gram`]) these are all the estimator sums over
//! the rows for a trial frequency.

/// Rows between phases computed exactly by [`fill_columns`]; the rows
/// between are turned from the row before (angle addition), so a phase is
/// at most 31 rotations, a few units of rounding, from the exact one.
pub const EXACT_PHASE_ROWS: usize = 32;

/// Harmonic columns and their products with each profile: entry `[p]` is
/// `sum_i y_p[i] cos(k w i)`, `sum_i y_p[i] sin(k w i)` for `k` in `1..=h`
/// (`w = 2 pi f`), in that order. `cols` is scratch space, reused.
///
/// On x86-64 with AVX2 the same code runs compiled for AVX2 (four doubles
/// per instruction); the sums are in a fixed order, whatever the CPU.
pub fn harmonic_products(
    cols: &mut Vec<f64>,
    profiles: &[Vec<f64>],
    n: usize,
    f: f64,
    h: usize,
) -> Vec<Vec<f64>> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has just been found to support AVX2, the only
        // feature the function is compiled for.
        return unsafe { products_avx2(cols, profiles, n, f, h) };
    }
    products_plain(cols, profiles, n, f, h)
}

/// [`harmonic_products`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn products_avx2(
    cols: &mut Vec<f64>,
    profiles: &[Vec<f64>],
    n: usize,
    f: f64,
    h: usize,
) -> Vec<Vec<f64>> {
    products_plain(cols, profiles, n, f, h)
}

/// The body of [`harmonic_products`], inlined into each compiled copy.
#[inline(always)]
fn products_plain(
    cols: &mut Vec<f64>,
    profiles: &[Vec<f64>],
    n: usize,
    f: f64,
    h: usize,
) -> Vec<Vec<f64>> {
    // Every value is written below: grow, never clear.
    if cols.len() < 2 * h * n {
        cols.resize(2 * h * n, 0.0);
    }
    let cols = &mut cols[..2 * h * n];
    fill_columns(cols, n, f, h);
    // Plain loops, not iterator adaptors: a generic `fold` would be
    // compiled apart from this function, without AVX2.
    let mut out = Vec::with_capacity(profiles.len());
    for y in profiles {
        let mut products = Vec::with_capacity(2 * h);
        for col in cols.chunks_exact(n) {
            products.push(dot(col, y));
        }
        out.push(products);
    }
    out
}

/// Fills `cols` (column-major, `n` rows a column) with `cos, sin` of
/// `k w i` for `k` in `1..=h`. The row's phase is computed exactly every
/// [`EXACT_PHASE_ROWS`] rows and turned by `w` from the row before in
/// between; harmonic `k + 1` is harmonic `k` turned by the row's phase
/// (angle addition), a column at a time, so the rows go four to an
/// instruction.
#[inline(always)]
pub fn fill_columns(cols: &mut [f64], n: usize, f: f64, h: usize) {
    let w = 2.0 * std::f64::consts::PI * f;
    let (sw, cw) = w.sin_cos();
    let (first, mut rest) = cols[..2 * h * n].split_at_mut(2 * n);
    let (c1, s1) = first.split_at_mut(n);
    let (mut s, mut c) = (0.0f64, 1.0f64);
    for (i, (ci, si)) in c1.iter_mut().zip(s1.iter_mut()).enumerate() {
        (s, c) = if i % EXACT_PHASE_ROWS == 0 {
            (w * i as f64).sin_cos()
        } else {
            (s * cw + c * sw, c * cw - s * sw)
        };
        *ci = c;
        *si = s;
    }
    let (c1, s1) = (&*c1, &*s1);
    let (mut prev_c, mut prev_s) = (c1, s1);
    while !rest.is_empty() {
        let (next, tail) = std::mem::take(&mut rest).split_at_mut(2 * n);
        let (nc, ns) = next.split_at_mut(n);
        for i in 0..n {
            let (c, s) = (prev_c[i], prev_s[i]);
            nc[i] = c * c1[i] - s * s1[i];
            ns[i] = s * c1[i] + c * s1[i];
        }
        (prev_c, prev_s) = (nc, ns);
        rest = tail;
    }
}

/// `sum_i a[i] b[i]` in eight running sums (lane `j` takes elements
/// `j, j + 8, ...`), combined pairwise: a fixed order, whatever the CPU.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for j in 0..8 {
            acc[j] += x[j] * y[j];
        }
    }
    for (j, (x, y)) in ra.iter().zip(rb).enumerate() {
        acc[j] += x * y;
    }
    let quads = [
        acc[0] + acc[4],
        acc[1] + acc[5],
        acc[2] + acc[6],
        acc[3] + acc[7],
    ];
    (quads[0] + quads[2]) + (quads[1] + quads[3])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_the_exact_harmonics_to_rounding() {
        let (n, h) = (4000, 10);
        let mut cols = vec![0.0; 2 * h * n];
        for f in [1.0 / 68.66, 0.2499, 1.0 / 1373.0, 0.013_579] {
            fill_columns(&mut cols, n, f, h);
            for k in 1..=h {
                for i in 0..n {
                    let angle = 2.0 * std::f64::consts::PI * f * (k * i) as f64;
                    let (s, c) = angle.sin_cos();
                    let (gc, gs) = (cols[(2 * k - 2) * n + i], cols[(2 * k - 1) * n + i]);
                    let err = (gc - c).abs().max((gs - s).abs());
                    // The exact phase's own argument is rounded to about
                    // eps * angle.
                    let bound = 1e-14 + 4.0 * f64::EPSILON * angle;
                    assert!(err < bound, "f={f} row {i} harmonic {k}: {err:e}");
                }
            }
        }
    }

    #[test]
    fn products_are_the_textbook_sums() {
        let (n, h, f) = (803, 7, 0.0371);
        let y: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 101) as f64 * 0.37 - 9.0)
            .collect();
        let z: Vec<f64> = y.iter().map(|v| v * v - 30.0).collect();
        let got = harmonic_products(&mut Vec::new(), &[y.clone(), z.clone()], n, f, h);
        for (p, prof) in [y, z].iter().enumerate() {
            for k in 1..=h {
                let (mut c, mut s, mut scale) = (0.0, 0.0, 0.0);
                for (i, v) in prof.iter().enumerate() {
                    let (sn, cs) = (2.0 * std::f64::consts::PI * f * (k * i) as f64).sin_cos();
                    c += v * cs;
                    s += v * sn;
                    scale += v.abs();
                }
                let tol = 1e-13 * scale;
                assert!((got[p][2 * k - 2] - c).abs() < tol, "p={p} k={k}");
                assert!((got[p][2 * k - 1] - s).abs() < tol, "p={p} k={k}");
            }
        }
    }
}
