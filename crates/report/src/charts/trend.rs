//! A value over the runs of a campaign (`ledflicker trend --svg`, the
//! charts of `ledflicker history --html`): one line per series, the runs
//! in order along x, each labelled by its firmware or date.

use plotters::prelude::*;

use super::{ChartError, FONT, FONT_FULL_WIDTH, SERIES_COLOURS};

/// One line of a trend chart: its legend and a value per run (`None`: no
/// value in that run, a gap in the line).
pub type TrendSeries = (String, Vec<Option<f64>>);

/// Series drawn in colour and named in the legend; the others are drawn
/// grey under them and counted in one legend entry, so a plan of many
/// cases still reads.
const NAMED: usize = 6;

/// Which series are named: the `NAMED` whose values move most over the
/// runs (largest minus smallest), ties in the given order; of them only
/// those that move, unless none does. A reader looks
/// at a trend chart for what changed; the first cases of a plan may be
/// the ones that never move.
fn named(series: &[TrendSeries]) -> Vec<bool> {
    let movement = |values: &[Option<f64>]| {
        let finite = values.iter().flatten().filter(|v| v.is_finite());
        let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
        if lo.is_finite() {
            hi - lo
        } else {
            f64::NEG_INFINITY
        }
    };
    let mut order: Vec<usize> = (0..series.len()).collect();
    order.sort_by(|&a, &b| movement(&series[b].1).total_cmp(&movement(&series[a].1)));
    // A line that never moves is named only when none moves: naming it
    // beside the lines that do would say it changed.
    let any_moves = order.first().is_some_and(|&k| movement(&series[k].1) > 0.0);
    let mut named = vec![false; series.len()];
    for &k in order.iter().take(NAMED) {
        named[k] = !any_moves || movement(&series[k].1) > 0.0;
    }
    named
}

/// A limit of the plotted KPI, drawn as a dashed line across the runs:
/// its value and its legend (`"limit >= 0.1"`).
pub type TrendLimit = (f64, String);

/// Width of the legend column right of the plot, pixels: the legend never
/// covers a value.
const LEGEND_W: u32 = 200;

