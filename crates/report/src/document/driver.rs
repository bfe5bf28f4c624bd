//! "What the driver sees": the report's section for a plan with
//! `[display]`. The monitor and the viewing geometry as the plan set them,
//! the limit, and per listed case and LED ROI the visibility index with a
//! reading in plain words (docs/visibility.md). Every field is text to
//! print; the HTML and the PDF lay it out alike.

use serde::Serialize;

use crate::model::{CaseInfo, Results, RoiKind};
use crate::util::fixed;

/// An index at or below this is a steady light on the monitor: the
/// rounding noise of a locked PWM's series is about 1e-15, and an 8-bit
/// monitor's smallest step on a 1 cd/m^2 light gives more than 1e-3.
const STEADY_MAX: f64 = 1e-3;

/// The section's content.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriverView {
    /// The monitor and the viewing geometry: (label, text) rows.
    pub display: Vec<(String, String)>,
    /// What the index is compared with: the plan's `visibility-max`, or
    /// the threshold 1 for information when the plan sets no limit.
    pub limit: String,
    /// The plan's `visibility-max`, if set.
    pub limit_value: Option<f64>,
    /// One sentence over the listed cases: how many are seen, the worst.
    pub reading: String,
    /// One row per listed case and LED ROI.
    pub rows: Vec<DriverRow>,
    /// One row per listed case and LED ROI with a colour (a plan with
    /// `scene.led-chromaticity-xy`); empty otherwise.
    pub colour: Vec<ColourRow>,
}

/// The colour of one LED ROI of one case over the PWM segment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ColourRow {
    /// Case id.
    pub case: String,
    /// ROI name.
    pub roi: String,
    /// Δu'v', 4 decimals, or "n/a".
    pub delta_uv: String,
    /// The signal colour judged against, or "—".
    pub region: String,
    /// PWM frames outside the region, or "—" without a region.
    pub outside: String,
    /// Some frame's colour left the region.
    pub over: bool,
    /// The reading in plain words.
    pub reading: String,
    /// FMI of the R, G and B planes, 3 decimals each, "R / G / B"; "—"
    /// when not computed.
    pub planes_fmi: String,
    /// Path of the ROI's u′v′ diagram in the report's charts.
    pub chart: String,
    /// What Δu′v′ is measured from, in words: "the colour the frames fuse
    /// to", or for an LED of dies "the colour the dies fuse to".
    pub reference: String,
}

/// One LED ROI of one case.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriverRow {
    /// Case id.
    pub case: String,
    /// "10 lux, 119 Hz, 30.0 %", or "conditions unknown".
    pub conditions: String,
    /// ROI name.
    pub roi: String,
    /// The index, 2 decimals, or "n/a".
    pub index: String,
    /// The index exceeds the limit (the threshold 1 without one).
    pub over: bool,
    /// Frequency of the most visible component, Hz, or "—".
    pub peak_hz: String,
    /// Mean displayed luminance, cd/m^2, or "—".
    pub luminance: String,
    /// The reading in plain words.
    pub reading: String,
}

/// The section of `results`, `None` for a plan without `[display]`;
/// `listed` says which cases the report lists.
pub fn driver_view(results: &Results, listed: impl Fn(&str) -> bool) -> Option<DriverView> {
    let d = results.display.as_ref()?;
    let eotf = d.eotf.title();
    let display = vec![
        (
            "Monitor".to_string(),
            format!(
                "{} Hz refresh, each camera frame held until the next is shown; {eotf} transfer curve; white {} cd/m², black {} cd/m² (preset {})",
                fixed(d.refresh_hz, 1),
                fixed(d.peak_cd_m2, 1),
                fixed(d.black_cd_m2, 3),
                d.preset.as_str()
            ),
        ),
        (
            "Camera code".to_string(),
            format!(
                "{} DN shown as white, 0 DN as black",
                fixed(d.full_scale_dn, 1)
            ),
        ),
        (
            "Viewing".to_string(),
            format!(
                "camera image {} px shown {} mm wide, seen from {} mm: 1 px subtends {} arcmin",
                d.image_width_px,
                fixed(d.image_width_mm, 1),
                fixed(d.distance_mm, 0),
                fixed(
                    (d.image_width_mm / f64::from(d.image_width_px) / d.distance_mm)
                        .atan()
                        .to_degrees()
                        * 60.0,
                    2
                )
            ),
        ),
    ];
    let limit_value = results.thresholds.visibility_max;
    let bound = limit_value.unwrap_or(1.0);
    let limit = match limit_value {
        Some(v) => format!(
            "the plan's limit visibility-max = {v}: a judged case whose LED ROI is above it fails"
        ),
        None => "no limit set (visibility-max): the index is shown against the threshold 1 and judges nothing".to_string(),
    };
    let rows: Vec<DriverRow> = results
        .cases
        .resident()
        .filter(|c| listed(&c.id))
        .flat_map(|c| rows_of(c, bound))
        .collect();
    let colour = results
        .cases
        .resident()
        .filter(|c| listed(&c.id))
        .flat_map(colour_rows_of)
        .collect();
    Some(DriverView {
        display,
        limit,
        limit_value,
        reading: overall(&rows, results),
        rows,
        colour,
    })
}

