//! Will the driver see the flicker on the CMS monitor? The visibility of
//! the displayed luminance's temporal modulation for the standard observer
//! (docs/visibility.md).
//!
//! Sits with the metrics: it sees the ROI's luma trace of the PWM
//! segment, its frame times and the plan's `[display]`, never the physics
//! that made the trace, so simulated and captured cases are judged alike.
//!
//! 1. [`screen`]: code value -> luminance (EOTF), frames held from refresh
//!    to refresh, the ROI's visual angle;
//! 2. the exact Fourier series of that piecewise-constant luminance over
//!    the segment, as modulation `m_n = 2 |c_n| / c_0` at `f_n = n / T`;
//! 3. [`tcsf`]: each component weighted by the elaTCSF sensitivity at the
//!    segment's mean luminance and the ROI's size, `v_n = m_n S(f_n)`;
//! 4. the index `V = (sum v_n^B)^(1/B)`, a Minkowski sum over frequency
//!    with the exponent `B = 3.7` the stroboscopic visibility measure uses
//!    for the same pooling (Perz et al. 2015; CIE TN 006:2016). A single
//!    sinusoid of modulation `m` at `f` gives `V = m S(f)`: 1 is threshold.

pub mod pstlm;
pub mod screen;
pub mod svm;
pub mod tcsf;
pub mod validation;

use serde::{Deserialize, Serialize};

use ledflicker_plan::plan::Roi;
use ledflicker_plan::plan::display::Display;
use ledflicker_plan::trace::{FrameInfo, Segment};

/// Minkowski exponent of the pooling over frequency (CIE TN 006:2016).
pub const POOLING_EXPONENT: f64 = 3.7;

/// Highest frequency summed, Hz. The elaTCSF sensitivity of a 60 deg
/// field at 1e5 cd/m^2 (the brightest display a plan accepts) is 0.006
/// at 400 Hz and falls about tenfold per 100 Hz above, so a component
/// there (modulation at most 2) adds at most 0.012 to the index.
pub const MAX_FREQUENCY_HZ: f64 = 400.0;

/// Modulation below which a component names no most-visible frequency:
/// the rounding noise of a steady light's series (1e-16) is far below it,
/// and an 8-bit display's smallest step (1/255, 4e-3) far above.
const MIN_MODULATION: f64 = 1e-9;

/// The visibility of one ROI's displayed flicker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Visibility {
    /// The index (1 = at threshold for the standard observer); `None`
    /// with `reason` when it cannot be computed.
    pub index: Option<f64>,
    /// Frequency of the component that contributes most, Hz.
    pub peak_frequency_hz: Option<f64>,
    /// Mean displayed luminance of the ROI over the segment, cd/m^2.
    pub mean_luminance_cd_m2: f64,
    /// Radius of the disk of the ROI's visual area, degrees.
    pub radius_deg: f64,
    /// Why `index` is `None`.
    pub reason: Option<String>,
}

impl Visibility {
    /// The index as a checkable metric.
    pub fn metric(&self) -> super::Metric {
        super::Metric {
            value: self.index,
            unbounded: false,
            reason: self.reason.clone(),
        }
    }
}

/// A Fourier component of a luminance: frequency (Hz) and modulation
/// (amplitude over mean, >= 0).
pub type Component = (f64, f64);

/// The Fourier series over `[0, T)` of the piecewise-constant `holds`
/// (`T` the end of the last hold), harmonics 1.. up to `max_hz`, and the
/// mean (`c_0`). Exact for steps: the integral of `e^(-i w t)` over a hold
/// `[a, b)` is `(e^(-i w a) - e^(-i w b)) / (i w)`.
pub fn spectrum(holds: &[screen::Hold], max_hz: f64) -> (f64, Vec<Component>) {
    let Some(last) = holds.last() else {
        return (0.0, Vec::new());
    };
    let period = last.end_s;
    let mean = holds
        .iter()
        .map(|h| h.luminance_cd_m2 * (h.end_s - h.start_s))
        .sum::<f64>()
        / period;
    // Inclusive, within rounding: a segment of exactly 60 frames at 60 fps
    // gives `400 T = 399.99999999999994`.
    let harmonics = (max_hz * period * (1.0 + 1e-12)).floor() as usize;
    let components = (1..=harmonics)
        .map(|n| {
            let w = 2.0 * std::f64::consts::PI * n as f64 / period;
            let (mut re, mut im) = (0.0, 0.0);
            for h in holds {
                let (sa, ca) = (w * h.start_s).sin_cos();
                let (sb, cb) = (w * h.end_s).sin_cos();
                re += h.luminance_cd_m2 * (ca - cb);
                im += h.luminance_cd_m2 * (sb - sa);
            }
            let c_n = re.hypot(im) / (w * period);
            let m = if mean > 0.0 { 2.0 * c_n / mean } else { 0.0 };
            (n as f64 / period, m)
        })
        .collect();
    (mean, components)
}

