//! Colour flicker in CIE terms: the chromaticity of an ROI's light frame
//! by frame, from its camera RGB through a camera-to-XYZ matrix, its
//! excursion in u'v', and the frames whose colour leaves a signal-colour
//! region (docs/visibility.md, section 6). It sees per-frame RGB values
//! only, never how they were made: the simulator gives them for an LED ROI
//! of a plan with colour ([`of_trace`]). `analysis::colour` models the RGB LED's side (per-die duty and phase,
//! hue over phase in BT.709 Cb/Cr) for `simulate --summary`.

use serde::{Deserialize, Serialize};

use super::flicker::Metric;
use super::p2020::{self, P2020Metrics, P2020Options};
use crate::plan::colour::{ColourConfig, SignalColourName};
use crate::trace::Segment;

/// A 3 x 3 matrix from linear camera RGB to CIE 1931 XYZ, rows X, Y, Z.
pub type CameraToXyz = [[f64; 3]; 3];

/// Linear sRGB to XYZ (IEC 61966-2-1, D65 white): the default for a
/// camera whose colour is not characterised.
pub const SRGB_TO_XYZ: CameraToXyz = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// `rgb` (linear camera values) as XYZ through `m`.
pub fn xyz(m: &CameraToXyz, rgb: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * rgb[0] + row[1] * rgb[1] + row[2] * rgb[2])
}

/// CIE 1931 chromaticity `(x, y)` of `xyz`; `None` without light.
pub fn xy([x, y, z]: [f64; 3]) -> Option<(f64, f64)> {
    let sum = x + y + z;
    (sum > 0.0).then(|| (x / sum, y / sum))
}

/// CIE 1976 UCS chromaticity `(u', v')` of `xyz`:
/// `u' = 4X / (X + 15Y + 3Z)`, `v' = 9Y / (X + 15Y + 3Z)`; `None` without
/// light.
pub fn uv([x, y, z]: [f64; 3]) -> Option<(f64, f64)> {
    let d = x + 15.0 * y + 3.0 * z;
    (d > 0.0).then(|| (4.0 * x / d, 9.0 * y / d))
}

/// A signal colour of a vehicle lamp, as UN Regulation No. 48 paragraph
/// 2.30 bounds it in the CIE 1931 chromaticity diagram (`z = 1 - x - y`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignalColour {
    /// Red: towards yellow `y <= 0.335`, towards purple `z <= 0.008`.
    Red,
    /// Amber: towards green `y <= 0.429`, towards red `y >= 0.398`,
    /// towards white `z <= 0.007`.
    Amber,
}

impl SignalColour {
    /// The chromaticity `(x, y)` lies in the region (on its edge counts).
    pub fn contains(self, (x, y): (f64, f64)) -> bool {
        let z = 1.0 - x - y;
        match self {
            SignalColour::Red => y <= 0.335 && z <= 0.008,
            SignalColour::Amber => (0.398..=0.429).contains(&y) && z <= 0.007,
        }
    }
}

/// The colour of one ROI over the PWM segment.
#[derive(Debug, Clone, PartialEq)]
pub struct Excursion {
    /// `(u', v')` of the segment's mean XYZ: the colour the frames fuse to.
    pub mean_uv: (f64, f64),
    /// Largest distance of a frame's `(u', v')` from `mean_uv` (>= 0).
    pub delta_uv: f64,
    /// Indices of the frames with light whose colour is outside the region.
    pub outside: Vec<usize>,
    /// Frames without light (no chromaticity): neither in nor out.
    pub dark: usize,
}

