//! Charts as SVG strings (plotters), one function per chart.
//!
//! Text is set in "DejaVu Sans", named explicitly: a generic "sans-serif"
//! falls back to a serif face in the PDF engine (DEPENDENCIES.md).

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::model::Segment;
use crate::model::{SegmentsFound, StepKind};

pub mod envelope;
mod fold_grid;
mod kpi_change;
mod roi_map;
mod trace;
mod trace_overlay;
mod trend;
mod uv;
mod worst_phase;

pub use fold_grid::{FOLD_GRID_FROM, fold_grid_svg};
pub use kpi_change::kpi_change_svg;
pub use roi_map::{ROI_MAP_WIDTH, roi_map_svg};
pub use trace::{luma_trace_svg, pwm_zoom_frames, trace_zoom_svg};
pub use trace_overlay::trace_overlay_svg;
pub use trend::{TrendSeries, trend_svg};
pub use uv::{UV_CHART_SIZE, uv_diagram_svg};
pub use worst_phase::worst_phase_svg;

/// Font family named in every chart.
pub const FONT: &str = "DejaVu Sans";

/// Width of the PDF's text column, points: A4 (595.3 pt) less the
/// template's margins of 1.8 cm each side.
pub const PDF_TEXT_WIDTH_PT: f64 = 493.2;
/// The smallest text of the printed report, points: below it a printed
/// value is hard to read.
pub const MIN_TEXT_PT: f64 = 7.0;
/// plotters writes a font of size `s` into the SVG as `font-size` of
/// `s / 1.24` pixels.
pub const PLOTTERS_FONT_SCALE: f64 = 1.24;
/// Font size (plotters' units) of a 760 px chart printed at the full text
/// width: 14 / 1.24 px x 493.2 / 760 = 7.3 pt.
pub const FONT_FULL_WIDTH: u32 = 14;
/// Font size of a 760 px chart printed at 90 to 94 % of the text width
/// (the zoom panels, the exposure advice): 7.1 pt and more.
pub const FONT_NARROW: u32 = 15;

/// Width of the y label area (pixels) that holds the widest tick label of
/// an axis from `lo` to `hi` at `font` beside the rotated axis title, so a
/// 12-bit trace's "4000" never runs into its title.
pub fn y_label_area(lo: f64, hi: f64, font: u32) -> u32 {
    let px = f64::from(font) / PLOTTERS_FONT_SCALE;
    let digits = |v: f64| crate::util::fixed(v.abs().max(1.0), 0).len();
    // plotters gives short ranges one or two decimals.
    let decimals = if hi - lo < 100.0 { 3 } else { 0 };
    let sign = usize::from(lo < 0.0);
    let chars = digits(lo).max(digits(hi)) + decimals + sign;
    // 0.64 em a character, a little over DejaVu Sans' digit advance.
    let tick = chars as f64 * 0.64 * px;
    (tick + 1.6 * px + 14.0).ceil() as u32
}

const SERIES_COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// A chart could not be drawn.
#[derive(Debug, Clone, thiserror::Error)]
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

/// Shades the detected segments over their spans and, in red, the settle
/// gaps between each step and the segment after it; returns the settle
/// gaps' legend text when there are any.
fn shade_detected<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    found: &SegmentsFound,
    (y0, y1): (f64, f64),
) -> Result<Option<String>, String> {
    let t0 = found.signal.first().map_or(0.0, |p| p.0);
    let spans = [
        (Segment::On, found.on_time_s),
        (Segment::Off, found.off_time_s),
        (Segment::Pwm, Some(found.pwm_time_s)),
    ];
    for (seg, span) in spans {
        let Some((a, b)) = span else { continue };
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(t0 + a, y0), (t0 + b, y1)],
                segment_fill(seg).filled(),
            )))
            .map_err(|e| e.to_string())?;
    }
    // Settle gap: from each step to the start of the segment it begins.
    let gaps: Vec<(f64, f64)> = found
        .steps
        .iter()
        .filter_map(|step| {
            let span = match step.kind {
                StepKind::On => found.on_time_s,
                StepKind::Off => found.off_time_s,
                StepKind::Pwm => Some(found.pwm_time_s),
                StepKind::End => None,
            };
            Some((step.time_s, span?.0))
        })
        .filter(|(a, b)| b > a)
        .collect();
    let hatch = RGBColor(220, 60, 60);
    for &(a, b) in &gaps {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(t0 + a, y0), (t0 + b, y1)],
                hatch.mix(0.18).filled(),
            )))
            .map_err(|e| e.to_string())?;
    }
    Ok((!gaps.is_empty()).then(|| {
        format!(
            "settle {} s after each step (left out)",
            found.settle_s.unwrap_or(0.0)
        )
    }))
}

