//! `ledflicker linetime`, `bands` and `calibrate`: their arguments and
//! output. The estimators and the camera fit are in `crate::calibrate`.

use super::output::outln;
use std::io::Write;
use std::path::PathBuf;

use clap::Args;

use super::{ExitCode, Failure};
use crate::calibrate::bands::{ColumnGroup, NoConfidence};
use crate::calibrate::frames::{self, FrameSet};
use crate::calibrate::profile::ProfileOptions;
use crate::calibrate::{Calibration, FlatTop, Light, estimate_bands};
use crate::error::UsageError;

/// No confident estimate: the input shows no usable banding. Exit code 7.
#[derive(Debug, thiserror::Error)]
#[error("no confident estimate from {input}: {reason}\n    hint: {hint}")]
pub struct NoEstimate {
    /// The input, as given.
    pub input: String,
    /// Why.
    pub reason: NoConfidence,
    /// What to change.
    pub hint: &'static str,
}

/// Inputs shared by the three commands.
#[derive(Args, Debug)]
pub struct FrameArgs {
    /// Frames: PNG, TIFF (8/16 bit) or JPEG files, or a video, Y4M file or
    /// frame directory (read through the capture readers).
    #[arg(required = true, value_name = "FRAME")]
    pub inputs: Vec<PathBuf>,
    /// Analyse only this rectangle, `X,Y,W,H` in pixels (e.g. one light).
    #[arg(long)]
    pub roi: Option<String>,
    /// Use frames `A..B` of the input (0-based, B exclusive).
    #[arg(long = "frames", value_name = "A..B")]
    pub frames_range: Option<String>,
}

/// `ledflicker linetime`.
#[derive(Args, Debug)]
pub struct LinetimeArgs {
    #[command(flatten)]
    input: FrameArgs,
    /// PWM frequency of the light, Hz (> 0).
    #[arg(long)]
    frequency_hz: f64,
}

/// `ledflicker bands`.
#[derive(Args, Debug)]
pub struct BandsArgs {
    #[command(flatten)]
    input: FrameArgs,
    /// Line time in microseconds (> 0).
    #[arg(long)]
    line_time_us: f64,
}

/// `ledflicker calibrate`.
#[derive(Args, Debug)]
pub struct CalibrateArgs {
    #[command(flatten)]
    input: FrameArgs,
    /// PWM frequency of the light, Hz (> 0).
    #[arg(long)]
    frequency_hz: f64,
    /// One-sigma uncertainty of the PWM frequency, Hz [default: 0, exact];
    /// it carries into the line time's and the exposure's sigma.
    #[arg(long, default_value_t = 0.0)]
    frequency_sigma_hz: f64,
    /// Duty cycle of the light in (0, 1); fitted when absent.
    #[arg(long)]
    duty: Option<f64>,
    /// Write the fitted camera profile (reference-data/cameras/ format) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Profile name [default: the --out file stem, else "calibrated"].
    #[arg(long)]
    name: Option<String>,
    /// Frame rate written to the profile [default: 30, or less when the
    /// readout needs it]; a still frame does not give it.
    #[arg(long)]
    fps: Option<f64>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn positive(flag: &str, v: f64) -> Result<f64, UsageError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(UsageError(format!("{flag} must be > 0, got {v}")))
    }
}

fn load(a: &FrameArgs) -> Result<FrameSet, Failure> {
    let roi = a
        .roi
        .as_deref()
        .map(frames::parse_roi)
        .transpose()
        .map_err(UsageError)?;
    let range = a
        .frames_range
        .as_deref()
        .map(frames::parse_frames)
        .transpose()
        .map_err(UsageError)?;
    Ok(frames::load(&a.inputs, range, roi)?)
}

fn input_name(a: &FrameArgs) -> String {
    let first = a
        .inputs
        .first()
        .map_or(String::new(), |p| format!("`{}`", p.display()));
    match a.inputs.len() {
        0 | 1 => first,
        n => format!("{first} and {} more", n - 1),
    }
}

fn refuse(a: &FrameArgs, reason: NoConfidence) -> Failure {
    let hint = reason.hint();
    NoEstimate {
        input: input_name(a),
        reason,
        hint,
    }
    .into()
}

