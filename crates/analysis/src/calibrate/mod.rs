//! Camera calibration from real banding frames: `ledflicker linetime`,
//! `bands` and `calibrate` (docs/calibration.md).
//!
//! Pipeline: [`frames`] reads frames (PNG, TIFF, JPEG, or a video through
//! the capture readers) into strip row profiles; [`bands`] estimates the
//! band period with an uncertainty, or refuses with a reason; [`fit`] fits
//! the rolling-shutter camera model (line time, exposure, duty, black
//! level, saturation, tone curve) to the row profiles; [`profile`] writes
//! the fitted camera as a profile of `reference-data/cameras/` and closes
//! the loop by letting the simulator render the same scene with it.

pub mod bands;
pub mod fit;
pub mod frames;
mod gram;
mod harmonics;
mod linalg;
pub mod profile;
pub mod recovery;
pub mod synth;
pub mod uncertainty;

use serde::Serialize;

use bands::{BandEstimate, NoConfidence};
use fit::{ModelFit, ModelParams, idx};
use frames::FrameSet;

/// Band estimate of a frame set: on the texture-divided profiles when
/// there are several frames and they still show bands (bands locked to the
/// frame rate divide out), else on the raw ones. The flag says which.
pub fn estimate_bands(set: &FrameSet) -> Result<(BandEstimate, bool), NoConfidence> {
    let layout = set.layout();
    if let Some(flat) = set.flattened() {
        match bands::estimate(&flat, &layout) {
            Ok(e) => return Ok((e, true)),
            Err(NoConfidence::NoBanding { .. } | NoConfidence::Flat { .. }) => {}
            Err(e) => return Err(e),
        }
    }
    bands::estimate(&set.raw, &layout).map(|e| (e, false))
}

/// What `calibrate` knows about the light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// PWM frequency, Hz (> 0).
    pub frequency_hz: f64,
    /// One-sigma uncertainty of the frequency, Hz (0: exact). It carries
    /// into the line time and the exposure, which scale as `1 / f`.
    pub frequency_sigma_hz: f64,
    /// Duty cycle in (0, 1) when known; fitted when `None`.
    pub duty: Option<f64>,
}

