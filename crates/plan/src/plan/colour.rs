//! A coloured LED on a colour camera: the light's chromaticity (one colour,
//! or dies of their own colour, duty and phase), the signal colour it must
//! keep, and the camera's colour planes (their exposure offsets, their
//! matrix to XYZ). Optional: a plan without `led-chromaticity-xy` or
//! `[[scene.led-die]]` has no colour, and its outputs are the luma ones
//! alone (docs/visibility.md, section 6).

/// A signal colour of a vehicle lamp (UN R48 paragraph 2.30), as a plan
/// names it (`signal-colour`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignalColourName {
    /// `"red"`.
    Red,
    /// `"amber"`.
    Amber,
}

impl SignalColourName {
    /// The plan's spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            SignalColourName::Red => "red",
            SignalColourName::Amber => "amber",
        }
    }
}

/// Linear sRGB to XYZ (IEC 61966-2-1, D65): the camera's colour matrix
/// when the plan gives none.
pub const DEFAULT_CAMERA_TO_XYZ: [[f64; 3]; 3] = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// One die of a multi-die (RGB) LED, validated (`[[scene.led-die]]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LedDie {
    /// CIE 1931 `(x, y)` of the die's light, inside the camera's gamut.
    pub xy: [f64; 2],
    /// The die's share of the LED's luminance while every die is ON
    /// (> 0; the dies' shares sum to 1).
    pub share: f64,
    /// The die's duty at a case duty of 1, in (0, 1]: a case of duty `D`
    /// drives it at `D x duty`.
    pub duty: f64,
    /// Its rising edge after the LED's common one, in PWM cycles, [0, 1).
    pub phase_cycles: f64,
    /// Its camera RGB per cd/m^2 (its XYZ at `Y = 1` through the matrix's
    /// inverse): each >= 0.
    pub rgb: [f64; 3],
}

/// The colour of the LED and of the camera's planes, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourConfig {
    /// CIE 1931 `(x, y)` of the LED's light (`x, y > 0`, `x + y < 1`); for
    /// an LED of dies, the colour they fuse to (each die's XYZ weighted by
    /// its share and duty).
    pub led_xy: [f64; 2],
    /// The region its colour must stay in; `None`: Δu'v' only.
    pub signal: Option<SignalColourName>,
    /// Start of each colour plane's (R, G, B) exposure after the frame's,
    /// seconds (>= 0): the chroma shift of a camera whose planes are not
    /// exposed together.
    pub plane_offsets_s: [f64; 3],
    /// Linear camera RGB to XYZ, rows X, Y, Z.
    pub camera_to_xyz: [[f64; 3]; 3],
    /// The LED's camera RGB per cd/m^2 (its XYZ through the matrix's
    /// inverse, Y = 1): each >= 0.
    pub led_rgb: [f64; 3],
    /// The grey background's camera RGB per cd/m^2 (D65 white, Y = 1).
    pub white_rgb: [f64; 3],
    /// The LED's dies, each with its own colour, duty and phase; empty for
    /// an LED of one colour whose light follows the case's PWM as a whole.
    pub dies: Vec<LedDie>,
}

/// The inverse of `m`; `None` when it is singular.
pub fn invert(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
    };
    let det = m[0][0] * cof(0, 0) + m[0][1] * cof(0, 1) + m[0][2] * cof(0, 2);
    (det.abs() > 1e-12).then(|| {
        let mut inv = [[0.0; 3]; 3];
        for (r, row) in inv.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = cof(c, r) / det;
            }
        }
        inv
    })
}

/// `m x v`.
pub fn apply(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inverse_of_the_srgb_matrix_takes_d65_white_to_equal_planes() {
        let inv = invert(&DEFAULT_CAMERA_TO_XYZ).unwrap();
        let rgb = apply(
            &inv,
            [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290],
        );
        for v in rgb {
            assert!((v - 1.0).abs() < 2e-3, "{rgb:?}");
        }
        assert!(invert(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }
}
