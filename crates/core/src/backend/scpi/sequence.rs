//! One case's timed sequence on the light source: the steps of
//! [`super::case_steps`], each held for its time measured on the host's
//! monotonic clock from the moment its first line was sent, so a slow
//! instrument shortens no segment. Every way out (the end, an instrument
//! error, a stop asked by the caller, Ctrl-C) leaves the output off.

use std::time::{Duration, Instant};

use super::{Instrument, SourceError, Step};
use crate::trace::SourceStep;

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