/// The fitted camera. Each fitted parameter has a `_sigma` (one sigma);
/// one the frames cannot determine is `None` with a bound beside it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    /// PWM frequency of the light, Hz.
    pub frequency_hz: f64,
    /// Frames fitted.
    pub frames: usize,
    /// Rows of the analysed area.
    pub rows: usize,
    /// Analysed area `[x, y, width, height]`, pixels.
    pub roi: [u32; 4],
    /// Band period from the band estimator, rows.
    pub band_period_rows: f64,
    /// Its sigma, rows.
    pub band_period_rows_sigma: f64,
    /// Band estimator's quality figure (0..1).
    pub band_quality: f64,
    /// Texture was divided out (several frames).
    pub texture_divided: bool,
    /// Column groups the band estimate left out, with their own period
    /// (`null`: no banding), left to right.
    pub dropped_columns: Vec<bands::ColumnGroup>,
    /// Periods of the codec's 8- and 16-row block grid were suppressed
    /// (JPEG or video input).
    pub block_grid_suppressed: bool,
    /// Line time, microseconds.
    pub line_time_us: f64,
    /// Its sigma, microseconds.
    pub line_time_us_sigma: f64,
    /// Exposure, microseconds; `None` when shorter than a row.
    pub exposure_us: Option<f64>,
    /// Its sigma.
    pub exposure_us_sigma: Option<f64>,
    /// Upper bound when the exposure is undetermined, microseconds.
    pub exposure_us_max: Option<f64>,
    /// Lower bound when the exposure is undetermined, microseconds: set
    /// when clipped rows leave only `duty + exposure` determined.
    pub exposure_us_min: Option<f64>,
    /// Duty cycle (given or fitted); `None` when clipped rows leave it
    /// undetermined, with `duty_min..=duty_max` beside it.
    pub duty: Option<f64>,
    /// Its sigma (0 when given).
    pub duty_sigma: Option<f64>,
    /// Lower bound when the duty is undetermined.
    pub duty_min: Option<f64>,
    /// Upper bound when the duty is undetermined.
    pub duty_max: Option<f64>,
    /// The two (duty, exposure) pairs that fit the frames equally well
    /// when neither can be told from the other (see [`mirror`]): empty
    /// when `duty` and `exposure_us` are values or bounds. `duty` and
    /// `exposure_us` are then `None`.
    pub solutions: Vec<Solution>,
    /// Duty of the fitted model (one member of the family when the duty is
    /// undetermined), used for the closed loop.
    #[serde(skip)]
    pub model_duty: f64,
    /// Tone curve `y = u^(1/gamma)`: gamma.
    pub gamma: f64,
    /// Its sigma.
    pub gamma_sigma: f64,
    /// Black level, DN; `None` when the frames only bound it (e.g. a linear
    /// response, where black level and ambient light trade off exactly).
    pub black_level_dn: Option<f64>,
    /// Its sigma, DN.
    pub black_level_dn_sigma: Option<f64>,
    /// Upper bound when undetermined: the dark level, DN (the bound is
    /// `0 <= black <= dark`).
    pub black_level_dn_max: Option<f64>,
    /// Black level of the fitted model, DN, written to the profile (with
    /// the matching ambient level it reproduces the dark level).
    #[serde(skip)]
    pub model_black_dn: f64,
    /// Clipping level, DN; `None` when no row clipped.
    pub saturation_dn: Option<f64>,
    /// Its sigma, DN.
    pub saturation_dn_sigma: Option<f64>,
    /// Lower bound when no row clipped: the brightest row, DN.
    pub saturation_dn_min: Option<f64>,
    /// What the bands' flat tops are, `None` when they have none.
    pub flat_top: Option<FlatTop>,
    /// Linear level of the light at full ON, fraction of white (scene).
    pub led_level: f64,
    /// Its sigma.
    pub led_level_sigma: f64,
    /// Linear level with the light OFF (ambient), fraction of white (scene).
    pub ambient_level: f64,
    /// Its sigma.
    pub ambient_level_sigma: f64,
    /// Illumination falloff over the rows, `g = 1 + v1 t + v2 t^2` (scene).
    pub shading: [f64; 2],
    /// PWM phase at the first analysed row of frame 0, cycles.
    pub phase_cycles: f64,
    /// Output full scale, DN.
    pub full_scale_dn: f64,
    /// RMS of the measured minus the fitted row profile, fraction of full scale.
    pub fit_rms: f64,
    /// RMS of the measured minus the simulator's prediction from the fitted
    /// profile (frame 0), fraction of full scale; set by [`profile::closed_loop`].
    pub profile_rms: Option<f64>,
    /// The files read, with SHA-256.
    pub sources: Vec<frames::Source>,
    /// Frame size, pixels.
    pub frame_size: (u32, u32),
    /// Measured row profile of frame 0, DN.
    #[serde(skip)]
    pub measured: Vec<f64>,
}

/// Fits the camera model to the frames. Errors only when the bands give no
/// confident period.
pub fn calibrate(set: &FrameSet, light: Light) -> Result<Calibration, NoConfidence> {
    let (band, texture_divided) = estimate_bands(set)?;
    let data = set.profiles();
    let a = set.full_scale_dn;
    let top = flat_top(&data, a);
    let clip = match top {
        Some((FlatTop::Clipped, level)) => level,
        _ => a,
    };
    let mut fixed = vec![false; idx::PHASE0 + data.len()];
    fixed[idx::DUTY] = light.duty.is_some();
    let mut best: Option<ModelFit> = None;
    for gamma in [1.0, 2.2] {
        for exposure_rows in [1.5, 5.0, 15.0] {
            let start = initial(&data, &band, a, clip, gamma, exposure_rows, light.duty);
            let f = fit::fit(&data, &start, &fixed, 200);
            if best.as_ref().is_none_or(|b| f.rms < b.rms) {
                best = Some(f);
            }
        }
    }
    // Polish the best from a fresh damping: LM can stall on the corners of
    // the piecewise-linear ON fraction.
    let best = best.map(|b| {
        let again = fit::fit(&data, &b.params, &fixed, 200);
        if again.rms < b.rms { again } else { b }
    });
    let Some(fit) = best else {
        return Err(NoConfidence::NoBanding {
            quality: 0.0,
            period_rows: band.period_rows,
        });
    };
    let inflation = uncertainty::inflation(&data, fit.params.values[idx::PERIOD]);
    let (mut fit, ends) = uncertainty::black_ends(&data, fit, &fixed);
    fit.sigma = uncertainty::honest_sigmas(&data, &fit, &fixed, inflation);
    let black = uncertainty::black_level(&data, &fit, &ends, &fixed, inflation);
    Ok(summarise(
        set,
        light,
        &band,
        texture_divided,
        &fit,
        black,
        top,
        &data,
    ))
}

