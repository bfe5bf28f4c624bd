//! The luma trace of one case (whole capture) and its zoomed panels.
//!
//! Traces longer than the plot is wide are drawn as a min/max envelope per
//! pixel column ([`super::envelope`]); shorter ones point by point. Frames
//! left out (settle gaps) or dropped break the line. The legend sits right
//! of the plot, never over the data.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::envelope::{self, Chart, draw_decimated};
use super::{ChartError, FONT, SERIES_COLOURS, segment_fill, shade_detected};
use crate::model::CaseResult;
use crate::model::FrameInfo;
use crate::model::Segment;
use crate::model::SegmentsFound;

/// Width of the legend column right of the trace, pixels.
const LEGEND_WIDTH: u32 = 200;
/// Characters a legend line holds beside its swatch at
/// [`super::FONT_FULL_WIDTH`] (about 6.9 px a character).
const LEGEND_CHARS: usize = 24;
/// Height of a legend line, pixels.
const LEGEND_LINE: i32 = 15;

/// Frames shown before and after a step in a zoomed panel.
const STEP_BEFORE: usize = 10;
const STEP_AFTER: usize = 20;

/// Frames of the PWM panel when the apparent frequency is unknown or 0.
const PWM_DEFAULT_FRAMES: usize = 40;

/// Bounds on the frames of the PWM panel (two beat periods).
const PWM_MIN_FRAMES: usize = 12;
const PWM_MAX_FRAMES: usize = 240;

/// What a legend entry shows left of its text.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Swatch {
    /// A solid line.
    Line(RGBColor),
    /// A dashed line.
    Dashed(RGBColor),
    /// A filled box (a shaded span).
    Fill(RGBAColor),
    /// A dot (a marker).
    Dot(RGBColor),
    /// A line with a break (a gap in the trace).
    Gap(RGBColor),
    /// Text only.
    None,
}

/// Splits `text` into lines of at most about `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// Draws `entries` top down in `area` (a column beside the plot). Entries
/// that do not fit are left out, the last one drawn saying how many
/// (`more` names them, e.g. "ROIs").
pub(crate) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(Swatch, String)],
    top: i32,
    more: &str,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let style = TextStyle::from((FONT, super::FONT_FULL_WIDTH).into_font()).color(&BLACK);
    let height = area.dim_in_pixel().1 as i32;
    let lines = |label: &str| wrap(label, LEGEND_CHARS).len() as i32;
    let mut y = top;
    for (k, (swatch, label)) in entries.iter().enumerate() {
        let rest = entries.len() - k;
        let fits = |n: i32| y + LEGEND_LINE * n + 4 <= height;
        // Room for this entry, and for the count line after it if needed.
        let truncated = !fits(lines(label) + if rest > 1 { 2 } else { 0 });
        let count = format!("and {rest} more {more}");
        let (swatch, label) = if truncated {
            (&Swatch::None, &count)
        } else {
            (swatch, label)
        };
        let (x, cy) = (6, y + 6);
        match *swatch {
            Swatch::Line(c) => area
                .draw(&PathElement::new(
                    [(x, cy), (x + 18, cy)],
                    c.stroke_width(2),
                ))
                .map_err(e)?,
            Swatch::Dashed(c) => {
                for k in 0..3 {
                    let x0 = x + 7 * k;
                    area.draw(&PathElement::new(
                        [(x0, cy), (x0 + 4, cy)],
                        c.stroke_width(1),
                    ))
                    .map_err(e)?;
                }
            }
            Swatch::Fill(c) => area
                .draw(&Rectangle::new([(x, cy - 5), (x + 18, cy + 5)], c.filled()))
                .map_err(e)?,
            Swatch::Dot(c) => area
                .draw(&Circle::new((x + 9, cy), 3, c.filled()))
                .map_err(e)?,
            Swatch::Gap(c) => {
                for x0 in [x, x + 12] {
                    area.draw(&PathElement::new(
                        [(x0, cy), (x0 + 6, cy)],
                        c.stroke_width(2),
                    ))
                    .map_err(e)?;
                }
            }
            Swatch::None => {}
        }
        for line in wrap(label, LEGEND_CHARS) {
            area.draw(&Text::new(line, (x + 24, y), style.clone()))
                .map_err(e)?;
            y += LEGEND_LINE;
        }
        y += 4;
        if truncated {
            break;
        }
    }
    Ok(())
}

