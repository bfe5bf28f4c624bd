//! Reading a plan's captures together.
//!
//! [`read_captures`] reads every capture at once, each on a thread of its
//! own (at most [`AT_ONCE`] at a time), rather than on the rayon pool: a
//! video's work is done in its FFmpeg process (ffprobe, then ffmpeg), so
//! these threads mostly wait on pipes. A plan with image, Y4M or CSV
//! captures, which are decoded in this process, reads as many at once as
//! the rayon pool has threads, the largest files first, so its memory
//! stays bounded.
//!
//! Several videos are probed and their decoders started all at once, then
//! read at most one per core at a time, the most work first
//! ([`read_videos`]): the cores each decode one video, and the longest
//! video does not run alone at the end while a core idles (the P2020
//! sample plan's three videos decoded all at once on two cores left one
//! core idle for the last quarter of the stage, docs/speed.md).
//!
//! When several videos are read, each FFmpeg decoder gets one thread and
//! a one-thread filter graph: the decoders share the cores among
//! themselves, without the CPU that frame threading and a filter thread
//! pool add. Neither changes a pixel (tests in `video`), so the numbers do
//! not depend on this choice, nor on the order or the number of videos
//! read at a time.

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::{
    CaptureError, CaptureTrace, ReadOptions, RoiRect, SourceKind, built_in_copy, check_exists,
    finish_trace, read_capture, source_kind, video,
};

/// Most captures read at the same time.
pub const AT_ONCE: usize = 8;

/// Reads every capture of `paths` (as [`read_capture`] does) with the same
/// ROIs and options: several videos through [`read_videos`], as many at a
/// time as the rayon pool has threads; other captures as many at once as
/// the rayon pool has threads. The traces come back in the order of
/// `paths`. On failure, no further capture is started (for videos: none
/// after the failing one in the order of `paths`), and the error is that
/// of the first failing capture in the order of `paths` among those
/// started.
pub fn read_captures(
    paths: &[&Path],
    rois: &[RoiRect],
    roi_names: &[String],
    opts: &ReadOptions,
) -> Result<Vec<CaptureTrace>, CaptureError> {
    let copies = paths
        .iter()
        .map(|p| built_in_copy(p))
        .collect::<Result<Vec<_>, _>>()?;
    let local: Vec<&Path> = paths
        .iter()
        .zip(&copies)
        .map(|(&p, copy)| copy.as_deref().unwrap_or(p))
        .collect();
    read_captures_on_disk(&local, rois, roi_names, opts).map_err(|e| {
        // Named by its path in the plan, not its temporary copy's.
        match local.iter().position(|&l| l == e.path()) {
            Some(i) => e.at(paths[i]),
            None => e,
        }
    })
}

fn read_captures_on_disk(
    paths: &[&Path],
    rois: &[RoiRect],
    roi_names: &[String],
    opts: &ReadOptions,
) -> Result<Vec<CaptureTrace>, CaptureError> {
    let videos = paths
        .iter()
        .filter(|p| source_kind(p) == SourceKind::Video)
        .count();
    let opts = ReadOptions {
        decoder_threads: decoder_threads(videos, opts.decoder_threads),
        ..*opts
    };
    if videos == paths.len() && videos > 1 {
        let slots = rayon::current_num_threads().max(1);
        return read_videos(paths, rois, &opts, slots).map_err(|e| e.with_roi_names(roi_names));
    }
    let sizes: Vec<u64> = paths
        .iter()
        .map(|p| std::fs::metadata(p).map_or(0, |m| m.len()))
        .collect();
    let mut largest_first: Vec<usize> = (0..paths.len()).collect();
    largest_first.sort_by_key(|&i| std::cmp::Reverse(sizes[i]));
    // Frames of other captures are decoded in this process, one frame of
    // up to 320 MB each at a time: no more at once than the pool has
    // threads, as before, so memory stays what it was.
    let threads = if videos == paths.len() {
        AT_ONCE
    } else {
        rayon::current_num_threads().clamp(1, AT_ONCE)
    };
    run_bounded(vec![(); paths.len()], &largest_first, threads, |i, ()| {
        read_capture(paths[i], rois, roi_names, &opts)
    })
}

