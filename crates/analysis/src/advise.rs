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
//! the LED. (Per-pixel merge rules belong to the camera model, docs/camera-model.md.)
//!
//! Frame time: a camera at `fps` frames per second cannot expose longer
//! than its frame time `1 / fps`; an HDR camera whose captures run one
//! after the other in the frame (sequential, DOL) has that time for all of
//! them, so its long capture `T` satisfies `T + sum_i T / r_i + sum_j F_j
//! <= 1 / fps` (ratio captures `T / r_i`, fixed captures `F_j`). Split-pixel
//! captures run at the same time and each has the whole frame time. Advice
//! with a [`FrameBound`] offers no exposure beyond that bound: longer ones
//! are listed in `left_out` with the reason, and when even the longest
//! exposure the camera can make is at or below `T*`, the advice says so and
//! names the lowest frequency (at `D_min`) and the lowest duty (at `f_min`)
//! that the longest exposure always catches: `f > (1 - D_min) / T_max`,
//! `D > 1 - f_min T_max`.

pub use ledflicker_results::advise::{Advice, Candidate, FrameBound, LeftOut};
use rayon::prelude::*;

use crate::analysis::finemap::Axis;
use ledflicker_physics::{Shutter, ShutterModel};

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
    /// The camera's frame time, which bounds every exposure; `None`: no bound.
    pub frame: Option<FrameBound>,
}

