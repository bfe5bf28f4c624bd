//! Honest uncertainties of the camera fit (docs/calibration.md,
//! "Uncertainty"): the covariance scaled for rows that repeat the same
//! sample, a row-block jackknife, and the profile test that tells a black
//! level the frames determine from one they only bound.

use super::fit::{self, ModelFit, ModelParams, idx};

/// Share of the output full scale below which a dark level counts as zero.
const DARK_FLOOR: f64 = 0.002;
/// Profile-likelihood threshold: an alternative within `Delta chi^2 <= 4`
/// (two sigma) of the best fit is consistent with the frames.
const CONSISTENT_CHI2: f64 = 4.0;

/// The black level as the frames give it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlackLevel {
    /// Black level, DN; `None` when only bounded.
    pub value: Option<f64>,
    /// Its one-sigma uncertainty, DN.
    pub sigma: Option<f64>,
    /// Upper bound when undetermined: the dark level, DN.
    pub max: Option<f64>,
}

/// The dark level of a fit, DN: what a row with the light OFF shows,
/// `B + A c0^(1/gamma)` (shading at its centre value).
pub fn dark_level(p: &ModelParams) -> f64 {
    let v = &p.values;
    let u = v[idx::C0].clamp(0.0, 1.0);
    v[idx::BLACK].max(0.0) + p.full_scale * u.powf(1.0 / v[idx::GAMMA])
}

/// The two ends of the black level's physical range, each refitted with
/// `B` fixed: `B = 0` (the dark level is ambient light) and `B = dark
/// level` (no ambient light). An end that fits better than `best` replaces
/// it. Returns the best fit and the two ends.
pub fn black_ends(data: &[Vec<f64>], best: ModelFit, fixed: &[bool]) -> (ModelFit, Vec<ModelFit>) {
    let a = best.params.full_scale;
    let dark = dark_level(&best.params);
    let mut fixed_b = fixed.to_vec();
    fixed_b[idx::BLACK] = true;
    let ends: Vec<ModelFit> = [0.0, dark]
        .iter()
        .map(|&b| {
            let mut start = best.params.clone();
            let g = start.values[idx::GAMMA];
            start.values[idx::BLACK] = b;
            start.values[idx::C0] = ((dark - b).max(0.0) / a).powf(g);
            fit::fit(data, &start, &fixed_b, 100)
        })
        .collect();
    let mut best = best;
    if let Some(e) = ends
        .iter()
        .filter(|e| e.rms < best.rms)
        .min_by(|x, y| x.rms.total_cmp(&y.rms))
    {
        // Refitted with the black level free, for its covariance.
        best = fit::fit(data, &e.params, fixed, 0);
    }
    (best, ends)
}

/// Profile test of the black level `B` of `best` against the `ends` of
/// [`black_ends`]. An end is consistent with the frames when it lies within
/// two reported sigmas of `B` or within `Delta chi^2 <= 4` (with the
/// residual variance scaled by `inflation^2`). When both ends are, `B` is
/// only bounded: `0 <= B <= dark level` (plus two residual sigmas). With a
/// linear response the ends are exactly degenerate, since
/// `B + A (c0 + c1 s) = (B + A c0) + A c1 s`. Otherwise the sigma is the
/// larger of the reported sigma and the parabolic profile sigma
/// `|B_end - B| / sqrt(Delta chi^2)`.
pub fn black_level(
    data: &[Vec<f64>],
    best: &ModelFit,
    ends: &[ModelFit],
    fixed: &[bool],
    inflation: f64,
) -> BlackLevel {
    let n_res = data.iter().flatten().filter(|y| !y.is_nan()).count() as f64;
    let free = fixed.iter().filter(|f| !**f).count() as f64;
    let cost = |f: &ModelFit| f.rms * f.rms * n_res;
    let a = best.params.full_scale;
    let b = best.params.values[idx::BLACK].max(0.0);
    let s2 = inflation * inflation * cost(best) / (n_res - free).max(1.0);
    let chi2 = |e: &ModelFit| ((cost(e) - cost(best)) / s2.max(1e-300)).max(0.0);
    let sigma = best.sigma[idx::BLACK];
    let dark = dark_level(&best.params);
    let end_b = |e: &ModelFit| e.params.values[idx::BLACK].max(0.0);
    let consistent = ends
        .iter()
        .all(|e| chi2(e) <= CONSISTENT_CHI2 || (end_b(e) - b).abs() <= 2.0 * sigma);
    if consistent && dark > DARK_FLOOR * a {
        return BlackLevel {
            value: None,
            sigma: None,
            // The fitted dark level plus two residual sigmas.
            max: Some(dark + 2.0 * s2.sqrt()),
        };
    }
    let profile_sigma = ends
        .iter()
        .map(|e| {
            let (db, c) = ((end_b(e) - b).abs(), chi2(e));
            if db > 0.0 && c > 0.0 {
                db / c.sqrt()
            } else {
                0.0
            }
        })
        .fold(0.0f64, f64::max);
    // A dark level below the floor bounds B to [0, dark]: half of it at least.
    let span = if dark <= DARK_FLOOR * a {
        0.5 * dark
    } else {
        0.0
    };
    BlackLevel {
        value: Some(b),
        sigma: Some(sigma.max(profile_sigma).max(span)),
        max: None,
    }
}

/// Rows whose sub-row band phases differ by less than this share of a row
/// sample the same point of the waveform.
const PHASE_BIN_ROWS: f64 = 0.05;
/// Row blocks of the jackknife.
const JACKKNIFE_BLOCKS: usize = 8;

