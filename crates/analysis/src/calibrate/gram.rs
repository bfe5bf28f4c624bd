//! The Gram matrix `A^T A` of the band estimator's design (`1, t, t^2`,
//! then `cos, sin` of `k w i` for `k` in `1..=h`, rows `i` in `0..n`,
//! `t = (i - c) / c`, `c = (n - 1) / 2`) in closed form
//! (docs/calibration.md, "Gram matrix in closed form"). Summed row by row
//! it costs `n (3 + 2h)^2 / 2` multiply-adds for each trial frequency; in
//! closed form it costs `O(h)` sines and cosines, and only `A^T y` is left
//! for the rows.
//!
//! Every entry reduces to the sums over the centred rows `j = i - c`
//! (`-c..=c`, symmetric, so odd terms vanish), with `x = phi / 2`:
//!
//! - `D0(phi) = sum_j cos(phi j) = sin(n x) / sin x` (Dirichlet kernel),
//! - `D1(phi) = sum_j j sin(phi j) = -dD0/dphi`,
//! - `D2(phi) = sum_j j^2 cos(phi j) = -d^2 D0 / dphi^2`,
//!
//! then shifted back by `cos, sin(phi c)`, and products of harmonics by
//! `cos a cos b = (cos(a - b) + cos(a + b)) / 2` and its kin. Where
//! `n |sin x|` is small for some `k` in `1..=2h` (`k f` within about 0.6
//! cycles per frame of a whole number) the closed form cancels:
//! [`harmonic_gram`] returns `None`, and the caller sums the rows.

/// Smallest `n |sin x|` (`x = k w / 2`, `k` in `1..=2h`) of the closed
/// form. Below it `sum_i cos(k w i)` can come close to `+-n` (a harmonic or
/// a product of two nearly constant over the rows, `k f` within about 0.6
/// cycles per frame of a whole number), so `(n - C) / 2` and the quotients
/// of `D0` cancel, and [`harmonic_gram`] leaves the matrix to the row sums.
const CLOSED_FORM_FROM: f64 = 2.0;

/// `sin, cos` of the exact product `a b` (not of its rounding): the
/// rounding error `e` of the product, found with a fused multiply-add, is
/// turned through to first order (`e^2 / 2` is far below rounding).
fn sin_cos_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let e = a.mul_add(b, -p);
    let (s, c) = p.sin_cos();
    (s + e * c, c - e * s)
}

/// `D0, D1, D2` of the module docs at `phi = k w` over `n` rows, or `None`
/// where `n |sin x|` is below [`CLOSED_FORM_FROM`]. Every angle is `w`
/// times an exact factor (`k / 2`, `n k / 2`), turned through exactly
/// ([`sin_cos_product`]): the rounding of `k w` alone, times `n^2` in `D1`,
/// would cost digits.
fn dirichlet_sums(n: usize, k: usize, w: f64) -> Option<(f64, f64, f64)> {
    let (nf, half_k) = (n as f64, 0.5 * k as f64);
    let (sx, cx) = sin_cos_product(half_k, w);
    if nf * sx.abs() < CLOSED_FORM_FROM || !sx.is_finite() {
        return None;
    }
    let (snx, cnx) = sin_cos_product(nf * half_k, w);
    let d0 = snx / sx;
    // Derivatives in x: D0' = (n cos(nx) sin x - sin(nx) cos x) / sin^2 x,
    // and D0'' = (1 - n^2) D0 - 2 cot(x) D0' (from sin(nx) = D0 sin x).
    let dx = (nf * cnx * sx - snx * cx) / (sx * sx);
    let dxx = (1.0 - nf * nf) * d0 - 2.0 * (cx / sx) * dx;
    Some((d0, -0.5 * dx, -0.25 * dxx))
}

