//! The light source of a command plan, driven over SCPI (`[source]`,
//! docs/lab.md): a function generator or LED driver reached by an LXI raw
//! socket. Sits inside the command backend: for each case it runs the
//! sequence of [`case_steps`] (ON at 100 % duty, OFF, the case's PWM) while
//! the plan's command records the camera.
//!
//! - [`client`]: the TCP line client (time limits, no retries);
//! - [`Instrument`]: identity, the error queue read after every step, a
//!   dropped connection reopened and the step sent again, the safe state
//!   (output off);
//! - [`sequence`]: the timed sequence of one case, with step times taken
//!   from the host clock;
//! - [`light`]: the source inside the command backend, one case at a time;
//! - [`simulator`]: an instrument on 127.0.0.1 for tests and demonstrations.

pub mod client;
pub mod light;
pub mod sequence;
pub mod simulator;

use std::time::Duration;

use client::{Client, ScpiError};

use ledflicker_plan::plan::source::{CommandSet, SourceConfig};
use ledflicker_plan::plan::{Sequence, TestCase};

/// Most entries read from the error queue after one step: a queue is 10
/// to 20 deep on common generators, and an instrument that never answers
/// "no error" must not hold the run.
const MAX_QUEUE: usize = 32;

/// One step of a case's sequence: the lines sent, then the time until the
/// next step.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// "prepare", "on", "off", "pwm" or "end".
    pub name: &'static str,
    /// The SCPI lines, placeholders filled.
    pub lines: Vec<String>,
    /// Seconds from this step's start to the next step's.
    pub hold_s: f64,
}

/// Why the source failed.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The connection failed or an answer did not come.
    #[error(transparent)]
    Scpi(#[from] ScpiError),
    /// The instrument's error queue held errors after a step.
    #[error("the instrument reported {} after the `{step}` step ({}): {}", plural(.errors.len()), .lines.join("; "), .errors.iter().map(|(c, m)| format!("{c}, \"{m}\"")).collect::<Vec<_>>().join("; "))]
    Instrument {
        /// The step.
        step: String,
        /// Its lines.
        lines: Vec<String>,
        /// Code and message of each error, oldest first.
        errors: Vec<(i64, String)>,
    },
    /// The error query's answer was not `<code>,<message>`.
    #[error(
        "the instrument answered the error query `{query}` with `{answer}`, not `<code>,<message>`\n    hint: set [source.commands] error-query to the instrument's error query, or to \"\" if it has none"
    )]
    ErrorAnswer {
        /// The query.
        query: String,
        /// Its answer.
        answer: String,
    },
}

impl SourceError {
    /// True when the instrument could not be reached at all (off, another
    /// address, a firewall), rather than answering wrongly.
    pub fn is_connection(&self) -> bool {
        matches!(self, SourceError::Scpi(e) if e.is_connection())
    }
}

fn plural(n: usize) -> String {
    if n == 1 {
        "an error".to_string()
    } else {
        format!("{n} errors")
    }
}

