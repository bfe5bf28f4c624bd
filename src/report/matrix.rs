//! The frequency x duty matrix of one light level, as SVG (plotters).
//!
//! Part of the report stage, next to [`super::charts`]. Each cell is one
//! case, coloured by the metric its verdict uses (worst over phase or as
//! captured, per the plan), with the verdict marked. Deegan 2018 Eq. (1),
//! `T_exp = (1 - D) / f`, is drawn over it for the camera's exposure: below
//! the line an exposure can fall entirely in the OFF part of a period, so
//! the light can appear OFF.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::charts::{ChartError, FONT};
use super::model::{CaseInfo, Results};
use crate::metrics::Verdict;
use crate::plan::{RoiKind, VerdictBasis};

/// Which metric a matrix shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shown {
    /// FDI (2018): higher is better, `threshold` is a minimum.
    Fdi,
    /// Percent Flicker: lower is better, `threshold` is a maximum.
    PercentFlicker,
}

/// The metric, its results.json name, title and threshold.
fn shown(model: &Results) -> (Shown, String, &'static str, Option<f64>) {
    let worst = model.thresholds.basis == VerdictBasis::WorstPhase;
    let suffix = if worst { "_worst_phase" } else { "" };
    if model.thresholds.fdi_2018_min.is_none() && model.thresholds.percent_flicker_max.is_some() {
        (
            Shown::PercentFlicker,
            format!("percent_flicker{suffix}"),
            "Percent Flicker",
            model.thresholds.percent_flicker_max,
        )
    } else {
        (
            Shown::Fdi,
            format!("fdi_2018{suffix}"),
            "FDI (2018)",
            model.thresholds.fdi_2018_min,
        )
    }
}

/// Position 0..1 on the colour scale: 0 worst, 0.5 at the threshold, 1 best.
fn scale(kind: Shown, value: f64, threshold: f64) -> f64 {
    match kind {
        Shown::Fdi => {
            // FDI <= 0: some frame is no brighter than the OFF reference,
            // the worst there is (the light appears OFF); unbounded above.
            if value < threshold {
                0.5 * (value / threshold.max(1e-9)).clamp(0.0, 1.0)
            } else {
                0.5 + 0.5 * ((1.0 + value - threshold).ln() / 11f64.ln()).clamp(0.0, 1.0)
            }
        }
        Shown::PercentFlicker => {
            if value <= threshold {
                0.5 + 0.5 * (1.0 - value / threshold.max(1e-9)).clamp(0.0, 1.0)
            } else {
                0.5 * (1.0 - (value - threshold) / (100.0 - threshold).max(1e-9)).clamp(0.0, 1.0)
            }
        }
    }
}

/// Red (worst) - yellow (threshold) - green (best).
fn colour(t: f64) -> RGBColor {
    let lerp = |a: (f64, f64, f64), b: (f64, f64, f64), u: f64| {
        RGBColor(
            (a.0 + (b.0 - a.0) * u).round() as u8,
            (a.1 + (b.1 - a.1) * u).round() as u8,
            (a.2 + (b.2 - a.2) * u).round() as u8,
        )
    };
    let red = (215.0, 48.0, 39.0);
    let yellow = (254.0, 224.0, 139.0);
    let green = (26.0, 152.0, 80.0);
    if t < 0.5 {
        lerp(red, yellow, t * 2.0)
    } else {
        lerp(yellow, green, (t - 0.5) * 2.0)
    }
}