/// The fitted profile could not be written or simulated back.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// Writing the profile file failed.
    #[error("cannot write `{}`: {error}", path.display())]
    Write {
        /// The profile file.
        path: std::path::PathBuf,
        /// Why (in the message, not a source: said once).
        error: std::io::Error,
    },
    /// The simulator could not render the scene with the profile.
    #[error("closed loop failed: {0}")]
    ClosedLoop(String),
}

/// Writes `cal`'s camera profile to `out` (else to a temporary file, removed
/// after), closes the loop (the simulator renders the same scene with the
/// profile) and stores its `profile_rms`.
pub fn write_profile(
    cal: &mut Calibration,
    opts: &profile::ProfileOptions,
    out: Option<&std::path::Path>,
) -> Result<(), ProfileError> {
    let text = profile::profile_toml(cal, opts);
    let (path, temporary) = match out {
        Some(p) => (p.to_path_buf(), false),
        None => (
            std::env::temp_dir().join(format!("ledflicker-calibrate-{}.toml", std::process::id())),
            true,
        ),
    };
    ledflicker_plan::util::write_atomic(&path, text.as_bytes()).map_err(|error| {
        ProfileError::Write {
            path: path.clone(),
            error,
        }
    })?;
    let fps_used = profile::frame_rate(cal, opts);
    let looped = profile::closed_loop(cal, &path, fps_used);
    if temporary {
        let _ = std::fs::remove_file(&path);
    }
    let (_, rms) = looped.map_err(ProfileError::ClosedLoop)?;
    cal.profile_rms = Some(rms);
    Ok(())
}

/// Share of the brightest samples' level within which samples count as
/// the flat top, of full scale.
const FLAT_TOP_WIDTH: f64 = 0.003;
/// Share of all samples that must lie on the flat top.
const FLAT_TOP_SHARE: f64 = 0.03;
/// A flat top within this share of a full scale sits at it.
const FULL_SCALE_MARGIN: f64 = 0.01;

/// What the flat tops of the bands are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FlatTop {
    /// The rows clip: the tops sit at the file's or the sensor's full scale.
    Clipped,
    /// The exposure window fits inside the ON time: every window inside an
    /// ON interval collects the same light, below full scale.
    Plateau,
}

/// The bands' flat top and its level (DN), `None` when they have none: at
/// least [`FLAT_TOP_SHARE`] of the samples within [`FLAT_TOP_WIDTH`] of
/// full scale of the brightest. It is clipping only at a full scale
/// ([`at_full_scale`]). A flat top lower down is the exposure's plateau:
/// a brighter light clipped there would fit exactly as well (with a wider
/// exposure and a smaller duty, docs/calibration.md), but cameras clip at
/// the top of their output, so the model's own plateau, which gives
/// values, is the explanation taken.
fn flat_top(data: &[Vec<f64>], a: f64) -> Option<(FlatTop, f64)> {
    let vmax = data
        .iter()
        .flatten()
        .fold(f64::NEG_INFINITY, |m, &v| m.max(v));
    let total = data.iter().map(Vec::len).sum::<usize>().max(1);
    let near = data
        .iter()
        .flatten()
        .filter(|&&v| v >= vmax - FLAT_TOP_WIDTH * a)
        .count();
    if (near as f64) < FLAT_TOP_SHARE * total as f64 {
        return None;
    }
    let kind = if at_full_scale(vmax, a) {
        FlatTop::Clipped
    } else {
        FlatTop::Plateau
    };
    Some((kind, vmax))
}

