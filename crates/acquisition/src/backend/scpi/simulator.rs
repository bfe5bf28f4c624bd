//! A SCPI instrument simulator on 127.0.0.1, for tests and demonstrations
//! without hardware: it listens on a free port, records every line it is
//! sent (with the host-clock time and the connection's number), answers
//! `*IDN?`, the error query (anything ending in `ERR?`) and other queries
//! (`0`), and can be told to misbehave ([`Faults`]): push an error for a
//! command, never answer a query, drop a connection. With a log file, it
//! also appends each line there as it arrives, with the Unix time: other
//! processes (a simulated camera, a person with `tail -f`) then see what
//! the instrument was told and when.
//!
//! PyVISA-sim cannot stand in for it: it runs inside Python and opens no
//! socket, while ledflicker talks to instruments over TCP.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The identity the simulator answers to `*IDN?`.
pub const IDENTITY: &str = "ledflicker,SCPI simulator,0,1.0";

/// What the simulator does wrong, on purpose.
#[derive(Debug, Clone, Default)]
pub struct Faults {
    /// A line that contains this text pushes `(code, message)` onto the
    /// error queue, as an instrument does for a value out of range.
    pub error_on: Option<(String, i64, String)>,
    /// A query that contains this text is never answered.
    pub stall_on: Option<String>,
    /// The first connection is closed after this many lines (the lines
    /// after it are not received).
    pub drop_after: Option<usize>,
}

/// One line received.
#[derive(Debug, Clone, PartialEq)]
pub struct Received {
    /// Connection number, from 0 in the order they were accepted.
    pub connection: usize,
    /// When it arrived, from the simulator's start.
    pub at: Duration,
    /// The line, without its end.
    pub line: String,
}

#[derive(Debug, Default)]
struct State {
    received: Vec<Received>,
    log: Option<std::fs::File>,
    errors: VecDeque<(i64, String)>,
    connections: usize,
    dropped: bool,
}

/// A running simulator; stops when dropped.
#[derive(Debug)]
pub struct SimInstrument {
    port: u16,
    state: Arc<Mutex<State>>,
    stop: Arc<AtomicBool>,
    accept: Option<std::thread::JoinHandle<()>>,
}

impl SimInstrument {
    /// Starts a simulator on 127.0.0.1 at a free port.
    pub fn start(faults: Faults) -> std::io::Result<SimInstrument> {
        Self::start_at(0, faults, None)
    }

    /// Starts a simulator on 127.0.0.1 at `port` (0: a free one). With
    /// `log`, every line received is appended to that file as
    /// `<Unix time, s> <connection> <line>`, written as it arrives.
    pub fn start_at(
        port: u16,
        faults: Faults,
        log: Option<&std::path::Path>,
    ) -> std::io::Result<SimInstrument> {
        let listener = TcpListener::bind(("127.0.0.1", port))?;
        listener.set_nonblocking(true)?;
        let port = listener.local_addr()?.port();
        let log = match log {
            Some(path) => Some(
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)?,
            ),
            None => None,
        };
        let state = Arc::new(Mutex::new(State {
            log,
            ..State::default()
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let started = Instant::now();
        let accept = {
            let (state, stop) = (Arc::clone(&state), Arc::clone(&stop));
            std::thread::spawn(move || {
                while !stop.load(Ordering::SeqCst) {
                    match listener.accept() {
                        Ok((stream, _)) => {
                            let number = match state.lock() {
                                Ok(mut s) => {
                                    s.connections += 1;
                                    s.connections - 1
                                }
                                Err(_) => return,
                            };
                            let conn = Connection {
                                number,
                                state: Arc::clone(&state),
                                faults: faults.clone(),
                                started,
                                stop: Arc::clone(&stop),
                            };
                            std::thread::spawn(move || conn.serve(stream));
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
            })
        };
        Ok(SimInstrument {
            port,
            state,
            stop,
            accept: Some(accept),
        })
    }

    /// The TCP port it listens on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Every line received, in order of arrival.
    pub fn received(&self) -> Vec<Received> {
        self.state
            .lock()
            .map(|s| s.received.clone())
            .unwrap_or_default()
    }

    /// The lines received, text only.
    pub fn lines(&self) -> Vec<String> {
        self.received().into_iter().map(|r| r.line).collect()
    }

    /// How many connections were accepted.
    pub fn connections(&self) -> usize {
        self.state.lock().map(|s| s.connections).unwrap_or(0)
    }
}

impl Drop for SimInstrument {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.accept.take() {
            let _ = t.join();
        }
    }
}

struct Connection {
    number: usize,
    state: Arc<Mutex<State>>,
    faults: Faults,
    started: Instant,
    stop: Arc<AtomicBool>,
}

impl Connection {
    fn serve(self, stream: TcpStream) {
        let _ = stream.set_nonblocking(false);
        let _ = stream.set_read_timeout(Some(Duration::from_millis(50)));
        let Ok(mut writer) = stream.try_clone() else {
            return;
        };
        let mut reader = BufReader::new(stream);
        let mut seen = 0usize;
        let mut line = String::new();
        while !self.stop.load(Ordering::SeqCst) {
            match reader.read_line(&mut line) {
                Ok(0) => return,
                Ok(_) if line.ends_with('\n') => {}
                // A partial line before the read timed out: keep it.
                Ok(_) => continue,
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    continue;
                }
                Err(_) => return,
            }
            let text = line.trim_end_matches(['\r', '\n']).to_string();
            line.clear();
            let Some(answer) = self.take(&text, &mut seen) else {
                return;
            };
            if let Some(answer) = answer
                && writer.write_all(format!("{answer}\n").as_bytes()).is_err()
            {
                return;
            }
        }
    }

    /// Records `text` and returns the answer: `None` to drop the
    /// connection, `Some(None)` for no answer.
    fn take(&self, text: &str, seen: &mut usize) -> Option<Option<String>> {
        let Ok(mut s) = self.state.lock() else {
            return None;
        };
        if let Some(limit) = self.faults.drop_after
            && self.number == 0
            && !s.dropped
            && *seen >= limit
        {
            s.dropped = true;
            return None;
        }
        *seen += 1;
        if let Some(log) = s.log.as_mut() {
            let unix = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap_or_default()
                .as_secs_f64();
            // A log that cannot be written loses lines, not the instrument.
            let _ = writeln!(log, "{unix:.6} {} {text}", self.number);
        }
        s.received.push(Received {
            connection: self.number,
            at: self.started.elapsed(),
            line: text.to_string(),
        });
        if let Some((pattern, code, message)) = &self.faults.error_on
            && text.contains(pattern.as_str())
        {
            s.errors.push_back((*code, message.clone()));
        }
        if !text.trim_end().ends_with('?') {
            return Some(None);
        }
        if let Some(pattern) = &self.faults.stall_on
            && text.contains(pattern.as_str())
        {
            return Some(None);
        }
        let upper = text.to_ascii_uppercase();
        let answer = if upper.starts_with("*IDN?") {
            IDENTITY.to_string()
        } else if upper.ends_with("ERR?") {
            match s.errors.pop_front() {
                Some((code, message)) => format!("{code},\"{message}\""),
                None => "+0,\"No error\"".to_string(),
            }
        } else {
            "0".to_string()
        };
        Some(Some(answer))
    }
}