/// Lowest and highest finite value of the ROI traces and `extra`.
fn value_range<'a>(values: impl Iterator<Item = &'a f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// Shades each run of frames of one segment; returns the segments shaded.
fn shade_runs(
    chart: &mut Chart<'_, '_>,
    frames: &[FrameInfo],
    x: impl Fn(&FrameInfo) -> f64,
    x_end: f64,
    step: f64,
    (y0, y1): (f64, f64),
) -> Result<Vec<Segment>, String> {
    let mut shaded = Vec::new();
    let mut start = 0;
    for i in 1..=frames.len() {
        if i == frames.len() || frames[i].segment != frames[start].segment {
            let x0 = x(&frames[start]);
            // To the next run, or one frame after this run's last frame
            // when frames are missing between them.
            let x1 = if i == frames.len() {
                x_end
            } else {
                x(&frames[i]).min(x(&frames[i - 1]) + step)
            };
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x0, y0), (x1, y1)],
                    segment_fill(frames[start].segment).filled(),
                )))
                .map_err(|e| e.to_string())?;
            if !shaded.contains(&frames[start].segment) {
                shaded.push(frames[start].segment);
            }
            start = i;
        }
    }
    Ok(shaded)
}

fn segment_name(s: Segment) -> &'static str {
    match s {
        Segment::On => "ON",
        Segment::Off => "OFF",
        Segment::Pwm => "PWM",
    }
}

/// ROI luma against time for one case, like Figure 10 of Deegan 2018: the
/// segments shaded, the ON and OFF reference levels of the first ROI drawn
/// dashed, and the PWM-segment min and max of each ROI marked. With
/// detected segments (`segments`), the whole capture's detection signal is
/// drawn in grey and the settle gaps after each step are shaded red.
/// Traces with more frames than the plot has pixel columns are drawn as
/// the min/max envelope per column; excluded or dropped frames are gaps.
pub fn luma_trace_svg(
    result: &CaseResult,
    segments: Option<&SegmentsFound>,
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("trace {}", result.case.id),
        message: e.to_string(),
    };
    let acq = &result.acquisition;
    let frames = &acq.frames;
    let detected = segments.filter(|s| !s.signal.is_empty());
    let signal = detected.map_or(&[][..], |s| &s.signal[..]);
    let t_end = frames
        .last()
        .map(|f| f.time_s)
        .into_iter()
        .chain(signal.last().map(|p| p.0))
        .fold(1e-3, f64::max);
    let Some((lo, hi)) = value_range(
        acq.rois
            .iter()
            .flat_map(|r| &r.luma)
            .chain(signal.iter().map(|p| &p.1)),
    ) else {
        return Err(err(&"the trace is empty"));
    };
    let pad = ((hi - lo) * 0.08).max(1.0);
    let (y0, y1) = ((lo - pad).max(0.0), hi + pad);
    let runs = envelope::runs(frames);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 250)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (plot, side) = root.split_horizontally(760 - LEGEND_WIDTH);
        let mut chart = super::linear_axes(
            &plot,
            &super::Axes {
                margin: 10,
                caption: None,
                label_areas: (36, super::y_label_area(y0, y1, super::FONT_FULL_WIDTH)),
                x: 0.0..t_end,
                y: y0..y1,
                desc: ("time (s)", "ROI luma (DN)"),
                font: super::FONT_FULL_WIDTH,
            },
        )
        .map_err(|e| err(&e))?;
        let columns = chart.plotting_area().dim_in_pixel().0 as usize;
        let span = (0.0, t_end);
        let mut legend = draw_segments(&mut chart, frames, detected, t_end, columns, (y0, y1))
            .map_err(|e| err(&e))?;
        legend.extend(draw_levels(&mut chart, result, t_end).map_err(|e| err(&e))?);
        let mut roi_legend =
            draw_rois(&mut chart, acq, &runs, span, columns).map_err(|e| err(&e))?;
        legend.push((Swatch::Dot(RGBColor(90, 90, 90)), "PWM min and max".into()));
        if runs.len() > 1 {
            legend.push((
                Swatch::Gap(RGBColor(90, 90, 90)),
                "gap: frames left out or dropped".into(),
            ));
        }
        if frames.len() > columns {
            legend.push((
                Swatch::None,
                format!(
                    "{} frames in {columns} pixel columns: lines are the min and max per column",
                    frames.len()
                ),
            ));
        }
        // ROIs last: with many ROIs, the ones that do not fit are counted.
        legend.append(&mut roi_legend);
        draw_legend(&side, &legend, 12, "ROIs").map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// Legend entries of a trace chart.
