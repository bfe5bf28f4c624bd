//! A lab-rig command as a contained process, for the command backend.
//!
//! The command starts in a process group of its own, so Ctrl-C on the
//! terminal reaches ledflicker only, and ledflicker decides: on time-out or
//! interrupt it kills the whole group (the command and everything it
//! started). The time-out counts from spawn and covers writing stdin (from
//! its own thread, so a command that never reads cannot block us), running,
//! and reading stderr. When the command exits, whatever it left running in
//! its group is killed too, and stderr is read for at most a short grace
//! period, so a background process that escaped the group and holds the
//! pipe does not hold the run. Only the last [`STDERR_TAIL`] bytes of
//! stderr are kept.

use std::io::{Read, Write};
use std::os::unix::process::CommandExt;
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Bytes of the command's stderr kept (the end of it).
pub const STDERR_TAIL: usize = 64 * 1024;

/// How long stderr is read after the command exited.
const STDERR_GRACE: Duration = Duration::from_millis(500);

/// Poll interval while the command runs.
const POLL: Duration = Duration::from_millis(10);

/// A command that ran to its end.
#[derive(Debug)]
pub struct Finished {
    /// Its exit status.
    pub status: ExitStatus,
    /// The last [`STDERR_TAIL`] bytes of its stderr, lossily decoded.
    pub stderr: String,
}

/// Why a command did not run to its end.
#[derive(Debug)]
pub enum RigError {
    /// It could not be started.
    Spawn(std::io::Error),
    /// It ran past the time-out and was killed with its group.
    TimedOut {
        /// The time-out.
        after: Duration,
        /// Its stderr so far.
        stderr: String,
    },
    /// A signal asked the run to stop; the group was killed.
    Interrupted {
        /// The signal.
        signal: i32,
    },
    /// Waiting for it failed.
    Wait(std::io::Error),
    /// The caller cancelled it (the light source failed); the group was
    /// killed.
    Cancelled,
}

/// The last [`STDERR_TAIL`] bytes of a stream.
#[derive(Debug, Default)]
struct Tail(Vec<u8>);

impl Tail {
    fn push(&mut self, bytes: &[u8]) {
        self.0.extend_from_slice(bytes);
        if self.0.len() > 2 * STDERR_TAIL {
            let cut = self.0.len() - STDERR_TAIL;
            self.0.drain(..cut);
        }
    }

    /// The kept bytes as text, with control characters escaped: the text
    /// goes into ledflicker's own messages and reports, where a rig's
    /// terminal escape codes (colours, cursor moves, a title change) or
    /// bidirectional overrides must not act on the user's terminal or hide
    /// what the message says.
    fn text(&self) -> String {
        let start = self.0.len().saturating_sub(STDERR_TAIL);
        escape_controls(&String::from_utf8_lossy(&self.0[start..]))
    }
}

