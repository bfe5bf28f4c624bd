//! One KPI of one ROI before and after, case by case, for the comparison
//! report (`ledflicker compare --report`): a row per case, the baseline's
//! value as a ring with the gate's noise band around it, the new run's
//! value as a dot, joined by a line that turns red where the case
//! regressed, and the check's limit as a dashed line.

use plotters::prelude::*;

use super::{ChartError, FONT, FONT_FULL_WIDTH};
use crate::comparison::KpiChart;

/// Width of the chart, pixels (printed at the PDF's full text width).
const WIDTH: u32 = 760;
/// Height of one case's row, pixels.
const ROW: u32 = 18;
/// Width of the case-id column left of the plot, pixels.
const LABELS: u32 = 190;

const BASELINE: RGBColor = RGBColor(31, 119, 180);
const NEW: RGBColor = RGBColor(29, 29, 31);
const REGRESSED: RGBColor = RGBColor(179, 38, 30);
const BAND: RGBColor = RGBColor(150, 150, 150);

/// The x range that holds every value, band and the limit, padded.
fn x_range(chart: &KpiChart) -> Option<(f64, f64)> {
    let values = chart
        .points
        .iter()
        .flat_map(|p| {
            let band = p.band.unwrap_or(0.0);
            [p.a.map(|a| a - band), p.a.map(|a| a + band), p.b]
        })
        .chain([chart.threshold])
        .flatten()
        .filter(|v| v.is_finite());
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let pad = ((hi - lo) * 0.06).max(1e-3 * hi.abs().max(1.0));
    Some((lo - pad, hi + pad))
}

/// The chart as SVG; a case whose value is undefined in a run has no mark
/// for that run.
pub fn kpi_change_svg(chart: &KpiChart) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("kpi change {} {}", chart.roi, chart.metric),
        message: e.to_string(),
    };
    let n = chart.points.len().max(1);
    let height = 70 + ROW * n as u32;
    let (lo, hi) = x_range(chart).unwrap_or((0.0, 1.0));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut c = ChartBuilder::on(&root)
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(LABELS)
            .build_cartesian_2d(lo..hi, -0.5..(n as f64 - 0.5))
            .map_err(|e| err(&e))?;
        c.configure_mesh()
            .x_desc(chart.name.as_str())
            .y_labels(0)
            .disable_y_mesh()
            .label_style((FONT, FONT_FULL_WIDTH))
            .axis_desc_style((FONT, FONT_FULL_WIDTH))
            .max_light_lines(0)
            .draw()
            .map_err(|e| err(&e))?;
        // Case ids top to bottom, in the chart's order.
        let y = |i: usize| (n - 1 - i) as f64;
        for (i, p) in chart.points.iter().enumerate() {
            let (px, py) = c.backend_coord(&(lo, y(i)));
            let colour = if p.regressed { REGRESSED } else { NEW };
            let style = TextStyle::from((FONT, FONT_FULL_WIDTH).into_font())
                .color(&colour)
                .pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Right,
                    plotters::style::text_anchor::VPos::Center,
                ));
            root.draw(&Text::new(p.case.clone(), (px - 6, py), style))
                .map_err(|e| err(&e))?;
            if let (Some(a), Some(band)) = (p.a, p.band.filter(|b| *b > 0.0)) {
                c.draw_series([Rectangle::new(
                    [(a - band, y(i) - 0.18), (a + band, y(i) + 0.18)],
                    BAND.mix(0.35).filled(),
                )])
                .map_err(|e| err(&e))?;
            }
            if let (Some(a), Some(b)) = (p.a, p.b) {
                let line = if p.regressed { REGRESSED } else { BAND };
                c.draw_series([PathElement::new(
                    [(a, y(i)), (b, y(i))],
                    line.stroke_width(2),
                )])
                .map_err(|e| err(&e))?;
            }
            if let Some(a) = p.a {
                c.draw_series([Circle::new((a, y(i)), 5, BASELINE.stroke_width(2))])
                    .map_err(|e| err(&e))?;
            }
            if let Some(b) = p.b {
                c.draw_series([Circle::new((b, y(i)), 4, colour.filled())])
                    .map_err(|e| err(&e))?;
            }
        }
        if let Some(t) = chart.threshold.filter(|t| t.is_finite()) {
            c.draw_series(DashedLineSeries::new(
                [(t, -0.5), (t, n as f64 - 0.5)],
                5,
                4,
                REGRESSED.mix(0.8).stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comparison::ChartPoint;

    fn point(case: &str, a: f64, b: f64, regressed: bool) -> ChartPoint {
        ChartPoint {
            case: case.to_string(),
            a: Some(a),
            b: Some(b),
            band: Some(0.05),
            regressed,
        }
    }

    #[test]
    fn every_case_is_named_and_a_regressed_case_is_drawn_red() {
        let chart = KpiChart {
            roi: "led".to_string(),
            metric: "fdi_2018".to_string(),
            name: "FDI (2018)".to_string(),
            threshold: Some(0.1),
            points: vec![
                point("c-60hz", 0.9, 0.88, false),
                point("c-150hz", 1.0, 0.02, true),
            ],
        };
        let svg = kpi_change_svg(&chart).unwrap();
        assert!(
            svg.contains("\nc-60hz\n") && svg.contains("\nc-150hz\n"),
            "{svg}"
        );
        assert!(svg.contains("#B3261E"), "no regressed mark in red");
        // The chart grows by a row a case.
        assert!(svg.contains("height=\"106\""), "{svg}");
        let mut three = chart.clone();
        three.points.push(point("c-300hz", 0.5, 0.5, false));
        let svg = kpi_change_svg(&three).unwrap();
        assert!(svg.contains("\nc-300hz\n") && svg.contains("height=\"124\""));
    }

    #[test]
    fn a_chart_without_a_defined_value_still_draws() {
        let chart = KpiChart {
            roi: "led".to_string(),
            metric: "mmp".to_string(),
            name: "MMP".to_string(),
            threshold: None,
            points: vec![ChartPoint {
                case: "x".to_string(),
                a: None,
                b: None,
                band: None,
                regressed: false,
            }],
        };
        assert!(kpi_change_svg(&chart).unwrap().contains("\nx\n"));
    }
}
