//! `ledflicker simulate --summary`: one condition's metrics as one JSON
//! object, under the names results.json uses.
//!
//! The simulator probe has no scene, so luma is in units of the LED's full
//! ON level: `luma = background + s`, where `s` is the exposure's ON
//! fraction and `background` (>= 0) the steady light in the ROI, which is
//! also the OFF reference `L_OFF`. With no background `L_OFF = 0` and FDI is
//! unbounded or undefined (null with its reason).

use std::collections::BTreeMap;
use std::ops::Range;

use serde::Serialize;

use super::{Banding, Beat, DriveFlicker, HazardClass, PhaseCoverage};
use ledflicker_metrics::metrics::flicker::{Metric, fdi_2018, percent_flicker};
use ledflicker_physics::{PwmDrive, Shutter};

/// The summary object.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// PWM frequency, Hz.
    pub frequency_hz: f64,
    /// Duty, (0, 1].
    pub duty: f64,
    /// Frames simulated.
    pub frames: u64,
    /// Background (= L_OFF) in units of the LED's full ON level.
    pub background: f64,
    /// Lowest, highest and mean luma over the frames.
    pub levels: BTreeMap<&'static str, f64>,
    /// Metric name -> value, `null` when undefined (reason in `reasons`).
    pub metrics: BTreeMap<&'static str, Option<f64>>,
    /// Metric name -> why it is null, or a caveat.
    pub reasons: BTreeMap<&'static str, String>,
    /// FDI is +infinity (no background, the light never vanishes).
    pub contrast_unbounded: bool,
    /// Apparent flicker frequency, Hz (physics).
    pub apparent_frequency_hz: f64,
    /// What the flicker looks like.
    pub hazard_class: HazardClass,
    /// Every named band the apparent frequency falls in.
    pub hazard_matches: Vec<HazardClass>,
    /// Beat period and capture.
    pub beat: Beat,
    /// The drive itself.
    pub drive: DriveFlicker,
    /// Phase coverage of the frames.
    pub phase_coverage: PhaseCoverage,
    /// Banding of a rolling shutter over `sensor_rows`.
    pub banding: Option<Banding>,
    /// Colour KPIs, when a colour scene was given.
    pub colour: Option<super::colour::ColourFlicker>,
}

/// A colour scene for the summary: background RGB and the LED's dies.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourScene {
    /// Background, linear camera RGB in units of the LED's full ON level.
    pub background: super::colour::Rgb,
    /// The dies (one for a white LED, three for an RGB LED).
    pub dies: Vec<super::colour::Die>,
}

/// Simulates `frames` frames of ROI `rows` and summarises them.
pub fn summarise(
    shutter: &Shutter,
    pwm: &PwmDrive,
    rows: Range<u32>,
    frames: u64,
    background: f64,
    sensor_rows: u32,
    colour: Option<&ColourScene>,
) -> Summary {
    let numbers: Vec<u64> = (0..frames).collect();
    // The batched closed form: bit for bit the per-frame values.
    let mut on = Vec::with_capacity(numbers.len());
    shutter.frame_on_fractions(pwm, 0..frames, rows.clone(), &mut on);
    let luma: Vec<f64> = on.iter().map(|&s| background + s).collect();
    let (lo, hi) = shutter.phase_envelope(pwm, rows.clone());
    let envelope = (background + lo, background + hi);
    let min = luma.iter().copied().fold(f64::INFINITY, f64::min);
    let max = luma.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mean = luma.iter().sum::<f64>() / luma.len().max(1) as f64;
    let pf = percent_flicker(min, max);
    let sampling = super::Sampling::Numbered {
        frames: &numbers,
        fps: shutter.fps,
    };
    let analysis = super::analyse_trace(
        &sampling,
        &luma,
        Some(pwm.frequency_hz()),
        shutter.row_offset_s(rows.start),
        Some(envelope),
        pf.value,
    );
    let mut metrics = BTreeMap::new();
    let mut reasons = BTreeMap::new();
    let mut unbounded = false;
    let spectrum = Metric {
        value: analysis.apparent_frequency_spectrum_hz,
        unbounded: false,
        reason: analysis.spectrum_reason.clone(),
    };
    for (name, m) in [
        ("fdi_2018", fdi_2018(min, Some(background))),
        ("percent_flicker", pf),
        (
            "fdi_2018_worst_phase",
            fdi_2018(envelope.0, Some(background)),
        ),
        (
            "percent_flicker_worst_phase",
            percent_flicker(envelope.0, envelope.1),
        ),
        ("apparent_frequency_spectrum_hz", spectrum),
    ] {
        metrics.insert(name, m.value);
        if let Some(r) = m.reason {
            reasons.insert(name, r);
        }
        unbounded |= m.unbounded;
    }
    let fa = super::apparent::apparent_frequency_hz(pwm.frequency_hz(), shutter.fps);
    metrics.insert("apparent_frequency_hz", Some(fa));
    metrics.insert("phase_coverage", Some(analysis.phase_coverage.coverage));
    if let Some(w) = &analysis.phase_coverage.warning {
        reasons.insert("phase_coverage", w.clone());
    }
    Summary {
        frequency_hz: pwm.frequency_hz(),
        duty: pwm.duty(),
        frames,
        background,
        levels: BTreeMap::from([("min", min), ("max", max), ("mean", mean)]),
        metrics,
        reasons,
        contrast_unbounded: unbounded,
        apparent_frequency_hz: fa,
        hazard_class: analysis.hazard_class,
        hazard_matches: analysis.hazard_matches,
        beat: super::apparent::beat(pwm.frequency_hz(), shutter.fps, frames as f64 / shutter.fps),
        drive: super::drive::drive_flicker(pwm.frequency_hz(), pwm.duty()),
        phase_coverage: analysis.phase_coverage,
        banding: super::banding::banding(shutter, pwm, sensor_rows),
        colour: colour.map(|c| {
            super::colour::colour_flicker(
                c.background,
                &c.dies,
                shutter.exposure_s * pwm.frequency_hz(),
            )
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_physics::ShutterModel;

    #[test]
    fn summary_agrees_with_the_closed_form_and_never_holds_nan() {
        let shutter = Shutter {
            model: ShutterModel::Global,
            exposure_s: 0.002,
            fps: 30.0,
        };
        // 91.5 Hz at 30 fps: f_a = 1.5 Hz, a turn-indicator-like beat.
        let pwm = PwmDrive::new(91.5, 0.1, 0.0).unwrap();
        let s = summarise(&shutter, &pwm, 0..1, 600, 0.1, 800, None);
        assert!((s.apparent_frequency_hz - 1.5).abs() < 1e-12);
        assert_eq!(s.hazard_class, HazardClass::TurnIndicatorLike);
        // The exposure (0.183 cycles) fits in the OFF gap: the light vanishes.
        assert!(s.metrics["fdi_2018_worst_phase"].unwrap().abs() < 1e-12);
        let spec = s.metrics["apparent_frequency_spectrum_hz"].unwrap();
        assert!((spec - 1.5).abs() <= 30.0 / 600.0, "{spec}");
        let json = serde_json::to_string(&s).unwrap();
        assert!(!json.contains("NaN") && !json.contains("inf"));
        // No background: FDI is unbounded or 0/0, null with a reason.
        let s = summarise(&shutter, &pwm, 0..1, 600, 0.0, 800, None);
        assert_eq!(s.metrics["fdi_2018"], None);
        assert!(s.reasons.contains_key("fdi_2018"));
    }
}
