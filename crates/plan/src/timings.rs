//! Timing spans for `plan --timings`: where a run spends its wall time.
//!
//! A span is recorded when its guard drops, only when timings were switched
//! on for this process, so the instrumented code pays one atomic load
//! otherwise. Depth is per thread (spans opened on rayon workers nest
//! under nothing). Spans may nest (the report stage holds its parts); the table
//! prints them in the order they finished, with their nesting depth.

use std::cell::Cell;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

static ENABLED: AtomicBool = AtomicBool::new(false);
static SPANS: Mutex<Vec<Span>> = Mutex::new(Vec::new());

thread_local! {
    /// Nesting depth of the open spans of this thread.
    static DEPTH: Cell<usize> = const { Cell::new(0) };
}

/// One finished span.
#[derive(Debug, Clone)]
pub struct Span {
    /// What ran, e.g. "report: pdf".
    pub name: &'static str,
    /// Nesting depth when it started (0 = top level).
    pub depth: usize,
    /// Wall time in seconds.
    pub seconds: f64,
    /// The process's peak resident memory when the span ended (Linux's
    /// `VmHWM`), bytes; `None` where the system does not say. Read in
    /// order, the spans show which stage raised the peak.
    pub peak_rss_bytes: Option<u64>,
}

/// Switches recording on for the rest of the process.
pub fn enable() {
    ENABLED.store(true, Ordering::Relaxed);
}

/// Records the wall time from now until the guard drops, under `name`.
#[must_use = "the span ends when the guard drops"]
pub fn span(name: &'static str) -> Guard {
    span_at(name, depth())
}

/// How deep the spans open on this thread are nested.
pub fn depth() -> usize {
    DEPTH.with(Cell::get)
}

/// A span nested at `depth`, for work handed to another thread: it shows
/// under the spans open where the work was handed out.
#[must_use = "the span ends when the guard drops"]
pub fn span_at(name: &'static str, depth: usize) -> Guard {
    if !ENABLED.load(Ordering::Relaxed) {
        return Guard(None);
    }
    let outer = DEPTH.with(|d| d.replace(depth + 1));
    Guard(Some((name, depth, Instant::now(), outer)))
}

/// Runs `f` with this thread's spans nested at `depth`: for work handed to
/// another thread that opens spans of its own.
/// The thread's depth is restored however `f` ends, a panic included (a
/// rayon worker thread goes on to run other work).
pub fn at_depth<R>(depth: usize, f: impl FnOnce() -> R) -> R {
    /// Puts the thread's depth back when dropped.
    struct Restore(usize);
    impl Drop for Restore {
        fn drop(&mut self) {
            DEPTH.with(|d| d.set(self.0));
        }
    }
    let _restore = Restore(DEPTH.with(|d| d.replace(depth)));
    f()
}

/// Ends its span when dropped.
pub struct Guard(Option<(&'static str, usize, Instant, usize)>);

impl Drop for Guard {
    fn drop(&mut self) {
        if let Some((name, depth, start, outer)) = self.0.take() {
            DEPTH.with(|d| d.set(outer));
            let seconds = start.elapsed().as_secs_f64();
            let peak_rss_bytes = peak_rss_bytes();
            if let Ok(mut spans) = SPANS.lock() {
                spans.push(Span {
                    name,
                    depth,
                    seconds,
                    peak_rss_bytes,
                });
            }
        }
    }
}

/// The process's peak resident memory so far, from `/proc/self/status`.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The spans recorded so far, in the order they finished.
pub fn take() -> Vec<Span> {
    SPANS
        .lock()
        .map(|mut s| std::mem::take(&mut *s))
        .unwrap_or_default()
}

/// The spans as an indented table, children above their parent.
pub fn table(spans: &[Span]) -> String {
    let mut out = String::from("timings (wall, seconds; peak memory so far, MB):\n");
    for s in spans {
        let peak = s
            .peak_rss_bytes
            .map_or(String::new(), |b| format!(" {:>8.1}", b as f64 / 1e6));
        out.push_str(&format!(
            "  {:indent$}{:<width$} {:>8.3}{peak}\n",
            "",
            s.name,
            s.seconds,
            indent = 2 * s.depth,
            width = 34 - 2 * s.depth.min(8)
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_nest_and_record_only_when_enabled() {
        drop(span("before enable"));
        enable();
        {
            let _outer = span("outer");
            let _inner = span("inner");
        }
        // Other tests may record spans meanwhile: look at ours only.
        let spans: Vec<_> = take()
            .into_iter()
            .filter(|s| ["before enable", "outer", "inner"].contains(&s.name))
            .collect();
        let names: Vec<_> = spans.iter().map(|s| (s.name, s.depth)).collect();
        assert_eq!(names, vec![("inner", 1), ("outer", 0)]);
        assert!(table(&spans).contains("    inner"));

        // A span handed to another thread nests where it was handed out.
        {
            let _outer = span("hand-out outer");
            let depth = depth();
            std::thread::scope(|s| {
                s.spawn(|| {
                    let _inner = span_at("handed out", depth);
                    drop(span("under handed out"));
                });
                s.spawn(|| at_depth(depth, || drop(span("run at depth"))));
            });
            // The other thread's depth does not leak into this one's.
            drop(span("after hand-out"));
        }
        let spans: Vec<_> = take()
            .into_iter()
            .filter(|s| s.name.contains("hand") || s.name == "run at depth")
            .map(|s| (s.name, s.depth))
            .collect();
        assert!(spans.contains(&("run at depth", 1)), "{spans:?}");
        let spans: Vec<_> = spans
            .into_iter()
            .filter(|s| s.0 != "run at depth")
            .collect();
        assert_eq!(
            spans,
            vec![
                ("under handed out", 2),
                ("handed out", 1),
                ("after hand-out", 1),
                ("hand-out outer", 0)
            ]
        );
    }

    #[test]
    fn a_panic_under_at_depth_restores_the_depth() {
        std::thread::spawn(|| {
            let before = depth();
            let caught = std::panic::catch_unwind(|| at_depth(before + 5, || panic!("case")));
            assert!(caught.is_err());
            assert_eq!(depth(), before);
        })
        .join()
        .unwrap();
    }
}
