//! The light source inside the command backend: one connection for the
//! whole run, opened at the first case, and one case at a time on it (a
//! lab has one light), while the case's capture command records.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::sequence::{self, SequenceError};
use super::{Instrument, case_steps};
use ledflicker_plan::plan::source::SourceConfig;
use ledflicker_plan::plan::{Sequence, TestCase};
use ledflicker_plan::trace::SourceLog;

/// A plan's `[source]`, connected on first use.
#[derive(Debug, Clone)]
pub struct LightSource {
    cfg: SourceConfig,
    sequence: Sequence,
    instrument: Arc<Mutex<Option<Instrument>>>,
}

impl LightSource {
    /// The source of `cfg`, playing `sequence` for each case; nothing is
    /// connected yet.
    pub fn new(cfg: SourceConfig, sequence: Sequence) -> LightSource {
        LightSource {
            cfg,
            sequence,
            instrument: Arc::new(Mutex::new(None)),
        }
    }

    /// Seconds of darkness recorded before the ON step.
    pub fn lead_in_s(&self) -> f64 {
        self.cfg.lead_in_s
    }

    /// Plays `case`'s sequence while `record` runs (the capture command,
    /// started at the same moment, killed when `cancel` is set: the
    /// sequence failed). A `record` that fails stops the sequence; either
    /// way the output is left off. The error is the instrument's when the
    /// sequence failed, else `record`'s.
    pub fn during<T>(
        &self,
        case: &TestCase,
        record: impl FnOnce(&AtomicBool) -> Result<T, String>,
    ) -> Result<(T, SourceLog), String> {
        let mut slot = self
            .instrument
            .lock()
            .map_err(|_| "the light source's connection was lost by a failed case".to_string())?;
        if slot.is_none() {
            let inst = Instrument::connect(&self.cfg).map_err(|e| format!("light source: {e}"))?;
            *slot = Some(inst);
        }
        let Some(inst) = slot.as_mut() else {
            return Err("the light source is not connected".to_string());
        };
        let steps = case_steps(&self.cfg, case, &self.sequence);
        let cancel = AtomicBool::new(false);
        let ended = AtomicBool::new(false);
        let start = Instant::now();
        let (recorded, played) = std::thread::scope(|s| {
            let player = s.spawn(|| {
                let played = sequence::run(inst, &steps, start, &|| ended.load(Ordering::SeqCst));
                if played.is_err() {
                    cancel.store(true, Ordering::SeqCst);
                }
                played
            });
            let recorded = record(&cancel);
            if recorded.is_err() {
                ended.store(true, Ordering::SeqCst);
            }
            (recorded, player.join())
        });
        let log = match played {
            Ok(Ok(steps)) => steps,
            Ok(Err(SequenceError::Stopped)) => return Err(recorded.err().unwrap_or_default()),
            Ok(Err(e)) => return Err(format!("light source: {e}")),
            Err(_) => return Err("the light source's sequence panicked".to_string()),
        };
        let value = recorded?;
        Ok((
            value,
            SourceLog {
                instrument: self.cfg.instrument.name().to_string(),
                address: inst.address(),
                identity: inst.identity().to_string(),
                steps: log,
            },
        ))
    }
}