/// `text` with every control character but newline and tab, and every
/// bidirectional embedding, override or isolate, written as `\x1b` or
/// `\u{202e}`.
pub fn escape_controls(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        let bidi = matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}');
        if (c.is_control() && c != '\n' && c != '\t') || bidi {
            if (c as u32) < 0x80 {
                out.push_str(&format!("\\x{:02x}", c as u32));
            } else {
                out.push_str(&format!("\\u{{{:x}}}", c as u32));
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// Runs `command` in its own process group with `stdin` on its standard
/// input, stdout discarded, and a time-out of `timeout` from spawn.
pub fn run(command: &mut Command, stdin: String, timeout: Duration) -> Result<Finished, RigError> {
    run_until(command, stdin, timeout, &AtomicBool::new(false))
}

/// [`run`], also killing the group as soon as `cancel` is set.
pub fn run_until(
    command: &mut Command,
    stdin: String,
    timeout: Duration,
    cancel: &AtomicBool,
) -> Result<Finished, RigError> {
    let start = Instant::now();
    let deadline = start + timeout;
    let mut child = command
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .map_err(RigError::Spawn)?;
    let pgid = child.id() as libc::pid_t;
    if let Some(mut pipe) = child.stdin.take() {
        // Detached: a command that never reads stdin blocks this thread
        // only until its group is killed (the pipe then breaks). A command
        // that does not read stdin closes it early; not an error.
        std::thread::spawn(move || {
            let _ = pipe.write_all(stdin.as_bytes());
        });
    }
    let tail = Arc::new(Mutex::new(Tail::default()));
    let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
    if let Some(mut pipe) = child.stderr.take() {
        let tail = Arc::clone(&tail);
        std::thread::spawn(move || {
            let mut buf = [0u8; 8192];
            while let Ok(n) = pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                if let Ok(mut t) = tail.lock() {
                    t.push(&buf[..n]);
                }
            }
            let _ = done_tx.send(());
        });
    } else {
        drop(done_tx);
    }
    let stderr = |tail: &Arc<Mutex<Tail>>| tail.lock().map(|t| t.text()).unwrap_or_default();
    loop {
        if let Some(signal) = crate::interrupt::requested() {
            kill_group(pgid);
            let _ = child.wait();
            return Err(RigError::Interrupted { signal });
        }
        if cancel.load(Ordering::SeqCst) {
            kill_group(pgid);
            let _ = child.wait();
            return Err(RigError::Cancelled);
        }
        match exited(pgid) {
            Ok(true) => break,
            Ok(false) if Instant::now() >= deadline => {
                kill_group(pgid);
                let _ = child.wait();
                // What it wrote before it was killed, without waiting for
                // a pipe that an escaped process may hold.
                let _ = done_rx.recv_timeout(STDERR_GRACE.min(POLL * 10));
                return Err(RigError::TimedOut {
                    after: timeout,
                    stderr: stderr(&tail),
                });
            }
            Ok(false) => std::thread::sleep(POLL),
            Err(e) => {
                kill_group(pgid);
                let _ = child.wait();
                return Err(RigError::Wait(e));
            }
        }
    }
    // The command has exited but is not reaped yet, so its pid (the group
    // id) cannot be reused: kill whatever it left running in its group.
    kill_group(pgid);
    let status = child.wait().map_err(RigError::Wait)?;
    let grace = deadline
        .saturating_duration_since(Instant::now())
        .min(STDERR_GRACE);
    let _ = done_rx.recv_timeout(grace);
    Ok(Finished {
        status,
        stderr: stderr(&tail),
    })
}

/// True once process `pid` has exited; it is left unreaped (a zombie).
fn exited(pid: libc::pid_t) -> std::io::Result<bool> {
    // SAFETY: waitid with WNOWAIT only inspects the child's state; `info`
    // is a zeroed siginfo_t that the call fills in.
    unsafe {
        let mut info: libc::siginfo_t = std::mem::zeroed();
        let r = libc::waitid(
            libc::P_PID,
            pid as libc::id_t,
            &mut info,
            libc::WEXITED | libc::WNOHANG | libc::WNOWAIT,
        );
        if r != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(info.si_pid() != 0)
    }
}

/// Sends SIGKILL to every process of group `pgid`.
fn kill_group(pgid: libc::pid_t) {
    ledflicker_plan::util::kill_group(pgid as u32);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(script: &str) -> Command {
        let mut c = Command::new("sh");
        c.args(["-c", script]);
        c
    }

    #[test]
    fn stderr_keeps_only_its_last_64_kib() {
        let mut t = Tail::default();
        for i in 0..100u8 {
            t.push(&vec![b'a' + i % 26; 4096]);
        }
        let s = t.text();
        assert_eq!(s.len(), STDERR_TAIL);
        assert!(s.ends_with(&"v".repeat(4096)), "{}", &s[s.len() - 10..]);
    }

    #[test]
    fn a_rigs_terminal_escape_codes_are_shown_not_sent_to_the_terminal() {
        let r = run(
            &mut sh(
                "printf 'ok \\033[31mred\\033]0;title\\007 \\342\\200\\256x\\r\\n' >&2; exit 3",
            ),
            String::new(),
            Duration::from_secs(10),
        )
        .unwrap();
        assert!(!r.status.success());
        assert_eq!(
            r.stderr,
            "ok \\x1b[31mred\\x1b]0;title\\x07 \\u{202e}x\\x0d\n"
        );
    }

    #[test]
    fn a_command_that_never_reads_a_large_stdin_still_times_out() {
        let t = Instant::now();
        let r = run(
            &mut sh("sleep 30"),
            "x".repeat(1 << 20),
            Duration::from_millis(300),
        );
        assert!(matches!(r, Err(RigError::TimedOut { .. })), "{r:?}");
        assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    }

    #[test]
    fn a_background_process_holding_stderr_does_not_hold_the_run() {
        let t = Instant::now();
        // `setsid` puts the sleeper outside the group, as an escaped
        // daemon would be; it keeps stderr open.
        let r = run(
            &mut sh("setsid sleep 8 & echo done >&2; exit 0"),
            String::new(),
            Duration::from_secs(20),
        )
        .unwrap();
        assert!(r.status.success());
        assert!(t.elapsed() < Duration::from_secs(4), "{:?}", t.elapsed());
    }

    #[test]
    fn the_whole_group_is_killed_on_time_out() {
        let dir = tempfile::tempdir().unwrap();
        let flag = dir.path().join("survived");
        let script = format!("(sleep 1; touch {}) & sleep 30", flag.display());
        let r = run(&mut sh(&script), String::new(), Duration::from_millis(200));
        assert!(matches!(r, Err(RigError::TimedOut { .. })), "{r:?}");
        std::thread::sleep(Duration::from_millis(1500));
        assert!(
            !flag.exists(),
            "a process of the rig's group outlived the time-out"
        );
    }
}