/// The colour rows of a case's LED ROIs that have a colour.
fn colour_rows_of(case: &CaseInfo) -> Vec<ColourRow> {
    case.rois
        .iter()
        .enumerate()
        .filter(|(_, r)| r.kind == RoiKind::Led && r.metrics.contains_key("delta_uv"))
        .map(|(k, r)| {
            let delta = r.metrics.get("delta_uv").copied().flatten();
            let outside = r
                .metrics
                .get("frames_outside_signal_colour")
                .copied()
                .flatten();
            let region = r.signal_colour.clone();
            let reading = match (delta, &region, outside) {
                (None, _, _) => "no PWM frame has light: no colour".to_string(),
                (Some(_), Some(name), Some(n)) if n > 0.0 => format!(
                    "its colour leaves the {name} region in {n:.0} frames: a {name} light that does not always read as {name}"
                ),
                (Some(d), Some(name), _) => format!(
                    "stays {name} in every frame{}",
                    if d > 1e-6 { " though its colour moves" } else { "" }
                ),
                (Some(d), None, _) if d > 1e-6 => "its colour moves from frame to frame".to_string(),
                (Some(_), None, _) => "one colour in every frame".to_string(),
            };
            ColourRow {
                case: case.id.clone(),
                roi: r.name.clone(),
                delta_uv: delta.map_or("n/a".to_string(), |d| fixed(d, 4)),
                region: region.clone().unwrap_or_else(|| "—".to_string()),
                outside: outside.map_or("—".to_string(), |n| format!("{n:.0}")),
                over: outside.is_some_and(|n| n > 0.0),
                reading,
                planes_fmi: planes_fmi(r),
                chart: crate::document::uv_chart_path(&case.id, k),
                reference: match r.delta_uv_reference.as_deref() {
                    Some("time-average") => "the colour the dies fuse to",
                    _ => "the colour the frames fuse to",
                }
                .to_string(),
            }
        })
        .collect()
}

/// The FMI of each colour plane of `r`, "R / G / B".
fn planes_fmi(r: &crate::model::RoiInfo) -> String {
    let values: Option<Vec<String>> = ["fmi_r", "fmi_g", "fmi_b"]
        .iter()
        .map(|k| {
            r.metrics
                .get(*k)
                .map(|v| v.map_or("n/a".to_string(), |v| fixed(v, 3)))
        })
        .collect();
    values.map_or("—".to_string(), |v| v.join(" / "))
}

fn rows_of(case: &CaseInfo, bound: f64) -> Vec<DriverRow> {
    let conditions = if case.duty > 0.0 {
        format!(
            "{} lux, {} Hz, {} %",
            case.light_lux,
            case.frequency_hz,
            fixed(case.duty * 100.0, 1)
        )
    } else {
        "conditions unknown".to_string()
    };
    case.rois
        .iter()
        .filter(|r| r.kind == RoiKind::Led)
        .map(|r| {
            let get = |k: &str| r.metrics.get(k).copied().flatten();
            let index = get("visibility");
            let peak = get("visibility_peak_hz");
            let reading = match index {
                None => format!(
                    "not computed: {}",
                    r.reasons
                        .get("visibility")
                        .map_or("no reason recorded", String::as_str)
                ),
                Some(v) => reading(v, peak, bound),
            };
            DriverRow {
                case: case.id.clone(),
                conditions: conditions.clone(),
                roi: r.name.clone(),
                index: index.map_or("n/a".to_string(), |v| fixed(v, 2)),
                over: index.is_some_and(|v| v > bound),
                peak_hz: peak.map_or("—".to_string(), |f| fixed(f, 2)),
                luminance: get("display_luminance_cd_m2")
                    .map_or("—".to_string(), |l| fixed(l, 2)),
                reading,
            }
        })
        .collect()
}