/// Reads the videos `paths` in groups of [`AT_ONCE`], in plan order: all
/// of a group are probed and their decoders started at once
/// ([`video::prepare`]); then at most `slots` of these decoders are read
/// at a time, the most work first ([`video::Prepared::work`]). A decoder
/// not read waits on its full pipe and uses no CPU, so each core decodes
/// one video at a time, and the longest video does not run alone at the
/// end while a core idles. The error is that of the first failing capture
/// in plan order: after a failure, no later capture is read, and no group
/// is started.
fn read_videos(
    paths: &[&Path],
    rois: &[RoiRect],
    opts: &ReadOptions,
    slots: usize,
) -> Result<Vec<CaptureTrace>, CaptureError> {
    let mut traces = Vec::with_capacity(paths.len());
    for group in paths.chunks(AT_ONCE) {
        let prepared: Vec<Result<video::Prepared, CaptureError>> = std::thread::scope(|s| {
            let started: Vec<_> = group
                .iter()
                .map(|&p| {
                    s.spawn(move || check_exists(p).and_then(|()| video::prepare(p, rois, opts)))
                })
                .collect();
            started.into_iter().map(join).collect()
        });
        let mut ready = Vec::with_capacity(group.len());
        let mut failed = None;
        for p in prepared {
            match p {
                Ok(p) if failed.is_none() => ready.push(p),
                // Captures after a failure cannot change the error.
                Ok(_) => {}
                Err(e) => {
                    failed.get_or_insert(e);
                }
            }
        }
        let mut order: Vec<usize> = (0..ready.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(ready[i].work()));
        let read = run_in_order(ready, &order, slots, |i, p: video::Prepared| {
            p.read(group[i], opts)
                .and_then(|t| finish_trace(group[i], t))
        })?;
        if let Some(e) = failed {
            return Err(e);
        }
        traces.extend(read);
    }
    Ok(traces)
}

/// The result of a scoped thread; its panic goes on in the caller.
fn join<T>(h: std::thread::ScopedJoinHandle<'_, T>) -> T {
    h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))
}

/// Runs `f(i, items[i])` for every item, in `order`, on at most `threads`
/// threads. After an error at item `i`, no item after `i` (in item order)
/// is started, but the items before it still run, so the result is the
/// first error in item order of all items, or every output in item order.
fn run_in_order<I: Send, O: Send, E: Send>(
    items: Vec<I>,
    order: &[usize],
    threads: usize,
    f: impl Fn(usize, I) -> Result<O, E> + Sync,
) -> Result<Vec<O>, E> {
    run_scheduled(items, order, threads, AfterError::FinishEarlier, f)
}

/// Decoder threads of each of `videos` videos read together: the caller's
/// choice (`given`) when made, FFmpeg's own for a single video, else one.
fn decoder_threads(videos: usize, given: Option<usize>) -> Option<usize> {
    match given {
        Some(n) => Some(n),
        None if videos < 2 => None,
        None => Some(1),
    }
}

/// Runs `f(i, items[i])` for every item, in `order`, on at most `threads`
/// threads. After the first error no item is started; the
/// result is the first error in item order, or every output in item order.
fn run_bounded<I: Send, O: Send, E: Send>(
    items: Vec<I>,
    order: &[usize],
    threads: usize,
    f: impl Fn(usize, I) -> Result<O, E> + Sync,
) -> Result<Vec<O>, E> {
    run_scheduled(items, order, threads, AfterError::StartNothing, f)
}

/// What [`run_scheduled`] still starts after an item failed.
#[derive(Clone, Copy, PartialEq)]
enum AfterError {
    /// Nothing.
    StartNothing,
    /// The items before the failed one in item order.
    FinishEarlier,
}

