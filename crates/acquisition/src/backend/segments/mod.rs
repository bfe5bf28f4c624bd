//! Where the ON, OFF and PWM segments of a capture are, when the plan does
//! not say: detected from the mean luma of the plan's LED ROIs, following
//! the plan's `[sequence]` (docs/plan-format.md, "Segment detection").
//!
//! Sits between reading a capture ([`crate::capture`]) and building its
//! acquisition ([`super::captured`]). Two rules:
//! - `sequence` (the sequence has an ON segment, as the paper's 2 s ON,
//!   2 s OFF, 60 s PWM): the ON step is the first bright run of the capture
//!   (after an optional dark lead-in, or from frame 0 when the capture starts
//!   in ON), the OFF step is where it ends, and the PWM step follows the OFF
//!   duration; the durations and the ON/OFF contrast are checked;
//! - `off-then-pwm` (no ON segment): a dark baseline, then the step where
//!   the light comes on (the rule of format version 1).
//!
//! After each step the frames within the settle time are left out (auto
//! exposure and gain hysteresis, Deegan 2018 section 4). A capture that does
//! not fit is refused with the levels and steps found: a case is never
//! judged on a guessed segment.

use std::path::Path;

use crate::capture::{CaptureError, CaptureTrace};
use ledflicker_plan::plan::{Plan, RoiKind, Sequence};
use ledflicker_plan::trace::{DetectionRule, SegmentMethod, StepKind, StepSource};

pub use ledflicker_plan::plan::DEFAULT_SETTLE_S;
/// Frames left out before each detected step (the frame that straddles it).
pub const GUARD_FRAMES: usize = 1;
/// Frames kept out on each side of the ON step by the `off-then-pwm` rule.
pub const OFF_THEN_PWM_GUARD_FRAMES: usize = 2;
/// A detected duration may differ from the sequence's by this fraction...
pub const DURATION_TOLERANCE: f64 = 0.1;
/// ...plus this many frame times.
pub const DURATION_TOLERANCE_FRAMES: f64 = 2.0;
/// The ON level must exceed the OFF level by this fraction of the ON level...
pub const MIN_ON_OFF_CONTRAST: f64 = 0.2;
/// ...and by this fraction of the source's full scale (5.1 DN of 255).
pub const MIN_STEP_OF_FULL_SCALE: f64 = 0.02;

/// What detection needs from the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// The light sequence: durations of ON, OFF and PWM, seconds.
    pub sequence: Sequence,
    /// Frames within this time after a step are left out, seconds (>= 0).
    pub settle_s: f64,
    /// Indices of the ROIs whose mean luma is used; empty for all.
    pub led_rois: Vec<usize>,
}

impl Detection {
    /// Detection for `plan`: its sequence, `[capture] settle-s` and LED ROIs.
    pub fn for_plan(plan: &Plan) -> Self {
        Self {
            sequence: plan.sequence,
            settle_s: plan
                .capture
                .as_ref()
                .map_or(DEFAULT_SETTLE_S, |c| c.settle_s),
            led_rois: led_rois(plan),
        }
    }

    /// The `off-then-pwm` rule over every ROI, for callers without a plan
    /// sequence (format version 1 behaviour).
    pub fn off_then_pwm() -> Self {
        Self {
            sequence: Sequence {
                on_s: 0.0,
                off_s: 0.0,
                pwm_s: 1.0,
            },
            settle_s: DEFAULT_SETTLE_S,
            led_rois: Vec::new(),
        }
    }
}

fn led_rois(plan: &Plan) -> Vec<usize> {
    let led: Vec<usize> = (0..plan.rois.len())
        .filter(|&i| plan.rois[i].kind == RoiKind::Led)
        .collect();
    if led.is_empty() {
        (0..plan.rois.len()).collect()
    } else {
        led
    }
}

pub use ledflicker_plan::trace::{LevelsFound, SegmentsFound, StepFound};

/// The frame times and the LED-ROI mean luma of a capture.
struct Signal {
    /// Seconds from the first frame.
    t: Vec<f64>,
    /// Time of the first frame in the capture's clock, seconds.
    t0: f64,
    /// Mean luma of the LED ROIs, DN.
    m: Vec<f64>,
    /// `m` through a 3-frame running median (single-frame noise removed).
    s: Vec<f64>,
    /// Typical frame interval (median), seconds.
    dt: f64,
    full_scale: f64,
}

