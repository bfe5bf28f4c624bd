//! The fitted camera as a profile of `reference-data/cameras/` (the
//! physical camera of docs/camera-model.md: one capture, no auto exposure,
//! no noise, a gamma tone curve), and the closed loop: the simulator renders
//! the calibration scene through that profile and the prediction is
//! compared with the measured row profile.

use std::fmt::Write as _;
use std::path::Path;

use super::Calibration;
use ledflicker_acquisition::backend::Backend;
use ledflicker_acquisition::backend::sim::Simulator;
use ledflicker_plan::plan::bounds::MIN_LIGHT_LUX;

/// Full well of the written sensor, electrons: any value works, the
/// sensitivity is scaled to it.
const FULL_WELL_E: f64 = 10_000.0;
/// LED luminance of the closed-loop scene, cd/m^2; the written sensitivity
/// makes the LED reach the fitted level at this luminance.
pub const REFERENCE_LED_CD_M2: f64 = 1000.0;

/// Settings of the written profile that the frames do not give.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileOptions {
    /// Profile name (`[camera] name`).
    pub name: String,
    /// Frame rate, frames per second; `None`: 30, or less when the readout
    /// needs it.
    pub fps: Option<f64>,
}

/// Frame rate written to the profile.
pub fn frame_rate(cal: &Calibration, opts: &ProfileOptions) -> f64 {
    opts.fps.unwrap_or_else(|| {
        let readout = cal.line_time_us * 1e-6 * cal.frame_size.1 as f64;
        30f64.min(0.95 / readout.max(1e-9))
    })
}

/// Exposure written to the profile, seconds: the fitted value, or its
/// upper bound when undetermined.
fn exposure_s(cal: &Calibration) -> f64 {
    cal.exposure_us
        // Two readings: the fitted one, which renders the frames back (the
        // command writes no profile file then).
        .or(cal.solutions.first().map(|s| s.exposure_us))
        .or(cal.exposure_us_max)
        .unwrap_or(cal.line_time_us)
        * 1e-6
}

/// The profile text.
pub fn profile_toml(cal: &Calibration, opts: &ProfileOptions) -> String {
    let mut t = String::new();
    let exposure = exposure_s(cal);
    header(&mut t, cal);
    camera_timing(&mut t, cal, opts, exposure);
    output_levels(&mut t, cal);
    sensor_and_tone(&mut t, cal, exposure);
    t
}

/// The comment block: what was fitted, from which files, how well.
fn header(t: &mut String, cal: &Calibration) {
    let _ = writeln!(
        t,
        "# Camera profile fitted by `ledflicker calibrate` (docs/calibration.md) to\n# {} frame(s) of a {} Hz PWM light, rows {}..{} of {}x{} frames:",
        cal.frames,
        cal.frequency_hz,
        cal.roi[1],
        cal.roi[1] + cal.roi[3],
        cal.frame_size.0,
        cal.frame_size.1
    );
    for s in &cal.sources {
        let _ = writeln!(t, "#   {}  sha256 {}", s.path, s.sha256);
    }
    let _ = writeln!(
        t,
        "# Each value's comment gives its one-sigma uncertainty. Model: the physical\n# camera of docs/camera-model.md with one capture, fixed exposure, no noise.\n# Measured minus fitted row profile: RMS {:.4} of full scale.\n",
        cal.fit_rms
    );
}

/// `[camera]` from its name to `pwm-delay-ms`: identity, sensor size,
/// line time, exposure (`exposure`, seconds), frame rate and PWM phase.
fn camera_timing(t: &mut String, cal: &Calibration, opts: &ProfileOptions, exposure: f64) {
    let f = cal.frequency_hz;
    let fps = frame_rate(cal, opts);
    let _ = writeln!(t, "[camera]\nname = {}", toml_str(&opts.name));
    let _ = writeln!(
        t,
        "description = {}",
        toml_str(&format!(
            "Fitted from {} frame(s) at {f} Hz: {:.4} us per line, gamma {:.3}",
            cal.frames, cal.line_time_us, cal.gamma
        ))
    );
    let _ = writeln!(
        t,
        "shutter = \"rolling\"\nsensor-rows = {}\nsensor-columns = {}",
        cal.frame_size.1, cal.frame_size.0
    );
    let _ = writeln!(
        t,
        "# {:.5} +- {:.5} us (band period {:.4} rows at {f} Hz).\nline-time-us = {:.6}",
        cal.line_time_us, cal.line_time_us_sigma, cal.band_period_rows, cal.line_time_us
    );
    exposure_comment(t, cal, exposure);
    let _ = writeln!(t, "exposure-ms = {:.7}", exposure * 1e3);
    let _ = writeln!(
        t,
        "# Not measured: a still frame has no frame rate ({}).\nframe-rate-fps = {fps}",
        if opts.fps.is_some() {
            "given with --fps"
        } else {
            "default"
        }
    );
    let _ = writeln!(
        t,
        "# PWM phase of the calibration frame (first rising edge after frame 0 starts).\npwm-delay-ms = {:.7}",
        pwm_delay_s(cal) * 1e3
    );
}

