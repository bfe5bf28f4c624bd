//! `ledflicker advise`: the exposure a camera needs so that it never loses a
//! PWM LED anywhere in a frequency range and a duty range, what flicker it
//! still leaves, and what it costs in motion blur.
//!
//! Deegan 2018 Eq. (1): an exposure `T` can miss every pulse when
//! `T < (1 - D) / f`. Over a range, the bound is the largest `(1 - D) / f`,
//! at the lowest frequency and the lowest duty: `T* = (1 - D_min) / f_min`.
//! At exactly `T*` the exposure can still just touch zero; any longer one
//! always catches part of a pulse. The residual modulation is the worst
//! over phase, frequency and duty of the Percent Flicker of the LED alone
//! (a dark background: the largest it can be), computed exactly with
//! [`Shutter::phase_envelope`].
//!
//! HDR: a multi-capture camera keeps the LED only if the capture its merge
//! uses for the LED's pixels is at least `T*` long. In daylight the merge
//! takes the short capture, so the set is judged by its shorter captures
//! `T* / ratio`: the table gives the share of the range where each can lose
//! the LED. (Per-pixel merge rules belong to the camera model, issue 3.)

use rayon::prelude::*;
use serde::Serialize;

use crate::analysis::finemap::Axis;
use crate::physics::{PwmDrive, Shutter, ShutterModel};

/// What to advise on.
#[derive(Debug, Clone, PartialEq)]
pub struct AdviseRequest {
    /// Frequency range, Hz (0 < min <= max).
    pub frequency_hz: (f64, f64),
    /// Duty range, (0, 1] (min <= max).
    pub duty: (f64, f64),
    /// Grid step over frequency for the residual, Hz (> 0).
    pub frequency_step_hz: f64,
    /// Grid step over duty for the residual (> 0).
    pub duty_step: f64,
    /// Image speed of a moving object, pixels per second; gives blur in px.
    pub speed_px_per_s: Option<f64>,
    /// Exposure ratios of shorter HDR captures (> 1), e.g. `[4, 16]`.
    pub hdr_ratios: Vec<f64>,
}

/// An invalid request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct AdviseError(pub String);

/// One exposure and what it leaves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// Exposure, seconds.
    pub exposure_s: f64,
    /// Exposure over the bound `T*`.
    pub times_bound: f64,
    /// Fraction (0..=1) of the (f, D) grid where some phase loses the LED
    /// (ON fraction 0).
    pub loses_led_fraction: f64,
    /// Worst-phase Percent Flicker of the LED alone, worst over the grid.
    pub residual_percent_flicker: f64,
    /// Where that worst residual is: (Hz, duty).
    pub residual_at: (f64, f64),
    /// Motion blur, pixels, when a speed was given.
    pub blur_px: Option<f64>,
}

/// The advice.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Advice {
    /// `T* = (1 - D_min) / f_min`, seconds.
    pub min_exposure_s: f64,
    /// The (f, D) corner that sets `T*`.
    pub binding: (f64, f64),
    /// Candidate exposures from `T*` upwards.
    pub candidates: Vec<Candidate>,
    /// Shorter HDR captures `T* / ratio`: each row is a candidate.
    pub hdr: Vec<Candidate>,
    /// Cells in the residual grid.
    pub grid_cells: usize,
}

/// Multiples of `T*` tabulated.
pub const MULTIPLES: [f64; 7] = [1.0, 1.05, 1.25, 1.5, 2.0, 3.0, 4.0];

fn axis(range: (f64, f64), step: f64) -> Axis {
    let count = ((range.1 - range.0) / step + 1e-9).floor() as usize + 1;
    Axis {
        start: range.0,
        step,
        count,
    }
}

