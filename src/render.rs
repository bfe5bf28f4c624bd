//! Frames of the ideal camera as 8-bit grey PNG files, for the example lab
//! rig (examples/sim-rig.sh) and for trying the captured-data path.
//!
//! Each row `r` of frame `k` is `background + gain * s`, rounded, where `s`
//! is the fraction of that row's exposure during which the LED was ON: the
//! duty cycle in the steady-ON segment (luminance matched to the PWM
//! average), 0 when OFF, and the exact PWM integral of
//! [`crate::physics::Shutter::frame_on_fraction`] in the PWM segment. The
//! whole frame is lit by the LED (a diffusely lit scene).

use std::path::Path;

use crate::physics::{PwmDrive, Shutter};

/// What to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSpec {
    /// Exposure timing (global or rolling shutter).
    pub shutter: Shutter,
    /// Frame width, pixels (>= 1).
    pub width: u32,
    /// Frame height, rows (>= 1).
    pub height: u32,
    /// Steady-ON, OFF and PWM frame counts.
    pub frames: (u64, u64, u64),
    /// Level with the LED off, DN.
    pub background_dn: f64,
    /// Level added by the LED fully on, DN.
    pub gain_dn: f64,
}

/// Writes `frame_000000.png`, ... into `dir`; returns the number written.
pub fn render_frames(spec: &RenderSpec, pwm: &PwmDrive, dir: &Path) -> Result<u64, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create `{}`: {e}", dir.display()))?;
    let (on, off, n_pwm) = spec.frames;
    let total = on + off + n_pwm;
    for k in 0..total {
        let mut img = image::GrayImage::new(spec.width, spec.height);
        for row in 0..spec.height {
            let s = if k < on {
                pwm.duty()
            } else if k < on + off {
                0.0
            } else {
                spec.shutter.frame_on_fraction(pwm, k, row..row + 1)
            };
            let v = (spec.background_dn + spec.gain_dn * s)
                .round()
                .clamp(0.0, 255.0) as u8;
            for x in 0..spec.width {
                img.put_pixel(x, row, image::Luma([v]));
            }
        }
        let path = dir.join(format!("frame_{k:06}.png"));
        img.save(&path)
            .map_err(|e| format!("cannot write `{}`: {e}", path.display()))?;
    }
    Ok(total)
}
