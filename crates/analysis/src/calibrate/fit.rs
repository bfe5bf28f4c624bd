//! The rolling-shutter camera model of a banded row profile and its
//! least-squares fit (docs/calibration.md, "Model").
//!
//! Row `r` of frame `j` (rows counted from the top of the analysed area)
//! starts its exposure `r` line times after row 0. In PWM cycles its
//! exposure window is `[phi_j + r / P, phi_j + r / P + e)`, with `P` the
//! band period in rows and `e = exposure x f` the exposure in cycles. It
//! collects the ON fraction `s = on_fraction(phi_j + r / P, e, D)` of a
//! square wave of duty `D` (the exact integral, docs/camera-model.md), so a
//! band edge is the square wave convolved with the exposure window: a ramp
//! `e P` rows wide. Then
//!
//! ```text
//! u = c0 + c1 g(r) s,          g(r) = 1 + v1 t + v2 t^2, t in [-1, 1]
//! y = min(B + A clamp(u, 0, 1)^(1 / gamma), S)
//! ```
//!
//! with `A` the output full scale (255 or 65535), `B >= 0` the black level,
//! `c0 >= 0` the ambient light,
//! `gamma` the tone curve, `S` the clipping level and `g` the scene's
//! illumination falloff over the rows (lens and lamp, not the camera).
//! Levenberg-Marquardt fits all of them at once; the covariance is
//! `s^2 (J^T J)^-1`.

use super::linalg::{inverse_spd, solve_spd};
use ledflicker_physics::pwm::{on_fraction, wrap_unit};

/// Index of each parameter in [`ModelParams::values`].
pub mod idx {
    /// Band period, rows.
    pub const PERIOD: usize = 0;
    /// Exposure, PWM cycles.
    pub const EXPOSURE: usize = 1;
    /// Duty, 0..1.
    pub const DUTY: usize = 2;
    /// Black level, DN.
    pub const BLACK: usize = 3;
    /// Linear offset (ambient light), fraction of white.
    pub const C0: usize = 4;
    /// Linear LED level, fraction of white.
    pub const C1: usize = 5;
    /// Tone-curve gamma.
    pub const GAMMA: usize = 6;
    /// Illumination falloff, linear term.
    pub const V1: usize = 7;
    /// Illumination falloff, quadratic term.
    pub const V2: usize = 8;
    /// First frame's phase, cycles; one per frame follows.
    pub const PHASE0: usize = 9;
}

/// Model parameters and fixed settings.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelParams {
    /// See [`idx`]; phases last, one per frame.
    pub values: Vec<f64>,
    /// Output full scale `A`, DN.
    pub full_scale: f64,
    /// Clipping level `S`, DN.
    pub clip: f64,
}

impl ModelParams {
    /// ON fraction `s` of row `r`'s exposure window in frame `j`, 0..1.
    pub fn on_fraction(&self, j: usize, r: usize) -> f64 {
        let v = &self.values;
        on_fraction(
            wrap_unit(v[idx::PHASE0 + j] + r as f64 / v[idx::PERIOD]),
            v[idx::EXPOSURE],
            v[idx::DUTY].clamp(1e-6, 1.0),
        )
    }

    /// Modelled value of row `r` (of `n`) in frame `j`.
    pub fn row(&self, j: usize, r: usize, n: usize) -> f64 {
        let v = &self.values;
        let s = self.on_fraction(j, r);
        let u = v[idx::C0].max(0.0) + v[idx::C1] * shading(v, r, n) * s;
        let black = v[idx::BLACK].max(0.0);
        let y = black + self.full_scale * u.clamp(0.0, 1.0).powf(1.0 / v[idx::GAMMA]);
        y.min(self.clip)
    }

    /// The modelled profiles, `[frame][row]`.
    pub fn profiles(&self, frames: usize, n: usize) -> Vec<Vec<f64>> {
        (0..frames)
            .map(|j| (0..n).map(|r| self.row(j, r, n)).collect())
            .collect()
    }
}

/// Illumination falloff `g(r)`.
pub fn shading(v: &[f64], r: usize, n: usize) -> f64 {
    let t = 2.0 * r as f64 / (n.max(2) - 1) as f64 - 1.0;
    1.0 + v[idx::V1] * t + v[idx::V2] * t * t
}

/// A finished fit.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFit {
    /// Best parameters.
    pub params: ModelParams,
    /// One-sigma uncertainty of each value (NaN-free: infinite when the
    /// data do not determine it).
    pub sigma: Vec<f64>,
    /// RMS of data minus model, DN.
    pub rms: f64,
}

