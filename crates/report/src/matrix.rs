//! The frequency x duty matrix of one light level, as SVG (plotters).
//!
//! Part of the report stage, next to [`super::charts`]. It draws the
//! model's plane of a light level ([`crate::model::plane`]): each cell is one
//! case, coloured by the metric its verdict uses (worst over phase or as
//! captured, per the plan), with the verdict marked. Deegan 2018 Eq. (1),
//! `T_exp = (1 - D) / f`, as the model gives it for the camera's exposure,
//! is drawn over it: below the line an exposure can fall entirely in the
//! OFF part of a period, so the light can appear OFF.

mod merge;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::charts::{ChartError, FONT};
use crate::model::Results;
use crate::model::Verdict;
use crate::model::VerdictBasis;
use crate::model::plane::{Eq1, LevelPlane, PlaneCell};
use merge::merged_cells;

/// Which metric a matrix shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shown {
    /// FDI (2018): higher is better, `threshold` is a minimum.
    Fdi,
    /// Percent Flicker: lower is better, `threshold` is a maximum.
    PercentFlicker,
    /// Visibility on the monitor: lower is better, `threshold` is a
    /// maximum; the scale ends at ten times it.
    Visibility,
}

/// The metric, its results.json name, title and threshold.
fn shown(model: &Results) -> (Shown, String, &'static str, Option<f64>) {
    let worst = model.thresholds.basis == VerdictBasis::WorstPhase;
    let suffix = if worst { "_worst_phase" } else { "" };
    // FDI compares with the OFF segment: a run without one is judged on
    // Percent Flicker only, whatever FDI's limit.
    let off = model
        .conditions
        .sequence
        .iter()
        .any(|s| s.segment == crate::model::Segment::Off);
    let fdi = model.thresholds.fdi_2018_min.is_some() && off;
    if !fdi && model.thresholds.percent_flicker_max.is_some() {
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
        Shown::PercentFlicker | Shown::Visibility => {
            let top = worst_of(kind, threshold);
            if value <= threshold {
                0.5 + 0.5 * (1.0 - value / threshold.max(1e-9)).clamp(0.0, 1.0)
            } else {
                0.5 * (1.0 - (value - threshold) / (top - threshold).max(1e-9)).clamp(0.0, 1.0)
            }
        }
    }
}

