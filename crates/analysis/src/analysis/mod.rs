//! Beyond the paper (docs/beyond-the-paper.md): what a case's flicker looks like to a driver
//! and to the light source's own standards.
//!
//! Sits after the runner and beside `metrics`: it reads a finished
//! [`CaseResult`] (traces, frame times, metrics) and the plan's camera, and
//! adds the apparent flicker frequency, a hazard class, the IEEE 1789 /
//! IES view of the drive, the phase coverage of the capture and banding
//! KPIs. The fine maps and `ledflicker advise` work from the physics alone.
//!
//! - [`apparent`]: beat frequency, from the physics and from the spectrum;
//! - [`hazard`]: what the flicker may be taken for (turn indicator, beacon, ...);
//! - [`drive`]: IEEE 1789 risk region and IES Flicker Index of the PWM;
//! - [`light`]: a light source's own waveform (`ledflicker light`): IEEE 1789, SVM, PstLM;
//! - [`phase_fold`]: the flicker signal folded by phase, phase coverage;
//! - [`banding`]: band period, contrast and velocity of a rolling shutter;
//! - [`finemap`]: worst-phase FDI and Percent Flicker over frequency x duty;
//! - [`colour`]: per-channel modulation and chroma shift (RGB and white LEDs);
//! - [`summary`]: `simulate --summary`;
//! - [`timing`]: frame rate, drops and spectrum from a capture's own frame times;
//! - [`roi`]: ROIs drawn on a capture's frame, and proposed from its ON -> OFF step.
//! - [`worst_phase`]: the trace and frame at the worst phase a verdict rests on.

pub mod apparent;
pub mod banding;
pub mod colour;
pub mod drive;
pub mod finemap;
pub mod hazard;
pub mod light;
pub mod light_signal;
pub mod phase_fold;
pub mod roi;
pub mod summary;
pub mod timing;
pub mod worst_phase;

pub use ledflicker_results::analysis::{FineMapInfo, RoiAnalysis};
use serde::{Deserialize, Serialize};

use ledflicker_acquisition::runner::CaseResult;
use ledflicker_metrics::metrics::flicker::Segment;
use ledflicker_physics::PwmDrive;
use ledflicker_plan::plan::{BackendKind, CameraConfig, Plan, RoiKind};

pub use apparent::{ApparentMethod, Beat};
pub use banding::{Banding, FrameBanding};
pub use drive::DriveFlicker;
pub use hazard::HazardClass;
pub use phase_fold::PhaseCoverage;
pub use timing::FrameTiming;

/// When the frames of a trace were taken.
#[derive(Debug, Clone, Copy)]
pub enum Sampling<'a> {
    /// Frame `n` starts at `n / fps` exactly (the simulator's clock).
    Numbered {
        /// Frame numbers.
        frames: &'a [u64],
        /// Frame rate, frames/s.
        fps: f64,
    },
    /// Frames start at their own measured times (captures and rigs).
    Timed(&'a FrameTiming),
}

impl Sampling<'_> {
    /// Frame rate, frames/s.
    pub fn fps(&self) -> f64 {
        match self {
            Sampling::Numbered { fps, .. } => *fps,
            Sampling::Timed(t) => t.fps,
        }
    }

    /// Duration of the capture, seconds.
    pub fn capture_s(&self) -> f64 {
        match self {
            Sampling::Numbered { frames, fps } => frames.len() as f64 / fps,
            Sampling::Timed(t) => t.capture_s,
        }
    }

    /// The spectrum of `luma`: an FFT over regular frames, a direct
    /// Fourier sum over the real times otherwise.
    fn spectrum(&self, luma: &[f64]) -> Result<f64, apparent::SpectrumError> {
        match self {
            Sampling::Timed(t) if !t.regular => {
                timing::dominant_frequency_at_times_hz(&t.times_s, luma, t.fps)
            }
            _ => apparent::dominant_frequency_hz(luma, self.fps()),
        }
    }

    /// (phase, luma) of each frame for a PWM (or beat) at `frequency_hz`.
    fn fold(&self, luma: &[f64], frequency_hz: f64, row_offset_s: f64) -> Vec<(f64, f64)> {
        match self {
            Sampling::Numbered { frames, fps } => {
                phase_fold::fold(frames, luma, frequency_hz, *fps, row_offset_s)
            }
            Sampling::Timed(t) => {
                phase_fold::fold_times(&t.times_s, luma, frequency_hz, row_offset_s)
            }
        }
    }
}

