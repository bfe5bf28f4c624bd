//! Frames of the ideal camera as 8-bit grey PNG files, for the example lab
//! rig (examples/sim-rig.sh) and for trying the captured-data path.
//!
//! Each row `r` of frame `k` is `background + gain * s`, rounded, where `s`
//! is the fraction of that row's exposure during which the LED was ON: the
//! duty cycle in the steady-ON segment (luminance matched to the PWM
//! average), 0 when OFF, and the exact PWM integral of
//! [`ledflicker_physics::Shutter::frame_on_fraction`] in the PWM segment. The
//! whole frame is lit by the LED (a diffusely lit scene).

use std::path::Path;

use ledflicker_physics::{PwmDrive, Shutter};

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
///
/// `dir` must be new or empty: render never replaces a file it did not
/// write. Each frame is written under a temporary name and renamed, and a
/// failure removes the frames written so far (and `dir`, when this call
/// created it), so a failed render leaves nothing half done.
pub fn render_frames(spec: &RenderSpec, pwm: &PwmDrive, dir: &Path) -> Result<u64, RenderError> {
    let created = prepare_dir(dir)?;
    let mut written = Vec::new();
    let result = write_frames(spec, pwm, dir, &mut written).map_err(RenderError::Write);
    if result.is_err() {
        for path in &written {
            let _ = std::fs::remove_file(path);
        }
        if created {
            let _ = std::fs::remove_dir(dir);
        }
    }
    result
}

/// Why [`render_frames`] wrote nothing, or stopped.
#[derive(Debug)]
pub enum RenderError {
    /// The output directory is not one render may write into.
    Refused(String),
    /// Writing failed; the frames written so far were removed.
    Write(String),
}

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Refused(m) | Self::Write(m) => f.write_str(m),
        }
    }
}

/// Checks that `dir` is missing or empty, and creates it when missing.
/// Returns whether it was created.
fn prepare_dir(dir: &Path) -> Result<bool, RenderError> {
    match std::fs::read_dir(dir) {
        Ok(mut entries) => match entries.next() {
            None => Ok(false),
            Some(_) => Err(RenderError::Refused(format!(
                "`{}` is not empty: render writes its frames only into a new or empty \
                 directory, so that it never replaces a file it did not write \
                 (hint: choose another --out, or empty this one)",
                dir.display()
            ))),
        },
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => std::fs::create_dir_all(dir)
            .map(|()| true)
            .map_err(|e| RenderError::Write(format!("cannot create `{}`: {e}", dir.display()))),
        Err(e) => Err(RenderError::Refused(format!(
            "cannot read `{}`: {e} (hint: --out must be a directory)",
            dir.display()
        ))),
    }
}

/// The frames, each written as `.frame_NNNNNN.png.tmp` and renamed;
/// `written` collects the final paths.
fn write_frames(
    spec: &RenderSpec,
    pwm: &PwmDrive,
    dir: &Path,
    written: &mut Vec<std::path::PathBuf>,
) -> Result<u64, String> {
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
        let name = format!("frame_{k:06}.png");
        let (tmp, path) = (dir.join(format!(".{name}.tmp")), dir.join(&name));
        ledflicker_plan::image_io::encode_png(
            img.as_raw(),
            spec.width,
            spec.height,
            image::ExtendedColorType::L8,
        )
        .and_then(|png| std::fs::write(&tmp, png).map_err(image::ImageError::IoError))
        .and_then(|()| std::fs::rename(&tmp, &path).map_err(image::ImageError::IoError))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("cannot write `{}`: {e}", path.display())
        })?;
        written.push(path);
    }
    Ok(total)
}
