//! `calibrate` on flat-topped band profiles: a plateau below full scale
//! (the exposure window fits inside the ON time) is not clipping, and a
//! profile that does clip at full scale is still reported as clipped.
//!
//! The frames come from a closed form written here, independent of the
//! simulator and of `calibrate::synth`: row `r` exposes over
//! `[r t_line, r t_line + E)` and reads `black + gain x (ON time in the
//! window) / E`, clipped at 255 and rounded to 8 bits.

use std::path::{Path, PathBuf};

use crate::{ledflicker, scratch, stderr};

/// A rolling-shutter camera looking at a PWM light, uniform scene.
#[derive(Debug, Clone, Copy)]
struct Trapezoid {
    rows: u32,
    width: u32,
    line_time_s: f64,
    exposure_s: f64,
    frequency_hz: f64,
    duty: f64,
    black_dn: f64,
    /// Drive of a window that is ON throughout, DN above black (before
    /// clipping at 255).
    gain_dn: f64,
}

impl Trapezoid {
    /// 500 Hz, 50 % duty, 0.4 ms exposure (under the 1 ms ON time), 14.6 us
    /// lines; the tops are flat at 235 of 255.
    fn unclipped() -> Self {
        Self {
            rows: 720,
            width: 64,
            line_time_s: 14.6e-6,
            exposure_s: 0.4e-3,
            frequency_hz: 500.0,
            duty: 0.5,
            black_dn: 10.0,
            gain_dn: 225.0,
        }
    }

    /// ON time of the light in `[0, t)`, seconds, for a light ON on
    /// `[k P, k P + D P)`; `t` may be negative.
    fn on_time_until(&self, t: f64) -> f64 {
        let period = 1.0 / self.frequency_hz;
        let k = (t / period).floor();
        k * self.duty * period + (t - k * period).min(self.duty * period)
    }

    /// Row `r`'s value before rounding, DN, with the light's first rising
    /// edge `delay_s` after row 0 starts exposing.
    fn row(&self, r: u32, delay_s: f64) -> f64 {
        let t0 = r as f64 * self.line_time_s - delay_s;
        let on = self.on_time_until(t0 + self.exposure_s) - self.on_time_until(t0);
        (self.black_dn + self.gain_dn * on / self.exposure_s).min(255.0)
    }

    /// Writes one 8-bit grey PNG per delay into `dir`.
    fn write(&self, dir: &Path, delays_s: &[f64]) -> Vec<PathBuf> {
        delays_s
            .iter()
            .enumerate()
            .map(|(i, &delay)| {
                let rows: Vec<u8> = (0..self.rows)
                    .map(|r| self.row(r, delay).round() as u8)
                    .collect();
                let img = image::ImageBuffer::from_fn(self.width, self.rows, |_, y| {
                    image::Luma([rows[y as usize]])
                });
                let path = dir.join(format!("frame-{i}.png"));
                img.save(&path).unwrap();
                path
            })
            .collect()
    }
}

/// PWM phases of the frames: the bands roll from frame to frame.
const DELAYS_S: [f64; 4] = [0.0, 0.53e-3, 1.07e-3, 1.41e-3];

/// `calibrate --json` on `paths` at the light's frequency, with its text
/// output beside it.
fn calibrate(paths: &[PathBuf], frequency_hz: f64) -> (serde_json::Value, String) {
    let mut args: Vec<String> = vec!["calibrate".into()];
    args.extend(paths.iter().map(|p| p.to_str().unwrap().to_string()));
    args.extend(["--frequency-hz".into(), frequency_hz.to_string()]);
    let run = |extra: &[&str]| {
        let mut all: Vec<&str> = args.iter().map(String::as_str).collect();
        all.extend(extra);
        let o = ledflicker(&all);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        o.stdout
    };
    let json = serde_json::from_slice(&run(&["--json"])).unwrap();
    let text = String::from_utf8(run(&[])).unwrap();
    (json, text)
}

fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("`{key}` is not a number: {v:#}"))
}

