//! The physical part of a camera: `[sensor]`, `[[capture]]` (HDR
//! captures), `[hdr]`, `[tone]` and the gains; `[auto-exposure]` is in
//! `ae.rs`. Keys sit under the camera's prefix (`dut.camera.` or
//! `camera.`).

use super::ae;
use crate::plan::PhysicalCamera;
use crate::plan::bounds::{
    ANALOG_GAIN_RANGE, DIGITAL_GAIN_RANGE, E_PER_DN_RANGE, FULL_WELL_E_RANGE, GAMMA_RANGE,
    LOG_A_RANGE, MIN_EXPOSURE_RATIO, MIN_EXPOSURE_S, MIN_FPS, SENSITIVITY_RANGE,
    SENSITIVITY_RATIO_RANGE, WHITE_DN_RANGE,
};
use crate::plan::check::Checker;
use crate::plan::raw::{RawCamera, RawCapture, RawHdr, RawSensor, RawTone};
use ledflicker_physics::hdr::{Capture, CaptureExposure, HdrMode, MergeRule, Tone, ToneCurve};
use ledflicker_physics::sensor::Sensor;

/// Validates the physical camera of `cam`, which has a `[sensor]` table.
/// `exposure_s` and `fps` are the camera's, `None` when invalid.
pub(super) fn physical_camera(
    c: &mut Checker<'_>,
    cam: &RawCamera,
    prefix: &str,
    exposure_s: Option<f64>,
    fps: Option<f64>,
) -> Option<PhysicalCamera> {
    let k = |s: &str| format!("{prefix}.{s}");
    let raw = cam.sensor.as_ref()?;
    let sensor = sensor(c, raw, prefix);
    let (captures, mut ok) = captures(c, &cam.capture, prefix);
    let hdr = cam.hdr.as_ref();
    let (hdr_mode, merge) = hdr_table(c, hdr, prefix);
    let (curve, out_bits) = tone_table(c, cam.tone.as_ref(), prefix);
    let frame_s = fps.map(|f| 1.0 / f);
    let ae = match &cam.auto_exposure {
        None => None,
        Some(a) => {
            let ae = ae::auto_exposure(c, a, prefix, curve, frame_s);
            ok &= ae.is_some();
            ae
        }
    };
    let analog_gain = c.within(
        cam.analog_gain.unwrap_or(1.0),
        &k("analog-gain"),
        ANALOG_GAIN_RANGE,
        "",
        "analogue gain amplifies; use digital-gain to scale down",
    );
    let digital_gain = c.within(
        cam.digital_gain.unwrap_or(1.0),
        &k("digital-gain"),
        DIGITAL_GAIN_RANGE,
        "",
        "a factor applied after the merge, e.g. 1.0",
    );
    // Sequential captures must fit in the frame at the longest exposure.
    let longest_t = ae.map(|a| a.max_exposure_s).or(exposure_s);
    if let (Some(HdrMode::Sequential), Some(t), Some(f)) = (hdr_mode, longest_t, frame_s) {
        ok &= sequential_fits(c, &captures, t, f, prefix);
    }
    let sensor = sensor?;
    let white = white_dn(c, hdr, &sensor, &captures, exposure_s?, prefix)?;
    if !ok {
        return None;
    }
    Some(PhysicalCamera {
        sensor,
        captures,
        hdr_mode: hdr_mode?,
        merge: merge?,
        tone: Tone {
            curve: curve?,
            white,
            output_max: (2f64).powi(out_bits? as i32) - 1.0,
        },
        auto_exposure: ae,
        analog_gain: analog_gain?,
        digital_gain: digital_gain?,
    })
}

