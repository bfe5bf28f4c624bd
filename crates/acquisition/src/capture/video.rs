//! Video (MP4, MOV, MKV, ... with H.264 and anything else FFmpeg decodes)
//! through the `ffmpeg` and `ffprobe` binaries as subprocesses.
//!
//! FFmpeg cuts each ROI out of each frame with a 2-pixel margin, aligned to
//! even pixels so 4:2:0 chroma sites stay where they were, stacks these
//! tiles into one narrow picture, converts it and pipes the raw frames; this
//! process reads one frame at a time, so memory stays bounded. When the
//! tiles would not be much smaller than the ROIs' bounding box (one ROI, or
//! ROIs close together), the bounding box (with the same margin) is the one
//! tile. Only the tiles cross the pipe and the pixel-format conversion:
//! for the 36 small ROIs of the P2020 samples, 5 % of the bounding box.
//! - `rgb` decode: `-pix_fmt rgb24`, the same swscale conversion OpenCV uses in
//!   the P2020 reference pipeline, then per-pixel luma;
//! - `luma-plane` decode: `extractplanes=y` (Y' as stored, no conversion),
//!   then the limited-to-full range expansion in a lookup table.
//!
//! Timestamps are the container's presentation times (ffprobe's integer
//! packet PTS, sorted, times the stream's time base), with the frame rate
//! as a fallback; the time base and the stated frame rate go with them
//! (`analysis::timing` fits the rate to the times).
//!
//! ffmpeg starts at the same time as ffprobe, with the cut of a frame too
//! large to clamp any tile (`layout`), and is kept when ffprobe's frame
//! gives the same cut ([`probe_and_read`]), so ffprobe's start-up is not
//! paid before ffmpeg's.

use std::io::Read;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::thread::JoinHandle;
use std::time::Duration;

mod seek;

pub(super) use seek::read_frames_seeking;

use super::layout::Layout;
use super::probe::{Probe, drain_stderr, probe, stopped, tool_error};
use super::watch::{STALL, Watchdog};
use super::{
    Accumulator, CaptureError, CaptureTrace, FrameSink, FrameView, Pixels, ReadOptions, RoiRect,
    VideoDecode, VideoRange, VideoRead, check_rois, limited_to_full_lut, open_file, times_from_fps,
};

