//! The runner: test cases -> backend -> metrics -> verdicts, in parallel.
//!
//! Cases run on rayon's pool; results come back in plan order and depend
//! only on the plan and its seed, never on the thread count or scheduling.
//! Progress is reported through a callback; the runner never prints.

pub use ledflicker_results::cases::{CHUNK, CaseReadError, CaseResult, CaseSource, for_each_chunk};
use rayon::prelude::*;

use crate::backend::{Backend, BackendError};
use ledflicker_metrics::metrics::flicker::Segment;
use ledflicker_metrics::metrics::p2020::{self};
use ledflicker_metrics::metrics::verdict::{CaseConditions, RoiFigures, effective_basis};
use ledflicker_metrics::metrics::{Verdict, chromaticity, evaluate_case, evaluate_roi, visibility};
use ledflicker_plan::plan::RoiKind;
use ledflicker_plan::plan::{BlackLevel, Plan, TestCase};

/// What the runner tells its caller while it works.
#[derive(Debug, Clone, Copy)]
pub enum RunEvent<'a> {
    /// The run starts with this many cases.
    Started {
        /// Number of cases.
        total: usize,
    },
    /// A case finished (cases finish in any order).
    CaseFinished {
        /// The case.
        case: &'a TestCase,
        /// Its verdict.
        verdict: Verdict,
    },
}

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A backend could not acquire a case.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// A trace came back without PWM frames or with the wrong shape.
    #[error("case `{case}`: {message}")]
    BadTrace {
        /// Case id.
        case: String,
        /// What is wrong.
        message: String,
    },
    /// SIGINT or SIGTERM asked the run to stop.
    #[error(transparent)]
    Interrupted(#[from] crate::interrupt::Interrupted),
    /// The thread pool could not be built.
    #[error("cannot start {threads} worker threads: {message}")]
    Threads {
        /// Threads asked for.
        threads: usize,
        /// Cause.
        message: String,
    },
}

