//! A shard's case results taken as input, for `merge`: each case read from
//! `cases.cbor` is checked against the plan (case, ROIs, frames, finite
//! values, what its backend can have produced), then evaluated again from
//! its traces by the runner's own evaluation, exactly as `plan` evaluates a
//! finished acquisition. A shard carries data, never conclusions: the
//! metrics, P2020 KPIs, checks and verdict it wrote are dropped, and the
//! SHA-256 in its manifest only tells damage from a good file, since anyone
//! who edits `cases.cbor` can rewrite that too.

use std::path::Path;
use std::sync::Mutex;

use rayon::prelude::*;

use super::ShardSpec;
use super::record;
use ledflicker_core::backend::sim::Simulator;
use ledflicker_core::backend::{Acquisition, Backend, BackendError, RenderedFrame};
use ledflicker_core::capture;
use ledflicker_core::error::UsageError;
use ledflicker_core::metrics::flicker::Segment;
use ledflicker_core::plan::{BackendKind, Plan, TestCase};
use ledflicker_core::runner::{self, CaseResult};
use ledflicker_core::trace::SegmentMethod;
use ledflicker_core::trace::SegmentsFound;

/// Decodes the `cases.cbor` of shard `shard` (`bytes`, read from `path`),
/// which its manifest says holds the cases `listed` of `all` (the plan's
/// expanded cases); checks every case and evaluates it again. The results
/// come back in the file's order, which is case order.
///
/// Every error names `path`, and the case when there is one; no input
/// panics, and none gives a non-finite number to the report.
pub fn shard_cases(
    plan: &Plan,
    all: &[TestCase],
    listed: &[usize],
    bytes: &[u8],
    path: &Path,
    shard: ShardSpec,
) -> Result<Vec<CaseResult>, UsageError> {
    let hint = format!(
        "\n    hint: the shard is damaged or was edited after it ran; re-run shard {shard} with `ledflicker plan PLAN --shard {shard} --out DIR`"
    );
    let cases = record::decode_cases(bytes, path).map_err(|e| UsageError(format!("{e}{hint}")))?;
    let indices: Vec<usize> = cases.iter().map(|c| c.result.case.index).collect();
    if indices != listed {
        return Err(UsageError(format!(
            "`{}` holds cases {indices:?}, its {} lists {listed:?}{hint}",
            path.display(),
            record::MANIFEST,
        )));
    }
    cases
        .into_par_iter()
        .map(|c| {
            let i = c.result.case.index;
            let name = match all.get(i) {
                Some(want) => format!("case {i} (`{}`)", want.id),
                None => format!("case {i}"),
            };
            let fail =
                |why: String| UsageError(format!("`{}`, {name}: {why}{hint}", path.display()));
            check_case(plan, all, &c.result).map_err(fail)?;
            evaluate_again(plan, c.result).map_err(fail)
        })
        .collect()
}

/// A case of a partial store, for `plan --resume`: checked as `merge`
/// checks a shard's case, then evaluated again. `idx` is its position in
/// the store.
pub fn stored_case(
    plan: &Plan,
    all: &[TestCase],
    idx: usize,
    stored: CaseResult,
) -> Result<CaseResult, String> {
    if stored.case.index != idx {
        return Err(format!(
            "stored at position {idx}, it holds the plan's case {} (`{}`)",
            stored.case.index, stored.case.id
        ));
    }
    check_case(plan, all, &stored)?;
    evaluate_again(plan, stored)
}

