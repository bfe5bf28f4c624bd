//! Small dense linear algebra for the least-squares fits of the band
//! estimator and the camera-model fit: normal equations solved by Cholesky.

/// Solves `a x = b` for a symmetric positive-definite `m x m` matrix `a`
/// (row-major), by Cholesky decomposition. Returns `None` when `a` is not
/// positive definite (a singular or rank-deficient design).
pub fn solve_spd(a: &[f64], b: &[f64], m: usize) -> Option<Vec<f64>> {
    let l = cholesky(a, m)?;
    // Forward: L z = b; back: L^T x = z.
    let mut z = vec![0.0; m];
    for i in 0..m {
        let s: f64 = (0..i).map(|k| l[i * m + k] * z[k]).sum();
        z[i] = (b[i] - s) / l[i * m + i];
    }
    let mut x = vec![0.0; m];
    for i in (0..m).rev() {
        let s: f64 = (i + 1..m).map(|k| l[k * m + i] * x[k]).sum();
        x[i] = (z[i] - s) / l[i * m + i];
    }
    Some(x)
}

/// Lower Cholesky factor of a symmetric positive-definite matrix.
fn cholesky(a: &[f64], m: usize) -> Option<Vec<f64>> {
    let (l, good) = cholesky_prefix(a, m);
    (good == m).then_some(l)
}

/// Lower Cholesky factor of the largest leading block of `a` that is
/// positive definite, and that block's size: columns `0..size` of the
/// factor are valid (the factor of a leading block is the leading block of
/// the factor).
fn cholesky_prefix(a: &[f64], m: usize) -> (Vec<f64>, usize) {
    let mut l = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i * m + k] * l[j * m + k]).sum();
            if i == j {
                let d = a[i * m + i] - s;
                if d.is_nan() || d <= 0.0 || !d.is_finite() {
                    return (l, i);
                }
                l[i * m + j] = d.sqrt();
            } else {
                l[i * m + j] = (a[i * m + j] - s) / l[j * m + j];
            }
        }
    }
    (l, m)
}

/// Inverse of a symmetric positive-definite matrix (column by column).
pub fn inverse_spd(a: &[f64], m: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0.0; m * m];
    for j in 0..m {
        let mut e = vec![0.0; m];
        e[j] = 1.0;
        let col = solve_spd(a, &e, m)?;
        for i in 0..m {
            inv[i * m + j] = col[i];
        }
    }
    Some(inv)
}

/// The normal equations of `y` on the design that `fill(design, stride)`
/// writes (row `i`, the `m` regressors of sample `i`, at
/// `design[i * stride..][..m]`; see [`per_row`]): `A^T A` (row-major, both
/// triangles), `A^T y` and `y^T y`.
///
/// On x86-64 with AVX2 the same loop runs compiled for AVX2 (four doubles
/// per instruction instead of two). Every element is still one product
/// added per sample in sample order, and Rust never fuses a multiply and
/// an add on its own, so the sums are bit for bit those of the plain loop.
fn normal_equations(
    y: &[f64],
    m: usize,
    fill: impl FnOnce(&mut [f64], usize),
) -> (Vec<f64>, Vec<f64>, f64) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has just been found to support AVX2, the only
        // feature the function is compiled for.
        return unsafe { normal_equations_avx2(y, m, fill) };
    }
    normal_equations_plain(y, m, fill)
}

/// A design filler for [`normal_equations`] from `basis(i, out)`, which
/// fills `out` with the `m` regressors of sample `i`.
pub fn per_row(
    m: usize,
    mut basis: impl FnMut(usize, &mut [f64]),
) -> impl FnOnce(&mut [f64], usize) {
    move |design: &mut [f64], stride: usize| {
        for (i, row) in design.chunks_exact_mut(stride).enumerate() {
            basis(i, &mut row[..m]);
        }
    }
}

/// [`normal_equations`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn normal_equations_avx2(
    y: &[f64],
    m: usize,
    fill: impl FnOnce(&mut [f64], usize),
) -> (Vec<f64>, Vec<f64>, f64) {
    normal_equations_plain(y, m, fill)
}

