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

/// Cell edges around sorted centres: midpoints (geometric when `log`).
fn edges(centres: &[f64], log: bool) -> Vec<f64> {
    let mid = |a: f64, b: f64| if log { (a * b).sqrt() } else { 0.5 * (a + b) };
    let n = centres.len();
    let mut e = Vec::with_capacity(n + 1);
    if n == 1 {
        let c = centres[0];
        return if log {
            vec![c / 1.3, c * 1.3]
        } else {
            vec![c - 5.0, c + 5.0]
        };
    }
    let first = if log {
        centres[0] * centres[0] / mid(centres[0], centres[1])
    } else {
        2.0 * centres[0] - mid(centres[0], centres[1])
    };
    e.push(first);
    for w in centres.windows(2) {
        e.push(mid(w[0], w[1]));
    }
    let last = if log {
        centres[n - 1] * centres[n - 1] / mid(centres[n - 2], centres[n - 1])
    } else {
        2.0 * centres[n - 1] - mid(centres[n - 2], centres[n - 1])
    };
    e.push(last);
    e
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

/// Light levels of the model, in plan order of first appearance.
pub fn light_levels(model: &Results) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for c in &model.cases {
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
        .filter(|c| c.light_lux == light_lux)
        .collect();
    if cases.is_empty() {
        return Err(err(&"no case at this light level"));
    }
    let freqs = distinct(cases.iter().map(|c| c.frequency_hz).collect());
    let duties = distinct(cases.iter().map(|c| c.duty * 100.0).collect());
    let fe = edges(&freqs, true);
    let de = edges(&duties, false);
    let (x0, x1) = (fe[0], fe[fe.len() - 1]);
    let (y0, y1) = (de[0].max(0.0), de[de.len() - 1]);
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
            .build_cartesian_2d((x0..x1).log_scale().with_key_points(freqs.clone()), y0..y1)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("PWM frequency (Hz, log scale)")
            .x_labels(freqs.len())
            .y_desc("duty (%)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
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
            let rect = [(fe[i], de[j].max(y0)), (fe[i + 1], de[j + 1])];
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
            let x = freqs[i];
            let y = duties[j];
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
            let duty_at = |f: f64| 100.0 * (1.0 - f * t);
            // f where the line meets the top and bottom of the plot.
            let fa = ((1.0 - y1 / 100.0) / t).max(x0);
            let fb = ((1.0 - y0 / 100.0) / t).min(x1);
            if t > 0.0 && fa < fb {
                let n = 64;
                let points: Vec<(f64, f64)> = (0..=n)
                    .map(|k| {
                        let f = fa * (fb / fa).powf(k as f64 / n as f64);
                        (f, duty_at(f).clamp(y0, y1))
                    })
                    .collect();
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
                        (fa * 1.04, y1),
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
    fn cell_edges_bracket_every_centre() {
        for (c, log) in [
            (vec![50.0, 90.0, 150.0, 1000.0], true),
            (vec![5.0, 20.0, 50.0, 100.0], false),
            (vec![60.0], true),
        ] {
            let e = edges(&c, log);
            assert_eq!(e.len(), c.len() + 1);
            for (i, x) in c.iter().enumerate() {
                assert!(e[i] < *x && *x < e[i + 1], "{e:?} {c:?}");
            }
        }
    }
}
