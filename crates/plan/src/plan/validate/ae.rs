//! `[auto-exposure]` of a physical camera: target, damping, deadband and
//! the exposure and gain limits of the controller.

use crate::plan::bounds::{ANALOG_GAIN_RANGE, DIGITAL_GAIN_RANGE, MIN_EXPOSURE_S, MIN_FPS};
use crate::plan::check::Checker;
use crate::plan::raw::RawAutoExposure;
use ledflicker_physics::ae::AutoExposure;
use ledflicker_physics::hdr::ToneCurve;

/// Validates `[auto-exposure]` under `prefix`. `curve` is the camera's
/// tone curve (`None` when invalid) and `frame_s` its frame time, seconds,
/// the default longest exposure.
pub(super) fn auto_exposure(
    c: &mut Checker<'_>,
    a: &RawAutoExposure,
    prefix: &str,
    curve: Option<ToneCurve>,
    frame_s: Option<f64>,
) -> Option<AutoExposure> {
    let kk = |s: &str| format!("{prefix}.auto-exposure.{s}");
    let f = fields(c, a, &kk, curve, frame_s);
    cross_check(c, &f, frame_s, &kk);
    Some(AutoExposure {
        target: f.target?,
        damping: f.damping?,
        deadband: f.deadband?,
        min_exposure_s: f.min_t?,
        max_exposure_s: f.max_t?,
        max_analog_gain: f.max_ga?,
        min_digital_gain: f.min_gd?,
        max_digital_gain: f.max_gd?,
    })
}

/// The keys of `[auto-exposure]`, each checked on its own (`None`:
/// invalid); exposures in seconds.
struct Fields {
    target: Option<f64>,
    damping: Option<f64>,
    deadband: Option<f64>,
    min_t: Option<f64>,
    max_t: Option<f64>,
    max_ga: Option<f64>,
    min_gd: Option<f64>,
    max_gd: Option<f64>,
}

/// Each key with its default: the longest exposure defaults to the frame
/// time `frame_s`.
fn fields(
    c: &mut Checker<'_>,
    a: &RawAutoExposure,
    kk: &dyn Fn(&str) -> String,
    curve: Option<ToneCurve>,
    frame_s: Option<f64>,
) -> Fields {
    let target = ae_target(c, a.target_luma, a.target, curve, kk);
    let damping = c.positive(
        a.damping.unwrap_or(0.5),
        &kk("damping"),
        "fraction of the error corrected per frame, in (0, 1]",
    );
    let deadband = c.non_negative(
        a.deadband.unwrap_or(0.05),
        &kk("deadband"),
        "relative error, e.g. 0.05",
    );
    let exposure_ms = (MIN_EXPOSURE_S * 1e3, 1e3 / MIN_FPS);
    let min_t = c
        .within(
            a.min_exposure_ms.unwrap_or(0.01),
            &kk("min-exposure-ms"),
            exposure_ms,
            " ms",
            "e.g. 11.111 for flicker mitigation above 90 Hz; at least 1 us",
        )
        .map(|v| v * 1e-3);
    let max_t = match (a.max_exposure_ms, frame_s) {
        (Some(v), _) => c
            .within(
                v,
                &kk("max-exposure-ms"),
                exposure_ms,
                " ms",
                "at most the frame time",
            )
            .map(|v| v * 1e-3),
        (None, Some(f)) => Some(f),
        (None, None) => None,
    };
    let max_ga = c.within(
        a.max_analog_gain.unwrap_or(16.0),
        &kk("max-analog-gain"),
        ANALOG_GAIN_RANGE,
        "",
        "analogue gain amplifies: at least 1",
    );
    let min_gd = c.within(
        a.min_digital_gain.unwrap_or(1.0),
        &kk("min-digital-gain"),
        DIGITAL_GAIN_RANGE,
        "",
        "e.g. 0.01 to scale bright scenes down",
    );
    let max_gd = c.within(
        a.max_digital_gain.unwrap_or(1.0),
        &kk("max-digital-gain"),
        DIGITAL_GAIN_RANGE,
        "",
        "at least min-digital-gain",
    );
    Fields {
        target,
        damping,
        deadband,
        min_t,
        max_t,
        max_ga,
        min_gd,
        max_gd,
    }
}

/// The checks between keys: damping at most 1, the exposure range in
/// order and within the frame time `frame_s`, the gain limits in order.
fn cross_check(c: &mut Checker<'_>, f: &Fields, frame_s: Option<f64>, kk: &dyn Fn(&str) -> String) {
    if f.damping.is_some_and(|d| d > 1.0) {
        c.error(
            &kk("damping"),
            "must be at most 1",
            Some("1 corrects the whole error in one frame"),
        );
    }
    if let (Some(lo), Some(hi)) = (f.min_t, f.max_t)
        && lo > hi
    {
        c.error(
            &kk("min-exposure-ms"),
            format!("{} ms is above max-exposure-ms {} ms", lo * 1e3, hi * 1e3),
            None,
        );
    }
    if let (Some(hi), Some(frame)) = (f.max_t, frame_s)
        && hi > frame * (1.0 + 1e-12)
    {
        c.error(
            &kk("max-exposure-ms"),
            format!(
                "{:.3} ms is longer than the frame time {:.3} ms",
                hi * 1e3,
                frame * 1e3
            ),
            None,
        );
    }
    if let (Some(lo), Some(hi)) = (f.min_gd, f.max_gd)
        && lo > hi
    {
        c.error(&kk("max-digital-gain"), "must be >= min-digital-gain", None);
    }
}

/// Default auto-exposure target: the output level of the metered area as a
/// fraction of full scale. 0.46 is where 18 % grey lands in sRGB
/// (IEC 61966-2-1): a mid-grey scene looks mid-grey.
pub const DEFAULT_TARGET_LUMA: f64 = 0.46;

/// The auto-exposure target as the controller uses it: a linear fraction of
/// white. `target-luma` (output level, 0..1 of full scale) goes through the
/// inverse tone curve; the older `target` is that linear fraction itself.
fn ae_target(
    c: &mut Checker<'_>,
    luma: Option<f64>,
    linear: Option<f64>,
    curve: Option<ToneCurve>,
    kk: &dyn Fn(&str) -> String,
) -> Option<f64> {
    let hint_luma =
        "the metered area's output level, 0..1 of full scale, e.g. 0.46 (18 % grey in sRGB)";
    match (luma, linear) {
        (Some(_), Some(_)) => {
            c.error(
                &kk("target"),
                "give target-luma or target, not both",
                Some("target-luma is the output level; target, the older key, a linear fraction of white"),
            );
            None
        }
        (None, Some(t)) => {
            let t = c.positive(t, &kk("target"), "a linear fraction of white, e.g. 0.0003")?;
            if t >= 1.0 {
                c.error(&kk("target"), "must be below 1 (white)", Some(hint_luma));
                return None;
            }
            Some(t)
        }
        (luma, None) => {
            let key = kk("target-luma");
            let y = luma.unwrap_or(DEFAULT_TARGET_LUMA);
            if !(y.is_finite() && y > 0.0 && y < 1.0) {
                c.error(&key, format!("{y} is outside (0, 1)"), Some(hint_luma));
                return None;
            }
            Some(curve?.inverse(y))
        }
    }
}
