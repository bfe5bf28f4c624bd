//! IEEE P2020 flicker KPIs (docs/metrics.md, section 3), as defined by the P2020
//! reference implementation (CARpublic/P2020-flicker, `metrics/flicker.py`):
//!
//! - FMI, Flicker Modulation Index: `(max x - min x) / (max x + min x)`;
//! - FDI (P2020), Flicker Detection Index: the share of PWM frames with
//!   `(x[n] - x_off) / x_off > 0.1`, `x_off` the mean of the OFF reference;
//! - MMP, Modulation Mitigation Probability: the share of PWM frames with
//!   `x_ref (1 - 0.1) < x[n] < x_ref (1 + 0.1)`, strict, as the reference code.
//!
//! `x` is the ROI luma of each frame of the PWM segment. Not to be confused
//! with the Deegan 2018 FDI in [`super::flicker`]: same name, other quantity.

use serde::{Deserialize, Serialize};

use super::metric::Metric;
use ledflicker_plan::trace::Segment;

pub use ledflicker_plan::plan::{MmpReference, P2020Options};

/// The P2020 KPIs of one ROI.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct P2020Metrics {
    /// Flicker Modulation Index, 0..1.
    pub fmi: Metric,
    /// Flicker Detection Index (P2020), a share of frames, 0..1.
    pub fdi: Metric,
    /// Modulation Mitigation Probability, a share of frames, 0..1.
    pub mmp: Metric,
    /// x_off, DN; `None` without OFF frames.
    pub x_off: Option<f64>,
    /// MMP reference level, DN; `None` when it is undefined.
    pub x_ref: Option<f64>,
}