/// Everything of one case that `merge` or a resume keeps as data, checked:
/// it is a case of this plan, with the plan's ROIs, and frames, traces and
/// pictures that this plan's backend can have produced.
fn check_case(plan: &Plan, all: &[TestCase], r: &CaseResult) -> Result<(), String> {
    let i = r.case.index;
    let want = all
        .get(i)
        .ok_or_else(|| format!("the plan has {} cases, numbered from 0", all.len()))?;
    if r.case != *want {
        return Err(format!(
            "the plan's case {i} is `{}` ({}), the shard holds `{}` ({})",
            want.id,
            conditions(want),
            r.case.id,
            conditions(&r.case)
        ));
    }
    let acq = &r.acquisition;
    check_rois(plan, acq)?;
    check_frames(acq)?;
    if !(acq.saturation_dn.is_finite() && acq.saturation_dn > 0.0) {
        return Err(format!(
            "saturation level {} DN is not a positive number",
            acq.saturation_dn
        ));
    }
    match plan.dut.backend {
        BackendKind::Simulator => check_simulated(plan, r)?,
        BackendKind::Captured | BackendKind::Command => check_captured(plan, r)?,
    }
    check_pictures(plan, r)
}

fn frame_name(f: Option<u64>) -> String {
    f.map_or("none".to_string(), |k| format!("frame {k}"))
}

/// A run (whole or a shard) renders the darkest PWM frame of the first LED
/// ROI wherever its backend can render a frame: the simulator always (of
/// the camera's size, checked with the simulated data), a capture but for
/// a CSV trace, a rig never. It renders a capture's lit frame, the frame
/// its capture summary names, the same way. A picture of a capture is
/// whole, and a case's two pictures are the same size.
fn check_pictures(plan: &Plan, r: &CaseResult) -> Result<(), String> {
    let capture = r.acquisition.capture.as_ref();
    let renders = match plan.dut.backend {
        BackendKind::Simulator => true,
        BackendKind::Captured => capture.is_some_and(|c| {
            capture::source_kind(Path::new(&c.source)) != capture::SourceKind::Csv
        }),
        BackendKind::Command => false,
    };
    let (sample, lit) = if renders {
        (
            runner::darkest_pwm_frame(plan, r),
            capture.and_then(|c| c.lit_frame).map(|l| l.frame),
        )
    } else {
        (None, None)
    };
    let pictures = [
        (
            "sample",
            &r.sample_frame,
            sample,
            "the darkest PWM frame of the LED ROI",
        ),
        (
            "lit",
            &r.lit_frame,
            lit,
            "the frame the capture summary names",
        ),
    ];
    for (what, picture, expected, rule) in pictures {
        let held = picture.as_ref().map(|f| f.index);
        if held != expected {
            return Err(format!(
                "the {what} frame is {}, but `plan` renders {} ({rule}, where the backend renders frames)",
                frame_name(held),
                frame_name(expected)
            ));
        }
    }
    if plan.dut.backend == BackendKind::Simulator {
        return Ok(());
    }
    for (what, picture, _, _) in pictures {
        if let Some(f) = picture {
            check_picture(f, what, f.width, f.height, f.full_scale_dn)?;
        }
    }
    if let (Some(a), Some(b)) = (&r.sample_frame, &r.lit_frame)
        && (a.width, a.height, a.full_scale_dn) != (b.width, b.height, b.full_scale_dn)
    {
        return Err(format!(
            "the sample frame is {} x {} px at full scale {} DN, the lit frame {} x {} px at {} DN",
            a.width, a.height, a.full_scale_dn, b.width, b.height, b.full_scale_dn
        ));
    }
    Ok(())
}

fn conditions(c: &TestCase) -> String {
    format!(
        "{} lx, {} Hz, duty {}, seed {}",
        c.light_lux, c.frequency_hz, c.duty, c.seed
    )
}

/// Largest luma magnitude a shard may hold, DN: the bound a capture's
/// luma is read within ([`ledflicker_core::capture::MAX_CSV_LUMA_DN`]), so that every
/// shard `plan --shard` writes merges. The metrics and analyses sum and
/// square luma over up to 10^7 frames; within this bound that stays near
/// 10^31, far from overflowing, where values near `f64::MAX` overflow to
/// infinity and give NaN metrics.
pub const MAX_LUMA_DN: f64 = ledflicker_core::capture::MAX_CSV_LUMA_DN;

fn in_range(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_LUMA_DN
}