impl Signal {
    fn new(trace: &CaptureTrace, led: &[usize]) -> Self {
        let n = trace.time_s.len();
        let rois: Vec<&Vec<f64>> = if led.is_empty() {
            trace.luma.iter().collect()
        } else {
            led.iter().filter_map(|&i| trace.luma.get(i)).collect()
        };
        let m: Vec<f64> = (0..n)
            .map(|k| rois.iter().map(|t| t[k]).sum::<f64>() / rois.len().max(1) as f64)
            .collect();
        let s = (0..n)
            .map(|k| median(&m[k.saturating_sub(1)..(k + 2).min(n)]))
            .collect();
        let t0 = trace.time_s.first().copied().unwrap_or(0.0);
        let t: Vec<f64> = trace.time_s.iter().map(|x| x - t0).collect();
        let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let dt = if d.is_empty() {
            1.0 / 30.0
        } else {
            median_mut(&mut d)
        };
        Self {
            t,
            t0,
            m,
            s,
            dt: if dt > 0.0 { dt } else { 1.0 / 30.0 },
            full_scale: trace.full_scale_dn,
        }
    }

    fn n(&self) -> usize {
        self.t.len()
    }

    /// First frame at or after `time` (n when none).
    fn at(&self, time: f64) -> usize {
        self.t.partition_point(|&x| x < time - 1e-9)
    }

    /// Start time of frame `k`; one frame interval past the last frame for `n`.
    fn time(&self, k: usize) -> f64 {
        match self.t.get(k) {
            Some(&x) => x,
            None => self.t.last().map_or(0.0, |x| x + self.dt),
        }
    }

    fn mean(&self, a: usize, b: usize) -> f64 {
        self.m[a..b].iter().sum::<f64>() / (b - a).max(1) as f64
    }

    fn points(&self) -> Vec<(f64, f64)> {
        let t0 = self.t0;
        self.t
            .iter()
            .map(|t| t + t0)
            .zip(self.m.iter().copied())
            .collect()
    }

    fn tolerance(&self, duration_s: f64) -> f64 {
        DURATION_TOLERANCE * duration_s + DURATION_TOLERANCE_FRAMES * self.dt
    }

    fn span_s(&self, (a, b): (u64, u64)) -> (f64, f64) {
        (self.time(a as usize), self.time(b as usize))
    }
}

fn median(v: &[f64]) -> f64 {
    median_mut(&mut v.to_vec())
}

