//! `ledflicker simulate`: probes the ideal camera for one condition; a CSV
//! trace of ON fractions, or with `--summary` one JSON object of metrics.

use super::output::outln;
use std::io::Write;

use clap::Args;

use super::args::{CameraArgs, PwmArgs};
use super::{ExitCode, Failure};
use crate::analysis::colour::Die;
use crate::error::UsageError;
use crate::physics::{PwmDrive, Shutter};

#[derive(Args, Debug)]
pub(super) struct SimulateArgs {
    #[command(flatten)]
    pwm: PwmArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// Number of frames (>= 1).
    #[arg(long, default_value_t = 30)]
    frames: u64,
    /// ROI rows `A:B`, A inclusive, B exclusive.
    #[arg(long, default_value = "0:1", value_parser = parse_rows)]
    rows: std::ops::Range<u32>,
    /// Print one JSON object with this condition's metrics (results.json
    /// names) instead of the CSV trace.
    #[arg(long)]
    summary: bool,
    /// With --summary: steady light in the ROI (also the OFF reference), in
    /// units of the LED's full ON level (>= 0). 0 leaves FDI unbounded.
    #[arg(long, default_value_t = 0.0)]
    background: f64,
    /// With --summary: sensor rows rendered for the banding KPIs.
    #[arg(long, default_value_t = 800)]
    sensor_rows: u32,
    /// With --summary: an RGB LED whose red, green and blue dies run at these
    /// duties (`R,G,B`, each in (0, 1]) on common rising edges; adds colour KPIs.
    #[arg(long, value_parser = parse_rgb)]
    rgb_duty: Option<[f64; 3]>,
    /// With --summary: a white LED of this linear camera RGB (`R,G,B`) at
    /// --duty; adds colour KPIs.
    #[arg(long, value_parser = parse_rgb)]
    led_rgb: Option<[f64; 3]>,
    /// With --summary: background linear RGB (`R,G,B`) [default: --background
    /// in every channel].
    #[arg(long, value_parser = parse_rgb)]
    background_rgb: Option<[f64; 3]>,
}

fn usage(m: String) -> Failure {
    Failure::from(UsageError(m))
}

/// clap's value parser of an `R,G,B` flag: three finite numbers, each >= 0.
fn parse_rgb(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| "not three numbers R,G,B".to_string())?;
    match v.as_slice() {
        [r, g, b] if v.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok([*r, *g, *b]),
        _ => Err("not three numbers R,G,B, each >= 0".to_string()),
    }
}

/// clap's value parser of `--rows A:B`: A inclusive, B exclusive, A < B.
fn parse_rows(s: &str) -> Result<std::ops::Range<u32>, String> {
    let bad = || "not A:B with A < B (A inclusive, B exclusive), e.g. 399:401".to_string();
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let a: u32 = a.trim().parse().map_err(|_| bad())?;
    let b: u32 = b.trim().parse().map_err(|_| bad())?;
    if a >= b {
        return Err(bad());
    }
    Ok(a..b)
}

/// Physical bounds of `simulate` inputs (docs/plan-format.md, "Limits"):
/// those of the drive and camera flags, then the frame count and sensor.
fn check_bounds(a: &SimulateArgs) -> Result<(), UsageError> {
    use crate::plan::bounds::{MAX_FRAMES_PER_CASE, MAX_SENSOR_SIDE};
    super::args::check_drive_and_camera(&a.pwm, &a.camera)?;
    if a.frames > MAX_FRAMES_PER_CASE {
        return Err(UsageError(format!(
            "--frames must be at most {MAX_FRAMES_PER_CASE}"
        )));
    }
    if a.sensor_rows > MAX_SENSOR_SIDE {
        return Err(UsageError(format!(
            "--sensor-rows must be at most {MAX_SENSOR_SIDE}"
        )));
    }
    Ok(())
}

/// The checked drive and shutter, and the ROI rows.
fn condition(a: &SimulateArgs) -> Result<(PwmDrive, Shutter, std::ops::Range<u32>), Failure> {
    check_bounds(a)?;
    let (p, c) = (&a.pwm, &a.camera);
    let pwm = PwmDrive::new(p.frequency_hz, p.duty, p.pwm_delay_ms * 1e-3).map_err(usage)?;
    if !(c.exposure_ms.is_finite() && c.exposure_ms > 0.0) {
        return Err(usage(format!(
            "--exposure-ms must be > 0, got {}",
            c.exposure_ms
        )));
    }
    if !(c.fps.is_finite() && c.fps > 0.0) {
        return Err(usage(format!("--fps must be > 0, got {}", c.fps)));
    }
    if a.frames == 0 {
        return Err(usage("--frames must be at least 1".into()));
    }
    if !(c.line_time_us.is_finite() && c.line_time_us >= 0.0) {
        return Err(usage(format!(
            "--line-time-us must be >= 0, got {}",
            c.line_time_us
        )));
    }
    Ok((pwm, c.shutter(), a.rows.clone()))
}

