//! A small generator of banding frames, independent of the simulator and
//! of `ledflicker::calibrate::synth`: a rolling shutter under PWM lights in
//! closed form, written as PNG or as JPEG at a chosen quality. The tests of
//! `bands_robust.rs` compute their truth from the same closed form.

use std::ops::Range;
use std::path::Path;

/// One PWM light over a range of columns. Rows are the time unit: row `r`
/// exposes over `[r, r + exposure_rows)` row times.
#[derive(Debug, Clone)]
pub struct Light {
    /// Columns it lights.
    pub columns: Range<u32>,
    /// Rows it lights.
    pub rows: Range<u32>,
    /// PWM period, rows (`1 / (f t_line)`).
    pub period_rows: f64,
    /// Duty cycle in (0, 1).
    pub duty: f64,
    /// First rising edge, rows.
    pub first_rise_rows: f64,
}

/// The ON share of `[r, r + e)` under a square wave of period `p` rows,
/// duty `d`, rising at `r0 + k p`: the ON time from the first rise to `u`
/// cycles is `floor(u) d + min(frac(u), d)`.
pub fn on_share(r: f64, e: f64, p: f64, d: f64, r0: f64) -> f64 {
    let g = |u: f64| u.floor() * d + (u - u.floor()).min(d);
    (g((r + e - r0) / p) - g((r - r0) / p)) * p / e
}

/// A grey 8-bit frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Width, pixels.
    pub width: u32,
    /// Height, rows.
    pub height: u32,
    /// Exposure, rows.
    pub exposure_rows: f64,
    /// Level where no light falls, DN, at the top and at the bottom row
    /// (a vertical gradient between them).
    pub dark_dn: (f64, f64),
    /// Level added across every 64 columns, from 0 at the first to this at
    /// the last, DN (a fine horizontal texture).
    pub ripple_dn: f64,
    /// Level a light adds at full ON, DN.
    pub lit_dn: f64,
    /// The lights, each over its own columns.
    pub lights: Vec<Light>,
    /// Peak-to-peak of a deterministic per-pixel dither, DN.
    pub dither_dn: f64,
    /// Static bright rectangles `(columns, rows)` drawn over everything.
    pub overlays: Vec<(Range<u32>, Range<u32>)>,
}

impl Frame {
    /// A dark frame with one light over all columns.
    pub fn lit(width: u32, height: u32, period_rows: f64) -> Self {
        Self {
            width,
            height,
            exposure_rows: 2.0,
            dark_dn: (20.0, 20.0),
            lit_dn: 180.0,
            lights: vec![Light {
                columns: 0..width,
                rows: 0..height,
                period_rows,
                duty: 0.4,
                first_rise_rows: 3.0,
            }],
            ripple_dn: 0.0,
            dither_dn: 2.0,
            overlays: Vec::new(),
        }
    }

    /// The pixel at column `x`, row `y`, DN (not yet rounded).
    pub fn pixel(&self, x: u32, y: u32) -> f64 {
        if self
            .overlays
            .iter()
            .any(|(c, r)| c.contains(&x) && r.contains(&y))
        {
            return 235.0;
        }
        let t = y as f64 / (self.height.max(2) - 1) as f64;
        let mut v = self.dark_dn.0
            + (self.dark_dn.1 - self.dark_dn.0) * t
            + self.ripple_dn * (x % 64) as f64 / 63.0;
        for l in &self.lights {
            if l.columns.contains(&x) && l.rows.contains(&y) {
                let s = on_share(
                    y as f64,
                    self.exposure_rows,
                    l.period_rows,
                    l.duty,
                    l.first_rise_rows,
                );
                v += self.lit_dn * s;
            }
        }
        v + self.dither_dn * (dither(x, y) - 0.5)
    }

    /// Writes the frame: PNG, or JPEG at `quality` for `.jpg`.
    pub fn save(&self, path: &Path, quality: u8) {
        let img = image::ImageBuffer::from_fn(self.width, self.height, |x, y| {
            image::Luma([self.pixel(x, y).round().clamp(0.0, 255.0) as u8])
        });
        if path.extension().is_some_and(|e| e == "jpg") {
            let file = std::fs::File::create(path).unwrap();
            let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(
                std::io::BufWriter::new(file),
                quality,
            );
            enc.encode_image(&img).unwrap();
        } else {
            img.save(path).unwrap();
        }
    }
}

/// Deterministic dither in [0, 1) from the pixel's position: the
/// splitmix64 finaliser, so that no row or column pattern survives.
fn dither(x: u32, y: u32) -> f64 {
    let mut z = (u64::from(x) << 32 | u64::from(y)).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// A dark frame whose only lights are a few small, directly imaged LEDs
/// (PWM period `led_period_rows`), over a faint vertical gradient.
pub fn small_leds(width: u32, height: u32, led_period_rows: f64) -> Frame {
    let spot = |cx: u32, cy: u32| Light {
        columns: cx..cx + 6,
        rows: cy..cy + 6,
        period_rows: led_period_rows,
        duty: 0.5,
        first_rise_rows: 0.0,
    };
    let mut f = Frame {
        dark_dn: (8.0, 30.0),
        lights: vec![
            spot(width / 7, height / 5),
            spot(width / 2, height / 2),
            spot(5 * width / 6, 3 * height / 4),
        ],
        ..Frame::lit(width, height, led_period_rows)
    };
    f.lit_dn = 230.0;
    f
}

#[test]
fn the_closed_form_is_the_integral_of_the_square_wave() {
    // The ON share against a fine Riemann sum of the square wave.
    for (r, e, p, d, r0) in [(0.0, 2.0, 37.3, 0.4, 3.0), (101.5, 7.7, 16.0, 0.1, -4.2)] {
        let steps = 200_000;
        let on = (0..steps)
            .filter(|k| {
                let t = r + e * (*k as f64 + 0.5) / steps as f64;
                ((t - r0) / p).rem_euclid(1.0) < d
            })
            .count() as f64
            / steps as f64;
        assert!((on_share(r, e, p, d, r0) - on).abs() < 1e-4, "{r} {e} {p}");
    }
}
