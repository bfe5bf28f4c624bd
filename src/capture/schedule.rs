//! Reading a plan's captures together.
//!
//! [`read_captures`] first opens every capture (a video is probed by
//! ffprobe), then reads them all, the costliest first. Both steps run on
//! threads of their own, at most [`AT_ONCE`] captures at a time, rather than
//! on the rayon pool: a video's work is done in its FFmpeg process, so the
//! threads here mostly wait on pipes, and every decoder starts at once
//! instead of waiting for a pool thread.
//!
//! Decoder threads: when several videos are read, each FFmpeg decoder gets
//! one thread, so that the decoders share the cores without frame-threading
//! overhead; except the costliest video (frames x pixels), which gets every
//! core when it alone is more than its fair share of the work (more than
//! `1 / cores` of all the pixels), because it then finishes last, alone.
//! Frame threading changes no pixel (tests in `video`), so the numbers do
//! not depend on this choice.

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use super::{CaptureError, CaptureTrace, Opened, ReadOptions, RoiRect, open, read_opened};

/// Most captures opened or read at the same time.
pub const AT_ONCE: usize = 8;

/// Reads every capture of `paths` (as [`super::read_capture`] does) with the
/// same ROIs and options; `cores` is the number of cores the run may use
/// (the rayon pool's threads). The traces come back in the order of
/// `paths`. On failure, no further capture is started, and the error is
/// that of the first failing capture in the order of `paths` among those
/// started.
pub fn read_captures(
    paths: &[&Path],
    rois: &[RoiRect],
    roi_names: &[String],
    opts: &ReadOptions,
    cores: usize,
) -> Result<Vec<CaptureTrace>, CaptureError> {
    let in_order: Vec<usize> = (0..paths.len()).collect();
    let opened = run_bounded(vec![(); paths.len()], &in_order, |i, ()| open(paths[i]))?;
    let costs: Vec<u64> = opened.iter().map(Opened::decode_cost).collect();
    let mut costliest_first = in_order;
    costliest_first.sort_by_key(|&i| std::cmp::Reverse(costs[i]));
    let videos = opened.iter().filter(|o| o.video.is_some()).count();
    let threads = decoder_threads(&costs, videos, opts.decoder_threads, cores);
    run_bounded(opened, &costliest_first, |i, o| {
        let opts = ReadOptions {
            decoder_threads: threads[i],
            ..*opts
        };
        read_opened(paths[i], o, rois, roi_names, &opts)
    })
}

/// FFmpeg decoder threads of each capture of decode cost `costs` (0 for
/// one read in this process), `videos` of them videos (see the module's
/// text); `given` (the caller's choice) wins, and a single video keeps
/// FFmpeg's choice.
fn decoder_threads(
    costs: &[u64],
    videos: usize,
    given: Option<usize>,
    cores: usize,
) -> Vec<Option<usize>> {
    if given.is_some() || videos < 2 {
        return vec![given; costs.len()];
    }
    let total: u64 = costs.iter().sum();
    let costliest = (0..costs.len()).max_by_key(|&i| (costs[i], std::cmp::Reverse(i)));
    (0..costs.len())
        .map(|i| {
            let alone_longest = costs[i] as u128 * cores as u128 > total as u128;
            let all_cores = Some(i) == costliest && alone_longest;
            Some(if all_cores { cores.max(1) } else { 1 })
        })
        .collect()
}