fn median_mut(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The ON/OFF step found by [`find_on_off`].
#[derive(Debug, Clone, Copy)]
struct OnOff {
    /// First frame of the bright ON run (0 when the capture starts in ON).
    rise: usize,
    /// First frame of the OFF segment.
    fall: usize,
    /// Midpoint between the ON and OFF levels, DN.
    mid: f64,
}

/// Detects the segments of `trace` by `det`'s rule.
pub fn detect(
    trace: &CaptureTrace,
    det: &Detection,
    path: &Path,
) -> Result<SegmentsFound, CaptureError> {
    let sig = Signal::new(trace, &det.led_rois);
    if det.sequence.on_s > 0.0 {
        detect_sequence(&sig, det, path)
    } else {
        detect_off_then_pwm(&sig, det, path)
    }
}

fn refuse(path: &Path, message: String, hint: String) -> CaptureError {
    CaptureError::Invalid {
        path: path.to_path_buf(),
        message,
        hint,
    }
}

const KEYS_HINT: &str = "give this case's segments in its [[case]] (on-time-s, off-time-s, pwm-time-s = [start, end] in seconds, or on-frames, off-frames, pwm-frames), or make [sequence] on-s, off-s, pwm-s match the recording (on-s = 0 for a dark baseline, then PWM)";

/// The first ON -> OFF step: the earliest frame `f` where the luma falls
/// below the midpoint of the ON level before it and the OFF level after it,
/// with the whole OFF segment dark, the ON level above the OFF level by the
/// required contrast, and nothing bright before the ON run.
fn find_on_off(sig: &Signal, seq: &Sequence, settle_s: f64) -> Option<OnOff> {
    let n = sig.n();
    let off_len = seq.off_s - sig.tolerance(seq.off_s);
    for f in 1..n {
        if sig.m[f] >= sig.m[f - 1] {
            continue;
        }
        let tf = sig.t[f];
        let on_a = sig.at(tf - 0.5 * seq.on_s);
        let on_b = f.saturating_sub(GUARD_FRAMES);
        let off_a = sig.at(tf + settle_s);
        let off_b = sig.at(tf + off_len);
        if on_b < on_a + 2 || off_b < off_a + 2 || sig.time(n) < tf + off_len {
            continue;
        }
        let on = median(&sig.m[on_a..on_b]);
        let off = median(&sig.m[off_a..off_b]);
        if !contrast_ok(on, off, sig.full_scale) {
            continue;
        }
        let mid = 0.5 * (on + off);
        if sig.m[f - 1] < mid || sig.m[f] >= mid || sig.s[f..off_b].iter().any(|&x| x >= mid) {
            continue;
        }
        let mut rise = f - 1;
        while rise > 0 && sig.s[rise - 1] >= mid {
            rise -= 1;
        }
        let lead_in = rise.saturating_sub(GUARD_FRAMES);
        if sig.s[..lead_in].iter().any(|&x| x >= mid) {
            continue;
        }
        return Some(OnOff { rise, fall: f, mid });
    }
    None
}

fn contrast_ok(on: f64, off: f64, full_scale: f64) -> bool {
    on - off >= MIN_ON_OFF_CONTRAST * on && on - off >= MIN_STEP_OF_FULL_SCALE * full_scale
}

/// The `sequence` rule: ON, OFF, PWM in that order.
fn detect_sequence(
    sig: &Signal,
    det: &Detection,
    path: &Path,
) -> Result<SegmentsFound, CaptureError> {
    let seq = &det.sequence;
    let settle = det.settle_s;
    check_sequence_detectable(sig, seq, settle, path)?;
    let Some(step) = find_on_off(sig, seq, settle) else {
        return Err(refuse(
            path,
            format!(
                "cannot detect segments: no ON step followed by a {} s OFF segment with the ON level at least {:.0} % (and {:.1} DN) above the OFF level; found {}",
                seq.off_s,
                100.0 * MIN_ON_OFF_CONTRAST,
                MIN_STEP_OF_FULL_SCALE * sig.full_scale,
                describe_runs(sig)
            ),
            KEYS_HINT.to_string(),
        ));
    };
    let s = SequenceSteps {
        sig,
        seq,
        settle,
        path,
        step,
    };
    s.check_on_duration()?;
    let (pwm_step, pwm_from) = s.pwm_step()?;
    let (end, end_from) = s.pwm_end(pwm_step)?;
    let (on, off, pwm) = s.settled_windows(pwm_step, end)?;
    let (l_on, l_off) = (sig.mean(on.0, on.1), sig.mean(off.0, off.1));
    if !contrast_ok(l_on, l_off, sig.full_scale) {
        return Err(s.refuse(
            format!(
                "cannot detect segments: the settled ON level {l_on:.2} DN is not {:.0} % (and {:.1} DN) above the OFF level {l_off:.2} DN; found {}",
                100.0 * MIN_ON_OFF_CONTRAST,
                MIN_STEP_OF_FULL_SCALE * sig.full_scale,
                s.found()
            ),
            KEYS_HINT.to_string(),
        ));
    }
    let OnOff { rise, fall, mid } = step;
    let step = |kind, k: usize, from| StepFound {
        kind,
        frame: k as u64,
        time_s: sig.time(k),
        from,
    };
    let steps = vec![
        step(
            StepKind::On,
            rise,
            if rise == 0 {
                StepSource::Capture
            } else {
                StepSource::Luma
            },
        ),
        step(StepKind::Off, fall, StepSource::Luma),
        step(StepKind::Pwm, pwm_step, pwm_from),
        step(StepKind::End, end, end_from),
    ];
    let frames = |(a, b): (usize, usize)| (a as u64, b as u64);
    let found = SegmentsFound {
        method: SegmentMethod::Detected,
        rule: Some(DetectionRule::Sequence),
        off: Some(frames(off)),
        on: Some(frames(on)),
        pwm: frames(pwm),
        off_time_s: Some(sig.span_s(frames(off))),
        on_time_s: Some(sig.span_s(frames(on))),
        pwm_time_s: sig.span_s(frames(pwm)),
        capture_frames: sig.n() as u64,
        threshold_dn: Some(mid),
        settle_s: Some(settle),
        levels_dn: Some(LevelsFound {
            off: Some(l_off),
            on: Some(l_on),
            pwm_mean: sig.mean(pwm.0, pwm.1),
        }),
        steps,
        text: String::new(),
        signal: sig.points(),
    };
    Ok(found.with_text(&format!(
        "detected from the LED-ROI luma by the plan's sequence ({} s ON, {} s OFF, {} s PWM)",
        seq.on_s, seq.off_s, seq.pwm_s
    )))
}

/// Refuses a sequence the `sequence` rule cannot work with: no OFF
/// reference, or a settle time that leaves a segment without frames.
fn check_sequence_detectable(
    sig: &Signal,
    seq: &Sequence,
    settle: f64,
    path: &Path,
) -> Result<(), CaptureError> {
    if seq.off_s <= 0.0 {
        return Err(refuse(
            path,
            "cannot detect segments: the plan's sequence has an ON segment but no OFF reference (sequence.off-s = 0)".to_string(),
            KEYS_HINT.to_string(),
        ));
    }
    if settle + 2.0 * sig.dt >= seq.off_s.min(seq.on_s).min(seq.pwm_s) {
        return Err(refuse(
            path,
            format!(
                "cannot detect segments: the settle time {settle} s leaves no frames of a {} s ON, {} s OFF, {} s PWM sequence",
                seq.on_s, seq.off_s, seq.pwm_s
            ),
            "shorten [capture] settle-s".to_string(),
        ));
    }
    Ok(())
}

/// A frame window: first frame, one past the last.
type Window = (usize, usize);

/// The `sequence` rule after its ON -> OFF step was found: the checks and
/// steps that follow from it, each refusal naming what was found.
struct SequenceSteps<'a> {
    sig: &'a Signal,
    seq: &'a Sequence,
    settle: f64,
    path: &'a Path,
    step: OnOff,
}