/// How the exposure written (`exposure`, seconds) was found: fitted with
/// its sigma, or a bound when the frame cannot determine it.
fn exposure_comment(t: &mut String, cal: &Calibration, exposure: f64) {
    match (cal.exposure_us, cal.exposure_us_sigma) {
        (Some(e), Some(s)) => {
            let _ = writeln!(
                t,
                "# {e:.2} +- {s:.2} us, from the width of the band edges."
            );
        }
        _ if !cal.solutions.is_empty() => {
            let _ = writeln!(
                t,
                "# Two readings fit alike (exposure and duty swapped); the fitted one, {:.2} us.",
                exposure * 1e6
            );
        }
        _ => match cal.exposure_us_min {
            Some(lo) => {
                let _ = writeln!(
                    t,
                    "# Undetermined (rows clip; only duty + exposure is fixed): {lo:.2} to {:.2} us,\n# written as the upper bound. Calibrate with --duty or below clipping to fix it.",
                    exposure * 1e6
                );
            }
            None => {
                let _ = writeln!(
                    t,
                    "# Undetermined (edges sharper than a row): at most {:.2} us, written as the bound.",
                    exposure * 1e6
                );
            }
        },
    }
}

/// `black-level-dn`, `full-scale-dn` and `saturation-dn`, each with how
/// it was found.
fn output_levels(t: &mut String, cal: &Calibration) {
    match (cal.black_level_dn, cal.black_level_dn_sigma) {
        (Some(b), Some(s)) => {
            let _ = writeln!(t, "# {b:.2} +- {s:.2} DN.");
        }
        _ => {
            let _ = writeln!(
                t,
                "# Undetermined: between 0 and the dark level {:.2} DN (black level and ambient\n# light trade off); the fitted pair is written.",
                cal.black_level_dn_max.unwrap_or(0.0)
            );
        }
    }
    let _ = writeln!(t, "black-level-dn = {:.4}", cal.model_black_dn);
    let clip = match (cal.saturation_dn, cal.saturation_dn_min) {
        (Some(s), _) => {
            let _ = writeln!(t, "# Rows clip at {s:.2} DN in the calibration frame.");
            s
        }
        (None, min) => {
            let _ = writeln!(
                t,
                "# No row clipped (brightest {:.2} DN): clipping is at least that; the output range is written.",
                min.unwrap_or(0.0)
            );
            cal.full_scale_dn
        }
    };
    let _ = writeln!(t, "full-scale-dn = {clip:.4}\nsaturation-dn = {clip:.4}\n");
}

/// `[camera.sensor]` (relative sensitivity at exposure `exposure`,
/// seconds) and `[camera.tone]` (the fitted gamma).
fn sensor_and_tone(t: &mut String, cal: &Calibration, exposure: f64) {
    let bits = if cal.full_scale_dn > 255.0 { 16 } else { 8 };
    let sensitivity = cal.led_level * FULL_WELL_E / (exposure * REFERENCE_LED_CD_M2);
    let _ = writeln!(
        t,
        "[camera.sensor]\n# Relative: the frames give the light's level ({:.4} +- {:.4} of white at full\n# ON), not the absolute sensitivity; this value reaches that level for an LED\n# of {REFERENCE_LED_CD_M2} cd/m^2.\nsensitivity-e-per-cd-m2-s = {sensitivity:.6}\nfull-well-e = {FULL_WELL_E}\n# Noise is not fitted.\nread-noise-e = 0.0\nshot-noise = false\nadc-bits = 16\n",
        cal.led_level, cal.led_level_sigma
    );
    let _ = writeln!(
        t,
        "[camera.tone]\n# y = u^(1/gamma), gamma {:.4} +- {:.4}.\ncurve = \"gamma\"\ngamma = {:.6}\noutput-bits = {bits}",
        cal.gamma, cal.gamma_sigma, cal.gamma
    );
}

