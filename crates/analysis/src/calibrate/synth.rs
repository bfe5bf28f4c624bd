//! Synthetic banding frames with known camera parameters, degraded as real
//! frames are (noise, gamma, vignetting, scene texture, a text overlay,
//! JPEG): the input of the parameter-recovery tests, the recovery table of
//! docs/calibration.md and the calibration benchmark.
//!
//! Each row's ON fraction comes from the simulator's exact shutter
//! integral ([`ledflicker_physics::Shutter::frame_on_fraction`]); the pixel is
//! `black + A clamp((c0 + c1 s) v t)^(1/gamma) + noise`, with `v` the
//! vignetting and `t` the texture of the pixel.

use std::path::Path;

use ledflicker_physics::sensor::Rng;
use ledflicker_physics::{PwmDrive, Shutter, ShutterModel};
use ledflicker_plan::image_io::{save, save_jpeg_grey};

/// A synthetic frame: camera, light and degradations.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthFrame {
    /// Width, pixels.
    pub width: u32,
    /// Height, rows.
    pub height: u32,
    /// Line time, seconds.
    pub line_time_s: f64,
    /// Exposure, seconds.
    pub exposure_s: f64,
    /// PWM frequency, Hz.
    pub frequency_hz: f64,
    /// Duty cycle in (0, 1].
    pub duty: f64,
    /// First PWM rising edge after row 0 starts, seconds.
    pub first_rise_s: f64,
    /// Black level, DN.
    pub black_dn: f64,
    /// Linear ambient level, fraction of white.
    pub ambient: f64,
    /// Linear LED level at full ON, fraction of white.
    pub led_level: f64,
    /// Tone-curve gamma (`y = u^(1/gamma)`); 1 is linear.
    pub gamma: f64,
    /// Gaussian noise per pixel, DN (one sigma).
    pub noise_dn: f64,
    /// Radial vignetting: `1 - k r^2`, `r` = 1 at the corners.
    pub vignetting: f64,
    /// Multiplicative scene texture depth, 0..1 (0: none).
    pub texture: f64,
    /// Burn in a bright caption over the lower left of the frame.
    pub overlay: bool,
    /// 16-bit output (else 8-bit).
    pub bits16: bool,
    /// Noise and texture seed.
    pub seed: u64,
}

impl SynthFrame {
    /// A clean 1080-row frame of a 1000 Hz, 50 % light (the gyroflow
    /// camera: 14.565 us lines, 62.5 us exposure), gamma 2.2.
    pub fn base() -> Self {
        Self {
            width: 640,
            height: 1080,
            line_time_s: 14.565e-6,
            exposure_s: 62.5e-6,
            frequency_hz: 1000.0,
            duty: 0.5,
            first_rise_s: 0.2e-3,
            black_dn: 4.0,
            ambient: 0.0,
            led_level: 0.5,
            gamma: 2.2,
            noise_dn: 0.0,
            vignetting: 0.0,
            texture: 0.0,
            overlay: false,
            bits16: false,
            seed: 1,
        }
    }

    /// Output full scale, DN.
    pub fn full_scale(&self) -> f64 {
        if self.bits16 { 65535.0 } else { 255.0 }
    }

    /// Luma of every pixel, row-major, DN (not yet quantised).
    pub fn render(&self) -> Result<Vec<f64>, String> {
        let shutter = Shutter {
            model: ShutterModel::Rolling {
                line_time_s: self.line_time_s,
            },
            exposure_s: self.exposure_s,
            fps: 30.0,
        };
        let pwm = PwmDrive::new(self.frequency_hz, self.duty, self.first_rise_s)?;
        let a = self.full_scale();
        let (w, h) = (self.width as usize, self.height as usize);
        let mut rng = Rng::new(self.seed);
        // Texture: a value per 16 x 16 block, fixed by the seed.
        let (bw, bh) = (w.div_ceil(16), h.div_ceil(16));
        let blocks: Vec<f64> = (0..bw * bh)
            .map(|_| 1.0 - self.texture * rng.uniform())
            .collect();
        let mut out = Vec::with_capacity(w * h);
        for y in 0..h {
            let s = shutter.frame_on_fraction(&pwm, 0, y as u32..y as u32 + 1);
            let lin = self.ambient + self.led_level * s;
            for x in 0..w {
                let (dx, dy) = (
                    2.0 * x as f64 / w as f64 - 1.0,
                    2.0 * y as f64 / h as f64 - 1.0,
                );
                let v = 1.0 - self.vignetting * 0.5 * (dx * dx + dy * dy);
                let t = blocks[(y / 16) * bw + x / 16];
                let u = (lin * v * t).clamp(0.0, 1.0);
                let mut p = self.black_dn + a * u.powf(1.0 / self.gamma);
                if self.noise_dn > 0.0 {
                    p += self.noise_dn * rng.normal();
                }
                if self.overlay && caption(x, y, w, h) {
                    p = 0.92 * a;
                }
                out.push(p.clamp(0.0, a));
            }
        }
        Ok(out)
    }

    /// Renders and saves the frame; the extension picks the format (`png`,
    /// `tif`/`tiff`, `jpg`/`jpeg` at quality `jpeg_quality`).
    pub fn save(&self, path: &Path, jpeg_quality: u8) -> Result<(), String> {
        let px = self.render()?;
        let (w, h) = (self.width, self.height);
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let err = |e: image::ImageError| format!("cannot write `{}`: {e}", path.display());
        if self.bits16 {
            let data: Vec<u16> = px.iter().map(|v| v.round() as u16).collect();
            let img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, data)
                .ok_or("frame size mismatch")?;
            return save(&image::DynamicImage::ImageLuma16(img), path).map_err(err);
        }
        let data: Vec<u8> = px.iter().map(|v| v.round() as u8).collect();
        if ext == "jpg" || ext == "jpeg" {
            return save_jpeg_grey(&data, (w, h), path, jpeg_quality).map_err(err);
        }
        let img = image::ImageBuffer::<image::Luma<u8>, _>::from_raw(w, h, data)
            .ok_or("frame size mismatch")?;
        save(&image::DynamicImage::ImageLuma8(img), path).map_err(err)
    }
}

/// A block-letter caption: rows 85-90 % of the height, columns 5-40 % of
/// the width, in 6-pixel strokes with gaps (a third of the strips at most).
fn caption(x: usize, y: usize, w: usize, h: usize) -> bool {
    let (y0, y1) = (h * 85 / 100, h * 90 / 100);
    let (x0, x1) = (w * 5 / 100, w * 40 / 100);
    y >= y0 && y < y1 && x >= x0 && x < x1 && !((x - x0) / 6 + (y - y0) / 4).is_multiple_of(3)
}