/// The chromaticity excursion of frames of linear camera `rgb` seen through `m`,
/// judged against `region`; `None` when no frame has light.
pub fn excursion(rgb: &[[f64; 3]], m: &CameraToXyz, region: SignalColour) -> Option<Excursion> {
    let frames: Vec<[f64; 3]> = rgb.iter().map(|&c| xyz(m, c)).collect();
    let n = frames.len() as f64;
    let mean = [0, 1, 2].map(|i| frames.iter().map(|f| f[i]).sum::<f64>() / n);
    let mean_uv = uv(mean)?;
    let mut delta_uv: f64 = 0.0;
    let mut outside = Vec::new();
    let mut dark = 0;
    for (i, &f) in frames.iter().enumerate() {
        match (uv(f), xy(f)) {
            (Some((u, v)), Some(c)) => {
                delta_uv = delta_uv.max((u - mean_uv.0).hypot(v - mean_uv.1));
                if !region.contains(c) {
                    outside.push(i);
                }
            }
            _ => dark += 1,
        }
    }
    Some(Excursion {
        mean_uv,
        delta_uv,
        outside,
        dark,
    })
}

impl From<SignalColourName> for SignalColour {
    fn from(name: SignalColourName) -> Self {
        match name {
            SignalColourName::Red => SignalColour::Red,
            SignalColourName::Amber => SignalColour::Amber,
        }
    }
}

/// The colour figures of one LED ROI over the PWM segment, as results.json
/// gives them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColourFigures {
    /// Largest distance in u'v' of a frame's colour from the segment's
    /// mean colour; `None` when no frame has light.
    pub delta_uv: Option<f64>,
    /// `(u', v')` of the segment's mean colour; `None` without light.
    pub mean_uv: Option<(f64, f64)>,
    /// The signal colour the plan names (`"red"`, `"amber"`), if any.
    pub region: Option<String>,
    /// PWM frames with light whose colour is outside that region; `None`
    /// without a region.
    pub frames_outside: Option<u64>,
    /// Indices (in the whole trace) of those frames, for the report.
    pub outside_frames: Vec<u64>,
    /// PWM frames.
    pub frames: u64,
    /// FMI, FDI (P2020) and MMP of each colour plane's trace (R, G, B), by
    /// the luma's definitions; empty when not computed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub planes: Vec<P2020Metrics>,
}

/// Why an LED ROI has no Δu′v′.
pub const NO_COLOUR: &str = "no PWM frame has light: no colour";

/// Names of the colour planes in metric ids (`fmi_r`, `mmp_b`).
pub const PLANE_SUFFIXES: [&str; 3] = ["r", "g", "b"];

impl ColourFigures {
    /// Δu′v′ as a metric to check against `delta-uv-max`.
    pub fn delta_uv_metric(&self) -> Metric {
        Metric {
            value: self.delta_uv,
            unbounded: false,
            reason: self.delta_uv.is_none().then(|| NO_COLOUR.to_string()),
        }
    }
}

/// FMI, FDI (P2020) and MMP of each colour plane of an ROI: the plane's DN
/// frame by frame (black level included, as the luma's) through the very
/// code of the luma's KPIs. Empty when the trace has no PWM frames.
pub fn plane_kpis(
    rgb: &[[f64; 3]],
    segments: &[Segment],
    opts: &P2020Options,
) -> Vec<P2020Metrics> {
    (0..3)
        .map(|p| {
            let plane: Vec<f64> = rgb.iter().map(|c| c[p]).collect();
            p2020::evaluate(&plane, segments, opts)
        })
        .collect::<Option<Vec<_>>>()
        .unwrap_or_default()
}

