//! `[dut.camera]` (or a profile's `[camera]`): shutter, sensor size, frame
//! timing and the output levels of the simulated camera. A `[sensor]`
//! table makes it a physical camera (`sensor.rs`).

use super::sensor;
use crate::plan::bounds::{FULL_SCALE_DN_RANGE, MAX_FPS, MAX_PWM_DELAY_S, MIN_FPS, RESPONSE_RANGE};
use crate::plan::check::{Checker, approx};
use crate::plan::raw::RawCamera;
use crate::plan::{CameraConfig, ShutterKind};

/// Validates a camera table whose keys sit under `prefix`; `source` is
/// where it came from ("plan" or the profile's path).
pub(super) fn camera_config(
    c: &mut Checker<'_>,
    cam: RawCamera,
    prefix: &str,
    source: &str,
) -> Option<CameraConfig> {
    let k = |s: &str| format!("{prefix}.{s}");
    let shutter = shutter(c, cam.shutter.as_deref(), &k("shutter"));
    let rows = c
        .required(
            cam.sensor_rows,
            &k("sensor-rows"),
            "sensor height in rows, e.g. 800",
        )
        .and_then(|v| c.pixels(v, &k("sensor-rows"), 1));
    let cols = c
        .required(
            cam.sensor_columns,
            &k("sensor-columns"),
            "sensor width in columns, e.g. 1280",
        )
        .and_then(|v| c.pixels(v, &k("sensor-columns"), 1));
    let (fps, exposure_s) = frame_timing(c, &cam, prefix);
    let line_time_s = line_time(c, &cam, prefix, shutter, rows, fps);
    let pwm_delay_s = match cam.pwm_delay_ms {
        Some(v) => c
            .within(
                v,
                &k("pwm-delay-ms"),
                (-MAX_PWM_DELAY_S * 1e3, MAX_PWM_DELAY_S * 1e3),
                " ms",
                "the first PWM rising edge after frame 0 starts; a delay of more than one PWM period is the same as its remainder",
            )
            .map(|ms| ms * 1e-3),
        None => Some(0.0),
    };
    let response = response(c, &cam, prefix);
    let physical = match cam.sensor {
        Some(_) => Some(sensor::physical_camera(c, &cam, prefix, exposure_s, fps)?),
        None => None,
    };
    let full_default = physical.as_ref().map_or(255.0, |p| p.tone.output_max);
    let (black, full, sat) = output_levels(c, &cam, prefix, full_default)?;
    Some(CameraConfig {
        name: cam.name.clone().unwrap_or_else(|| "inline".to_string()),
        description: cam.description.clone().unwrap_or_default(),
        source: source.to_string(),
        physical,
        shutter: shutter?,
        sensor_rows: rows?,
        sensor_columns: cols?,
        line_time_s: line_time_s?,
        exposure_s: exposure_s?,
        fps: fps?,
        pwm_delay_s: pwm_delay_s?,
        response_dn_per_cd_m2_s: response?,
        black_level_dn: black?,
        full_scale_dn: full?,
        saturation_dn: sat?,
    })
}

/// `shutter`: "global" or "rolling", required.
fn shutter(c: &mut Checker<'_>, value: Option<&str>, key: &str) -> Option<ShutterKind> {
    match value {
        Some("global") => Some(ShutterKind::Global),
        Some("rolling") => Some(ShutterKind::Rolling),
        Some(other) => {
            c.error(
                key,
                format!("unknown shutter `{other}`"),
                Some("use \"global\" or \"rolling\""),
            );
            None
        }
        None => {
            c.error(
                key,
                "missing required key",
                Some("shutter = \"global\" or \"rolling\""),
            );
            None
        }
    }
}

/// `frame-rate-fps` and `exposure-ms` (returned in seconds); the exposure
/// must fit in the frame time.
fn frame_timing(c: &mut Checker<'_>, cam: &RawCamera, prefix: &str) -> (Option<f64>, Option<f64>) {
    let k = |s: &str| format!("{prefix}.{s}");
    let fps = c
        .required(
            cam.frame_rate_fps,
            &k("frame-rate-fps"),
            "e.g. frame-rate-fps = 30.0",
        )
        .and_then(|v| {
            c.within(
                v,
                &k("frame-rate-fps"),
                (MIN_FPS, MAX_FPS),
                " fps",
                "frames per second: automotive cameras run at 10 to 120 fps",
            )
        });
    let exposure_s = c
        .required(
            cam.exposure_ms,
            &k("exposure-ms"),
            "exposure time in milliseconds, e.g. 11.111",
        )
        .and_then(|v| c.positive(v, &k("exposure-ms"), "exposure time in milliseconds"))
        .map(|ms| ms * 1e-3);
    if let (Some(t), Some(fps)) = (exposure_s, fps)
        && t > 1.0 / fps * (1.0 + 1e-12)
    {
        c.error(
            &k("exposure-ms"),
            format!(
                "exposure {} ms is longer than the frame time {:.3} ms",
                t * 1e3,
                1e3 / fps
            ),
            // Ten times the frame time and more, yet within it read as
            // microseconds: a unit slip, not a slightly long exposure.
            Some(&if t > 10.0 / fps && t * 1e-3 <= 1.0 / fps {
                format!(
                    "exposure-ms is in milliseconds: {} reads like microseconds ({} ms)",
                    approx(t * 1e3),
                    approx(t)
                )
            } else {
                "lower exposure-ms or frame-rate-fps".to_string()
            }),
        );
    }
    (fps, exposure_s)
}

