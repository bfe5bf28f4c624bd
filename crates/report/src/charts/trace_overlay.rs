//! One regressed case's trace in both runs, for the comparison report
//! (`ledflicker compare --report`): the ROI's mean luma against time, the
//! baseline A and the new run B on the same axes, so a reader sees what
//! changed (a deeper modulation, a darker PWM segment, a lost OFF frame)
//! and not only a KPI's number.

use plotters::prelude::*;

use super::{ChartError, FONT, FONT_FULL_WIDTH};
use crate::comparison::TraceOverlay;

/// Size of the chart, pixels (printed at the PDF's full text width).
const WIDTH: u32 = 760;
/// See [`WIDTH`].
const HEIGHT: u32 = 250;
/// The legend's row above the plot, pixels.
const LEGEND_H: u32 = 20;

const BASELINE: RGBColor = RGBColor(31, 119, 180);
const NEW: RGBColor = RGBColor(179, 38, 30);

/// The chart as SVG; frames with an undefined value are left out.
pub fn trace_overlay_svg(o: &TraceOverlay) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("trace overlay {} {}", o.case, o.roi),
        message: e.to_string(),
    };
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let all = || o.a.iter().chain(&o.b).filter(finite);
    let (t0, t1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let y1 = all().fold(0.0f64, |m, p| m.max(p.1));
    let (t0, t1) = if t0 < t1 { (t0, t1) } else { (0.0, 1.0) };
    let y1 = if y1 > 0.0 { y1 * 1.08 } else { 1.0 };
    let mut svg = String::new();
    {
        let canvas = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        canvas.fill(&WHITE).map_err(|e| err(&e))?;
        // The legend in a row above the plot: over the plot it would
        // cover the ON level, where both traces start.
        let (legend, root) = canvas.split_vertically(LEGEND_H);
        let mut c = ChartBuilder::on(&root)
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, 0.0..y1)
            .map_err(|e| err(&e))?;
        c.configure_mesh()
            .x_desc("time (s)")
            .y_desc("ROI mean luma (DN)")
            .label_style((FONT, FONT_FULL_WIDTH))
            .axis_desc_style((FONT, FONT_FULL_WIDTH))
            .max_light_lines(0)
            .draw()
            .map_err(|e| err(&e))?;
        for (points, colour) in [(&o.a, BASELINE), (&o.b, NEW)] {
            c.draw_series(LineSeries::new(
                points.iter().filter(finite).copied(),
                colour.stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
        }
        let text = TextStyle::from((FONT, FONT_FULL_WIDTH).into_font());
        let mut x = 68;
        for (colour, label) in [(BASELINE, &o.a_label), (NEW, &o.b_label)] {
            let y = LEGEND_H as i32 / 2 + 2;
            legend
                .draw(&PathElement::new(
                    [(x, y), (x + 18, y)],
                    colour.stroke_width(3),
                ))
                .map_err(|e| err(&e))?;
            legend
                .draw(&Text::new(label.clone(), (x + 24, y - 6), text.clone()))
                .map_err(|e| err(&e))?;
            // DejaVu Sans: about 0.62 em a character.
            x +=
                24 + (0.62 * f64::from(FONT_FULL_WIDTH) * label.chars().count() as f64) as i32 + 24;
        }
        canvas.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_runs_are_drawn_with_their_labels_and_undefined_frames_are_skipped() {
        let o = TraceOverlay {
            case: "2000lux-90hz-5pct".to_string(),
            roi: "led".to_string(),
            a_label: "A: firmware ideal-1".to_string(),
            b_label: "B: firmware 1.1".to_string(),
            a: vec![(0.0, 10.0), (0.5, 12.0), (1.0, f64::NAN)],
            b: vec![(0.0, 10.0), (0.5, 2.0), (1.0, 3.0)],
        };
        let svg = trace_overlay_svg(&o).unwrap();
        assert!(svg.contains("A: firmware ideal-1") && svg.contains("B: firmware 1.1"));
        assert!(
            svg.contains("#1F77B4") || svg.contains("rgb(31,119,180)"),
            "{svg}"
        );
        assert!(!svg.contains("NaN"));
    }
}