fn mean(xs: &[f64]) -> Option<f64> {
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

fn value(v: f64) -> Metric {
    Metric {
        value: Some(v),
        unbounded: false,
        reason: None,
    }
}

fn undefined(reason: String) -> Metric {
    Metric {
        value: None,
        unbounded: false,
        reason: Some(reason),
    }
}

/// Computes FMI, FDI (P2020) and MMP of one ROI trace. Returns `None` when
/// the trace has no PWM frames.
pub fn evaluate(luma: &[f64], segments: &[Segment], opts: &P2020Options) -> Option<P2020Metrics> {
    let pick = |s: Segment| -> Vec<f64> {
        luma.iter()
            .zip(segments)
            .filter(|(_, g)| **g == s)
            .map(|(x, _)| *x)
            .collect()
    };
    let pwm = pick(Segment::Pwm);
    if pwm.is_empty() {
        return None;
    }
    let n = pwm.len() as f64;
    let min = pwm.iter().copied().fold(f64::INFINITY, f64::min);
    let max = pwm.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let fmi = if max + min > 0.0 {
        value((max - min) / (max + min))
    } else {
        undefined(format!(
            "max + min = {:.4} DN: no light in the ROI, FMI is 0/0",
            max + min
        ))
    };

    let x_off = mean(&pick(Segment::Off));
    let t = opts.contrast_threshold;
    let fdi = match x_off {
        None => undefined(
            "no OFF reference frames: FDI needs the OFF level (give the sequence an OFF segment)"
                .to_string(),
        ),
        Some(x0) if x0 > 0.0 => {
            value(pwm.iter().filter(|&&x| (x - x0) / x0 > t).count() as f64 / n)
        }
        Some(0.0) => {
            // Dark baseline: (x - 0) / 0 is +inf for x > 0 (above any
            // threshold) and 0/0 for x = 0. The share is the limit for
            // x_off -> 0+, i.e. the frames with any light, which is also what
            // the reference code's IEEE arithmetic counts.
            let share = pwm.iter().filter(|&&x| x > 0.0).count() as f64 / n;
            Metric {
                value: Some(share),
                unbounded: false,
                reason: Some(
                    "dark OFF reference (level 0): every frame with light has unbounded contrast; FDI is the share of PWM frames with luma > 0 (its limit as the OFF reference falls to 0)"
                        .to_string(),
                ),
            }
        }
        Some(x0) => undefined(format!(
            "x_off = {x0:.4} DN is negative: check the black level"
        )),
    };

    let (x_ref, ref_name) = match opts.mmp_reference {
        MmpReference::PwmMean => (mean(&pwm), "PWM-segment mean"),
        MmpReference::OnLevel => (mean(&pick(Segment::On)), "steady-ON level"),
    };
    let mmp = match x_ref {
        None => undefined(format!(
            "no {ref_name}: the capture has no steady-ON frames (p2020.mmp-reference = \"on-level\")"
        )),
        Some(r) if r > 0.0 => {
            let (lo, hi) = (r - opts.mmp_delta * r, r + opts.mmp_delta * r);
            value(pwm.iter().filter(|&&x| x > lo && x < hi).count() as f64 / n)
        }
        Some(r) => undefined(format!(
            "{ref_name} = {r:.4} DN: the band +-{} x reference is empty",
            opts.mmp_delta
        )),
    };
    Some(P2020Metrics {
        fmi,
        fdi,
        mmp,
        x_off,
        x_ref,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use Segment::*;

    fn seg(off: usize, on: usize, pwm: usize) -> Vec<Segment> {
        [vec![Off; off], vec![On; on], vec![Pwm; pwm]].concat()
    }

    #[test]
    fn steady_light_has_zero_fmi_full_fdi_and_full_mmp() {
        let luma = [10.0, 10.0, 100.0, 100.0, 100.0, 100.0];
        let m = evaluate(&luma, &seg(2, 1, 3), &P2020Options::default()).unwrap();
        assert_eq!(m.fmi.value, Some(0.0));
        assert_eq!(m.fdi.value, Some(1.0));
        assert_eq!(m.mmp.value, Some(1.0));
        assert_eq!(m.x_off, Some(10.0));
    }

    #[test]
    fn fdi_and_mmp_count_frames_with_strict_inequalities() {
        // x_off = 100: 110 is exactly +10 % (not counted), 111 is counted.
        let luma = [100.0, 110.0, 111.0, 50.0, 129.0];
        let m = evaluate(&luma, &seg(1, 0, 4), &P2020Options::default()).unwrap();
        assert_eq!(m.fdi.value, Some(0.5));
        // PWM mean = 100: band (90, 110) strictly; 110 is out, so none inside.
        assert_eq!(m.x_ref, Some(100.0));
        assert_eq!(m.mmp.value, Some(0.0));
        assert!((m.fmi.value.unwrap() - (129.0 - 50.0) / 179.0).abs() < 1e-15);
    }

    #[test]
    fn dark_baseline_counts_lit_frames_and_says_why_never_nan() {
        let luma = [0.0, 0.0, 0.0, 5.0, 0.0, 7.0];
        let m = evaluate(&luma, &seg(2, 0, 4), &P2020Options::default()).unwrap();
        assert_eq!(m.fdi.value, Some(0.5));
        assert!(
            m.fdi
                .reason
                .unwrap()
                .contains("dark OFF reference (level 0)")
        );
        let dark = evaluate(&[0.0, 0.0, 0.0], &seg(1, 0, 2), &P2020Options::default()).unwrap();
        assert_eq!(dark.fmi.value, None);
        assert_eq!(dark.mmp.value, None);
        assert_eq!(dark.fdi.value, Some(0.0));
    }

    #[test]
    fn mmp_on_level_reference_needs_on_frames() {
        let opts = P2020Options {
            mmp_reference: MmpReference::OnLevel,
            ..P2020Options::default()
        };
        let m = evaluate(&[100.0, 95.0, 150.0], &seg(0, 1, 2), &opts).unwrap();
        assert_eq!(m.mmp.value, Some(0.5));
        let m = evaluate(&[100.0, 95.0], &seg(0, 0, 2), &opts).unwrap();
        assert!(m.mmp.reason.unwrap().contains("steady-ON"));
    }
}