/// Most columns of `A^T A` that [`normal_equations`] sums at once: up to
/// 16 running sums in registers, so that the adds of one sample do not wait
/// on each other.
const BLOCK: usize = 16;

/// Columns of the design rows: `m` rounded up to whole AVX2 registers of
/// four doubles, so that a block never sums more than three zero columns.
const LANES: usize = 4;

/// The loop of [`normal_equations`], inlined into each compiled copy. The
/// design rows are built first (padded with zeros to a multiple of
/// [`LANES`] columns); then each row `p` of the lower triangle is summed
/// over the samples in blocks of up to [`BLOCK`] columns held in registers
/// (the last block of a row as narrow as the triangle allows). Every
/// element is still the sum of its products in sample order from 0.0, so
/// the result is bit for bit that of one pass over the samples.
#[inline(always)]
fn normal_equations_plain(
    y: &[f64],
    m: usize,
    fill: impl FnOnce(&mut [f64], usize),
) -> (Vec<f64>, Vec<f64>, f64) {
    let stride = m.div_ceil(LANES).max(1) * LANES;
    let mut design = vec![0.0; y.len() * stride];
    fill(&mut design, stride);
    let (aty, yy) = aty_yy(&design, stride, y, m);
    let mut ata = vec![0.0; m * m];
    // Rows `p` and `p + 1` of the triangle together: each design value
    // loaded serves both.
    for p in (0..m).step_by(2) {
        let last = (p + 1).min(m - 1);
        let mut q0 = 0;
        while q0 <= last {
            let width = (last + 1 - q0).div_ceil(LANES) * LANES;
            let (mut a, mut b) = ([0.0; BLOCK], [0.0; BLOCK]);
            let sums = (&mut a, &mut b);
            match width {
                w if w >= 16 => block_sums::<16>(&design, stride, (p, last), q0, sums),
                12 => block_sums::<12>(&design, stride, (p, last), q0, sums),
                8 => block_sums::<8>(&design, stride, (p, last), q0, sums),
                _ => block_sums::<4>(&design, stride, (p, last), q0, sums),
            }
            for (row, sums) in [(p, &a[..]), (last, &b[..])] {
                let end = (row + 1).min(q0 + BLOCK);
                if end > q0 {
                    ata[row * m + q0..row * m + end].copy_from_slice(&sums[..end - q0]);
                }
            }
            q0 += BLOCK;
        }
    }
    for p in 0..m {
        for q in 0..p {
            ata[q * m + p] = ata[p * m + q];
        }
    }
    (ata, aty, yy)
}

/// `sum_i A[i][p] A[i][q]` and `sum_i A[i][p2] A[i][q]` for the `W`
/// columns `q0..q0 + W` of the design rows (`stride` apart), each summed in
/// sample order from 0.0, into the first `W` entries of `sums`.
#[inline(always)]
fn block_sums<const W: usize>(
    design: &[f64],
    stride: usize,
    (p, p2): (usize, usize),
    q0: usize,
    sums: (&mut [f64; BLOCK], &mut [f64; BLOCK]),
) {
    let (mut a, mut b) = ([0.0f64; W], [0.0f64; W]);
    for row in design.chunks_exact(stride) {
        let (rp, rp2) = (row[p], row[p2]);
        let cols: &[f64; W] = row[q0..q0 + W].try_into().expect("W columns");
        for j in 0..W {
            a[j] += rp * cols[j];
            b[j] += rp2 * cols[j];
        }
    }
    sums.0[..W].copy_from_slice(&a);
    sums.1[..W].copy_from_slice(&b);
}

/// Residual sum of squares of the least-squares fit of `y` on the columns
/// produced by `basis(i, out)` (which fills `out` with the `m` regressors
/// of sample `i`). `None` when the design is singular.
pub fn lsq_rss(y: &[f64], m: usize, basis: impl FnMut(usize, &mut [f64])) -> Option<f64> {
    let (mut ata, aty, yy) = normal_equations(y, m, per_row(m, basis));
    // A relative ridge keeps nearly collinear columns (e.g. a harmonic at
    // a very low frequency against the trend) from breaking the solve.
    let trace: f64 = (0..m).map(|p| ata[p * m + p]).sum::<f64>() / m as f64;
    for p in 0..m {
        ata[p * m + p] += 1e-12 * trace;
    }
    let x = solve_spd(&ata, &aty, m)?;
    let explained: f64 = x.iter().zip(&aty).map(|(a, b)| a * b).sum();
    Some((yy - explained).max(0.0))
}