/// Sorted distinct values.
fn distinct(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Position of `v` on an axis whose cells are the sorted `knots` at
/// indices 0, 1, ...: piecewise linear between knots (in `ln` when `log`),
/// extrapolating the end segments. A single knot spans one cell between
/// x 1/1.3 and x 1.3 (`log`), or +/- 5 units.
fn to_index(knots: &[f64], v: f64, log: bool) -> f64 {
    let m = |x: f64| if log { x.ln() } else { x };
    if knots.len() == 1 {
        let half = if log { 1.3f64.ln() } else { 5.0 };
        return 0.5 * (m(v) - m(knots[0])) / half;
    }
    let k = knots
        .windows(2)
        .position(|w| v <= w[1])
        .unwrap_or(knots.len() - 2);
    k as f64 + (m(v) - m(knots[k])) / (m(knots[k + 1]) - m(knots[k]))
}

/// Inverse of [`to_index`].
fn from_index(knots: &[f64], x: f64, log: bool) -> f64 {
    let m = |v: f64| if log { v.ln() } else { v };
    let inv = |v: f64| if log { v.exp() } else { v };
    if knots.len() == 1 {
        let half = if log { 1.3f64.ln() } else { 5.0 };
        return inv(m(knots[0]) + 2.0 * x * half);
    }
    let k = (x.floor().max(0.0) as usize).min(knots.len() - 2);
    inv(m(knots[k]) + (x - k as f64) * (m(knots[k + 1]) - m(knots[k])))
}

/// The value shown for a case (first LED ROI, else first ROI), and whether
/// it is +infinity.
fn case_value(case: &CaseInfo, metric: &str) -> (Option<f64>, bool) {
    let Some(roi) = case
        .rois
        .iter()
        .find(|r| r.kind == RoiKind::Led)
        .or(case.rois.first())
    else {
        return (None, false);
    };
    let unbounded = roi.contrast_unbounded && metric.starts_with("fdi");
    (roi.metrics.get(metric).copied().flatten(), unbounded)
}

/// Whether a case's conditions are known (a capture may carry only a
/// source file; its light level, frequency and duty are then 0 in the model
/// and `null` in results.json). Only known cases go into a matrix.
fn known(c: &CaseInfo) -> bool {
    c.light_lux > 0.0 && c.frequency_hz > 0.0 && c.duty > 0.0
}

/// Light levels of the model's cases with known conditions, in plan order
/// of first appearance.
pub fn light_levels(model: &Results) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for c in model.cases.iter().filter(|c| known(c)) {
        if !out.contains(&c.light_lux) {
            out.push(c.light_lux);
        }
    }
    out
}