/// Evaluates one exposure over the grid.
pub fn evaluate(
    exposure_s: f64,
    bound_s: f64,
    fa: Axis,
    da: Axis,
    speed: Option<f64>,
) -> Candidate {
    let shutter = Shutter {
        model: ShutterModel::Global,
        exposure_s,
        fps: 30.0,
    };
    // (lost, pf, f, d) per cell, reduced in index order: deterministic.
    let cells: Vec<(bool, f64, f64, f64)> = (0..fa.count)
        .into_par_iter()
        .flat_map_iter(|i| {
            (0..da.count).map(move |j| {
                let (f, d) = (fa.at(i), da.at(j).min(1.0));
                let (lo, hi) = PwmDrive::new(f, d, 0.0)
                    .map(|p| shutter.phase_envelope(&p, 0..1))
                    .unwrap_or((0.0, 0.0));
                let pf = if hi + lo > 0.0 {
                    100.0 * (hi - lo) / (hi + lo)
                } else {
                    100.0
                };
                (lo <= 1e-12, pf, f, d)
            })
        })
        .collect();
    let lost = cells.iter().filter(|c| c.0).count();
    let worst = cells
        .iter()
        .fold((f64::NEG_INFINITY, (0.0, 0.0)), |acc, c| {
            if c.1 > acc.0 { (c.1, (c.2, c.3)) } else { acc }
        });
    Candidate {
        exposure_s,
        times_bound: exposure_s / bound_s,
        loses_led_fraction: lost as f64 / cells.len().max(1) as f64,
        residual_percent_flicker: worst.0,
        residual_at: worst.1,
        blur_px: speed.map(|v| v * exposure_s),
    }
}

/// Advice for a request.
pub fn advise(req: &AdviseRequest) -> Result<Advice, AdviseError> {
    let (f0, f1) = req.frequency_hz;
    let (d0, d1) = req.duty;
    if !(f0.is_finite() && f0 > 0.0 && f1 >= f0 && f1.is_finite()) {
        return Err(AdviseError(format!(
            "frequency range {f0}..{f1} Hz must have 0 < min <= max"
        )));
    }
    if !(d0 > 0.0 && d1 >= d0 && d1 <= 1.0) {
        return Err(AdviseError(format!(
            "duty range {d0}..{d1} must lie in (0, 1] with min <= max"
        )));
    }
    if !(req.frequency_step_hz > 0.0 && req.duty_step > 0.0) {
        return Err(AdviseError("grid steps must be > 0".into()));
    }
    if d0 >= 1.0 {
        return Err(AdviseError(
            "a duty of 100 % never flickers: any exposure keeps the LED".into(),
        ));
    }
    let bound = (1.0 - d0) / f0;
    let fa = axis(req.frequency_hz, req.frequency_step_hz);
    let da = axis(req.duty, req.duty_step);
    let candidates = MULTIPLES
        .iter()
        .map(|m| evaluate(bound * m, bound, fa, da, req.speed_px_per_s))
        .collect();
    let hdr = req
        .hdr_ratios
        .iter()
        .map(|r| evaluate(bound / r, bound, fa, da, req.speed_px_per_s))
        .collect();
    Ok(Advice {
        min_exposure_s: bound,
        binding: (f0, d0),
        candidates,
        hdr,
        grid_cells: fa.count * da.count,
    })
}