/// One trace per plan ROI, in plan order and by name, each as long as the
/// frame list, every value finite and within [`MAX_LUMA_DN`].
fn check_rois(plan: &Plan, acq: &Acquisition) -> Result<(), String> {
    let names: Vec<&str> = plan.rois.iter().map(|r| r.name.as_str()).collect();
    let got: Vec<&str> = acq.rois.iter().map(|r| r.name.as_str()).collect();
    if got != names {
        return Err(format!(
            "ROI traces {got:?}, the plan's ROIs are {names:?} (one trace each, in plan order)"
        ));
    }
    let n = acq.frames.len();
    for t in &acq.rois {
        if t.luma.len() != n {
            return Err(format!(
                "ROI `{}` has {} luma values for {n} frames",
                t.name,
                t.luma.len()
            ));
        }
        if let Some(k) = t.luma.iter().position(|v| !in_range(*v)) {
            let v = t.luma[k];
            let what = if v.is_finite() {
                format!("out of range (at most {MAX_LUMA_DN:e} DN either side of 0)")
            } else {
                "not a finite number".to_string()
            };
            return Err(format!(
                "ROI `{}` luma of frame {} is {v}, {what}",
                t.name, acq.frames[k].index
            ));
        }
        if let Some((lo, hi)) = t.phase_envelope
            && !(in_range(lo) && in_range(hi) && lo <= hi)
        {
            return Err(format!(
                "ROI `{}` luma envelope over phase ({lo}, {hi}) is not two finite numbers within {MAX_LUMA_DN:e} DN of 0, lowest first",
                t.name
            ));
        }
    }
    Ok(())
}

/// At least one PWM frame; frame numbers and times strictly rising, times
/// finite.
fn check_frames(acq: &Acquisition) -> Result<(), String> {
    let frames = &acq.frames;
    if !frames.iter().any(|f| f.segment == Segment::Pwm) {
        return Err(format!(
            "{} frames, none in the PWM segment: nothing to evaluate",
            frames.len()
        ));
    }
    if let Some(f) = frames.iter().find(|f| !f.time_s.is_finite()) {
        return Err(format!(
            "frame {} time {} s is not finite",
            f.index, f.time_s
        ));
    }
    if let Some(w) = frames
        .windows(2)
        .find(|w| w[1].index <= w[0].index || w[1].time_s <= w[0].time_s)
    {
        return Err(format!(
            "frame {} ({} s) follows frame {} ({} s): frame numbers and times must rise",
            w[1].index, w[1].time_s, w[0].index, w[0].time_s
        ));
    }
    Ok(())
}

/// The simulator's frames are the plan's (every frame, `k / fps`, labelled
/// by the sequence), its saturation level the camera's, and its picture a
/// whole sensor of finite luma.
fn check_simulated(plan: &Plan, r: &CaseResult) -> Result<(), String> {
    let acq = &r.acquisition;
    let cam = &plan.dut.camera;
    if acq.capture.is_some() {
        return Err("a simulated case carries a capture summary".to_string());
    }
    let frames = Simulator::new(plan).frames();
    if acq.frames != frames {
        let at = acq
            .frames
            .iter()
            .zip(&frames)
            .position(|(a, b)| a != b)
            .unwrap_or(acq.frames.len().min(frames.len()));
        return Err(format!(
            "{} frames that differ from the plan's {} simulated frames (at frame {at})",
            acq.frames.len(),
            frames.len()
        ));
    }
    if acq.saturation_dn != cam.saturation_dn {
        return Err(format!(
            "saturation level {} DN, the plan's camera has {} DN",
            acq.saturation_dn, cam.saturation_dn
        ));
    }
    if let Some(f) = &r.sample_frame {
        check_picture(
            f,
            "sample",
            cam.sensor_columns,
            cam.sensor_rows,
            cam.full_scale_dn,
        )?;
    }
    Ok(())
}

