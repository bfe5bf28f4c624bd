//! Colour: per-channel modulation and chroma shift of an RGB or white LED
//! seen by a camera, in the simulator and on captured RGB traces.
//!
//! Self-contained (the simulator's camera model is being rewritten): a pixel
//! is `background_c + led_c * s_c` per channel `c` in linear camera RGB,
//! where `s_c` is the exposure's ON fraction of the die that feeds channel
//! `c`. A white (phosphor) LED has one die, so all `s_c` are equal and the
//! colour shifts only through the mix with the background; an RGB LED has
//! three dies with their own duties, so the colour shifts with the phase.
//!
//! Chroma is BT.709 Y'CbCr applied to linear RGB (`Y = 0.2126 R + 0.7152 G
//! + 0.0722 B`, `Cb = (B - Y) / 1.8556`, `Cr = (R - Y) / 1.5748`), so it is a
//! linear function of the three ON fractions. Each `s_c` is piecewise
//! linear in the phase with corners where an exposure edge meets a PWM edge
//! of that die, so between the union of those corners the pixel moves on a
//! straight line in (Cb, Cr): its distance from a fixed point is largest at
//! a corner, and its hue angle is monotone. Extremes over phase are exact at
//! the corners, as in [`ledflicker_physics::Shutter::phase_envelope`].
//!
//! Spectra are reduced to camera RGB by integrating against channel
//! sensitivities; [`GaussianSensitivity`] is a stand-in for a measured
//! camera (peaks 600, 540, 460 nm), documented as such.

// Channel loops index several RGB arrays by the same k; zipping three or
// four arrays reads worse than `for k in 0..3`.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use ledflicker_physics::pwm::{on_fraction, wrap_unit};

/// Linear camera RGB, arbitrary units (>= 0).
pub type Rgb = [f64; 3];

/// Y, Cb, Cr (BT.709 coefficients) of linear RGB.
pub fn ycbcr(c: Rgb) -> [f64; 3] {
    let y = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    [y, (c[2] - y) / 1.8556, (c[0] - y) / 1.5748]
}

/// Hue angle in degrees, `atan2(Cr, Cb)`, in (-180, 180].
pub fn hue_deg(c: Rgb) -> f64 {
    let [_, cb, cr] = ycbcr(c);
    cr.atan2(cb).to_degrees()
}

fn wrap_deg(x: f64) -> f64 {
    let w = (x + 180.0).rem_euclid(360.0) - 180.0;
    if w == -180.0 { 180.0 } else { w }
}

/// One channel's die: its peak contribution when ON for the whole
/// exposure, its duty and its rising edge in cycles after the common one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Die {
    /// Linear camera RGB added by this die fully ON (>= 0 each).
    pub rgb: Rgb,
    /// Duty in (0, 1].
    pub duty: f64,
    /// Rising edge, PWM cycles after the common reference, `[0, 1)`.
    pub offset_cycles: f64,
}

/// Colour KPIs of one condition.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColourFlicker {
    /// Percent Flicker of R, G and B, worst over phase (`None` where a
    /// channel has no light).
    pub percent_flicker_rgb: [Option<f64>; 3],
    /// Largest distance in (Cb, Cr) from the steady colour (each die at its
    /// duty), over the steady luma Y; 0 when the colour never shifts.
    pub chroma_shift: f64,
    /// Largest hue change from the steady colour, degrees (0..=180); `None`
    /// when the steady colour is grey (hue undefined).
    pub hue_shift_deg: Option<f64>,
    /// Phase (cycles) of the largest chroma shift.
    pub worst_phase_cycles: f64,
}

/// Pixel colour at start phase `phase` (cycles) for an exposure of `width`
/// cycles.
pub fn pixel(background: Rgb, dies: &[Die], phase: f64, width: f64) -> Rgb {
    let mut c = background;
    for d in dies {
        let s = on_fraction(wrap_unit(phase - d.offset_cycles), width, d.duty);
        for k in 0..3 {
            c[k] += d.rgb[k] * s;
        }
    }
    c
}

/// The phases (cycles) where some die's ON fraction has a corner.
fn corners(dies: &[Die], width: f64) -> Vec<f64> {
    dies.iter()
        .flat_map(|d| [0.0, d.duty, -width, d.duty - width].map(|c| wrap_unit(c + d.offset_cycles)))
        .collect()
}