/// The advice as a plain-text table.
pub fn table(a: &Advice) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let (f0, d0) = a.binding;
    let _ = writeln!(
        out,
        "shortest exposure that never loses the LED: T > T* = (1 - D_min) / f_min = (1 - {d0}) / {f0} Hz = {:.4} ms",
        a.min_exposure_s * 1e3
    );
    let _ = writeln!(
        out,
        "T* is set by the lowest frequency and the lowest duty (Deegan 2018 Eq. 1); raising f_min to {} Hz or D_min to {:.2} halves it.\n",
        2.0 * f0,
        (1.0 + d0) / 2.0
    );
    let blur = a.candidates.iter().any(|c| c.blur_px.is_some());
    let _ = writeln!(
        out,
        "{:<10} {:>12} {:>9} {:>17} {:>22}{}",
        "capture",
        "exposure ms",
        "x T*",
        "loses LED (grid)",
        "worst residual PF %",
        if blur { "   blur px" } else { "" }
    );
    let rows = a
        .candidates
        .iter()
        .map(|c| ("single", c))
        .chain(a.hdr.iter().map(|c| ("HDR short", c)));
    for (label, c) in rows {
        let _ = write!(
            out,
            "{:<10} {:>12.4} {:>9.3} {:>16.1}% {:>9.2} @ {:>5} Hz {:>3.0}%",
            label,
            c.exposure_s * 1e3,
            c.times_bound,
            100.0 * c.loses_led_fraction,
            c.residual_percent_flicker,
            c.residual_at.0,
            100.0 * c.residual_at.1
        );
        if let Some(b) = c.blur_px {
            let _ = write!(out, " {b:>9.2}");
        }
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "\nresidual: worst over phase, frequency and duty ({} grid cells) of the LED-only Percent Flicker; motion blur grows linearly with exposure, so the cost lies in the low-frequency, low-duty corner that sets T*.",
        a.grid_cells
    );
    out
}

/// Residual modulation against exposure, from `T* / 4` to `4 T*`, for a
/// chart: (exposure s, candidate).
pub fn curve(req: &AdviseRequest, points: usize) -> Result<Vec<Candidate>, AdviseError> {
    let a = advise(&AdviseRequest {
        hdr_ratios: Vec::new(),
        ..req.clone()
    })?;
    let fa = axis(req.frequency_hz, req.frequency_step_hz);
    let da = axis(req.duty, req.duty_step);
    let n = points.max(2);
    Ok((0..n)
        .map(|i| {
            // Log-spaced from T*/4 to 4 T*.
            let x = -2.0 + 4.0 * i as f64 / (n - 1) as f64;
            let t = a.min_exposure_s * 2f64.powf(x);
            evaluate(t, a.min_exposure_s, fa, da, req.speed_px_per_s)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bound_is_the_maximum_of_eq1_over_a_brute_force_grid() {
        let req = AdviseRequest {
            frequency_hz: (90.0, 600.0),
            duty: (0.1, 0.9),
            frequency_step_hz: 10.0,
            duty_step: 0.05,
            speed_px_per_s: Some(1000.0),
            hdr_ratios: vec![4.0],
        };
        let a = advise(&req).unwrap();
        let brute = (0..=51)
            .flat_map(|i| {
                (0..=16).map(move |j| (1.0 - (0.1 + j as f64 * 0.05)) / (90.0 + i as f64 * 10.0))
            })
            .fold(0.0, f64::max);
        assert!((a.min_exposure_s - brute).abs() < 1e-15);
        // Longer than T*: never loses the LED; shorter HDR capture: does.
        assert!(
            a.candidates[1..]
                .iter()
                .all(|c| c.loses_led_fraction == 0.0)
        );
        assert!(a.hdr[0].loses_led_fraction > 0.0);
        // At T* itself the corner (f_min, D_min) just touches zero: 100 %.
        assert!((a.candidates[0].residual_percent_flicker - 100.0).abs() < 1e-9);
        // The residual falls as the exposure grows past the bound.
        assert!(
            a.candidates[6].residual_percent_flicker < a.candidates[2].residual_percent_flicker
        );
        assert!((a.candidates[4].blur_px.unwrap() - 2000.0 * a.min_exposure_s).abs() < 1e-9);
    }

    #[test]
    fn invalid_ranges_are_rejected() {
        let mut req = AdviseRequest {
            frequency_hz: (100.0, 90.0),
            duty: (0.1, 0.9),
            frequency_step_hz: 1.0,
            duty_step: 0.01,
            speed_px_per_s: None,
            hdr_ratios: vec![],
        };
        assert!(advise(&req).is_err());
        req.frequency_hz = (90.0, 100.0);
        req.duty = (0.0, 0.5);
        assert!(advise(&req).is_err());
    }
}