/// True when `ffmpeg` and `ffprobe` can be run.
pub fn ffmpeg_available() -> bool {
    ["ffmpeg", "ffprobe"].iter().all(|tool| {
        Command::new(tool)
            .arg("-version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    })
}

/// Probes the video at `path` and reads the ROI means of every frame.
///
/// ffmpeg starts at the same time as ffprobe, with the layout the ROIs get
/// in a frame large enough that nothing is clamped to its edges
/// ([`Layout::speculative`]); until the probe answers, ffmpeg blocks on its
/// full pipe. When the probe's frame gives the same layout, that ffmpeg is
/// read (the same command line as a start after the probe). Otherwise (ROIs
/// near an edge or outside the frame, a failed probe) its process group is
/// killed and reaped, and the capture goes on exactly as when ffprobe runs
/// first: the same errors, and a second ffmpeg with the frame's layout.
pub(super) fn probe_and_read(
    path: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    probe_and_read_with(path, rois, opts, probe, STALL)
}

/// [`probe_and_read`] through `probe_with`, with ffmpeg's watchdog at `stall`.
fn probe_and_read_with(
    path: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
    probe_with: impl FnOnce(&Path) -> Result<Probe, CaptureError>,
    stall: Duration,
) -> Result<CaptureTrace, CaptureError> {
    let ready = prepare_with(path, rois, opts, probe_with)?;
    ready.decoder.read(path, ready.probe, opts, stall, None)
}

/// Reads every frame of the video at `path` whole, handing each to `sink`.
pub(super) fn read_whole(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn FrameSink,
) -> Result<CaptureTrace, CaptureError> {
    let ready = prepare_with(path, &[], opts, probe)?;
    ready
        .decoder
        .read(path, ready.probe, opts, STALL, Some((sink, None)))
}

/// Hands the whole frames of `path` up to frame `last` (0-based) to
/// `sink`, then stops ffmpeg: a sample frame costs the decode up to it,
/// not the whole video's. A video shorter than that ends as it is.
pub(super) fn read_until(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn FrameSink,
    last: u64,
) -> Result<(), CaptureError> {
    let ready = prepare_with(path, &[], opts, probe)?;
    ready
        .decoder
        .read(path, ready.probe, opts, STALL, Some((sink, Some(last))))
        .map(drop)
}

/// A video probed, its ROIs checked, and its ffmpeg started on the layout
/// of its frame. ffmpeg decodes until its pipe is full and then waits,
/// using no CPU, until [`Prepared::read`]; dropped unread, its process
/// group is killed and reaped.
pub(super) struct Prepared {
    decoder: Decoder,
    probe: Probe,
}

impl Prepared {
    /// The pixels of every frame (packets times frame size): what decoding
    /// costs, to read the longest first.
    pub(super) fn work(&self) -> u64 {
        let frame = u64::from(self.probe.width) * u64::from(self.probe.height);
        (self.probe.packet_times.len() as u64).saturating_mul(frame)
    }

    /// Reads every frame, as [`probe_and_read`] does after the probe. The
    /// watchdog starts now: the time ffmpeg waited is not a stall.
    pub(super) fn read(
        self,
        path: &Path,
        opts: &ReadOptions,
    ) -> Result<CaptureTrace, CaptureError> {
        self.decoder.read(path, self.probe, opts, STALL, None)
    }
}

/// The first half of [`probe_and_read`]: probes `path` and starts its
/// ffmpeg, without reading a frame.
pub(super) fn prepare(
    path: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
) -> Result<Prepared, CaptureError> {
    prepare_with(path, rois, opts, probe)
}

/// [`prepare`] through `probe_with`.
fn prepare_with(
    path: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
    probe_with: impl FnOnce(&Path) -> Result<Probe, CaptureError>,
) -> Result<Prepared, CaptureError> {
    // FFmpeg's tools would wait on a FIFO (or read a device for ever):
    // anything but a regular file is refused before either starts.
    drop(open_file(path)?);
    // Not started (e.g. no `ffmpeg`): the start after the probe reports why.
    let early = Layout::speculative(rois).and_then(|l| Decoder::start(path, l, opts).ok());
    // On an error here `early` is dropped: its group killed and reaped.
    let probe = probe_with(path)?;
    check_rois(path, 0, rois, probe.width, probe.height)?;
    let layout = Layout::for_rois(rois, (probe.width, probe.height));
    let decoder = match early {
        Some(d) if d.layout == layout => d,
        early => {
            drop(early);
            Decoder::start(path, layout, opts)?
        }
    };
    Ok(Prepared { decoder, probe })
}

/// Reads the ROI means of every frame of the video at `path`, which `p`
/// describes, through the layout that `layout_for` chooses for the frame
/// size (tests compare layouts with it).
#[cfg(test)]
fn read_with(
    path: &Path,
    p: Probe,
    rois: &[RoiRect],
    opts: &ReadOptions,
    layout_for: fn(&[RoiRect], (u32, u32)) -> Layout,
) -> Result<CaptureTrace, CaptureError> {
    check_rois(path, 0, rois, p.width, p.height)?;
    let layout = layout_for(rois, (p.width, p.height));
    Decoder::start(path, layout, opts)?.read(path, p, opts, STALL, None)
}

/// An ffmpeg process decoding a video through `layout`, its stderr drained
/// on a thread. Dropped before [`Decoder::read`] has reaped it, its process
/// group is killed and reaped (a speculative start not needed, an error, a
/// panic).
struct Decoder {
    child: Child,
    err_thread: Option<JoinHandle<String>>,
    layout: Layout,
    reaped: bool,
}

impl Decoder {
    /// Starts ffmpeg on `path` through `layout`, in the pixel format of
    /// `opts.video_decode`.
    fn start(path: &Path, layout: Layout, opts: &ReadOptions) -> Result<Decoder, CaptureError> {
        Decoder::start_seeking(path, layout, opts, &[])
    }

    /// [`Decoder::start`] from `seeks[0]` seconds into the file when there
    /// is one time; with more, the first frame after each time (seconds
    /// into the file), in that order: one input per time, each seeking on
    /// its own, their first frames joined into one stream. One process rather than one per frame saves
    /// FFmpeg's start-up (about 0.05 s of CPU), and each frame is converted
    /// alone, as a single seek converts it.
    fn start_seeking(
        path: &Path,
        layout: Layout,
        opts: &ReadOptions,
        seeks: &[f64],
    ) -> Result<Decoder, CaptureError> {
        let (pix_fmt, _, planes) = pixel_format(opts.video_decode);
        let filter = if seeks.len() < 2 {
            layout.filter(planes)
        } else {
            let mut g = String::new();
            for i in 0..seeks.len() {
                g.push_str(&format!("[{i}:v:0]trim=end_frame=1[f{i}];"));
            }
            (0..seeks.len()).for_each(|i| g.push_str(&format!("[f{i}]")));
            g.push_str(&format!("concat=n={}:v=1:a=0[joined];", seeks.len()));
            g + &layout.filter_from("[joined]", planes)
        };
        let mut child = spawn_ffmpeg(path, &filter, pix_fmt, (opts.decoder_threads, seeks))?;
        if let Some(out) = &child.stdout {
            grow_pipe(out);
        }
        let err_thread = Some(drain_stderr(child.stderr.take()));
        Ok(Decoder {
            child,
            err_thread,
            layout,
            reaped: false,
        })
    }

    /// Reads every frame under a watchdog that fires after `stall` without
    /// a frame; `p` is the probe of `path`. With a sink, each whole frame
    /// also goes to it, and with a last frame the read stops after it
    /// (the trace then holds the frames read, and ffmpeg is killed).
    fn read(
        mut self,
        path: &Path,
        p: Probe,
        opts: &ReadOptions,
        stall: Duration,
        sink: Option<(&mut dyn FrameSink, Option<u64>)>,
    ) -> Result<CaptureTrace, CaptureError> {
        let (sink, last) = sink.map_or((None, None), |(s, last)| (Some(s), last));
        let (_, bpp, _) = pixel_format(opts.video_decode);
        let mut acc = Accumulator::new(&self.layout.rois, opts.luma)
            .linearising(opts.colour_transfer)
            .with_sink(sink);
        let full = match opts.range {
            VideoRange::Full => true,
            VideoRange::Limited => false,
            VideoRange::Auto => p.full_range.unwrap_or(false),
        };
        if opts.video_decode == VideoDecode::LumaPlane && !full {
            acc.expand = Some(limited_to_full_lut(8));
        }
        let layout = &self.layout;
        let frame_bytes = layout.width as usize * layout.height as usize * bpp;
        let dog = Watchdog::start(self.child.id(), stall);
        let read = read_frames(
            path,
            &mut self.child,
            &mut acc,
            (layout, frame_bytes, last),
            opts,
            &dog,
        );
        if last.is_some_and(|l| matches!(read, Ok((n, false)) if n > l)) {
            // Stopped on purpose: ffmpeg, its pipe closed, is killed and
            // reaped when the decoder drops; its status says nothing.
            let _ = dog.finish();
            return Ok(trace(acc, p, opts, full));
        }
        let status = self.child.wait().map_err(|e| tool_error(path, "ffmpeg", e));
        self.reaped = status.is_ok();
        let stderr_text = self
            .err_thread
            .take()
            .map_or_else(String::new, |t| t.join().unwrap_or_default());
        if let Some(fired) = dog.finish() {
            return Err(stopped(path, fired, "ffmpeg"));
        }
        let ((frame, partial), status) = (read?, status?);
        if !status.success() || partial {
            return Err(undecodable(path, frame, &stderr_text));
        }
        Ok(trace(acc, p, opts, full))
    }
}

impl Drop for Decoder {
    fn drop(&mut self) {
        if !self.reaped {
            ledflicker_plan::util::kill_group(self.child.id());
            let _ = self.child.wait();
        }
        if let Some(t) = self.err_thread.take() {
            let _ = t.join();
        }
    }
}

/// Most bytes ffmpeg's stdout pipe holds: frames it may decode ahead of
/// the reader (about 50 of the P2020 samples' tiles), e.g. while it waits
/// for the probe or for a core (`schedule`).
const PIPE_BYTES: libc::c_int = 1 << 20;

/// Lets the pipe `out` hold [`PIPE_BYTES`] (Linux's default largest size
/// for a user), rather than 64 KB. Where the system refuses, the pipe
/// keeps its size: this changes when ffmpeg waits, never what it writes.
fn grow_pipe(out: &std::process::ChildStdout) {
    use std::os::fd::AsRawFd;
    // SAFETY: F_SETPIPE_SZ on a pipe descriptor this process owns; it only
    // resizes the pipe's buffer, and its failure is harmless.
    unsafe { libc::fcntl(out.as_raw_fd(), libc::F_SETPIPE_SZ, PIPE_BYTES) };
}

/// ffmpeg's output pixel format, its bytes per pixel, and the filter that
/// ends the graph, for `decode`.
fn pixel_format(decode: VideoDecode) -> (&'static str, usize, &'static str) {
    match decode {
        VideoDecode::Rgb => ("rgb24", 3, ""),
        // Crop first (no copy), so extractplanes copies only the tiles.
        VideoDecode::LumaPlane => ("gray", 1, ",extractplanes=y"),
    }
}

/// Starts ffmpeg decoding the first video stream of `path` through the
/// filter graph `filter` (ending in `[out]`) to raw `pix_fmt` frames on its
/// stdout, with `threads` decoder threads and a one-thread filter graph
/// (FFmpeg's choice for both when `None`): from the start, or with one
/// input of `path` per time of `seeks` (seconds into the file), the
/// inputs numbered in that order.
fn spawn_ffmpeg(
    path: &Path,
    filter: &str,
    pix_fmt: &str,
    (threads, seeks): (Option<usize>, &[f64]),
) -> Result<Child, CaptureError> {
    let mut cmd = Command::new("ffmpeg");
    cmd.args(["-nostdin", "-v", "error", "-xerror"]);
    if threads.is_some() {
        // Decoders that share the cores: the filter graph (crops, stack,
        // conversion of a small picture) runs on one thread, which costs
        // less CPU than handing slices to a pool (about 7 % less for the
        // P2020 samples).
        cmd.args(["-filter_complex_threads", "1"]);
    }
    let input = |cmd: &mut Command, seek_s: Option<f64>| {
        if let Some(at) = seek_s {
            // Microseconds, FFmpeg's own time unit: a shorter decimal could
            // round past the midpoint between two frames.
            cmd.arg("-ss").arg(format!("{at:.6}"));
        }
        if let Some(n) = threads {
            cmd.arg("-threads").arg(n.to_string());
        }
        // Frames as stored, whatever rotation the file tags them with for
        // display, and cropped exactly as the stream says (FFmpeg's H.264
        // decoder otherwise keeps up to 31 columns of a left crop to align
        // its rows): ffprobe's width and height, which the ROIs are checked
        // against, are the picture's so read.
        cmd.args(["-noautorotate", "-flags", "unaligned", "-i"])
            .arg(path);
    };
    if seeks.is_empty() {
        input(&mut cmd, None);
    }
    for &at in seeks {
        input(&mut cmd, Some(at));
    }
    cmd.args([
        "-filter_complex",
        filter,
        "-map",
        "[out]",
        "-fps_mode",
        "passthrough",
        "-f",
        "rawvideo",
        "-pix_fmt",
        pix_fmt,
        "-",
    ])
    .stdin(Stdio::null())
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .process_group(0)
    .spawn()
    .map_err(|e| tool_error(path, "ffmpeg", e))
}

/// Feeds every whole frame of ffmpeg's stdout to `acc`, up to frame `last`
/// when given. Returns the frames read and whether the stream ended inside
/// a frame; a read error kills ffmpeg and names the frame.
fn read_frames(
    path: &Path,
    child: &mut Child,
    acc: &mut Accumulator<'_>,
    (layout, frame_bytes, last): (&Layout, usize, Option<u64>),
    opts: &ReadOptions,
    dog: &Watchdog,
) -> Result<(u64, bool), CaptureError> {
    let mut buf = vec![0u8; frame_bytes];
    let mut frame: u64 = 0;
    let Some(mut out) = child.stdout.take() else {
        return Ok((frame, false));
    };
    loop {
        match read_full(&mut out, &mut buf) {
            Ok(0) => return Ok((frame, false)),
            Ok(n) if n == frame_bytes => {
                let pixels = match opts.video_decode {
                    VideoDecode::Rgb => Pixels::Rgb8(&buf, 3),
                    VideoDecode::LumaPlane => Pixels::Grey8(&buf),
                };
                acc.push(&FrameView {
                    pixels,
                    origin: (0, 0),
                    width: layout.width,
                });
                frame += 1;
                dog.tick();
                if last.is_some_and(|l| frame > l) {
                    return Ok((frame, false));
                }
            }
            Ok(_) => return Ok((frame, true)),
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(CaptureError::Frame {
                    path: path.to_path_buf(),
                    frame,
                    message: format!("reading decoded frames failed: {e}"),
                });
            }
        }
    }
}

/// ffmpeg failed, or stopped inside a frame, at `frame`; its first lines
/// of stderr say why.
fn undecodable(path: &Path, frame: u64, stderr_text: &str) -> CaptureError {
    let detail = stderr_text.trim();
    CaptureError::Frame {
        path: path.to_path_buf(),
        frame,
        message: format!(
            "the video cannot be decoded from this frame on (corrupt or truncated){}",
            if detail.is_empty() {
                String::new()
            } else {
                format!(
                    ": {}",
                    detail.lines().take(3).collect::<Vec<_>>().join("; ")
                )
            }
        ),
    }
}

/// The trace of the frames in `acc`: timestamps from the container when
/// every frame has one, else from the frame rate. `full` is the Y' range
/// used.
fn trace(acc: Accumulator<'_>, p: Probe, opts: &ReadOptions, full: bool) -> CaptureTrace {
    let n = acc.frames();
    let (luma, rgb) = acc.finish();
    let container = p.packet_times.len() == n && n > 0;
    let (time_s, timestamps) = if container {
        (
            p.packet_times,
            ledflicker_plan::trace::TimestampSource::Container,
        )
    } else {
        match p.fps.or(opts.fps) {
            Some(fps) => (
                times_from_fps(n, fps),
                ledflicker_plan::trace::TimestampSource::Fps,
            ),
            None => (
                times_from_fps(n, f64::NAN),
                ledflicker_plan::trace::TimestampSource::None,
            ),
        }
    };
    CaptureTrace {
        time_s,
        luma,
        rgb,
        full_scale_dn: 255.0,
        frame_size: (p.width, p.height),
        timestamps,
        format: format!(
            "video {} {} {}x{} (ffmpeg, {})",
            p.codec,
            p.pix_fmt,
            p.width,
            p.height,
            match opts.video_decode {
                VideoDecode::Rgb => "rgb24".to_string(),
                VideoDecode::LumaPlane =>
                    format!("Y' plane, {} range", if full { "full" } else { "limited" }),
            }
        ),
        time_base_s: p.time_base_s.filter(|_| container),
        stated_fps: p.stated_fps,
        video: Some(VideoRead {
            origin_s: p.seek_origin_s.filter(|_| container),
            full_range: full,
        }),
    }
}

/// Reads until `buf` is full or the stream ends; returns the bytes read.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests;