/// Runs `cases` of `plan` on `backend`, with `threads` workers (default:
/// rayon's, one per core), and returns their results in case order.
/// `on_event` is called from worker threads.
pub fn run(
    plan: &Plan,
    cases: &[TestCase],
    backend: &dyn Backend,
    threads: Option<usize>,
    on_event: &(dyn Fn(RunEvent<'_>) + Sync),
) -> Result<Vec<CaseResult>, RunError> {
    let options = RunOptions {
        threads,
        sample_frames: false,
    };
    let mut results = InOrder(vec![None; cases.len()]);
    run_streaming(plan, cases, backend, options, on_event, &mut results)?;
    Ok(results.0.into_iter().flatten().collect())
}

/// A sink that keeps every case, in case order.
struct InOrder(Vec<Option<CaseResult>>);

impl CaseSink for InOrder {
    type Error = RunError;
    type Item = CaseResult;

    fn prepare(result: CaseResult) -> CaseResult {
        result
    }

    fn put(&mut self, position: usize, result: CaseResult) -> Result<(), RunError> {
        self.0[position] = Some(result);
        Ok(())
    }
}

/// How [`run_streaming`] runs.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// Worker threads (default: rayon's, one per core, or more where the
    /// backend's cases wait on other processes: [`Backend::cases_at_once`]).
    pub threads: Option<usize>,
    /// Render each case's sample frame in its worker ([`render_sample_frame`]).
    pub sample_frames: bool,
}

/// Where [`run_streaming`] hands finished cases, on the calling thread.
pub trait CaseSink {
    /// The sink's error; a run error becomes one.
    type Error: From<RunError>;
    /// What a case's worker hands the sink.
    type Item: Send;
    /// Turns a finished case into the sink's item, in the case's worker:
    /// work done here (encoding a case for the store, say) runs on every
    /// core, while [`CaseSink::put`] runs on one thread for the whole run.
    fn prepare(result: CaseResult) -> Self::Item;
    /// Takes the case at `position` of the run's cases.
    fn put(&mut self, position: usize, item: Self::Item) -> Result<(), Self::Error>;
    /// No case has finished for [`IDLE`]: a moment to flush.
    fn idle(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// How long the sink waits for a case before [`CaseSink::idle`].
pub const IDLE: std::time::Duration = std::time::Duration::from_millis(250);

/// Cases finished but not yet taken by the sink, per worker: enough that a
/// worker rarely waits, few enough that memory does not grow with the run.
const QUEUE_PER_WORKER: usize = 2;

/// Runs `cases` and hands each finished case, with its position in
/// `cases`, to `sink` on the calling thread as soon as it finishes (in any
/// order). Workers wait when the sink falls behind by a few cases (a
/// bounded channel), so a run holds a few cases in memory whatever its
/// size. The first error (a case's, or the sink's) stops the run.
pub fn run_streaming<S: CaseSink>(
    plan: &Plan,
    cases: &[TestCase],
    backend: &dyn Backend,
    options: RunOptions,
    on_event: &(dyn Fn(RunEvent<'_>) + Sync),
    sink: &mut S,
) -> Result<(), S::Error> {
    use std::sync::mpsc::RecvTimeoutError;
    on_event(RunEvent::Started { total: cases.len() });
    let threads = options.threads.or_else(|| {
        let at_once = backend.cases_at_once()?.min(cases.len());
        (at_once > rayon::current_num_threads()).then_some(at_once)
    });
    let pool = match threads {
        None => None,
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| RunError::Threads {
                    threads: n,
                    message: e.to_string(),
                })?,
        ),
    };
    let workers = pool
        .as_ref()
        .map_or_else(rayon::current_num_threads, |p| p.current_num_threads());
    let (tx, rx) = std::sync::mpsc::sync_channel(QUEUE_PER_WORKER * workers.max(1));
    std::thread::scope(|scope| {
        let work = scope.spawn(move || {
            let work = || {
                cases
                    .par_iter()
                    .enumerate()
                    .try_for_each_with(tx, |tx, (i, case)| {
                        let result = finish_case(plan, case, backend, options.sample_frames)
                            .map_err(Some)?;
                        on_event(RunEvent::CaseFinished {
                            case,
                            verdict: result.verdict,
                        });
                        // A closed channel means the sink failed: stop quietly,
                        // the sink's error is the one reported.
                        tx.send((i, S::prepare(result)))
                            .map_err(|_| None::<RunError>)
                    })
            };
            match &pool {
                None => work(),
                Some(p) => p.install(work),
            }
        });
        let failed = loop {
            let taken = match rx.recv_timeout(IDLE) {
                Ok((i, result)) => sink.put(i, result),
                Err(RecvTimeoutError::Timeout) => sink.idle(),
                Err(RecvTimeoutError::Disconnected) => break None,
            };
            if let Err(e) = taken {
                break Some(e);
            }
        };
        // Dropping the receiver makes every worker's next send fail.
        drop(rx);
        let worked = work.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        match (failed, worked) {
            (Some(e), _) => Err(e),
            (None, Err(Some(e))) => Err(e.into()),
            (None, _) => Ok(()),
        }
    })
}

/// One case in its worker: acquired, evaluated and, when asked, its sample
/// frame rendered. Stops between cases once Ctrl-C or SIGTERM arrived; a
/// case that fails because its rig was killed for the same reason is
/// reported as the interruption.
fn finish_case(
    plan: &Plan,
    case: &TestCase,
    backend: &dyn Backend,
    sample_frame: bool,
) -> Result<CaseResult, RunError> {
    crate::interrupt::check()?;
    let as_interrupted =
        |e: RunError| crate::interrupt::check().map_or_else(RunError::Interrupted, |()| e);
    let mut result = run_case(plan, case, backend).map_err(as_interrupted)?;
    if sample_frame {
        render_sample_frame(plan, &mut result, backend).map_err(as_interrupted)?;
    }
    Ok(result)
}

/// Acquires and evaluates one case.
pub fn run_case(
    plan: &Plan,
    case: &TestCase,
    backend: &dyn Backend,
) -> Result<CaseResult, RunError> {
    let acquisition = backend.acquire(case)?;
    let bad = |message: String| RunError::BadTrace {
        case: case.id.clone(),
        message,
    };
    if acquisition.rois.len() != plan.rois.len() {
        return Err(bad(format!(
            "backend returned {} ROI traces for {} ROIs",
            acquisition.rois.len(),
            plan.rois.len()
        )));
    }
    let segments: Vec<_> = acquisition.frames.iter().map(|f| f.segment).collect();
    let mut metrics = Vec::with_capacity(plan.rois.len());
    let mut p2020s = Vec::with_capacity(plan.rois.len());
    for (trace, roi) in acquisition.rois.iter().zip(&plan.rois) {
        if trace.luma.len() != segments.len() {
            return Err(bad(format!(
                "ROI `{}` has {} luma values for {} frames",
                trace.name,
                trace.luma.len(),
                segments.len()
            )));
        }
        if let Some((lo, hi)) = trace.phase_envelope
            && !(lo.is_finite() && hi.is_finite())
        {
            return Err(bad(format!(
                "ROI `{}` worst case over phase is not finite",
                trace.name
            )));
        }
        if let Some(i) = trace.luma.iter().position(|x| !x.is_finite()) {
            return Err(bad(format!(
                "ROI `{}` luma of frame {i} is not a finite number",
                trace.name
            )));
        }
        let m = evaluate_roi(
            &trace.luma,
            &segments,
            trace.phase_envelope,
            acquisition.saturation_dn,
        )
        .ok_or_else(|| bad("the trace has no PWM frames".to_string()))?;
        let mut m = m;
        m.visibility = plan
            .display
            .as_ref()
            .map(|d| visibility::of_trace(d, &acquisition.frames, &trace.luma, roi));
        m.colour = match plan.colour.as_ref().zip(trace.rgb.as_ref()) {
            None => None,
            Some((c, rgb)) => {
                let black = match plan.capture.as_ref().map(|c| c.black_level) {
                    Some(BlackLevel::OffSegment) => chromaticity::off_segment_black(rgb, &segments)
                        .ok_or_else(|| {
                            bad(format!(
                                "ROI `{}`: capture.black-level = \"off-segment\" takes each colour plane's black from the OFF frames, and this case has none; give its OFF segment (off-frames or off-time-s), or use black-level = \"camera\"",
                                trace.name
                            ))
                        })?,
                    _ => [plan.dut.camera.black_level_dn; 3],
                };
                let mut figures = chromaticity::of_trace(c, rgb, &segments, black);
                figures.planes = chromaticity::plane_kpis(rgb, &segments, &plan.p2020);
                let clipped = chromaticity::clipped_planes(rgb, acquisition.saturation_dn);
                // The ROI is flagged as luma saturation flags it.
                m.saturated |= !clipped.is_empty();
                figures.mark_clipped(clipped);
                Some(figures)
            }
        };
        metrics.push(m);
        p2020s.extend(p2020::evaluate(&trace.luma, &segments, &plan.p2020));
    }
    let figures: Vec<RoiFigures<'_>> = plan
        .rois
        .iter()
        .zip(&metrics)
        .enumerate()
        .map(|(i, (roi, m))| RoiFigures {
            roi,
            metrics: m,
            p2020: p2020s.get(i),
        })
        .collect();
    let eval = evaluate_case(
        &case_conditions(plan, case),
        &figures,
        &plan.thresholds,
        effective_basis(plan.dut.backend, &plan.thresholds),
    );
    Ok(CaseResult {
        case: case.clone(),
        acquisition,
        metrics,
        verdict: eval.verdict,
        checks: eval.checks,
        not_judged: eval.not_judged,
        not_checked: eval.not_checked,
        sample_frame: None,
        p2020: p2020s,
        lit_frame: None,
    })
}

/// The conditions a verdict needs: a captured case's unknown conditions are
/// 0 in its [`TestCase`], and its `informative` flag is in the plan.
fn case_conditions(plan: &Plan, case: &TestCase) -> CaseConditions {
    let known = |v: f64| (v > 0.0).then_some(v);
    let informative = plan
        .capture
        .as_ref()
        .and_then(|c| c.cases.iter().find(|k| k.id == case.id))
        .is_some_and(|k| k.informative);
    CaseConditions {
        frequency_hz: known(case.frequency_hz),
        light_lux: known(case.light_lux),
        informative,
    }
}

/// The PWM-segment frame with the lowest luma in the first LED ROI: the
/// frame where the light looks most OFF (Deegan 2018, Figure 11).
pub fn darkest_pwm_frame(plan: &Plan, result: &CaseResult) -> Option<u64> {
    let i = plan.rois.iter().position(|r| r.kind == RoiKind::Led)?;
    let acq = &result.acquisition;
    acq.frames
        .iter()
        .zip(&acq.rois.get(i)?.luma)
        .filter(|(f, _)| f.segment == Segment::Pwm)
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(f, _)| f.index)
}

/// Renders each case's darkest PWM frame, in parallel, where the backend
/// can; full frames are made only here, never for the metrics.
pub fn render_sample_frames(
    plan: &Plan,
    results: &mut [CaseResult],
    backend: &dyn Backend,
) -> Result<(), RunError> {
    results.par_iter_mut().try_for_each(|r| {
        crate::interrupt::check()?;
        render_sample_frame(plan, r, backend)
    })
}

/// Renders one case's darkest PWM frame into its result, and its capture's
/// lit frame ([`ledflicker_plan::trace::LitFrame`]) when it names one,
/// where the backend can.
pub fn render_sample_frame(
    plan: &Plan,
    result: &mut CaseResult,
    backend: &dyn Backend,
) -> Result<(), RunError> {
    let lit = result
        .acquisition
        .capture
        .as_ref()
        .and_then(|c| c.lit_frame);
    // Both frames in one request: a captured video's are then sought in
    // one FFmpeg process, which pays its start-up once.
    let sample = darkest_pwm_frame(plan, result);
    let lit = lit.map(|lit| lit.frame);
    let wanted: Vec<u64> = sample
        .into_iter()
        .chain(lit.filter(|&l| Some(l) != sample))
        .collect();
    let mut rendered = backend.render_frames(&result.case, &wanted).into_iter();
    let sample_frame = sample.and_then(|_| rendered.next().flatten()).transpose()?;
    let lit_frame = match (lit, sample) {
        (Some(l), Some(s)) if l == s => sample_frame.clone(),
        (Some(_), _) => rendered.next().flatten().transpose()?,
        (None, _) => None,
    };
    if sample_frame.is_some() {
        result.sample_frame = sample_frame;
    }
    if lit_frame.is_some() {
        result.lit_frame = lit_frame;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_plan::trace::{Acquisition, FrameInfo, RoiTrace, Segment};

    /// What the fake backend does for every case.
    #[derive(Clone, Copy)]
    enum Fault {
        None,
        Fails,
        MissingRoi,
        ShortTrace,
        NanLuma,
        NoPwmFrames,
        InfiniteEnvelope,
    }

    /// A backend that returns a fixed, well-formed trace (OFF, ON, then a
    /// PWM segment alternating between two levels), broken as `fault` says.
    struct Fake {
        rois: usize,
        fault: Fault,
    }

    impl Backend for Fake {
        fn id(&self) -> &str {
            "fake"
        }

        fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
            if let Fault::Fails = self.fault {
                return Err(BackendError {
                    backend: "fake".into(),
                    case: case.id.clone(),
                    message: "the rig is unplugged".into(),
                });
            }
            let pwm = if let Fault::NoPwmFrames = self.fault {
                Segment::On
            } else {
                Segment::Pwm
            };
            let segment = |i: u64| match i {
                0..10 => Segment::Off,
                10..20 => Segment::On,
                _ => pwm,
            };
            let frames: Vec<FrameInfo> = (0..60)
                .map(|i| FrameInfo {
                    index: i,
                    time_s: i as f64 / 30.0,
                    segment: segment(i),
                })
                .collect();
            let level = |i: u64| match segment(i) {
                Segment::Off => 10.0,
                Segment::On => 100.0,
                Segment::Pwm => [60.0, 140.0][(i % 2) as usize],
            };
            let mut luma: Vec<f64> = (0..60).map(level).collect();
            let mut envelope = None;
            match self.fault {
                Fault::ShortTrace => luma.truncate(59),
                Fault::NanLuma => luma[30] = f64::NAN,
                Fault::InfiniteEnvelope => envelope = Some((0.0, f64::INFINITY)),
                _ => {}
            }
            let rois = if let Fault::MissingRoi = self.fault {
                self.rois - 1
            } else {
                self.rois
            };
            Ok(Acquisition {
                frames,
                rois: (0..rois)
                    .map(|k| RoiTrace {
                        name: format!("roi{k}"),
                        luma: luma.clone(),
                        phase_envelope: envelope,
                        rgb: None,
                    })
                    .collect(),
                saturation_dn: 250.0,
                capture: None,
            })
        }
    }

    fn plan() -> Plan {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("test-plans/daylight.toml");
        ledflicker_plan::plan::load(&path).unwrap()
    }

    fn run_with(fault: Fault) -> Result<Vec<CaseResult>, RunError> {
        let plan = plan();
        let cases = ledflicker_plan::plan::expand_cases(&plan);
        let fake = Fake {
            rois: plan.rois.len(),
            fault,
        };
        run(&plan, &cases[..3], &fake, Some(1), &|_| {})
    }

    #[test]
    fn a_well_formed_trace_is_evaluated() {
        let results = run_with(Fault::None).unwrap();
        assert_eq!(results.len(), 3);
        // PWM alternates 60/140 DN over a 10 DN OFF: PF = 80/200 = 40 %.
        let pf = results[0].metrics[0].percent_flicker.value.unwrap();
        assert!((pf - 40.0).abs() < 1e-9, "{pf}");
    }

    #[test]
    fn every_broken_acquisition_is_a_named_error() {
        let cases = [
            (Fault::Fails, "the rig is unplugged"),
            (Fault::MissingRoi, "ROI traces for"),
            (Fault::ShortTrace, "59 luma values for 60 frames"),
            (Fault::NanLuma, "luma of frame 30 is not a finite number"),
            (Fault::NoPwmFrames, "no PWM frames"),
            (
                Fault::InfiniteEnvelope,
                "worst case over phase is not finite",
            ),
        ];
        for (fault, words) in cases {
            let e = run_with(fault).unwrap_err();
            let text = e.to_string();
            assert!(text.contains(words), "{text}");
            assert!(text.contains("2000lux-"), "names the case: {text}");
            match (fault, &e) {
                (Fault::Fails, RunError::Backend(_)) => {}
                (Fault::Fails, _) => panic!("a backend failure is RunError::Backend: {e:?}"),
                (_, RunError::BadTrace { .. }) => {}
                _ => panic!("a malformed trace is RunError::BadTrace: {e:?}"),
            }
        }
    }

    /// A backend whose cases wait on other processes: each acquisition
    /// waits (at most a few seconds) until `want` cases are in it at once.
    struct Waiting {
        inner: Fake,
        want: usize,
        in_flight: std::sync::Mutex<usize>,
        most: std::sync::Mutex<usize>,
        changed: std::sync::Condvar,
    }

    impl Backend for Waiting {
        fn id(&self) -> &str {
            "waiting"
        }

        fn cases_at_once(&self) -> Option<usize> {
            Some(self.want)
        }

        fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
            let n = {
                let mut n = self.in_flight.lock().unwrap();
                *n += 1;
                *n
            };
            let mut most = self.most.lock().unwrap();
            *most = (*most).max(n);
            self.changed.notify_all();
            // Until `want` were in at once (they may have left since).
            let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
            while *most < self.want && std::time::Instant::now() < deadline {
                most = self
                    .changed
                    .wait_timeout(most, std::time::Duration::from_millis(50))
                    .unwrap()
                    .0;
            }
            drop(most);
            let acq = self.inner.acquire(case);
            *self.in_flight.lock().unwrap() -= 1;
            acq
        }
    }

    /// With no thread count set, a backend that asks for more cases at once
    /// than there are cores gets them.
    #[test]
    fn a_backend_whose_cases_wait_runs_as_many_as_it_asks() {
        let plan = plan();
        let cases = ledflicker_plan::plan::expand_cases(&plan);
        let cores = rayon::current_num_threads();
        {
            let (threads, want, expect) = (None, cores + 2, cores + 2);
            let backend = Waiting {
                inner: Fake {
                    rois: plan.rois.len(),
                    fault: Fault::None,
                },
                want,
                in_flight: std::sync::Mutex::new(0),
                most: std::sync::Mutex::new(0),
                changed: std::sync::Condvar::new(),
            };
            let cases: Vec<TestCase> = cases.iter().cycle().take(cores + 2).cloned().collect();
            let results = run(&plan, &cases, &backend, threads, &|_| {}).unwrap();
            assert_eq!(results.len(), cores + 2);
            let most = *backend.most.lock().unwrap();
            assert_eq!(most, expect, "threads {threads:?}, asked for {want}");
        }
    }
}
