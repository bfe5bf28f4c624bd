//! The colour of an LED ROI over the PWM segment in the CIE 1976 u′v′
//! diagram (docs/visibility.md, section 6): the spectrum locus, the UN R48
//! red and amber signal-colour regions, each PWM frame's colour joined in
//! frame order, the frames outside the plan's region marked, and the
//! colour the frames fuse to.

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::{ChartError, FONT};
use crate::model::{ColourFigures, SPECTRUM_LOCUS, SignalColour, uv_of_xy};

/// Chart size, px: two panels side by side, printed at the PDF's full
/// text width (493.2 pt): a pixel is 0.49 pt.
pub const UV_CHART_SIZE: (u32, u32) = (1000, 560);

/// Font size (plotters' units): 21 / 1.24 px x 0.49 pt/px = 8.4 pt
/// printed.
const UV_FONT: u32 = 21;

/// One panel's size and the margins of its axis labels, px.
const PANEL: (u32, u32) = (500, 520);
const X_LABEL_AREA: u32 = 56;
const Y_LABEL_AREA: u32 = 84;
const CAPTION: u32 = 34;

const RED_REGION: RGBColor = RGBColor(214, 39, 40);
const AMBER_REGION: RGBColor = RGBColor(255, 153, 0);
const PATH: RGBColor = RGBColor(31, 119, 180);
const OUTSIDE: RGBColor = RGBColor(0, 0, 0);
const MEAN: RGBColor = RGBColor(148, 103, 189);

type Window = ((f64, f64), (f64, f64));

/// The locus in u′v′, densified (20 points between tabulated ones) so
/// that a window crossing it cuts it where it leaves, and closed by the
/// purple line.
fn locus_uv() -> Vec<(f64, f64)> {
    let xy: Vec<(f64, f64)> = SPECTRUM_LOCUS.iter().map(|&(_, x, y)| (x, y)).collect();
    let mut closed = xy.clone();
    closed.push(xy[0]);
    let mut out = Vec::new();
    for w in closed.windows(2) {
        for k in 0..20 {
            let t = f64::from(k) / 20.0;
            let p = (
                w[0].0 + t * (w[1].0 - w[0].0),
                w[0].1 + t * (w[1].1 - w[0].1),
            );
            out.push(uv_of_xy(p));
        }
    }
    out.push(uv_of_xy(xy[0]));
    out
}

/// The plotting area of a panel, px.
fn plot_size() -> (f64, f64) {
    (
        f64::from(PANEL.0 - Y_LABEL_AREA - 20),
        f64::from(PANEL.1 - X_LABEL_AREA - CAPTION - 20),
    )
}

/// `(lo, hi)` of each axis, widened so that one unit of u′ and of v′ take
/// the same length on the page (the diagram is uniform in both), with a
/// margin.
fn window(points: &[(f64, f64)]) -> Window {
    let fold = |f: fn(&(f64, f64)) -> f64| {
        points
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let (mut u, mut v) = (fold(|p| p.0), fold(|p| p.1));
    let pad = 0.08 * (u.1 - u.0).max(v.1 - v.0).max(0.02);
    u = (u.0 - pad, u.1 + pad);
    v = (v.0 - pad, v.1 + pad);
    let (width, height) = plot_size();
    let per_px = ((u.1 - u.0) / width).max((v.1 - v.0) / height);
    let grow = |(lo, hi): (f64, f64), px: f64| {
        let extra = (per_px * px - (hi - lo)) / 2.0;
        (lo - extra, hi + extra)
    };
    (grow(u, width), grow(v, height))
}

/// The bounding box of `points` with a margin of a tenth each way: the
/// zoom, whose scales differ (a signal-colour region is a thin strip
/// along the locus).
fn bounding(points: &[(f64, f64)]) -> Window {
    let fold = |f: fn(&(f64, f64)) -> f64| {
        let (lo, hi) = points
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        let pad = 0.1 * (hi - lo).max(1e-3);
        (lo - pad, hi + pad)
    };
    (fold(|p| p.0), fold(|p| p.1))
}

/// Runs of consecutive points inside the window.
fn inside_runs(points: &[(f64, f64)], (u, v): Window) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for &p in points {
        let inside = (u.0..=u.1).contains(&p.0) && (v.0..=v.1).contains(&p.1);
        match (inside, runs.last_mut()) {
            (true, Some(run)) => run.push(p),
            (false, Some(run)) if !run.is_empty() => runs.push(Vec::new()),
            _ => {}
        }
    }
    runs.retain(|r| r.len() > 1);
    runs
}