/// Whether `level` (DN) sits at a full scale: the file's (`a`), or, in a
/// 16-bit file, a sensor's of 8 to 15 bits stored unshifted (`2^k - 1`),
/// within [`FULL_SCALE_MARGIN`] of it. A sensor's full scale shifted to the
/// top of the 16 bits is within the margin of the file's.
fn at_full_scale(level: f64, a: f64) -> bool {
    let near = |full: f64| level >= full * (1.0 - FULL_SCALE_MARGIN) && level <= full;
    near(a) || (a > 255.0 && (8..16).map(|k| f64::from((1u32 << k) - 1)).any(near))
}

/// Start values: levels from percentiles, duty from the share of bright
/// rows, phase from the fundamental's phase.
fn initial(
    data: &[Vec<f64>],
    band: &BandEstimate,
    a: f64,
    clip: f64,
    gamma: f64,
    exposure_rows: f64,
    duty: Option<f64>,
) -> ModelParams {
    let p = band.period_rows;
    let mut all: Vec<f64> = data.iter().flatten().copied().collect();
    all.sort_by(f64::total_cmp);
    let pct = |q: f64| all[((all.len() - 1) as f64 * q) as usize];
    let (lo, hi) = (pct(0.02), pct(0.98));
    let mid = 0.5 * (lo + hi);
    let d = duty.unwrap_or_else(|| {
        (all.iter().filter(|&&v| v > mid).count() as f64 / all.len() as f64).clamp(0.05, 0.95)
    });
    let e = (exposure_rows / p).min(0.9);
    let c1 = ((hi - lo).max(1e-9) / a).powf(gamma).max(1e-6);
    let mut values = vec![0.0; idx::PHASE0 + data.len()];
    values[idx::PERIOD] = p;
    values[idx::EXPOSURE] = e;
    values[idx::DUTY] = d;
    values[idx::BLACK] = lo;
    values[idx::C0] = 0.0;
    values[idx::C1] = c1;
    values[idx::GAMMA] = gamma;
    for (j, y) in data.iter().enumerate() {
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let (mut c, mut s) = (0.0, 0.0);
        for (r, v) in y.iter().enumerate() {
            let (sn, cs) = (2.0 * std::f64::consts::PI * r as f64 / p).sin_cos();
            c += (v - mean) * cs;
            s += (v - mean) * sn;
        }
        // The fundamental peaks at row r* = psi P / 2 pi, where the window
        // centre phi + r/P + e/2 sits on the pulse centre D/2.
        let r_peak = s.atan2(c) / (2.0 * std::f64::consts::PI) * p;
        values[idx::PHASE0 + j] =
            ledflicker_physics::pwm::wrap_unit(0.5 * d - 0.5 * e - r_peak / p);
    }
    ModelParams {
        values,
        full_scale: a,
        clip,
    }
}