type Legend = Vec<(Swatch, String)>;

/// Shades the segments (the detected ones with the whole capture's
/// detection signal, else the frames' own labels); their legend entries.
fn draw_segments(
    chart: &mut Chart<'_, '_>,
    frames: &[FrameInfo],
    detected: Option<&SegmentsFound>,
    t_end: f64,
    columns: usize,
    (y0, y1): (f64, f64),
) -> Result<Legend, String> {
    let mut legend = Legend::new();
    let span = (0.0, t_end);
    let signal = detected.map_or(&[][..], |s| &s.signal[..]);
    if let Some(found) = detected {
        let settle = shade_detected(chart, found, (y0, y1))?;
        for (seg, span) in [
            (Segment::On, found.on_time_s),
            (Segment::Off, found.off_time_s),
            (Segment::Pwm, Some(found.pwm_time_s)),
        ] {
            if span.is_some() {
                legend.push((
                    Swatch::Fill(segment_fill(seg)),
                    format!("{} segment", segment_name(seg)),
                ));
            }
        }
        if let Some(label) = settle {
            legend.push((Swatch::Fill(RGBColor(220, 60, 60).mix(0.3)), label));
        }
        let grey = RGBColor(150, 150, 150);
        draw_decimated(chart, signal, span, columns, grey, None)?;
        legend.push((
            Swatch::Line(grey),
            "LED-ROI mean, whole capture (detection)".into(),
        ));
    } else {
        let shaded = shade_runs(
            chart,
            frames,
            |f| f.time_s,
            t_end,
            frame_interval(frames).unwrap_or(t_end),
            (y0, y1),
        )?;
        for seg in shaded {
            legend.push((
                Swatch::Fill(segment_fill(seg)),
                format!("{} segment", segment_name(seg)),
            ));
        }
    }

    Ok(legend)
}

/// The ON and OFF levels of the first ROI, dashed; their legend entries.
fn draw_levels(
    chart: &mut Chart<'_, '_>,
    result: &CaseResult,
    t_end: f64,
) -> Result<Legend, String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let mut legend = Legend::new();
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
                .map_err(e)?;
            legend.push((Swatch::Dashed(colour), format!("{label} {level:.2} DN")));
        }
    }

    Ok(legend)
}

/// Each ROI's trace, run by run, with its PWM-segment extremes marked;
/// the ROI legend.
fn draw_rois(
    chart: &mut Chart<'_, '_>,
    acq: &crate::model::Acquisition,
    runs: &[std::ops::Range<usize>],
    span: (f64, f64),
    columns: usize,
) -> Result<Legend, String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let frames = &acq.frames;
    let mut roi_legend = Legend::new();
    for (i, roi) in acq.rois.iter().enumerate() {
        let colour = SERIES_COLOURS[i % SERIES_COLOURS.len()];
        for run in runs {
            let points: Vec<(f64, f64)> = frames[run.clone()]
                .iter()
                .zip(&roi.luma[run.clone()])
                .map(|(f, &v)| (f.time_s, v))
                .collect();
            draw_decimated(
                chart,
                &points,
                span,
                columns,
                colour,
                Some(colour.mix(0.35)),
            )?;
        }
        roi_legend.push((Swatch::Line(colour), roi.name.clone()));
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
                .map_err(e)?;
        }
    }
    Ok(roi_legend)
}

/// One zoomed panel: frames `window` of the acquisition, and its title.
struct Panel {
    title: String,
    window: std::ops::Range<usize>,
}

/// Median frame interval of `frames`, seconds.
fn frame_interval(frames: &[FrameInfo]) -> Option<f64> {
    let mut steps: Vec<f64> = frames
        .windows(2)
        .filter(|w| w[1].index == w[0].index + 1)
        .map(|w| w[1].time_s - w[0].time_s)
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    steps.sort_by(f64::total_cmp);
    steps.get(steps.len() / 2).copied()
}

