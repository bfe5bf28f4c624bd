//! A raw-socket SCPI client on `std::net`: one TCP connection to an LXI
//! instrument's SCPI port (5025), lines ended by `\n`, a time limit on
//! connecting, writing and every answer.
//!
//! The client never retries by itself: a dropped connection is reported
//! as [`ScpiError::Connection`], and the caller ([`super::Instrument`])
//! reopens it and sends the whole step again, because a setting written
//! into a connection the instrument had already closed is lost without
//! an error on our side.

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// Longest answer line kept, bytes: an `*IDN?` or error message is short,
/// and an instrument that streams without a newline must not fill memory.
const MAX_LINE: usize = 64 * 1024;

/// Why talking to the instrument failed.
#[derive(Debug, thiserror::Error)]
pub enum ScpiError {
    /// The connection could not be opened, or broke (reset, closed).
    #[error("cannot reach the instrument at {address}: {source}")]
    Connection {
        /// `host:port`.
        address: String,
        /// The socket's error.
        #[source]
        source: std::io::Error,
    },
    /// No (whole) answer within the time limit.
    #[error("the instrument at {address} did not answer `{query}` within {seconds:.1} s")]
    Timeout {
        /// `host:port`.
        address: String,
        /// The query sent.
        query: String,
        /// The time limit.
        seconds: f64,
    },
    /// The answer was not a line of text.
    #[error("the instrument at {address} answered `{query}` with {what}")]
    BadAnswer {
        /// `host:port`.
        address: String,
        /// The query sent.
        query: String,
        /// What was wrong.
        what: String,
    },
}

impl ScpiError {
    /// True for a connection that broke or could not be opened: worth
    /// reopening.
    pub fn is_connection(&self) -> bool {
        matches!(self, ScpiError::Connection { .. })
    }
}

/// One connection to an instrument; [`Client::reopen`] replaces it.
#[derive(Debug)]
pub struct Client {
    host: String,
    port: u16,
    timeout: Duration,
    stream: Option<TcpStream>,
    /// Bytes read after the last whole line.
    pending: Vec<u8>,
}

impl Client {
    /// Connects to `host:port`, waiting at most `timeout`.
    pub fn connect(host: &str, port: u16, timeout: Duration) -> Result<Client, ScpiError> {
        let mut c = Client {
            host: host.to_string(),
            port,
            timeout,
            stream: None,
            pending: Vec::new(),
        };
        c.reopen()?;
        Ok(c)
    }

    /// `host:port`, for messages.
    pub fn address(&self) -> String {
        format!("{}:{}", self.host, self.port)
    }

    fn connection(&self, source: std::io::Error) -> ScpiError {
        ScpiError::Connection {
            address: self.address(),
            source,
        }
    }

    /// Closes the connection (if any) and opens a new one.
    pub fn reopen(&mut self) -> Result<(), ScpiError> {
        self.stream = None;
        self.pending.clear();
        let addrs: Vec<_> = (self.host.as_str(), self.port)
            .to_socket_addrs()
            .map_err(|e| self.connection(e))?
            .collect();
        let mut last = std::io::Error::new(std::io::ErrorKind::NotFound, "no address found");
        for addr in addrs {
            match TcpStream::connect_timeout(&addr, self.timeout) {
                Ok(s) => {
                    // SCPI lines are small and each waits for the last:
                    // Nagle's delay would hold every setting back.
                    s.set_nodelay(true).map_err(|e| self.connection(e))?;
                    s.set_write_timeout(Some(self.timeout))
                        .map_err(|e| self.connection(e))?;
                    self.stream = Some(s);
                    return Ok(());
                }
                Err(e) => last = e,
            }
        }
        Err(self.connection(last))
    }

    /// Sends one line (a `\n` is added).
    pub fn send(&mut self, line: &str) -> Result<(), ScpiError> {
        let Some(stream) = self.stream.as_mut() else {
            let e = std::io::Error::new(std::io::ErrorKind::NotConnected, "not connected");
            return Err(self.connection(e));
        };
        let mut bytes = Vec::with_capacity(line.len() + 1);
        bytes.extend_from_slice(line.as_bytes());
        bytes.push(b'\n');
        let written = stream.write_all(&bytes).and_then(|_| stream.flush());
        written.map_err(|e| {
            self.stream = None;
            self.connection(e)
        })
    }

    /// Sends `line` and reads one answer line, without its `\r\n`.
    pub fn query(&mut self, line: &str) -> Result<String, ScpiError> {
        self.send(line)?;
        let deadline = Instant::now() + self.timeout;
        loop {
            if let Some(end) = self.pending.iter().position(|&b| b == b'\n') {
                let raw: Vec<u8> = self.pending.drain(..=end).collect();
                let text = String::from_utf8_lossy(&raw);
                return Ok(text.trim_end_matches(['\r', '\n']).to_string());
            }
            if self.pending.len() > MAX_LINE {
                return Err(ScpiError::BadAnswer {
                    address: self.address(),
                    query: line.to_string(),
                    what: format!("more than {MAX_LINE} bytes without a line end"),
                });
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                // The answer may still come and would be taken for the
                // next query's: this connection is out of step.
                self.stream = None;
                return Err(ScpiError::Timeout {
                    address: self.address(),
                    query: line.to_string(),
                    seconds: self.timeout.as_secs_f64(),
                });
            }
            let Some(stream) = self.stream.as_mut() else {
                let e = std::io::Error::new(std::io::ErrorKind::NotConnected, "not connected");
                return Err(self.connection(e));
            };
            let mut buf = [0u8; 4096];
            let _ = stream.set_read_timeout(Some(left));
            match stream.read(&mut buf) {
                Ok(0) => {
                    self.stream = None;
                    let e = std::io::Error::new(
                        std::io::ErrorKind::ConnectionAborted,
                        "the instrument closed the connection",
                    );
                    return Err(self.connection(e));
                }
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock
                            | std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => {
                    self.stream = None;
                    return Err(self.connection(e));
                }
            }
        }
    }
}