/// A number as a SCPI parameter: at most 6 decimals, no trailing zeros
/// (`137`, `12.5`, `0.000001`), never an exponent.
pub fn scpi_number(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" || s.is_empty() {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// `lines` with their placeholders filled for `case` (`None`: the steady
/// commands, which take no frequency or duty).
fn fill(cfg: &SourceConfig, lines: &[String], case: Option<&TestCase>) -> Vec<String> {
    let mut values = vec![
        ("{channel}", cfg.channel.to_string()),
        ("{amplitude-vpp}", scpi_number(cfg.amplitude_vpp)),
        ("{offset-v}", scpi_number(cfg.offset_v)),
        ("{high-v}", scpi_number(cfg.high_v())),
        ("{low-v}", scpi_number(cfg.low_v())),
    ];
    if let Some(case) = case {
        values.push(("{frequency-hz}", scpi_number(case.frequency_hz)));
        values.push(("{duty-percent}", scpi_number(case.duty * 100.0)));
    } else {
        values.push(("{frequency-hz}", "0".to_string()));
        values.push(("{duty-percent}", "100".to_string()));
    }
    lines
        .iter()
        .map(|l| {
            values
                .iter()
                .fold(l.clone(), |acc, (k, v)| acc.replace(k, v))
        })
        .collect()
}

/// The steps of one case: `prepare` (output off, steady level set; then
/// the dark lead-in), `on` (output on: 100 % duty), `off` (output off, the
/// case's PWM set), `pwm` (output on), `end` (output off). Without an ON
/// segment (`on-s = 0`) there is no `on` step; a case at duty 1 gets the
/// steady level for its PWM (a square wave cannot reach 100 %).
pub fn case_steps(cfg: &SourceConfig, case: &TestCase, sequence: &Sequence) -> Vec<Step> {
    let c = &cfg.commands;
    let with = |a: &[String], b: &[String]| [a, b].concat();
    let steady = fill(cfg, &c.steady, None);
    let pwm = if case.duty >= 1.0 {
        steady.clone()
    } else {
        fill(cfg, &c.pwm, Some(case))
    };
    let on = fill(cfg, &c.output_on, None);
    let off = fill(cfg, &c.output_off, None);
    let mut steps = vec![Step {
        name: "prepare",
        lines: if sequence.on_s > 0.0 {
            with(&off, &steady)
        } else {
            off.clone()
        },
        hold_s: cfg.lead_in_s,
    }];
    if sequence.on_s > 0.0 {
        steps.push(Step {
            name: "on",
            lines: on.clone(),
            hold_s: sequence.on_s,
        });
    }
    steps.push(Step {
        name: "off",
        lines: with(&off, &pwm),
        hold_s: sequence.off_s,
    });
    steps.push(Step {
        name: "pwm",
        lines: on,
        hold_s: sequence.pwm_s,
    });
    steps.push(Step {
        name: "end",
        lines: off,
        hold_s: 0.0,
    });
    steps
}

/// The lines sent once after connecting: the identity query, the setup
/// lines (filled) and the error query.
pub fn connect_lines(cfg: &SourceConfig) -> Vec<String> {
    let c = &cfg.commands;
    let mut lines = vec![c.identify.clone()];
    lines.extend(fill(cfg, &c.setup, None));
    if !c.error_query.is_empty() {
        lines.push(c.error_query.clone());
    }
    lines
}

/// An instrument, connected.
#[derive(Debug)]
pub struct Instrument {
    cfg: SourceConfig,
    client: Client,
    identity: String,
}

impl Instrument {
    /// Connects and asks the identity (when the template has a query for
    /// it); sends nothing else.
    fn open(cfg: &SourceConfig) -> Result<Instrument, SourceError> {
        let timeout = Duration::from_secs_f64(cfg.timeout_s);
        let mut client = Client::connect(&cfg.host, cfg.port, timeout)?;
        let identity = if cfg.commands.identify.is_empty() {
            String::new()
        } else {
            client.query(&cfg.commands.identify)?.trim().to_string()
        };
        Ok(Instrument {
            cfg: cfg.clone(),
            client,
            identity,
        })
    }

    /// Connects, asks its identity, sends the setup lines and reads the
    /// error queue.
    pub fn connect(cfg: &SourceConfig) -> Result<Instrument, SourceError> {
        let mut inst = Instrument::open(cfg)?;
        let setup = fill(cfg, &cfg.commands.setup, None);
        inst.apply_lines("setup", &setup)?;
        Ok(inst)
    }

    /// Connects, asks the identity and reads the error queue, and sends
    /// nothing else: no setup line, nothing that lights the LED (`rig
    /// check`). Returns the identity and the queue's entries.
    pub fn probe(cfg: &SourceConfig) -> Result<(String, Vec<(i64, String)>), SourceError> {
        let mut inst = Instrument::open(cfg)?;
        let errors = inst.errors()?;
        Ok((inst.identity, errors))
    }

    /// Its answer to the identity query (`*IDN?`), trimmed.
    pub fn identity(&self) -> &str {
        &self.identity
    }

    /// `host:port`.
    pub fn address(&self) -> String {
        self.client.address()
    }

    /// The commands it is driven with.
    pub fn commands(&self) -> &CommandSet {
        &self.cfg.commands
    }

    /// The error queue's entries, oldest first, until it answers code 0;
    /// empty when it has no error query.
    pub fn errors(&mut self) -> Result<Vec<(i64, String)>, SourceError> {
        let query = self.cfg.commands.error_query.clone();
        let mut errors = Vec::new();
        if query.is_empty() {
            return Ok(errors);
        }
        for _ in 0..MAX_QUEUE {
            let answer = self.client.query(&query)?;
            let (code, message) = parse_error(&answer).ok_or_else(|| SourceError::ErrorAnswer {
                query: query.clone(),
                answer: answer.clone(),
            })?;
            if code == 0 {
                break;
            }
            errors.push((code, message));
        }
        Ok(errors)
    }

    /// Sends a step's lines and reads the error queue. A dropped
    /// connection is reopened (up to `[source] reconnects` times) and the
    /// whole step sent again: every line sets a state, so sending it twice
    /// is harmless, while a line sent into a closed connection is lost.
    pub fn apply_lines(&mut self, step: &str, lines: &[String]) -> Result<(), SourceError> {
        let mut attempt = 0;
        loop {
            match self.try_lines(lines) {
                Ok(errors) if errors.is_empty() => return Ok(()),
                Ok(errors) => {
                    return Err(SourceError::Instrument {
                        step: step.to_string(),
                        lines: lines.to_vec(),
                        errors,
                    });
                }
                Err(SourceError::Scpi(e)) if e.is_connection() && attempt < self.cfg.reconnects => {
                    attempt += 1;
                    std::thread::sleep(Duration::from_millis(200 * u64::from(attempt)));
                    // A reopen that fails counts as an attempt too.
                    let _ = self.client.reopen();
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn try_lines(&mut self, lines: &[String]) -> Result<Vec<(i64, String)>, SourceError> {
        for line in lines {
            self.client.send(line)?;
        }
        self.errors()
    }

    /// Puts the output off: the safe state, sent on success, on error and
    /// on Ctrl-C. A connection that broke is reopened first.
    pub fn output_off(&mut self) -> Result<(), SourceError> {
        let off = fill(&self.cfg, &self.cfg.commands.output_off, None);
        self.apply_lines("safe state (output off)", &off)
    }
}

/// `<code>,<message>` (SCPI's `-222,"Data out of range"`, `+0,"No error"`)
/// as the code and the message without quotes; a bare code is accepted.
pub fn parse_error(answer: &str) -> Option<(i64, String)> {
    let answer = answer.trim();
    let (code, message) = answer.split_once(',').unwrap_or((answer, ""));
    let code: i64 = code.trim().trim_start_matches('+').parse().ok()?;
    Some((code, message.trim().trim_matches('"').to_string()))
}

#[cfg(test)]
mod tests;