/// Fewest phase bins a fold must fill to be drawn; with fewer, every
/// frame saw one or a few PWM phases (the PWM is phase locked to the
/// frame rate) and the fold shows no waveform.
pub const MIN_FOLD_PHASES: usize = 4;

/// The sentence printed instead of the phase fold of ROI `roi` whose PWM
/// frames fell in `covered` of its `bins` phase bins, or [`None`] when the
/// fold is worth drawing (at least [`MIN_FOLD_PHASES`] bins hold a frame).
/// Works from results.json (`phase_coverage`), so a report rendered again
/// from its directory says the same.
/// `frequency_known` is false for a capture of unknown PWM frequency, whose
/// frames carry no phase.
pub fn degenerate_fold_sentence(
    roi: &str,
    covered: usize,
    bins: usize,
    frequency_known: bool,
) -> Option<String> {
    let why = match covered {
        c if c >= MIN_FOLD_PHASES => return None,
        _ if !frequency_known => {
            "the capture's PWM frequency is unknown, so its frames have no PWM phase".to_string()
        }
        0 => "no PWM frame fell in any phase bin".to_string(),
        1 => format!(
            "every PWM frame saw the same PWM phase (1 of {bins} phase bins): the frame rate locks to the PWM, so a fold would show one point"
        ),
        n => format!(
            "the PWM frames saw only {n} of {bins} PWM phases: the frame rate nearly locks to the PWM, so a fold shows no waveform"
        ),
    };
    Some(format!("Phase fold of {roi} not drawn: {why}."))
}

/// The flicker signal of one ROI: its trace folded by PWM phase (per-bin
/// min and max of the frames that fell in each bin), with the exact envelope
/// over phase dashed when the backend knows it (Sumner, EI 2020).
pub fn phase_fold_svg(
    title: &str,
    bins: &[Option<(f64, f64)>],
    envelope: Option<(f64, f64)>,
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("phase fold {title}"),
        message: e.to_string(),
    };
    let n = bins.len().max(1) as f64;
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &(a, b) in bins.iter().flatten().chain(envelope.as_ref()) {
        lo = lo.min(a);
        hi = hi.max(b);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(err(&"no samples"));
    }
    let pad = ((hi - lo) * 0.1).max(0.5);
    let (y0, y1) = (lo - pad, hi + pad);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (380, 220)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = linear_axes(
            &root,
            &Axes {
                margin: 8,
                caption: Some((title, 12)),
                label_areas: (30, 46),
                x: 0.0..1.0,
                y: y0..y1,
                desc: ("PWM phase at exposure start (cycles)", "luma (DN)"),
                font: 10,
            },
        )
        .map_err(|e| err(&e))?;
        if let Some((a, b)) = envelope {
            for v in [a, b] {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(0.0, v), (1.0, v)],
                        5,
                        4,
                        RGBColor(214, 39, 40).stroke_width(1),
                    ))
                    .map_err(|e| err(&e))?;
            }
        }
        let colour = SERIES_COLOURS[0];
        for (i, b) in bins.iter().enumerate() {
            let Some((a, c)) = *b else { continue };
            let x = (i as f64 + 0.5) / n;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    [(x, a), (x, c)],
                    colour.stroke_width(2),
                )))
                .map_err(|e| err(&e))?;
            chart
                .draw_series([
                    Circle::new((x, a), 2, colour.filled()),
                    Circle::new((x, c), 2, colour.filled()),
                ])
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// Which fine map to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FineMapKind {
    /// Worst-phase FDI (2018), green at or above the threshold.
    Fdi,
    /// Worst-phase Percent Flicker, 0 (white) to 100 % (dark red).
    PercentFlicker,
}