/// Analyses one trace of the PWM segment: its `sampling`, `luma` (DN) of
/// the PWM frames, the PWM `frequency_hz` when known, the ROI's first-row
/// offset `row_offset_s`, its exact `envelope` if known and its Percent
/// Flicker as captured.
///
/// With the frequency known, the apparent frequency is
/// `|f - fps round(f / fps)|` at the frame rate of `sampling`, and frames
/// are folded by PWM phase. Without it, the apparent frequency is the
/// dominant frequency of the spectrum, and frames are folded by the phase
/// of that beat: at frame times `t_n = n / fps` the PWM phase
/// `frac(f t_n)` equals `frac(+-f_a t_n)`, so the bins hit are the same up
/// to a reflection of the circle.
pub fn analyse_trace(
    sampling: &Sampling<'_>,
    luma: &[f64],
    frequency_hz: Option<f64>,
    row_offset_s: f64,
    envelope: Option<(f64, f64)>,
    percent_flicker: Option<f64>,
) -> RoiAnalysis {
    let fps = sampling.fps();
    let resolution = fps / luma.len().max(1) as f64;
    let spectrum = sampling.spectrum(luma);
    let (spectrum_hz, spectrum_reason) = match (&spectrum, frequency_hz) {
        (Ok(s), Some(f)) => {
            let fa = apparent::apparent_frequency_hz(f, fps);
            let note = match apparent::aliased_harmonic(*s, f, fps, resolution) {
                Some(1) => None,
                Some(k) => Some(format!(
                    "the strongest component is PWM harmonic {k} aliased to {s:.4} Hz; the fundamental's alias f_a is {fa:.4} Hz"
                )),
                None => Some(format!(
                    "the strongest component ({s:.4} Hz) is not an alias of the PWM harmonics 1-8 (f_a = {fa:.4} Hz)"
                )),
            };
            (Some(*s), note)
        }
        (Ok(s), None) => (Some(*s), None),
        (Err(e), _) => (None, Some(e.to_string())),
    };
    let visible = percent_flicker.is_some_and(|p| p >= hazard::VISIBLE_PERCENT_FLICKER);
    let (fa, method, fold_hz, row_offset) = match frequency_hz {
        Some(f) => (
            apparent::apparent_frequency_hz(f, fps),
            ApparentMethod::FrameTimes,
            f,
            row_offset_s,
        ),
        None => {
            let s = spectrum_hz.unwrap_or(0.0);
            (s, ApparentMethod::Spectrum, s, 0.0)
        }
    };
    let (hazard_class, hazard_matches) = match (&spectrum, frequency_hz) {
        // A visible beat slower than the capture resolves: a slow pulsing.
        (Err(apparent::SpectrumError::Unresolved(_)), None) if visible => {
            (HazardClass::SlowDrift, Vec::new())
        }
        _ => hazard::classify(fa, percent_flicker),
    };
    let points = sampling.fold(luma, fold_hz, row_offset);
    RoiAnalysis {
        apparent_frequency_spectrum_hz: spectrum_hz,
        spectrum_reason,
        apparent_frequency_hz: fa,
        apparent_method: method,
        hazard_class,
        hazard_matches,
        phase_coverage: phase_fold::coverage_over(
            &points,
            fps,
            sampling.capture_s(),
            fold_hz,
            envelope,
        ),
        folded_bins: phase_fold::bin_extremes(&points, phase_fold::PHASE_BINS),
        envelope,
        spectrum,
    }
}

/// The analysis of one case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseAnalysis {
    /// Apparent frequency and beat.
    pub beat: Beat,
    /// The case's hazard class: the most salient over its LED ROIs.
    pub hazard_class: HazardClass,
    /// The PWM drive before any camera.
    pub drive: DriveFlicker,
    /// Banding KPIs (rolling shutter only).
    pub banding: Option<Banding>,
    /// One per plan ROI, in plan order.
    pub rois: Vec<RoiAnalysis>,
    /// The frame timing of a captured or rig case's PWM frames; `None` for
    /// the simulator, whose frames run on the plan camera's clock.
    #[serde(default)]
    pub timing: Option<FrameTiming>,
    /// The case run again at the worst phase its verdict rests on
    /// ([`worst_phase`]); the model states it, so it is not stored here.
    #[serde(skip)]
    pub worst_phase: Option<worst_phase::WorstPhaseRun>,
}