/// `sum_i t^p` for `p` in `0..=4` over `n` rows, in row order: the
/// trend block of the Gram matrix, the same for every frequency.
pub fn trend_sums(n: usize) -> [f64; 5] {
    // The products as the row-by-row accumulation of `1, t, t^2` forms
    // them, so that these sums are bit for bit its trend block.
    let mut sums = [0.0; 5];
    for i in 0..n {
        let t = 2.0 * i as f64 / (n.max(2) - 1) as f64 - 1.0;
        let t2 = t * t;
        for (s, v) in sums.iter_mut().zip([1.0, t, t2, t * t2, t2 * t2]) {
            *s += v;
        }
    }
    sums
}

/// The Gram matrix (row-major, `m = 3 + 2h` square, both triangles) of the
/// design of `1, t, t^2` and `h` harmonics of `w` radians per row over `n`
/// rows; `trend` is [`trend_sums`] of `n`. `None` where the closed form
/// cancels (see [`CLOSED_FORM_FROM`]): sum the rows instead.
pub fn harmonic_gram(n: usize, w: f64, h: usize, trend: &[f64; 5]) -> Option<Vec<f64>> {
    let m = 3 + 2 * h;
    let c = 0.5 * (n.max(2) as f64 - 1.0);
    // cs[k] = (sum_i cos(k w i), sum_i sin(k w i)) for k in 0..=2h;
    // tw[k] = sums of t and t^2 times cos and sin of k w i, k in 1..=h.
    let mut cs = vec![(n as f64, 0.0); 2 * h + 1];
    let mut tw = vec![[0.0; 4]; h + 1];
    for k in 1..=2 * h {
        let (d0, d1, d2) = dirichlet_sums(n, k, w)?;
        let (sc, cc) = sin_cos_product(k as f64 * c, w);
        cs[k] = (cc * d0, sc * d0);
        if k <= h {
            tw[k] = [
                -sc * d1 / c,
                cc * d1 / c,
                cc * d2 / (c * c),
                sc * d2 / (c * c),
            ];
        }
    }
    let mut g = vec![0.0; m * m];
    for p in 0..3 {
        for q in 0..3 {
            g[p * m + q] = trend[p + q];
        }
    }
    for k in 1..=h {
        let (cos_col, sin_col) = (1 + 2 * k, 2 + 2 * k);
        let trend_col = [
            (cs[k].0, cs[k].1),
            (tw[k][0], tw[k][1]),
            (tw[k][2], tw[k][3]),
        ];
        for (p, (tc, ts)) in trend_col.into_iter().enumerate() {
            g[p * m + cos_col] = tc;
            g[p * m + sin_col] = ts;
        }
        for l in 1..=k {
            let (diff, sum) = (cs[k - l], cs[k + l]);
            let (lc, ls) = (1 + 2 * l, 2 + 2 * l);
            g[cos_col * m + lc] = 0.5 * (diff.0 + sum.0);
            g[sin_col * m + ls] = 0.5 * (diff.0 - sum.0);
            // sin(a) cos(b) = (sin(a + b) + sin(a - b)) / 2.
            g[sin_col * m + lc] = 0.5 * (sum.1 + diff.1);
            g[cos_col * m + ls] = 0.5 * (sum.1 - diff.1);
        }
    }
    for p in 0..m {
        for q in p + 1..m {
            // Fill the lower triangle from the upper where only the upper
            // was set (trend rows), and the upper from the lower otherwise.
            if p < 3 {
                g[q * m + p] = g[p * m + q];
            } else {
                g[p * m + q] = g[q * m + p];
            }
        }
    }
    Some(g)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Neumaier's compensated sum.
    fn accurate_sum(values: impl Iterator<Item = f64>) -> f64 {
        let (mut s, mut comp) = (0.0f64, 0.0f64);
        for v in values {
            let t = s + v;
            comp += if s.abs() >= v.abs() {
                (s - t) + v
            } else {
                (v - t) + s
            };
            s = t;
        }
        s + comp
    }

    /// The design row `i` with exact phases `(k i) w` (the integer `k i`
    /// is exact, the product with `w` is turned through exactly).
    fn exact_row(n: usize, w: f64, h: usize, i: usize) -> Vec<f64> {
        let t = 2.0 * i as f64 / (n as f64 - 1.0) - 1.0;
        let mut r = vec![1.0, t, t * t];
        for k in 1..=h {
            let (s, c) = sin_cos_product((k * i) as f64, w);
            r.extend([c, s]);
        }
        r
    }

    /// Largest error of [`harmonic_gram`] against the compensated row sums
    /// of the exact design, over the scale `sqrt(G_pp G_qq)` of each entry
    /// (its Cauchy-Schwarz bound); `None` where the closed form declines.
    fn worst_error(n: usize, w: f64, h: usize) -> Option<f64> {
        let m = 3 + 2 * h;
        let rows: Vec<Vec<f64>> = (0..n).map(|i| exact_row(n, w, h, i)).collect();
        let reference: Vec<f64> = (0..m * m)
            .map(|pq| accurate_sum(rows.iter().map(|r| r[pq / m] * r[pq % m])))
            .collect();
        let g = harmonic_gram(n, w, h, &trend_sums(n))?;
        let mut worst = 0.0f64;
        for p in 0..m {
            for q in 0..m {
                let scale = (reference[p * m + p] * reference[q * m + q]).sqrt();
                let err = (g[p * m + q] - reference[p * m + q]).abs() / scale;
                assert!(err.is_finite(), "n={n} w={w} h={h} ({p},{q})");
                worst = worst.max(err);
            }
        }
        Some(worst)
    }

    #[test]
    fn closed_form_gram_is_the_row_sums_on_hard_frequencies() {
        let tau = 2.0 * std::f64::consts::PI;
        let (mut closed, mut declined) = (0, 0);
        for n in [16, 17, 240, 799, 800, 1080] {
            let nf = n as f64;
            // Cycles per row: the lowest searched, ordinary ones, the
            // highest, and ones where a harmonic or a product of two (`k f`,
            // `k <= 2h`) lies `off` cycles per frame from a whole number,
            // near and on either side of where the closed form declines
            // (`n |sin(pi k f)| = 2`, `off` about 0.64).
            let mut freqs = vec![1.0 / nf, 1.5 / nf, 1.0 / 68.66, 0.013_579, 0.1234, 0.25];
            for k in [2, 3, 4, 7, 20] {
                for off in [-4.0, -1.0, -0.66, -0.3, 0.0, 0.62, 0.7, 2.5] {
                    freqs.push((1.0 + off / nf) / k as f64);
                }
            }
            freqs.extend([0.25 - 1e-9, 0.1 + 1e-12, 0.05 - 1e-7]);
            for f in freqs {
                let h_max = ((0.5 / f) as usize).clamp(1, 10);
                for h in [1, 3, h_max, 10] {
                    match worst_error(n, tau * f, h) {
                        Some(worst) => {
                            closed += 1;
                            assert!(worst < 1e-13, "n={n} f={f} h={h}: {worst:e}");
                        }
                        None => declined += 1,
                    }
                }
            }
        }
        // Most are in closed form (the declined ones are mostly 10 harmonics
        // of high frequencies), and the test saw both paths.
        assert!(closed > 2 * declined && declined > 0, "{closed} {declined}");
    }

    #[test]
    fn ordinary_frequencies_are_in_closed_form() {
        // The daylight camera's band frequencies, 100 Hz to 1 kHz, with
        // the harmonics the estimator fits there.
        for period in [686.6, 457.8, 343.3, 137.3, 68.66, 4.5] {
            let f = 1.0 / period;
            let h = ((0.5 / f) as usize).clamp(1, 10);
            let w = 2.0 * std::f64::consts::PI * f;
            assert!(
                harmonic_gram(800, w, h, &trend_sums(800)).is_some(),
                "{period}"
            );
        }
    }

    #[test]
    fn the_gram_of_fewer_harmonics_is_its_leading_block() {
        let (n, w) = (800, 0.091);
        let big = harmonic_gram(n, w, 10, &trend_sums(n)).unwrap();
        let small = harmonic_gram(n, w, 3, &trend_sums(n)).unwrap();
        for p in 0..9 {
            for q in 0..9 {
                assert_eq!(big[p * 23 + q].to_bits(), small[p * 9 + q].to_bits());
            }
        }
    }
}
