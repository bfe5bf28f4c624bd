//! `[display]`: the monitor of a camera-monitor system (CMS) and where
//! the driver sits, as a plan gives them. The displayed luminance and its
//! visibility are computed in `metrics::visibility`, which takes this type
//! from here. docs/plan-format.md lists the keys and docs/visibility.md
//! the model.

use serde::{Deserialize, Serialize};

/// How the monitor turns a code value into luminance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Eotf {
    /// IEC 61966-2-1 (sRGB): a linear toe below 0.04045, a 2.4 power
    /// above; black level added on top.
    Srgb,
    /// ITU-R BT.1886 Annex 1: `a max(V + b, 0)^2.4`, with `a` and `b`
    /// from the white and black luminances.
    Bt1886,
}

impl Eotf {
    /// The curve's name and its standard, for a reader.
    pub fn title(self) -> &'static str {
        match self {
            Eotf::Srgb => "sRGB (IEC 61966-2-1)",
            Eotf::Bt1886 => "BT.1886 (ITU-R)",
        }
    }
}

/// A named set of defaults: the monitor's peak luminance by day or night.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DisplayPreset {
    /// 500 cd/m^2: a CMS monitor at full brightness in daylight.
    Day,
    /// 50 cd/m^2: the same monitor dimmed for night driving.
    Night,
}

impl DisplayPreset {
    /// Peak (white) luminance of the preset, cd/m^2.
    pub fn peak_cd_m2(self) -> f64 {
        match self {
            DisplayPreset::Day => 500.0,
            DisplayPreset::Night => 50.0,
        }
    }

    /// Lowercase name, as in a plan.
    pub fn as_str(self) -> &'static str {
        match self {
            DisplayPreset::Day => "day",
            DisplayPreset::Night => "night",
        }
    }
}

/// Contrast ratio of the default black level: an IPS panel's 1000:1.
pub const DEFAULT_CONTRAST_RATIO: f64 = 1000.0;
/// Default refresh rate, Hz: the usual rate of CMS monitors.
pub const DEFAULT_REFRESH_HZ: f64 = 60.0;
/// Default width of the camera image on the screen, mm: a 7-inch 16:9
/// panel (177.8 mm diagonal) showing the image across its width.
pub const DEFAULT_IMAGE_WIDTH_MM: f64 = 155.0;
/// Default eye-to-screen distance, mm: a door-mounted CMS monitor seen
/// from the driver's seat.
pub const DEFAULT_DISTANCE_MM: f64 = 700.0;

/// The monitor and the viewing geometry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Display {
    /// The preset the defaults came from.
    pub preset: DisplayPreset,
    /// Transfer function from code value to luminance.
    pub eotf: Eotf,
    /// Refresh rate, Hz (> 0): each camera frame is held on screen from
    /// the first refresh after it arrives to the first after the next.
    pub refresh_hz: f64,
    /// Luminance of full-scale white, cd/m^2 (> 0).
    pub peak_cd_m2: f64,
    /// Luminance of code 0, cd/m^2 (>= 0, < peak).
    pub black_cd_m2: f64,
    /// Width of the camera image on the screen, mm (> 0).
    pub image_width_mm: f64,
    /// Eye-to-screen distance, mm (> 0).
    pub distance_mm: f64,
    /// Camera code value shown as full-scale white, DN (> 0).
    pub full_scale_dn: f64,
    /// Width of the camera image in pixels (>= 1).
    pub image_width_px: u32,
}