/// The chart as SVG, 760 x 380 px: `labels` along x (one a run, the axis
/// described by `x_desc`), `series` as lines with a dot at each value,
/// each of `limits` as a dashed line; the legend is right of the plot.
pub fn trend_svg(
    title: &str,
    (x_desc, y_desc): (&str, &str),
    labels: &[String],
    series: &[TrendSeries],
    limits: &[TrendLimit],
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("trend {title}"),
        message: e.to_string(),
    };
    let values = series
        .iter()
        .flat_map(|s| s.1.iter().flatten().copied())
        .chain(limits.iter().map(|l| l.0));
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let (lo, hi) = if lo.is_finite() {
        let pad = ((hi - lo) * 0.08).max(1e-3 * hi.abs().max(1.0));
        (lo - pad, hi + pad)
    } else {
        (0.0, 1.0)
    };
    let n = labels.len().max(1);
    let mut svg = String::new();
    {
        let canvas = SVGBackend::with_string(&mut svg, (760, 380)).into_drawing_area();
        canvas.fill(&WHITE).map_err(|e| err(&e))?;
        let (root, legend) = canvas.split_horizontally(760 - LEGEND_W);
        let mut c = ChartBuilder::on(&root)
            .margin(10)
            .caption(title, (FONT, FONT_FULL_WIDTH + 2))
            .x_label_area_size(50)
            .y_label_area_size(super::y_label_area(lo, hi, FONT_FULL_WIDTH))
            .build_cartesian_2d(-0.5..(n as f64 - 0.5), lo..hi)
            .map_err(|e| err(&e))?;
        // At most 8 labels along x (plotters' SVG sets text upright), so
        // that labels of a dozen characters never overlap.
        let every = n.div_ceil(8).max(1);
        c.configure_mesh()
            .y_desc(y_desc)
            .x_labels(0)
            .x_desc(x_desc)
            .label_style((FONT, FONT_FULL_WIDTH))
            .axis_desc_style((FONT, FONT_FULL_WIDTH))
            .max_light_lines(0)
            .draw()
            .map_err(|e| err(&e))?;
        let style = TextStyle::from((FONT, FONT_FULL_WIDTH).into_font()).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Top,
            ),
        );
        for (i, label) in labels.iter().enumerate().step_by(every) {
            let (x, y) = c.backend_coord(&(i as f64, lo));
            root.draw(&Text::new(label.clone(), (x, y + 6), style.clone()))
                .map_err(|e| err(&e))?;
        }
        let dashed = |colour: RGBColor, (x0, x1): (f64, f64), y: f64| {
            // plotters' SVG has no dash style: short segments.
            let step = (x1 - x0) / 60.0;
            (0..30).map(move |i| {
                let a = x0 + 2.0 * i as f64 * step;
                PathElement::new([(a, y), (a + step, y)], colour.stroke_width(2))
            })
        };
        let limit_colour = RGBColor(180, 30, 30);
        for l in limits {
            c.draw_series(dashed(limit_colour, (-0.5, n as f64 - 0.5), l.0))
                .map_err(|e| err(&e))?;
        }
        let named = named(series);
        let colours = colours(&named);
        // Grey lines are drawn first, so that a named line is never hidden
        // under one.
        let mut draw_order: Vec<usize> = (0..series.len()).filter(|&k| !named[k]).collect();
        draw_order.extend((0..series.len()).filter(|&k| named[k]));
        let mut entries: Vec<(String, RGBColor, bool)> = Vec::new();
        for k in draw_order {
            let (name, values) = &series[k];
            let colour = colours[k];
            // A gap (no value) breaks the line.
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for (i, v) in values.iter().enumerate() {
                match (v.filter(|v| v.is_finite()), runs.last_mut()) {
                    (Some(v), Some(run)) => run.push((i as f64, v)),
                    _ => runs.push(Vec::new()),
                }
            }
            for (j, run) in runs.into_iter().filter(|r| !r.is_empty()).enumerate() {
                c.draw_series(LineSeries::new(run.clone(), colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
                if named[k] && j == 0 {
                    entries.push((name.clone(), colour, false));
                }
                c.draw_series(run.into_iter().map(|p| Circle::new(p, 3, colour.filled())))
                    .map_err(|e| err(&e))?;
            }
        }
        // The legend lists the named series in the given order.
        entries.sort_by_key(|e| series.iter().position(|s| s.0 == e.0));
        let others = named.iter().filter(|&&n| !n).count();
        if others > 0 {
            entries.push((format!("{others} others, in grey"), GREY, false));
        }
        entries.extend(limits.iter().map(|l| (l.1.clone(), limit_colour, true)));
        draw_legend(&legend, entries).map_err(|e| err(&e))?;
        canvas.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// The colour of the series that are not named.
const GREY: RGBColor = RGBColor(190, 190, 190);

/// Each series' colour: the chart colours in order for the named ones,
/// grey for the others.
fn colours(named: &[bool]) -> Vec<RGBColor> {
    let mut next = 0;
    named
        .iter()
        .map(|&n| {
            if n {
                next += 1;
                SERIES_COLOURS[(next - 1) % SERIES_COLOURS.len()]
            } else {
                GREY
            }
        })
        .collect()
}

/// The legend column: each entry's line (dashed for a limit) and name,
/// one under the other.
fn draw_legend<DB: DrawingBackend>(
    legend: &DrawingArea<DB, plotters::coord::Shift>,
    entries: Vec<(String, RGBColor, bool)>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let text = TextStyle::from((FONT, FONT_FULL_WIDTH).into_font());
    // Characters that fit beside the line (DejaVu Sans, about 0.62 em);
    // a longer name wraps at a space onto a second line.
    let px = f64::from(FONT_FULL_WIDTH) / super::PLOTTERS_FONT_SCALE;
    let fits = (f64::from(LEGEND_W - 36) / (0.62 * px)) as usize;
    let mut y = 40;
    for (name, colour, limit) in entries {
        let line = if limit {
            PathElement::new([(8, y), (14, y)], colour.stroke_width(2))
        } else {
            PathElement::new([(8, y), (26, y)], colour.stroke_width(2))
        };
        legend.draw(&line)?;
        if limit {
            legend.draw(&PathElement::new(
                [(20, y), (26, y)],
                colour.stroke_width(2),
            ))?;
        }
        let mut lines = vec![name.as_str()];
        if name.chars().count() > fits {
            // The last space that fits, else the first one.
            let spaces = || {
                name.char_indices()
                    .filter(|&(_, c)| c == ' ')
                    .map(|(i, _)| i)
            };
            if let Some(at) = spaces().rfind(|&i| i <= fits).or_else(|| spaces().next()) {
                lines = vec![&name[..at], &name[at + 1..]];
            }
        }
        for line in lines {
            // A line still too long ends in an ellipsis at the column's edge.
            let line: String = if line.chars().count() > fits {
                line.chars().take(fits - 1).chain(['\u{2026}']).collect()
            } else {
                line.to_string()
            };
            legend.draw(&Text::new(line, (32, y - 6), text.clone()))?;
            y += 16;
        }
        y += 4;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_run_is_labelled_and_a_named_series_is_in_the_legend() {
        let labels: Vec<String> = (0..5).map(|i| format!("fw-1.{i}")).collect();
        let series = vec![
            (
                "case-a".to_string(),
                vec![Some(1.0), Some(1.1), None, Some(0.2), Some(0.2)],
            ),
            (
                "case-b".to_string(),
                vec![Some(0.5), Some(0.5), Some(0.5), Some(0.5), Some(0.6)],
            ),
        ];
        let limits = [(0.1, "limit >= 0.1".to_string())];
        let svg = trend_svg(
            "FDI over firmware",
            ("firmware", "FDI"),
            &labels,
            &series,
            &limits,
        )
        .unwrap();
        for l in &labels {
            assert!(svg.contains(&format!("\n{l}\n")), "no label {l}");
        }
        assert!(svg.contains("\ncase-a\n") && svg.contains("\ncase-b\n"));
        // The legend is right of the plot, never over a value.
        for name in ["case-a", "case-b", "limit &gt;= 0.1"] {
            let at = svg
                .find(&format!("\n{name}\n"))
                .unwrap_or_else(|| panic!("no legend {name}: {svg}"));
            let tag = &svg[svg[..at].rfind("<text x=\"").unwrap() + 9..];
            let x: f64 = tag[..tag.find('"').unwrap()].parse().unwrap();
            assert!(x >= f64::from(760 - LEGEND_W), "{name} at x = {x}");
        }
        // Nine dots: four of case-a (one gap), five of case-b.
        assert_eq!(svg.matches("<circle").count(), 9, "{svg}");
    }

    #[test]
    fn the_series_that_move_most_are_named_and_the_others_counted() {
        let labels = vec!["a".to_string(), "b".to_string()];
        // Eight series; the last two move most, the first two not at all.
        let series: Vec<TrendSeries> = (0..8)
            .map(|k| (format!("s{k}"), vec![Some(1.0), Some(1.0 + f64::from(k))]))
            .collect();
        let svg = trend_svg("t", ("run", "y"), &labels, &series, &[]).unwrap();
        for k in 2..8 {
            assert!(svg.contains(&format!("\ns{k}\n")), "s{k} not named");
        }
        assert!(!svg.contains("\ns0\n") && !svg.contains("\ns1\n"), "{svg}");
        assert!(svg.contains("\n2 others, in grey\n"), "{svg}");
        // Named in the given order.
        assert!(svg.find("\ns2\n") < svg.find("\ns7\n"));
    }

    #[test]
    fn a_line_that_does_not_move_is_not_named_beside_lines_that_do() {
        let labels = vec!["a".to_string(), "b".to_string()];
        let series: Vec<TrendSeries> = vec![
            ("flat1".to_string(), vec![Some(1.0), Some(1.0)]),
            ("moves".to_string(), vec![Some(1.0), Some(2.0)]),
            ("flat2".to_string(), vec![Some(3.0), Some(3.0)]),
        ];
        let svg = trend_svg("t", ("run", "y"), &labels, &series, &[]).unwrap();
        assert!(svg.contains("\nmoves\n") && svg.contains("\n2 others, in grey\n"));
        assert!(
            !svg.contains("\nflat1\n") && !svg.contains("\nflat2\n"),
            "{svg}"
        );
        // None moves: the first ones are named, as there is nothing else.
        let svg = trend_svg("t", ("run", "y"), &labels, &series[..1], &[]).unwrap();
        assert!(svg.contains("\nflat1\n"), "{svg}");
    }

    #[test]
    fn a_long_legend_name_wraps_inside_the_chart() {
        let labels = vec!["a".to_string(), "b".to_string()];
        let long = "2000lux-100hz-10pct background";
        let series = vec![(long.to_string(), vec![Some(1.0), Some(2.0)])];
        let svg = trend_svg("t", ("run", "y"), &labels, &series, &[]).unwrap();
        assert!(svg.contains("\n2000lux-100hz-10pct\n") && svg.contains("\nbackground\n"));
        // The column's right edge, at the width the font takes.
        let px = f64::from(FONT_FULL_WIDTH) / super::super::PLOTTERS_FONT_SCALE;
        let x = f64::from(760 - LEGEND_W) + 32.0;
        assert!(x + 0.62 * px * "2000lux-100hz-10pct".len() as f64 <= 760.0);
    }

    #[test]
    fn many_runs_get_a_label_every_few_runs() {
        let labels: Vec<String> = (0..60).map(|i| format!("r{i}")).collect();
        let series = vec![("x".to_string(), vec![Some(1.0); 60])];
        let svg = trend_svg("t", ("run", "y"), &labels, &series, &[]).unwrap();
        // Every eighth run.
        assert!(svg.contains("\nr0\n") && svg.contains("\nr8\n"), "{svg}");
        assert!(!svg.contains("\nr4\n"));
    }
}
