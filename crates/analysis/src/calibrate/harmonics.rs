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
/// Only the first harmonic and the last two are held (six columns of `n`
/// rows, in the first level of cache for a few thousand rows): each
/// harmonic is turned from the one before and its products taken at once.
#[inline(always)]
fn products_plain(
    cols: &mut Vec<f64>,
    profiles: &[Vec<f64>],
    n: usize,
    f: f64,
    h: usize,
) -> Vec<Vec<f64>> {
    // Every value is written before it is read: grow, never clear.
    if cols.len() < 6 * n {
        cols.resize(6 * n, 0.0);
    }
    let (first, work) = cols[..6 * n].split_at_mut(2 * n);
    let (c1, s1) = first.split_at_mut(n);
    first_harmonic(c1, s1, f);
    let (c1, s1) = (&*c1, &*s1);
    let mut out: Vec<Vec<f64>> = Vec::with_capacity(profiles.len());
    // Plain loops, not iterator adaptors: a generic `fold` would be
    // compiled apart from this function, without AVX2.
    for y in profiles {
        let mut products = Vec::with_capacity(2 * h);
        products.push(dot(c1, y));
        products.push(dot(s1, y));
        out.push(products);
    }
    let (slot_a, slot_b) = work.split_at_mut(2 * n);
    for k in 2..=h {
        // Harmonic k goes to slot a for even k, b for odd, from k - 1.
        let (prev, next): ((&[f64], &[f64]), &mut [f64]) = if k == 2 {
            ((c1, s1), slot_a)
        } else if k % 2 == 0 {
            (slot_b.split_at(n), slot_a)
        } else {
            (slot_a.split_at(n), slot_b)
        };
        let (next_c, next_s) = next.split_at_mut(n);
        next_harmonic(prev, (c1, s1), (next_c, next_s));
        for (products, y) in out.iter_mut().zip(profiles) {
            products.push(dot(next_c, y));
            products.push(dot(next_s, y));
        }
    }
    out
}

/// `cos, sin` of `w i` (`w = 2 pi f`) for every row `i`. The row's phase
/// is computed exactly every [`EXACT_PHASE_ROWS`] rows and turned by `w`
/// from the row before in between.
#[inline(always)]
pub fn first_harmonic(c1: &mut [f64], s1: &mut [f64], f: f64) {
    let w = 2.0 * std::f64::consts::PI * f;
    let (sw, cw) = w.sin_cos();
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
}

/// Harmonic `k + 1` from harmonic `k` turned by the row's phase (angle
/// addition), a column at a time, so the rows go four to an instruction.
#[inline(always)]
pub fn next_harmonic(
    (prev_c, prev_s): (&[f64], &[f64]),
    (c1, s1): (&[f64], &[f64]),
    (next_c, next_s): (&mut [f64], &mut [f64]),
) {
    let n = next_c.len();
    let (prev_c, prev_s, c1, s1) = (&prev_c[..n], &prev_s[..n], &c1[..n], &s1[..n]);
    let next_s = &mut next_s[..n];
    for i in 0..n {
        let (c, s) = (prev_c[i], prev_s[i]);
        next_c[i] = c * c1[i] - s * s1[i];
        next_s[i] = s * c1[i] + c * s1[i];
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
        for f in [1.0 / 68.66, 0.2499, 1.0 / 1373.0, 0.013_579] {
            let (mut c1, mut s1) = (vec![0.0; n], vec![0.0; n]);
            first_harmonic(&mut c1, &mut s1, f);
            let (mut c, mut s) = (c1.clone(), s1.clone());
            for k in 1..=h {
                if k > 1 {
                    let (mut nc, mut ns) = (vec![0.0; n], vec![0.0; n]);
                    next_harmonic((&c, &s), (&c1, &s1), (&mut nc, &mut ns));
                    (c, s) = (nc, ns);
                }
                for i in 0..n {
                    let angle = 2.0 * std::f64::consts::PI * f * (k * i) as f64;
                    let (es, ec) = angle.sin_cos();
                    let err = (c[i] - ec).abs().max((s[i] - es).abs());
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