/// A run of one colour along the frequency axis: from, to, colour.
type Run = (f64, f64, RGBColor);

/// Merges runs of rows `(y0, y1, runs)` (bottom up) that repeat, with the
/// same span and colour, in the rows above into one rectangle
/// `(x0, x1, colour, y0, y1)`: the same picture from fewer rectangles.
fn merge_rows(rows: &[(f64, f64, Vec<Run>)]) -> Vec<(f64, f64, RGBColor, f64, f64)> {
    let mut done = Vec::new();
    let mut open: Vec<(f64, f64, RGBColor, f64, f64)> = Vec::new();
    for (y0, y1, runs) in rows {
        let mut next = Vec::with_capacity(runs.len());
        for &(a, b, c) in runs {
            match open.iter().position(|o| (o.0, o.1, o.2) == (a, b, c)) {
                Some(k) => {
                    let mut o = open.swap_remove(k);
                    o.4 = *y1;
                    next.push(o);
                }
                None => next.push((a, b, c, *y0, *y1)),
            }
        }
        done.append(&mut open);
        open = next;
    }
    done.append(&mut open);
    done
}

/// Heatmap of a fine map over frequency x duty. Cells are merged into
/// display blocks (at most about 400 x 100) keeping the block's worst value
/// (lowest FDI, highest Percent Flicker), so the picture never hides a bad
/// cell; colours come in steps (FDI: 8 per side of the threshold; Percent
/// Flicker: 20 steps of its square root).
pub fn finemap_svg(
    map: &crate::model::FineMap,
    kind: FineMapKind,
    fdi_threshold: Option<f64>,
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: "fine map".to_string(),
        message: e.to_string(),
    };
    let (nf, nd) = (map.frequency.count, map.duty.count);
    if nf == 0 || nd == 0 {
        return Err(err(&"empty map"));
    }
    let bf = nf.div_ceil(400);
    let bd = nd.div_ceil(100);
    let values = match kind {
        FineMapKind::Fdi => &map.fdi_worst,
        FineMapKind::PercentFlicker => &map.pf_worst,
    };
    let colour = |v: Option<f64>| finemap_colour(kind, fdi_threshold, v);
    let f_lo = map.frequency.start - map.frequency.step / 2.0;
    let f_hi = map.frequency.end() + map.frequency.step / 2.0;
    let d_lo = 100.0 * (map.duty.start - map.duty.step / 2.0);
    let d_hi = 100.0 * (map.duty.end() + map.duty.step / 2.0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 300)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (plot, bar) = root.split_horizontally(760 - FINEMAP_SCALE_WIDTH);
        let caption = match kind {
            FineMapKind::Fdi => crate::model::human_name("fdi_2018_worst_phase"),
            FineMapKind::PercentFlicker => crate::model::human_name("percent_flicker_worst_phase"),
        };
        // Right and top margins hold half a tick label, so the labels at
        // the ends of the axes are never cut off.
        let mut chart = ChartBuilder::on(&plot)
            .margin(10)
            .margin_right(24)
            .margin_top(14)
            .margin_bottom(16)
            .caption(caption, (FONT, FONT_FULL_WIDTH + 2))
            .x_label_area_size(38)
            .y_label_area_size(y_label_area(0.0, 100.0, FONT_FULL_WIDTH))
            .build_cartesian_2d(f_lo..f_hi, d_lo..d_hi)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("PWM frequency (Hz)")
            .y_desc("duty (%)")
            .x_label_formatter(&|x| crate::util::fixed(*x, 0))
            .y_label_formatter(&|y| crate::util::fixed(*y, 0))
            .label_style((FONT, FONT_FULL_WIDTH))
            .axis_desc_style((FONT, FONT_FULL_WIDTH))
            .disable_mesh()
            .draw()
            .map_err(|e| err(&e))?;
        let top = chart.plotting_area().get_pixel_range().1;
        draw_finemap_scale(&bar, kind, fdi_threshold, top.start, top.end).map_err(|e| err(&e))?;
        // Blocks of one colour that touch along the frequency axis are
        // merged into one rectangle: same picture, a fraction of the SVG.
        let rows = finemap_rows(map, values, kind, (bf, bd), colour);
        let rects = merge_rows(&rows)
            .into_iter()
            .map(|(a, b, c, y0, y1)| Rectangle::new([(a, y0), (b, y1)], c.filled()));
        chart.draw_series(rects).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// Width of a fine map's colour scale, right of the map, pixels.