/// Analyses a finished case. The simulator's frames run on the plan
/// camera's clock (`n / fps`); captured and rig frames carry their own
/// times, which give the frame rate, the fold and the coverage. A case
/// whose PWM frequency is unknown (0) takes its apparent frequency from the
/// spectrum of its LED trace.
pub fn analyse_case(plan: &Plan, r: &CaseResult) -> CaseAnalysis {
    let mut a = analyse_case_deferred(plan, r);
    a.banding = case_banding(plan, r.case.frequency_hz, r.case.duty);
    a
}

/// [`analyse_case`] without the banding KPIs (`banding` is `None`): the
/// band estimator fits every row of the sensor, the costliest analysis of
/// a simulated case, and a large run lists only some of its cases, so
/// their KPIs come later, from [`case_banding`].
pub fn analyse_case_deferred(plan: &Plan, r: &CaseResult) -> CaseAnalysis {
    let cam: &CameraConfig = &plan.dut.camera;
    let (f, delay_s) = case_pwm(plan, r.case.frequency_hz);
    let simulated = plan.dut.backend == BackendKind::Simulator;
    let known = (f > 0.0).then_some(f);
    let shutter = cam.exposure_timing();
    let pwm_frames: Vec<usize> = r
        .acquisition
        .frames
        .iter()
        .enumerate()
        .filter(|(_, fr)| fr.segment == Segment::Pwm)
        .map(|(i, _)| i)
        .collect();
    let numbers: Vec<u64> = pwm_frames
        .iter()
        .map(|&i| r.acquisition.frames[i].index)
        .collect();
    let timing = (!simulated)
        .then(|| {
            let times: Vec<f64> = pwm_frames
                .iter()
                .map(|&i| r.acquisition.frames[i].time_s)
                .collect();
            let source =
                r.acquisition
                    .capture
                    .as_ref()
                    .map_or_else(timing::TimeSource::default, |c| timing::TimeSource {
                        time_base_s: c.time_base_s,
                        stated_fps: c.stated_frame_rate_fps,
                    });
            timing::from_times(&times, &source)
        })
        .flatten();
    let sampling = match &timing {
        Some(t) => Sampling::Timed(t),
        None => Sampling::Numbered {
            frames: &numbers,
            fps: cam.fps,
        },
    };
    let rois: Vec<RoiAnalysis> = r
        .acquisition
        .rois
        .iter()
        .zip(&plan.rois)
        .zip(&r.metrics)
        .map(|((trace, roi), m)| {
            let luma: Vec<f64> = pwm_frames.iter().map(|&i| trace.luma[i]).collect();
            analyse_trace(
                &sampling,
                &luma,
                known,
                shutter.row_offset_s(roi.y_px) - delay_s,
                trace.phase_envelope,
                m.percent_flicker.value,
            )
        })
        .collect();
    let led = || {
        plan.rois
            .iter()
            .zip(&rois)
            .filter(|(roi, _)| roi.kind == RoiKind::Led)
            .map(|(_, a)| a)
    };
    let hazard_class = led()
        .map(|a| a.hazard_class)
        .max()
        .unwrap_or(HazardClass::Steady);
    let (fps, capture_s) = (sampling.fps(), sampling.capture_s());
    let mut beat = match known {
        Some(f) => apparent::beat(f, fps, capture_s),
        None => {
            // The most salient LED ROI (the first of the case's class).
            let measured = led()
                .find(|a| a.hazard_class == hazard_class)
                .or_else(|| rois.first())
                .map_or(Err(apparent::SpectrumError::TooShort(0)), |a| {
                    a.spectrum.clone()
                });
            let resolution = fps / numbers.len().max(1) as f64;
            apparent::beat_from_spectrum(&measured, fps, capture_s, resolution)
        }
    };
    if let Some(t) = &timing {
        beat.note += &timing_note(t);
    }
    CaseAnalysis {
        beat,
        hazard_class,
        drive: drive::drive_flicker(f, r.case.duty),
        banding: None,
        rois,
        timing,
        worst_phase: worst_phase::worst_phase_run(plan, r),
    }
}