/// `line-time-us` in seconds: required for a rolling shutter, whose
/// readout must fit in the frame time; 0 by default for a global one.
fn line_time(
    c: &mut Checker<'_>,
    cam: &RawCamera,
    prefix: &str,
    shutter: Option<ShutterKind>,
    rows: Option<u32>,
    fps: Option<f64>,
) -> Option<f64> {
    let k = |s: &str| format!("{prefix}.{s}");
    let line_time_s = match (shutter, cam.line_time_us) {
        (Some(ShutterKind::Rolling), None) => {
            c.error(
                &k("line-time-us"),
                "missing required key for a rolling shutter",
                Some("the time between row starts in microseconds, e.g. 14.565"),
            );
            None
        }
        (_, Some(v)) => c
            .non_negative(v, &k("line-time-us"), "line time in microseconds")
            .map(|us| us * 1e-6),
        (_, None) => Some(0.0),
    };
    if let (Some(ShutterKind::Rolling), Some(lt), Some(rows), Some(fps)) =
        (shutter, line_time_s, rows, fps)
    {
        readout_fits(c, &k("line-time-us"), lt, rows, fps);
    }
    line_time_s
}

/// Shortest line time taken at face value, seconds. The fastest CMOS
/// sensors start a row every microsecond or so; below 100 ns a value is
/// far more likely a line time in milliseconds written under `-us`
/// (14.565 us as 0.014565).
const MIN_PLAUSIBLE_LINE_TIME_S: f64 = 1e-7;

/// The rolling readout, `rows` rows `lt` seconds apart, must fit in the
/// frame time at `fps`: an error when it does not (with the nanosecond
/// reading in the hint when that fits), a warning when the line time is
/// implausibly short and its millisecond reading fits.
fn readout_fits(c: &mut Checker<'_>, key: &str, lt: f64, rows: u32, fps: f64) {
    let (readout, frame) = (lt * rows as f64, 1.0 / fps);
    let us = lt * 1e6;
    if readout > frame * (1.0 + 1e-12) {
        // Ten times the frame time and more, yet within it read as
        // nanoseconds: a unit slip, not a slightly long readout.
        let hint = if readout > 10.0 * frame && readout * 1e-3 <= frame {
            format!(
                "line-time-us is in microseconds: {} reads like nanoseconds ({} us, a {:.3} ms readout)",
                approx(us),
                approx(us * 1e-3),
                readout
            )
        } else {
            "check line-time-us and sensor-rows".to_string()
        };
        c.error(
            key,
            format!(
                "readout of {rows} rows takes {:.3} ms, longer than the frame time {:.3} ms",
                readout * 1e3,
                frame * 1e3
            ),
            Some(&hint),
        );
    } else if lt > 0.0 && lt < MIN_PLAUSIBLE_LINE_TIME_S && readout * 1e3 <= frame {
        c.warn(
            key,
            format!(
                "line time {} us is below 0.1 us, so the {rows} rows read out in {} us ({} % of the {:.3} ms frame): likely given in milliseconds",
                approx(us),
                approx(readout * 1e6),
                approx(readout / frame * 100.0),
                frame * 1e3
            ),
            &format!(
                "line-time-us is in microseconds: {} ms is {} us (a {:.3} ms readout)",
                approx(us),
                approx(us * 1e3),
                readout * 1e6
            ),
        );
    }
}

/// `response-dn-per-cd-m2-s`: required by the ideal camera, refused by a
/// physical one (0 there: the sensor sets the response).
fn response(c: &mut Checker<'_>, cam: &RawCamera, prefix: &str) -> Option<f64> {
    let key = format!("{prefix}.response-dn-per-cd-m2-s");
    if cam.sensor.is_some() {
        if cam.response_dn_per_cd_m2_s.is_some() {
            c.error(
                &key,
                "the ideal camera's response does not apply to a camera with a [sensor] table",
                Some("remove it; the sensor's sensitivity sets the response"),
            );
        }
        return Some(0.0);
    }
    c.required(
        cam.response_dn_per_cd_m2_s,
        &key,
        "output DN per cd/m^2 per second of exposure, e.g. 20.0",
    )
    .and_then(|v| {
        c.within(
            v,
            &key,
            RESPONSE_RANGE,
            "",
            "a linear gain: the reference cameras use 1 to 300 DN per cd/m^2 per second",
        )
    })
}

/// Levels each checked: (`black-level-dn`, `full-scale-dn`,
/// `saturation-dn`); `None` when black is not below full scale.
type Levels = (Option<f64>, Option<f64>, Option<f64>);

/// `black-level-dn`, `full-scale-dn` (default `full_default`) and
/// `saturation-dn` (default 240/255 of full scale).
fn output_levels(
    c: &mut Checker<'_>,
    cam: &RawCamera,
    prefix: &str,
    full_default: f64,
) -> Option<Levels> {
    let k = |s: &str| format!("{prefix}.{s}");
    let black = c.non_negative(
        cam.black_level_dn.unwrap_or(0.0),
        &k("black-level-dn"),
        "DN for no light",
    );
    let full = c.within(
        cam.full_scale_dn.unwrap_or(full_default),
        &k("full-scale-dn"),
        FULL_SCALE_DN_RANGE,
        " DN",
        "255 for 8-bit output; at most 24 bits",
    );
    let sat_default = full.map(|f| f * 240.0 / 255.0).unwrap_or(240.0);
    let sat = c.positive(
        cam.saturation_dn.unwrap_or(sat_default),
        &k("saturation-dn"),
        "the P2020 reference code flags 240 of 255",
    );
    if let (Some(b), Some(f)) = (black, full)
        && b >= f
    {
        c.error(
            &k("black-level-dn"),
            format!("black level {b} is not below full scale {f}"),
            None,
        );
        return None;
    }
    Some((black, full, sat))
}