/// The ideal camera's ON fraction and start time of each of `frames`
/// frames over the ROI rows `rows`: the CSV of `ledflicker simulate`,
/// with its checks, for callers of the library (the Python package).
pub fn on_fractions(
    pwm: PwmArgs,
    camera: CameraArgs,
    frames: u64,
    rows: std::ops::Range<u32>,
) -> Result<Vec<(f64, f64)>, Failure> {
    let a = SimulateArgs {
        pwm,
        camera,
        frames,
        rows,
        summary: false,
        background: 0.0,
        sensor_rows: 800,
        rgb_duty: None,
        led_rgb: None,
        background_rgb: None,
    };
    let (pwm, shutter, rows) = condition(&a)?;
    (0..a.frames)
        .map(|k| {
            let s = shutter.frame_on_fraction(&pwm, k, rows.clone());
            let t = k as f64 / a.camera.fps;
            if s.is_finite() && t.is_finite() {
                Ok((t, s))
            } else {
                Err(usage(format!(
                    "frame {k} has no finite ON fraction for these inputs; check their ranges (`ledflicker simulate --help`)"
                )))
            }
        })
        .collect()
}

pub(super) fn simulate(a: SimulateArgs) -> Result<ExitCode, Failure> {
    if a.summary {
        let (pwm, shutter, rows) = condition(&a)?;
        return summary(&a, &pwm, &shutter, rows);
    }
    let rows = a.rows.clone();
    // Never print NaN: a frame beyond what the model covers fails the
    // whole trace before a line of it is written.
    let trace = on_fractions(a.pwm, a.camera, a.frames, rows)?;
    let mut w = std::io::BufWriter::new(super::output::Stdout);
    writeln!(w, "frame,time_s,on_fraction")?;
    for (k, (t, s)) in trace.iter().enumerate() {
        writeln!(w, "{k},{t},{s}")?;
    }
    w.flush()?;
    Ok(ExitCode::Pass)
}

/// The LED dies `--rgb-duty` or `--led-rgb` describe, if either.
fn dies(a: &SimulateArgs) -> Result<Option<Vec<Die>>, Failure> {
    Ok(match (&a.rgb_duty, &a.led_rgb) {
        (Some(_), Some(_)) => {
            return Err(usage("give --rgb-duty or --led-rgb, not both".into()));
        }
        (Some(d), None) => {
            let d = *d;
            if d.iter().any(|x| !(*x > 0.0 && *x <= 1.0)) {
                return Err(usage(format!(
                    "--rgb-duty duties must be in (0, 1], got {d:?}"
                )));
            }
            let primary = |k: usize| {
                let mut c = [0.0; 3];
                c[k] = 1.0;
                Die {
                    rgb: c,
                    duty: d[k],
                    offset_cycles: 0.0,
                }
            };
            Some(vec![primary(0), primary(1), primary(2)])
        }
        (None, Some(c)) => Some(vec![Die {
            rgb: *c,
            duty: a.pwm.duty,
            offset_cycles: 0.0,
        }]),
        (None, None) => None,
    })
}

/// `--summary`: one JSON object of this condition's metrics.
fn summary(
    a: &SimulateArgs,
    pwm: &PwmDrive,
    shutter: &Shutter,
    rows: std::ops::Range<u32>,
) -> Result<ExitCode, Failure> {
    if !(a.background.is_finite() && a.background >= 0.0) {
        return Err(usage(format!(
            "--background must be >= 0, got {}",
            a.background
        )));
    }
    if a.sensor_rows == 0 {
        return Err(usage("--sensor-rows must be at least 1".into()));
    }
    let dies = dies(a)?;
    let background_rgb = match &a.background_rgb {
        Some(b) => *b,
        None => [a.background; 3],
    };
    let scene = dies.map(|dies| crate::analysis::summary::ColourScene {
        background: background_rgb,
        dies,
    });
    let summary = crate::analysis::summary::summarise(
        shutter,
        pwm,
        rows,
        a.frames,
        a.background,
        a.sensor_rows,
        scene.as_ref(),
    );
    // serde_json writes a non-finite number as null, never NaN.
    outln!("{}", serde_json::to_string_pretty(&summary)?)?;
    Ok(ExitCode::Pass)
}
