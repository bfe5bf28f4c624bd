//! One case's timed sequence on the light source: the steps of
//! [`super::case_steps`], each held for its time measured on the host's
//! monotonic clock from the moment its first line was sent, so a slow
//! instrument shortens no segment. Every way out (the end, an instrument
//! error, a stop asked by the caller, Ctrl-C) leaves the output off.
//! [`timing_warnings`] compares the steps found in the recording with
//! the log.

use std::time::{Duration, Instant};

use super::{Instrument, SourceError, Step};
use ledflicker_plan::trace::{SourceStep, StepFound, StepKind, StepSource};

/// How often a hold looks at the stop flags.
const POLL: Duration = Duration::from_millis(5);

/// Why a sequence did not run to its end.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    /// The instrument failed or reported an error.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// SIGINT or SIGTERM.
    #[error("interrupted by {}", crate::interrupt::signal_name(*.signal))]
    Interrupted {
        /// The signal.
        signal: i32,
    },
    /// The caller asked it to stop (the capture command failed).
    #[error("stopped: the capture command ended first")]
    Stopped,
}

/// Runs `steps` on `inst`; step times are seconds from `start`. `stop`
/// is asked while holding: true ends the sequence early. The output is
/// off afterwards, whatever happened (when the instrument can be reached);
/// a failure to put it off is added to the error.
pub fn run(
    inst: &mut Instrument,
    steps: &[Step],
    start: Instant,
    stop: &dyn Fn() -> bool,
) -> Result<Vec<SourceStep>, SequenceError> {
    let mut log = Vec::with_capacity(steps.len());
    let outcome = (|| {
        for step in steps {
            let at = Instant::now();
            log.push(SourceStep {
                step: step.name.to_string(),
                time_s: at.duration_since(start).as_secs_f64(),
                commands: step.lines.clone(),
            });
            inst.apply_lines(step.name, &step.lines)?;
            hold(at + Duration::from_secs_f64(step.hold_s), stop)?;
        }
        Ok(())
    })();
    match outcome {
        Ok(()) => Ok(log),
        Err(e) => {
            // The last step may have been "end" (output off) itself; the
            // safe state is sent again regardless: it costs one line.
            if let Err(off) = inst.output_off() {
                eprintln!("warning: the light source's output could not be put off: {off}");
            }
            Err(e)
        }
    }
}

/// Waits until `until`, or a stop.
fn hold(until: Instant, stop: &dyn Fn() -> bool) -> Result<(), SequenceError> {
    loop {
        if let Some(signal) = crate::interrupt::requested() {
            return Err(SequenceError::Interrupted { signal });
        }
        if stop() {
            return Err(SequenceError::Stopped);
        }
        let now = Instant::now();
        if now >= until {
            return Ok(());
        }
        std::thread::sleep(POLL.min(until - now));
    }
}

/// Where the steps found in a recording disagree with the light source's
/// log by more than `frame_s`: the ON and OFF segments' lengths, each
/// between two steps seen in the luma, against the same steps' times on
/// the host clock. Lengths, not times, because the recording's first
/// frame comes an unknown start-up time after the command started.
pub fn timing_warnings(found: &[StepFound], log: &[SourceStep], frame_s: f64) -> Vec<String> {
    let seen = |kind: StepKind| {
        found
            .iter()
            .find(|s| s.kind == kind && s.from == StepSource::Luma)
            .map(|s| s.time_s)
    };
    let sent = |name: &str| log.iter().find(|s| s.step == name).map(|s| s.time_s);
    let mut warnings = Vec::new();
    for (segment, from, to) in [
        ("ON", StepKind::On, StepKind::Off),
        ("OFF", StepKind::Off, StepKind::Pwm),
    ] {
        let (Some(a), Some(b), Some(x), Some(y)) =
            (seen(from), seen(to), sent(from.as_str()), sent(to.as_str()))
        else {
            continue;
        };
        let (recorded, logged) = (b - a, y - x);
        if (recorded - logged).abs() > frame_s {
            warnings.push(format!(
                "the {segment} segment lasts {recorded:.3} s in the recording but {logged:.3} s in the light source's log, more than a frame ({frame_s:.3} s) apart: check the segments found, or give them in [capture]"
            ));
        }
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    fn found(kind: StepKind, time_s: f64) -> StepFound {
        StepFound {
            kind,
            frame: (time_s * 30.0) as u64,
            time_s,
            from: StepSource::Luma,
        }
    }

    fn sent(step: &str, time_s: f64) -> SourceStep {
        SourceStep {
            step: step.into(),
            time_s,
            commands: Vec::new(),
        }
    }

    #[test]
    fn segments_more_than_a_frame_off_the_log_are_warned_of() {
        let log = [
            sent("prepare", 0.0),
            sent("on", 1.0),
            sent("off", 3.0),
            sent("pwm", 5.0),
        ];
        // The recording started 0.7 s late: the same lengths, no warning.
        let same = [
            found(StepKind::On, 0.3),
            found(StepKind::Off, 2.3 + 0.02),
            found(StepKind::Pwm, 4.3),
        ];
        assert!(timing_warnings(&same, &log, 1.0 / 30.0).is_empty());
        // The OFF segment 0.1 s short in the recording.
        let short = [
            found(StepKind::On, 0.3),
            found(StepKind::Off, 2.3),
            found(StepKind::Pwm, 4.2),
        ];
        let w = timing_warnings(&short, &log, 1.0 / 30.0);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with("the OFF segment lasts 1.900 s in the recording but 2.000 s"),
            "{}",
            w[0]
        );
        // A step placed by timing, not seen, is not compared.
        let mut timed = short;
        timed[2].from = StepSource::Timing;
        assert!(timing_warnings(&timed, &log, 1.0 / 30.0).is_empty());
    }
}
