//! The plot of docs/visibility.md: the eye model (elaTCSF) against the
//! flicker thresholds of de Lange (1958) and Kelly (1961). Every run draws
//! it and checks it holds every measured point; with
//! `LEDFLICKER_WRITE_DOCS=1` it also writes docs/visibility-fit.svg.

use ledflicker_core::metrics::visibility::tcsf::disk_sensitivity;
use ledflicker_core::metrics::visibility::validation::{Threshold, read};
use plotters::prelude::*;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// One colour per luminance, darkest for the lowest.
const COLOURS: [RGBColor; 7] = [
    RGBColor(68, 1, 84),
    RGBColor(70, 50, 127),
    RGBColor(54, 92, 141),
    RGBColor(39, 127, 142),
    RGBColor(31, 161, 135),
    RGBColor(74, 193, 109),
    RGBColor(160, 218, 57),
];

/// One panel: a data set's thresholds (points) and the model at each of
/// its luminances (lines), on log-log axes drawn as log10 values.
fn panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    title: &str,
    data: &[&Threshold],
) -> Result<usize, String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .caption(title, ("sans-serif", 16))
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0f64..2.0f64, -0.3f64..3.0f64)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("frequency (Hz)")
        .y_desc("sensitivity (1 / threshold modulation)")
        .x_label_formatter(&|x| format!("{}", (10f64.powf(*x) * 10.0).round() / 10.0))
        .y_label_formatter(&|y| format!("{}", (10f64.powf(*y) * 10.0).round() / 10.0))
        .draw()
        .map_err(|e| err(&e))?;
    let mut levels: Vec<(f64, f64)> = data
        .iter()
        .map(|t| (t.luminance_cd_m2, t.radius_deg))
        .collect();
    levels.sort_by(|a, b| a.0.total_cmp(&b.0));
    levels.dedup_by(|a, b| a.0 == b.0);
    let mut drawn = 0;
    for (i, &(l, r)) in levels.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let line = (0..=200).map(|k| {
            let lf = k as f64 / 100.0;
            let s = disk_sensitivity(10f64.powf(lf), r, l).max(0.5);
            (lf, s.log10())
        });
        chart
            .draw_series(LineSeries::new(line, colour.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(format!("{l:.3} cd/m^2"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2)));
        let points: Vec<(f64, f64)> = data
            .iter()
            .filter(|t| t.luminance_cd_m2 == l)
            .map(|t| (t.frequency_hz.log10(), t.sensitivity.log10()))
            .collect();
        drawn += points.len();
        chart
            .draw_series(
                points
                    .into_iter()
                    .map(|p| Circle::new(p, 3, colour.filled())),
            )
            .map_err(|e| err(&e))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerLeft)
        .draw()
        .map_err(|e| err(&e))?;
    Ok(drawn)
}

#[test]
fn the_fit_plot_holds_every_measured_threshold() {
    let text = std::fs::read_to_string(format!("{ROOT}/tests/data/tcsf/flicker_thresholds.csv"))
        .expect("tests/data/tcsf/flicker_thresholds.csv");
    let data = read(&text);
    let of = |set: &str| -> Vec<&Threshold> { data.iter().filter(|t| t.data_set == set).collect() };
    let (de_lange, kelly) = (of("deLange1958"), of("kelly1961"));
    let mut svg = String::new();
    let drawn = {
        let root = SVGBackend::with_string(&mut svg, (1100, 480)).into_drawing_area();
        root.fill(&WHITE).unwrap();
        let (left, right) = root.split_horizontally(550);
        let a = panel(
            &left,
            "de Lange 1958, 2 deg field: data (points), elaTCSF (lines)",
            &de_lange,
        )
        .unwrap();
        let b = panel(
            &right,
            "Kelly 1961, 60 deg field: data (points), elaTCSF (lines)",
            &kelly,
        )
        .unwrap();
        root.present().unwrap();
        a + b
    };
    assert_eq!(drawn, de_lange.len() + kelly.len());
    assert_eq!(drawn, 171);
    assert_eq!(svg.matches("<circle").count(), 171);
    if std::env::var_os("LEDFLICKER_WRITE_DOCS").is_some() {
        std::fs::write(format!("{ROOT}/docs/visibility-fit.svg"), &svg).unwrap();
    }
}
