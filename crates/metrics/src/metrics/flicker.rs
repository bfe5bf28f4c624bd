//! Deegan 2018 metrics (docs/metrics.md, section 2):
//! - Flicker Detection Index, Eq. (3): `(min x - L_OFF) / L_OFF`; the light
//!   "appears OFF" below 0.1;
//! - Percent Flicker, Eq. (4) and IEEE 1789: `100 (max x - min x) / (max x + min x)`;
//!
//! where `x` is the ROI luma of each frame of the PWM segment and `L_OFF` the
//! mean luma of the OFF segment. Undefined values are `None` with a reason:
//! a report never shows NaN.

use serde::{Deserialize, Serialize};

pub use super::metric::Metric;

/// Luma levels of an ROI, in DN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Levels {
    /// Mean of the OFF segment (L_OFF); `None` when the sequence has no OFF frames.
    pub off: Option<f64>,
    /// Mean of the steady-ON segment; `None` when there are no ON frames.
    pub on: Option<f64>,
    /// Lowest PWM-segment luma.
    pub min: f64,
    /// Highest PWM-segment luma.
    pub max: f64,
    /// Mean PWM-segment luma.
    pub mean: f64,
}

/// Everything measured on one ROI of one case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoiMetrics {
    /// Luma levels.
    pub levels: Levels,
    /// FDI (Deegan 2018) of the trace as captured.
    pub fdi_2018: Metric,
    /// Percent Flicker of the trace as captured.
    pub percent_flicker: Metric,
    /// FDI (2018) at the worst PWM phase, where the backend can compute it.
    pub fdi_2018_worst_phase: Option<Metric>,
    /// Percent Flicker over all PWM phases, where the backend can compute it.
    pub percent_flicker_worst_phase: Option<Metric>,
    /// Some frame reached the saturation level.
    pub saturated: bool,
    /// Visibility of the flicker on the plan's `[display]`; `None` when the
    /// plan has no display.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visibility: Option<super::visibility::Visibility>,
    /// Colour of the light over the PWM segment, for an LED ROI of a plan
    /// with colour; `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<super::chromaticity::ColourFigures>,
}

/// FDI (2018) = `(min - L_OFF) / L_OFF`.
///
/// `L_OFF <= 0` (a dark OFF reference) makes the contrast unbounded: with
/// light in the PWM segment (`min > 0`) the value is +infinity and marked
/// `unbounded`; with `min <= 0` the light cannot be told from OFF and the
/// value is undefined.
pub fn fdi_2018(min: f64, l_off: Option<f64>) -> Metric {
    let Some(l_off) = l_off else {
        return Metric::undefined("no OFF reference: the sequence has no OFF frames".to_string());
    };
    if l_off > 0.0 {
        let v = (min - l_off) / l_off;
        if v.is_finite() {
            return Metric::value(v);
        }
    }
    // A zero reference, or one so near zero (a subnormal L_OFF) that the
    // ratio overflows: the limit L_OFF -> 0+.
    if min > 0.0 {
        let off = if l_off > 0.0 {
            format!("L_OFF = {l_off:e} DN (dark OFF reference, too near 0 for the ratio)")
        } else if l_off < 0.0 {
            format!("L_OFF = {l_off:.4} DN, below 0 (dark OFF reference)")
        } else {
            "L_OFF = 0 (dark OFF reference)".to_string()
        };
        Metric {
            value: None,
            unbounded: true,
            reason: Some(format!(
                "{off}: the contrast is unbounded (infinite); min luma {min:.4} DN is above it, so the light never appears OFF"
            )),
        }
    } else if l_off == 0.0 {
        Metric::undefined(format!(
            "L_OFF = 0 and min luma = {min:.4} DN: 0/0, the light cannot be told from OFF"
        ))
    } else {
        Metric::undefined(format!(
            "L_OFF = {l_off:.4} DN and min luma = {min:.4} DN, neither above 0: the light cannot be told from OFF"
        ))
    }
}

/// Percent Flicker = `100 (max - min) / (max + min)`; undefined when
/// `max + min <= 0` (no light at all in the ROI).
pub fn percent_flicker(min: f64, max: f64) -> Metric {
    let sum = max + min;
    if sum > 0.0 {
        Metric::value(100.0 * (max - min) / sum)
    } else {
        Metric::undefined(format!(
            "max + min = {sum:.4} DN: no light in the ROI, modulation undefined"
        ))
    }
}

pub use ledflicker_plan::trace::Segment;

fn mean(xs: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, s) = xs.fold((0usize, 0.0), |(n, s), x| (n + 1, s + x));
    (n > 0).then(|| s / n as f64)
}