/// Frames of the PWM panel: two periods of the apparent frequency
/// `apparent_hz` at the frame rate, within bounds; [`PWM_DEFAULT_FRAMES`]
/// when the apparent frequency is 0 (phase locked) or unknown. Returns the
/// count and a note for the title.
pub fn pwm_zoom_frames(apparent_hz: f64, fps: Option<f64>) -> (usize, String) {
    match fps {
        Some(fps) if apparent_hz.is_finite() && apparent_hz > 0.0 && fps > 0.0 => {
            let two = (2.0 * fps / apparent_hz).ceil();
            let n = (two.min(PWM_MAX_FRAMES as f64) as usize).max(PWM_MIN_FRAMES);
            let beats = n as f64 * apparent_hz / fps;
            let note = if two > PWM_MAX_FRAMES as f64 {
                format!("first {n} of the {two:.0} frames of two beats")
            } else {
                format!("{beats:.0} beats of {apparent_hz:.3} Hz")
            };
            (n, note)
        }
        _ => (
            PWM_DEFAULT_FRAMES,
            "no beat (phase locked), first frames".to_string(),
        ),
    }
}

/// The panels: the first two segment changes and the start of the PWM
/// segment.
fn panels(frames: &[FrameInfo], apparent_hz: f64) -> Vec<Panel> {
    let mut out = Vec::new();
    let changes = (1..frames.len()).filter(|&i| frames[i].segment != frames[i - 1].segment);
    for i in changes.take(2) {
        out.push(Panel {
            title: format!(
                "{} \u{2192} {} step",
                segment_name(frames[i - 1].segment),
                segment_name(frames[i].segment)
            ),
            window: i.saturating_sub(STEP_BEFORE)..(i + STEP_AFTER).min(frames.len()),
        });
    }
    if let Some(p0) = frames.iter().position(|f| f.segment == Segment::Pwm) {
        let fps = frame_interval(frames).map(|dt| 1.0 / dt);
        let (n, note) = pwm_zoom_frames(apparent_hz, fps);
        let p1 = frames[p0..]
            .iter()
            .position(|f| f.segment != Segment::Pwm)
            .map_or(frames.len(), |k| p0 + k);
        out.push(Panel {
            title: format!("PWM: {note}"),
            window: p0..(p0 + n).min(p1),
        });
    }
    out
}

/// Draws one panel: every ROI of frames `panel.window`, against frame
/// number, one marker per frame, segments shaded.
fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    result: &CaseResult,
    panel: &Panel,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let acq = &result.acquisition;
    let frames = &acq.frames[panel.window.clone()];
    let Some((lo, hi)) = value_range(acq.rois.iter().flat_map(|r| &r.luma[panel.window.clone()]))
    else {
        return Ok(());
    };
    let pad = ((hi - lo) * 0.1).max(0.5);
    let (y0, y1) = (lo - pad, hi + pad);
    let x0 = frames.first().map_or(0.0, |f| f.index as f64) - 0.5;
    let x1 = frames.last().map_or(1.0, |f| f.index as f64) + 0.5;
    let mut chart = ChartBuilder::on(area)
        .margin(6)
        .caption(&panel.title, (FONT, super::FONT_NARROW))
        .x_label_area_size(34)
        .y_label_area_size(super::y_label_area(y0, y1, super::FONT_NARROW))
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("frame")
        .y_desc("luma (DN)")
        .x_labels(5)
        .y_labels(5)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style((FONT, super::FONT_NARROW))
        .axis_desc_style((FONT, super::FONT_NARROW))
        .max_light_lines(0)
        .draw()
        .map_err(e)?;
    shade_runs(
        &mut chart,
        frames,
        |f| f.index as f64 - 0.5,
        x1,
        1.0,
        (y0, y1),
    )?;
    for (i, roi) in acq.rois.iter().enumerate() {
        let colour = SERIES_COLOURS[i % SERIES_COLOURS.len()];
        let luma = &roi.luma[panel.window.clone()];
        for run in envelope::runs(frames) {
            let points = frames[run.clone()]
                .iter()
                .zip(&luma[run])
                .map(|(f, &v)| (f.index as f64, v));
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(1)))
                .map_err(e)?;
            chart
                .draw_series(points.map(|p| Circle::new(p, 2, colour.filled())))
                .map_err(e)?;
        }
    }
    Ok(())
}

