//! How far the report stage of this process has got, for the CLI's
//! progress line: pictures drawn of those planned. The report writer
//! counts; the CLI reads. A process writes one report at a time, so one
//! set of counters serves.

use std::sync::atomic::{AtomicUsize, Ordering};

static PLANNED: AtomicUsize = AtomicUsize::new(0);
static DRAWN: AtomicUsize = AtomicUsize::new(0);

/// Starts counting a report's pictures afresh.
pub fn reset() {
    PLANNED.store(0, Ordering::Relaxed);
    DRAWN.store(0, Ordering::Relaxed);
}

/// One more picture to draw.
pub(crate) fn planned() {
    PLANNED.fetch_add(1, Ordering::Relaxed);
}

/// One more picture drawn.
pub(crate) fn drawn() {
    DRAWN.fetch_add(1, Ordering::Relaxed);
}

/// Pictures drawn and planned so far.
pub fn pictures() -> (usize, usize) {
    (
        DRAWN.load(Ordering::Relaxed),
        PLANNED.load(Ordering::Relaxed),
    )
}
