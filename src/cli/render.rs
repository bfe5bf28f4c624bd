//! `ledflicker render`: ideal-camera frames (ON, OFF, PWM) as grey PNG
//! files, from the PWM drive and camera flags it shares with `simulate`.

use std::path::PathBuf;

use clap::Args;

use super::args::{CameraArgs, PwmArgs, check_drive_and_camera};
use super::{ExitCode, Failure};
use crate::error::UsageError;
use crate::physics::PwmDrive;
use crate::plan::bounds::{
    MAX_FRAMES_PER_CASE, MAX_OUTPUT_BYTES, MAX_SENSOR_PIXELS, MAX_SENSOR_SIDE,
};

#[derive(Args, Debug)]
pub(super) struct RenderArgs {
    #[command(flatten)]
    pwm: PwmArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// Steady-ON duration, seconds.
    #[arg(long, default_value_t = 0.0)]
    on_s: f64,
    /// OFF duration, seconds.
    #[arg(long, default_value_t = 1.0)]
    off_s: f64,
    /// PWM duration, seconds.
    #[arg(long, default_value_t = 2.0)]
    pwm_s: f64,
    /// Frame width, pixels.
    #[arg(long, default_value_t = 64)]
    width: u32,
    /// Frame height, rows.
    #[arg(long, default_value_t = 48)]
    height: u32,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

pub(super) fn render(a: RenderArgs) -> Result<ExitCode, Failure> {
    let usage = |m: String| Failure::from(UsageError(m));
    let (p, c) = (&a.pwm, &a.camera);
    let pwm = PwmDrive::new(p.frequency_hz, p.duty, p.pwm_delay_ms * 1e-3).map_err(usage)?;
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    if !(c.exposure_ms.is_finite() && c.exposure_ms > 0.0 && c.fps.is_finite() && c.fps > 0.0)
        || !(ok(a.on_s) && ok(a.off_s) && ok(a.pwm_s) && ok(c.line_time_us))
        || a.width == 0
        || a.height == 0
    {
        return Err(usage(
            "--exposure-ms and --fps must be > 0; durations, --line-time-us >= 0; --width, --height >= 1"
                .into(),
        ));
    }
    check_drive_and_camera(p, c)?;
    let frames = |d: f64| (d * c.fps).round() as u64;
    let counts = (frames(a.on_s), frames(a.off_s), frames(a.pwm_s));
    let total = counts.0.saturating_add(counts.1).saturating_add(counts.2);
    check_size(a.width, a.height, total)?;
    let spec = crate::render::RenderSpec {
        shutter: c.shutter(),
        width: a.width,
        height: a.height,
        frames: counts,
        background_dn: 20.0,
        gain_dn: 200.0,
    };
    let n = crate::render::render_frames(&spec, &pwm, &a.out).map_err(|e| match e {
        crate::render::RenderError::Refused(m) => usage(m),
        crate::render::RenderError::Write(m) => Failure::Internal(m),
    })?;
    eprintln!("wrote {n} frames to {}", a.out.display());
    Ok(ExitCode::Pass)
}

/// Frame size and count within the limits of a plan's sensor and case
/// (docs/plan-format.md, "Limits"), and at most [`MAX_OUTPUT_BYTES`]
/// of pixels in all, so that a typing slip cannot fill the disk.
fn check_size(width: u32, height: u32, frames: u64) -> Result<(), UsageError> {
    let pixels = u64::from(width) * u64::from(height);
    let problem = if width.max(height) > MAX_SENSOR_SIDE {
        format!("--width and --height must be at most {MAX_SENSOR_SIDE}")
    } else if pixels > MAX_SENSOR_PIXELS {
        format!("a frame must have at most {MAX_SENSOR_PIXELS} pixels, got {width} x {height}")
    } else if frames > MAX_FRAMES_PER_CASE {
        format!(
            "at most {MAX_FRAMES_PER_CASE} frames, got {frames} (--on-s + --off-s + --pwm-s times --fps)"
        )
    } else if pixels as f64 * frames as f64 > MAX_OUTPUT_BYTES {
        format!(
            "{frames} frames of {width} x {height} are {:.1} GB of pixels, more than the {:.0} GB limit; render fewer or smaller frames",
            (pixels * frames) as f64 / 1e9,
            MAX_OUTPUT_BYTES / 1e9
        )
    } else {
        return Ok(());
    };
    Err(UsageError(problem))
}