/// Residual sums of squares of the nested least-squares fits of `y` on the
/// first `k` columns of the design `fill` writes (as for
/// [`normal_equations`]), for every `k` in `0..=m`, from one pass
/// over the samples and one Cholesky factorisation: with `A^T A = L L^T`
/// and `L z = A^T y`, the fit on the first `k` columns explains
/// `z_0^2 + ... + z_(k-1)^2`. The relative ridge (as in [`lsq_rss`]) is
/// `1e-12` of the mean of the first `ridge_cols` diagonal entries, the same
/// for every `k`, so the fits are truly nested. Entries whose leading block
/// is singular are infinite.
pub fn lsq_rss_nested(
    y: &[f64],
    m: usize,
    ridge_cols: usize,
    fill: impl FnOnce(&mut [f64], usize),
) -> Vec<f64> {
    let (ata, aty, yy) = normal_equations(y, m, fill);
    nested_rss(ata, &aty, yy, m, ridge_cols)
}

/// `A^T y` and `y^T y` over design rows `stride` apart, in sample order.
#[inline(always)]
fn aty_yy(design: &[f64], stride: usize, y: &[f64], m: usize) -> (Vec<f64>, f64) {
    let mut aty = vec![0.0; m];
    let mut yy = 0.0;
    for (row, &v) in design.chunks_exact(stride).zip(y) {
        for (a, &r) in aty.iter_mut().zip(&row[..m]) {
            *a += r * v;
        }
        yy += v * v;
    }
    (aty, yy)
}

/// The nested residuals of [`lsq_rss_nested`] from its normal equations.
fn nested_rss(ata: Vec<f64>, aty: &[f64], yy: f64, m: usize, ridge_cols: usize) -> Vec<f64> {
    let (l, good) = ridged_cholesky(ata, m, ridge_cols);
    nested_from_factor(&l, good, aty, yy, m)
}

/// The ridge of [`lsq_rss_nested`] added to `ata`, then the Cholesky
/// factor of its largest positive-definite leading block, and that block's
/// size: shared by every right-hand side of the same design.
pub fn ridged_cholesky(mut ata: Vec<f64>, m: usize, ridge_cols: usize) -> (Vec<f64>, usize) {
    let cols = ridge_cols.clamp(1, m.max(1));
    let ridge = 1e-12 * (0..cols.min(m)).map(|p| ata[p * m + p]).sum::<f64>() / cols as f64;
    for p in 0..m {
        ata[p * m + p] += ridge;
    }
    cholesky_prefix(&ata, m)
}