/// Colour KPIs, exact over phase, for an exposure of `width_cycles` PWM
/// cycles (> 0).
pub fn colour_flicker(background: Rgb, dies: &[Die], width_cycles: f64) -> ColourFlicker {
    let mut steady = background;
    for d in dies {
        for k in 0..3 {
            steady[k] += d.rgb[k] * d.duty;
        }
    }
    let [y0, cb0, cr0] = ycbcr(steady);
    let grey = cb0.hypot(cr0) <= 1e-12 * y0.abs().max(1e-300);
    let h0 = hue_deg(steady);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut shift = 0.0;
    let mut worst_phase = 0.0;
    let mut hue_shift: f64 = 0.0;
    let mut phases = corners(dies, width_cycles);
    phases.sort_by(f64::total_cmp);
    let points: Vec<[f64; 3]> = phases
        .iter()
        .map(|&p| ycbcr(pixel(background, dies, p, width_cycles)))
        .collect();
    for (&p, &[_, cb, cr]) in phases.iter().zip(&points) {
        let c = pixel(background, dies, p, width_cycles);
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
        let d = (cb - cb0).hypot(cr - cr0) / y0.max(f64::MIN_POSITIVE);
        if d > shift {
            shift = d;
            worst_phase = p;
        }
        if !grey && cb.hypot(cr) > 0.0 {
            hue_shift = hue_shift.max(wrap_deg(cr.atan2(cb).to_degrees() - h0).abs());
        }
    }
    // The wrapped hue change peaks at 180 degrees inside a segment that
    // crosses the ray opposite the steady hue, not at its corners.
    if !grey {
        let n = cb0.hypot(cr0);
        let u = (-cb0 / n, -cr0 / n);
        let cross = |q: &[f64; 3]| u.0 * q[2] - u.1 * q[1];
        let dot = |cb: f64, cr: f64| u.0 * cb + u.1 * cr;
        for i in 0..points.len() {
            let (a, b) = (&points[i], &points[(i + 1) % points.len()]);
            let (ca, cbx) = (cross(a), cross(b));
            if (ca <= 0.0) != (cbx <= 0.0) {
                let t = ca / (ca - cbx);
                if dot(a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])) > 0.0 {
                    hue_shift = 180.0;
                }
            }
        }
    }
    let pf = |k: usize| (hi[k] + lo[k] > 0.0).then(|| 100.0 * (hi[k] - lo[k]) / (hi[k] + lo[k]));
    ColourFlicker {
        percent_flicker_rgb: [pf(0), pf(1), pf(2)],
        chroma_shift: shift,
        hue_shift_deg: (!grey).then_some(hue_shift),
        worst_phase_cycles: worst_phase,
    }
}

/// Colour KPIs of a captured trace of ROI-mean RGB per frame, against a
/// steady reference colour (the ON segment's mean); the trace samples the
/// phases it happened to hit, so these are lower bounds of the exact ones.
pub fn trace_colour_flicker(trace: &[Rgb], steady: Rgb) -> ColourFlicker {
    let [y0, cb0, cr0] = ycbcr(steady);
    let grey = cb0.hypot(cr0) <= 1e-12 * y0.abs().max(1e-300);
    let h0 = hue_deg(steady);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let (mut shift, mut hue_shift, mut worst) = (0.0, 0.0f64, 0usize);
    for (i, c) in trace.iter().enumerate() {
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
        let [_, cb, cr] = ycbcr(*c);
        let d = (cb - cb0).hypot(cr - cr0) / y0.max(f64::MIN_POSITIVE);
        if d > shift {
            shift = d;
            worst = i;
        }
        if !grey && cb.hypot(cr) > 0.0 {
            hue_shift = hue_shift.max(wrap_deg(hue_deg(*c) - h0).abs());
        }
    }
    let pf = |k: usize| (hi[k] + lo[k] > 0.0).then(|| 100.0 * (hi[k] - lo[k]) / (hi[k] + lo[k]));
    ColourFlicker {
        percent_flicker_rgb: [pf(0), pf(1), pf(2)],
        chroma_shift: shift,
        hue_shift_deg: (!grey).then_some(hue_shift),
        worst_phase_cycles: worst as f64,
    }
}

/// Gaussian channel sensitivities: a stand-in for a measured camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianSensitivity {
    /// Peak wavelengths of R, G, B, nm.
    pub peak_nm: [f64; 3],
    /// Standard deviations, nm.
    pub sigma_nm: [f64; 3],
}

impl Default for GaussianSensitivity {
    /// Peaks 600, 540 and 460 nm, sigma 35 nm: roughly a CMOS sensor
    /// behind an IR-cut filter (not a measured camera).
    fn default() -> Self {
        Self {
            peak_nm: [600.0, 540.0, 460.0],
            sigma_nm: [35.0, 35.0, 35.0],
        }
    }
}