/// Zoomed panels of one case's trace, side by side in one SVG: the first
/// two segment steps (e.g. ON -> OFF, OFF -> PWM; 10 frames before and 20
/// after each) and two periods of the apparent (beat) frequency
/// `apparent_hz` at the start of the PWM segment (40 frames when it is 0,
/// i.e. phase locked; at most 240), every frame marked. Colours are those
/// of [`luma_trace_svg`]. `apparent_hz` is the case's
/// `apparent_frequency_hz` in the report model.
pub fn trace_zoom_svg(result: &CaseResult, apparent_hz: f64) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("trace zoom {}", result.case.id),
        message: e.to_string(),
    };
    let panels = panels(&result.acquisition.frames, apparent_hz);
    if panels.is_empty() {
        return Err(err(&"the trace has no segment step and no PWM frame"));
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 220)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let areas = root.split_evenly((1, panels.len()));
        for (area, panel) in areas.iter().zip(&panels) {
            draw_panel(area, result, panel).map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_core::backend::sim::Simulator;

    /// The first case of the shipped daylight plan (1,920 frames), run on
    /// the simulator.
    fn daylight_case() -> CaseResult {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("test-plans/daylight.toml");
        let plan = ledflicker_core::plan::load(&path).unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let case = cases
            .iter()
            .find(|c| c.id == "2000lux-100hz-10pct")
            .unwrap();
        ledflicker_core::runner::run_case(&plan, case, &Simulator::new(&plan)).unwrap()
    }

    /// Points of every `<polyline>` and `<polygon>` of an SVG.
    fn shapes(svg: &str) -> Vec<(&'static str, usize)> {
        let mut out = Vec::new();
        for tag in ["polyline", "polygon"] {
            for part in svg.split(&format!("<{tag} ")).skip(1) {
                let points = part.split("points=\"").nth(1).unwrap_or("");
                let points = &points[..points.find('"').unwrap_or(0)];
                out.push((tag, points.split_whitespace().count()));
            }
        }
        out
    }

    /// Points of a line through `v` that are not inside a run of equal
    /// values: what the chart must draw.
    fn corners(v: &[f64]) -> usize {
        let mut n = 0;
        for i in 0..v.len() {
            if i == 0 || i + 1 == v.len() || !(v[i - 1] == v[i] && v[i + 1] == v[i]) {
                n += 1;
            }
        }
        n
    }

    #[test]
    fn a_long_trace_has_no_line_longer_than_the_plot_is_wide() {
        let r = daylight_case();
        assert_eq!(r.acquisition.frames.len(), 1920);
        let svg = luma_trace_svg(&r, None).unwrap();
        // 760 px less the legend, margins and the y label area.
        let plot_width = (760 - LEGEND_WIDTH - 20 - 52) as usize;
        let shapes = shapes(&svg);
        assert!(shapes.iter().any(|s| s.0 == "polyline"));
        for (tag, n) in shapes {
            let limit = if tag == "polygon" {
                2 * plot_width
            } else {
                plot_width
            };
            assert!(n <= limit, "{tag} of {n} points, plot {plot_width} px wide");
        }
        assert!(
            svg.contains("1920 frames in"),
            "the legend says the trace is decimated"
        );
    }

    /// The daylight case cut to its first `frames` frames.
    fn daylight_case_of(frames: usize) -> CaseResult {
        let mut r = daylight_case();
        r.acquisition.frames.truncate(frames);
        for roi in &mut r.acquisition.rois {
            roi.luma.truncate(frames);
        }
        r
    }

    /// Point counts of the SVG's polylines.
    fn polyline_points(svg: &str) -> Vec<usize> {
        shapes(svg)
            .into_iter()
            .filter(|s| s.0 == "polyline")
            .map(|s| s.1)
            .collect()
    }

    #[test]
    fn a_short_trace_is_drawn_point_by_point() {
        // 300 frames: fewer than the plot's pixel columns.
        let r = daylight_case_of(300);
        let svg = luma_trace_svg(&r, None).unwrap();
        let lines = polyline_points(&svg);
        // The LED line has a point for every frame but the inside of runs
        // of equal luma (counted here by brute force); no envelope band.
        let led = &r.acquisition.rois[0].luma;
        assert_eq!(
            corners(led),
            184,
            "the daylight case has flat runs and PWM swings"
        );
        assert!(lines.contains(&corners(led)), "{lines:?}");
        assert!(!svg.contains("<polygon"));
    }

    #[test]
    fn a_dropped_frame_breaks_the_line() {
        let mut r = daylight_case_of(300);
        // Drop frame 200.
        r.acquisition.frames.remove(200);
        for roi in &mut r.acquisition.rois {
            roi.luma.remove(200);
        }
        let svg = luma_trace_svg(&r, None).unwrap();
        let lines = polyline_points(&svg);
        // Two LED lines, frames 0-199 and 201-299, none across the gap.
        let led = &r.acquisition.rois[0].luma;
        let (a, b) = (corners(&led[..200]), corners(&led[200..]));
        assert!(
            lines.contains(&a) && lines.contains(&b),
            "{a} {b} {lines:?}"
        );
        assert!(!lines.contains(&corners(led)), "{lines:?}");
        assert!(svg.contains("gap: frames left out"));
    }

    #[test]
    fn a_legend_of_many_rois_stays_inside_the_chart() {
        let mut r = daylight_case();
        let roi = r.acquisition.rois[1].clone();
        for k in 2..36 {
            let mut extra = roi.clone();
            extra.name = format!("roi{k}");
            r.acquisition.rois.push(extra);
        }
        let svg = luma_trace_svg(&r, None).unwrap();
        let shown = (0..36)
            .filter(|k| svg.contains(&format!(">\n{}\n</text>", r.acquisition.rois[*k].name)))
            .count();
        assert!(shown > 0 && shown < 36, "{shown} ROI names shown");
        assert!(
            svg.contains(&format!("and {} more ROIs", 36 - shown)),
            "the rest are counted"
        );
        // Legend lines (right of the plot) end inside the 250 px chart.
        for part in svg.split("<text").skip(1) {
            let attr = |name: &str| -> f64 {
                let v = part.split(&format!(" {name}=\"")).nth(1).unwrap();
                v.split('"').next().unwrap().parse().unwrap()
            };
            if attr("x") > f64::from(760 - LEGEND_WIDTH) {
                assert!(
                    attr("y") + 13.0 <= 250.0,
                    "a legend line at y {} runs off",
                    attr("y")
                );
            }
        }
    }

    #[test]
    fn zoom_panels_cover_the_steps_and_two_beats() {
        let r = daylight_case();
        let panels = panels(&r.acquisition.frames, 10.0);
        let titles: Vec<&str> = panels.iter().map(|p| p.title.as_str()).collect();
        assert_eq!(titles.len(), 3, "{titles:?}");
        assert!(titles[0].starts_with("ON \u{2192} OFF"), "{titles:?}");
        assert!(titles[1].starts_with("OFF \u{2192} PWM"), "{titles:?}");
        // 30 fps, 10 Hz apparent: two beats are 6 frames, shown as 12.
        assert_eq!(panels[2].window.len(), PWM_MIN_FRAMES);
        assert!(r.acquisition.frames[panels[2].window.start].segment == Segment::Pwm);
        assert!(
            trace_zoom_svg(&r, 10.0)
                .unwrap()
                .contains("OFF \u{2192} PWM step")
        );
    }

    #[test]
    fn pwm_panel_length_follows_the_beat() {
        assert_eq!(pwm_zoom_frames(0.0, Some(30.0)).0, PWM_DEFAULT_FRAMES);
        assert_eq!(pwm_zoom_frames(1.0, None).0, PWM_DEFAULT_FRAMES);
        assert_eq!(pwm_zoom_frames(1.0, Some(30.0)).0, 60);
        assert_eq!(pwm_zoom_frames(0.01, Some(30.0)).0, PWM_MAX_FRAMES);
        assert_eq!(pwm_zoom_frames(14.0, Some(30.0)).0, PWM_MIN_FRAMES);
    }
}