/// Parameters are fitted through a transform that keeps them physical:
/// exposure, gamma and LED level positive, duty in (0, 1).
fn to_internal(v: &[f64]) -> Vec<f64> {
    let mut z = v.to_vec();
    z[idx::EXPOSURE] = v[idx::EXPOSURE].ln();
    z[idx::GAMMA] = v[idx::GAMMA].ln();
    z[idx::C1] = v[idx::C1].ln();
    let d = v[idx::DUTY].clamp(1e-4, 1.0 - 1e-4);
    z[idx::DUTY] = (d / (1.0 - d)).ln();
    z
}

fn to_natural(z: &[f64]) -> Vec<f64> {
    let mut v = z.to_vec();
    v[idx::EXPOSURE] = z[idx::EXPOSURE].exp();
    v[idx::GAMMA] = z[idx::GAMMA].exp().clamp(0.05, 20.0);
    v[idx::C1] = z[idx::C1].exp();
    v[idx::DUTY] = 1.0 / (1.0 + (-z[idx::DUTY]).exp());
    v
}

/// Residuals `data - model` for natural parameters `v`.
fn residuals(data: &[Vec<f64>], v: &[f64], full_scale: f64, clip: f64, out: &mut Vec<f64>) {
    let p = ModelParams {
        values: v.to_vec(),
        full_scale,
        clip,
    };
    let n = data.first().map_or(0, Vec::len);
    out.clear();
    for (j, frame) in data.iter().enumerate() {
        for (r, &y) in frame.iter().enumerate() {
            // A NaN row is left out (the jackknife's held-out block).
            out.push(if y.is_nan() { 0.0 } else { y - p.row(j, r, n) });
        }
    }
}