/// The worst end of a maximum's scale: 100 % for Percent Flicker, ten
/// times the limit for the visibility index (unbounded above).
fn worst_of(kind: Shown, threshold: f64) -> f64 {
    match kind {
        Shown::Visibility => 10.0 * threshold,
        _ => 100.0,
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

/// Canvas width of a matrix, pixels.
const WIDTH: i32 = 760;
/// Left of the cells (room for the duty labels and title), pixels.
const LEFT: i32 = 64;
/// Right of the cells; the colour bar is right of it, pixels.
const RIGHT: i32 = WIDTH - 140;
/// Top of the cells (below the title), pixels.
const TOP: i32 = 38;
/// Below the cells: frequency labels, axis title, Eq. (1) legend (two
/// lines), pixels.
const BOTTOM: i32 = 100;
/// Cells narrower than this, pixels, are drawn without borders.
const DENSE_CELL_PX: f64 = 5.0;
/// Space kept between neighbouring axis labels, pixels.
const LABEL_GAP: f64 = 6.0;
/// Font size of every text of a matrix but its title (plotters' units: 7.3
/// pt printed at the full text width, [`super::charts::FONT_FULL_WIDTH`]).
const LABEL_SIZE: f64 = super::charts::FONT_FULL_WIDTH as f64;

/// Estimated width of `text` set at `size` px in DejaVu Sans: 0.64 em per
/// character, a little over its digit advance (0.636 em), so estimates err
/// wide.
pub fn text_width(text: &str, size: f64) -> f64 {
    text.chars().count() as f64 * 0.64 * size
}

/// An axis label at the centre of its cell.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLabel {
    /// Cell index.
    pub index: usize,
    /// Text.
    pub text: String,
    /// Centre along the axis, pixels from the axis start.
    pub centre: f64,
    /// Half the label's extent along the axis, pixels.
    pub half: f64,
}

/// Labels for cells `cell` px wide, one every `k`-th cell, `k` the smallest
/// step that keeps [`LABEL_GAP`] px between neighbours; `extent` is a
/// label's size along the axis. The first cell is always labelled.
pub fn thin_labels(texts: &[String], cell: f64, extent: impl Fn(&str) -> f64) -> Vec<AxisLabel> {
    let widest = texts.iter().map(|t| extent(t)).fold(0.0, f64::max);
    let step = ((widest + LABEL_GAP) / cell.max(1e-9)).ceil().max(1.0) as usize;
    texts
        .iter()
        .enumerate()
        .step_by(step)
        .map(|(i, t)| AxisLabel {
            index: i,
            text: t.clone(),
            centre: (i as f64 + 0.5) * cell,
            half: extent(t) / 2.0,
        })
        .collect()
}

/// The text of a cell `w` x `h` px that fits, with its font size: the
/// verdict mark and the value, else the value alone, else the mark alone,
/// else nothing; always at [`LABEL_SIZE`], never smaller, so that what is
/// printed can be read (the colour and outline still give value and
/// verdict).
pub fn cell_text(mark: &str, value: &str, w: f64, h: f64) -> Option<(String, f64)> {
    let px = LABEL_SIZE / super::charts::PLOTTERS_FONT_SCALE;
    [
        format!("{mark} {value}"),
        value.to_string(),
        mark.to_string(),
    ]
    .into_iter()
    .find(|t| text_width(t, px) <= w - 4.0 && px + 3.0 <= h)
    .map(|t| (t, LABEL_SIZE))
}

/// Inverse of [`scale`]: the value at position `t` of the colour scale.
fn unscale(kind: Shown, t: f64, threshold: f64) -> f64 {
    match kind {
        Shown::Fdi if t < 0.5 => 2.0 * t * threshold,
        Shown::Fdi => threshold + 11f64.powf(2.0 * t - 1.0) - 1.0,
        Shown::PercentFlicker | Shown::Visibility if t >= 0.5 => threshold * (2.0 - 2.0 * t),
        Shown::PercentFlicker | Shown::Visibility => {
            threshold + (1.0 - 2.0 * t) * (worst_of(kind, threshold) - threshold)
        }
    }
}

/// Geometry of a matrix drawing, pixels.
struct Grid {
    rows: usize,
    cell_w: f64,
    cell_h: f64,
}

impl Grid {
    fn new(cols: usize, rows: usize) -> Grid {
        // Cells 18 to 46 px high, and the block at least 150 px high so the
        // colour bar has room for its ticks.
        let cell_h = (360.0 / rows as f64)
            .clamp(18.0, 46.0)
            .max(150.0 / rows as f64);
        Grid {
            rows,
            cell_w: f64::from(RIGHT - LEFT) / cols as f64,
            cell_h,
        }
    }
    fn height(&self) -> i32 {
        (self.cell_h * self.rows as f64).round() as i32
    }
    /// Pixel x of the left edge of column `i` (i may be `cols`).
    fn x(&self, i: usize) -> i32 {
        LEFT + (i as f64 * self.cell_w).round() as i32
    }
    /// Pixel y of the bottom edge of row `j` (row 0 at the bottom).
    fn y(&self, j: usize) -> i32 {
        TOP + self.height() - (j as f64 * self.cell_h).round() as i32
    }
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn text_style(size: f64, pos: Pos) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font())
        .color(&BLACK)
        .pos(pos)
}

