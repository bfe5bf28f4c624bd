//! Ctrl-C and `kill`: SIGINT and SIGTERM become a flag that the runner, the
//! lab-rig backend and the report writer poll, so that a run stops between
//! cases, kills its rig's process group and leaves the old report in place.
//!
//! Sits beside the pipeline: `cli` installs the handler for `plan`; the
//! runner ([`crate::runner`]) and the command backend read [`requested`].
//! The handlers only store the signal number (async-signal-safe), and a
//! second Ctrl-C takes the default action, so it ends the process at once.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, LazyLock};

/// The signal that asked the run to stop, or 0.
static SIGNAL: LazyLock<Arc<AtomicUsize>> = LazyLock::new(|| Arc::new(AtomicUsize::new(0)));

/// Set by the first SIGINT or SIGTERM: a second one takes the default
/// action (the process ends at once).
static ASKED: LazyLock<Arc<AtomicBool>> = LazyLock::new(|| Arc::new(AtomicBool::new(false)));

/// Set by [`embed`]: the host process (Python) owns the signals.
static EMBEDDED: AtomicBool = AtomicBool::new(false);

/// Hands the signals to a host process that embeds the engine (the Python
/// package): [`install`] then installs no handler, since the host's own
/// handler must keep running (Python raises `KeyboardInterrupt` from it),
/// and a stop in a stage that cannot look at the flag ([`Prompt`]) waits
/// for that stage rather than end the host. The host asks for a stop with
/// [`request`] and clears it with [`clear`] before the next run.
pub fn embed() {
    EMBEDDED.store(true, Ordering::SeqCst);
}

/// Whether a host process embeds the engine ([`embed`]).
pub fn is_embedded() -> bool {
    EMBEDDED.load(Ordering::SeqCst)
}

/// Forgets a stop request, for a host that runs again after a stopped
/// run ([`embed`]); a command line process never runs twice.
pub fn clear() {
    SIGNAL.store(0, Ordering::SeqCst);
}

/// Installs the SIGINT and SIGTERM handlers (signal-hook's, which only
/// store to atomics). Idempotent: a second call changes nothing; none is
/// installed in an embedded engine ([`embed`]).
pub fn install() {
    if EMBEDDED.load(Ordering::SeqCst) {
        return;
    }
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        for sig in [libc::SIGINT, libc::SIGTERM] {
            // The condition is read before this signal's own flag is set,
            // so the first signal only sets the flags and the second ends
            // the process. Registration fails only for a forbidden signal.
            let registered =
                signal_hook::flag::register_conditional_default(sig, Arc::clone(&ASKED))
                    .and_then(|_| signal_hook::flag::register(sig, Arc::clone(&ASKED)))
                    .and_then(|_| {
                        signal_hook::flag::register_usize(sig, Arc::clone(&SIGNAL), sig as usize)
                    });
            debug_assert!(registered.is_ok(), "{registered:?}");
        }
    });
}

/// The signal number that asked the run to stop, if any.
pub fn requested() -> Option<i32> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        s => Some(s as i32),
    }
}

/// Asks the run to stop as if `signal` had arrived (tests, and a fatal
/// error in one worker that should stop the others).
pub fn request(signal: i32) {
    SIGNAL.store(signal.max(0) as usize, Ordering::SeqCst);
}

/// Name of a signal for messages: "SIGINT", "SIGTERM" or "signal N".
pub fn signal_name(signal: i32) -> String {
    match signal {
        libc::SIGINT => "SIGINT (Ctrl-C)".to_string(),
        libc::SIGTERM => "SIGTERM".to_string(),
        s => format!("signal {s}"),
    }
}

/// The run was stopped by a signal.
#[derive(Debug, thiserror::Error)]
#[error("interrupted by {}: the workers stopped; no new report was written", signal_name(*.signal))]
pub struct Interrupted {
    /// Signal number.
    pub signal: i32,
}

impl Interrupted {
    /// Exit code of a run stopped by this signal: 128 + the signal number,
    /// as a shell reports a process killed by it (130 for SIGINT, 143 for
    /// SIGTERM).
    pub fn exit_code(&self) -> i32 {
        128 + self.signal
    }
}

/// `Err(Interrupted)` once a stop was requested.
pub fn check() -> Result<(), Interrupted> {
    match requested() {
        Some(signal) => Err(Interrupted { signal }),
        None => Ok(()),
    }
}

/// How often [`Prompt`] looks at the stop flag.
const PROMPT_POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// While it lives, a stop request ends the process within a twentieth of
/// a second: for a stage that cannot look at the flag itself, such as the
/// PDF layout (one Typst call of several seconds on a large report). The
/// directory `discard` (the new generation being written) is removed
/// first, so the stop leaves the old report exactly as a stop between
/// cases does; a run killed outright would leave it for the next run to
/// remove.
#[derive(Debug)]
pub struct Prompt {
    /// Dropped to tell the watcher the stage is over; it wakes at once.
    done: Option<std::sync::mpsc::Sender<()>>,
    watcher: Option<std::thread::JoinHandle<()>>,
}

impl Prompt {
    /// Starts watching; see [`Prompt`]. With `keep` (a file name and a
    /// hint), a stop keeps that file of `discard` (a run's finished case
    /// store, for `--resume`) and removes the rest, then prints the hint.
    pub fn start(discard: std::path::PathBuf, keep: Option<(&'static str, String)>) -> Prompt {
        if EMBEDDED.load(Ordering::SeqCst) {
            return Prompt {
                done: None,
                watcher: None,
            };
        }
        let (done, over) = std::sync::mpsc::channel::<()>();
        let watcher = std::thread::spawn(move || {
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                over.recv_timeout(PROMPT_POLL)
            {
                if let Some(signal) = requested() {
                    eprintln!("error: {}", Interrupted { signal });
                    match &keep {
                        Some((file, hint)) if discard.join(file).is_file() => {
                            prune(&discard, file);
                            eprintln!("{hint}");
                        }
                        _ => {
                            // The writer may still add files: try a few times.
                            for _ in 0..5 {
                                if std::fs::remove_dir_all(&discard).is_ok() || !discard.exists() {
                                    break;
                                }
                            }
                        }
                    }
                    std::process::exit(Interrupted { signal }.exit_code());
                }
            }
        });
        Prompt {
            done: Some(done),
            watcher: Some(watcher),
        }
    }
}

/// Removes every entry of `dir` but `keep` (the writer may still add
/// files: a few passes).
pub fn prune(dir: &std::path::Path, keep: &str) {
    for _ in 0..5 {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        let mut left = false;
        for e in entries.flatten() {
            if e.file_name() == keep {
                continue;
            }
            let path = e.path();
            let gone = match e.file_type() {
                Ok(t) if t.is_dir() => std::fs::remove_dir_all(&path),
                _ => std::fs::remove_file(&path),
            };
            left |= gone.is_err();
        }
        if !left {
            return;
        }
    }
}

impl Drop for Prompt {
    fn drop(&mut self) {
        drop(self.done.take());
        if let Some(w) = self.watcher.take() {
            let _ = w.join();
        }
    }
}