/// Turns the fit into reported values, bounds for what is undetermined.
#[allow(clippy::too_many_arguments)]
fn summarise(
    set: &FrameSet,
    light: Light,
    band: &BandEstimate,
    texture_divided: bool,
    fit: &ModelFit,
    black: uncertainty::BlackLevel,
    top: Option<(FlatTop, f64)>,
    data: &[Vec<f64>],
) -> Calibration {
    let saturated = matches!(top, Some((FlatTop::Clipped, _)));
    let v = &fit.params.values;
    let s = &fit.sigma;
    let f = light.frequency_hz;
    let a = set.full_scale_dn;
    let p = v[idx::PERIOD];
    let rel_f = light.frequency_sigma_hz / f;
    let rel_p = (s[idx::PERIOD] / p).max(band.period_sigma_rows / band.period_rows);
    let rel_t = rel_p.hypot(rel_f);
    let line_time = 1.0 / (f * p);
    let exposure_s = v[idx::EXPOSURE] / f;
    let exposure_sigma = exposure_s * (s[idx::EXPOSURE] / v[idx::EXPOSURE]).hypot(rel_f);
    let exposure_rows = v[idx::EXPOSURE] * p;
    let traded = (saturated && light.duty.is_none())
        .then(|| traded_bounds(&fit.params, data.first().map_or(0, Vec::len)))
        .flatten();
    let determined = traded.is_none() && exposure_rows >= 1.0 && exposure_sigma < 0.5 * exposure_s;
    let vmax = data
        .iter()
        .flatten()
        .fold(f64::NEG_INFINITY, |m, &x| m.max(x));
    let (member, c1_scale) = written_member(v, traded);
    let (e, d) = (v[idx::EXPOSURE], v[idx::DUTY]);
    // The complements need the ambient light `c0 + c1 (e + D - 1) / e`.
    let complement_ok = v[idx::C0] + v[idx::C1] * (e + d - 1.0) / e >= 0.0;
    let found = if traded.is_none() && determined {
        readings(
            (d, s[idx::DUTY]),
            (e, exposure_sigma * f),
            complement_ok,
            light.duty.is_some(),
        )
    } else {
        Vec::new()
    };
    let solutions: Vec<Solution> = found
        .iter()
        .map(|&(duty, duty_sigma, e, e_sigma)| Solution {
            duty,
            duty_sigma,
            exposure_us: e / f * 1e6,
            exposure_us_sigma: e_sigma / f * 1e6,
        })
        .collect();
    let chosen = solutions.is_empty();
    Calibration {
        frequency_hz: f,
        frames: data.len(),
        rows: data.first().map_or(0, Vec::len),
        roi: [set.roi.x, set.roi.y, set.roi.width, set.roi.height],
        band_period_rows: band.period_rows,
        band_period_rows_sigma: band.period_sigma_rows,
        band_quality: band.quality,
        texture_divided,
        dropped_columns: band.dropped.clone(),
        block_grid_suppressed: band.block_grid_suppressed,
        line_time_us: line_time * 1e6,
        line_time_us_sigma: line_time * rel_t * 1e6,
        exposure_us: (determined && chosen).then_some(exposure_s * 1e6),
        exposure_us_sigma: (determined && chosen).then_some(exposure_sigma * 1e6),
        exposure_us_max: match traded {
            Some((_, hi)) => Some(hi / f * 1e6),
            None => (!determined).then(|| (exposure_s + 2.0 * exposure_sigma).max(line_time) * 1e6),
        },
        exposure_us_min: traded.map(|(lo, _)| lo / f * 1e6),
        duty: (traded.is_none() && chosen).then_some(v[idx::DUTY]),
        duty_sigma: (traded.is_none() && chosen).then_some(s[idx::DUTY]),
        solutions,
        duty_min: traded.map(|(lo, _)| lo),
        duty_max: traded.map(|(_, hi)| hi.min(1.0)),
        model_duty: member[idx::DUTY],
        gamma: v[idx::GAMMA],
        gamma_sigma: s[idx::GAMMA],
        black_level_dn: black.value,
        black_level_dn_sigma: black.sigma,
        black_level_dn_max: black.max,
        model_black_dn: v[idx::BLACK].max(0.0),
        saturation_dn: saturated.then_some(fit.params.clip),
        saturation_dn_sigma: saturated.then_some(0.003 * a),
        saturation_dn_min: (!saturated).then_some(vmax),
        flat_top: top.map(|(kind, _)| kind),
        led_level: member[idx::C1],
        led_level_sigma: s[idx::C1] * c1_scale,
        ambient_level: v[idx::C0].max(0.0),
        ambient_level_sigma: s[idx::C0],
        shading: [v[idx::V1], v[idx::V2]],
        phase_cycles: member[idx::PHASE0],
        full_scale_dn: a,
        fit_rms: fit.rms / a,
        profile_rms: None,
        sources: set.sources.clone(),
        frame_size: set.frame_size,
        measured: data.first().cloned().unwrap_or_default(),
    }
}

/// One of two readings of the same frames: a duty and an exposure.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Solution {
    /// Duty cycle.
    pub duty: f64,
    /// Its sigma.
    pub duty_sigma: f64,
    /// Exposure, microseconds.
    pub exposure_us: f64,
    /// Its sigma.
    pub exposure_us_sigma: f64,
}

