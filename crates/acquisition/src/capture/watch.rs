//! A watchdog for the FFmpeg processes a capture is read through: each
//! runs in a process group of its own, and the group is killed when the
//! tool makes no progress for [`STALL`] (a hung decoder, a file on a dead
//! network share) or when the user interrupts the run.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Longest time without progress (a decoded frame, or the end of ffprobe).
pub const STALL: Duration = Duration::from_secs(120);
/// How often the watchdog looks.
const POLL: Duration = Duration::from_millis(100);

/// Why the watchdog killed the tool.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fired {
    /// No progress for this long.
    Stalled(Duration),
    /// The user interrupted the run (this signal).
    Interrupted(i32),
}

/// Watches the process group `pgid` until [`Watchdog::finish`].
pub struct Watchdog {
    progress: Arc<AtomicU64>,
    /// Dropped by `finish`, which wakes the watching thread at once.
    stop: mpsc::Sender<()>,
    thread: JoinHandle<Option<Fired>>,
}

impl Watchdog {
    /// Starts watching group `pgid`, which must have no progress for
    /// `stall` to be killed.
    pub fn start(pgid: u32, stall: Duration) -> Self {
        let progress = Arc::new(AtomicU64::new(0));
        let (stop, stopped) = mpsc::channel::<()>();
        let thread = {
            let progress = Arc::clone(&progress);
            std::thread::spawn(move || {
                let (mut seen, mut since) = (0, Instant::now());
                while let Err(mpsc::RecvTimeoutError::Timeout) = stopped.recv_timeout(POLL) {
                    let fired = if let Some(signal) = crate::interrupt::requested() {
                        Some(Fired::Interrupted(signal))
                    } else {
                        let now = progress.load(Ordering::Acquire);
                        if now != seen {
                            (seen, since) = (now, Instant::now());
                        }
                        (since.elapsed() >= stall).then_some(Fired::Stalled(stall))
                    };
                    if fired.is_some() {
                        ledflicker_plan::util::kill_group(pgid);
                        return fired;
                    }
                }
                None
            })
        };
        Self {
            progress,
            stop,
            thread,
        }
    }

    /// The tool made progress.
    pub fn tick(&self) {
        self.progress.fetch_add(1, Ordering::Release);
    }

    /// Stops watching; says whether the group was killed, and why.
    pub fn finish(self) -> Option<Fired> {
        drop(self.stop);
        self.thread.join().unwrap_or(None)
    }
}

impl Fired {
    /// What to tell the user about `tool`.
    pub fn message(self, tool: &str) -> String {
        match self {
            Fired::Stalled(d) => format!(
                "`{tool}` made no progress for {} s and was stopped (its process group killed)\n    hint: check that the file is readable and not still being written; try `{tool}` on it by hand",
                d.as_secs()
            ),
            Fired::Interrupted(signal) => {
                format!("interrupted (signal {signal}) while `{tool}` was reading it")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::os::unix::process::CommandExt;
    use std::process::Command;

    use super::*;

    fn sleeper() -> std::process::Child {
        Command::new("sh")
            .args(["-c", "sleep 30 & sleep 30"])
            .process_group(0)
            .spawn()
            .expect("sh runs")
    }

    #[test]
    fn a_stalled_group_is_killed_with_what_it_started() {
        let mut child = sleeper();
        let pgid = child.id();
        let start = Instant::now();
        let dog = Watchdog::start(pgid, Duration::from_millis(300));
        let status = child.wait().expect("waits");
        assert!(!status.success());
        assert_eq!(
            dog.finish(),
            Some(Fired::Stalled(Duration::from_millis(300)))
        );
        assert!(start.elapsed() < Duration::from_secs(10));
    }

    #[test]
    fn progress_keeps_it_alive_and_finish_stops_it() {
        let mut child = sleeper();
        let dog = Watchdog::start(child.id(), Duration::from_millis(400));
        for _ in 0..8 {
            std::thread::sleep(Duration::from_millis(100));
            dog.tick();
        }
        assert_eq!(dog.finish(), None);
        // Not killed by the watchdog: still running until we stop it.
        assert!(child.try_wait().expect("try_wait").is_none());
        ledflicker_plan::util::kill_group(child.id());
        let _ = child.wait();
    }
}