/// `|value - truth|` is within 3.5 reported sigmas (the recovery test's
/// limit) and within `tol` of the truth.
fn holds(v: &serde_json::Value, key: &str, truth: f64, tol: f64) -> bool {
    let (x, s) = (num(v, key), num(v, &format!("{key}_sigma")));
    (x - truth).abs() <= 3.5 * s && (x - truth).abs() <= tol
}

/// [`holds`], or a failure naming the value.
fn assert_holds(v: &serde_json::Value, key: &str, truth: f64, tol: f64) {
    let (x, s) = (num(v, key), num(v, &format!("{key}_sigma")));
    assert!(
        (x - truth).abs() <= 3.5 * s && (x - truth).abs() <= tol,
        "{key}: {x} +- {s}, truth {truth}: {v:#}"
    );
}

#[test]
fn a_flat_top_below_full_scale_is_a_plateau_of_the_exposure_not_clipping() {
    let cam = Trapezoid::unclipped();
    let dir = scratch("saturation-plateau");
    let paths = cam.write(&dir, &DELAYS_S);
    // The closed form's own top: every row whose window lies inside an ON
    // interval reads black + gain, and no pixel reaches 255.
    let top = cam.black_dn + cam.gain_dn;
    let rows: Vec<f64> = (0..cam.rows).map(|r| cam.row(r, 0.0)).collect();
    let flat = rows.iter().filter(|&&y| (y - top).abs() < 1e-9).count();
    assert!(flat > 100 && top.round() < 255.0, "{flat} rows at {top}");

    let (v, text) = calibrate(&paths, cam.frequency_hz);
    assert!(v["saturation_dn"].is_null(), "{v:#}");
    assert!((num(&v, "saturation_dn_min") - top).abs() <= 1.0, "{v:#}");
    assert_eq!(v["flat_top"], "plateau", "{v:#}");
    assert_holds(&v, "line_time_us", cam.line_time_s * 1e6, 0.001 * 14.6);
    // Exposure and duty swapped fit alike: both readings are given, and
    // one is the camera's, within 3.5 sigmas.
    let solutions = v["solutions"].as_array().unwrap();
    assert_eq!(solutions.len(), 2, "{v:#}");
    assert!(
        solutions.iter().any(|s| {
            holds(s, "exposure_us", cam.exposure_s * 1e6, 0.05 * 400.0)
                && holds(s, "duty", cam.duty, 0.01)
        }),
        "{v:#}"
    );
    let rms = num(&v, "profile_rms");
    assert!(rms < 0.01, "profile_rms {rms}: {v:#}");
    assert!(
        text.contains("plateau below full scale: the exposure and the ON time differ in length"),
        "{text}"
    );
}

#[test]
fn a_profile_driven_past_full_scale_is_still_clipped() {
    // The same camera with the light at twice what the output holds: the
    // tops clip at 255 before the window is fully ON.
    let cam = Trapezoid {
        gain_dn: 450.0,
        ..Trapezoid::unclipped()
    };
    let dir = scratch("saturation-clipped");
    let paths = cam.write(&dir, &DELAYS_S);
    let (v, text) = calibrate(&paths, cam.frequency_hz);
    assert_eq!(v["flat_top"], "clipped", "{v:#}");
    assert!((num(&v, "saturation_dn") - 255.0).abs() <= 1.0, "{v:#}");
    // Clipped tops leave the duty and the exposure trading off: they come
    // out as bounds, which must hold the truth.
    let e = cam.exposure_s * 1e6;
    assert!(
        num(&v, "exposure_us_min") <= e && e <= num(&v, "exposure_us_max"),
        "{v:#}"
    );
    assert!(
        num(&v, "duty_min") <= cam.duty && cam.duty <= num(&v, "duty_max"),
        "{v:#}"
    );
    // The profile holds one member of the family, which the simulator
    // must render back as the frames show.
    let rms = num(&v, "profile_rms");
    assert!(rms < 0.01, "profile_rms {rms}: {v:#}");
    assert!(text.contains("clipped at 255 DN"), "{text}");
}