/// `[sensor]`: sensitivity and full well (required), read noise, shot
/// noise, ADC bits and electrons per DN (default: full well over the ADC
/// range).
fn sensor(c: &mut Checker<'_>, raw: &RawSensor, prefix: &str) -> Option<Sensor> {
    let k = |s: &str| format!("{prefix}.{s}");
    let hint = "see docs/camera-model.md";
    let sens = c
        .required(
            raw.sensitivity_e_per_cd_m2_s,
            &k("sensor.sensitivity-e-per-cd-m2-s"),
            hint,
        )
        .and_then(|v| {
            c.within(
                v,
                &k("sensor.sensitivity-e-per-cd-m2-s"),
                SENSITIVITY_RANGE,
                "",
                "electrons per cd/m^2 per second: a few thousand for a 3 um pixel; see docs/camera-model.md",
            )
        });
    let full_well = c
        .required(
            raw.full_well_e,
            &k("sensor.full-well-e"),
            "full-well capacity in electrons, e.g. 10000",
        )
        .and_then(|v| {
            c.within(
                v,
                &k("sensor.full-well-e"),
                FULL_WELL_E_RANGE,
                " e-",
                "automotive HDR pixels hold 10000 to 100000 electrons",
            )
        });
    let read_noise = c.non_negative(
        raw.read_noise_e.unwrap_or(0.0),
        &k("sensor.read-noise-e"),
        hint,
    );
    let bits = raw.adc_bits.unwrap_or(12);
    let bits = if (1..=24).contains(&bits) {
        Some(bits as u32)
    } else {
        c.error(
            &k("sensor.adc-bits"),
            format!("{bits} bits is outside 1..=24"),
            Some("e.g. 12"),
        );
        None
    };
    let e_per_dn = match (raw.e_per_dn, full_well, bits) {
        (Some(v), _, _) => c.within(
            v,
            &k("sensor.e-per-dn"),
            E_PER_DN_RANGE,
            "",
            "electrons per DN at gain 1, e.g. the full well over the ADC range",
        ),
        (None, Some(fw), Some(b)) => Some(fw / ((2f64).powi(b as i32) - 1.0)),
        _ => None,
    };
    Some(Sensor {
        sensitivity_e_per_cd_m2_s: sens?,
        full_well_e: full_well?,
        read_noise_e: read_noise?,
        shot_noise: raw.shot_noise.unwrap_or(true),
        adc_bits: bits?,
        e_per_dn: e_per_dn?,
    })
}

/// `[[capture]]`: 1 to 4 HDR captures, the first the reference (L); one
/// L capture when none is given. The flag is false after an error.
fn captures(c: &mut Checker<'_>, raw: &[RawCapture], prefix: &str) -> (Vec<Capture>, bool) {
    let mut captures = Vec::new();
    let mut ok = true;
    if raw.is_empty() {
        captures.push(Capture {
            name: "L".to_string(),
            exposure: CaptureExposure::Ratio(1.0),
            sensitivity_ratio: 1.0,
        });
    }
    if raw.len() > 4 {
        c.error(
            &format!("{prefix}.capture"),
            format!("{} captures; at most 4", raw.len()),
            Some("HDR schemes use 1 to 4 captures"),
        );
        ok = false;
    }
    for (i, cap) in raw.iter().enumerate() {
        match capture(c, cap, &format!("{prefix}.capture[{i}]")) {
            Some((exposure, sensitivity_ratio)) => captures.push(Capture {
                name: cap
                    .name
                    .clone()
                    .unwrap_or_else(|| ["L", "M", "S", "VS"][i.min(3)].to_string()),
                exposure,
                sensitivity_ratio,
            }),
            None => ok = false,
        }
    }
    (captures, ok)
}

/// One capture under `key`: its exposure (a ratio of L's, or fixed) and
/// its sensitivity ratio.
fn capture(c: &mut Checker<'_>, cap: &RawCapture, key: &str) -> Option<(CaptureExposure, f64)> {
    let kk = |s: &str| format!("{key}.{s}");
    let exposure = match (cap.exposure_ratio, cap.exposure_ms) {
        (Some(_), Some(_)) | (None, None) => {
            c.error(
                &kk("exposure-ratio"),
                "give exactly one of `exposure-ratio` and `exposure-ms`",
                Some("a ratio follows auto exposure; exposure-ms is fixed"),
            );
            None
        }
        (Some(r), None) => c
            .within(
                r,
                &kk("exposure-ratio"),
                (MIN_EXPOSURE_RATIO, 1.0),
                "",
                "a fraction of the first, longest capture's exposure",
            )
            .map(CaptureExposure::Ratio),
        (None, Some(ms)) => c
            .within(
                ms,
                &kk("exposure-ms"),
                (MIN_EXPOSURE_S * 1e3, 1e3 / MIN_FPS),
                " ms",
                "milliseconds, at least 1 us and within the frame time",
            )
            .map(|ms| CaptureExposure::Fixed(ms * 1e-3)),
    };
    let sensitivity = c.within(
        cap.sensitivity_ratio.unwrap_or(1.0),
        &kk("sensitivity-ratio"),
        SENSITIVITY_RATIO_RANGE,
        "",
        "1 for a normal pixel, e.g. 0.0625 for a small split pixel",
    );
    Some((exposure?, sensitivity?))
}