impl SequenceSteps<'_> {
    fn refuse(&self, message: String, hint: String) -> CaptureError {
        refuse(self.path, message, hint)
    }

    /// The ON step and the runs of the signal, for messages.
    fn found(&self) -> String {
        let OnOff { rise, fall, mid } = self.step;
        let (t_rise, t_fall) = (self.sig.t[rise], self.sig.t[fall]);
        format!(
            "ON from frame {rise} ({t_rise:.3} s) to frame {fall} ({t_fall:.3} s), midpoint {mid:.1} DN; {}",
            describe_runs(self.sig)
        )
    }

    /// The ON run must last the sequence's ON time (at most that when the
    /// capture starts in ON).
    fn check_on_duration(&self) -> Result<(), CaptureError> {
        let OnOff { rise, fall, .. } = self.step;
        let (t_rise, t_fall) = (self.sig.t[rise], self.sig.t[fall]);
        let on_seen = t_fall - t_rise;
        let tol_on = self.sig.tolerance(self.seq.on_s);
        let on_wrong = if rise > 0 {
            (on_seen - self.seq.on_s).abs() > tol_on
        } else {
            on_seen > self.seq.on_s + tol_on
        };
        if !on_wrong {
            return Ok(());
        }
        Err(self.refuse(
            format!(
                "cannot detect segments: the ON segment lasts {on_seen:.3} s, the sequence's {} s +- {tol_on:.3} s; found {}",
                self.seq.on_s,
                self.found()
            ),
            format!("{KEYS_HINT}; e.g. on-time-s = [{t_rise:.3}, {t_fall:.3}]"),
        ))
    }

    /// The PWM step and where it came from: seen as the first bright frame
    /// after the OFF segment when it is near the sequence's time, else from
    /// the timing (a PWM segment may start looking dark: the light "appears
    /// OFF"). A bright frame well before that time is refused.
    fn pwm_step(&self) -> Result<(usize, StepSource), CaptureError> {
        let (sig, seq) = (self.sig, self.seq);
        let OnOff { fall, mid, .. } = self.step;
        let t_fall = sig.t[fall];
        let t_pwm = t_fall + seq.off_s;
        let tol_off = sig.tolerance(seq.off_s);
        let seen = (fall..sig.n()).find(|&k| sig.s[k] >= mid);
        if let Some(k) = seen.filter(|&k| sig.t[k] < t_pwm - tol_off) {
            return Err(self.refuse(
                format!(
                    "cannot detect segments: the OFF segment lasts {:.3} s (frames {fall}..{k}), the sequence's {} s +- {tol_off:.3} s; found {}",
                    sig.t[k] - t_fall,
                    seq.off_s,
                    self.found()
                ),
                format!(
                    "{KEYS_HINT}; e.g. off-time-s = [{t_fall:.3}, {:.3}]",
                    sig.t[k]
                ),
            ));
        }
        Ok(match seen.filter(|&k| sig.t[k] <= t_pwm + 1.5 * sig.dt) {
            Some(k) => (k, StepSource::Luma),
            None => (sig.at(t_pwm - 0.5 * sig.dt), StepSource::Timing),
        })
    }

    /// The end of the PWM segment and where it came from: the sequence's
    /// PWM time after `pwm_step`, or the end of the capture. A capture
    /// shorter than that (beyond the tolerance) is refused.
    fn pwm_end(&self, pwm_step: usize) -> Result<(usize, StepSource), CaptureError> {
        let (sig, seq) = (self.sig, self.seq);
        let n = sig.n();
        let t_end = sig.time(pwm_step) - 0.5 * sig.dt + seq.pwm_s;
        let tol_pwm = sig.tolerance(seq.pwm_s);
        if sig.time(n) < t_end - tol_pwm {
            return Err(self.refuse(
                format!(
                    "cannot detect segments: the capture ends {:.3} s into the PWM segment, which the sequence makes {} s (+- {tol_pwm:.3} s) long; found {}",
                    sig.time(n) - sig.time(pwm_step),
                    seq.pwm_s,
                    self.found()
                ),
                format!(
                    "{KEYS_HINT}; e.g. pwm-time-s = [{:.3}] (to the end), or set [sequence] pwm-s to the recorded length",
                    sig.time(pwm_step)
                ),
            ));
        }
        Ok(if t_end < sig.time(n) {
            (sig.at(t_end), StepSource::Timing)
        } else {
            (n, StepSource::Capture)
        })
    }

    /// The ON, OFF and PWM frame windows, each after the settle time and
    /// before the guard frames; each must hold at least 2 frames.
    fn settled_windows(
        &self,
        pwm_step: usize,
        end: usize,
    ) -> Result<(Window, Window, Window), CaptureError> {
        let (sig, settle) = (self.sig, self.settle);
        let n = sig.n();
        let OnOff { rise, fall, .. } = self.step;
        let after = |k: usize| if k == 0 { 0 } else { sig.at(sig.t[k] + settle) };
        let on = (after(rise), fall - GUARD_FRAMES);
        let off = (after(fall), pwm_step.saturating_sub(GUARD_FRAMES));
        let pwm = (
            after(pwm_step),
            if end < n { end - GUARD_FRAMES } else { n },
        );
        for (name, (a, b)) in [("ON", on), ("OFF", off), ("PWM", pwm)] {
            if b < a + 2 {
                return Err(self.refuse(
                    format!(
                        "cannot detect segments: after the {settle} s settle time the {name} segment holds {} frames; found {}",
                        b.saturating_sub(a),
                        self.found()
                    ),
                    format!("shorten [capture] settle-s, or {KEYS_HINT}"),
                ));
            }
        }
        Ok((on, off, pwm))
    }
}