/// The nested residuals of [`lsq_rss_nested`] from the factor
/// [`ridged_cholesky`] gives, `A^T y` and `y^T y`.
pub fn nested_from_factor(l: &[f64], good: usize, aty: &[f64], yy: f64, m: usize) -> Vec<f64> {
    let mut rss = Vec::with_capacity(m + 1);
    rss.push(yy.max(0.0));
    let (mut z, mut explained) = (vec![0.0; m], 0.0);
    for i in 0..m {
        if i >= good {
            rss.push(f64::INFINITY);
            continue;
        }
        let s: f64 = (0..i).map(|k| l[i * m + k] * z[k]).sum();
        z[i] = (aty[i] - s) / l[i * m + i];
        explained += z[i] * z[i];
        rss.push((yy - explained).max(0.0));
    }
    rss
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_small_system_exactly() {
        // [[4, 2], [2, 3]] x = [2, 1] -> x = [0.5, 0].
        let x = solve_spd(&[4.0, 2.0, 2.0, 3.0], &[2.0, 1.0], 2).unwrap();
        assert!((x[0] - 0.5).abs() < 1e-12 && x[1].abs() < 1e-12, "{x:?}");
        assert!(solve_spd(&[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0], 2).is_none());
    }

    #[test]
    fn a_line_is_fitted_with_zero_residual() {
        let y: Vec<f64> = (0..10).map(|i| 3.0 - 0.5 * i as f64).collect();
        let rss = lsq_rss(&y, 2, |i, r| {
            r[0] = 1.0;
            r[1] = i as f64;
        })
        .unwrap();
        assert!(rss < 1e-6, "{rss}");
    }

    /// The normal equations accumulated element by element, as written in
    /// the textbook.
    fn textbook(
        y: &[f64],
        m: usize,
        basis: impl Fn(usize, &mut [f64]),
    ) -> (Vec<f64>, Vec<f64>, f64) {
        let (mut ata, mut aty, mut row, mut yy) =
            (vec![0.0; m * m], vec![0.0; m], vec![0.0; m], 0.0);
        for (i, &v) in y.iter().enumerate() {
            basis(i, &mut row);
            for p in 0..m {
                aty[p] += row[p] * v;
                for q in 0..=p {
                    ata[p * m + q] += row[p] * row[q];
                }
            }
            yy += v * v;
        }
        for p in 0..m {
            for q in 0..p {
                ata[q * m + p] = ata[p * m + q];
            }
        }
        (ata, aty, yy)
    }

    /// [`textbook`], then solved like `lsq_rss`.
    fn naive_rss(y: &[f64], m: usize, basis: impl Fn(usize, &mut [f64])) -> Option<f64> {
        let (mut ata, aty, yy) = textbook(y, m, basis);
        let trace: f64 = (0..m).map(|p| ata[p * m + p]).sum::<f64>() / m as f64;
        for p in 0..m {
            ata[p * m + p] += 1e-12 * trace;
        }
        let x = solve_spd(&ata, &aty, m)?;
        let explained: f64 = x.iter().zip(&aty).map(|(a, b)| a * b).sum();
        Some((yy - explained).max(0.0))
    }

    #[test]
    fn the_dispatched_accumulation_is_the_plain_loop_bit_for_bit() {
        let y: Vec<f64> = (0..500).map(|i| ((i * 7919) % 101) as f64 * 0.37).collect();
        let basis = |i: usize, r: &mut [f64]| {
            for (k, x) in r.iter_mut().enumerate() {
                *x = ((k + 1) as f64 * i as f64 * 0.013).sin();
            }
        };
        // Every block width (4, 8, 12, 16 and a 16 plus a narrower tail).
        for m in 1..=37 {
            let fast = normal_equations(&y, m, per_row(m, basis));
            let plain = normal_equations_plain(&y, m, per_row(m, basis));
            let book = textbook(&y, m, basis);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for other in [&plain, &book] {
                assert_eq!(bits(&fast.0), bits(&other.0), "m={m}");
                assert_eq!(bits(&fast.1), bits(&other.1), "m={m}");
                assert_eq!(fast.2.to_bits(), other.2.to_bits(), "m={m}");
            }
        }
    }

    #[test]
    fn residual_is_bit_for_bit_the_textbook_accumulation() {
        // Trend plus 10 harmonics over 800 rows of a noisy banded profile.
        let y: Vec<f64> = (0..800)
            .map(|i| {
                let t = i as f64 / 68.6;
                (t.fract() < 0.5) as u8 as f64 + 0.01 * ((i * 7919 % 101) as f64 - 50.0)
            })
            .collect();
        let basis = |i: usize, r: &mut [f64]| {
            let t = 2.0 * i as f64 / 799.0 - 1.0;
            r[..3].copy_from_slice(&[1.0, t, t * t]);
            for k in 0..10 {
                let w = 2.0 * std::f64::consts::PI * (k + 1) as f64 * i as f64 / 68.6;
                r[3 + 2 * k] = w.cos();
                r[4 + 2 * k] = w.sin();
            }
        };
        let fast = lsq_rss(&y, 23, basis).unwrap();
        let naive = naive_rss(&y, 23, basis).unwrap();
        assert_eq!(fast.to_bits(), naive.to_bits(), "{fast} vs {naive}");
    }
}