/// The PWM frequency and first rising edge (seconds) that a case of
/// `frequency_hz` was made with: the simulator drives the LED off its own
/// clock (`pwm-clock-offset-ppm`) with its first rising edge at
/// `pwm-delay-ms`; a capture's PWM is the case's frequency, at a phase
/// nobody knows.
fn case_pwm(plan: &Plan, frequency_hz: f64) -> (f64, f64) {
    if plan.dut.backend == BackendKind::Simulator {
        (
            frequency_hz * (1.0 + plan.scene.pwm_clock_offset_ppm * 1e-6),
            plan.dut.camera.pwm_delay_s,
        )
    } else {
        (frequency_hz, 0.0)
    }
}

/// The banding KPIs of a case of `frequency_hz` and `duty` (rolling
/// shutter only), as [`analyse_case`] gives them.
pub fn case_banding(plan: &Plan, frequency_hz: f64, duty: f64) -> Option<Banding> {
    let cam = &plan.dut.camera;
    let (f, _) = case_pwm(plan, frequency_hz);
    PwmDrive::new(f, duty, cam.pwm_delay_s)
        .ok()
        .and_then(|pwm| banding::banding(&cam.exposure_timing(), &pwm, cam.sensor_rows))
}

/// How a capture's frame times were used, for the beat's note: the rate
/// with its uncertainty, the times' resolution, the stated rate, the
/// times the analyses use and the dropped frames.
fn timing_note(t: &FrameTiming) -> String {
    // Two significant digits of the uncertainty, and the rate to the same place.
    let places = if t.fps_uncertainty > 0.0 {
        ((-t.fps_uncertainty.log10()).ceil() as i64 + 1).clamp(4, 9) as usize
    } else {
        4
    };
    let resolution = t
        .resolution_s
        .map_or("finer than 1 us".to_string(), seconds_text);
    // Below a billionth the spread is the doubles' rounding of exact times.
    let spread = if t.fps_uncertainty < 0.5e-9 {
        "0 (to 1e-9)".to_string()
    } else {
        format!("{:.places$}", t.fps_uncertainty)
    };
    let mut note = format!(
        "; frame rate {:.places$} +/- {spread} fps (one sigma) fitted to the frames' own times, resolution {resolution}",
        t.fps
    );
    match (t.stated_fps, t.stated_rate_used) {
        (Some(r), true) => {
            note += &format!(
                "; the container states {r} fps, which the fit agrees with, so that rate is used exactly"
            )
        }
        (Some(r), false) => {
            note += &format!(
                "; the container states {r} fps, which the fit does not agree with, so the fitted rate is used"
            )
        }
        (None, _) => {}
    }
    if t.slot_times {
        note += "; the times fit a constant rate to within their resolution, so the fold, the coverage and the spectrum use the fitted frame times";
    }
    if t.dropped_frames > 0 {
        let s = if t.dropped_frames == 1 { "" } else { "s" };
        note += &format!(
            "; {} dropped frame{s} (empty slots of the fit)",
            t.dropped_frames
        );
    }
    if !t.regular {
        note += "; the times are irregular, so the spectrum is a direct Fourier sum over each frame's time";
    }
    note
}

/// A duration in seconds as `1/N s` when it is the inverse of a whole
/// number (time bases are), else in engineering notation.
fn seconds_text(s: f64) -> String {
    let inverse = 1.0 / s;
    if (inverse - inverse.round()).abs() <= 1e-6 * inverse {
        format!("1/{} s", inverse.round())
    } else {
        format!("{s:e} s")
    }
}

/// The ideal linear camera of a plan at `lux`: the luma model the
/// simulator's ideal camera uses (`backend::sim` module docs), for an LED
/// ROI filled `scene.led-fill`.
pub fn ideal_luma_model(plan: &Plan, lux: f64) -> finemap::LumaModel {
    let cam = &plan.dut.camera;
    let k = cam.response_dn_per_cd_m2_s * cam.exposure_s;
    finemap::LumaModel {
        off_dn: (cam.black_level_dn + k * plan.scene.background_luminance_cd_m2(lux))
            .min(cam.full_scale_dn),
        led_peak_dn: k * plan.scene.led_fill * plan.scene.led_luminance_cd_m2,
        full_scale_dn: cam.full_scale_dn,
    }
}

