//! The phase folds of a case with many LED ROIs (a P2020 chart of 36
//! patches) as small multiples: one panel per ROI, on one chart, where one
//! chart per ROI would take a third of a page each and say the same.
//!
//! Each panel names its ROI, gives its Percent Flicker and the luma range
//! it is drawn on (each panel has its own scale: the patches differ in
//! level), and draws the fold's per-bin min and max as in
//! [`super::phase_fold_svg`]. The text is 12 px, which the PDF's 80 %-wide
//! image of a [`WIDTH`]-pixel chart sets at 7.7 pt.

use plotters::prelude::*;

use super::{ChartError, FONT, SERIES_COLOURS};
use crate::model::RoiInfo;

/// A case with more drawn folds than this gets one chart of panels.
pub const FOLD_GRID_FROM: usize = 6;

/// Chart width, pixels.
pub const WIDTH: u32 = 600;
/// Panels per row.
const COLUMNS: u32 = 6;
/// Panel height, pixels: three lines of text and the plot.
const PANEL_HEIGHT: u32 = 112;
/// Height of the explanation under the panels (two lines), pixels.
const FOOTER: u32 = 48;
/// Text size, pixels (before plotters' scaling).
const TEXT_PX: u32 = 14;
/// Line spacing of the footer, pixels.
const LINE: u32 = 18;

/// The folds of `rois` (each with its bins) as panels, `COLUMNS` a row,
/// with an explanation under them. `case_id` names the chart in
/// errors.
pub fn fold_grid_svg(case_id: &str, rois: &[&RoiInfo]) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("phase folds {case_id}"),
        message: e.to_string(),
    };
    let rows = (rois.len() as u32).div_ceil(COLUMNS).max(1);
    let mut lines = vec![
        "Each panel: one LED ROI's luma folded by the PWM phase at exposure start",
        "(0 to 1 cycle, left to right), min and max per phase bin, on its own scale.",
    ];
    if rois.iter().any(|r| r.analysis.envelope.is_some()) {
        lines.push("Red lines: the lowest and highest luma over every phase.");
    }
    let height = rows * PANEL_HEIGHT + FOOTER + LINE * (lines.len() as u32 - 2);
    let mut svg = String::new();
    {
        let e = |e: DrawingAreaErrorKind<std::io::Error>| err(&e);
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let (grid, footer) = root.split_vertically(rows * PANEL_HEIGHT);
        let panels = grid.split_evenly((rows as usize, COLUMNS as usize));
        for (area, roi) in panels.iter().zip(rois) {
            panel(area, roi).map_err(|m| err(&m))?;
        }
        let style = TextStyle::from((FONT, TEXT_PX).into_font()).color(&BLACK);
        for (k, line) in lines.into_iter().enumerate() {
            footer
                .draw(&Text::new(
                    line,
                    (4, 8 + (LINE * k as u32) as i32),
                    style.clone(),
                ))
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    Ok(svg)
}

/// One ROI's panel: name, Percent Flicker, luma range, and the fold.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    roi: &RoiInfo,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let bins = &roi.analysis.folded_bins;
    let envelope = roi.analysis.envelope;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(a, b) in bins.iter().flatten().chain(envelope.as_ref()) {
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let style = TextStyle::from((FONT, TEXT_PX).into_font()).color(&BLACK);
    let pf = match roi.metrics.get("percent_flicker").copied().flatten() {
        Some(v) => format!("PF {v:.1} %"),
        None => "PF n/a".to_string(),
    };
    let range = if lo.is_finite() && hi.is_finite() {
        // Whole DN from 100 up: the range then still fits its panel.
        let places = if hi.abs().max(lo.abs()) >= 100.0 {
            0
        } else {
            1
        };
        format!("{lo:.places$}\u{2013}{hi:.places$} DN")
    } else {
        "no samples".to_string()
    };
    for (k, line) in [roi.name.as_str(), &pf, &range].into_iter().enumerate() {
        area.draw(&Text::new(
            line.to_string(),
            (4, 2 + 14 * k as i32),
            style.clone(),
        ))
        .map_err(e)?;
    }
    let (w, h) = area.dim_in_pixel();
    let (left, top, right, bottom) = (4, 48, w as i32 - 6, h as i32 - 8);
    area.draw(&Rectangle::new(
        [(left, top), (right, bottom)],
        RGBColor(160, 160, 160).stroke_width(1),
    ))
    .map_err(e)?;
    if !(lo.is_finite() && hi.is_finite()) {
        return Ok(());
    }
    let pad = ((hi - lo) * 0.1).max(0.5);
    let (y0, y1) = (lo - pad, hi + pad);
    let y = |v: f64| bottom - ((v - y0) / (y1 - y0) * f64::from(bottom - top)).round() as i32;
    let n = bins.len().max(1) as f64;
    let x = |i: usize| left + (((i as f64 + 0.5) / n) * f64::from(right - left)).round() as i32;
    if let Some((a, b)) = envelope {
        for v in [a, b] {
            area.draw(&PathElement::new(
                [(left, y(v)), (right, y(v))],
                RGBColor(214, 39, 40).stroke_width(1),
            ))
            .map_err(e)?;
        }
    }
    let colour = SERIES_COLOURS[0];
    for (i, b) in bins.iter().enumerate() {
        let Some((a, c)) = *b else { continue };
        let (ya, yc) = (y(a), y(c));
        // A bin whose frames agree is a point: one pixel tall, still seen.
        let yc = if yc == ya { ya - 1 } else { yc };
        area.draw(&PathElement::new(
            [(x(i), ya), (x(i), yc)],
            colour.stroke_width(2),
        ))
        .map_err(e)?;
    }
    Ok(())
}