/// Runs `f(i, items[i])` for every item, in `order`, on at most
/// [`AT_ONCE`] threads. After the first error no item is started; the
/// result is the first error in item order, or every output in item order.
fn run_bounded<I: Send, O: Send, E: Send>(
    items: Vec<I>,
    order: &[usize],
    f: impl Fn(usize, I) -> Result<O, E> + Sync,
) -> Result<Vec<O>, E> {
    let n = items.len();
    let inputs: Vec<Mutex<Option<I>>> = items.into_iter().map(|x| Mutex::new(Some(x))).collect();
    let outputs: Vec<Mutex<Option<Result<O, E>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let worker = || {
        while !failed.load(Ordering::Acquire) {
            let Some(&i) = order.get(next.fetch_add(1, Ordering::AcqRel)) else {
                return;
            };
            let Some(item) = take(&inputs[i]) else {
                continue;
            };
            let out = f(i, item);
            if out.is_err() {
                failed.store(true, Ordering::Release);
            }
            *outputs[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(out);
        }
    };
    std::thread::scope(|s| {
        for _ in 0..n.min(AT_ONCE) {
            s.spawn(worker);
        }
    });
    let outputs: Vec<Option<Result<O, E>>> = outputs.into_iter().map(into_inner).collect();
    if let Some(e) = outputs.iter().position(|o| matches!(o, Some(Err(_)))) {
        let Some(Some(Err(e))) = outputs.into_iter().nth(e) else {
            unreachable!("position() found an error here")
        };
        return Err(e);
    }
    // Without an error every item ran.
    Ok(outputs.into_iter().flatten().flatten().collect())
}

fn take<T>(slot: &Mutex<Option<T>>) -> Option<T> {
    slot.lock().unwrap_or_else(|e| e.into_inner()).take()
}

fn into_inner<T>(slot: Mutex<T>) -> T {
    slot.into_inner().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_costliest_video_gets_every_core_only_when_it_is_the_longest_alone() {
        // The P2020 samples: 899, 429 and 369 frames of one size.
        assert_eq!(
            decoder_threads(&[899, 429, 369], 3, None, 2),
            vec![Some(2), Some(1), Some(1)]
        );
        // Equal captures share the cores, one decoder thread each.
        assert_eq!(
            decoder_threads(&[500, 500, 500], 3, None, 2),
            vec![Some(1); 3]
        );
        // On 4 cores none of five equal videos is more than a quarter.
        assert_eq!(decoder_threads(&[20; 5], 5, None, 4), vec![Some(1); 5]);
        // Ties go to the first; the caller's choice and a lone video win.
        assert_eq!(
            decoder_threads(&[10, 10, 0], 2, None, 4),
            vec![Some(4), Some(1), Some(1)]
        );
        assert_eq!(
            decoder_threads(&[899, 429], 2, Some(3), 2),
            vec![Some(3); 2]
        );
        assert_eq!(decoder_threads(&[899, 0], 1, None, 2), vec![None; 2]);
    }

    #[test]
    fn run_bounded_keeps_item_order_whatever_the_running_order() {
        let order = [3, 0, 2, 1, 4];
        let out = run_bounded(vec![10, 11, 12, 13, 14], &order, |i, x| {
            Ok::<_, String>((i, x * 2))
        })
        .unwrap();
        assert_eq!(out, vec![(0, 20), (1, 22), (2, 24), (3, 26), (4, 28)]);
    }

    #[test]
    fn run_bounded_returns_the_first_error_in_item_order() {
        // All four run at once (the barrier holds each until all started);
        // items 1 and 3 fail, item 3 first: item 1's error is the one.
        let all_started = std::sync::Barrier::new(4);
        let err = run_bounded(vec![(); 4], &[3, 2, 1, 0], |i, ()| {
            all_started.wait();
            if i == 1 {
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            if i % 2 == 1 {
                Err(format!("item {i}"))
            } else {
                Ok(i)
            }
        });
        assert_eq!(err.unwrap_err(), "item 1");
    }

    #[test]
    fn run_bounded_starts_nothing_after_an_error() {
        // Item 0 is taken first and fails; the items taken alongside it
        // wait until it has failed (and a little longer, so that the
        // failure is recorded), so no thread may take another item.
        let n = 2 * AT_ONCE;
        let started = AtomicUsize::new(0);
        let first_done = AtomicBool::new(false);
        let order: Vec<usize> = (0..n).collect();
        let err = run_bounded(vec![(); n], &order, |i, ()| {
            if i == 0 {
                first_done.store(true, Ordering::Release);
                return Err("item 0");
            }
            started.fetch_add(1, Ordering::AcqRel);
            while !first_done.load(Ordering::Acquire) {
                std::thread::yield_now();
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
            Ok(i)
        });
        assert_eq!(err.unwrap_err(), "item 0");
        assert!(first_done.load(Ordering::Acquire));
        // At most the AT_ONCE - 1 items taken alongside item 0 ran.
        assert!(started.load(Ordering::Acquire) < AT_ONCE, "{started:?}");
    }

    #[test]
    fn run_bounded_runs_more_items_than_threads() {
        let n = 3 * AT_ONCE + 1;
        let order: Vec<usize> = (0..n).rev().collect();
        let out = run_bounded((0..n).collect(), &order, |_, x: usize| Ok::<_, ()>(x)).unwrap();
        assert_eq!(out, (0..n).collect::<Vec<_>>());
    }
}