/// `linetime`: the line time on the first line (microseconds), then details.
pub fn linetime(a: LinetimeArgs) -> Result<ExitCode, Failure> {
    let f = positive("--frequency-hz", a.frequency_hz)?;
    let set = load(&a.input)?;
    let (e, divided) = estimate_bands(&set).map_err(|r| refuse(&a.input, r))?;
    let (t, sigma) = e.line_time_s(f);
    let mut w = super::output::Stdout;
    writeln!(w, "{:.3}", t * 1e6)?;
    writeln!(w, "line_time_us: {:.4} +- {:.4}", t * 1e6, sigma * 1e6)?;
    writeln!(
        w,
        "band_period_rows: {:.3} +- {:.3}",
        e.period_rows, e.period_sigma_rows
    )?;
    writeln!(
        w,
        "readout_ms ({} rows): {:.4}",
        set.frame_size.1,
        t * set.frame_size.1 as f64 * 1e3
    )?;
    writeln!(
        w,
        "bands: {:.2} in {} rows, {} frame(s){}",
        e.bands,
        e.rows,
        e.frames,
        if divided { ", texture divided out" } else { "" }
    )?;
    writeln!(w, "fit_quality: {:.3}", e.quality)?;
    write_caveats(&mut w, &e.dropped, e.block_grid_suppressed)?;
    Ok(ExitCode::Pass)
}

/// `bands`: the PWM frequency from the band spacing, JSON.
pub fn bands(a: BandsArgs) -> Result<ExitCode, Failure> {
    let t = positive("--line-time-us", a.line_time_us)? * 1e-6;
    let set = load(&a.input)?;
    let (e, divided) = estimate_bands(&set).map_err(|r| refuse(&a.input, r))?;
    let (f, sigma) = e.frequency_hz(t);
    let out = serde_json::json!({
        "frame": a.input.inputs.first().map(|p| p.display().to_string()),
        "frames": e.frames,
        "rows": e.rows,
        "roi": [set.roi.x, set.roi.y, set.roi.width, set.roi.height],
        "line_time_us": a.line_time_us,
        "band_period_rows": e.period_rows,
        "band_period_rows_sigma": e.period_sigma_rows,
        "bands": e.bands,
        "quality": e.quality,
        "texture_divided": divided,
        "dropped_columns": e.dropped,
        "block_grid_suppressed": e.block_grid_suppressed,
        "estimated_frequency_hz": f,
        "estimated_frequency_hz_sigma": sigma,
    });
    outln!("{}", serde_json::to_string_pretty(&out)?)?;
    Ok(ExitCode::Pass)
}

/// `calibrate`: fits the camera, closes the loop, writes the profile.
pub fn calibrate(a: CalibrateArgs) -> Result<ExitCode, Failure> {
    let f = positive("--frequency-hz", a.frequency_hz)?;
    if let Some(d) = a.duty
        && !(d > 0.0 && d < 1.0)
    {
        return Err(UsageError(format!("--duty must be in (0, 1), got {d}")).into());
    }
    let fps = a.fps.map(|v| positive("--fps", v)).transpose()?;
    let set = load(&a.input)?;
    if !(a.frequency_sigma_hz >= 0.0 && a.frequency_sigma_hz.is_finite()) {
        return Err(UsageError(format!(
            "--frequency-sigma-hz must be >= 0, got {}",
            a.frequency_sigma_hz
        ))
        .into());
    }
    let light = Light {
        frequency_hz: f,
        frequency_sigma_hz: a.frequency_sigma_hz,
        duty: a.duty,
    };
    let mut cal = crate::calibrate::calibrate(&set, light).map_err(|r| refuse(&a.input, r))?;
    let name = a
        .name
        .clone()
        .or_else(|| {
            a.out
                .as_ref()
                .and_then(|p| p.file_stem())
                .map(|s| s.to_string_lossy().into_owned())
        })
        .unwrap_or_else(|| "calibrated".to_string());
    let opts = ProfileOptions { name, fps };
    // Two readings of the frames: a profile would have to pick one, and a
    // plan run at another frequency would then inherit the wrong exposure.
    let ambiguous = !cal.solutions.is_empty();
    let out = a.out.as_deref().filter(|_| !ambiguous);
    crate::calibrate::write_profile(&mut cal, &opts, out)?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&cal)?)?;
    } else {
        print_text(&cal, out)?;
    }
    if ambiguous && let Some(p) = &a.out {
        eprintln!(
            "error: profile `{}` not written: the frames fit several readings of the exposure and the duty equally well (a band is the ON time convolved with the exposure window, the same whichever is longer)\n    hint: give the light's duty with --duty (from the driver's specification or a scope) and run again; at a duty of 0.5, calibrate at another duty",
            p.display()
        );
        return Ok(ExitCode::NoConfidence);
    }
    Ok(ExitCode::Pass)
}