/// The diagram of one LED ROI's colour, `title` above it: on the left
/// every frame, on the right the signal-colour regions at a scale where
/// they read. `region` is the plan's signal colour (its frames outside are
/// marked); both regions are drawn whatever it is.
pub fn uv_diagram_svg(
    title: &str,
    colour: &ColourFigures,
    region: Option<SignalColour>,
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("u'v' diagram {title}"),
        message: e.to_string(),
    };
    let polygons: Vec<Vec<(f64, f64)>> = [SignalColour::Red, SignalColour::Amber]
        .iter()
        .map(|r| r.polygon_xy().into_iter().map(uv_of_xy).collect())
        .collect();
    let path: Vec<(f64, f64)> = colour.path.iter().map(|&(_, u, v)| (u, v)).collect();
    let mut all: Vec<(f64, f64)> = polygons.iter().flatten().copied().collect();
    all.extend(&path);
    all.extend(colour.mean_uv);
    // The zoom: the plan's region (both without one) and the mean colour.
    let mut near: Vec<(f64, f64)> = match region {
        Some(SignalColour::Red) => polygons[0].clone(),
        Some(SignalColour::Amber) => polygons[1].clone(),
        None => polygons.iter().flatten().copied().collect(),
    };
    near.extend(colour.mean_uv);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, UV_CHART_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (top, body) = root.split_vertically(UV_CHART_SIZE.1 - PANEL.1);
        top.draw(&Text::new(
            title.to_string(),
            (10, 8),
            (FONT, UV_FONT + 2).into_font(),
        ))
        .map_err(|e| err(&e))?;
        let (left, right) = body.split_horizontally(PANEL.0);
        let panels = [
            (left, "every PWM frame", window(&all), true),
            (
                right,
                "the signal colour, v′ stretched",
                bounding(&near),
                false,
            ),
        ];
        for (area, name, w, legend) in panels {
            panel(&area, name, w, colour, region, &polygons, &path, legend).map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

type DrawResult = Result<(), DrawingAreaErrorKind<std::io::Error>>;

/// The chart of one panel.
type Panel<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The spectrum locus where it crosses the window `(u, v)`, with some
/// wavelengths.
fn locus(
    c: &mut Panel<'_, '_>,
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    (u, v): Window,
) -> DrawResult {
    let grey = RGBColor(110, 110, 110);
    for (k, run) in inside_runs(&locus_uv(), (u, v)).into_iter().enumerate() {
        let drawn = c.draw_series(LineSeries::new(run, grey.stroke_width(1)))?;
        if k == 0 {
            drawn.label("spectrum locus").legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 18, y)], grey.stroke_width(1))
            });
        }
    }
    // Wavelengths along the locus, where they fall in the window and at
    // least 60 px from the last one labelled.
    let mut last: Option<(i32, i32)> = None;
    for &(nm, x, y) in SPECTRUM_LOCUS.iter().filter(|p| p.0 >= 560) {
        let p = uv_of_xy((x, y));
        if !((u.0..=u.1).contains(&p.0) && (v.0..=v.1).contains(&p.1)) {
            continue;
        }
        let px = c.backend_coord(&p);
        if last.is_some_and(|q| ((q.0 - px.0).pow(2) + (q.1 - px.1).pow(2)) < 3600) {
            continue;
        }
        last = Some(px);
        let at = (
            px.0 - area.get_base_pixel().0 - 30,
            px.1 - area.get_base_pixel().1 + 8,
        );
        area.draw(&Text::new(
            format!("{nm} nm"),
            at,
            (FONT, UV_FONT).into_font().color(&grey),
        ))?;
        c.draw_series(std::iter::once(Circle::new(p, 2, grey.filled())))?;
    }
    Ok(())
}