/// Measures one ROI. `luma[i]` is the ROI mean luma of frame `i` (DN) and
/// `segments[i]` its segment. `envelope` is the (min, max) PWM luma over
/// every phase, if the backend knows it; the worst-phase metrics use it
/// widened by the captured extremes. Returns `None` when the trace
/// has no PWM frames.
pub fn evaluate_roi(
    luma: &[f64],
    segments: &[Segment],
    envelope: Option<(f64, f64)>,
    saturation_dn: f64,
) -> Option<RoiMetrics> {
    let in_segment = |s: Segment| {
        luma.iter()
            .zip(segments)
            .filter(move |(_, seg)| **seg == s)
            .map(|(x, _)| *x)
    };
    let pwm_mean = mean(in_segment(Segment::Pwm))?;
    let min = in_segment(Segment::Pwm).fold(f64::INFINITY, f64::min);
    let max = in_segment(Segment::Pwm).fold(f64::NEG_INFINITY, f64::max);
    let levels = Levels {
        off: mean(in_segment(Segment::Off)),
        on: mean(in_segment(Segment::On)),
        min,
        max,
        mean: pwm_mean,
    };
    let saturated = luma.iter().any(|&x| x >= saturation_dn);
    // The worst case is the worse of what every phase can give (with the
    // camera settled) and what the capture actually showed (noise, auto
    // exposure transients).
    let worst = envelope.map(|(lo, hi)| (lo.min(min), hi.max(max)));
    let mut m = RoiMetrics {
        fdi_2018: fdi_2018(min, levels.off),
        percent_flicker: percent_flicker(min, max),
        fdi_2018_worst_phase: worst.map(|(lo, _)| fdi_2018(lo, levels.off)),
        percent_flicker_worst_phase: worst.map(|(lo, hi)| percent_flicker(lo, hi)),
        saturated,
        levels,
        visibility: None,
        colour: None,
    };
    if saturated {
        let note = format!(
            "ROI saturated (luma reached {saturation_dn} DN): clipping hides modulation, so the metrics understate flicker"
        );
        for metric in [&mut m.fdi_2018, &mut m.percent_flicker]
            .into_iter()
            .chain(m.fdi_2018_worst_phase.as_mut())
            .chain(m.percent_flicker_worst_phase.as_mut())
        {
            if metric.reason.is_none() {
                metric.reason = Some(note.clone());
            }
        }
    }
    Some(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fdi_of_a_light_at_its_off_level_is_zero() {
        assert_eq!(fdi_2018(20.0, Some(20.0)).value, Some(0.0));
        assert_eq!(fdi_2018(22.0, Some(20.0)).value, Some(0.1));
    }

    #[test]
    fn dark_off_reference_makes_fdi_unbounded_not_nan() {
        let m = fdi_2018(5.0, Some(0.0));
        assert_eq!(m.value, None);
        assert!(m.unbounded);
        assert!(m.reason.unwrap().contains("unbounded"));
        let m = fdi_2018(0.0, Some(0.0));
        assert_eq!(m.value, None);
        assert!(!m.unbounded);
        assert!(m.reason.unwrap().contains("0/0"));
        // A reference below 0 (a black level over-subtracted) is dark too,
        // and the reason gives it as it is.
        let m = fdi_2018(5.0, Some(-1.0));
        assert!(m.unbounded && m.value.is_none());
        assert!(m.reason.unwrap().starts_with("L_OFF = -1.0000 DN, below 0"));
        let m = fdi_2018(-2.0, Some(-1.0));
        assert!(!m.unbounded && m.value.is_none());
        assert!(
            m.reason
                .unwrap()
                .starts_with("L_OFF = -1.0000 DN and min luma = -2.0000 DN")
        );
    }

    #[test]
    fn off_reference_too_near_zero_for_the_ratio_is_unbounded_not_infinite() {
        // 1 / 5e-324 overflows: the value would be +inf, which no output
        // may hold as a number.
        let m = fdi_2018(1.0, Some(5e-324));
        assert_eq!(m.value, None);
        assert!(m.unbounded);
        assert!(m.reason.unwrap().contains("5e-324"));
        // A small but normal reference still gives a (large) value.
        assert_eq!(
            fdi_2018(1.0, Some(1e-300)).value,
            Some((1.0 - 1e-300) / 1e-300)
        );
    }

    #[test]
    fn missing_off_segment_leaves_fdi_undefined() {
        let m = fdi_2018(5.0, None);
        assert_eq!(m.value, None);
        assert!(m.reason.unwrap().contains("no OFF frames"));
    }

    #[test]
    fn percent_flicker_of_black_roi_is_undefined() {
        let m = percent_flicker(0.0, 0.0);
        assert_eq!(m.value, None);
        assert!(m.reason.unwrap().contains("max + min"));
        assert_eq!(percent_flicker(10.0, 30.0).value, Some(50.0));
        assert_eq!(percent_flicker(7.0, 7.0).value, Some(0.0));
    }

    #[test]
    fn saturated_roi_is_flagged_with_a_caveat() {
        use Segment::*;
        let luma = [255.0, 255.0, 10.0, 10.0, 200.0, 255.0];
        let seg = [On, On, Off, Off, Pwm, Pwm];
        let m = evaluate_roi(&luma, &seg, None, 240.0).unwrap();
        assert!(m.saturated);
        assert_eq!(m.levels.off, Some(10.0));
        assert_eq!(m.levels.min, 200.0);
        assert!((m.fdi_2018.value.unwrap() - 19.0).abs() < 1e-12);
        assert!(m.percent_flicker.reason.unwrap().contains("saturated"));
    }

    #[test]
    fn trace_without_pwm_frames_has_no_metrics() {
        assert!(evaluate_roi(&[1.0], &[Segment::On], None, 240.0).is_none());
    }
}