/// The matrix of cases at `light_lux`, as SVG.
pub fn matrix_svg(model: &Results, light_lux: f64) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("matrix {light_lux} lux"),
        message: e.to_string(),
    };
    let cases: Vec<&CaseInfo> = model
        .cases
        .iter()
        .filter(|c| known(c) && c.light_lux == light_lux)
        .collect();
    if cases.is_empty() {
        return Err(err(&"no case at this light level"));
    }
    let freqs = distinct(cases.iter().map(|c| c.frequency_hz).collect());
    let duties = distinct(cases.iter().map(|c| c.duty * 100.0).collect());
    // Equal cells: column i is freqs[i], row j is duties[j].
    let (x0, x1) = (-0.5, freqs.len() as f64 - 0.5);
    let (y0, y1) = (-0.5, duties.len() as f64 - 0.5);
    let label_at = |knots: &[f64], v: f64| {
        let i = v.round();
        if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < knots.len() {
            crate::util::fixed(
                knots[i as usize],
                if knots[i as usize].fract() == 0.0 {
                    0
                } else {
                    1
                },
            )
        } else {
            String::new()
        }
    };
    let (kind, metric, title, threshold) = shown(model);
    let th = threshold.unwrap_or(match kind {
        Shown::Fdi => 0.1,
        Shown::PercentFlicker => 10.0,
    });

    let mut svg = String::new();
    {
        let rows = duties.len() as u32;
        let height = 90 + 46 * rows.max(3);
        let root = SVGBackend::with_string(&mut svg, (760, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(10)
            .caption(
                format!(
                    "{light_lux} lux: {title}{} by PWM frequency and duty",
                    if metric.ends_with("worst_phase") {
                        ", worst phase,"
                    } else {
                        ""
                    }
                ),
                (FONT, 14),
            )
            .x_label_area_size(34)
            .y_label_area_size(52)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("PWM frequency (Hz)")
            .x_labels(freqs.len() + 1)
            .y_labels(duties.len() + 1)
            .y_desc("duty (%)")
            .x_label_formatter(&|x| label_at(&freqs, *x))
            .y_label_formatter(&|y| label_at(&duties, *y))
            .label_style((FONT, 11))
            .axis_desc_style((FONT, 12))
            .draw()
            .map_err(|e| err(&e))?;

        let centre = Pos::new(HPos::Center, VPos::Center);
        for c in &cases {
            let (Some(i), Some(j)) = (
                freqs.iter().position(|&f| f == c.frequency_hz),
                duties.iter().position(|&d| d == c.duty * 100.0),
            ) else {
                continue;
            };
            let (value, unbounded) = case_value(c, &metric);
            let fill = match (value, unbounded) {
                (_, true) => colour(1.0),
                (Some(v), false) => colour(scale(kind, v, th)),
                (None, false) => RGBColor(200, 200, 200),
            };
            let fill = if c.verdict == Verdict::Info {
                fill.mix(0.45)
            } else {
                fill.mix(1.0)
            };
            let (x, y) = (i as f64, j as f64);
            let rect = [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)];
            chart
                .draw_series(std::iter::once(Rectangle::new(rect, fill.filled())))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(std::iter::once(Rectangle::new(rect, WHITE.stroke_width(2))))
                .map_err(|e| err(&e))?;
            let mark = match c.verdict {
                Verdict::Pass => "\u{2714}",
                Verdict::Fail => "\u{2718}",
                Verdict::Info => "info",
            };
            let text = match (value, unbounded) {
                (_, true) => "+\u{221e}".to_string(),
                (Some(v), false) => crate::util::fixed(v, 2),
                (None, false) => "n/a".to_string(),
            };
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{mark} {text}"),
                    (x, y),
                    TextStyle::from((FONT, 11).into_font())
                        .color(&BLACK)
                        .pos(centre),
                )))
                .map_err(|e| err(&e))?;
        }

        // Eq. (1) for the camera's exposure: D = 1 - f T_exp, in percent.
        if let Some(cam) = &model.dut.camera {
            let t = cam.exposure_ms * 1e-3;
            // Walk along the columns; keep the part inside the rows.
            let n = 40 * freqs.len();
            let points: Vec<(f64, f64)> = (0..=n)
                .map(|k| x0 + (x1 - x0) * k as f64 / n as f64)
                .map(|x| {
                    let f = from_index(&freqs, x, true);
                    (x, to_index(&duties, 100.0 * (1.0 - f * t), false))
                })
                .filter(|(_, y)| (y0..=y1).contains(y))
                .collect();
            if t > 0.0 && points.len() > 1 {
                let (lx, _) = points[0];
                chart
                    .draw_series(LineSeries::new(points, BLACK.stroke_width(2)))
                    .map_err(|e| err(&e))?;
                // Label at the top end of the line, above the cell texts.
                chart
                    .draw_series(std::iter::once(Text::new(
                        format!(
                            "Eq. (1), T_exp = {} ms",
                            crate::util::fixed(cam.exposure_ms, 3)
                        ),
                        (lx + 0.03, y1),
                        TextStyle::from((FONT, 11).into_font())
                            .color(&BLACK)
                            .pos(Pos::new(HPos::Left, VPos::Top)),
                    )))
                    .map_err(|e| err(&e))?;
            }
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_scale_puts_the_threshold_in_the_middle() {
        assert!((scale(Shown::Fdi, 0.1, 0.1) - 0.5).abs() < 1e-12);
        assert_eq!(scale(Shown::Fdi, -1.0, 0.1), 0.0);
        assert_eq!(scale(Shown::Fdi, 0.0, 0.1), 0.0);
        assert!(scale(Shown::Fdi, 0.05, 0.1) < 0.5);
        assert!(scale(Shown::Fdi, 3.0, 0.1) > 0.5);
        assert!((scale(Shown::PercentFlicker, 10.0, 10.0) - 0.5).abs() < 1e-12);
        assert!(scale(Shown::PercentFlicker, 50.0, 10.0) < 0.5);
        assert_eq!(scale(Shown::PercentFlicker, 0.0, 10.0), 1.0);
    }

    #[test]
    fn axis_positions_hit_the_cells_and_invert() {
        let f = [50.0, 90.0, 100.0, 1000.0];
        for (i, v) in f.iter().enumerate() {
            assert!((to_index(&f, *v, true) - i as f64).abs() < 1e-12);
        }
        for x in [-0.5, 0.3, 1.5, 2.9, 3.5] {
            assert!((to_index(&f, from_index(&f, x, true), true) - x).abs() < 1e-9);
        }
        let one = [60.0];
        assert!((to_index(&one, 60.0 * 1.3, true) - 0.5).abs() < 1e-12);
        let d = [5.0, 20.0, 50.0];
        assert!((to_index(&d, 35.0, false) - 1.5).abs() < 1e-12);
        assert!((from_index(&d, 1.5, false) - 35.0).abs() < 1e-12);
    }
}