/// An invalid request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct AdviseError(pub String);

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
            let f = fa.at(i);
            let duties: Vec<f64> = (0..da.count).map(|j| da.at(j).min(1.0)).collect();
            // A row's envelopes at once (the same doubles as one by one);
            // an invalid drive gets (0, 0).
            let envelopes = shutter.phase_envelopes_checked(f, &duties, 0..1);
            duties.into_iter().zip(envelopes).map(move |(d, e)| {
                let (lo, hi) = e.unwrap_or((0.0, 0.0));
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
    let t_max = match req.frame {
        Some(fb) => {
            let t = fb.max_exposure_s();
            if !(fb.fps.is_finite() && fb.fps > 0.0 && t > 0.0) {
                return Err(AdviseError(format!(
                    "at {} fps the other captures leave no time in the frame for an exposure",
                    fb.fps
                )));
            }
            Some(t)
        }
        None => None,
    };
    let fits = |t: f64| t_max.is_none_or(|m| t <= m * (1.0 + 1e-12));
    let fa = axis(req.frequency_hz, req.frequency_step_hz);
    let da = axis(req.duty, req.duty_step);
    let eval = |t: f64| evaluate(t, bound, fa, da, req.speed_px_per_s);
    let mut left_out = Vec::new();
    let mut candidates = Vec::new();
    for m in MULTIPLES {
        let t = bound * m;
        if fits(t) {
            candidates.push(eval(t));
        } else if let Some(fb) = req.frame {
            left_out.push(LeftOut {
                exposure_s: t,
                reason: fb.reason(),
            });
        }
    }
    // The longest exposure the camera can make, when the table stops short
    // of it (or offers nothing).
    if let Some(m) = t_max
        && candidates
            .last()
            .is_none_or(|c| c.exposure_s < m * (1.0 - 1e-9))
        && MULTIPLES.iter().any(|k| bound * k > m)
    {
        candidates.push(eval(m));
    }
    // HDR: the short captures of a long capture at T* (or at the longest
    // the camera can make, if shorter).
    let long = t_max.map_or(bound, |m| bound.min(m));
    let hdr = req.hdr_ratios.iter().map(|r| eval(long / r)).collect();
    let covered = t_max.map(|m| ((1.0 - d0) / m, (1.0 - f0 * m).max(0.0)));
    let infeasible = match (t_max, req.frame) {
        (Some(m), Some(fb)) if m <= bound => {
            let (fc, dc) = covered.unwrap_or_default();
            Some(format!(
                "no exposure this camera can make keeps the LED over the whole range: T* = {:.3} ms, but the longest exposure is {:.3} ms at {} fps; at this frame rate the longest exposure always catches the LED only above {fc:.1} Hz at duty {:.1} %, or above duty {:.1} % at {f0} Hz",
                bound * 1e3,
                m * 1e3,
                fb.fps,
                100.0 * d0,
                100.0 * dc
            ))
        }
        _ => None,
    };
    Ok(Advice {
        min_exposure_s: bound,
        binding: (f0, d0),
        candidates,
        hdr,
        grid_cells: fa.count * da.count,
        frame: req.frame,
        max_exposure_s: t_max,
        left_out,
        infeasible,
        lowest_covered_frequency_hz: covered.map(|c| c.0),
        lowest_covered_duty: covered.map(|c| c.1),
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
    if let (Some(fb), Some(m)) = (a.frame, a.max_exposure_s) {
        let _ = writeln!(
            out,
            "frame bound: at {} fps the longest exposure is {:.4} ms (frame time {:.4} ms{}); nothing longer is offered.",
            fb.fps,
            m * 1e3,
            1e3 / fb.fps,
            if fb.other_ratio > 0.0 || fb.other_fixed_s > 0.0 {
                " less the other captures"
            } else {
                ""
            }
        );
        if let Some(why) = &a.infeasible {
            let _ = writeln!(out, "{why}.");
        }
        for l in &a.left_out {
            let _ = writeln!(out, "left out: {:.4} ms, {}", l.exposure_s * 1e3, l.reason);
        }
        out.push('\n');
    }
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
    let t_max = a.max_exposure_s.unwrap_or(f64::INFINITY);
    Ok((0..n)
        .map(|i| {
            // Log-spaced from T*/4 to 4 T*, none beyond the frame bound.
            let x = -2.0 + 4.0 * i as f64 / (n - 1) as f64;
            a.min_exposure_s * 2f64.powf(x)
        })
        .filter(|&t| t <= t_max)
        .map(|t| evaluate(t, a.min_exposure_s, fa, da, req.speed_px_per_s))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_physics::PwmDrive;
    use ledflicker_physics::hdr::{Capture, CaptureExposure, HdrMode};

    #[test]
    fn bound_is_the_maximum_of_eq1_over_a_brute_force_grid() {
        let req = AdviseRequest {
            frequency_hz: (90.0, 600.0),
            duty: (0.1, 0.9),
            frequency_step_hz: 10.0,
            duty_step: 0.05,
            speed_px_per_s: Some(1000.0),
            hdr_ratios: vec![4.0],
            frame: None,
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
            frame: None,
        };
        assert!(advise(&req).is_err());
        req.frequency_hz = (90.0, 100.0);
        req.duty = (0.0, 0.5);
        assert!(advise(&req).is_err());
    }

    fn request(
        f: (f64, f64),
        d: (f64, f64),
        frame: Option<FrameBound>,
        hdr: Vec<f64>,
    ) -> AdviseRequest {
        AdviseRequest {
            frequency_hz: f,
            duty: d,
            frequency_step_hz: 5.0,
            duty_step: 0.05,
            speed_px_per_s: None,
            hdr_ratios: hdr,
            frame,
        }
    }

    /// A 60 fps camera: nothing beyond 16.67 ms is offered; the multiples
    /// of T* beyond it are listed with the reason, and the frame time itself
    /// is offered instead.
    #[test]
    fn no_offer_exceeds_the_frame_time() {
        let fb = FrameBound::frame_time(60.0);
        let a = advise(&request((90.0, 600.0), (0.1, 0.9), Some(fb), vec![])).unwrap();
        assert!((a.min_exposure_s - 0.01).abs() < 1e-15);
        assert!(
            a.candidates
                .iter()
                .all(|c| c.exposure_s <= 1.0 / 60.0 + 1e-15)
        );
        assert_eq!(a.left_out.len(), 3, "{:?}", a.left_out);
        assert!(
            a.left_out[0]
                .reason
                .contains("frame time 16.667 ms at 60 fps")
        );
        let last = a.candidates.last().unwrap();
        assert!((last.exposure_s - 1.0 / 60.0).abs() < 1e-15);
        assert_eq!(last.loses_led_fraction, 0.0);
        assert!(a.infeasible.is_none());
        let unbounded = advise(&request((90.0, 600.0), (0.1, 0.9), None, vec![])).unwrap();
        assert_eq!(unbounded.candidates.len(), MULTIPLES.len());
        // The chart's curve stops at the bound too.
        let curve = curve(&request((90.0, 600.0), (0.1, 0.9), Some(fb), vec![]), 33).unwrap();
        assert!(curve.iter().all(|c| c.exposure_s <= 1.0 / 60.0 + 1e-15));
        assert!(curve.len() < 33);
    }

    /// T* = (1 - 0.11) / 45 Hz = 19.8 ms does not fit a 60 fps frame: the
    /// advice says so, offers only the frame time, and names what it covers;
    /// checked against the exact envelope just above and below.
    #[test]
    fn infeasible_range_names_what_the_frame_rate_can_cover() {
        let fb = FrameBound::frame_time(60.0);
        let a = advise(&request((45.0, 400.0), (0.11, 0.5), Some(fb), vec![])).unwrap();
        assert_eq!(a.candidates.len(), 1);
        assert!(a.candidates[0].loses_led_fraction > 0.0);
        assert_eq!(a.left_out.len(), MULTIPLES.len());
        let why = a.infeasible.as_deref().unwrap();
        assert!(why.contains("no exposure this camera can make"), "{why}");
        let t = 1.0 / 60.0;
        let fc = a.lowest_covered_frequency_hz.unwrap();
        let dc = a.lowest_covered_duty.unwrap();
        assert!((fc - 0.89 * 60.0).abs() < 1e-9 && (dc - 0.25).abs() < 1e-12);
        let shutter = Shutter {
            model: ShutterModel::Global,
            exposure_s: t,
            fps: 60.0,
        };
        let lowest = |f: f64, d: f64| {
            shutter
                .phase_envelope(&PwmDrive::new(f, d, 0.0).unwrap(), 0..1)
                .0
        };
        assert!(lowest(fc * 1.001, 0.11) > 0.0 && lowest(fc * 0.999, 0.11) <= 1e-12);
        assert!(lowest(45.0, dc + 0.001) > 0.0 && lowest(45.0, dc - 0.001) <= 1e-12);
    }

    /// Sequential HDR at 30 fps with captures T, T/4, T/16: the long capture
    /// gets (1/30) / (1 + 1/4 + 1/16) = 25.4 ms, and every offer fits the frame
    /// with its short captures.
    #[test]
    fn sequential_hdr_shares_the_frame_time() {
        let fb = FrameBound::sequential(30.0, &[4.0, 16.0]);
        let a = advise(&request(
            (50.0, 400.0),
            (0.1, 0.9),
            Some(fb),
            vec![4.0, 16.0],
        ))
        .unwrap();
        let m = a.max_exposure_s.unwrap();
        assert!((m - (1.0 / 30.0) / 1.3125).abs() < 1e-15);
        for c in &a.candidates {
            assert!(c.exposure_s * (1.0 + 0.25 + 0.0625) <= 1.0 / 30.0 + 1e-15);
        }
        let split = FrameBound::of_captures(
            30.0,
            &[
                Capture {
                    name: "L".into(),
                    exposure: CaptureExposure::Ratio(1.0),
                    sensitivity_ratio: 1.0,
                },
                Capture {
                    name: "S".into(),
                    exposure: CaptureExposure::Fixed(0.011),
                    sensitivity_ratio: 0.1,
                },
            ],
            HdrMode::SplitPixel,
        );
        assert_eq!(split.max_exposure_s(), 1.0 / 30.0);
        let seq = FrameBound {
            other_fixed_s: 0.04,
            ..split
        };
        assert!(advise(&request((50.0, 400.0), (0.1, 0.9), Some(seq), vec![])).is_err());
    }
}
