//! Parameter recovery: synthetic frames with known parameters, degraded as
//! real frames are, run through `calibrate`. The integration tests assert
//! each case's tolerances; `cargo run --example calibration_table` prints
//! the table of docs/calibration.md from the same cases.

use std::path::Path;

use super::synth::SynthFrame;
use super::{Light, frames};

/// Largest accepted error of each parameter in a recovery case.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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
    /// Parameters the frame cannot determine, which must come out as a
    /// bound that holds the truth (`"black"`, `"exposure"`).
    pub bounds: &'static [&'static str],
    /// What the scene adds to the rendered frame.
    pub scene: Scene,
    /// JPEG quality when `ext` is `jpg`.
    pub jpeg_quality: u8,
}

/// What a case's scene adds to the rendered frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scene {
    /// The frame as rendered.
    Plain,
    /// The columns from `from_quarter` quarters of the width on lit by a
    /// second light instead, of this frequency (Hz) and duty: the column
    /// groups band at two periods, so `calibrate` must refuse, naming both
    /// regions, whether the second light has half the columns or a quarter.
    SecondLight {
        /// Its PWM frequency, Hz.
        frequency_hz: f64,
        /// Its duty cycle.
        duty: f64,
        /// Where its columns start, in quarters of the width (1 to 3).
        from_quarter: usize,
    },
    /// Bright ruled lines over the right quarter of the columns, half a band
    /// period thick, every 1.0075 band periods: that column group's own
    /// period is pulled 0.75 % off, and it cannot be told from a second
    /// light there: refused, naming both regions.
    RuledOverlay,
}

/// How a parameter came back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Recovered {
    /// A value: its error (units of [`Tolerance`]) and its error over its
    /// reported sigma.
    Value {
        /// Error.
        error: f64,
        /// `|error| / sigma`.
        z: f64,
    },
    /// A bound; whether it holds the truth.
    Bound {
        /// The truth lies within the bound.
        holds: bool,
    },
}

impl Recovered {
    fn value(error: f64, sigma: f64) -> Self {
        Recovered::Value {
            error,
            z: error.abs() / sigma,
        }
    }

    /// Table cell: the error in `unit` with the tolerance, or the bound.
    fn cell(&self, scale: f64, digits: usize, unit: &str, tol: f64) -> String {
        match *self {
            Recovered::Value { error, z } => format!(
                "{:+.digits$}{unit} (±{}{unit}; {z:.1} σ)",
                scale * error,
                scale * tol
            ),
            Recovered::Bound { holds } => {
                format!("bound ({})", if holds { "holds" } else { "VIOLATED" })
            }
        }
    }
}

/// Errors of one recovered case (same units as [`Tolerance`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RecoveryErrors {
    /// Line time.
    pub line_time: Recovered,
    /// Exposure.
    pub exposure: Recovered,
    /// Duty.
    pub duty: Recovered,
    /// Gamma.
    pub gamma: Recovered,
    /// Black level.
    pub black: Recovered,
    /// Closed-loop `profile_rms` is not run here; the fit RMS, fraction of
    /// full scale.
    pub fit_rms: f64,
}

