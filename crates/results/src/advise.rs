//! The exposure advice as results.json and `advise --json` carry it: the
//! bound an exposure must exceed, the candidates and what each leaves, and
//! the frame time that bounds them. Computed by `ledflicker-analysis`.

use serde::{Deserialize, Serialize};

use ledflicker_physics::hdr::{Capture, CaptureExposure, HdrMode};

/// What bounds an exposure: the frame time less the frame's other captures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameBound {
    /// Frame rate, frames/s (> 0).
    pub fps: f64,
    /// Sum of the other captures' exposures as fractions of the advised
    /// capture's (sequential HDR: `sum 1 / r_i`; 0 for one capture or
    /// split pixels).
    pub other_ratio: f64,
    /// Sum of the other captures' fixed exposures, seconds.
    pub other_fixed_s: f64,
}

impl FrameBound {
    /// A single-capture camera (or split pixels) at `fps`.
    pub fn frame_time(fps: f64) -> Self {
        Self {
            fps,
            other_ratio: 0.0,
            other_fixed_s: 0.0,
        }
    }

    /// Sequential HDR captures at `fps` whose shorter captures are the long
    /// one over `ratios`.
    pub fn sequential(fps: f64, ratios: &[f64]) -> Self {
        Self {
            fps,
            other_ratio: ratios.iter().map(|r| 1.0 / r).sum(),
            other_fixed_s: 0.0,
        }
    }

    /// The frame bound of the first of `captures` (the long one, whose
    /// exposure is advised) at `fps`: sequential captures share the frame
    /// time, split-pixel ones each have all of it.
    pub fn of_captures(fps: f64, captures: &[Capture], mode: HdrMode) -> Self {
        let mut b = Self::frame_time(fps);
        if mode == HdrMode::Sequential {
            for c in captures.iter().skip(1) {
                match c.exposure {
                    CaptureExposure::Ratio(r) => b.other_ratio += r,
                    CaptureExposure::Fixed(s) => b.other_fixed_s += s,
                }
            }
        }
        b
    }

    /// Longest exposure of the advised capture: `(1 / fps - fixed) / (1 +
    /// ratio)`, seconds (may be <= 0: nothing fits).
    pub fn max_exposure_s(&self) -> f64 {
        (1.0 / self.fps - self.other_fixed_s) / (1.0 + self.other_ratio)
    }

    /// Why an exposure beyond the bound is left out.
    pub fn reason(&self) -> String {
        let frame_ms = 1e3 / self.fps;
        if self.other_ratio == 0.0 && self.other_fixed_s == 0.0 {
            format!(
                "longer than the frame time {frame_ms:.3} ms at {} fps",
                self.fps
            )
        } else {
            format!(
                "longer than {:.3} ms, the frame time {frame_ms:.3} ms at {} fps less the other captures",
                self.max_exposure_s() * 1e3,
                self.fps
            )
        }
    }
}

/// An exposure the advice does not offer, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LeftOut {
    /// Exposure, seconds.
    pub exposure_s: f64,
    /// Why the camera cannot make it.
    pub reason: String,
}

/// One exposure and what it leaves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Exposure, seconds.
    pub exposure_s: f64,
    /// Exposure over the bound `T*`.
    pub times_bound: f64,
    /// Fraction (0..=1) of the (f, D) grid where some phase loses the LED
    /// (ON fraction 0).
    pub loses_led_fraction: f64,
    /// Worst-phase Percent Flicker of the LED alone, worst over the grid.
    pub residual_percent_flicker: f64,
    /// Where that worst residual is: (Hz, duty).
    pub residual_at: (f64, f64),
    /// Motion blur, pixels, when a speed was given.
    pub blur_px: Option<f64>,
}

/// The advice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Advice {
    /// `T* = (1 - D_min) / f_min`, seconds.
    pub min_exposure_s: f64,
    /// The (f, D) corner that sets `T*`.
    pub binding: (f64, f64),
    /// Candidate exposures from `T*` upwards.
    pub candidates: Vec<Candidate>,
    /// Shorter HDR captures `T* / ratio`: each row is a candidate.
    pub hdr: Vec<Candidate>,
    /// Cells in the residual grid.
    pub grid_cells: usize,
    /// The frame bound applied, if any.
    pub frame: Option<FrameBound>,
    /// Longest exposure the camera can make, seconds (with a frame bound).
    pub max_exposure_s: Option<f64>,
    /// Multiples of `T*` (and HDR captures) beyond the bound, not offered.
    pub left_out: Vec<LeftOut>,
    /// Set when no exposure the camera can make keeps the LED over the
    /// whole range: what it cannot cover, and what it can.
    pub infeasible: Option<String>,
    /// Lowest frequency at `D_min` that the longest exposure always
    /// catches, Hz (`(1 - D_min) / T_max`, strictly above); with a bound.
    pub lowest_covered_frequency_hz: Option<f64>,
    /// Lowest duty at `f_min` that the longest exposure always catches
    /// (`1 - f_min T_max`, strictly above; 0: every duty); with a bound.
    pub lowest_covered_duty: Option<f64>,
}