/// Camera RGB of a sampled spectrum `(wavelength nm, power)` (ascending
/// wavelengths), by the trapezoid rule against `sens`.
pub fn reduce_spectrum(spectrum: &[(f64, f64)], sens: &GaussianSensitivity) -> Rgb {
    let mut out = [0.0; 3];
    for k in 0..3 {
        let s = |l: f64| (-0.5 * ((l - sens.peak_nm[k]) / sens.sigma_nm[k]).powi(2)).exp();
        out[k] = spectrum
            .windows(2)
            .map(|w| 0.5 * (w[1].0 - w[0].0) * (w[0].1 * s(w[0].0) + w[1].1 * s(w[1].0)))
            .sum();
    }
    out
}

/// A Gaussian emission line sampled every nm over 380..780 nm.
pub fn gaussian_spectrum(peak_nm: f64, sigma_nm: f64, power: f64) -> Vec<(f64, f64)> {
    (380..=780)
        .map(|l| {
            let l = l as f64;
            (l, power * (-0.5 * ((l - peak_nm) / sigma_nm).powi(2)).exp())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white_die(duty: f64) -> Die {
        Die {
            rgb: [1.0, 1.0, 1.0],
            duty,
            offset_cycles: 0.0,
        }
    }

    #[test]
    fn white_led_on_grey_never_shifts_colour() {
        let c = colour_flicker([0.2, 0.2, 0.2], &[white_die(0.3)], 0.45);
        assert!(c.chroma_shift < 1e-12);
        assert_eq!(c.hue_shift_deg, None);
        // All channels flicker alike: as the single-channel envelope.
        let pf = c.percent_flicker_rgb[0].unwrap();
        assert!((pf - c.percent_flicker_rgb[2].unwrap()).abs() < 1e-12);
    }

    /// Exact corners against a dense phase sweep (a lower bound).
    #[test]
    fn rgb_led_chroma_shift_is_exact_at_the_corners() {
        let dies = [
            Die {
                rgb: [0.9, 0.1, 0.0],
                duty: 0.3,
                offset_cycles: 0.0,
            },
            Die {
                rgb: [0.1, 0.8, 0.1],
                duty: 0.55,
                offset_cycles: 0.1,
            },
            Die {
                rgb: [0.0, 0.1, 0.9],
                duty: 0.2,
                offset_cycles: 0.6,
            },
        ];
        let bg = [0.05, 0.05, 0.05];
        for width in [0.17, 0.6, 1.3, 2.45] {
            let c = colour_flicker(bg, &dies, width);
            let mut steady = bg;
            for d in &dies {
                for k in 0..3 {
                    steady[k] += d.rgb[k] * d.duty;
                }
            }
            let trace: Vec<Rgb> = (0..20_000)
                .map(|i| pixel(bg, &dies, i as f64 / 20_000.0, width))
                .collect();
            let t = trace_colour_flicker(&trace, steady);
            assert!(c.chroma_shift >= t.chroma_shift - 1e-12, "w={width}");
            assert!(
                c.chroma_shift - t.chroma_shift < 1e-3,
                "w={width}: {} vs {}",
                c.chroma_shift,
                t.chroma_shift
            );
            let (h, th) = (c.hue_shift_deg.unwrap(), t.hue_shift_deg.unwrap());
            assert!(h >= th - 1e-9 && h - th < 0.1, "w={width}: {h} vs {th}");
            assert!(c.chroma_shift > 0.01);
        }
        // A whole number of periods: every die at its duty, no shift.
        let c = colour_flicker(bg, &dies, 2.0);
        assert!(c.chroma_shift < 1e-12 && c.hue_shift_deg.unwrap() < 1e-9);
    }

    #[test]
    fn spectrum_reduction_matches_the_gaussian_product_integral() {
        // Integral of two Gaussians: sqrt(2 pi) s1 s2 / sqrt(s1^2 + s2^2)
        // * exp(-(m1 - m2)^2 / (2 (s1^2 + s2^2))).
        let sens = GaussianSensitivity::default();
        let (m, s) = (525.0, 12.0);
        let rgb = reduce_spectrum(&gaussian_spectrum(m, s, 1.0), &sens);
        for k in 0..3 {
            let (m2, s2) = (sens.peak_nm[k], sens.sigma_nm[k]);
            let v = s * s + s2 * s2;
            let exact = (2.0 * std::f64::consts::PI).sqrt() * s * s2 / v.sqrt()
                * (-(m - m2).powi(2) / (2.0 * v)).exp();
            assert!(
                (rgb[k] - exact).abs() < 1e-6 * exact.max(1e-3),
                "{k}: {} vs {exact}",
                rgb[k]
            );
        }
        assert!(rgb[1] > rgb[0] && rgb[1] > rgb[2]);
    }
}
