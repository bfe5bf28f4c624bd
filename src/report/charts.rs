//! Charts as SVG strings (plotters), one function per chart.
//!
//! Text is set in "DejaVu Sans", named explicitly: a generic "sans-serif"
//! falls back to a serif face in the PDF engine (DEPENDENCIES.md).

use plotters::prelude::*;

use crate::metrics::flicker::Segment;
use crate::runner::CaseResult;

/// Font family named in every chart.
pub const FONT: &str = "DejaVu Sans";

const SERIES_COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// A chart could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw chart `{chart}`: {message}")]
pub struct ChartError {
    /// Which chart.
    pub chart: String,
    /// Cause.
    pub message: String,
}

fn segment_fill(s: Segment) -> RGBAColor {
    match s {
        Segment::On => RGBColor(255, 200, 60).mix(0.18),
        Segment::Off => RGBColor(60, 60, 60).mix(0.12),
        Segment::Pwm => RGBColor(80, 140, 255).mix(0.06),
    }
}

/// ROI luma against time for one case, like Figure 10 of Deegan 2018: the
/// segments shaded, the ON and OFF reference levels of the first ROI drawn
/// dashed, and the PWM-segment min and max of each ROI marked.
pub fn luma_trace_svg(result: &CaseResult) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("trace {}", result.case.id),
        message: e.to_string(),
    };
    let acq = &result.acquisition;
    let frames = &acq.frames;
    let t_end = frames.last().map(|f| f.time_s).unwrap_or(0.0).max(1e-3);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for roi in &acq.rois {
        for &v in &roi.luma {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(err(&"the trace is empty"));
    }
    let pad = ((hi - lo) * 0.08).max(1.0);
    let (y0, y1) = ((lo - pad).max(0.0), hi + pad);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 250)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(10)
            .x_label_area_size(34)
            .y_label_area_size(52)
            .build_cartesian_2d(0.0..t_end, y0..y1)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc("ROI luma (DN)")
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 12))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| err(&e))?;

        // Shade each run of frames of one segment.
        let mut start = 0;
        for i in 1..=frames.len() {
            if i == frames.len() || frames[i].segment != frames[start].segment {
                let x0 = frames[start].time_s;
                let x1 = if i == frames.len() {
                    t_end
                } else {
                    frames[i].time_s
                };
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x0, y0), (x1, y1)],
                        segment_fill(frames[start].segment).filled(),
                    )))
                    .map_err(|e| err(&e))?;
                start = i;
            }
        }

        if let Some(m) = result.metrics.first() {
            for (level, label, colour) in [
                (m.levels.on, "ON level", RGBColor(200, 120, 0)),
                (m.levels.off, "OFF level", RGBColor(60, 60, 60)),
            ] {
                let Some(level) = level else { continue };
                chart
                    .draw_series(DashedLineSeries::new(
                        [(0.0, level), (t_end, level)],
                        6,
                        4,
                        colour.stroke_width(1),
                    ))
                    .map_err(|e| err(&e))?
                    .label(format!("{label} {level:.2} DN"))
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour));
            }
        }

        for (i, roi) in acq.rois.iter().enumerate() {
            let colour = SERIES_COLOURS[i % SERIES_COLOURS.len()];
            chart
                .draw_series(LineSeries::new(
                    frames.iter().zip(&roi.luma).map(|(f, &v)| (f.time_s, v)),
                    colour.stroke_width(1),
                ))
                .map_err(|e| err(&e))?
                .label(roi.name.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour));
            // Mark the PWM-segment extremes that the metrics use.
            let pwm = || {
                frames
                    .iter()
                    .zip(&roi.luma)
                    .filter(|(f, _)| f.segment == Segment::Pwm)
            };
            let min = pwm().min_by(|a, b| a.1.total_cmp(b.1));
            let max = pwm().max_by(|a, b| a.1.total_cmp(b.1));
            for (f, &v) in min.into_iter().chain(max) {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (f.time_s, v),
                        3,
                        colour.filled(),
                    )))
                    .map_err(|e| err(&e))?;
            }
        }

        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font((FONT, 11))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}