/// The `off-then-pwm` rule (format version 1): a dark baseline, then the
/// step where the light comes on; the PWM segment runs to the end.
fn detect_off_then_pwm(
    sig: &Signal,
    det: &Detection,
    path: &Path,
) -> Result<SegmentsFound, CaptureError> {
    let n = sig.n();
    let m = &sig.m;
    let lo = m.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = m.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let fail = |message: String| {
        refuse(
            path,
            message,
            "give the segments in the plan: off-frames = [a, b] and pwm-frames = [c] (or *-time-s)"
                .to_string(),
        )
    };
    if hi - lo <= MIN_STEP_OF_FULL_SCALE * sig.full_scale || !hi.is_finite() || !lo.is_finite() {
        return Err(fail(format!(
            "cannot detect segments: the ROI luma stays within {lo:.2}..{hi:.2} DN (no ON step)"
        )));
    }
    // The ON step: the first frame above a quarter of the range. The OFF
    // baseline ends where the luma first leaves the dark level (2 % of the
    // range), so a slow rise is not averaged into x_off.
    let threshold = lo + 0.25 * (hi - lo);
    let step = m.iter().position(|&x| x > threshold).unwrap_or(0);
    let rise = m
        .iter()
        .position(|&x| x > lo + 0.02 * (hi - lo))
        .unwrap_or(0);
    if rise <= OFF_THEN_PWM_GUARD_FRAMES {
        return Err(fail(
            "cannot detect segments: the capture does not start with a dark OFF baseline"
                .to_string(),
        ));
    }
    let fps = if n > 1 {
        (n - 1) as f64 / sig.t[n - 1].max(1e-9)
    } else {
        30.0
    };
    let pwm_start = step + ((det.settle_s * fps).round() as usize).max(OFF_THEN_PWM_GUARD_FRAMES);
    if pwm_start + 2 > n {
        return Err(fail(format!(
            "the light comes on at frame {step}, too late for a PWM segment of 2 frames or more"
        )));
    }
    let off = (0, (rise - OFF_THEN_PWM_GUARD_FRAMES) as u64);
    let pwm = (pwm_start as u64, n as u64);
    let found = SegmentsFound {
        method: SegmentMethod::Detected,
        rule: Some(DetectionRule::OffThenPwm),
        off: Some(off),
        on: None,
        pwm,
        off_time_s: Some(sig.span_s(off)),
        on_time_s: None,
        pwm_time_s: sig.span_s(pwm),
        capture_frames: n as u64,
        threshold_dn: Some(threshold),
        settle_s: Some(det.settle_s),
        levels_dn: Some(LevelsFound {
            off: Some(sig.mean(0, off.1 as usize)),
            on: None,
            pwm_mean: sig.mean(pwm_start, n),
        }),
        steps: vec![
            StepFound {
                kind: StepKind::Pwm,
                frame: step as u64,
                time_s: sig.time(step),
                from: StepSource::Luma,
            },
            StepFound {
                kind: StepKind::End,
                frame: n as u64,
                time_s: sig.time(n),
                from: StepSource::Capture,
            },
        ],
        text: String::new(),
        signal: sig.points(),
    };
    Ok(found.with_text(
        "detected from the LED-ROI luma by the off-then-pwm rule (the sequence has no ON segment)",
    ))
}