/// A whole picture (the `what` frame) of `width` x `height` finite pixels
/// at full scale `full_scale_dn`, every row as wide as the frame.
fn check_picture(
    f: &RenderedFrame,
    what: &str,
    width: u32,
    height: u32,
    full_scale_dn: f64,
) -> Result<(), String> {
    if (f.width, f.height) != (width, height) || f.full_scale_dn != full_scale_dn {
        return Err(format!(
            "the {what} frame is {} x {} px at full scale {} DN, the plan's camera {width} x {height} px at {full_scale_dn} DN",
            f.width, f.height, f.full_scale_dn
        ));
    }
    if !(full_scale_dn.is_finite() && full_scale_dn > 0.0) {
        return Err(format!(
            "the {what} frame's full scale {full_scale_dn} DN is not a positive number"
        ));
    }
    for y in 0..f.height {
        let runs = f.runs(y);
        let pixels: u64 = runs.iter().map(|r| u64::from(r.len)).sum();
        if pixels != u64::from(width) {
            return Err(format!(
                "row {y} of the {what} frame holds {pixels} pixels, not its width {width}"
            ));
        }
        if runs.iter().any(|r| r.len > 0 && !r.value.is_finite()) {
            return Err(format!(
                "row {y} of the {what} frame has pixels that are not finite numbers"
            ));
        }
    }
    Ok(())
}

/// A capture's frames are the frames inside its segments, each labelled by
/// the segment it is in, and its numbers are finite.
fn check_captured(plan: &Plan, r: &CaseResult) -> Result<(), String> {
    let acq = &r.acquisition;
    let Some(summary) = &acq.capture else {
        return Err("a captured case without its capture summary".to_string());
    };
    if let Some(cap) = &plan.capture {
        if plan.dut.backend == BackendKind::Captured {
            let source = cap.cases.iter().find(|k| k.id == r.case.id);
            if let Some(k) = source
                && k.source_text != summary.source
            {
                return Err(format!(
                    "capture `{}`, the plan's case reads `{}`",
                    summary.source, k.source_text
                ));
            }
        }
        if let Some(s) = cap.saturation_dn
            && s != acq.saturation_dn
        {
            return Err(format!(
                "saturation level {} DN, the plan's [capture] saturation-dn is {s}",
                acq.saturation_dn
            ));
        }
    }
    check_segments(&summary.segments)?;
    let s = &summary.segments;
    let label = |k: u64| {
        let inside = |span: Option<(u64, u64)>| span.is_some_and(|(a, b)| k >= a && k < b);
        if inside(Some(s.pwm)) {
            Some(Segment::Pwm)
        } else if inside(s.off) {
            Some(Segment::Off)
        } else if inside(s.on) {
            Some(Segment::On)
        } else {
            None
        }
    };
    // Frames in the union of the spans, counted span by span (the frame
    // count is data, so no loop over it).
    let mut spans: Vec<(u64, u64)> = [Some(s.pwm), s.off, s.on].into_iter().flatten().collect();
    spans.sort_unstable();
    let mut expected = 0u64;
    let mut covered = 0u64;
    for (a, b) in spans {
        let a = a.max(covered);
        if b > a {
            expected += b - a;
            covered = b;
        }
    }
    if let Some(f) = acq
        .frames
        .iter()
        .find(|f| label(f.index) != Some(f.segment))
    {
        return Err(format!(
            "frame {} is labelled {}, but the capture's segments put it {}",
            f.index,
            f.segment.as_str(),
            label(f.index).map_or("in none", |l| l.as_str())
        ));
    }
    if acq.frames.len() as u64 != expected {
        return Err(format!(
            "{} frames, but the capture's segments hold {expected}",
            acq.frames.len()
        ));
    }
    Ok(())
}