/// The index of `components` seen at mean luminance `mean_cd_m2` (>=
/// [`tcsf::MIN_LUMINANCE_CD_M2`]) over a disk of `radius_deg`: the
/// Minkowski sum of `m S(f)`, and the frequency of its largest term.
pub fn index(components: &[Component], mean_cd_m2: f64, radius_deg: f64) -> (f64, Option<f64>) {
    let mut sum = 0.0;
    let mut peak: Option<(f64, f64)> = None;
    for &(f, m) in components {
        let v = m * tcsf::disk_sensitivity(f, radius_deg, mean_cd_m2);
        sum += v.powf(POOLING_EXPONENT);
        if m > MIN_MODULATION && peak.is_none_or(|(_, p)| v > p) {
            peak = Some((f, v));
        }
    }
    (sum.powf(1.0 / POOLING_EXPONENT), peak.map(|(f, _)| f))
}

/// The visibility of an ROI of `width_px` x `height_px` whose PWM-segment
/// frames start at `times_s` (seconds, increasing, one per frame, at least
/// two) with `luma` DN, each frame lasting `frame_s`, shown on `d`.
pub fn evaluate(
    d: &Display,
    times_s: &[f64],
    luma: &[f64],
    frame_s: f64,
    (width_px, height_px): (u32, u32),
) -> Visibility {
    let radius_deg = screen::roi_radius_deg(d, width_px, height_px);
    let lum: Vec<f64> = luma
        .iter()
        .map(|x| screen::luminance_cd_m2(d, x / d.full_scale_dn))
        .collect();
    let holds = screen::holds(d.refresh_hz, times_s, &lum, frame_s);
    let (mean, components) = spectrum(&holds, MAX_FREQUENCY_HZ);
    let undefined = |reason: String| Visibility {
        index: None,
        peak_frequency_hz: None,
        mean_luminance_cd_m2: mean,
        radius_deg,
        reason: Some(reason),
    };
    if holds.len() < 2 {
        return undefined(format!(
            "the {} Hz monitor shows fewer than two frames of the PWM segment",
            d.refresh_hz
        ));
    }
    if mean < tcsf::MIN_LUMINANCE_CD_M2 {
        return undefined(format!(
            "the mean displayed luminance {mean:.4} cd/m^2 is below the {} cd/m^2 the eye model covers",
            tcsf::MIN_LUMINANCE_CD_M2
        ));
    }
    let (value, peak) = index(&components, mean, radius_deg);
    Visibility {
        index: Some(value),
        peak_frequency_hz: peak,
        mean_luminance_cd_m2: mean,
        radius_deg,
        reason: None,
    }
}

/// The visibility of `roi`'s trace `luma` over the PWM-segment frames of
/// `frames`, shown on `d`. Each frame lasts the mean interval of the
/// segment's frames.
pub fn of_trace(d: &Display, frames: &[FrameInfo], luma: &[f64], roi: &Roi) -> Visibility {
    let (times, values): (Vec<f64>, Vec<f64>) = frames
        .iter()
        .zip(luma)
        .filter(|(f, _)| f.segment == Segment::Pwm)
        .map(|(f, &x)| (f.time_s, x))
        .unzip();
    let frame_s = match (times.first(), times.last()) {
        (Some(a), Some(b)) if times.len() > 1 => (b - a) / (times.len() - 1) as f64,
        _ => 0.0,
    };
    evaluate(d, &times, &values, frame_s, (roi.width_px, roi.height_px))
}

#[cfg(test)]
mod tests;
