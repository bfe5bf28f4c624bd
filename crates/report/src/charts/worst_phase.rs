//! The evidence of a worst-phase verdict: one ROI's trace as run and at
//! the worst PWM phase, frame by frame around the frame put at that phase,
//! with the OFF level and the FDI limit the verdict compares against.

use plotters::prelude::*;

use super::ChartError;
use super::trace::{Swatch, draw_legend};
use crate::model::evidence::WorstPhaseInfo;
use crate::model::{CaseResult, Segment};

/// Width of the legend column right of the plot, pixels.
const LEGEND_WIDTH: u32 = 200;

/// PWM frames drawn either side of the frame at the worst phase: two
/// seconds at 30 fps, enough to show a beat of a few hertz frame by frame.
const WINDOW_FRAMES: usize = 60;

/// The trace as run, in the trace chart's first series colour.
const AS_RUN: RGBColor = RGBColor(31, 119, 180);
/// The trace at the worst phase: the report's warning orange.
const WORST: RGBColor = RGBColor(214, 95, 0);

/// The PWM frames within [`WINDOW_FRAMES`] of position `at`, as (frame
/// number, luma as run, luma at the worst phase).
fn window(result: &CaseResult, captured: &[f64], info: &WorstPhaseInfo, at: usize) -> Window {
    let frames = &result.acquisition.frames;
    (at.saturating_sub(WINDOW_FRAMES)..(at + WINDOW_FRAMES + 1).min(frames.len()))
        .filter(|&k| frames[k].segment == Segment::Pwm)
        .map(|k| (frames[k].index as f64, captured[k], info.luma[k]))
        .collect()
}

/// Points of [`window`].
type Window = Vec<(f64, f64, f64)>;

/// The x range (half a frame beyond each end) and the padded y range that
/// hold `window` and the `levels` drawn across it.
fn ranges(window: &Window, levels: [Option<f64>; 2]) -> Result<(f64, f64, f64, f64), String> {
    let values = window
        .iter()
        .flat_map(|p| [p.1, p.2])
        .chain(levels.into_iter().flatten())
        .filter(|v| v.is_finite());
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (Some(first), Some(last)) = (window.first(), window.last()) else {
        return Err("no PWM frames around the frame at the worst phase".to_string());
    };
    if !(lo.is_finite() && hi.is_finite()) {
        return Err("the trace has no finite values".to_string());
    }
    let pad = ((hi - lo) * 0.08).max(1.0);
    Ok((first.0 - 0.5, last.0 + 0.5, (lo - pad).max(0.0), hi + pad))
}