/// Segment spans inside the capture, start before end; every number finite.
fn check_segments(s: &SegmentsFound) -> Result<(), String> {
    let n = s.capture_frames;
    let span_ok = |span: (u64, u64)| span.0 < span.1 && span.1 <= n;
    for (what, span) in [("PWM", Some(s.pwm)), ("OFF", s.off), ("ON", s.on)] {
        if let Some(span) = span
            && !span_ok(span)
        {
            return Err(format!(
                "the {what} segment, frames {}..{}, is not inside the capture's {n} frames",
                span.0, span.1
            ));
        }
    }
    let mut numbers = vec![s.pwm_time_s.0, s.pwm_time_s.1];
    for t in [s.off_time_s, s.on_time_s].into_iter().flatten() {
        numbers.extend([t.0, t.1]);
    }
    numbers.extend(s.threshold_dn);
    numbers.extend(s.settle_s);
    if let Some(l) = s.levels_dn {
        numbers.extend([l.off, l.on, Some(l.pwm_mean)].into_iter().flatten());
    }
    numbers.extend(s.steps.iter().map(|st| st.time_s));
    numbers.extend(s.signal.iter().flat_map(|&(t, v)| [t, v]));
    if numbers.iter().any(|v| !v.is_finite()) {
        return Err("the capture's segment summary holds a number that is not finite".to_string());
    }
    // Detection reads every frame of the capture and keeps its signal for
    // the trace chart; segments given in the plan have none.
    let signal_frames = match s.method {
        SegmentMethod::Detected => n,
        SegmentMethod::Plan => 0,
    };
    if s.signal.len() as u64 != signal_frames {
        return Err(format!(
            "the segment-detection signal has {} values, segments `{}` in a capture of {n} frames keep {signal_frames}",
            s.signal.len(),
            s.method
        ));
    }
    Ok(())
}

/// The shard's acquisition handed back to the runner, as if a backend had
/// just acquired it.
struct Replay {
    acquisition: Mutex<Option<Acquisition>>,
}

impl Backend for Replay {
    fn id(&self) -> &str {
        "shard"
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        self.acquisition
            .lock()
            .ok()
            .and_then(|mut a| a.take())
            .ok_or_else(|| BackendError {
                backend: self.id().to_string(),
                case: case.id.clone(),
                message: "the acquisition was taken already".to_string(),
            })
    }
}

/// The case evaluated again from its acquisition by [`runner::run_case`],
/// the evaluation `plan` runs: the shard's (or a partial store's)
/// metrics, KPIs, checks and verdict are replaced. The sample frame (a
/// picture, checked) is kept.
pub fn evaluate_again(plan: &Plan, shard: CaseResult) -> Result<CaseResult, String> {
    let replay = Replay {
        acquisition: Mutex::new(Some(shard.acquisition)),
    };
    let mut fresh = runner::run_case(plan, &shard.case, &replay).map_err(|e| match e {
        runner::RunError::BadTrace { message, .. } => message,
        other => other.to_string(),
    })?;
    // Bounded traces keep every figure finite; should one still not be,
    // it must not reach the report.
    let figures = ciborium::Value::serialized(&(&fresh.metrics, &fresh.p2020, &fresh.checks))
        .map_err(|e| format!("cannot evaluate the case: {e}"))?;
    if !all_finite(&figures) {
        return Err("its traces give a metric that is not a finite number".to_string());
    }
    fresh.sample_frame = shard.sample_frame;
    fresh.lit_frame = shard.lit_frame;
    Ok(fresh)
}

/// Whether every float in `v` is finite.
fn all_finite(v: &ciborium::Value) -> bool {
    use ciborium::Value;
    match v {
        Value::Float(x) => x.is_finite(),
        Value::Array(a) => a.iter().all(all_finite),
        Value::Map(m) => m.iter().all(|(k, v)| all_finite(k) && all_finite(v)),
        Value::Tag(_, v) => all_finite(v),
        _ => true,
    }
}

/// Which backend id a plan's shards must have recorded: the one its
/// backend reports, without building it (a captured plan's would read
/// every capture).
pub fn backend_id(plan: &Plan) -> String {
    match plan.dut.backend {
        BackendKind::Simulator => Simulator::new(plan).id().to_string(),
        BackendKind::Captured => "captured".to_string(),
        BackendKind::Command => "command".to_string(),
    }
}