/// One panel of the diagram over the window `(u, v)`.
#[allow(clippy::too_many_arguments)]
fn panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    name: &str,
    (u, v): Window,
    colour: &ColourFigures,
    region: Option<SignalColour>,
    polygons: &[Vec<(f64, f64)>],
    path: &[(f64, f64)],
    legend: bool,
) -> DrawResult {
    let mut c = ChartBuilder::on(area)
        .margin(10)
        .caption(name, (FONT, UV_FONT))
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(u.0..u.1, v.0..v.1)?;
    // Enough decimals that ticks about a fifth of the range apart differ.
    let decimals = |(lo, hi): (f64, f64)| if hi - lo < 0.06 { 3 } else { 2 };
    let (du, dv) = (decimals(u), decimals(v));
    c.configure_mesh()
        .x_desc("u′ (CIE 1976)")
        .y_desc("v′ (CIE 1976)")
        .x_labels(5)
        .y_labels(6)
        .x_label_formatter(&|x| format!("{x:.du$}"))
        .y_label_formatter(&|y| format!("{y:.dv$}"))
        .label_style((FONT, UV_FONT))
        .axis_desc_style((FONT, UV_FONT))
        .max_light_lines(0)
        .bold_line_style(RGBColor(235, 235, 235))
        .draw()?;
    locus(&mut c, area, (u, v))?;
    let named = [("UN R48 red", RED_REGION), ("UN R48 amber", AMBER_REGION)];
    for ((label, fill), poly) in named.into_iter().zip(polygons) {
        c.draw_series(std::iter::once(Polygon::new(poly.clone(), fill.mix(0.3))))?;
        let mut outline = poly.clone();
        outline.extend(poly.first());
        c.draw_series(LineSeries::new(outline, fill.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 6), (x + 18, y + 6)], fill.mix(0.5).filled())
            });
    }
    // The frames in order, joined where both ends are in the window; the
    // ones outside the region marked.
    for run in inside_runs(path, (u, v)) {
        c.draw_series(LineSeries::new(run, PATH.mix(0.35).stroke_width(1)))?;
    }
    let seen = |p: &&(u64, f64, f64)| (u.0..=u.1).contains(&p.1) && (v.0..=v.1).contains(&p.2);
    let outside: std::collections::BTreeSet<u64> = colour.outside_frames.iter().copied().collect();
    let (inside, out): (Vec<_>, Vec<_>) = colour
        .path
        .iter()
        .filter(seen)
        .partition(|(i, _, _)| !(region.is_some() && outside.contains(i)));
    c.draw_series(
        inside
            .iter()
            .map(|&&(_, a, b)| Circle::new((a, b), 3, PATH.filled())),
    )?
    .label(if region.is_some() {
        "a PWM frame's colour, in the region"
    } else {
        "a PWM frame's colour"
    })
    .legend(|(x, y)| Circle::new((x + 9, y), 3, PATH.filled()));
    if let Some(r) = region {
        let name = match r {
            SignalColour::Red => "red",
            SignalColour::Amber => "amber",
        };
        c.draw_series(
            out.iter()
                .map(|&&(_, a, b)| Cross::new((a, b), 5, OUTSIDE.stroke_width(2))),
        )?
        .label(format!("a frame outside the {name} region"))
        .legend(|(x, y)| Cross::new((x + 9, y), 5, OUTSIDE.stroke_width(2)));
    }
    if let Some(m) = colour.mean_uv {
        c.draw_series(std::iter::once(TriangleMarker::new(m, 8, MEAN.filled())))?
            .label(if colour.mean_is_time_average {
                "the colour the dies fuse to"
            } else {
                "the colour the frames fuse to"
            })
            .legend(|(x, y)| TriangleMarker::new((x + 9, y), 6, MEAN.filled()));
    }
    if legend {
        c.configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .label_font((FONT, UV_FONT))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(200, 200, 200))
            .draw()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures(path: Vec<(u64, f64, f64)>, outside: Vec<u64>) -> ColourFigures {
        ColourFigures {
            clipped: Vec::new(),
            delta_uv: Some(0.05),
            mean_uv: Some((0.55, 0.52)),
            mean_is_time_average: false,
            region: Some("red".to_string()),
            frames_outside: Some(outside.len() as u64),
            outside_frames: outside,
            frames: path.len() as u64,
            planes: Vec::new(),
            path,
        }
    }

    #[test]
    fn the_diagram_draws_both_regions_the_path_and_marks_the_frames_outside() {
        let path = vec![(10, 0.56, 0.52), (11, 0.50, 0.53), (12, 0.57, 0.52)];
        let svg = uv_diagram_svg(
            "case, lamp",
            &figures(path, vec![11]),
            Some(SignalColour::Red),
        )
        .unwrap();
        for text in [
            "UN R48 red",
            "UN R48 amber",
            "spectrum locus",
            "a frame outside the red region",
            "the colour the frames fuse to",
        ] {
            assert!(svg.contains(text), "no {text}");
        }
        assert!(svg.matches("<polygon").count() >= 2, "{svg}");
        // Two frames inside (circles, plus the legend's), one outside.
        let dots = svg.matches("<circle").count();
        assert!(dots >= 3, "{dots}");
        // Every text is at least 8 pt printed at the text width.
        let scale = crate::charts::PDF_TEXT_WIDTH_PT / f64::from(UV_CHART_SIZE.0);
        for size in svg.split("font-size=\"").skip(1) {
            let px: f64 = size
                .split('"')
                .next()
                .unwrap()
                .trim_end_matches("px")
                .parse()
                .unwrap();
            assert!(px * scale >= 8.0, "{px} px is {} pt", px * scale);
        }
    }

    #[test]
    fn equal_scales_on_both_axes() {
        let ((u0, u1), (v0, v1)) = window(&[(0.4, 0.5), (0.6, 0.52)]);
        let (width, height) = plot_size();
        assert!((((u1 - u0) / width) - ((v1 - v0) / height)).abs() < 1e-12);
        assert!(u0 < 0.4 && u1 > 0.6 && v0 < 0.5 && v1 > 0.52);
    }
}