impl RecoveryErrors {
    /// Each parameter with its name and tolerance.
    pub fn named(&self, tol: &Tolerance) -> [(&'static str, Recovered, f64); 5] {
        [
            ("line time", self.line_time, tol.line_time),
            ("exposure", self.exposure, tol.exposure),
            ("duty", self.duty, tol.duty),
            ("gamma", self.gamma, tol.gamma),
            ("black", self.black, tol.black),
        ]
    }

    /// What is wrong, named: a value outside `tol`, a bound where a value
    /// was expected or the other way round, a bound that misses the truth.
    pub fn failures(&self, case: &RecoveryCase) -> Vec<String> {
        self.named(&case.tol)
            .iter()
            .filter_map(|&(name, r, max)| {
                let bound = case.bounds.contains(&name);
                match r {
                    Recovered::Value { error, .. } if bound => Some(format!(
                        "{name}: a value ({error:.4}) where a bound is expected"
                    )),
                    Recovered::Value { error, .. } if error.is_nan() || error.abs() > max => {
                        Some(format!("{name}: error {error:.4} > {max}"))
                    }
                    Recovered::Bound { .. } if !bound => {
                        Some(format!("{name}: reported as a bound"))
                    }
                    Recovered::Bound { holds: false } => {
                        Some(format!("{name}: the bound misses the truth"))
                    }
                    _ => None,
                }
            })
            .collect()
    }

    /// Largest `|error| / sigma` over the parameters given as values.
    pub fn max_z(&self) -> f64 {
        self.named(&Tolerance::default())
            .iter()
            .filter_map(|(_, r, _)| match r {
                Recovered::Value { z, .. } => Some(*z),
                Recovered::Bound { .. } => None,
            })
            .fold(0.0, f64::max)
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
    let mut all = response_cases(&base);
    all.extend(scene_cases(&base));
    all.extend(band_cases(&base));
    all.extend(output_cases(&base));
    all.push(combined_case(base));
    all
}

/// Tolerances of every recovery case.
const TOLERANCE: Tolerance = Tolerance {
    line_time: 0.001,
    exposure: 0.10,
    duty: 0.01,
    gamma: 0.05,
    black: 0.01,
};

/// A case with the common tolerances and every parameter a value.
fn case(name: &'static str, frame: SynthFrame, ext: &'static str) -> RecoveryCase {
    RecoveryCase {
        name,
        frame,
        ext,
        tol: TOLERANCE,
        bounds: &[],
        scene: Scene::Plain,
        jpeg_quality: 80,
    }
}

/// The tone response: the base frame (gamma 2.2), and a linear one.
fn response_cases(base: &SynthFrame) -> Vec<RecoveryCase> {
    vec![
        case("clean, gamma 2.2, 15.7 bands", base.clone(), "png"),
        // Linear: black level and ambient light trade off exactly.
        RecoveryCase {
            bounds: &["black"],
            ..case(
                "linear (gamma 1), duty 0.3",
                SynthFrame {
                    gamma: 1.0,
                    duty: 0.3,
                    ..base.clone()
                },
                "png",
            )
        },
    ]
}

/// What the picture adds to the bands: noise, vignetting, scene texture,
/// a text overlay, JPEG compression.
fn scene_cases(base: &SynthFrame) -> Vec<RecoveryCase> {
    vec![
        case(
            "noise 3 DN per pixel",
            SynthFrame {
                noise_dn: 3.0,
                ..base.clone()
            },
            "png",
        ),
        case(
            "vignetting 40 %",
            SynthFrame {
                vignetting: 0.4,
                ..base.clone()
            },
            "png",
        ),
        // Texture steps every 16 rows, which the smooth shading term cannot
        // follow: black level and ambient trade off within the residual.
        RecoveryCase {
            bounds: &["black"],
            ..case(
                "scene texture 30 %",
                SynthFrame {
                    texture: 0.3,
                    ..base.clone()
                },
                "png",
            )
        },
        case(
            "text overlay",
            SynthFrame {
                overlay: true,
                ..base.clone()
            },
            "png",
        ),
        // JPEG blocks blur the foot of the ramps, where black level and
        // ambient differ.
        RecoveryCase {
            bounds: &["black"],
            ..case("JPEG quality 80", base.clone(), "jpg")
        },
        RecoveryCase {
            bounds: &["black"],
            jpeg_quality: 50,
            ..case("JPEG quality 50", base.clone(), "jpg")
        },
        // At quality 95 the foot of the ramps survives: a value.
        RecoveryCase {
            jpeg_quality: 95,
            ..case("JPEG quality 95", base.clone(), "jpg")
        },
        RecoveryCase {
            scene: Scene::RuledOverlay,
            ..case("overlay on one column group", base.clone(), "png")
        },
        RecoveryCase {
            scene: Scene::SecondLight {
                frequency_hz: 1130.0,
                duty: 0.3,
                from_quarter: 2,
            },
            ..case(
                "two lights (1130 Hz on the right half)",
                base.clone(),
                "png",
            )
        },
        RecoveryCase {
            scene: Scene::SecondLight {
                frequency_hz: 700.0,
                duty: 0.5,
                from_quarter: 3,
            },
            ..case(
                "two lights (700 Hz on the right quarter)",
                base.clone(),
                "png",
            )
        },
    ]
}

/// Few and many bands in the frame.
fn band_cases(base: &SynthFrame) -> Vec<RecoveryCase> {
    vec![
        case(
            "3.3 bands",
            SynthFrame {
                frequency_hz: frequency_for(3.3),
                ..base.clone()
            },
            "png",
        ),
        // A band period of exactly 36 rows: every band repeats the same 36
        // samples, too few to tell black level from ambient.
        RecoveryCase {
            bounds: &["black"],
            ..case(
                "30 bands",
                SynthFrame {
                    frequency_hz: frequency_for(30.0),
                    ..base.clone()
                },
                "png",
            )
        },
    ]
}

/// The output range: 16-bit TIFF with ambient light, flat tops below full
/// scale, and clipping.
fn output_cases(base: &SynthFrame) -> Vec<RecoveryCase> {
    vec![
        case(
            "16-bit TIFF, duty 0.2, ambient 5 %",
            SynthFrame {
                bits16: true,
                duty: 0.2,
                ambient: 0.05,
                ..base.clone()
            },
            "tif",
        ),
        // An exposure shorter than the ON time flattens the band tops at
        // 234 of 255 DN: a plateau of the exposure window, not clipping.
        case(
            "flat-topped unclipped profile (tops at 92 % of full scale)",
            SynthFrame {
                led_level: 0.8,
                exposure_s: 250e-6,
                ..base.clone()
            },
            "png",
        ),
        // The LED at 3x what the output can hold: rows clip at full scale,
        // so only duty + exposure is fixed and both come out as bounds.
        RecoveryCase {
            bounds: &["exposure", "duty"],
            ..case(
                "clipped (LED at 3x full scale)",
                SynthFrame {
                    led_level: 3.0,
                    ..base.clone()
                },
                "png",
            )
        },
    ]
}

/// Every degradation of [`scene_cases`] at once.
fn combined_case(base: SynthFrame) -> RecoveryCase {
    // Texture and JPEG together (see above).
    RecoveryCase {
        bounds: &["black"],
        ..case(
            "all: noise, vignetting, texture, overlay, JPEG",
            SynthFrame {
                noise_dn: 3.0,
                vignetting: 0.4,
                texture: 0.2,
                overlay: true,
                ..base
            },
            "jpg",
        )
    }
}

/// Writes the case's frame, with its scene, to `path`.
pub fn write_case(case: &RecoveryCase, path: &Path) -> Result<(), String> {
    let fr = &case.frame;
    let (w, h) = (fr.width as usize, fr.height as usize);
    let mut px = match case.scene {
        Scene::Plain => return fr.save(path, case.jpeg_quality),
        Scene::SecondLight {
            frequency_hz,
            duty,
            from_quarter,
        } => {
            let right = SynthFrame {
                frequency_hz,
                duty,
                ..fr.clone()
            }
            .render()?;
            let mut px = fr.render()?;
            for (i, p) in px.iter_mut().enumerate() {
                if i % w >= from_quarter * w / 4 {
                    *p = right[i];
                }
            }
            px
        }
        Scene::RuledOverlay => {
            let period = super::bands::band_period_rows(fr.frequency_hz, fr.line_time_s);
            let mut px = fr.render()?;
            for (i, p) in px.iter_mut().enumerate() {
                let phase = ((i / w) as f64 / (1.0075 * period)).fract();
                if i % w >= 3 * w / 4 && phase < 0.5 {
                    *p = 0.92 * fr.full_scale();
                }
            }
            px
        }
    };
    px.truncate(w * h);
    let data: Vec<u8> = px
        .iter()
        .map(|v| v.round().clamp(0.0, 255.0) as u8)
        .collect();
    let img = image::ImageBuffer::<image::Luma<u8>, _>::from_raw(fr.width, fr.height, data)
        .ok_or("frame size mismatch")?;
    ledflicker_plan::image_io::save(&image::DynamicImage::ImageLuma8(img), path)
        .map_err(|e| format!("cannot write `{}`: {e}", path.display()))
}

/// Writes the case's frame into `dir` and calibrates it.
fn calibrate_case(
    case: &RecoveryCase,
    dir: &Path,
    index: usize,
) -> Result<Result<super::Calibration, super::bands::NoConfidence>, String> {
    let path = dir.join(format!("recovery-{index}.{}", case.ext));
    write_case(case, &path)?;
    let set = frames::load(&[path], None, None).map_err(|e| e.to_string())?;
    Ok(super::calibrate(
        &set,
        Light {
            frequency_hz: case.frame.frequency_hz,
            frequency_sigma_hz: 0.0,
            duty: None,
        },
    ))
}

/// A case of two lights: the refusal's regions, each with its relative
/// period error against its own light, left to right; an error when
/// `calibrate` does not refuse with two regions, each within the line-time
/// tolerance of its light.
pub fn refusal(case: &RecoveryCase, dir: &Path, index: usize) -> Result<Vec<String>, String> {
    let fr = &case.frame;
    // The second region's columns and its light (none for an overlay,
    // whose period is only checked to be another one).
    let (split, second) = match case.scene {
        Scene::SecondLight {
            frequency_hz,
            from_quarter,
            ..
        } => (from_quarter as u32 * fr.width / 4, Some(frequency_hz)),
        Scene::RuledOverlay => (3 * fr.width / 4, None),
        Scene::Plain => return Err(format!("{}: not a case of two regions", case.name)),
    };
    let period = |f: f64| super::bands::band_period_rows(f, fr.line_time_s);
    let regions = match calibrate_case(case, dir, index)? {
        Err(super::bands::NoConfidence::StripsDisagree { regions }) => regions,
        other => {
            return Err(format!(
                "{}: not refused as two regions: {other:?}",
                case.name
            ));
        }
    };
    if regions.len() != 2 {
        return Err(format!("{}: {} regions, not 2", case.name, regions.len()));
    }
    let mut out = Vec::new();
    for r in &regions {
        let ([a, b], Some(p)) = (r.columns[0], r.period_rows) else {
            return Err(format!("{}: a region without banding: {r}", case.name));
        };
        let truth = if b <= split {
            period(fr.frequency_hz)
        } else if a >= split {
            match second {
                Some(f) => period(f),
                None => {
                    out.push((a, format!("columns {a}..{b}: the overlay's period")));
                    continue;
                }
            }
        } else {
            return Err(format!("{}: a region across both lights: {r}", case.name));
        };
        let error = p / truth - 1.0;
        if error.abs() > case.tol.line_time {
            return Err(format!(
                "{}: region {r}: period error {error:+.5}",
                case.name
            ));
        }
        out.push((a, format!("columns {a}..{b}: {:+.4} %", 100.0 * error)));
    }
    out.sort();
    Ok(out.into_iter().map(|(_, s)| s).collect())
}

/// Writes the case's frame into `dir`, calibrates it and returns the errors.
pub fn recover(case: &RecoveryCase, dir: &Path, index: usize) -> Result<RecoveryErrors, String> {
    let fr = &case.frame;
    let cal = calibrate_case(case, dir, index)?.map_err(|e| format!("{}: {e}", case.name))?;
    let true_exposure_us = fr.exposure_s * 1e6;
    // Two readings (exposure and duty swapped): one of them must be the
    // truth, within its sigmas; the frames cannot say which.
    let nearest = cal.solutions.iter().min_by(|a, b| {
        (a.duty - fr.duty)
            .abs()
            .total_cmp(&(b.duty - fr.duty).abs())
    });
    let exposure = match (cal.exposure_us, cal.exposure_us_sigma, nearest) {
        (_, _, Some(s)) => Recovered::value(
            s.exposure_us / true_exposure_us - 1.0,
            s.exposure_us_sigma / true_exposure_us,
        ),
        (Some(e), Some(s), None) => {
            Recovered::value(e / true_exposure_us - 1.0, s / true_exposure_us)
        }
        _ => Recovered::Bound {
            holds: cal.exposure_us_max.is_some_and(|m| true_exposure_us <= m)
                && cal.exposure_us_min.is_none_or(|m| true_exposure_us >= m),
        },
    };
    let a = fr.full_scale();
    let black = match (cal.black_level_dn, cal.black_level_dn_sigma) {
        (Some(b), Some(s)) => Recovered::value((b - fr.black_dn) / a, s / a),
        _ => Recovered::Bound {
            holds: cal.black_level_dn_max.is_some_and(|m| fr.black_dn <= m),
        },
    };
    let lt = cal.line_time_us * 1e-6;
    Ok(RecoveryErrors {
        line_time: Recovered::value(
            lt / fr.line_time_s - 1.0,
            cal.line_time_us_sigma * 1e-6 / fr.line_time_s,
        ),
        exposure,
        duty: match (cal.duty, cal.duty_sigma, nearest) {
            (_, _, Some(s)) => Recovered::value(s.duty - fr.duty, s.duty_sigma),
            (Some(d), Some(s), None) => Recovered::value(d - fr.duty, s),
            _ => Recovered::Bound {
                holds: cal
                    .duty_min
                    .zip(cal.duty_max)
                    .is_some_and(|(lo, hi)| (lo..=hi).contains(&fr.duty)),
            },
        },
        gamma: Recovered::value(cal.gamma / fr.gamma - 1.0, cal.gamma_sigma / fr.gamma),
        black,
        fit_rms: cal.fit_rms,
    })
}

/// The markdown table of docs/calibration.md: measured error, tolerance
/// and error in reported sigmas of every parameter in every case.
pub fn table(dir: &Path) -> Result<String, String> {
    let mut t = String::from(
        "| case | line time | exposure | duty | gamma | black level | fit RMS |\n|---|---|---|---|---|---|---|\n",
    );
    for (i, case) in cases().iter().enumerate() {
        if !matches!(case.scene, Scene::Plain) {
            let regions = refusal(case, dir, i)?;
            t.push_str(&format!(
                "| {} | refused (exit 7), two regions: {} | | | | | |\n",
                case.name,
                regions.join(", ")
            ));
            continue;
        }
        let e = recover(case, dir, i)?;
        let tol = case.tol;
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {:.4} |\n",
            case.name,
            e.line_time.cell(100.0, 4, " %", tol.line_time),
            e.exposure.cell(100.0, 2, " %", tol.exposure),
            e.duty.cell(1.0, 4, "", tol.duty),
            e.gamma.cell(100.0, 2, " %", tol.gamma),
            e.black.cell(100.0, 3, " %", tol.black),
            e.fit_rms
        ));
    }
    Ok(t)
}
