//! Colour flicker in CIE terms: the chromaticity of an ROI's light frame
//! by frame, from its camera RGB through a camera-to-XYZ matrix, its
//! excursion in u'v', and the frames whose colour leaves a signal-colour
//! region (docs/visibility.md, section 6). It sees per-frame RGB values
//! only, never how they were made: the simulator gives them for an LED ROI
//! of a plan with colour ([`of_trace`]). `analysis::colour` models the RGB LED's side (per-die duty and phase,
//! hue over phase in BT.709 Cb/Cr) for `simulate --summary`.

use serde::{Deserialize, Serialize};

use super::metric::Metric;
use super::p2020::{self, P2020Metrics, P2020Options};
use ledflicker_plan::plan::colour::{ColourConfig, SignalColourName};
use ledflicker_plan::trace::Segment;

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

impl SignalColour {
    /// The region's boundary lines of UN R48 paragraph 2.30 as half-planes
    /// `a x + b y <= c` in CIE 1931 `(x, y)`; the spectrum locus closes it.
    pub fn half_planes(self) -> &'static [(f64, f64, f64)] {
        match self {
            // y <= 0.335; z <= 0.008, i.e. -x - y <= -0.992.
            SignalColour::Red => &[(0.0, 1.0, 0.335), (-1.0, -1.0, -0.992)],
            // y <= 0.429; y >= 0.398; z <= 0.007.
            SignalColour::Amber => &[(0.0, 1.0, 0.429), (0.0, -1.0, -0.398), (-1.0, -1.0, -0.993)],
        }
    }

    /// The region as a polygon in `(x, y)`: the spectrum locus closed by
    /// the purple line ([`SPECTRUM_LOCUS`]), clipped by each boundary line
    /// (Sutherland-Hodgman), vertices in order.
    pub fn polygon_xy(self) -> Vec<(f64, f64)> {
        let mut poly: Vec<(f64, f64)> = SPECTRUM_LOCUS.iter().map(|&(_, x, y)| (x, y)).collect();
        for &(a, b, c) in self.half_planes() {
            let inside = |p: (f64, f64)| a * p.0 + b * p.1 <= c;
            let cut = |p: (f64, f64), q: (f64, f64)| {
                let (fp, fq) = (a * p.0 + b * p.1 - c, a * q.0 + b * q.1 - c);
                let t = fp / (fp - fq);
                (p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1))
            };
            let mut out = Vec::with_capacity(poly.len() + 2);
            for (i, &q) in poly.iter().enumerate() {
                let p = poly[(i + poly.len() - 1) % poly.len()];
                match (inside(p), inside(q)) {
                    (true, true) => out.push(q),
                    (true, false) => out.push(cut(p, q)),
                    (false, true) => {
                        out.push(cut(p, q));
                        out.push(q);
                    }
                    (false, false) => {}
                }
            }
            poly = out;
        }
        poly
    }
}

/// The spectrum locus of the CIE 1931 standard colorimetric observer
/// (2°): wavelength (nm) and chromaticity `(x, y)` of monochromatic light
/// (CIE 15:2004, from the colour-matching functions at 5 to 20 nm steps;
/// finer where the locus bends). The polygon closes with the purple line
/// from 700 nm back to 380 nm; beyond 700 nm the locus stays at 700 nm's
/// chromaticity to four decimals.
pub const SPECTRUM_LOCUS: &[(u32, f64, f64)] = &[
    (380, 0.1741, 0.0050),
    (420, 0.1714, 0.0051),
    (440, 0.1644, 0.0109),
    (450, 0.1566, 0.0177),
    (460, 0.1440, 0.0297),
    (470, 0.1241, 0.0578),
    (475, 0.1096, 0.0868),
    (480, 0.0913, 0.1327),
    (485, 0.0687, 0.2007),
    (490, 0.0454, 0.2950),
    (495, 0.0235, 0.4127),
    (500, 0.0082, 0.5384),
    (505, 0.0039, 0.6548),
    (510, 0.0139, 0.7502),
    (515, 0.0389, 0.8120),
    (520, 0.0743, 0.8338),
    (525, 0.1142, 0.8262),
    (530, 0.1547, 0.8059),
    (540, 0.2296, 0.7543),
    (550, 0.3016, 0.6923),
    (560, 0.3731, 0.6245),
    (570, 0.4441, 0.5547),
    (575, 0.4788, 0.5202),
    (580, 0.5125, 0.4866),
    (585, 0.5448, 0.4544),
    (590, 0.5752, 0.4242),
    (595, 0.6029, 0.3965),
    (600, 0.6270, 0.3725),
    (605, 0.6482, 0.3514),
    (610, 0.6658, 0.3340),
    (615, 0.6801, 0.3197),
    (620, 0.6915, 0.3083),
    (625, 0.7006, 0.2993),
    (630, 0.7079, 0.2920),
    (635, 0.7140, 0.2859),
    (640, 0.7190, 0.2809),
    (650, 0.7260, 0.2740),
    (660, 0.7300, 0.2700),
    (680, 0.7334, 0.2666),
    (700, 0.7347, 0.2653),
];

