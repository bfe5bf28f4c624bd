//! The metrics on numpy arrays: the library's own functions
//! ([`ledflicker::metrics`], [`ledflicker::analysis::light`]) on the
//! caller's buffer, read in place when it is contiguous float64. Every
//! array is checked first (type, 1-D, float64, finite, lengths), so that
//! a bad one raises a Python exception naming the argument.

use std::borrow::Cow;

use ledflicker::metrics::Metric;
use ledflicker::metrics::flicker::{self, Segment};
use ledflicker::metrics::p2020::{self, MmpReference, P2020Options};
use numpy::{
    PyArray1, PyArrayDescrMethods, PyArrayMethods, PyReadonlyArray1, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The codes of [`Segment`] in a segments array (uint8): the order of
/// `ledflicker.ON`, `OFF`, `PWM`.
pub const SEGMENT_CODES: [(u8, Segment); 3] =
    [(0, Segment::On), (1, Segment::Off), (2, Segment::Pwm)];

/// `obj` as a 1-D numpy array of `T`, or the exception that says why not.
fn array1<'py, T: numpy::Element>(
    name: &str,
    obj: &Bound<'py, PyAny>,
    kind: &str,
) -> PyResult<PyReadonlyArray1<'py, T>> {
    let py = obj.py();
    let Ok(arr) = obj.cast::<PyUntypedArray>() else {
        let given = obj.get_type().name()?;
        return Err(PyTypeError::new_err(format!(
            "{name} must be a 1-D numpy array of {kind}, got {given}"
        )));
    };
    if arr.ndim() != 1 {
        return Err(PyValueError::new_err(format!(
            "{name} must be a 1-D array, got {} dimensions (shape {:?})",
            arr.ndim(),
            arr.shape()
        )));
    }
    let dtype = arr.dtype();
    if !dtype.is_equiv_to(&numpy::dtype::<T>(py)) {
        return Err(PyTypeError::new_err(format!(
            "{name} must be of dtype {kind}, got {}\n    hint: convert it with numpy.asarray({name}, dtype=numpy.{kind})",
            dtype.str()?
        )));
    }
    Ok(arr.cast::<PyArray1<T>>()?.readonly())
}

/// The samples of a checked array: in place when contiguous, else copied.
fn values<'a, T: numpy::Element + Copy>(a: &'a PyReadonlyArray1<'_, T>) -> Cow<'a, [T]> {
    match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
    }
}

/// Refuses a non-finite sample, naming its index.
fn finite(name: &str, x: &[f64]) -> PyResult<()> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(PyValueError::new_err(format!(
            "{name}[{i}] is {}: every sample must be a finite number",
            x[i]
        ))),
        None => Ok(()),
    }
}

/// A float64 trace, checked.
pub fn trace<'py>(name: &str, obj: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArray1<'py, f64>> {
    let a = array1::<f64>(name, obj, "float64")?;
    finite(name, &values(&a))?;
    Ok(a)
}

/// The samples of `x` in a segment, with their segments: every sample
/// PWM when `segments` is `None`; a sample coded 255 (left out after a
/// step, as `segments()` marks it) is dropped.
fn selected<'a>(
    x: Cow<'a, [f64]>,
    segments: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Cow<'a, [f64]>, Vec<Segment>)> {
    let n = x.len();
    let Some(obj) = segments else {
        return Ok((x, vec![Segment::Pwm; n]));
    };
    let a = array1::<u8>("segments", obj, "uint8")?;
    let codes = values(&a);
    if codes.len() != n {
        return Err(PyValueError::new_err(format!(
            "segments has {} samples but luma has {n}: one segment per sample",
            codes.len()
        )));
    }
    let mut segs = Vec::with_capacity(n);
    for (i, &c) in codes.iter().enumerate() {
        match SEGMENT_CODES.iter().find(|(code, _)| *code == c) {
            Some((_, s)) => segs.push(*s),
            None if c == crate::simulate::LEFT_OUT => {}
            None => {
                return Err(PyValueError::new_err(format!(
                    "segments[{i}] is {c}: a segment is ledflicker.ON (0), OFF (1), PWM (2) or LEFT_OUT (255)"
                )));
            }
        }
    }
    if segs.len() == n {
        return Ok((x, segs));
    }
    let kept = x
        .iter()
        .zip(codes.iter())
        .filter(|(_, c)| **c != crate::simulate::LEFT_OUT)
        .map(|(v, _)| *v)
        .collect();
    Ok((Cow::Owned(kept), segs))
}