/// `[hdr]` `mode` and `merge`.
fn hdr_table(
    c: &mut Checker<'_>,
    hdr: Option<&RawHdr>,
    prefix: &str,
) -> (Option<HdrMode>, Option<MergeRule>) {
    let hdr_mode = match hdr.and_then(|h| h.mode.as_deref()) {
        None | Some("sequential") => Some(HdrMode::Sequential),
        Some("split-pixel") => Some(HdrMode::SplitPixel),
        Some(other) => {
            c.error(
                &format!("{prefix}.hdr.mode"),
                format!("unknown HDR mode `{other}`"),
                Some("use \"sequential\" or \"split-pixel\""),
            );
            None
        }
    };
    let merge = match hdr.and_then(|h| h.merge.as_deref()) {
        None | Some("longest-unsaturated") => Some(MergeRule::LongestUnsaturated),
        Some("weighted") => Some(MergeRule::Weighted),
        Some(other) => {
            c.error(
                &format!("{prefix}.hdr.merge"),
                format!("unknown merge rule `{other}`"),
                Some("use \"longest-unsaturated\" or \"weighted\""),
            );
            None
        }
    };
    (hdr_mode, merge)
}

/// `[tone]`: the curve (with its parameter) and the output bits.
fn tone_table(
    c: &mut Checker<'_>,
    tone_raw: Option<&RawTone>,
    prefix: &str,
) -> (Option<ToneCurve>, Option<u32>) {
    let k = |s: &str| format!("{prefix}.{s}");
    let curve = match tone_raw.and_then(|t| t.curve.as_deref()) {
        None | Some("linear") => Some(ToneCurve::Linear),
        Some("gamma") => c
            .within(
                tone_raw.and_then(|t| t.gamma).unwrap_or(2.2),
                &k("tone.gamma"),
                GAMMA_RANGE,
                "",
                "e.g. 2.2",
            )
            .map(ToneCurve::Gamma),
        Some("log") => c
            .within(
                tone_raw.and_then(|t| t.log_a).unwrap_or(1000.0),
                &k("tone.log-a"),
                LOG_A_RANGE,
                "",
                "compression, e.g. 1000",
            )
            .map(ToneCurve::Log),
        Some(other) => {
            c.error(
                &k("tone.curve"),
                format!("unknown tone curve `{other}`"),
                Some("use \"linear\", \"gamma\" or \"log\""),
            );
            None
        }
    };
    let out_bits = tone_raw.and_then(|t| t.output_bits).unwrap_or(8);
    let out_bits = if (8..=16).contains(&out_bits) {
        Some(out_bits as u32)
    } else {
        c.error(
            &k("tone.output-bits"),
            format!("{out_bits} is outside 8..=16"),
            Some("8 or 16"),
        );
        None
    };
    (curve, out_bits)
}

/// Whether sequential captures at longest exposure `t` fit in frame time
/// `f`, both seconds; reports when they do not.
fn sequential_fits(
    c: &mut Checker<'_>,
    captures: &[Capture],
    t: f64,
    f: f64,
    prefix: &str,
) -> bool {
    let total: f64 = captures.iter().map(|cap| cap.exposure_s(t)).sum();
    if total <= f * (1.0 + 1e-9) {
        return true;
    }
    c.error(
        &format!("{prefix}.capture"),
        format!(
            "sequential captures take {:.3} ms at the longest exposure, more than the frame time {:.3} ms",
            total * 1e3,
            f * 1e3
        ),
        Some("lower the exposure ratios or auto-exposure.max-exposure-ms"),
    );
    false
}

/// `[hdr] white-dn`: the L-equivalent DN mapped to white; by default the
/// sensor's top DN scaled up by the least sensitive capture at the nominal
/// exposure `nominal_t` (seconds).
fn white_dn(
    c: &mut Checker<'_>,
    hdr: Option<&RawHdr>,
    sensor: &Sensor,
    captures: &[Capture],
    nominal_t: f64,
    prefix: &str,
) -> Option<f64> {
    let min_scale = captures
        .iter()
        .map(|cap| {
            cap.exposure_s(nominal_t) / captures[0].exposure_s(nominal_t) * cap.sensitivity_ratio
                / captures[0].sensitivity_ratio
        })
        .fold(f64::INFINITY, f64::min);
    match hdr.and_then(|h| h.white_dn) {
        Some(w) => c.within(
            w,
            &format!("{prefix}.hdr.white-dn"),
            WHITE_DN_RANGE,
            " DN",
            "L-equivalent DN mapped to white",
        ),
        None => Some(sensor.dn_max() / min_scale.min(1.0)),
    }
}