/// First PWM rising edge after frame 0 starts, seconds, such that the first
/// analysed row sees the fitted phase: `phase = (y0 t_line - delay) f`.
fn pwm_delay_s(cal: &Calibration) -> f64 {
    let f = cal.frequency_hz;
    let cycles = cal.roi[1] as f64 * cal.line_time_us * 1e-6 * f - cal.phase_cycles;
    ledflicker_physics::pwm::wrap_unit(cycles) / f
}

fn toml_str(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => {}
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A plan that renders the calibration scene (frame 0) through the profile
/// at `profile`: one ROI per analysed row, one PWM case at the light's
/// frequency and duty, ambient light matching the fitted level.
pub fn closed_loop_plan(cal: &Calibration, profile: &Path, fps: f64) -> String {
    // Ambient: c0 = sens T L_bg / full well, with the LED scaled to c1.
    // A plan's light starts at its lowest valid level: no ambient light is
    // that level, whose signal (about 3e-8 of the LED's) no output resolves.
    let lux = (std::f64::consts::PI * REFERENCE_LED_CD_M2 * cal.ambient_level.max(0.0)
        / cal.led_level.max(1e-12))
    .max(MIN_LIGHT_LUX);
    let mut t = format!(
        "format-version = 2\n\n[plan]\nid = \"calibration-check\"\ntitle = \"Closed loop of ledflicker calibrate\"\n\n[sequence]\non-s = 0.0\noff-s = 0.0\npwm-s = {}\n\n[light]\nlevels-lux = [{lux:?}]\n\n[grid]\nfrequencies-hz = [{:?}]\nduty-cycles = [{:?}]\n\n[dut]\nbackend = \"simulator\"\ncamera-profile = {}\n\n[scene]\nbackground-reflectance = 1.0\nled-luminance-cd-m2 = {REFERENCE_LED_CD_M2:?}\nled-fill = 1.0\n\n[thresholds]\nfdi-2018-min = 0.1\n",
        2.0 / fps,
        cal.frequency_hz,
        cal.model_duty.clamp(1e-6, 1.0),
        toml_str(&profile.display().to_string())
    );
    for r in 0..cal.rows as u32 {
        let _ = write!(
            t,
            "\n[[roi]]\nname = \"r{r}\"\nx-px = {}\ny-px = {}\nwidth-px = {}\nheight-px = 1\n",
            cal.roi[0],
            cal.roi[1] + r,
            cal.roi[2]
        );
    }
    t
}

/// The simulator's row profile of frame 0 through the profile at
/// `profile`, and its RMS against the measured profile as a fraction of
/// full scale. Errors name what failed (an invalid profile is a bug here).
pub fn closed_loop(cal: &Calibration, profile: &Path, fps: f64) -> Result<(Vec<f64>, f64), String> {
    let text = closed_loop_plan(cal, profile, fps);
    let plan_path = profile.with_extension("closed-loop.toml");
    // One case, simulated and never reported: a report's work limits (a
    // case page per ROI of its thousands of rows) do not apply.
    let plan = ledflicker_plan::plan::parse_within(&text, &plan_path, String::new(), false)
        .map_err(|e| format!("the fitted profile does not validate: {e}"))?;
    let cases = ledflicker_plan::plan::expand_cases(&plan);
    let case = cases.first().ok_or("the closed-loop plan has no case")?;
    let acq = Simulator::new(&plan)
        .acquire(case)
        .map_err(|e| e.to_string())?;
    let predicted: Vec<f64> = acq
        .rois
        .iter()
        .map(|r| r.luma.first().copied().unwrap_or(f64::NAN))
        .collect();
    let n = predicted.len().min(cal.measured.len()).max(1);
    let ss: f64 = predicted
        .iter()
        .zip(&cal.measured)
        .map(|(p, m)| (p - m) * (p - m))
        .sum();
    let rms = (ss / n as f64).sqrt() / cal.full_scale_dn;
    if !rms.is_finite() {
        return Err("the simulator's prediction is not finite".to_string());
    }
    Ok((predicted, rms))
}