/// A metric as `(value, unbounded, reason)`.
type MetricTuple = (Option<f64>, bool, Option<String>);

fn tuple(m: Metric) -> MetricTuple {
    (m.value, m.unbounded, m.reason)
}

fn no_pwm() -> PyErr {
    PyValueError::new_err(
        "no PWM samples: the metrics read the PWM segment (segments == ledflicker.PWM)",
    )
}

/// Deegan 2018 FDI and Percent Flicker of one ROI trace, as
/// `(fdi_2018, percent_flicker)`, through [`flicker::evaluate_roi`].
#[pyfunction]
#[pyo3(signature = (luma, segments=None))]
pub fn flicker_2018(
    py: Python<'_>,
    luma: &Bound<'_, PyAny>,
    segments: Option<&Bound<'_, PyAny>>,
) -> PyResult<(MetricTuple, MetricTuple)> {
    let a = trace("luma", luma)?;
    let (x, segs) = selected(values(&a), segments)?;
    let m = py.detach(|| flicker::evaluate_roi(&x, &segs, None, f64::INFINITY));
    let m = m.ok_or_else(no_pwm)?;
    Ok((tuple(m.fdi_2018), tuple(m.percent_flicker)))
}

/// The IEEE P2020 KPIs of one ROI trace, through [`p2020::evaluate`]: a
/// dict of `fmi`, `fdi`, `mmp` (each `(value, unbounded, reason)`),
/// `x_off` and `x_ref`.
#[pyfunction]
#[pyo3(signature = (luma, segments=None, contrast_threshold=0.1, mmp_delta=0.1, mmp_reference="pwm-mean"))]
pub fn p2020_kpis<'py>(
    py: Python<'py>,
    luma: &Bound<'py, PyAny>,
    segments: Option<&Bound<'py, PyAny>>,
    contrast_threshold: f64,
    mmp_delta: f64,
    mmp_reference: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let mmp_reference = match mmp_reference {
        "pwm-mean" => MmpReference::PwmMean,
        "on-level" => MmpReference::OnLevel,
        other => {
            return Err(PyValueError::new_err(format!(
                "mmp_reference `{other}` is not `pwm-mean` or `on-level`"
            )));
        }
    };
    for (name, v) in [
        ("contrast_threshold", contrast_threshold),
        ("mmp_delta", mmp_delta),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} must be a finite number above 0, got {v}"
            )));
        }
    }
    let opts = P2020Options {
        contrast_threshold,
        mmp_delta,
        mmp_reference,
    };
    let a = trace("luma", luma)?;
    let (x, segs) = selected(values(&a), segments)?;
    let k = py.detach(|| p2020::evaluate(&x, &segs, &opts));
    let k = k.ok_or_else(no_pwm)?;
    let d = PyDict::new(py);
    d.set_item("fmi", tuple(k.fmi))?;
    d.set_item("fdi", tuple(k.fdi))?;
    d.set_item("mmp", tuple(k.mmp))?;
    d.set_item("x_off", k.x_off)?;
    d.set_item("x_ref", k.x_ref)?;
    Ok(d)
}

