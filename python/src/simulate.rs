//! The ideal camera (`simulate`) and segment detection (`segments`) on
//! arrays.

use ledflicker::backend::segments::{Detection, detect};
use ledflicker::capture::CaptureTrace;
use ledflicker::cli::{CameraArgs, PwmArgs, ShutterArg};
use ledflicker::plan::Sequence;
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays::{SEGMENT_CODES, trace};
use crate::errors;

/// The code of a frame in no segment (left out after a step).
pub const LEFT_OUT: u8 = 255;

/// Frame start times (s) and ON fractions, one entry per frame.
type Trace<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// The ideal camera's frames for one PWM condition, as `ledflicker
/// simulate` prints them: `(time_s, on_fraction)` arrays.
#[pyfunction]
#[pyo3(signature = (frequency_hz, duty, exposure_ms, fps, frames=30, shutter="global", line_time_us=0.0, pwm_delay_ms=0.0, rows=(0, 1)))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    frequency_hz: f64,
    duty: f64,
    exposure_ms: f64,
    fps: f64,
    frames: u64,
    shutter: &str,
    line_time_us: f64,
    pwm_delay_ms: f64,
    rows: (u32, u32),
) -> PyResult<Trace<'py>> {
    let shutter = match shutter {
        "global" => ShutterArg::Global,
        "rolling" => ShutterArg::Rolling,
        other => {
            return Err(errors::usage(
                py,
                format!("shutter `{other}` is not `global` or `rolling`"),
            ));
        }
    };
    if rows.0 >= rows.1 {
        return Err(errors::usage(
            py,
            format!("rows {rows:?} is not (A, B) with A < B (A inclusive, B exclusive)"),
        ));
    }
    // `--duty` as the command line reads it: a share in (0, 1].
    if !(duty > 0.0 && duty <= 1.0) {
        return Err(errors::usage(
            py,
            format!("duty {duty} is not a share of the period in (0, 1]"),
        ));
    }
    let pwm = PwmArgs {
        frequency_hz,
        duty,
        pwm_delay_ms,
    };
    let camera = CameraArgs {
        exposure_ms,
        fps,
        shutter,
        line_time_us,
    };
    let simulated =
        py.detach(|| ledflicker::cli::simulate::on_fractions(pwm, camera, frames, rows.0..rows.1));
    let frames = simulated.map_err(|f| errors::to_py(py, f))?;
    let (t, s): (Vec<f64>, Vec<f64>) = frames.into_iter().unzip();
    Ok((PyArray1::from_vec(py, t), PyArray1::from_vec(py, s)))
}

/// The ON, OFF and PWM segments of a recorded trace, found as a captured
/// plan finds them: a uint8 array of one code per frame (ON, OFF, PWM, or
/// 255 for a frame left out after a step) and what was found, as JSON text
/// (the frames and times of each segment, the levels, the rule).
#[pyfunction]
#[pyo3(signature = (t, luma, on_s=2.0, off_s=2.0, pwm_s=60.0, settle_s=ledflicker::backend::segments::DEFAULT_SETTLE_S, full_scale_dn=255.0))]
#[allow(clippy::too_many_arguments)]
pub fn detect_segments<'py>(
    py: Python<'py>,
    t: &Bound<'py, PyAny>,
    luma: &Bound<'py, PyAny>,
    on_s: f64,
    off_s: f64,
    pwm_s: f64,
    settle_s: f64,
    full_scale_dn: f64,
) -> PyResult<(Bound<'py, PyArray1<u8>>, String)> {
    for (name, v) in [("on_s", on_s), ("off_s", off_s), ("settle_s", settle_s)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} must be >= 0, got {v}"
            )));
        }
    }
    for (name, v) in [("pwm_s", pwm_s), ("full_scale_dn", full_scale_dn)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} must be > 0, got {v}"
            )));
        }
    }
    let (ta, la) = (trace("t", t)?, trace("luma", luma)?);
    let (times, levels) = (ta.as_array().to_vec(), la.as_array().to_vec());
    if times.len() != levels.len() {
        return Err(PyValueError::new_err(format!(
            "t has {} frames but luma has {}: one time per frame",
            times.len(),
            levels.len()
        )));
    }
    if let Some(i) = (1..times.len()).find(|&i| times[i] <= times[i - 1]) {
        return Err(PyValueError::new_err(format!(
            "t[{i}] = {} is not after t[{}] = {}: frame times must increase",
            times[i],
            i - 1,
            times[i - 1]
        )));
    }
    let n = times.len();
    let capture = CaptureTrace {
        time_s: times,
        luma: vec![levels],
        rgb: None,
        full_scale_dn,
        frame_size: (1, 1),
        timestamps: ledflicker::trace::TimestampSource::Csv,
        format: "array".to_string(),
        time_base_s: None,
        stated_fps: None,
        video: None,
    };
    let det = Detection {
        sequence: Sequence { on_s, off_s, pwm_s },
        settle_s,
        led_rois: Vec::new(),
    };
    let found = py.detach(|| detect(&capture, &det, "the arrays t, luma".as_ref()));
    let found = found.map_err(|e| {
        errors::to_py(
            py,
            ledflicker::cli::Failure::Frames(ledflicker::calibrate::frames::FrameError::Capture(e)),
        )
    })?;
    let mut codes = vec![LEFT_OUT; n];
    for (range, segment) in [(found.on, 0), (found.off, 1), (Some(found.pwm), 2)] {
        if let Some((a, b)) = range {
            let code = SEGMENT_CODES[segment].0;
            for c in codes.iter_mut().take(b as usize).skip(a as usize) {
                *c = code;
            }
        }
    }
    let json = serde_json::to_string(&found)
        .map_err(|e| errors::to_py(py, ledflicker::cli::Failure::Json(e)))?;
    Ok((PyArray1::from_vec(py, codes), json))
}