/// CIE 1976 `(u', v')` of the chromaticity `(x, y)`.
pub fn uv_of_xy((x, y): (f64, f64)) -> (f64, f64) {
    let d = -2.0 * x + 12.0 * y + 3.0;
    (4.0 * x / d, 9.0 * y / d)
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
    excursion_from(rgb, m, region, None)
}

/// [`excursion`] measured from `reference` (linear camera RGB) instead of
/// the frames' mean when it is given: the colour the light fuses to when
/// the frames, sampling a few phases, may not.
pub fn excursion_from(
    rgb: &[[f64; 3]],
    m: &CameraToXyz,
    region: SignalColour,
    reference: Option<[f64; 3]>,
) -> Option<Excursion> {
    let frames: Vec<[f64; 3]> = rgb.iter().map(|&c| xyz(m, c)).collect();
    let n = frames.len() as f64;
    let mean = match reference {
        Some(c) => xyz(m, c),
        None => [0, 1, 2].map(|i| frames.iter().map(|f| f[i]).sum::<f64>() / n),
    };
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
    /// `(u', v')` of the segment's mean colour; `None` without light. For
    /// an LED of dies, the colour the light fuses to over time instead
    /// ([`ColourFigures::mean_is_time_average`]).
    pub mean_uv: Option<(f64, f64)>,
    /// `mean_uv` is the light's time average (the ON segment's steady
    /// colour, each die at its duty), not the PWM frames' mean: an LED of
    /// dies (`[[scene.led-die]]`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub mean_is_time_average: bool,
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
    /// The colour planes (`"r"`, `"g"`, `"b"`) that reached the
    /// saturation level in some frame, with the frames and the level: a
    /// clipped plane gives the wrong colour and hides its own modulation,
    /// though the luma may stay low.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub clipped: Vec<ClippedPlane>,
    /// Each PWM frame with light: its index in the whole trace and its
    /// `(u', v')`, for the report's diagram.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub path: Vec<(u64, f64, f64)>,
}

/// A colour plane that clipped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClippedPlane {
    /// `"r"`, `"g"` or `"b"`.
    pub plane: String,
    /// Frames of the trace in which it reached the level.
    pub frames: u64,
    /// The saturation level, DN.
    pub level_dn: f64,
}

impl ClippedPlane {
    /// The caveat a figure computed from this plane carries.
    pub fn note(&self) -> String {
        let name = match self.plane.as_str() {
            "r" => "red",
            "g" => "green",
            _ => "blue",
        };
        format!(
            "the {name} plane clipped (reached {} DN in {} frame(s)): the colour and the plane's modulation are wrong where it did",
            self.level_dn, self.frames
        )
    }
}

/// The colour planes of `rgb` that reach `saturation_dn` in some frame.
pub fn clipped_planes(rgb: &[[f64; 3]], saturation_dn: f64) -> Vec<ClippedPlane> {
    PLANE_SUFFIXES
        .iter()
        .enumerate()
        .filter_map(|(p, name)| {
            let frames = rgb.iter().filter(|c| c[p] >= saturation_dn).count() as u64;
            (frames > 0).then(|| ClippedPlane {
                plane: (*name).to_string(),
                frames,
                level_dn: saturation_dn,
            })
        })
        .collect()
}

/// Why an LED ROI has no Δu′v′.
pub const NO_COLOUR: &str = "no PWM frame has light: no colour";

/// Names of the colour planes in metric ids (`fmi_r`, `mmp_b`).
pub const PLANE_SUFFIXES: [&str; 3] = ["r", "g", "b"];