/// The index `v` in words: steady, below the threshold, or seen, with
/// what the most visible component looks like. `bound` is the limit.
fn reading(v: f64, peak_hz: Option<f64>, bound: f64) -> String {
    if v <= STEADY_MAX {
        return "steady on the monitor: no flicker reaches the screen".to_string();
    }
    let at = |f: f64| {
        // The bands follow the report's hazard classes (the Method
        // section): a slow pulsing a driver can count, the 10-25 Hz peak
        // of flicker sensitivity (de Lange 1958), and faster flicker.
        let what = if f < 4.0 {
            "a slow pulsing"
        } else if f < 10.0 {
            "a flicker"
        } else if f <= 25.0 {
            "a flicker near the eye's most sensitive rate"
        } else {
            "a fast flicker"
        };
        format!("{what} at {} Hz", fixed(f, 1))
    };
    let seen = if v <= 1.0 {
        format!(
            "below the standard observer's threshold (it needs {} times this modulation)",
            fixed(1.0 / v, 1)
        )
    } else {
        let what = peak_hz.map_or("flicker".to_string(), at);
        // Two decimals below 10, so that 1.02 does not read as "1.0 times".
        format!(
            "seen: {what}, {} times the modulation at threshold",
            fixed(v, if v < 10.0 { 2 } else { 1 })
        )
    };
    if v > bound && bound != 1.0 {
        format!("{seen}; above the limit {bound}")
    } else {
        seen
    }
}