/// Levenberg-Marquardt from `start` (natural parameters); at most `iters`
/// iterations.
/// Parameters whose `fixed[p]` is true keep their start value (sigma 0).
pub fn fit(data: &[Vec<f64>], start: &ModelParams, fixed: &[bool], iters: usize) -> ModelFit {
    let (a, clip) = (start.full_scale, start.clip);
    let m = start.values.len();
    let mut z = to_internal(&start.values);
    let mut res = Vec::new();
    residuals(data, &to_natural(&z), a, clip, &mut res);
    let mut cost: f64 = res.iter().map(|r| r * r).sum();
    let mut lambda = 1e-3;
    let mut jac = Vec::new();
    for _ in 0..iters {
        jacobian(data, &z, a, clip, &res, &mut jac, true, fixed);
        let (jtj, jtr) = normal_equations(&jac, &res, m);
        let mut improved = false;
        for _ in 0..12 {
            let mut damped = jtj.clone();
            for p in 0..m {
                damped[p * m + p] += lambda * jtj[p * m + p] + 1e-12;
            }
            let Some(step) = solve_spd(&damped, &jtr, m) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = z.iter().zip(&step).map(|(a, b)| a + b).collect();
            let mut tres = Vec::new();
            residuals(data, &to_natural(&trial), a, clip, &mut tres);
            let tcost: f64 = tres.iter().map(|r| r * r).sum();
            if tcost.is_finite() && tcost < cost {
                let gain = (cost - tcost) / cost.max(1e-300);
                z = trial;
                res = tres;
                cost = tcost;
                lambda = (lambda * 0.3).max(1e-9);
                improved = gain > 1e-10;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let values = to_natural(&z);
    let n_res = res.len();
    let sigma = covariance_sigma(data, &values, a, clip, &res, cost, fixed);
    ModelFit {
        params: ModelParams {
            values,
            full_scale: a,
            clip,
        },
        sigma,
        rms: (cost / n_res.max(1) as f64).sqrt(),
    }
}

/// One-sigma uncertainties of the natural parameters: the larger of the
/// classical `s^2 (J^T J)^-1` and the sandwich variance.
fn covariance_sigma(
    data: &[Vec<f64>],
    v: &[f64],
    a: f64,
    clip: f64,
    res: &[f64],
    cost: f64,
    fixed: &[bool],
) -> Vec<f64> {
    let m = v.len();
    let mut jac = Vec::new();
    jacobian(data, v, a, clip, res, &mut jac, false, fixed);
    let (mut jtj, _) = normal_equations(&jac, res, m);
    let free = fixed.iter().filter(|f| !**f).count();
    let s2 = cost / (res.len() as f64 - free as f64).max(1.0);
    // A parameter the model does not depend on here (fixed, or held at a
    // bound such as black level 0) is left out of the inverse.
    let scale = (0..m).map(|p| jtj[p * m + p]).fold(0.0f64, f64::max);
    let inert: Vec<bool> = (0..m)
        .map(|p| fixed[p] || jtj[p * m + p] <= 1e-14 * scale)
        .collect();
    for p in (0..m).filter(|&p| inert[p]) {
        for q in 0..m {
            jtj[p * m + q] = 0.0;
            jtj[q * m + p] = 0.0;
        }
        jtj[p * m + p] = 1.0;
    }
    let n = res.len();
    let inv = inverse_spd(&jtj, m);
    // Heteroscedasticity-consistent ("sandwich", White 1980, HC1) variance:
    // `inv (sum_i r_i^2 J_i J_i^T) inv n / (n - p)`. Rows where the model is
    // flat (a plateau) carry no information but lower `s^2`; the sandwich
    // weighs each row's residual by its leverage instead.
    let sandwich = inv.as_ref().map(|inv| {
        let mut meat = vec![0.0; m * m];
        let mut row = vec![0.0; m];
        for (i, r) in res.iter().enumerate() {
            for (p, x) in row.iter_mut().enumerate() {
                *x = if inert[p] { 0.0 } else { jac[p * n + i] };
            }
            for p in 0..m {
                for q in 0..m {
                    meat[p * m + q] += r * r * row[p] * row[q];
                }
            }
        }
        let dof = n as f64 / (n as f64 - free as f64).max(1.0);
        (0..m)
            .map(|p| {
                let mut v = 0.0;
                for a in 0..m {
                    for b in 0..m {
                        v += inv[p * m + a] * meat[a * m + b] * inv[b * m + p];
                    }
                }
                v * dof
            })
            .collect::<Vec<f64>>()
    });
    match inv {
        Some(inv) => (0..m)
            .map(|p| {
                let hc = sandwich.as_ref().map_or(0.0, |v| v[p]);
                let x = (inv[p * m + p] * s2).max(hc);
                if inert[p] {
                    0.0
                } else if x.is_finite() && x >= 0.0 {
                    x.sqrt()
                } else {
                    f64::INFINITY
                }
            })
            .collect(),
        None => vec![f64::INFINITY; m],
    }
}

/// Forward-difference Jacobian of the residuals, column-major
/// (`jac[p * n + i]`), in internal (`internal = true`) or natural
/// parameters. Columns of fixed parameters are zero.
#[allow(clippy::too_many_arguments)]
fn jacobian(
    data: &[Vec<f64>],
    z: &[f64],
    a: f64,
    clip: f64,
    res: &[f64],
    jac: &mut Vec<f64>,
    internal: bool,
    fixed: &[bool],
) {
    let m = z.len();
    let n = res.len();
    jac.clear();
    jac.resize(m * n, 0.0);
    let mut tres = Vec::new();
    for p in (0..m).filter(|&p| !fixed[p]) {
        let h = 1e-6 * z[p].abs().max(1e-3);
        let mut zp = z.to_vec();
        zp[p] += h;
        let v = if internal { to_natural(&zp) } else { zp };
        residuals(data, &v, a, clip, &mut tres);
        for i in 0..n {
            // d(data - model)/dz = -(model' - model)/h = (tres - res)/h.
            jac[p * n + i] = -(tres[i] - res[i]) / h;
        }
    }
}

/// `J^T J` and `J^T r` for the Gauss-Newton step `J^T J dz = J^T r` (with
/// `J` the model's Jacobian: the residual's is its negative).
fn normal_equations(jac: &[f64], res: &[f64], m: usize) -> (Vec<f64>, Vec<f64>) {
    let n = res.len();
    let mut jtj = vec![0.0; m * m];
    let mut jtr = vec![0.0; m];
    for p in 0..m {
        let jp = &jac[p * n..(p + 1) * n];
        jtr[p] = jp.iter().zip(res).map(|(a, b)| a * b).sum();
        for q in 0..=p {
            let jq = &jac[q * n..(q + 1) * n];
            let s: f64 = jp.iter().zip(jq).map(|(a, b)| a * b).sum();
            jtj[p * m + q] = s;
            jtj[q * m + p] = s;
        }
    }
    (jtj, jtr)
}