/// The readings `(duty, sigma, exposure, sigma)` (exposure in PWM cycles)
/// that render the frames alike with the fitted duty `d` and exposure `e`
/// (values with sigmas); empty when there is only the fit. A row collects
/// the ON square wave (duty `D`) convolved with the exposure window (`e`
/// cycles), and:
///
/// - the **mirror** `(D' = e, e' = D)`, with the LED level `c1 D / e` and
///   each phase moved by `e - D`, renders every row the same, exactly;
/// - the **complements** `(1 - D, 1 - e)` and `(1 - e, 1 - D)` do too
///   with flat illumination, given the ambient light `c0 + c1 (e + D - 1)
///   / e`: they are readings when that is not negative (`complement_ok`).
///
/// A known duty (`duty_given`) keeps the readings of that duty only: the
/// complement `(D, 1 - e)` at `D = 0.5`. Readings outside (0, 1), and any
/// within 2 combined sigmas of an earlier one (the same camera), are left
/// out. An exposure of a cycle or more has no such readings here.
pub fn readings(
    d: (f64, f64),
    e: (f64, f64),
    complement_ok: bool,
    duty_given: bool,
) -> Vec<(f64, f64, f64, f64)> {
    if e.0 >= 1.0 {
        return Vec::new();
    }
    let mut all = vec![(d.0, d.1, e.0, e.1)];
    if !duty_given {
        all.push((e.0, e.1, d.0, d.1));
    }
    if complement_ok {
        all.push((1.0 - d.0, d.1, 1.0 - e.0, e.1));
        if !duty_given {
            all.push((1.0 - e.0, e.1, 1.0 - d.0, d.1));
        }
    }
    let mut out: Vec<(f64, f64, f64, f64)> = Vec::new();
    for r in all {
        let inside = [r.0, r.2].iter().all(|v| *v > 0.0 && *v < 1.0);
        let same_duty = !duty_given || (r.0 - d.0).abs() <= 1e-9;
        let new = out.iter().all(|o| {
            (o.0 - r.0).abs() > 2.0 * o.1.hypot(r.1) || (o.2 - r.2).abs() > 2.0 * o.3.hypot(r.3)
        });
        if inside && same_duty && new {
            out.push(r);
        }
    }
    if out.len() < 2 {
        out.clear();
    }
    out
}

/// The member of the fit's family that the profile holds, and the factor
/// its LED level has over the fit's. Without `traded` bounds it is the fit.
/// With them it is the member at the exposure's upper bound `e' = hi`
/// (the profile's exposure): duty `lo = D + e - e'`, the same rising slope
/// `c1' / e' = c1 / e`, and each phase moved by `e - e'`, so that the rising
/// ramp starts on the same row (its window's end enters the pulse there)
/// and the falling one ends on the same row (its start leaves it there).
fn written_member(v: &[f64], traded: Option<(f64, f64)>) -> (Vec<f64>, f64) {
    let mut m = v.to_vec();
    let Some((lo, hi)) = traded else {
        return (m, 1.0);
    };
    let e = v[idx::EXPOSURE];
    let scale = hi / e;
    m[idx::EXPOSURE] = hi;
    m[idx::DUTY] = lo;
    m[idx::C1] *= scale;
    for phase in &mut m[idx::PHASE0..] {
        *phase = ledflicker_physics::pwm::wrap_unit(*phase + e - hi);
    }
    (m, scale)
}

/// Bounds, in PWM cycles, on the duty `D` and the exposure `e` when rows
/// clip and the duty is not given (docs/calibration.md, "Saturation").
/// The frames fix the rising slope of the linear level, `k = c1 / e`, and
/// the base width of a band, `D + e`; the family `c1 / e = k`,
/// `D + e = sum` fits them all equally, as long as its peak,
/// `c0 + k g min(D, e)`, is hidden above the clipping level `u_S`. So
/// `min(D, e) >= m = (u_S - c0) / (k g_max)` and both lie in
/// `[m, sum - m]`. `None` when the fit is not of that kind (no room
/// between the bounds).
fn traded_bounds(params: &ModelParams, rows: usize) -> Option<(f64, f64)> {
    let v = &params.values;
    let (e, d) = (v[idx::EXPOSURE], v[idx::DUTY]);
    let sum = d + e;
    let k = v[idx::C1] / e.max(1e-12);
    let black = v[idx::BLACK].max(0.0);
    let u_s = ((params.clip - black) / params.full_scale)
        .clamp(0.0, 1.0)
        .powf(v[idx::GAMMA]);
    let g_max = [0, rows / 2, rows.saturating_sub(1)]
        .into_iter()
        .map(|r| fit::shading(v, r, rows.max(2)))
        .chain(vertex_shading(v))
        .fold(f64::MIN_POSITIVE, f64::max);
    let m = ((u_s - v[idx::C0].max(0.0)) / (k * g_max)).max(0.0);
    (k.is_finite() && m.is_finite() && sum - m > m).then_some((m, sum - m))
}

