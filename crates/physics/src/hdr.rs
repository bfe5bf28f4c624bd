//! Multi-capture HDR: capture timing, merge rules and the global tone curve.
//!
//! Captures are either *sequential* (L then M then S inside the frame: each
//! row starts capture `c` when it finishes capture `c - 1`) or *split-pixel*
//! (all captures of a row expose at the same time, with different
//! sensitivities, as in LOFIC / split-photodiode sensors). The merge works in
//! "L-equivalent DN": each capture's DN divided by its exposure x
//! sensitivity relative to the first capture.

use super::sensor::CaptureSample;

/// How the captures of one frame are timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HdrMode {
    /// L, then M, then S, back to back in each row.
    Sequential,
    /// All captures start together (split pixel, LOFIC).
    SplitPixel,
}

/// How captures are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MergeRule {
    /// The capture with the most signal that did not clip.
    LongestUnsaturated,
    /// A weighted mean: weight = relative sensitivity x a hat that falls to 0
    /// at clipping, so long captures dominate until they near saturation.
    Weighted,
}

/// Exposure of one capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CaptureExposure {
    /// A fraction of the auto-exposure time (the first capture is 1).
    Ratio(f64),
    /// A fixed time in seconds, whatever auto exposure does (e.g. the
    /// 11.11 ms small-pixel exposure of a split-pixel LFM sensor).
    Fixed(f64),
}

/// One capture of a multi-capture HDR scheme.
#[derive(Debug, Clone, PartialEq)]
pub struct Capture {
    /// Short name, e.g. "L".
    pub name: String,
    /// Its exposure.
    pub exposure: CaptureExposure,
    /// Sensitivity relative to the sensor's (1 for a normal pixel; e.g.
    /// 1/16 for a small split pixel). > 0.
    pub sensitivity_ratio: f64,
}

impl Capture {
    /// Exposure time in seconds for auto-exposure time `t_s`.
    pub fn exposure_s(&self, t_s: f64) -> f64 {
        match self.exposure {
            CaptureExposure::Ratio(r) => r * t_s,
            CaptureExposure::Fixed(s) => s,
        }
    }
}

/// Merges the captures of one row into L-equivalent DN. `scale[c]` is
/// capture c's exposure x sensitivity relative to capture 0; `dn_max` the
/// ADC maximum. Returns the merged value and whether every capture clipped.
pub fn merge(
    samples: &[CaptureSample],
    scale: &[f64],
    rule: MergeRule,
    dn_max: f64,
) -> (f64, bool) {
    debug_assert_eq!(samples.len(), scale.len());
    let all_clipped = samples.iter().all(|s| s.saturated);
    match rule {
        MergeRule::LongestUnsaturated => {
            // Most signal first: the largest scale that did not clip; if all
            // clipped, the least sensitive capture (it clipped least badly).
            let mut best: Option<usize> = None;
            for (i, s) in samples.iter().enumerate() {
                if !s.saturated && best.is_none_or(|b| scale[i] > scale[b]) {
                    best = Some(i);
                }
            }
            let i = best.unwrap_or_else(|| {
                (0..samples.len())
                    .min_by(|&a, &b| scale[a].total_cmp(&scale[b]))
                    .unwrap_or(0)
            });
            (samples[i].dn / scale[i], all_clipped)
        }
        MergeRule::Weighted => {
            let mut num = 0.0;
            let mut den = 0.0;
            for (s, &k) in samples.iter().zip(scale) {
                // Hat: 1 up to 80 % of full scale, falling to 0 at clipping.
                let u = s.dn / dn_max;
                let hat = if s.saturated {
                    0.0
                } else {
                    ((1.0 - u) / 0.2).clamp(0.0, 1.0)
                };
                let w = k * hat;
                num += w * (s.dn / k);
                den += w;
            }
            if den > 0.0 {
                (num / den, all_clipped)
            } else {
                let i = (0..samples.len())
                    .min_by(|&a, &b| scale[a].total_cmp(&scale[b]))
                    .unwrap_or(0);
                (samples[i].dn / scale[i], all_clipped)
            }
        }
    }
}

/// Global tone curve from merged linear signal to output luma.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToneCurve {
    /// `y = u`.
    Linear,
    /// `y = u^(1/gamma)`.
    Gamma(f64),
    /// `y = ln(1 + a u) / ln(1 + a)`: compresses a wide HDR range.
    Log(f64),
}