/// Covariance inflation `sqrt(N / N_eff)`: `N_eff` counts the distinct
/// sub-row band phases (bins of [`PHASE_BIN_ROWS`]) per frame. Rows that
/// sample the same phase of the same waveform repeat the same quantisation
/// error and the same model error, so they are one sample, not many (a
/// band period of a whole number of rows repeats every band exactly).
pub fn inflation(data: &[Vec<f64>], period_rows: f64) -> f64 {
    let bins = (period_rows / PHASE_BIN_ROWS).ceil().max(1.0);
    let mut seen = std::collections::HashSet::new();
    let mut n = 0usize;
    for (j, frame) in data.iter().enumerate() {
        for (r, y) in frame.iter().enumerate() {
            if y.is_nan() {
                continue;
            }
            n += 1;
            let phase = (r as f64 / period_rows).fract();
            seen.insert((j, ((phase * bins) as u64).min(bins as u64 - 1)));
        }
    }
    (n as f64 / seen.len().max(1) as f64).sqrt()
}

/// Delete-one-block jackknife (Quenouille 1956, Tukey 1958; row blocks as
/// in Kunsch 1989): the fit is repeated without each of
/// [`JACKKNIFE_BLOCKS`] contiguous row blocks, from `best`, and
/// `sigma^2 = (K - 1) / K sum_k (theta_k - mean)^2` for every parameter.
/// Structured model error (a scene the model does not know) moves the
/// blocks apart, where the covariance, which assumes independent rows,
/// does not see it.
pub fn jackknife(data: &[Vec<f64>], best: &ModelFit, fixed: &[bool]) -> Vec<f64> {
    let n = data.first().map_or(0, Vec::len);
    let m = best.params.values.len();
    let k = JACKKNIFE_BLOCKS.min(n / 8);
    if k < 2 {
        return vec![0.0; m];
    }
    let runs: Vec<Vec<f64>> = (0..k)
        .map(|b| {
            let (lo, hi) = (b * n / k, (b + 1) * n / k);
            let held: Vec<Vec<f64>> = data
                .iter()
                .map(|f| {
                    let mut f = f.clone();
                    f[lo..hi].iter_mut().for_each(|y| *y = f64::NAN);
                    f
                })
                .collect();
            fit::fit(&held, &best.params, fixed, 60).params.values
        })
        .collect();
    (0..m)
        .map(|p| {
            let mean = runs.iter().map(|v| v[p]).sum::<f64>() / k as f64;
            let ss: f64 = runs.iter().map(|v| (v[p] - mean).powi(2)).sum();
            ((k - 1) as f64 / k as f64 * ss).sqrt()
        })
        .collect()
}

/// One code of the frames' output, DN: the step a row value is rounded to.
const QUANTUM_DN: f64 = 1.0;
/// An ON fraction within this of 0 or 1 is flat: the window lies wholly
/// outside or inside an ON interval.
const FLAT_ON_FRACTION: f64 = 1e-9;

/// Shift of each parameter when a flat level moves by its rounding error.
/// The rows of a flat level (ON fraction 0: the floor, 1: the plateau of an
/// exposure shorter than the ON time) all show the same value, rounded
/// once: one error, uniform with sigma `q / sqrt(12)` (`q` one code),
/// repeated over every such row of every frame. The covariance counts it
/// as many independent errors and the jackknife's row blocks all share it,
/// so neither sees it: a plateau rounded 0.4 DN down moves exposure and
/// duty by some 12 of their other sigmas. Each level is moved by `q / sqrt(12)` in
/// turn and the fit repeated from `best`; the shifts of the levels add in
/// quadrature.
pub fn flat_level_quantisation(data: &[Vec<f64>], best: &ModelFit, fixed: &[bool]) -> Vec<f64> {
    let m = best.params.values.len();
    let delta = QUANTUM_DN / 12f64.sqrt();
    let mut sum2 = vec![0.0; m];
    for level in [0.0, 1.0] {
        let mut moved = data.to_vec();
        let mut any = false;
        for (j, frame) in moved.iter_mut().enumerate() {
            for (r, y) in frame.iter_mut().enumerate() {
                if (best.params.on_fraction(j, r) - level).abs() <= FLAT_ON_FRACTION {
                    *y += delta;
                    any = true;
                }
            }
        }
        if !any {
            continue;
        }
        let refit = fit::fit(&moved, &best.params, fixed, 60).params.values;
        for (s2, (a, b)) in sum2.iter_mut().zip(refit.iter().zip(&best.params.values)) {
            *s2 += (a - b) * (a - b);
        }
    }
    sum2.into_iter().map(f64::sqrt).collect()
}

/// The reported sigmas: the larger of the inflated covariance sigma and
/// the jackknife sigma, with the flat levels' rounding
/// ([`flat_level_quantisation`]) added in quadrature, for each parameter.
pub fn honest_sigmas(
    data: &[Vec<f64>],
    best: &ModelFit,
    fixed: &[bool],
    inflation: f64,
) -> Vec<f64> {
    let jk = jackknife(data, best, fixed);
    let flat = flat_level_quantisation(data, best, fixed);
    best.sigma
        .iter()
        .zip(&jk)
        .zip(&flat)
        .zip(fixed)
        .map(|(((s, j), q), &f)| {
            if f {
                0.0
            } else {
                (inflation * s).max(*j).hypot(*q)
            }
        })
        .collect()
}