/// Axis labels and titles of both axes.
fn draw_axes(area: &Area<'_>, grid: &Grid, freqs: &[f64], duties: &[f64]) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    // A duty of 0.55 is 55.00000000000001 percent: whole to within 1e-9
    // reads as whole.
    let label = |v: f64| crate::util::fixed(v, if (v - v.round()).abs() < 1e-9 { 0 } else { 1 });
    let fx: Vec<String> = freqs.iter().map(|&v| label(v)).collect();
    for l in thin_labels(&fx, grid.cell_w, |t| text_width(t, LABEL_SIZE)) {
        let x = LEFT + l.centre.round() as i32;
        let y = TOP + grid.height();
        area.draw(&PathElement::new(
            [(x, y), (x, y + 4)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?;
        area.draw(&Text::new(
            l.text,
            (x, y + 6),
            text_style(LABEL_SIZE, Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(e)?;
    }
    let dy: Vec<String> = duties.iter().map(|&v| label(v)).collect();
    for l in thin_labels(&dy, grid.cell_h, |_| LABEL_SIZE) {
        let y = TOP + grid.height() - l.centre.round() as i32;
        area.draw(&PathElement::new(
            [(LEFT - 4, y), (LEFT, y)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?;
        area.draw(&Text::new(
            l.text,
            (LEFT - 6, y),
            text_style(LABEL_SIZE, Pos::new(HPos::Right, VPos::Center)),
        ))
        .map_err(e)?;
    }
    area.draw(&Text::new(
        "PWM frequency (Hz)",
        ((LEFT + RIGHT) / 2, TOP + grid.height() + 26),
        text_style(LABEL_SIZE, Pos::new(HPos::Center, VPos::Top)),
    ))
    .map_err(e)?;
    area.draw(&Text::new(
        "duty (%)",
        (14, TOP + grid.height() / 2),
        TextStyle::from(
            (FONT, LABEL_SIZE)
                .into_font()
                .transform(FontTransform::Rotate270),
        )
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(e)?;
    Ok(())
}

/// The colour bar right of the cells, with ticks at the worst end, half
/// way to the threshold, the threshold, and two values above it.
fn draw_colour_bar(
    area: &Area<'_>,
    grid: &Grid,
    kind: Shown,
    title: &str,
    threshold: f64,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let (x0, x1) = (RIGHT + 24, RIGHT + 38);
    let (top, h) = (TOP + 18, grid.height() - 18);
    area.draw(&Text::new(
        title.to_string(),
        (x0 - 4, TOP - 6),
        text_style(LABEL_SIZE, Pos::new(HPos::Left, VPos::Top)),
    ))
    .map_err(e)?;
    let steps = 24;
    for k in 0..steps {
        let (a, b) = (top + h * k / steps, top + h * (k + 1) / steps);
        let t = 1.0 - (k as f64 + 0.5) / steps as f64;
        area.draw(&Rectangle::new([(x0, a), (x1, b)], colour(t).filled()))
            .map_err(e)?;
    }
    area.draw(&Rectangle::new(
        [(x0, top), (x1, top + h)],
        BLACK.stroke_width(1),
    ))
    .map_err(e)?;
    for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
        let y = top + (f64::from(h) * (1.0 - t)).round() as i32;
        let v = crate::util::fixed(unscale(kind, t, threshold), 2);
        let text = match (kind, t) {
            (_, 0.5) => format!("{v} limit"),
            (Shown::Fdi, 1.0) | (Shown::PercentFlicker | Shown::Visibility, 0.0) => {
                format!("\u{2265} {v}")
            }
            (Shown::Fdi, 0.0) => format!("\u{2264} {v}"),
            _ => v,
        };
        area.draw(&PathElement::new(
            [(x1, y), (x1 + 4, y)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?;
        area.draw(&Text::new(
            text,
            (x1 + 6, y),
            text_style(LABEL_SIZE, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// Deegan 2018 Eq. (1) as a staircase along the cell edges: below and
/// left of it `T_exp < (1 - D) / f`; the legend goes under the axis title.
fn draw_eq1(area: &Area<'_>, grid: &Grid, eq1: &Eq1) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let rows = &eq1.off_rows;
    let style = BLACK.stroke_width(3);
    for (i, &b) in rows.iter().enumerate() {
        if b > 0 {
            area.draw(&PathElement::new(
                [(grid.x(i), grid.y(b)), (grid.x(i + 1), grid.y(b))],
                style,
            ))
            .map_err(e)?;
        }
        let next = rows.get(i + 1).copied().unwrap_or(0);
        if b != next {
            let x = grid.x(i + 1);
            area.draw(&PathElement::new(
                [(x, grid.y(b)), (x, grid.y(next))],
                style,
            ))
            .map_err(e)?;
        }
    }
    let y = TOP + grid.height() + 56;
    area.draw(&PathElement::new([(LEFT, y), (LEFT + 24, y)], style))
        .map_err(e)?;
    let exposure_ms = eq1.exposure_ms;
    // Two lines, so the legend fits the width at a readable size.
    let lines = if eq1.any_off() {
        [
            format!(
                "Eq. (1) at the {} ms exposure: below and left of the line",
                crate::util::fixed(exposure_ms, 3)
            ),
            "exposure < (1 \u{2212} D) / f, the LED can appear OFF".to_string(),
        ]
    } else {
        [
            format!(
                "Eq. (1) at the {} ms exposure:",
                crate::util::fixed(exposure_ms, 3)
            ),
            "no cell has exposure < (1 \u{2212} D) / f".to_string(),
        ]
    };
    for (k, text) in lines.into_iter().enumerate() {
        area.draw(&Text::new(
            text,
            (LEFT + 30, y + 17 * k as i32),
            text_style(LABEL_SIZE, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// One cell: fill by value, failing cells outlined, text when it fits.
fn draw_cell(
    area: &Area<'_>,
    grid: &Grid,
    (cell, columns): (&PlaneCell, std::ops::Range<usize>),
    (kind, threshold): (Shown, f64),
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let (j, value, unbounded) = (cell.row, cell.value, cell.unbounded);
    let fill = match (value, unbounded) {
        (_, true) => colour(1.0),
        (Some(v), false) => colour(scale(kind, v, threshold)),
        (None, false) => RGBColor(200, 200, 200),
    };
    let fill = if cell.verdict == Verdict::Info {
        fill.mix(0.45)
    } else {
        fill.mix(1.0)
    };
    let (x0, x1) = (grid.x(columns.start), grid.x(columns.end));
    let (y0, y1) = (grid.y(j + 1), grid.y(j));
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], fill.filled()))
        .map_err(e)?;
    // Cells narrower than a few pixels (a dense sweep) join into a heat
    // map: a white border on each would leave stripes of white, or white
    // only.
    if grid.cell_w >= DENSE_CELL_PX && grid.cell_h >= DENSE_CELL_PX {
        let gap = if grid.cell_w >= 8.0 { 1 } else { 0 };
        area.draw(&Rectangle::new(
            [(x0, y0), (x1, y1)],
            WHITE.stroke_width(gap + 1),
        ))
        .map_err(e)?;
    }
    if cell.verdict == Verdict::Fail && grid.cell_w >= 8.0 && grid.cell_h >= 8.0 {
        area.draw(&Rectangle::new(
            [(x0 + 2, y0 + 2), (x1 - 2, y1 - 2)],
            RGBColor(120, 0, 0).stroke_width(2),
        ))
        .map_err(e)?;
    }
    let mark = match cell.verdict {
        Verdict::Pass => "\u{2714}",
        Verdict::Fail => "\u{2718}",
        Verdict::Info => "info",
    };
    let text = match (value, unbounded) {
        (_, true) => "+\u{221e}".to_string(),
        (Some(v), false) => crate::util::fixed(v, 2),
        (None, false) => "n/a".to_string(),
    };
    if let Some((text, size)) = cell_text(mark, &text, f64::from(x1 - x0), f64::from(y1 - y0)) {
        area.draw(&Text::new(
            text,
            ((x0 + x1) / 2, (y0 + y1) / 2),
            text_style(size, Pos::new(HPos::Center, VPos::Center)),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// The matrix of cases at `light_lux`, as SVG: one cell per case, coloured
/// on the scale of the colour bar (right), failing cells outlined dark
/// red, the verdict mark and value written where they fit, axis labels
/// thinned so they never overlap (1 to 64 and more frequencies), and
/// Deegan 2018 Eq. (1) drawn along the cell edges with its legend below
/// the axis.
pub fn matrix_svg(model: &Results, light_lux: f64) -> Result<String, ChartError> {
    draw_matrix(model, light_lux, shown(model))
}

/// The matrix of the visibility index on the plan's monitor at
/// `light_lux`, as [`matrix_svg`] draws the verdict metric; the limit is
/// `visibility-max`, else 1 (the standard observer's threshold).
pub fn visibility_matrix_svg(model: &Results, light_lux: f64) -> Result<String, ChartError> {
    let limit = model.thresholds.visibility_max.or(Some(1.0));
    let title = "visibility";
    draw_matrix(
        model,
        light_lux,
        (Shown::Visibility, "visibility".to_string(), title, limit),
    )
}

fn draw_matrix(
    model: &Results,
    light_lux: f64,
    (kind, metric, title, threshold): (Shown, String, &'static str, Option<f64>),
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("matrix {light_lux} lux"),
        message: e.to_string(),
    };
    let Some(plane) = model.plane(light_lux, &metric) else {
        return Err(err(&"no case at this light level"));
    };
    let LevelPlane {
        frequencies_hz: freqs,
        duties_percent: duties,
        ..
    } = &plane;
    let th = threshold.unwrap_or(match kind {
        Shown::Fdi => 0.1,
        Shown::PercentFlicker => 10.0,
        Shown::Visibility => 1.0,
    });
    let grid = Grid::new(freqs.len(), duties.len());
    let mut svg = String::new();
    {
        let height = (TOP + grid.height() + BOTTOM) as u32;
        let root = SVGBackend::with_string(&mut svg, (WIDTH as u32, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let caption = format!(
            "{light_lux} lux: {} by PWM frequency and duty",
            crate::model::human_name(&metric)
        );
        root.draw(&Text::new(
            caption,
            ((LEFT + RIGHT) / 2, 8),
            text_style(LABEL_SIZE + 2.0, Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(|e| err(&e))?;
        for (columns, cell) in merged_cells(&plane.cells, &grid, kind) {
            draw_cell(&root, &grid, (&cell, columns), (kind, th)).map_err(|e| err(&e))?;
        }
        draw_axes(&root, &grid, freqs, duties).map_err(|e| err(&e))?;
        draw_colour_bar(&root, &grid, kind, title, th).map_err(|e| err(&e))?;
        // Eq. (1) is about the camera's exposure; the monitor's
        // visibility is another question.
        if let Some(eq1) = plane.eq1.as_ref().filter(|_| kind != Shown::Visibility) {
            draw_eq1(&root, &grid, eq1).map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
pub(crate) mod tests {
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
        // Visibility: the limit at the middle, ten times it at the worst end.
        assert!((scale(Shown::Visibility, 1.0, 1.0) - 0.5).abs() < 1e-12);
        assert_eq!(scale(Shown::Visibility, 12.0, 1.0), 0.0);
        for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let v = unscale(Shown::Visibility, t, 2.0);
            assert!((scale(Shown::Visibility, v, 2.0) - t).abs() < 1e-12, "{t}");
        }
        assert!((unscale(Shown::Visibility, 0.0, 2.0) - 20.0).abs() < 1e-12);
    }

    /// The daylight plan with `n` frequencies from 50 Hz in 37 Hz steps,
    /// a 1 s PWM segment, run on the simulator, as a report model.
    pub(crate) fn model_with(n: usize) -> Results {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("test-plans/daylight.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let freqs: Vec<String> = (0..n).map(|i| format!("{}.0", 50 + 37 * i)).collect();
        let text = text
            .replace(
                "frequencies-hz = [50.0, 90.0, 100.0, 150.0, 200.0, 500.0, 1000.0]",
                &format!("frequencies-hz = [{}]", freqs.join(", ")),
            )
            .replace("pwm-s = 60.0", "pwm-s = 1.0")
            // A small sensor keeps the plan inside the memory limit.
            .replace("sensor-rows = 800", "sensor-rows = 80")
            .replace("sensor-columns = 1280", "sensor-columns = 128")
            .replace("x-px = 590", "x-px = 59")
            .replace("y-px = 399", "y-px = 39")
            .replace("x-px = 100", "x-px = 10")
            .replace("y-px = 100", "y-px = 10")
            .replace("width-px = 100", "width-px = 10");
        let plan = ledflicker_core::plan::parse(&text, &path, String::new()).unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let backend = ledflicker_core::backend::sim::Simulator::new(&plan);
        let results =
            ledflicker_core::runner::run(&plan, &cases, &backend, Some(1), &|_| {}).unwrap();
        ledflicker_core::model::assemble(&plan, "sim-ideal", &results)
    }

    /// (x, y, font size, anchor, text) of every `<text>` of an SVG.
    fn texts(svg: &str) -> Vec<(f64, f64, f64, String, String)> {
        let attr = |tag: &str, name: &str| -> String {
            tag.split(&format!(" {name}=\""))
                .nth(1)
                .and_then(|s| s.split('"').next())
                .unwrap_or("")
                .to_string()
        };
        svg.split("<text")
            .skip(1)
            .map(|part| {
                let (tag, rest) = part.split_once('>').unwrap();
                let content = rest.split("</text>").next().unwrap().trim().to_string();
                (
                    attr(tag, "x").parse().unwrap(),
                    attr(tag, "y").parse().unwrap(),
                    attr(tag, "font-size").parse().unwrap_or(0.0),
                    attr(tag, "text-anchor"),
                    content,
                )
            })
            .collect()
    }

    #[test]
    fn axis_labels_never_overlap_from_1_to_64_frequencies() {
        for n in [1, 8, 32, 64, 200] {
            let grid = Grid::new(n, 5);
            let texts: Vec<String> = (0..n).map(|i| format!("{}", 50 + 37 * i)).collect();
            let labels = thin_labels(&texts, grid.cell_w, |t| text_width(t, LABEL_SIZE));
            assert_eq!(labels[0].index, 0);
            assert!(
                labels.len() >= n.min(8),
                "{n} frequencies: {} labels",
                labels.len()
            );
            for w in labels.windows(2) {
                let gap = (w[1].centre - w[1].half) - (w[0].centre + w[0].half);
                assert!(
                    gap >= LABEL_GAP,
                    "{n} frequencies: labels {} and {} {gap} px apart",
                    w[0].text,
                    w[1].text
                );
            }
            // Inside the cells' span.
            let last = labels.last().unwrap();
            assert!(last.centre < f64::from(RIGHT - LEFT));
        }
        // Without thinning 64 labels of 4 digits would overlap.
        let grid = Grid::new(64, 5);
        assert!(text_width("2381", LABEL_SIZE) > grid.cell_w);
    }

    #[test]
    fn cell_text_is_written_only_where_it_fits() {
        // 14 / 1.24 = 11.3 px: "✔ 8.73" is 6 x 0.64 x 11.3 = 43.4 px wide.
        let size = LABEL_SIZE;
        assert_eq!(
            cell_text("\u{2714}", "8.73", 80.0, 46.0),
            Some(("\u{2714} 8.73".to_string(), size))
        );
        assert_eq!(
            cell_text("\u{2714}", "8.73", 40.0, 46.0),
            Some(("8.73".to_string(), size))
        );
        assert_eq!(
            cell_text("\u{2714}", "8.73", 12.0, 46.0),
            Some(("\u{2714}".to_string(), size))
        );
        assert_eq!(cell_text("\u{2714}", "8.73", 8.0, 46.0), None);
        assert_eq!(cell_text("\u{2714}", "8.73", 80.0, 12.0), None);
    }

    #[test]
    fn colour_bar_ticks_invert_the_scale() {
        for kind in [Shown::Fdi, Shown::PercentFlicker] {
            let th = if kind == Shown::Fdi { 0.1 } else { 10.0 };
            for t in [0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0] {
                let v = unscale(kind, t, th);
                assert!(
                    (scale(kind, v, th) - t).abs() < 1e-9,
                    "{kind:?} t {t}: v {v}"
                );
            }
        }
    }

    #[test]
    fn rendered_matrices_keep_labels_apart_and_text_inside_cells() {
        for n in [1, 8, 32, 64] {
            let model = model_with(n);
            let svg = matrix_svg(&model, 2000.0).unwrap();
            let grid = Grid::new(n, 5);
            let bottom = f64::from(TOP + grid.height());
            // Frequency labels: the texts just under the cells.
            let mut labels: Vec<(f64, f64)> = texts(&svg)
                .into_iter()
                .filter(|t| t.1 > bottom && t.1 < bottom + 12.0 && t.3 == "middle")
                .map(|t| {
                    (
                        t.0 - text_width(&t.4, t.2) / 2.0,
                        t.0 + text_width(&t.4, t.2) / 2.0,
                    )
                })
                .collect();
            labels.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert!(!labels.is_empty(), "{n}: no frequency labels");
            for w in labels.windows(2) {
                assert!(
                    w[1].0 - w[0].1 >= LABEL_GAP - 1.0,
                    "{n} frequencies: labels overlap {w:?}"
                );
            }
            // Cell texts: centred in the cells, no wider than a cell.
            for t in texts(&svg).iter().filter(|t| {
                t.1 > f64::from(TOP)
                    && t.1 < bottom
                    && f64::from(RIGHT) > t.0
                    && t.0 > f64::from(LEFT)
            }) {
                assert!(
                    text_width(&t.4, t.2) <= grid.cell_w - 4.0 + 1e-9,
                    "{n}: `{}` too wide",
                    t.4
                );
            }
            assert!(svg.contains("limit"), "colour bar marks the limit");
            assert!(svg.contains("Eq. (1)"));
        }
    }
}