/// The colour of an LED ROI's PWM segment: the planes' DN less the black
/// level (light only) of the frames whose segment is PWM, through the
/// plan's camera-to-XYZ matrix, judged against its signal colour.
pub fn of_trace(
    colour: &ColourConfig,
    rgb: &[[f64; 3]],
    segments: &[Segment],
    black_level_dn: f64,
) -> ColourFigures {
    let (index, light): (Vec<u64>, Vec<[f64; 3]>) = rgb
        .iter()
        .zip(segments)
        .enumerate()
        .filter(|(_, (_, s))| **s == Segment::Pwm)
        .map(|(i, (c, _))| (i as u64, c.map(|v| (v - black_level_dn).max(0.0))))
        .unzip();
    let region = colour.signal.map(SignalColour::from);
    let found = excursion(
        &light,
        &colour.camera_to_xyz,
        region.unwrap_or(SignalColour::Red),
    );
    let outside_frames: Vec<u64> = match (&found, region) {
        (Some(e), Some(_)) => e.outside.iter().map(|&i| index[i]).collect(),
        _ => Vec::new(),
    };
    ColourFigures {
        delta_uv: found.as_ref().map(|e| e.delta_uv),
        mean_uv: found.as_ref().map(|e| e.mean_uv),
        region: colour.signal.map(|s| s.as_str().to_string()),
        frames_outside: region.map(|_| outside_frames.len() as u64),
        outside_frames,
        frames: light.len() as u64,
        planes: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera whose red plane sees a saturated red (x 0.700, y 0.295):
    /// wider than sRGB, whose red primary is too pale for a signal red.
    const WIDE: CameraToXyz = [
        [0.4746, 0.3576, 0.1805],
        [0.2000, 0.7152, 0.0722],
        [0.0034, 0.1192, 0.9505],
    ];

    /// Seconds of `[a, b)` in which a PWM light of `f` Hz and `duty`,
    /// rising at 0, is on.
    fn on_time(f: f64, duty: f64, a: f64, b: f64) -> f64 {
        let up_to = |t: f64| {
            let cycles = (t * f).floor();
            (cycles * duty + (t * f - cycles).min(duty)) / f
        };
        up_to(b) - up_to(a)
    }

    /// A red PWM signal at 90 Hz, 20 % duty, filmed at 29.97 fps with a
    /// 2 ms exposure: the red plane sees 1, the green 0.01 and the blue
    /// nothing of the LED per second on. `shift_s` exposes the green plane
    /// that much later than the red one (a chroma shift).
    fn red_signal(shift_s: f64) -> Vec<[f64; 3]> {
        let (f, duty, fps, exposure) = (90.0, 0.2, 29.97, 0.002);
        (0..300)
            .map(|n| {
                let t = n as f64 / fps;
                let r = on_time(f, duty, t, t + exposure);
                let g = 0.01 * on_time(f, duty, t + shift_s, t + shift_s + exposure);
                [r, g, 0.0]
            })
            .collect()
    }

    #[test]
    fn the_srgb_white_is_d65_and_a_signal_red_is_red() {
        let (x, y) = xy(xyz(&SRGB_TO_XYZ, [1.0, 1.0, 1.0])).unwrap();
        assert!(
            (x - 0.3127).abs() < 2e-4 && (y - 0.3290).abs() < 2e-4,
            "{x} {y}"
        );
        let (u, v) = uv(xyz(&SRGB_TO_XYZ, [1.0, 1.0, 1.0])).unwrap();
        assert!(
            (u - 0.1978).abs() < 3e-4 && (v - 0.4683).abs() < 3e-4,
            "{u} {v}"
        );
        assert!(SignalColour::Red.contains((0.70, 0.295)));
        assert!(
            !SignalColour::Red.contains((0.64, 0.33)),
            "sRGB red is too pale"
        );
        assert!(SignalColour::Amber.contains((0.58, 0.415)));
        assert!(!SignalColour::Amber.contains((0.69, 0.30)));
        assert_eq!(uv([0.0; 3]), None);
    }

    #[test]
    fn a_red_pwm_signal_leaves_the_red_region_only_with_a_chroma_shift() {
        // Without a shift every frame with light has the LED's colour.
        let steady = excursion(&red_signal(0.0), &WIDE, SignalColour::Red).unwrap();
        assert!(steady.delta_uv < 1e-12, "{steady:?}");
        assert!(steady.outside.is_empty(), "{steady:?}");
        assert!(steady.dark > 0, "a 2 ms exposure misses some pulses");
        // With the green plane 1.5 ms late, the planes see different parts
        // of a pulse: some frames turn purple or yellow, out of the region.
        let shifted = excursion(&red_signal(0.0015), &WIDE, SignalColour::Red).unwrap();
        assert!(shifted.delta_uv > 0.01, "{shifted:?}");
        assert!(!shifted.outside.is_empty(), "{shifted:?}");
        let lit = 300 - shifted.dark;
        assert!(
            shifted.outside.len() < lit,
            "{} of {lit}",
            shifted.outside.len()
        );
    }
}