impl ToneCurve {
    /// The curve, `u` (fraction of white, 0..=1) to output `y` (0..=1).
    pub fn apply(&self, u: f64) -> f64 {
        match *self {
            ToneCurve::Linear => u,
            ToneCurve::Gamma(g) => u.powf(1.0 / g),
            ToneCurve::Log(a) => (1.0 + a * u).ln() / (1.0 + a).ln(),
        }
    }

    /// The inverse: the fraction of white `u` that the curve maps to output
    /// `y` (0..=1). Auto exposure's `target-luma` is set through it.
    pub fn inverse(&self, y: f64) -> f64 {
        match *self {
            ToneCurve::Linear => y,
            ToneCurve::Gamma(g) => y.powf(g),
            ToneCurve::Log(a) => ((y * (1.0 + a).ln()).exp() - 1.0) / a,
        }
    }
}

/// Tone mapping: `u = linear / white` clipped to [0, 1], then the curve,
/// then scaled to `output_max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tone {
    /// Curve.
    pub curve: ToneCurve,
    /// Linear value (L-equivalent DN after digital gain) that maps to white.
    pub white: f64,
    /// Output code of white: 255 for 8-bit, 65535 for 16-bit.
    pub output_max: f64,
}

impl Tone {
    /// Output luma (0..=output_max) of a linear value.
    pub fn apply(&self, linear: f64) -> f64 {
        let u = (linear / self.white).clamp(0.0, 1.0);
        self.curve.apply(u) * self.output_max
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(dn: f64, saturated: bool) -> CaptureSample {
        CaptureSample { dn, saturated }
    }

    #[test]
    fn longest_unsaturated_picks_the_most_sensitive_unclipped_capture() {
        let scale = [1.0, 1.0 / 16.0, 1.0 / 256.0];
        let (v, all) = merge(
            &[s(4095.0, true), s(1000.0, false), s(62.5, false)],
            &scale,
            MergeRule::LongestUnsaturated,
            4095.0,
        );
        assert_eq!(v, 16_000.0);
        assert!(!all);
        let (v, all) = merge(
            &[s(4095.0, true), s(4095.0, true), s(4095.0, true)],
            &scale,
            MergeRule::LongestUnsaturated,
            4095.0,
        );
        assert_eq!(v, 4095.0 * 256.0);
        assert!(all);
    }

    #[test]
    fn weighted_merge_of_consistent_captures_is_their_common_value() {
        let scale = [1.0, 0.25];
        let (v, _) = merge(
            &[s(800.0, false), s(200.0, false)],
            &scale,
            MergeRule::Weighted,
            4095.0,
        );
        assert!((v - 800.0).abs() < 1e-9);
        // A clipped long capture gets no weight.
        let (v, _) = merge(
            &[s(4095.0, true), s(2000.0, false)],
            &scale,
            MergeRule::Weighted,
            4095.0,
        );
        assert!((v - 8000.0).abs() < 1e-9);
    }

    #[test]
    fn tone_curve_inverse_undoes_the_curve() {
        for curve in [
            ToneCurve::Linear,
            ToneCurve::Gamma(2.2),
            ToneCurve::Log(1e6),
        ] {
            for i in 0..=20 {
                let y = i as f64 / 20.0;
                let u = curve.inverse(y);
                assert!((curve.apply(u) - y).abs() < 1e-12, "{curve:?} {y}");
            }
        }
        // The Deegan 2018 profile's log curve: 0.0003 of white is output 0.4131.
        let y = ToneCurve::Log(1e6).apply(0.0003);
        assert!((y - 301f64.ln() / 1_000_001f64.ln()).abs() < 1e-15);
        assert!((y - 0.41309).abs() < 1e-4, "{y}");
    }

    #[test]
    fn tone_curves_map_black_to_0_and_white_to_full_scale_monotonically() {
        for curve in [
            ToneCurve::Linear,
            ToneCurve::Gamma(2.2),
            ToneCurve::Log(300.0),
        ] {
            let t = Tone {
                curve,
                white: 1000.0,
                output_max: 255.0,
            };
            assert_eq!(t.apply(0.0), 0.0);
            assert!((t.apply(1000.0) - 255.0).abs() < 1e-9);
            assert!((t.apply(5000.0) - 255.0).abs() < 1e-9);
            let mut prev = -1.0;
            for i in 0..=100 {
                let y = t.apply(i as f64 * 10.0);
                assert!(y > prev);
                prev = y;
            }
        }
    }
}