/// `ledflicker light --json`'s figures of the waveform `x` sampled at the
/// times `t` (seconds), as JSON text.
#[pyfunction]
#[pyo3(signature = (t, x, bandwidth_hz=Some(ledflicker::analysis::light::DEFAULT_BANDWIDTH_HZ), dark=0.0))]
pub fn light_json(
    py: Python<'_>,
    t: &Bound<'_, PyAny>,
    x: &Bound<'_, PyAny>,
    bandwidth_hz: Option<f64>,
    dark: f64,
) -> PyResult<String> {
    if let Some(b) = bandwidth_hz.filter(|b| !(b.is_finite() && *b > 0.0)) {
        return Err(PyValueError::new_err(format!(
            "bandwidth_hz {b} is not a band limit; give a frequency in Hz above 0, or None for the raw samples"
        )));
    }
    if !dark.is_finite() {
        return Err(PyValueError::new_err(format!(
            "dark {dark} is not a level; give the detector's dark reading in the samples' unit"
        )));
    }
    let (ta, xa) = (trace("t", t)?, trace("x", x)?);
    let (times, levels) = (values(&ta), values(&xa));
    if times.len() != levels.len() {
        return Err(PyValueError::new_err(format!(
            "t has {} samples but x has {}: one time per level",
            times.len(),
            levels.len()
        )));
    }
    let figures = py.detach(|| light(&times, &levels, bandwidth_hz, dark));
    figures.map_err(|f| crate::errors::to_py(py, f))
}

fn light(
    times: &[f64],
    levels: &[f64],
    bandwidth_hz: Option<f64>,
    dark: f64,
) -> Result<String, ledflicker::cli::Failure> {
    use ledflicker::analysis::light as l;
    // The caller's samples in place, unless a dark level is taken off.
    let levels: Cow<[f64]> = if dark == 0.0 {
        Cow::Borrowed(levels)
    } else {
        Cow::Owned(levels.iter().map(|x| x - dark).collect())
    };
    let rate_hz = ledflicker::capture::sample_rate(times, &levels, "the arrays t, x".as_ref())
        .map_err(|e| {
            ledflicker::cli::Failure::Frames(ledflicker::calibrate::frames::FrameError::Capture(e))
        })?;
    if levels.iter().sum::<f64>() <= 0.0 {
        return Err(ledflicker::error::UsageError(
            "x: the levels average 0 or less, no light to analyse\n    hint: x holds the light's level, 0 for dark".to_string(),
        )
        .into());
    }
    let figures = l::analyse(&levels, rate_hz, &l::LightOptions { bandwidth_hz });
    let mut json = serde_json::to_value(&figures)?;
    if let Some(o) = json.as_object_mut() {
        o.insert("format".into(), l::FORMAT.into());
    }
    Ok(serde_json::to_string(&json)?)
}

/// Median seconds of `reps` calls of the Rust function behind `kind`
/// (`"percent_flicker"`: [`flicker::evaluate_roi`] on an all-PWM trace;
/// `"light"`: [`ledflicker::analysis::light::analyse`]) on Rust-owned
/// copies of the arrays, inputs prepared outside the timing: the
/// reference of the package's benchmark (python/bench/bench_metrics.py).
#[pyfunction]
pub fn rust_call_seconds(
    py: Python<'_>,
    kind: &str,
    t: &Bound<'_, PyAny>,
    x: &Bound<'_, PyAny>,
    reps: usize,
) -> PyResult<f64> {
    use ledflicker::analysis::light as l;
    let (ta, xa) = (trace("t", t)?, trace("x", x)?);
    let (times, levels) = (ta.as_array().to_vec(), xa.as_array().to_vec());
    // The rate exactly as `light` reads it.
    let rate_hz = ledflicker::capture::sample_rate(&times, &levels, "x".as_ref())
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let segs = vec![Segment::Pwm; levels.len()];
    let call: Box<dyn Fn() + Send + Sync> = match kind {
        "percent_flicker" => Box::new(|| {
            std::hint::black_box(flicker::evaluate_roi(
                std::hint::black_box(&levels),
                &segs,
                None,
                f64::INFINITY,
            ));
        }),
        "light" => Box::new(|| {
            std::hint::black_box(l::analyse(
                std::hint::black_box(&levels),
                rate_hz,
                &l::LightOptions::default(),
            ));
        }),
        other => {
            return Err(PyValueError::new_err(format!(
                "kind `{other}` is not `percent_flicker` or `light`"
            )));
        }
    };
    let mut seconds: Vec<f64> = py.detach(|| {
        (0..reps.max(1))
            .map(|_| {
                let start = std::time::Instant::now();
                call();
                start.elapsed().as_secs_f64()
            })
            .collect()
    });
    seconds.sort_by(f64::total_cmp);
    Ok(seconds[seconds.len() / 2])
}
