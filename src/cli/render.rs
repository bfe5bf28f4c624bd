//! `ledflicker render`: ideal-camera frames (ON, OFF, PWM) as grey PNG
//! files, from the PWM drive and camera flags it shares with `simulate`.

use std::path::PathBuf;

use clap::Args;

use super::EXIT_PASS;
use super::args::{CameraArgs, PwmArgs};
use crate::error::UsageError;
use crate::physics::PwmDrive;

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

pub(super) fn render(a: RenderArgs) -> anyhow::Result<i32> {
    let usage = |m: String| anyhow::Error::from(UsageError(m));
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
    let frames = |d: f64| (d * c.fps).round() as u64;
    let spec = crate::render::RenderSpec {
        shutter: c.shutter(),
        width: a.width,
        height: a.height,
        frames: (frames(a.on_s), frames(a.off_s), frames(a.pwm_s)),
        background_dn: 20.0,
        gain_dn: 200.0,
    };
    let n = crate::render::render_frames(&spec, &pwm, &a.out).map_err(anyhow::Error::msg)?;
    eprintln!("wrote {n} frames to {}", a.out.display());
    Ok(EXIT_PASS)
}
