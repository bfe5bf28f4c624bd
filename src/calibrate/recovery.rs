//! Parameter recovery: synthetic frames with known parameters, degraded as
//! real frames are, run through `calibrate`. The integration tests assert
//! each case's tolerances; `cargo run --example calibration_table` prints
//! the table of docs/calibration.md from the same cases.

use std::path::Path;

use super::synth::SynthFrame;
use super::{Light, frames};

/// Largest accepted error of each parameter in a recovery case.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Line time, relative.
    pub line_time: f64,
    /// Exposure, relative.
    pub exposure: f64,
    /// Duty, absolute.
    pub duty: f64,
    /// Gamma, relative.
    pub gamma: f64,
    /// Black level, fraction of full scale.
    pub black: f64,
}

/// One recovery case.
#[derive(Debug, Clone, PartialEq)]
pub struct RecoveryCase {
    /// What is degraded.
    pub name: &'static str,
    /// The frame.
    pub frame: SynthFrame,
    /// File extension written and read back (`png`, `tif`, `jpg`).
    pub ext: &'static str,
    /// Tolerances.
    pub tol: Tolerance,
}

/// Errors of one recovered case (same units as [`Tolerance`]); `None` for
/// a parameter reported as a bound.
#[derive(Debug, Clone, PartialEq)]
pub struct RecoveryErrors {
    /// Line time.
    pub line_time: f64,
    /// Exposure.
    pub exposure: Option<f64>,
    /// Duty.
    pub duty: f64,
    /// Gamma.
    pub gamma: f64,
    /// Black level.
    pub black: f64,
    /// Closed-loop `profile_rms` is not run here; the fit RMS, fraction of
    /// full scale.
    pub fit_rms: f64,
}

impl RecoveryErrors {
    /// The parameters outside `tol`, named.
    pub fn failures(&self, tol: &Tolerance) -> Vec<String> {
        let exposure = self.exposure.unwrap_or(f64::NAN);
        [
            ("line time", self.line_time, tol.line_time),
            ("exposure", exposure, tol.exposure),
            ("duty", self.duty, tol.duty),
            ("gamma", self.gamma, tol.gamma),
            ("black", self.black, tol.black),
        ]
        .iter()
        .filter(|(_, err, max)| err.is_nan() || err.abs() > *max)
        .map(|(name, err, max)| format!("{name}: error {err:.4} > {max} (NaN: a bound)"))
        .collect()
    }
}

/// Frequency that puts `bands` band periods in the base frame's rows.
fn frequency_for(bands: f64) -> f64 {
    let b = SynthFrame::base();
    bands / (b.height as f64 * b.line_time_s)
}

/// The recovery cases: each degradation alone, then all at once.
pub fn cases() -> Vec<RecoveryCase> {
    let base = SynthFrame::base();
    let tol = Tolerance {
        line_time: 0.001,
        exposure: 0.10,
        duty: 0.01,
        gamma: 0.05,
        black: 0.01,
    };
    let case = |name, frame: SynthFrame, ext, tol| RecoveryCase {
        name,
        frame,
        ext,
        tol,
    };
    vec![
        case("clean, gamma 2.2, 15.7 bands", base.clone(), "png", tol),
        case(
            "linear (gamma 1), duty 0.3",
            SynthFrame {
                gamma: 1.0,
                duty: 0.3,
                ..base.clone()
            },
            "png",
            tol,
        ),
        case(
            "noise 3 DN per pixel",
            SynthFrame {
                noise_dn: 3.0,
                ..base.clone()
            },
            "png",
            tol,
        ),
        case(
            "vignetting 40 %",
            SynthFrame {
                vignetting: 0.4,
                ..base.clone()
            },
            "png",
            tol,
        ),
        case(
            "scene texture 30 %",
            SynthFrame {
                texture: 0.3,
                ..base.clone()
            },
            "png",
            tol,
        ),
        case(
            "text overlay",
            SynthFrame {
                overlay: true,
                ..base.clone()
            },
            "png",
            tol,
        ),
        case("JPEG quality 80", base.clone(), "jpg", tol),
        case(
            "3.3 bands",
            SynthFrame {
                frequency_hz: frequency_for(3.3),
                ..base.clone()
            },
            "png",
            tol,
        ),
        case(
            "30 bands",
            SynthFrame {
                frequency_hz: frequency_for(30.0),
                ..base.clone()
            },
            "png",
            tol,
        ),
        case(
            "16-bit TIFF, duty 0.2, ambient 5 %",
            SynthFrame {
                bits16: true,
                duty: 0.2,
                ambient: 0.05,
                ..base.clone()
            },
            "tif",
            tol,
        ),
        case(
            "all: noise, vignetting, texture, overlay, JPEG",
            SynthFrame {
                noise_dn: 3.0,
                vignetting: 0.4,
                texture: 0.2,
                overlay: true,
                ..base
            },
            "jpg",
            tol,
        ),
    ]
}

/// Writes the case's frame into `dir`, calibrates it and returns the errors.
pub fn recover(case: &RecoveryCase, dir: &Path, index: usize) -> Result<RecoveryErrors, String> {
    let path = dir.join(format!("recovery-{index}.{}", case.ext));
    case.frame.save(&path, 80)?;
    let set = frames::load(&[path], None, None).map_err(|e| e.to_string())?;
    let fr = &case.frame;
    let cal = super::calibrate(
        &set,
        Light {
            frequency_hz: fr.frequency_hz,
            duty: None,
        },
    )
    .map_err(|e| format!("{}: {e}", case.name))?;
    Ok(RecoveryErrors {
        line_time: cal.line_time_us * 1e-6 / fr.line_time_s - 1.0,
        exposure: cal.exposure_us.map(|e| e * 1e-6 / fr.exposure_s - 1.0),
        duty: cal.duty - fr.duty,
        gamma: cal.gamma / fr.gamma - 1.0,
        black: (cal.black_level_dn - fr.black_dn) / fr.full_scale(),
        fit_rms: cal.fit_rms,
    })
}

/// The markdown table of docs/calibration.md: measured error and
/// tolerance of every parameter in every case.
pub fn table(dir: &Path) -> Result<String, String> {
    let mut t = String::from(
        "| case | line time | exposure | duty | gamma | black level | fit RMS |\n|---|---|---|---|---|---|---|\n",
    );
    for (i, case) in cases().iter().enumerate() {
        let e = recover(case, dir, i)?;
        let tol = case.tol;
        let exposure = e.exposure.map_or("bound".to_string(), |x| {
            format!("{:+.2} % (±{:.0} %)", 100.0 * x, 100.0 * tol.exposure)
        });
        t.push_str(&format!(
            "| {} | {:+.3} % (±{} %) | {exposure} | {:+.4} (±{}) | {:+.2} % (±{:.0} %) | {:+.4} (±{}) | {:.4} |\n",
            case.name,
            100.0 * e.line_time,
            100.0 * tol.line_time,
            e.duty,
            tol.duty,
            100.0 * e.gamma,
            100.0 * tol.gamma,
            e.black,
            tol.black,
            e.fit_rms
        ));
    }
    Ok(t)
}
