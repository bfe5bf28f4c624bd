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

/// Hands one frame of `path`, whole, to `sink` as frame `frame`, decoding
/// from the key frame before it rather than from the start: ffmpeg's
/// accurate seek (`-ss`, an input option) goes to `at_s` on the file's
/// timeline, decodes from the key frame before it and drops the frames
/// before `at_s`. The caller puts `at_s` halfway between the frame's
/// presentation time and the one before it. Returns the ROI means of the
/// frame it landed on (`rois` in frame coordinates), for the caller to
/// check against the trace: a file whose index sends a seek to another
/// key frame lands on another frame. None when nothing came.
pub(in crate::capture) fn read_frame_seeking(
    path: &Path,
    opts: &ReadOptions,
    (frame, at_s): (u64, f64),
    (width, height, video): (u32, u32, VideoRead),
    rois: &[RoiRect],
    sink: &mut dyn FrameSink,
) -> Result<Option<Vec<f64>>, CaptureError> {
    drop(open_file(path)?);
    check_rois(path, frame, rois, width, height)?;
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
    let mut relabel = Relabel { sink, frame };
    let opts = ReadOptions {
        range: if video.full_range {
            VideoRange::Full
        } else {
            VideoRange::Limited
        },
        // A seek decodes a key frame's group, at most a few hundred frames,
        // and several seeks run at once (a case's sample and lit frames,
        // cases in parallel): frame threading would add its CPU and its
        // start-up delay, and no pixel changes with it.
        decoder_threads: Some(1),
        ..*opts
    };
    let trace = Decoder::start_at(path, layout, &opts, Some(at_s))?.read(
        path,
        probe,
        &opts,
        STALL,
        Some((&mut relabel, Some(0))),
    )?;
    Ok(trace.luma.iter().map(|roi| roi.first().copied()).collect())
}

/// Hands the first frame a seek gives to `sink` as frame `frame`.
struct Relabel<'s> {
    sink: &'s mut dyn FrameSink,
    frame: u64,
}

impl FrameSink for Relabel<'_> {
    fn frame(&mut self, f: &GreyFrame<'_>) {
        if f.index == 0 {
            self.sink.frame(&GreyFrame {
                index: self.frame,
                ..*f
            });
        }
    }
}