/// The falloff at its extremum inside the rows, if it has one there.
fn vertex_shading(v: &[f64]) -> Option<f64> {
    let (v1, v2) = (v[idx::V1], v[idx::V2]);
    let t = -v1 / (2.0 * v2);
    (v2 != 0.0 && t.abs() <= 1.0).then_some(1.0 + v1 * t + v2 * t * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::synth::SynthFrame;

    /// A trapezoid of 40-row periods from 10 DN up to `top` DN, flat on
    /// a quarter of its rows.
    fn trapezoid(top: f64) -> Vec<Vec<f64>> {
        let ramp = |x: f64| 10.0 + (top - 10.0) * x;
        let row = |r: usize| match r % 40 {
            k @ 0..10 => ramp(k as f64 / 10.0),
            10..20 => top,
            k @ 20..30 => ramp(1.0 - (k - 20) as f64 / 10.0),
            _ => 10.0,
        };
        vec![(0..400).map(row).collect()]
    }

    #[test]
    fn a_flat_top_is_clipping_only_at_a_full_scale() {
        let kind = |a: f64, top: f64| flat_top(&trapezoid(top), a).map(|(k, _)| k);
        let (clipped, plateau) = (Some(FlatTop::Clipped), Some(FlatTop::Plateau));
        // The file's full scale, and 1 % below it.
        assert_eq!(kind(255.0, 255.0), clipped);
        assert_eq!(kind(255.0, 253.0), clipped);
        assert_eq!(kind(65535.0, 65520.0), clipped);
        // A 12-bit sensor's codes stored as they are in a 16-bit file.
        assert_eq!(kind(65535.0, 4095.0), clipped);
        // Lower down: the exposure's plateau, even in the top tenth.
        assert_eq!(kind(255.0, 235.0), plateau);
        assert_eq!(kind(65535.0, 4000.0), plateau);
        assert_eq!(kind(65535.0, 60000.0), plateau);
        // A triangle has no flat top.
        let triangle = vec![(0..400).map(|r| (r % 40).min(40 - r % 40) as f64).collect()];
        assert_eq!(flat_top(&triangle, 255.0), None);
    }

    #[test]
    fn a_frequency_uncertainty_carries_into_line_time_and_exposure() {
        let dir =
            std::env::temp_dir().join(format!("ledflicker-cal-fsigma-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("frame.png");
        SynthFrame::base().save(&path, 90).unwrap();
        let set = frames::load(&[path], None, None).unwrap();
        let run = |sigma_hz| {
            let light = Light {
                frequency_hz: 1000.0,
                frequency_sigma_hz: sigma_hz,
                duty: None,
            };
            calibrate(&set, light).unwrap()
        };
        let (exact, loose) = (run(0.0), run(5.0));
        let _ = std::fs::remove_dir_all(&dir);
        // 5 Hz of 1000 is 0.5 %, added in quadrature to the frame's sigma.
        let want = |s0: f64, v: f64| s0.hypot(0.005 * v);
        let lt = want(exact.line_time_us_sigma, exact.line_time_us);
        assert!(
            (loose.line_time_us_sigma / lt - 1.0).abs() < 1e-9,
            "{loose:?}"
        );
        // Without the duty the exposure is one of two readings; the fitted
        // one comes first.
        let (e, s) = (
            exact.solutions[0].exposure_us,
            exact.solutions[0].exposure_us_sigma,
        );
        assert!((loose.solutions[0].exposure_us_sigma / want(s, e) - 1.0).abs() < 1e-9);
        assert_eq!(loose.line_time_us, exact.line_time_us);
    }
}
