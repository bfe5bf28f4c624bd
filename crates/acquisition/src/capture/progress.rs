//! Frames decoded so far, for the terminal progress line of `plan` while
//! the captures of a captured plan are read (they are read in parallel,
//! before any case runs).
//!
//! One process-wide counter: every frame that reaches the ROI accumulator
//! counts once. It only feeds the progress display; no result depends on it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

static DECODED: AtomicU64 = AtomicU64::new(0);

/// Counts one decoded frame.
pub(crate) fn count_frame() {
    DECODED.fetch_add(1, Ordering::Relaxed);
}

/// Frames decoded by this process so far (all captures, monotonic).
pub fn frames_decoded() -> u64 {
    DECODED.load(Ordering::Relaxed)
}

/// The progress text: `"1234 frames decoded (617 frames/s)"`; the rate is
/// left out until a tenth of a second has passed.
pub fn decode_progress_text(frames: u64, elapsed: Duration) -> String {
    let noun = if frames == 1 { "frame" } else { "frames" };
    let s = elapsed.as_secs_f64();
    if s < 0.1 {
        return format!("{frames} {noun} decoded");
    }
    format!(
        "{frames} {noun} decoded ({:.0} frames/s)",
        frames as f64 / s
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_text_gives_the_count_and_the_rate() {
        assert_eq!(
            decode_progress_text(1234, Duration::from_secs(2)),
            "1234 frames decoded (617 frames/s)"
        );
        assert_eq!(
            decode_progress_text(1, Duration::from_millis(10)),
            "1 frame decoded"
        );
        assert_eq!(
            decode_progress_text(0, Duration::from_secs(1)),
            "0 frames decoded (0 frames/s)"
        );
    }

    #[test]
    fn the_counter_counts_frames() {
        let before = frames_decoded();
        count_frame();
        count_frame();
        // Other tests may decode at the same time: at least these two.
        assert!(frames_decoded() >= before + 2);
    }
}
