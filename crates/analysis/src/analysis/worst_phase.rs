//! The evidence behind a verdict on the worst case over PWM phase.
//!
//! A simulated case can fail on `fdi_2018_worst_phase` while its own trace
//! shows the lamp plainly: the worst case is at a PWM phase the run did not
//! have. The simulator is run again with the LED's first rising edge moved
//! so that the case's darkest PWM frame falls at that phase
//! ([`Shutter::darkest_phase`]), which gives the trace and the frame the
//! verdict stands on. Only cases whose verdict rests on a worst-phase check
//! that is not met get this run, and only for the ideal camera, whose worst
//! phase is a closed form. A case whose trace already holds its worst
//! case (the capture saw that phase) needs no run: its trace is the
//! evidence.
//!
//! [`Shutter::darkest_phase`]: ledflicker_physics::Shutter::darkest_phase

use ledflicker_acquisition::backend::Backend;
use ledflicker_acquisition::backend::sim::Simulator;
use ledflicker_acquisition::runner::CaseResult;
use ledflicker_metrics::metrics::flicker::Segment;
use ledflicker_metrics::metrics::{Check, Verdict, evaluate_roi};
use ledflicker_physics::pwm::wrap_unit;
use ledflicker_plan::plan::{BackendKind, Plan};
use ledflicker_plan::trace::RenderedFrame;

/// Suffix of the metrics judged on the worst case over phase.
const WORST_PHASE_SUFFIX: &str = "_worst_phase";

/// The case run again at its ROI's darkest PWM phase.
#[derive(Debug, Clone, PartialEq)]
pub struct WorstPhaseRun {
    /// The ROI whose worst-phase check fails by the widest margin.
    pub roi: String,
    /// That check's metric, e.g. `fdi_2018_worst_phase`.
    pub metric: String,
    /// That check's value, as reported; `None` when undefined.
    pub reported: Option<f64>,
    /// Phase of row 0's exposure start in the shown frame, cycles from a
    /// rising edge, in `[0, 1)`.
    pub phase_cycles: f64,
    /// First rising edge after frame 0 starts that gives the run, seconds,
    /// in `[0, 1 / f)`.
    pub pwm_delay_s: f64,
    /// The frame put at the darkest phase: the case's darkest PWM frame of
    /// the ROI.
    pub frame: u64,
    /// The ROI's mean luma per frame of the run (DN), frame for frame with
    /// the case's trace.
    pub luma: Vec<f64>,
    /// FDI (Deegan 2018, Eq. 3) of `luma`: its PWM minimum against its OFF
    /// mean; `None` when undefined or unbounded.
    pub fdi_2018: Option<f64>,
    /// Percent Flicker of `luma`'s PWM segment; `None` when undefined.
    pub percent_flicker: Option<f64>,
    /// The frame `frame` of the run, whole.
    pub rendered: Option<RenderedFrame>,
}

/// The ROI and check a worst-phase verdict of `r` rests on and that its
/// trace does not show: among the worst-phase checks not met whose value
/// differs from the same metric as run ([`shown_as_run`]), the one with the
/// lowest margin (plan order breaks ties). `None` for a passing case, one
/// judged on other checks, or one whose trace already holds its worst case.
pub fn failing_check(r: &CaseResult) -> Option<&Check> {
    if r.verdict == Verdict::Pass {
        return None;
    }
    r.checks
        .iter()
        .filter(|k| !k.pass && k.metric.ends_with(WORST_PHASE_SUFFIX))
        .filter(|k| !shown_as_run(r, k))
        .min_by(|a, b| a.margin().total_cmp(&b.margin()))
}

/// Relative difference under which a worst-phase value is the value as run:
/// the worst phase then is in the trace, which shows the verdict already.
const SAME_VALUE: f64 = 1e-9;

/// Whether the check's worst-phase value is its metric's value as run (the
/// capture saw its worst phase).
fn shown_as_run(r: &CaseResult, k: &Check) -> bool {
    let Some(m) = r
        .acquisition
        .rois
        .iter()
        .position(|t| t.name == k.roi)
        .and_then(|i| r.metrics.get(i))
    else {
        return false;
    };
    let as_run = match k.metric.strip_suffix(WORST_PHASE_SUFFIX) {
        Some("fdi_2018") => &m.fdi_2018,
        Some("percent_flicker") => &m.percent_flicker,
        _ => return false,
    };
    match (as_run.value, k.value) {
        (Some(a), Some(w)) => (a - w).abs() <= SAME_VALUE * a.abs().max(w.abs()).max(1.0),
        (None, None) => as_run.unbounded == k.unbounded,
        _ => false,
    }
}

/// The case `r` of `plan` run again at the worst phase of the ROI its
/// worst-phase verdict rests on; `None` when the case needs no such run
/// ([`failing_check`]), or the backend is not the ideal simulated camera,
/// or the LED has dies of their own duty and phase (the darkest phase of
/// one PWM waveform is not theirs).
pub fn worst_phase_run(plan: &Plan, r: &CaseResult) -> Option<WorstPhaseRun> {
    if plan.dut.backend != BackendKind::Simulator
        || plan.colour.as_ref().is_some_and(|c| !c.dies.is_empty())
    {
        return None;
    }
    let check = failing_check(r)?;
    let i = plan.rois.iter().position(|roi| roi.name == check.roi)?;
    let sim = Simulator::new(plan);
    if !sim.is_ideal() {
        return None;
    }
    let pwm = sim.pwm_for(&r.case).ok()?;
    let shutter = sim.shutter();
    let phase = shutter.darkest_phase(&pwm, plan.rois[i].rows());
    let acq = &r.acquisition;
    let segments: Vec<Segment> = acq.frames.iter().map(|f| f.segment).collect();
    let frame = acq
        .frames
        .iter()
        .zip(&acq.rois.get(i)?.luma)
        .filter(|(f, _)| f.segment == Segment::Pwm)
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(f, _)| f.index)?;
    // Frame `frame` starts `whole` cycles after a rising edge of a drive
    // whose first rise is at 0; a first rise `d` later shifts it by
    // `-d f`, so `d = (whole - phase) / f` puts it at `phase`.
    let f = pwm.frequency_hz();
    let whole = pwm.phase_at(frame, shutter.fps, pwm.first_rise_s());
    let delay_s = wrap_unit(whole - phase) / f;
    let shifted = sim.with_pwm_delay(delay_s);
    let run = shifted.acquire(&r.case).ok()?;
    let luma = run.rois.get(i)?.luma.clone();
    let metrics = evaluate_roi(&luma, &segments, None, run.saturation_dn)?;
    let rendered = shifted.render_frame(&r.case, frame).and_then(Result::ok);
    Some(WorstPhaseRun {
        roi: check.roi.clone(),
        metric: check.metric.clone(),
        reported: check.value,
        phase_cycles: phase,
        pwm_delay_s: delay_s,
        frame,
        luma,
        fdi_2018: metrics.fdi_2018.value,
        percent_flicker: metrics.percent_flicker.value,
        rendered,
    })
}