/// The columns the band estimate left out, and the suppressed block grid,
/// one line each.
fn write_caveats(
    w: &mut impl Write,
    dropped: &[ColumnGroup],
    block_grid: bool,
) -> std::io::Result<()> {
    // Only groups without banding are dropped: a group banding at another
    // period is refused with the rest (`NoConfidence::StripsDisagree`).
    for d in dropped {
        writeln!(w, "dropped: {d}")?;
    }
    if block_grid {
        writeln!(
            w,
            "block_grid: periods of 16 / k rows suppressed (JPEG or video input)"
        )?;
    }
    Ok(())
}

fn print_text(cal: &Calibration, out: Option<&std::path::Path>) -> std::io::Result<()> {
    let mut w = super::output::Stdout;
    let pm = |v: f64, s: f64, d: usize| format!("{v:.d$} +- {s:.d$}");
    writeln!(
        w,
        "line_time_us:   {}",
        pm(cal.line_time_us, cal.line_time_us_sigma, 4)
    )?;
    match (
        cal.exposure_us,
        cal.exposure_us_sigma,
        cal.exposure_us_min,
        cal.exposure_us_max,
    ) {
        (Some(e), Some(s), _, _) => writeln!(w, "exposure_us:    {}", pm(e, s, 2))?,
        (_, _, Some(lo), Some(hi)) => writeln!(
            w,
            "exposure_us:    {lo:.2} ..= {hi:.2} (undetermined: rows clip, only duty + exposure is fixed; give --duty)"
        )?,
        (_, _, None, Some(m)) => writeln!(
            w,
            "exposure_us:    <= {m:.2} (undetermined: edges sharper than a row)"
        )?,
        _ => {}
    }
    if !cal.solutions.is_empty() {
        let each: Vec<String> = cal
            .solutions
            .iter()
            .map(|r| {
                format!(
                    "exposure {} with duty {}",
                    pm(r.exposure_us, r.exposure_us_sigma, 2),
                    pm(r.duty, r.duty_sigma, 4)
                )
            })
            .collect();
        writeln!(
            w,
            "exposure_us, duty: {} readings fit alike: {} (a band is the ON time convolved with the exposure window: it looks the same whichever is longer, and, with ambient light, for their complements; give --duty to choose)",
            each.len(),
            each.join("; or ")
        )?;
    }
    match (cal.duty, cal.duty_sigma, cal.duty_min, cal.duty_max) {
        (Some(d), Some(s), _, _) => writeln!(w, "duty:           {}", pm(d, s, 4))?,
        (_, _, Some(lo), Some(hi)) => writeln!(
            w,
            "duty:           {lo:.4} ..= {hi:.4} (undetermined: rows clip; give --duty)"
        )?,
        _ => {}
    }
    writeln!(w, "gamma:          {}", pm(cal.gamma, cal.gamma_sigma, 3))?;
    match (
        cal.black_level_dn,
        cal.black_level_dn_sigma,
        cal.black_level_dn_max,
    ) {
        (Some(b), Some(s), _) => writeln!(w, "black_level_dn: {}", pm(b, s, 2))?,
        (_, _, Some(m)) => writeln!(
            w,
            "black_level_dn: <= {m:.2} (undetermined: trades off with ambient light)"
        )?,
        _ => {}
    }
    match (cal.saturation_dn, cal.saturation_dn_min, cal.flat_top) {
        (Some(s), _, _) => writeln!(
            w,
            "saturation_dn:  {s:.2} (clipped at {s:.0} DN: the flat tops sit at full scale)"
        )?,
        (None, Some(m), Some(FlatTop::Plateau)) => writeln!(
            w,
            "saturation_dn:  >= {m:.2} (plateau below full scale: the exposure and the ON time differ in length)"
        )?,
        (None, Some(m), _) => writeln!(w, "saturation_dn:  >= {m:.2} (no row clipped)")?,
        _ => {}
    }
    writeln!(w, "fit_rms:        {:.4} of full scale", cal.fit_rms)?;
    if let Some(r) = cal.profile_rms {
        writeln!(
            w,
            "profile_rms:    {r:.4} of full scale (simulator with the fitted profile)"
        )?;
    }
    if let Some(p) = out {
        writeln!(w, "profile:        {}", p.display())?;
    }
    write_caveats(&mut w, &cal.dropped_columns, cal.block_grid_suppressed)
}