const FINEMAP_SCALE_WIDTH: u32 = 110;

/// A fine map's colour scale, from `y0` to `y1` (pixels, top down): the
/// colours of [`finemap_colour`] against the value, ticked, with the grey
/// of an undefined cell below. FDI: the lower half runs from 0 to the
/// threshold (red), the upper half from it to 11 times it (green), linear
/// in each; Percent Flicker: 0 to 100 % on the square-root scale the map
/// uses.
fn draw_finemap_scale(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    kind: FineMapKind,
    fdi_threshold: Option<f64>,
    y0: i32,
    y1: i32,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let t = fdi_threshold.unwrap_or(0.1);
    // Value at position p of the bar, 0 at the bottom, 1 at the top.
    let value = |p: f64| match kind {
        FineMapKind::Fdi if p <= 0.5 => 2.0 * p * t,
        FineMapKind::Fdi => t + (2.0 * p - 1.0) * 10.0 * t,
        FineMapKind::PercentFlicker => 100.0 * p * p,
    };
    let (x0, x1) = (6, 22);
    let grey = 18;
    let (top, bottom) = (y0, y1 - grey - 6);
    let h = f64::from(bottom - top);
    let steps = 40;
    for k in 0..steps {
        let a = top + (h * k as f64 / steps as f64).round() as i32;
        let b = top + (h * (k + 1) as f64 / steps as f64).round() as i32;
        let p = 1.0 - (k as f64 + 0.5) / steps as f64;
        let c = finemap_colour(kind, fdi_threshold, Some(value(p)));
        area.draw(&Rectangle::new([(x0, a), (x1, b)], c.filled()))
            .map_err(e)?;
    }
    area.draw(&Rectangle::new(
        [(x0, top), (x1, bottom)],
        BLACK.stroke_width(1),
    ))
    .map_err(e)?;
    let style = TextStyle::from((FONT, FONT_FULL_WIDTH).into_font())
        .color(&BLACK)
        .pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Left,
            plotters::style::text_anchor::VPos::Center,
        ));
    // Positions on the bar; Percent Flicker's are 0, 25, 50 and 100 %.
    let ticks: &[f64] = match kind {
        FineMapKind::Fdi => &[0.0, 0.25, 0.5, 0.75, 1.0],
        FineMapKind::PercentFlicker => &[0.0, 0.5, std::f64::consts::FRAC_1_SQRT_2, 1.0],
    };
    for &p in ticks {
        let y = bottom - (h * p).round() as i32;
        let v = value(p);
        let text = match kind {
            FineMapKind::Fdi if p == 0.5 => format!("{} limit", crate::util::fixed(v, 2)),
            FineMapKind::Fdi if p == 1.0 => format!("\u{2265} {}", crate::util::fixed(v, 2)),
            FineMapKind::Fdi => crate::util::fixed(v, 2),
            FineMapKind::PercentFlicker => format!("{} %", crate::util::fixed(v, 0)),
        };
        area.draw(&PathElement::new(
            [(x1, y), (x1 + 4, y)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?;
        area.draw(&Text::new(text, (x1 + 6, y), style.clone()))
            .map_err(e)?;
    }
    let gy = y1 - grey;
    area.draw(&Rectangle::new(
        [(x0, gy), (x1, y1)],
        finemap_colour(kind, fdi_threshold, None).filled(),
    ))
    .map_err(e)?;
    area.draw(&Text::new("undefined", (x1 + 6, gy + grey / 2), style))
        .map_err(e)?;
    Ok(())
}

/// Colour of a fine-map cell of value `v` (grey when undefined).
fn finemap_colour(kind: FineMapKind, fdi_threshold: Option<f64>, v: Option<f64>) -> RGBColor {
    match (kind, v) {
        (_, None) => RGBColor(160, 160, 160),
        (FineMapKind::Fdi, Some(v)) => {
            let t = fdi_threshold.unwrap_or(0.1);
            if v < t - crate::model::VERDICT_TOLERANCE {
                // Red, darker the closer the light comes to vanishing.
                let x = ((v / t).clamp(0.0, 1.0) * 8.0).round() / 8.0;
                RGBColor(
                    150 + (90.0 * x) as u8,
                    (40.0 + 120.0 * x) as u8,
                    (40.0 + 120.0 * x) as u8,
                )
            } else {
                let x = (((v - t) / (10.0 * t)).clamp(0.0, 1.0) * 8.0).round() / 8.0;
                RGBColor(
                    (200.0 - 170.0 * x) as u8,
                    (235.0 - 95.0 * x) as u8,
                    (200.0 - 150.0 * x) as u8,
                )
            }
        }
        (FineMapKind::PercentFlicker, Some(v)) => {
            // 20 steps of sqrt(PF / 100), so that small modulation still
            // shows; equal colours merge into one rectangle.
            let x = ((v / 100.0).clamp(0.0, 1.0).sqrt() * 20.0).round() / 20.0;
            RGBColor(
                255 - (90.0 * x) as u8,
                255 - (235.0 * x) as u8,
                255 - (225.0 * x) as u8,
            )
        }
    }
}

/// The map's display blocks (`bf` x `bd` cells each, keeping the worst
/// value), row by row; touching blocks of one colour along the frequency
/// axis merged into one run.
fn finemap_rows(
    map: &crate::model::FineMap,
    values: &[Option<f64>],
    kind: FineMapKind,
    (bf, bd): (usize, usize),
    colour: impl Fn(Option<f64>) -> RGBColor,
) -> Vec<(f64, f64, Vec<Run>)> {
    let (nf, nd) = (map.frequency.count, map.duty.count);
    let mut rows: Vec<(f64, f64, Vec<Run>)> = Vec::new();
    for j0 in (0..nd).step_by(bd) {
        let j1 = (j0 + bd).min(nd);
        let y0 = 100.0 * (map.duty.at(j0) - map.duty.step / 2.0);
        let y1 = 100.0 * (map.duty.at(j1 - 1) + map.duty.step / 2.0);
        let mut runs = Vec::new();
        let mut run: Option<(f64, f64, RGBColor)> = None;
        for i0 in (0..nf).step_by(bf) {
            let i1 = (i0 + bf).min(nf);
            let mut worst: Option<Option<f64>> = None;
            for i in i0..i1 {
                for j in j0..j1 {
                    let v = values[i * nd + j];
                    worst = Some(match (worst, v) {
                        (None, v) => v,
                        (Some(None), _) | (_, None) => None,
                        (Some(Some(w)), Some(v)) => Some(match kind {
                            FineMapKind::Fdi => w.min(v),
                            FineMapKind::PercentFlicker => w.max(v),
                        }),
                    });
                }
            }
            let x0 = map.frequency.at(i0) - map.frequency.step / 2.0;
            let x1 = map.frequency.at(i1 - 1) + map.frequency.step / 2.0;
            let c = colour(worst.flatten());
            run = match run {
                Some((a, _, rc)) if rc == c => Some((a, x1, rc)),
                Some(done) => {
                    runs.push(done);
                    Some((x0, x1, c))
                }
                None => Some((x0, x1, c)),
            };
        }
        runs.extend(run);
        rows.push((y0, y1, runs));
    }
    rows
}

/// `ledflicker advise`: worst residual Percent Flicker and the share of the
/// range where the LED can vanish, against exposure, with the bound `T*`.
pub fn advise_svg(curve: &[crate::model::Candidate], bound_s: f64) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: "advise".to_string(),
        message: e.to_string(),
    };
    let x_max = curve
        .iter()
        .map(|c| c.exposure_s * 1e3)
        .fold(bound_s * 1e3, f64::max)
        * 1.02;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 280)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(10)
            .x_label_area_size(38)
            .y_label_area_size(y_label_area(0.0, 105.0, FONT_NARROW))
            .build_cartesian_2d(0.0..x_max, 0.0..105.0)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("exposure (ms)")
            .y_desc("percent (%)")
            .label_style((FONT, FONT_NARROW))
            .axis_desc_style((FONT, FONT_NARROW))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| err(&e))?;
        let pf = SERIES_COLOURS[1];
        let lost = SERIES_COLOURS[0];
        chart
            .draw_series(LineSeries::new(
                curve
                    .iter()
                    .map(|c| (c.exposure_s * 1e3, c.residual_percent_flicker)),
                pf.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("worst residual Percent Flicker")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], pf));
        chart
            .draw_series(LineSeries::new(
                curve
                    .iter()
                    .map(|c| (c.exposure_s * 1e3, 100.0 * c.loses_led_fraction)),
                lost.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("share of the range where the LED can vanish")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], lost));
        let t = bound_s * 1e3;
        chart
            .draw_series(DashedLineSeries::new(
                [(t, 0.0), (t, 105.0)],
                5,
                4,
                BLACK.stroke_width(1),
            ))
            .map_err(|e| err(&e))?
            .label(format!("T* = {t:.3} ms"))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, FONT_NARROW))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// The frame of a chart with linear axes and no light grid lines.