/// ROI `info.roi` of `result` frame by frame, as run and at the worst
/// phase (`info.luma`), over the PWM frames within [`WINDOW_FRAMES`] of
/// frame `info.frame`, with its OFF level and, for an FDI verdict, the
/// level that FDI `fdi_min` puts on the PWM minimum (`L_OFF (1 +
/// FDI_min)`, Deegan 2018 Eq. 3). The frame at the worst phase is marked.
pub fn worst_phase_svg(
    result: &CaseResult,
    info: &WorstPhaseInfo,
    fdi_min: Option<f64>,
) -> Result<String, ChartError> {
    let err = |e: &dyn std::fmt::Display| ChartError {
        chart: format!("worst phase {}", result.case.id),
        message: e.to_string(),
    };
    let acq = &result.acquisition;
    let i = acq
        .rois
        .iter()
        .position(|r| r.name == info.roi)
        .ok_or_else(|| err(&format!("the case has no ROI `{}`", info.roi)))?;
    let captured = &acq.rois[i].luma;
    if info.luma.len() != acq.frames.len() {
        return Err(err(&format!(
            "{} worst-phase values for {} frames",
            info.luma.len(),
            acq.frames.len()
        )));
    }
    let at = acq
        .frames
        .iter()
        .position(|f| f.index == info.frame)
        .ok_or_else(|| err(&format!("the case has no frame {}", info.frame)))?;
    let off = result.metrics.get(i).and_then(|m| m.levels.off);
    let limit = match (off, fdi_min) {
        (Some(off), Some(min)) if off > 0.0 && info.metric.starts_with("fdi_2018") => {
            Some(off * (1.0 + min))
        }
        _ => None,
    };
    let window = window(result, captured, info, at);
    let (x0, x1, y0, y1) = ranges(&window, [off, limit]).map_err(|m| err(&m))?;

    let mut svg = String::new();
    {
        let e = |e: DrawingAreaErrorKind<std::io::Error>| err(&e);
        let root = SVGBackend::with_string(&mut svg, (760, 230)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let (plot, side) = root.split_horizontally(760 - LEGEND_WIDTH);
        let mut chart = super::linear_axes(
            &plot,
            &super::Axes {
                margin: 10,
                caption: None,
                label_areas: (36, super::y_label_area(y0, y1, super::FONT_FULL_WIDTH)),
                x: x0..x1,
                y: y0..y1,
                desc: ("frame", "ROI luma (DN)"),
                font: super::FONT_FULL_WIDTH,
            },
        )
        .map_err(|m| err(&m))?;
        let mut legend = Vec::new();
        for (level, label, colour) in [
            (off, "OFF level", RGBColor(60, 60, 60)),
            (limit, "FDI limit on the minimum", RGBColor(200, 0, 0)),
        ] {
            let Some(level) = level else { continue };
            chart
                .draw_series(DashedLineSeries::new(
                    [(x0, level), (x1, level)],
                    6,
                    4,
                    colour.stroke_width(1),
                ))
                .map_err(e)?;
            legend.push((Swatch::Dashed(colour), format!("{label} {level:.2} DN")));
        }
        for (colour, pick) in [
            (
                AS_RUN,
                (|p: &(f64, f64, f64)| p.1) as fn(&(f64, f64, f64)) -> f64,
            ),
            (WORST, |p: &(f64, f64, f64)| p.2),
        ] {
            let points: Vec<(f64, f64)> = window.iter().map(|p| (p.0, pick(p))).collect();
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(1)))
                .map_err(e)?;
            chart
                .draw_series(
                    points
                        .into_iter()
                        .map(|p| Circle::new(p, 2, colour.filled())),
                )
                .map_err(e)?;
        }
        let shown = (info.frame as f64, info.luma[at]);
        chart
            .draw_series(std::iter::once(Circle::new(
                shown,
                5,
                WORST.stroke_width(2),
            )))
            .map_err(e)?;
        legend.push((Swatch::Line(AS_RUN), format!("{} as run", info.roi)));
        legend.push((
            Swatch::Line(WORST),
            format!(
                "{} at the worst phase ({:.3} cycles at frame {})",
                info.roi, info.phase_cycles, info.frame
            ),
        ));
        legend.push((
            Swatch::Dot(WORST),
            format!("frame {}: {:.2} DN", info.frame, shown.1),
        ));
        draw_legend(&side, &legend, 12, "entries").map_err(|m| err(&m))?;
        root.present().map_err(e)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{CaseInfo, Verdict};

    /// Absolute tolerance on FDI between the value reported for the worst
    /// phase and the one recomputed from the worst-phase trace: both come
    /// from the same closed form, apart from the rounding of the phase.
    const FDI_TOLERANCE: f64 = 1e-9;

    /// The daylight plan with a 5 ms exposure (shorter than `(1 - D) / f`
    /// for many cases, so the LED can vanish at some phase), run on the
    /// simulator, and its model.
    fn daylight_at_5_ms() -> (
        ledflicker_core::plan::Plan,
        Vec<CaseResult>,
        crate::model::Results,
    ) {
        let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
        let text = std::fs::read_to_string(root.join("test-plans/daylight.toml")).unwrap();
        assert!(
            text.contains("exposure-ms = 11.111"),
            "daylight.toml changed"
        );
        let text = text.replace("exposure-ms = 11.111", "exposure-ms = 5.0");
        let dir = std::env::temp_dir().join(format!("ledflicker-worst-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("daylight-5ms.toml");
        std::fs::write(&path, text).unwrap();
        let plan = ledflicker_core::plan::load(&path).unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let sim = ledflicker_core::backend::sim::Simulator::new(&plan);
        let results = ledflicker_core::runner::run(&plan, &cases, &sim, Some(2), &|_| {}).unwrap();
        let model = ledflicker_core::model::assemble(&plan, "sim-ideal", &results);
        let _ = std::fs::remove_dir_all(&dir);
        (plan, results, model)
    }

    /// The case fails (or is informational) on a worst-phase FDI that its
    /// trace as run does not show: the FDI as run differs from it.
    fn fails_on_an_unseen_worst_phase(c: &CaseInfo) -> bool {
        c.verdict != Verdict::Pass
            && c.checks.iter().any(|k| {
                let as_run = c.rois.iter().find(|r| r.name == k.roi);
                let as_run = as_run.and_then(|r| r.metrics.get("fdi_2018").copied().flatten());
                k.metric == "fdi_2018_worst_phase"
                    && !k.pass
                    && matches!((as_run, k.value), (Some(a), Some(w))
                        if (a - w).abs() > 1e-9 * a.abs().max(w.abs()).max(1.0))
            })
    }

    #[test]
    fn failing_worst_phase_cases_show_the_trace_and_frame_at_the_worst_phase() {
        let (plan, results, model) = daylight_at_5_ms();
        let failing: Vec<(&CaseInfo, &CaseResult)> = model
            .cases
            .resident()
            .zip(&results)
            .filter(|(c, _)| fails_on_an_unseen_worst_phase(c))
            .collect();
        assert!(failing.len() >= 3, "{} failing cases", failing.len());
        for (c, r) in &failing {
            let w = c.worst_phase.as_ref().unwrap_or_else(|| panic!("{}", c.id));
            let frames = &r.acquisition.frames;
            assert_eq!(w.luma.len(), frames.len(), "{}", c.id);
            // FDI (Deegan 2018, Eq. 3) of the worst-phase trace, computed
            // here from its frames: the PWM minimum against the OFF mean.
            let of = |s: Segment| {
                frames
                    .iter()
                    .zip(&w.luma)
                    .filter(move |(f, _)| f.segment == s)
            };
            let off =
                of(Segment::Off).map(|(_, v)| v).sum::<f64>() / of(Segment::Off).count() as f64;
            let min = of(Segment::Pwm)
                .map(|(_, v)| *v)
                .fold(f64::INFINITY, f64::min);
            let fdi = (min - off) / off;
            let reported = c
                .checks
                .iter()
                .find(|k| k.roi == w.roi && k.metric == "fdi_2018_worst_phase")
                .and_then(|k| k.value)
                .unwrap();
            assert!(
                (fdi - reported).abs() <= FDI_TOLERANCE,
                "{}: FDI {fdi} from the worst-phase trace, {reported} reported",
                c.id
            );
            assert_eq!(
                w.fdi_2018.map(|v| (v - fdi).abs() <= FDI_TOLERANCE),
                Some(true)
            );
            // The frame shown at the worst phase is that trace's frame: its
            // ROI pixels average to the trace's value there.
            let frame = w.rendered.as_ref().unwrap();
            assert_eq!(frame.index, w.frame);
            let roi = plan.rois.iter().find(|x| x.name == w.roi).unwrap();
            let mut sum = 0.0;
            for y in roi.y_px..roi.y_px + roi.height_px {
                for x in roi.x_px..roi.x_px + roi.width_px {
                    sum += frame.pixel(x, y).unwrap();
                }
            }
            let mean = sum / f64::from(roi.width_px * roi.height_px);
            let at = frames.iter().position(|f| f.index == w.frame).unwrap();
            assert!(
                (mean - w.luma[at]).abs() < 1e-6,
                "{}: {mean} vs {}",
                c.id,
                w.luma[at]
            );
            assert!(w.sample_frame.is_some(), "{}", c.id);
        }
        // Cases that pass, and those whose trace shows their worst case,
        // carry no such run.
        for c in &model.cases {
            if !fails_on_an_unseen_worst_phase(&c) {
                assert!(c.worst_phase.is_none(), "{}", c.id);
            }
        }
        // The report shows the chart and the frame on each failing case's page.
        let html = crate::html::render(&model, &results, "2026-01-01").unwrap();
        for (c, _) in &failing {
            let start = html
                .find(&format!("id=\"{}-worst-phase\"", c.id))
                .unwrap_or_else(|| panic!("{}: no worst-phase block", c.id));
            let block = &html[start..start + html[start..].find("</div>").unwrap()];
            assert!(block.contains("<svg"), "{}: no chart", c.id);
            assert!(
                block.contains("at the worst phase ("),
                "{}: no legend",
                c.id
            );
            assert!(
                block.contains("src=\"data:image/png;base64,"),
                "{}: no frame",
                c.id
            );
        }
    }
}