/// The capture's dark and bright runs around the midpoint of its 2nd and
/// 98th percentile luma, for error messages: "dark frames 0..29 (0.000 s,
/// 12.3 DN), bright ..." (the first 6 runs).
fn describe_runs(sig: &Signal) -> String {
    let n = sig.n();
    if n == 0 {
        return "no frames".to_string();
    }
    let mut sorted = sig.s.clone();
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| sorted[((n - 1) as f64 * p).round() as usize];
    let (lo, hi) = (q(0.02), q(0.98));
    let mid = 0.5 * (lo + hi);
    let mut runs = Vec::new();
    let mut start = 0;
    for k in 1..=n {
        if k == n || (sig.s[k] >= mid) != (sig.s[start] >= mid) {
            runs.push((start, k));
            start = k;
        }
    }
    let shown: Vec<String> = runs
        .iter()
        .take(6)
        .map(|&(a, b)| {
            format!(
                "{} frames {a}..{b} ({:.3}-{:.3} s, mean {:.1} DN)",
                if sig.s[a] >= mid { "bright" } else { "dark" },
                sig.time(a),
                sig.time(b),
                sig.mean(a, b)
            )
        })
        .collect();
    let more = if runs.len() > 6 {
        format!(" and {} more runs", runs.len() - 6)
    } else {
        String::new()
    };
    format!(
        "LED-ROI luma {lo:.1}..{hi:.1} DN (2nd..98th percentile), {n} frames, {:.3} s: {}{more}",
        sig.time(n),
        shown.join(", ")
    )
}

#[cfg(test)]
mod tests;