pub(crate) struct Axes<'a> {
    /// Margin around the chart, pixels.
    pub margin: u32,
    /// Title and its font size.
    pub caption: Option<(&'a str, u32)>,
    /// Heights of the x and y label areas, pixels.
    pub label_areas: (u32, u32),
    /// Range of the x axis.
    pub x: std::ops::Range<f64>,
    /// Range of the y axis.
    pub y: std::ops::Range<f64>,
    /// Descriptions of the x and y axes.
    pub desc: (&'a str, &'a str),
    /// Font size of the labels and descriptions.
    pub font: u32,
}

/// Builds the chart `axes` describes on `area` and draws its axes.
pub(crate) fn linear_axes<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    axes: &Axes<'_>,
) -> Result<envelope::Chart<'a, 'b>, String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let mut builder = ChartBuilder::on(area);
    builder.margin(axes.margin);
    if let Some((title, size)) = axes.caption {
        builder.caption(title, (FONT, size));
    }
    let mut chart = builder
        .x_label_area_size(axes.label_areas.0)
        .y_label_area_size(axes.label_areas.1)
        .build_cartesian_2d(axes.x.clone(), axes.y.clone())
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(axes.desc.0)
        .y_desc(axes.desc.1)
        .label_style((FONT, axes.font))
        .axis_desc_style((FONT, axes.font))
        .max_light_lines(0)
        .draw()
        .map_err(e)?;
    Ok(chart)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_y_label_area_holds_the_widest_tick_beside_the_axis_title() {
        let px = f64::from(FONT_FULL_WIDTH) / PLOTTERS_FONT_SCALE;
        // A 12-bit trace: ticks up to "4000", then the rotated title (one
        // line, `px` wide) and the gaps plotters leaves.
        let area = f64::from(y_label_area(0.0, 4095.0, FONT_FULL_WIDTH));
        assert!(
            area >= crate::matrix::text_width("4000", px) + px + 10.0,
            "{area}"
        );
        // More digits, or decimals for a short range, take more room.
        let of = |lo, hi| y_label_area(lo, hi, FONT_FULL_WIDTH);
        assert!(of(0.0, 65535.0) > of(0.0, 4095.0));
        assert!(of(24.0, 66.0) > of(0.0, 255.0));
        assert!(of(-20.0, 4095.0) > of(0.0, 4095.0));
    }

    #[test]
    fn a_fold_with_few_phases_is_a_sentence() {
        let say = |covered| degenerate_fold_sentence("led", covered, 32, true);
        assert!(
            degenerate_fold_sentence("led", 1, 32, false)
                .unwrap()
                .contains("PWM frequency is unknown")
        );
        assert_eq!(degenerate_fold_sentence("led", 40, 64, false), None);
        assert!(say(0).unwrap().contains("no PWM frame"));
        assert!(say(1).unwrap().contains("same PWM phase (1 of 32"));
        assert!(say(3).unwrap().contains("only 3 of 32"));
        assert!(say(3).unwrap().starts_with("Phase fold of led not drawn"));
        assert_eq!(say(MIN_FOLD_PHASES), None);
        assert_eq!(say(32), None);
    }

    #[test]
    fn merged_rows_paint_the_same_picture() {
        let (r, g) = (RGBColor(255, 0, 0), RGBColor(0, 255, 0));
        let rows = vec![
            (0.0, 1.0, vec![(0.0, 2.0, r), (2.0, 3.0, g)]),
            (1.0, 2.0, vec![(0.0, 2.0, r), (2.0, 3.0, r)]),
            (2.0, 3.0, vec![(0.0, 2.0, r), (2.0, 3.0, g)]),
        ];
        let merged = merge_rows(&rows);
        assert_eq!(merged.len(), 4, "{merged:?}");
        // Brute force: the colour at every cell centre, and no overlap.
        for (y0, y1, runs) in &rows {
            for &(a, b, c) in runs {
                let (x, y) = ((a + b) / 2.0, (y0 + y1) / 2.0);
                let hits: Vec<RGBColor> = merged
                    .iter()
                    .filter(|m| m.0 < x && x < m.1 && m.3 < y && y < m.4)
                    .map(|m| m.2)
                    .collect();
                assert_eq!(hits, vec![c], "at ({x}, {y})");
            }
        }
    }

    #[test]
    fn fine_map_tick_labels_stay_on_the_canvas() {
        let model = crate::matrix::tests::model_with(8);
        let map = &model
            .fine_maps
            .first()
            .expect("the daylight plan has a fine map")
            .map;
        for kind in [FineMapKind::Fdi, FineMapKind::PercentFlicker] {
            let svg = finemap_svg(map, kind, Some(0.1)).unwrap();
            let mut n = 0;
            for part in svg.split("<text").skip(1) {
                let (tag, rest) = part.split_once('>').unwrap();
                let attr = |name: &str| -> String {
                    tag.split(&format!(" {name}=\""))
                        .nth(1)
                        .and_then(|s| s.split('"').next())
                        .unwrap_or("")
                        .to_string()
                };
                let text = rest.split("</text>").next().unwrap().trim();
                let x: f64 = attr("x").parse().unwrap();
                let y: f64 = attr("y").parse().unwrap();
                let size: f64 = attr("font-size").parse().unwrap();
                let w = crate::matrix::text_width(text, size);
                let (left, right) = match attr("text-anchor").as_str() {
                    "middle" => (x - w / 2.0, x + w / 2.0),
                    "end" => (x - w, x),
                    _ => (x, x + w),
                };
                if attr("transform").is_empty() {
                    assert!(
                        left >= 0.0 && right <= 760.0,
                        "`{text}` at x {x} runs off the canvas"
                    );
                }
                assert!(
                    y - size >= 0.0 && y + size <= 300.0,
                    "`{text}` at y {y} runs off the canvas"
                );
                n += 1;
            }
            assert!(n > 10, "{n} texts");
        }
    }
}