/// Runs `f(i, items[i])` for every item, in `order`, on at most `threads`
/// threads, starting after an error only what `after_error` says. Returns
/// the first error in item order among the items run, or every output in
/// item order.
fn run_scheduled<I: Send, O: Send, E: Send>(
    items: Vec<I>,
    order: &[usize],
    threads: usize,
    after_error: AfterError,
    f: impl Fn(usize, I) -> Result<O, E> + Sync,
) -> Result<Vec<O>, E> {
    let n = items.len();
    let inputs: Vec<Mutex<Option<I>>> = items.into_iter().map(|x| Mutex::new(Some(x))).collect();
    let outputs: Vec<Mutex<Option<Result<O, E>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    let next = AtomicUsize::new(0);
    // The lowest failed item so far; `n` while none failed.
    let first_failed = AtomicUsize::new(n);
    let worker = || {
        while let Some(&i) = order.get(next.fetch_add(1, Ordering::AcqRel)) {
            let Some(item) = take(&inputs[i]) else {
                continue;
            };
            // An item not started is dropped here (a video's decoder is
            // killed at once).
            let failed = first_failed.load(Ordering::Acquire);
            let skip = match after_error {
                AfterError::StartNothing => failed < n,
                AfterError::FinishEarlier => i > failed,
            };
            if skip {
                continue;
            }
            let out = f(i, item);
            if out.is_err() {
                first_failed.fetch_min(i, Ordering::AcqRel);
            }
            *outputs[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(out);
        }
    };
    std::thread::scope(|s| {
        for _ in 0..n.min(threads.max(1)) {
            s.spawn(worker);
        }
    });
    let mut done = Vec::with_capacity(n);
    for out in outputs.into_iter().map(into_inner) {
        match out {
            Some(Ok(o)) => done.push(o),
            Some(Err(e)) => return Err(e),
            // Not started after an error.
            None => {}
        }
    }
    Ok(done)
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
    fn videos_read_together_get_one_decoder_thread_each() {
        assert_eq!(decoder_threads(3, None), Some(1));
        assert_eq!(decoder_threads(1, None), None);
        assert_eq!(decoder_threads(0, None), None);
        assert_eq!(decoder_threads(3, Some(2)), Some(2));
    }

    /// Read together, the P2020 sample videos give exactly what each gives
    /// read alone with FFmpeg's own threads, in the order asked; a missing
    /// capture among them is the error.
    #[test]
    fn captures_read_together_equal_each_read_alone() {
        assert!(
            super::super::ffmpeg_available(),
            "this test needs `ffmpeg` and `ffprobe` (scripts/test.sh installs them)"
        );
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("reference-data/p2020-flicker-videos");
        let paths: Vec<_> = ["test_vid3.mp4", "test_vid2.mp4"]
            .iter()
            .map(|f| dir.join(f))
            .collect();
        let refs: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
        let rois = two_rois();
        let opts = ReadOptions {
            luma: super::super::LumaWeights::Bt601,
            video_decode: super::super::VideoDecode::Rgb,
            range: super::super::VideoRange::Auto,
            colour_transfer: super::super::ColourTransfer::Linear,
            fps: None,
            decoder_threads: None,
        };
        let together = read_captures(&refs, &rois, &[], &opts).unwrap();
        let alone: Vec<CaptureTrace> = refs
            .iter()
            .map(|p| read_capture(p, &rois, &[], &opts).unwrap())
            .collect();
        assert_eq!(together.len(), 2);
        assert_eq!(together[0].luma[0].len(), 369);
        assert_eq!(together, alone);
        let missing = dir.join("no_such_video.mp4");
        let e = read_captures(&[refs[0], &missing], &rois, &[], &opts).unwrap_err();
        assert!(e.to_string().contains("no_such_video.mp4"), "{e}");
    }

    /// Read through the slots, one, two or three at a time, the sample
    /// videos give what each gives read alone; a truncated video among
    /// them is the same error as read alone, whichever slot reads it.
    #[test]
    fn videos_read_through_slots_equal_each_read_alone() {
        assert!(
            super::super::ffmpeg_available(),
            "this test needs `ffmpeg` and `ffprobe` (scripts/test.sh installs them)"
        );
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("reference-data/p2020-flicker-videos");
        let paths: Vec<_> = ["test_vid3.mp4", "test_vid1.mp4", "test_vid2.mp4"]
            .iter()
            .map(|f| dir.join(f))
            .collect();
        let refs: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
        let rois = two_rois();
        let opts = ReadOptions {
            decoder_threads: Some(1),
            ..sample_opts()
        };
        let alone: Vec<CaptureTrace> = refs
            .iter()
            .map(|p| read_capture(p, &rois, &[], &opts).unwrap())
            .collect();
        for slots in [1, 2, 3] {
            let read = read_videos(&refs, &rois, &opts, slots).unwrap();
            assert_eq!(read, alone, "{slots} slots");
        }
        let scratch = tempfile::tempdir().unwrap();
        let cut = scratch.path().join("cut.mp4");
        let bytes = std::fs::read(&paths[1]).unwrap();
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let text = |e: CaptureError| masked(&e.to_string());
        let want = text(read_capture(&cut, &rois, &[], &opts).unwrap_err());
        assert!(want.contains("cut.mp4"), "{want}");
        for at in 0..3 {
            let mut with_cut = refs.clone();
            with_cut[at] = &cut;
            for slots in [1, 2] {
                let e = read_videos(&with_cut, &rois, &opts, slots).unwrap_err();
                assert_eq!(text(e), want, "cut video at {at}, {slots} slots");
            }
        }
    }

    /// The decoding work orders the sample videos by frames (same frame
    /// size): 899, 429, 369.
    #[test]
    fn the_video_with_the_most_frames_has_the_most_work() {
        assert!(super::super::ffmpeg_available(), "this test needs `ffmpeg`");
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("reference-data/p2020-flicker-videos");
        let work = |f: &str| {
            video::prepare(&dir.join(f), &two_rois(), &sample_opts())
                .unwrap()
                .work()
        };
        assert_eq!(work("test_vid1.mp4"), 899 * 1280 * 800);
        assert_eq!(work("test_vid2.mp4"), 429 * 1280 * 800);
        assert_eq!(work("test_vid3.mp4"), 369 * 1280 * 800);
    }

    /// `text` with the hex digits after every `0x` (FFmpeg names its
    /// contexts by address) and the number after `frame ` masked: the
    /// frame at which ffmpeg stops on a truncated file varies by one from
    /// run to run, whoever runs it.
    fn masked(text: &str) -> String {
        let mut out = text.to_string();
        for (mark, digits) in [("0x", 16), ("frame ", 10)] {
            let mut done = String::new();
            let mut rest = out.as_str();
            while let Some(at) = rest.find(mark) {
                done.push_str(&rest[..at + mark.len()]);
                done.push('?');
                rest = rest[at + mark.len()..].trim_start_matches(|c: char| c.is_digit(digits));
            }
            out = done + rest;
        }
        out
    }

    fn two_rois() -> [RoiRect; 2] {
        [
            RoiRect {
                x: 457,
                y: 247,
                width: 20,
                height: 2,
            },
            RoiRect {
                x: 640,
                y: 500,
                width: 13,
                height: 9,
            },
        ]
    }

    fn sample_opts() -> ReadOptions {
        ReadOptions {
            luma: super::super::LumaWeights::Bt601,
            video_decode: super::super::VideoDecode::Rgb,
            range: super::super::VideoRange::Auto,
            colour_transfer: super::super::ColourTransfer::Linear,
            fps: None,
            decoder_threads: None,
        }
    }

    #[test]
    fn run_in_order_keeps_item_order_and_runs_earlier_items_after_an_error() {
        let ok = run_in_order(vec![10, 11, 12, 13], &[2, 0, 3, 1], 2, |i, x| {
            Ok::<_, String>((i, x))
        });
        assert_eq!(ok.unwrap(), vec![(0, 10), (1, 11), (2, 12), (3, 13)]);
        // One thread, item 2 first: it fails; 3 is after it and is not
        // started, 0 and 1 still run, and 1's error comes first.
        let started = Mutex::new(Vec::new());
        let e = run_in_order(vec![(); 4], &[2, 3, 0, 1], 1, |i, ()| {
            started.lock().unwrap().push(i);
            if i >= 1 {
                Err(format!("item {i}"))
            } else {
                Ok(i)
            }
        });
        assert_eq!(e.unwrap_err(), "item 1");
        assert_eq!(*started.lock().unwrap(), vec![2, 0, 1]);
    }

    #[test]
    fn run_bounded_keeps_item_order_whatever_the_running_order() {
        let order = [3, 0, 2, 1, 4];
        let out = run_bounded(vec![10, 11, 12, 13, 14], &order, AT_ONCE, |i, x| {
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
        let err = run_bounded(vec![(); 4], &[3, 2, 1, 0], AT_ONCE, |i, ()| {
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
        let first_done = std::sync::atomic::AtomicBool::new(false);
        let order: Vec<usize> = (0..n).collect();
        let err = run_bounded(vec![(); n], &order, AT_ONCE, |i, ()| {
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
        let out = run_bounded((0..n).collect(), &order, AT_ONCE, |_, x: usize| {
            Ok::<_, ()>(x)
        })
        .unwrap();
        assert_eq!(out, (0..n).collect::<Vec<_>>());
    }
}