/// Default fine-map frequency axis: 50 Hz to 2 kHz in 1 Hz steps.
pub const FINE_FREQUENCY: finemap::Axis = finemap::Axis {
    start: 50.0,
    step: 1.0,
    count: 1951,
};
/// Default fine-map duty axis: 1 % to 100 % in 1 % steps.
pub const FINE_DUTY: finemap::Axis = finemap::Axis {
    start: 0.01,
    step: 0.01,
    count: 100,
};

/// Why a plan gets no fine maps, if it gets none: they model the ideal,
/// linear, single-exposure simulated camera only.
pub fn fine_maps_note(plan: &Plan) -> Option<String> {
    if plan.dut.backend != ledflicker_plan::plan::BackendKind::Simulator {
        Some(
            "no fine maps: the plan measures captured data or a lab rig, not a simulated camera"
                .to_string(),
        )
    } else if plan.dut.camera.physical.is_some() {
        Some(format!(
            "no fine maps: they model the ideal linear single-exposure camera, and camera `{}` has a physical sensor (HDR merge, tone curve, auto exposure); the per-case worst case over phase covers it",
            plan.dut.camera.name
        ))
    } else if !plan.rois.iter().any(|r| r.kind == RoiKind::Led) {
        Some("no fine maps: the plan has no LED ROI".to_string())
    } else if plan.colour.as_ref().is_some_and(|c| !c.dies.is_empty()) {
        Some("no fine maps: they model one PWM waveform, and the LED's dies ([[scene.led-die]]) each have their own duty and phase; the per-case worst case over phase covers them".to_string())
    } else {
        None
    }
}

/// Fine maps of the plan's camera for its first LED ROI, one per light
/// level; empty when [`fine_maps_note`] says why.
pub fn fine_maps(plan: &Plan) -> Vec<FineMapInfo> {
    if fine_maps_note(plan).is_some() {
        return Vec::new();
    }
    let Some(roi) = plan.rois.iter().find(|r| r.kind == RoiKind::Led) else {
        return Vec::new();
    };
    let shutter = plan.dut.camera.exposure_timing();
    plan.light_levels_lux
        .iter()
        .map(|&lux| {
            let luma = ideal_luma_model(plan, lux);
            let map = finemap::compute(&shutter, roi.rows(), luma, FINE_FREQUENCY, FINE_DUTY);
            FineMapInfo {
                light_lux: lux,
                roi: roi.name.clone(),
                luma,
                summary: map.summary(plan.thresholds.fdi_2018_min),
                map,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_plan::trace::Ratio;

    /// The beat's note states the fitted rate with its uncertainty, the
    /// resolution, the stated rate and the drops.
    #[test]
    fn the_timing_note_states_rate_uncertainty_resolution_and_drops() {
        let slots: Vec<u64> = (0..200).filter(|k| *k != 90).collect();
        let times: Vec<f64> = slots
            .iter()
            .map(|&k| ((k * 1001) as f64 / 30.0).round() / 1000.0)
            .collect();
        let source = timing::TimeSource {
            time_base_s: Ratio::new(1, 1000),
            stated_fps: Ratio::new(30000, 1001),
        };
        let note = timing_note(&timing::from_times(&times, &source).unwrap());
        for part in [
            "frame rate 29.9700 +/- 0.00",
            "fps (one sigma) fitted to the frames' own times, resolution 1/1000 s",
            "the container states 30000/1001 fps, which the fit agrees with, so that rate is used exactly",
            "use the fitted frame times",
            "; 1 dropped frame (empty slots of the fit)",
        ] {
            assert!(note.contains(part), "{part:?} not in {note:?}");
        }
        let exact: Vec<f64> = (0..100).map(|k| k as f64 * 0.04).collect();
        let note = timing_note(&timing::from_times(&exact, &Default::default()).unwrap());
        assert!(note.contains("frame rate 25.0000 +/- "), "{note}");
    }
}