impl ColourFigures {
    /// The region the plan names, as [`SignalColour`].
    pub fn signal_colour(&self) -> Option<SignalColour> {
        match self.region.as_deref()? {
            "red" => Some(SignalColour::Red),
            "amber" => Some(SignalColour::Amber),
            _ => None,
        }
    }

    /// Δu′v′ as a metric to check against `delta-uv-max`.
    pub fn delta_uv_metric(&self) -> Metric {
        let reason = match (self.delta_uv, self.clipped.first()) {
            (None, _) => Some(NO_COLOUR.to_string()),
            (Some(_), Some(c)) => Some(c.note()),
            (Some(_), None) => None,
        };
        Metric {
            value: self.delta_uv,
            unbounded: false,
            reason,
        }
    }

    /// Marks the figures of the clipped planes (and Δu′v′, through
    /// [`ColourFigures::delta_uv_metric`]) with their caveat.
    pub fn mark_clipped(&mut self, clipped: Vec<ClippedPlane>) {
        for c in &clipped {
            let Some(p) = PLANE_SUFFIXES.iter().position(|s| *s == c.plane) else {
                continue;
            };
            if let Some(kpis) = self.planes.get_mut(p) {
                for m in [&mut kpis.fmi, &mut kpis.fdi, &mut kpis.mmp] {
                    if m.reason.is_none() {
                        m.reason = Some(c.note());
                    }
                }
            }
        }
        self.clipped = clipped;
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

/// Each colour plane's mean over the OFF frames (`capture.black-level =
/// "off-segment"`): the black a recording's planes sit on; `None` without
/// OFF frames.
pub fn off_segment_black(rgb: &[[f64; 3]], segments: &[Segment]) -> Option<[f64; 3]> {
    let off: Vec<&[f64; 3]> = rgb
        .iter()
        .zip(segments)
        .filter(|(_, s)| **s == Segment::Off)
        .map(|(c, _)| c)
        .collect();
    let n = off.len() as f64;
    (!off.is_empty()).then(|| [0, 1, 2].map(|p| off.iter().map(|c| c[p]).sum::<f64>() / n))
}

/// The colour of an LED ROI's PWM segment: the planes' DN less the black
/// level `black` (light only) of the frames whose segment is PWM, through the
/// plan's camera-to-XYZ matrix, judged against its signal colour. For an
/// LED of dies, Δu′v′ is measured from the ON segment's colour, where the
/// LED shines steadily at its PWM average (every die at its duty): the
/// colour the eye fuses, which the PWM frames' mean only approaches.
pub fn of_trace(
    colour: &ColourConfig,
    rgb: &[[f64; 3]],
    segments: &[Segment],
    black: [f64; 3],
) -> ColourFigures {
    let light_of = |c: &[f64; 3]| [0, 1, 2].map(|p| (c[p] - black[p]).max(0.0));
    let (index, light): (Vec<u64>, Vec<[f64; 3]>) = rgb
        .iter()
        .zip(segments)
        .enumerate()
        .filter(|(_, (_, s))| **s == Segment::Pwm)
        .map(|(i, (c, _))| (i as u64, light_of(c)))
        .unzip();
    let region = colour.signal.map(SignalColour::from);
    let steady: Vec<[f64; 3]> = rgb
        .iter()
        .zip(segments)
        .filter(|(_, s)| **s == Segment::On)
        .map(|(c, _)| light_of(c))
        .collect();
    let reference = (!colour.dies.is_empty() && !steady.is_empty()).then(|| {
        let n = steady.len() as f64;
        [0, 1, 2].map(|i| steady.iter().map(|c| c[i]).sum::<f64>() / n)
    });
    let found = excursion_from(
        &light,
        &colour.camera_to_xyz,
        region.unwrap_or(SignalColour::Red),
        reference,
    );
    let outside_frames: Vec<u64> = match (&found, region) {
        (Some(e), Some(_)) => e.outside.iter().map(|&i| index[i]).collect(),
        _ => Vec::new(),
    };
    let path = index
        .iter()
        .zip(&light)
        .filter_map(|(&i, &c)| uv(xyz(&colour.camera_to_xyz, c)).map(|(u, v)| (i, u, v)))
        .collect();
    ColourFigures {
        path,
        delta_uv: found.as_ref().map(|e| e.delta_uv),
        mean_uv: found.as_ref().map(|e| e.mean_uv),
        mean_is_time_average: reference.is_some() && found.is_some(),
        region: colour.signal.map(|s| s.as_str().to_string()),
        frames_outside: region.map(|_| outside_frames.len() as u64),
        outside_frames,
        frames: light.len() as u64,
        planes: Vec::new(),
        clipped: Vec::new(),
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

    /// The distance of `p` from the line `a x + b y = c`.
    fn off_line(p: (f64, f64), (a, b, c): (f64, f64, f64)) -> f64 {
        (a * p.0 + b * p.1 - c).abs() / a.hypot(b)
    }

    #[test]
    fn the_region_polygons_are_bounded_by_the_standards_lines_and_the_locus() {
        // The corners where two of UN R48's lines meet, by hand: red's
        // y = 0.335 and z = 0.008 at x = 1 - 0.008 - 0.335; amber's
        // z = 0.007 at y = 0.398 and y = 0.429.
        let corners = [
            (SignalColour::Red, vec![(0.657, 0.335)]),
            (SignalColour::Amber, vec![(0.595, 0.398), (0.564, 0.429)]),
        ];
        for (region, expected) in corners {
            let poly = region.polygon_xy();
            assert!(poly.len() >= 4, "{region:?}: {poly:?}");
            for c in expected {
                assert!(
                    poly.iter().any(|p| (p.0 - c.0).hypot(p.1 - c.1) < 1e-12),
                    "{region:?} has no corner {c:?}: {poly:?}"
                );
            }
            for &p in &poly {
                // Every vertex is in the region (on its edge), and lies on
                // a boundary line or on the locus (a tabulated point or the
                // segment between two).
                let within = region
                    .half_planes()
                    .iter()
                    .all(|&(a, b, c)| a * p.0 + b * p.1 <= c + 1e-12);
                assert!(within, "{region:?}: {p:?} outside");
                let on_line = region.half_planes().iter().any(|&l| off_line(p, l) < 1e-12);
                let on_locus = SPECTRUM_LOCUS.windows(2).any(|w| {
                    let (a, b) = ((w[0].1, w[0].2), (w[1].1, w[1].2));
                    let cross = (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0);
                    let within = (p.0 - a.0) * (p.0 - b.0) <= 1e-15;
                    cross.abs() < 1e-12 && within
                });
                assert!(on_line || on_locus, "{region:?}: {p:?} on no boundary");
            }
            // The half-planes are the lines `contains` judges by: the two
            // agree on a grid over the diagram (points on a line aside).
            for i in 0..=200 {
                for j in 0..=200 {
                    let p = (
                        0.5 + 0.25 * f64::from(i) / 200.0,
                        0.25 + 0.2 * f64::from(j) / 200.0,
                    );
                    let margin = region
                        .half_planes()
                        .iter()
                        .map(|&(a, b, c)| c - a * p.0 - b * p.1)
                        .fold(f64::INFINITY, f64::min);
                    if margin.abs() > 1e-9 {
                        assert_eq!(region.contains(p), margin > 0.0, "{region:?} {p:?}");
                    }
                }
            }
            let n = poly.len() as f64;
            let mid = poly
                .iter()
                .fold((0.0, 0.0), |s, p| (s.0 + p.0 / n, s.1 + p.1 / n));
            assert!(region.contains(mid), "{region:?}: centroid {mid:?}");
        }
        // Red stops where the locus crosses y = 0.335 (between 605 and
        // 610 nm); amber spans the locus from about 586 to 591 nm.
        let red = SignalColour::Red.polygon_xy();
        let top = red.iter().filter(|p| (p.1 - 0.335).abs() < 1e-12).count();
        assert_eq!(top, 2, "{red:?}");
        assert!(red.iter().any(|p| (p.0 - 0.7347).abs() < 1e-12), "700 nm");
        // u'v' of a tabulated point, by hand: 610 nm.
        let (u, v) = uv_of_xy((0.6658, 0.3340));
        let d = -2.0 * 0.6658 + 12.0 * 0.3340 + 3.0;
        assert!((u - 4.0 * 0.6658 / d).abs() < 1e-15 && (v - 9.0 * 0.334 / d).abs() < 1e-15);
        let via_xyz = super::uv([0.6658, 0.3340, 1.0 - 0.6658 - 0.3340]).unwrap();
        assert!((via_xyz.0 - u).abs() < 1e-12 && (via_xyz.1 - v).abs() < 1e-12);
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
