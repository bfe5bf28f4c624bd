//! One frame of a video read by seeking: ffmpeg decodes from the key frame
//! before it rather than from the start.

use std::path::Path;

use super::super::grey::GreyFrame;
use super::super::layout::Layout;
use super::super::probe::Probe;
use super::super::watch::STALL;
use super::super::{
    CaptureError, FrameSink, ReadOptions, RoiRect, VideoRange, VideoRead, check_rois, open_file,
};
use super::Decoder;

/// Hands frames of `path`, whole, to `sink`, each decoded from the key
/// frame before it rather than from the start: for each `(frame, at_s)` of
/// `seeks`, ffmpeg's accurate seek (`-ss`, an input option) goes to `at_s`
/// on the file's timeline, decodes from the key frame before it and drops
/// the frames before `at_s`, and the first frame left goes to `sink` as
/// `frame`. The caller puts `at_s` halfway between the frame's
/// presentation time and the one before it. All seeks run in one ffmpeg
/// process. Returns, for each seek, the ROI means of the frame it landed on
/// (`rois` in frame coordinates), for the caller to check against the
/// trace: a file whose index sends a seek to another key frame lands on
/// another frame; None for every seek when fewer frames came than seeks.
pub(in crate::capture) fn read_frames_seeking(
    path: &Path,
    opts: &ReadOptions,
    seeks: &[(u64, f64)],
    (width, height, video): (u32, u32, VideoRead),
    rois: &[RoiRect],
    sink: &mut dyn FrameSink,
) -> Result<Vec<Option<Vec<f64>>>, CaptureError> {
    drop(open_file(path)?);
    let Some(&(first, _)) = seeks.first() else {
        return Ok(Vec::new());
    };
    check_rois(path, first, rois, width, height)?;
    let whole = RoiRect {
        x: 0,
        y: 0,
        width,
        height,
    };
    let layout = Layout::single(whole, rois);
    let probe = Probe {
        width,
        height,
        codec: String::new(),
        pix_fmt: String::new(),
        full_range: Some(video.full_range),
        fps: None,
        time_base_s: None,
        stated_fps: None,
        packet_times: Vec::new(),
        seek_origin_s: None,
    };
    let frames: Vec<u64> = seeks.iter().map(|&(frame, _)| frame).collect();
    let times: Vec<f64> = seeks.iter().map(|&(_, at_s)| at_s).collect();
    let mut relabel = Relabel {
        sink,
        frames: &frames,
    };
    let opts = ReadOptions {
        range: if video.full_range {
            VideoRange::Full
        } else {
            VideoRange::Limited
        },
        // A seek decodes a key frame's group, at most a few hundred frames,
        // and several seeks run at once (cases in parallel): frame
        // threading would add its CPU and its start-up delay, and no pixel
        // changes with it.
        decoder_threads: Some(1),
        ..*opts
    };
    let last = seeks.len() as u64 - 1;
    let trace = Decoder::start_seeking(path, layout, &opts, &times)?.read(
        path,
        probe,
        &opts,
        STALL,
        Some((&mut relabel, Some(last))),
    )?;
    // Each input gives one frame. Fewer frames means an input gave none,
    // and a later input's frame came under an earlier one's number: none
    // is trusted then (the caller reads them from the start).
    if trace.luma.first().map_or(0, Vec::len) != seeks.len() {
        return Ok(vec![None; seeks.len()]);
    }
    Ok((0..seeks.len())
        .map(|k| trace.luma.iter().map(|roi| roi.get(k).copied()).collect())
        .collect())
}

/// Hands the `k`th frame the seeks give to `sink` as frame `frames[k]`.
struct Relabel<'s> {
    sink: &'s mut dyn FrameSink,
    frames: &'s [u64],
}

impl FrameSink for Relabel<'_> {
    fn frame(&mut self, f: &GreyFrame<'_>) {
        let Some(&frame) = usize::try_from(f.index)
            .ok()
            .and_then(|k| self.frames.get(k))
        else {
            return;
        };
        self.sink.frame(&GreyFrame { index: frame, ..*f });
    }
}