/// One sentence over the rows.
fn overall(rows: &[DriverRow], results: &Results) -> String {
    let seen: Vec<&DriverRow> = rows
        .iter()
        .filter(|r| r.index.parse::<f64>().is_ok_and(|v| v > 1.0))
        .collect();
    let cases = |rs: &[&DriverRow]| {
        let mut ids: Vec<&str> = rs.iter().map(|r| r.case.as_str()).collect();
        ids.dedup();
        ids.len()
    };
    let all: Vec<&DriverRow> = rows.iter().collect();
    let listed = cases(&all);
    let worst = rows
        .iter()
        .filter_map(|r| r.index.parse::<f64>().ok().map(|v| (v, r)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let of = if listed < results.cases.len() {
        format!("Of the {listed} cases listed here")
    } else {
        format!("Of the {listed} cases")
    };
    match (seen.is_empty(), worst) {
        (_, None) => format!("{of}, none has a visibility index."),
        (true, Some((v, r))) => format!(
            "{of}, none flickers visibly on the monitor for the standard observer; the highest index is {} ({}, {}).",
            fixed(v, 2),
            r.case,
            r.roi
        ),
        (false, Some((v, r))) => format!(
            "{of}, {} {} an LED whose flicker the standard observer sees on the monitor (index above 1); the most visible is {}, {}: {}.",
            cases(&seen),
            if cases(&seen) == 1 { "shows" } else { "show" },
            r.case,
            r.roi,
            reading(v, r.peak_hz.parse().ok(), 1.0)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_locked_pwm_reads_as_steady_and_a_beat_as_seen() {
        assert!(reading(1e-9, None, 1.0).starts_with("steady"));
        let below = reading(0.25, Some(30.0), 1.0);
        assert!(
            below.contains("below") && below.contains("4.0 times"),
            "{below}"
        );
        let seen = reading(9.05, Some(1.0), 1.0);
        assert!(
            seen.starts_with("seen: a slow pulsing at 1.0 Hz") && seen.contains("9.05 times"),
            "{seen}"
        );
        assert!(reading(6.1, Some(20.0), 1.0).contains("most sensitive"));
        assert!(!reading(1.5, Some(30.0), 2.0).contains("limit"));
        assert!(reading(2.5, Some(30.0), 2.0).ends_with("above the limit 2"));
    }

    /// The fixture plan at 33 Hz (a 3 Hz beat at 30 fps, seen) and 150 Hz
    /// (locked: steady), 20 % duty; with a night `[display]` and
    /// `visibility-max = 1` when `display`.
    fn run(display: bool) -> crate::document::Document {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("tests/fixtures/plans/base.toml");
        let mut text = std::fs::read_to_string(path)
            .unwrap()
            .replace(
                "frequencies-hz = [60.0, 150.0]",
                "frequencies-hz = [33.0, 150.0]",
            )
            .replace("duty-cycles = [0.2, 0.5]", "duty-cycles = [0.2]");
        if display {
            text = text.replace("[thresholds]", "[thresholds]\nvisibility-max = 1.0");
            text.push_str("\n[display]\npreset = \"night\"\n");
        }
        let plan =
            ledflicker_core::plan::parse(&text, std::path::Path::new("vis.toml"), String::new())
                .unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let sim = ledflicker_core::backend::sim::Simulator::new(&plan);
        let results = ledflicker_core::runner::run(&plan, &cases, &sim, Some(2), &|_| {}).unwrap();
        let model = ledflicker_core::model::assemble(&plan, "sim-ideal", &results);
        crate::document::Document::build(&model, &results, "2026-01-01", Vec::new()).unwrap()
    }

    #[test]
    fn the_driver_section_reads_each_case_and_appears_only_with_a_display() {
        let doc = run(true);
        let view = doc.driver().expect("a plan with [display] has the section");
        assert_eq!(view.limit_value, Some(1.0));
        assert!(view.display[0].1.starts_with("60.0 Hz refresh"), "{view:?}");
        assert!(view.display[0].1.contains("white 50.0 cd/m²"), "{view:?}");
        // One row per case (one LED ROI), each with the index of results.json.
        assert_eq!(view.rows.len(), doc.results.cases.len());
        for (row, case) in view.rows.iter().zip(&doc.results.cases) {
            let v = case.rois[0].metrics["visibility"].unwrap();
            assert_eq!(row.index, fixed(v, 2));
            assert_eq!(row.over, v > 1.0);
        }
        let beat = &view.rows[0];
        assert!(
            beat.over && beat.reading.starts_with("seen: a slow pulsing at 3.0 Hz"),
            "{beat:?}"
        );
        assert!(
            view.rows[1].reading.starts_with("steady"),
            "{:?}",
            view.rows[1]
        );
        assert!(view.reading.contains("1 shows an LED"), "{}", view.reading);

        let html = crate::html::render_document(&doc).unwrap();
        let section = html
            .split("<h2 id=\"driver\">")
            .nth(1)
            .expect("the section");
        assert!(
            section.starts_with("3. What the driver sees"),
            "{section:.80}"
        );
        let section = section.split("<h2").next().unwrap();
        assert!(
            section.contains(&format!("<b>{}</b>", beat.index)),
            "{section}"
        );
        assert!(html.contains("<a href=\"#driver\">What the driver sees</a>"));
        assert!(html.contains("<h2 id=\"verdicts\">4. Every case</h2>"));
        let every = html.split("<h2 id=\"verdicts\">").nth(1).unwrap();
        let every = every.split("</table>").next().unwrap();
        assert!(
            every.contains("<th title=\"Visibility on the monitor\">visible</th>"),
            "{every}"
        );
        assert!(every.contains(&format!("<td class=\"num\">{}</td>", beat.index)));
        #[cfg(feature = "pdf")]
        {
            let typ = crate::pdf::render_markup(&doc).unwrap();
            assert!(typ.contains("= What the driver sees"));
            assert!(
                typ.contains(&format!("*#\"{}\"*", beat.index)),
                "bold index"
            );
        }

        let doc = run(false);
        assert!(doc.driver().is_none());
        let html = crate::html::render_document(&doc).unwrap();
        assert!(!html.contains("driver") && !html.contains("Visibility on the monitor"));
        assert!(html.contains("<h2 id=\"verdicts\">3. Every case</h2>"));
        #[cfg(feature = "pdf")]
        assert!(
            !crate::pdf::render_markup(&doc)
                .unwrap()
                .contains("driver sees")
        );
    }
}
