//! Captured camera data -> per-frame ROI means, streaming.
//!
//! Sits in front of the captured and command backends: it reads image
//! sequences (PNG 8/16-bit, TIFF incl. LZW; grey or RGB), Y4M files, MP4/MOV
//! video (through the `ffmpeg` binary, as a subprocess) and CSV luma traces,
//! one frame at a time, and keeps only the mean luma (and R, G, B means when
//! the source has colour) of every ROI. Memory is bounded by one frame (or,
//! for video, the ROIs' bounding box) plus the traces.
//!
//! Luma follows the P2020 reference pipeline (CARpublic/P2020-flicker): the
//! frame is full-range RGB, grey is taken per pixel (BT.601 by default, as
//! OpenCV's `COLOR_BGR2GRAY`, rounded to whole DN as an integer image would
//! be), and the ROI mean is the mean of those grey pixels.

mod accumulate;
mod built_in;
mod csv_trace;
mod grey;
mod images;
mod layout;
mod mp4;
mod probe;
mod progress;
mod schedule;
mod video;
mod watch;
mod waveform;
mod y4m;

pub(crate) use accumulate::Accumulator;
pub use grey::{FrameSink, GreyFrame};

use std::path::{Path, PathBuf};

pub use csv_trace::MAX_CSV_LUMA_DN;
pub use progress::{decode_progress_text, frames_decoded};
pub use schedule::{AT_ONCE, read_captures};
pub use video::ffmpeg_available;
pub use waveform::{Column, Waveform, read_waveform, sample_rate};

pub(crate) use built_in::built_in_copy;
use built_in::with_built_in;

// The plan's `[capture]` choices; defined with the plan, read here.
pub use ledflicker_plan::plan::{ColourTransfer, LumaWeights, VideoDecode, VideoRange};
pub use ledflicker_plan::trace::Ratio;

/// A rectangle of pixels, 0-based from the top-left corner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RoiRect {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width in columns (>= 1).
    pub width: u32,
    /// Height in rows (>= 1).
    pub height: u32,
}

/// How to read a capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadOptions {
    /// Luma weights for RGB sources.
    pub luma: LumaWeights,
    /// Video decode path.
    pub video_decode: VideoDecode,
    /// Y' range of video and Y4M.
    pub range: VideoRange,
    /// How R, G and B codes encode light: the colour planes' ROI means are
    /// of the codes decoded with it (the luma's are of the codes).
    pub colour_transfer: ColourTransfer,
    /// Frame rate used for timestamps when the source has none, frames/s.
    pub fps: Option<f64>,
    /// Threads of each FFmpeg video decoder; `None` leaves FFmpeg's choice
    /// (one per core). Several captures read at once share the cores;
    /// with `Some`, the filter graph runs on one thread too.
    pub decoder_threads: Option<usize>,
}

/// ROI means of every frame of a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureTrace {
    /// Time of each frame from the first, seconds.
    pub time_s: Vec<f64>,
    /// `luma[roi][frame]`, DN.
    pub luma: Vec<Vec<f64>>,
    /// `rgb[roi][frame]` R, G, B means, DN, when the source has colour.
    pub rgb: Option<Vec<Vec<[f64; 3]>>>,
    /// Largest value of the source's scale, DN (255 for 8-bit).
    pub full_scale_dn: f64,
    /// Frame width and height, pixels (0 for CSV traces).
    pub frame_size: (u32, u32),
    /// Where the timestamps came from: "container", "sidecar", "fps", "csv".
    pub timestamps: ledflicker_plan::trace::TimestampSource,
    /// What was read, e.g. "video h264 (ffmpeg, rgb24)".
    pub format: String,
    /// The container's time base, seconds, when `time_s` are its timestamps.
    pub time_base_s: Option<Ratio>,
    /// The frame rate the source states, frames/s, when it states one.
    pub stated_fps: Option<Ratio>,
    /// For a video, what reading one of its frames again by seeking needs.
    pub video: Option<VideoRead>,
}

/// How a video was read, so that one frame of it can be read again by
/// seeking ([`read_grey_frame`]) rather than by decoding it from the start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VideoRead {
    /// Where the first frame is on the timeline that ffmpeg's `-ss` seeks
    /// on (the file's start time is 0 there), seconds: frame `k` is at
    /// `origin_s + time_s[k]`. None when the probe gave no times.
    pub origin_s: Option<f64>,
    /// Whether the Y' range read was full (else limited).
    pub full_range: bool,
}

/// Why a capture could not be read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The file or directory is missing or unreadable.
    #[error("cannot read capture `{path}`: {message}")]
    Read {
        /// Path.
        path: PathBuf,
        /// Cause.
        message: String,
    },
    /// A frame is corrupt, truncated or inconsistent with the others.
    #[error("capture `{path}`, frame {frame}: {message}")]
    Frame {
        /// Path of the capture (or of the frame's file).
        path: PathBuf,
        /// 0-based frame number.
        frame: u64,
        /// What is wrong.
        message: String,
    },
    /// A ROI does not lie on the capture's frame.
    #[error(
        "capture `{path}`, frame {frame}: ROI `{name}` (columns {}..{}, rows {}..{}) falls outside the {width}x{height} frame\n    hint: pixels are 0-based: x-px + width-px must be at most {width} and y-px + height-px at most {height}",
        .rect.x,
        .rect.x as u64 + .rect.width as u64,
        .rect.y,
        .rect.y as u64 + .rect.height as u64
    )]
    RoiOutside {
        /// Path of the capture (or of the frame's file).
        path: PathBuf,
        /// 0-based frame number.
        frame: u64,
        /// The ROI's name; `roi[i]` (its key path, 0-based) until the
        /// reader's caller names it ([`CaptureError::with_roi_names`]).
        name: String,
        /// Its index in the ROIs read.
        index: usize,
        /// Its rectangle.
        rect: RoiRect,
        /// Frame width, pixels.
        width: u32,
        /// Frame height, pixels.
        height: u32,
    },
    /// The capture as a whole is unusable (no frames, unknown format, ...).
    #[error("capture `{path}`: {message}\n    hint: {hint}")]
    Invalid {
        /// Path.
        path: PathBuf,
        /// What is wrong.
        message: String,
        /// How to fix it.
        hint: String,
    },
    /// An external tool (ffmpeg) is missing or broke.
    #[error("capture `{path}`: {message}")]
    Tool {
        /// Path.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The user stopped the read (Ctrl-C, SIGTERM); the signal is the
    /// source, so that the exit code is the signal's.
    #[error("reading capture `{path}` was stopped")]
    Interrupted {
        /// Path.
        path: PathBuf,
        /// The signal.
        #[source]
        source: crate::interrupt::Interrupted,
    },
}

impl CaptureError {
    /// True for problems with the input (exit code 2), false for a missing
    /// or failing tool (exit code 3) and for a read the user stopped.
    pub fn is_input_error(&self) -> bool {
        match self {
            CaptureError::Read { .. }
            | CaptureError::Frame { .. }
            | CaptureError::RoiOutside { .. }
            | CaptureError::Invalid { .. } => true,
            CaptureError::Tool { .. } | CaptureError::Interrupted { .. } => false,
        }
    }
}

impl CaptureError {
    /// The error with its ROI named from `names` (the plan's ROI names,
    /// in the order of the ROIs read): readers know ROIs by index only.
    pub fn with_roi_names(self, names: &[String]) -> CaptureError {
        match self {
            CaptureError::RoiOutside {
                path,
                frame,
                name,
                index,
                rect,
                width,
                height,
            } => CaptureError::RoiOutside {
                name: names.get(index).cloned().unwrap_or(name),
                path,
                frame,
                index,
                rect,
                width,
                height,
            },
            other => other,
        }
    }
}

/// `Err(Interrupted)` naming `path` once the user asked the run to stop
/// (SIGINT, SIGTERM). Long reads poll it every frame (or chunk), so that
/// Ctrl-C stops a read of a large capture within a frame's time.
pub fn check_interrupt(path: &Path) -> Result<(), CaptureError> {
    crate::interrupt::check().map_err(|source| CaptureError::Interrupted {
        path: path.to_path_buf(),
        source,
    })
}

/// Opens a capture file for reading: a FIFO, a device, a socket or a
/// directory in its place is refused at once (never waited on), naming it.
pub(crate) fn open_file(path: &Path) -> Result<std::fs::File, CaptureError> {
    ledflicker_plan::util::open_input(path).map_err(|e| CaptureError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Bytes read at a time by [`read_file`] between checks for Ctrl-C.
const READ_CHUNK: usize = 8 << 20;

/// The whole of a capture file ([`open_file`]), read in chunks with a
/// check for Ctrl-C between them.
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, CaptureError> {
    use std::io::Read;
    let mut file = open_file(path)?;
    let len = file.metadata().map_or(0, |m| m.len());
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0).min(1 << 30));
    loop {
        check_interrupt(path)?;
        let n = (&mut file)
            .take(READ_CHUNK as u64)
            .read_to_end(&mut bytes)
            .map_err(|e| CaptureError::Read {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
        if n == 0 {
            return Ok(bytes);
        }
    }
}

/// An image decoder on the frame file `path` ([`open_file`]): the format
/// from the file name, corrected by the file's first bytes.
pub fn image_reader(path: &Path) -> Result<ledflicker_plan::image_io::FileReader, CaptureError> {
    let file = open_file(path)?;
    let mut reader = image::ImageReader::new(std::io::BufReader::new(file));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    reader
        .with_guessed_format()
        .map_err(|e| CaptureError::Read {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// The kind of capture a path holds, from its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceKind {
    /// A directory of PNG or TIFF frames, sorted by name.
    ImageDir,
    /// A single PNG or TIFF frame.
    Image,
    /// A YUV4MPEG2 file.
    Y4m,
    /// Anything FFmpeg reads: MP4, MOV, MKV, AVI.
    Video,
    /// A CSV luma trace.
    Csv,
}

/// Guesses the kind of capture at `path` from its extension.
pub fn source_kind(path: &Path) -> SourceKind {
    if path.is_dir() {
        return SourceKind::ImageDir;
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "png" | "tif" | "tiff" => SourceKind::Image,
        "y4m" => SourceKind::Y4m,
        "csv" => SourceKind::Csv,
        _ => SourceKind::Video,
    }
}

/// The frame size (width, height in pixels) of the capture at `path`,
/// read from the first frame's header (an image, a Y4M header), an MP4 or
/// MOV file's sample description, or ffprobe's stream facts, without
/// decoding a frame; `None` for a CSV
/// trace, which has no frame, and for a capture that cannot be read now
/// (its read at run time says why). Plan validation checks ROIs with it
/// ([`ledflicker_plan::plan::FrameSize`]).
pub fn frame_size(path: &Path) -> Option<(u32, u32)> {
    with_built_in(path, |path| Ok(frame_size_on_disk(path)))
        .ok()
        .flatten()
}

fn frame_size_on_disk(path: &Path) -> Option<(u32, u32)> {
    // A FIFO or a device in a capture's place is never waited on.
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file() || m.is_dir()) {
        return None;
    }
    match source_kind(path) {
        SourceKind::ImageDir => images::frame_size(images::frame_files(path).ok()?.first()?),
        SourceKind::Image => images::frame_size(path),
        SourceKind::Y4m => y4m::frame_size(path),
        SourceKind::Video => mp4::frame_size(path).or_else(|| probe::frame_size(path)),
        SourceKind::Csv => None,
    }
}

/// Reads the capture at `path` and returns the means of `rois` in every
/// frame. `roi_names` name the columns of a CSV trace.
pub fn read_capture(
    path: &Path,
    rois: &[RoiRect],
    roi_names: &[String],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    with_built_in(path, |path| {
        read_capture_on_disk(path, rois, roi_names, opts)
    })
}

fn read_capture_on_disk(
    path: &Path,
    rois: &[RoiRect],
    roi_names: &[String],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    check_exists(path)?;
    let trace = match source_kind(path) {
        SourceKind::ImageDir => images::read_dir(path, rois, opts, None),
        SourceKind::Image => images::read_files(path, &[path.to_path_buf()], rois, opts, None),
        SourceKind::Y4m => y4m::read(path, rois, opts, None),
        SourceKind::Video => video::probe_and_read(path, rois, opts),
        SourceKind::Csv => csv_trace::read(path, roi_names, opts),
    }
    .map_err(|e| e.with_roi_names(roi_names))?;
    finish_trace(path, trace)
}

/// The error of a capture `path` that does not exist.
fn check_exists(path: &Path) -> Result<(), CaptureError> {
    if path.exists() {
        return Ok(());
    }
    Err(CaptureError::Read {
        path: path.to_path_buf(),
        message: "no such file or directory".to_string(),
    })
}

/// The checks and the timestamp sidecar that every capture's trace gets
/// after its frames are read.
fn finish_trace(path: &Path, mut trace: CaptureTrace) -> Result<CaptureTrace, CaptureError> {
    if trace.time_s.is_empty() {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: "the capture has no frames".to_string(),
            hint: "check that the recording finished and the file is complete".to_string(),
        });
    }
    // A sidecar `<capture>.timestamps.csv` (one time in seconds per line, or
    // `frame,time_s`) overrides other timestamps.
    let sidecar = sidecar_path(path);
    // Whatever stands at the sidecar's name is read: a FIFO or a
    // directory there is refused, not skipped.
    if std::fs::symlink_metadata(&sidecar).is_ok() {
        trace.time_s = read_sidecar(&sidecar, trace.time_s.len())?;
        trace.timestamps = ledflicker_plan::trace::TimestampSource::Sidecar;
        // The sidecar's times are not in the container's unit.
        trace.time_base_s = None;
    }
    check_times(path, &trace.time_s)?;
    if trace.timestamps == ledflicker_plan::trace::TimestampSource::None {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: "the capture has no timestamps".to_string(),
            hint: format!(
                "set capture.frame-rate-fps, or give one time per frame in `{}`",
                sidecar.display()
            ),
        });
    }
    Ok(trace)
}

/// The timestamp sidecar of the capture `path`: `<path>.timestamps.csv`.
pub fn sidecar_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".timestamps.csv");
    PathBuf::from(s)
}

fn read_sidecar(path: &Path, frames: usize) -> Result<Vec<f64>, CaptureError> {
    let bytes = read_file(path)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!("line {line} holds binary data (byte {at}), not text"),
            hint: "one time in seconds per frame, or `frame,time_s` rows".to_string(),
        }
    })?;
    let hint = "one time in seconds per frame, or `frame,time_s` rows";
    let mut out = Vec::with_capacity(frames);
    let mut rows = csv_trace::Rows::new(&text);
    while let Some((line, row)) = rows.next(path, hint)? {
        // An indented comment line.
        if row.get(0).is_some_and(|f| f.trim_start().starts_with('#')) {
            continue;
        }
        // The last field: the time of a `frame,time_s` row or of a lone time.
        let field = row.iter().next_back().map_or("", str::trim);
        match field.parse::<f64>() {
            Ok(t) if t.is_finite() => out.push(t),
            _ if out.is_empty() && line == 1 => continue, // header
            _ => {
                return Err(CaptureError::Invalid {
                    path: path.to_path_buf(),
                    message: format!(
                        "line {line}: `{}` is not a time in seconds",
                        field.chars().take(40).collect::<String>()
                    ),
                    hint: hint.to_string(),
                });
            }
        }
    }
    if out.len() != frames {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!("{} timestamps for {frames} frames", out.len()),
            hint: "give one timestamp per frame".to_string(),
        });
    }
    Ok(out)
}

/// Frame times must rise strictly: a reversed or repeated timestamp is an
/// error naming the frame (NaN times, from a capture without a frame rate,
/// are left to the "no timestamps" error).
fn check_times(path: &Path, times: &[f64]) -> Result<(), CaptureError> {
    for (i, w) in times.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        if a.is_nan() || b.is_nan() {
            continue;
        }
        if b <= a {
            return Err(CaptureError::Frame {
                path: path.to_path_buf(),
                frame: (i + 1) as u64,
                message: format!(
                    "timestamp {b} s is {} frame {i}'s {a} s; frame times must rise",
                    if b == a { "the same as" } else { "before" }
                ),
            });
        }
    }
    Ok(())
}

/// Frame times `k / fps`.
fn times_from_fps(n: usize, fps: f64) -> Vec<f64> {
    (0..n).map(|k| k as f64 / fps).collect()
}

/// Checks the ROIs against the frame size.
fn check_rois(
    path: &Path,
    frame: u64,
    rois: &[RoiRect],
    width: u32,
    height: u32,
) -> Result<(), CaptureError> {
    for (i, r) in rois.iter().enumerate() {
        if r.x as u64 + r.width as u64 > width as u64
            || r.y as u64 + r.height as u64 > height as u64
        {
            return Err(CaptureError::RoiOutside {
                path: path.to_path_buf(),
                frame,
                name: format!("roi[{i}]"),
                index: i,
                rect: *r,
                width,
                height,
            });
        }
    }
    Ok(())
}

/// The smallest rectangle holding every ROI.
fn bounding_box(rois: &[RoiRect]) -> Option<RoiRect> {
    let x0 = rois.iter().map(|r| r.x).min()?;
    let y0 = rois.iter().map(|r| r.y).min()?;
    let x1 = rois.iter().map(|r| r.x + r.width).max()?;
    let y1 = rois.iter().map(|r| r.y + r.height).max()?;
    Some(RoiRect {
        x: x0,
        y: y0,
        width: x1 - x0,
        height: y1 - y0,
    })
}

/// Pixels of one frame (or of a crop of it), in one of the layouts sources give.
pub(crate) enum Pixels<'a> {
    /// One grey sample per pixel, 8-bit.
    Grey8(&'a [u8]),
    /// One grey sample per pixel, 16-bit.
    Grey16(&'a [u16]),
    /// Interleaved R, G, B, 8-bit; `channels` samples per pixel (3 or 4).
    Rgb8(&'a [u8], usize),
    /// Interleaved R, G, B, 16-bit; `channels` samples per pixel (3 or 4).
    Rgb16(&'a [u16], usize),
}

/// A frame view: `pixels` covers the rectangle `origin` + `width` x rows.
pub(crate) struct FrameView<'a> {
    pub pixels: Pixels<'a>,
    /// Frame coordinates of the view's top-left pixel.
    pub origin: (u32, u32),
    /// Width of the view in pixels (the row stride).
    pub width: u32,
}

/// `[roi][frame]` R, G, B means, DN.
pub(crate) type RgbTraces = Vec<Vec<[f64; 3]>>;

/// Reads every frame of the capture at `path` whole, handing each to
/// `sink` as grey pixels; returns the capture's trace (frame times, scale,
/// size) without ROIs. A CSV trace has no pixels and is refused.
pub fn read_grey_frames(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn FrameSink,
) -> Result<CaptureTrace, CaptureError> {
    with_built_in(path, |path| read_grey_frames_on_disk(path, opts, sink))
}

/// Hands frame `frame` of a capture, whole, to `sink` (with the frames
/// before it), and returns the capture's full scale: a video is decoded up
/// to that frame only, the other kinds are read whole.
pub fn read_grey_frame(
    path: &Path,
    opts: &ReadOptions,
    frame: u64,
    sink: &mut dyn FrameSink,
) -> Result<f64, CaptureError> {
    with_built_in(path, |path| {
        if source_kind(path) == SourceKind::Video {
            check_exists(path)?;
            // Every video is decoded to 8-bit codes.
            video::read_until(path, opts, sink, frame).map(|()| 255.0)
        } else {
            read_grey_frames_on_disk(path, opts, sink).map(|t| t.full_scale_dn)
        }
    })
}

/// Where a video's frames are, so that they can be read by seeking.
pub struct FrameSeek<'a> {
    /// Frame width and height, pixels.
    pub size: (u32, u32),
    /// How the video was read.
    pub video: VideoRead,
    /// The ROIs, frame coordinates.
    pub rois: &'a [RoiRect],
    /// The frames wanted.
    pub frames: &'a [SeekTo<'a>],
}

/// One frame wanted by [`FrameSeek`].
pub struct SeekTo<'a> {
    /// Frame number, 0-based.
    pub frame: u64,
    /// Where ffmpeg's `-ss` goes: halfway between the frame's presentation
    /// time and the one before it, on the file's timeline, seconds.
    pub at_s: f64,
    /// The frame's ROI means as the trace holds them, DN.
    pub means: &'a [f64],
}

/// Most difference, DN, between a ROI mean of the frame a seek landed on
/// and the trace's mean of the frame wanted: the same pixels give the same
/// sums; this only absorbs the order they are added in.
const SEEK_MEANS_TOLERANCE_DN: f64 = 1e-9;

/// Hands each frame of `seek.frames` of the video at `path`, whole, to
/// `sink`, decoding it from the key frame before it rather than from the
/// start (all of them in one FFmpeg process), and says for each whether the
/// frame that came has its `means` in every ROI. False (a file whose index
/// sends the seek elsewhere, or no ROI to check by): the frame `sink` got
/// under that number, if any, is not the one wanted, and the caller reads
/// it from the start ([`read_grey_frame`]).
pub fn read_video_frames_seeking(
    path: &Path,
    opts: &ReadOptions,
    seek: &FrameSeek<'_>,
    sink: &mut dyn FrameSink,
) -> Result<Vec<bool>, CaptureError> {
    if seek.rois.is_empty() || seek.frames.is_empty() {
        return Ok(vec![false; seek.frames.len()]);
    }
    let seeks: Vec<(u64, f64)> = seek.frames.iter().map(|s| (s.frame, s.at_s)).collect();
    let got = with_built_in(path, |path| {
        let (w, h) = seek.size;
        video::read_frames_seeking(path, opts, &seeks, (w, h, seek.video), seek.rois, sink)
    })?;
    let landed = |s: &SeekTo<'_>, got: Option<Vec<f64>>| {
        got.is_some_and(|got| {
            got.len() == s.means.len()
                && got
                    .iter()
                    .zip(s.means)
                    .all(|(a, b)| (a - b).abs() <= SEEK_MEANS_TOLERANCE_DN)
        })
    };
    Ok(seek
        .frames
        .iter()
        .zip(got)
        .map(|(s, got)| landed(s, got))
        .collect())
}

fn read_grey_frames_on_disk(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn FrameSink,
) -> Result<CaptureTrace, CaptureError> {
    check_exists(path)?;
    let trace = match source_kind(path) {
        SourceKind::ImageDir => images::read_dir(path, &[], opts, Some(sink))?,
        SourceKind::Image => {
            images::read_files(path, &[path.to_path_buf()], &[], opts, Some(sink))?
        }
        SourceKind::Y4m => y4m::read(path, &[], opts, Some(sink))?,
        SourceKind::Video => video::read_whole(path, opts, sink)?,
        SourceKind::Csv => {
            return Err(CaptureError::Invalid {
                path: path.to_path_buf(),
                message: "a CSV trace holds ROI means, not pixels".to_string(),
                hint: "give the video or image sequence the trace was made from".to_string(),
            });
        }
    };
    finish_trace(path, trace)
}

/// Lookup table from limited-range Y' (`bits` bits) to full-range grey,
/// rounded and clipped: 8-bit `(Y' - 16) * 255 / 219`.
/// The table has `2^bits` entries for 8-bit samples and 65536 for wider
/// ones, so that any stored sample indexes it.
pub(crate) fn limited_to_full_lut(bits: u32) -> Vec<u32> {
    let max = (1u32 << bits) - 1;
    let len = if bits <= 8 { 256 } else { 65536 };
    let scale = (1u32 << (bits - 8)) as f64;
    let (lo, span) = (16.0 * scale, 219.0 * scale);
    (0..len as u32)
        .map(|y| {
            let v = ((y as f64 - lo) * max as f64 / span).round();
            v.clamp(0.0, max as f64) as u32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A P2020 sample video of the repository's reference data.
    pub(super) fn p2020_sample(name: &str) -> PathBuf {
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("reference-data/p2020-flicker-videos")
            .join(name)
    }

    #[test]
    fn bt601_grey_matches_opencv_fixed_point_on_corners() {
        let w = LumaWeights::Bt601;
        assert_eq!(w.luma(0, 0, 0), 0);
        assert_eq!(w.luma(255, 255, 255), 255);
        assert_eq!(w.luma(255, 0, 0), 76);
        assert_eq!(w.luma(0, 255, 0), 150);
        assert_eq!(w.luma(0, 0, 255), 29);
        assert_eq!(LumaWeights::Bt709.luma(0, 255, 0), 182);
    }

    #[test]
    fn limited_range_expands_16_235_to_0_255() {
        let lut = limited_to_full_lut(8);
        assert_eq!(lut[16], 0);
        assert_eq!(lut[235], 255);
        assert_eq!(lut[0], 0);
        assert_eq!(lut[255], 255);
        assert_eq!(lut[126], 128);
    }

    #[test]
    fn accumulator_means_only_the_roi_pixels() {
        // 4x3 grey frame, values = 10 * row + column.
        let px: Vec<u8> = (0..3)
            .flat_map(|r| (0..4).map(move |c| 10 * r + c))
            .collect();
        let rois = [RoiRect {
            x: 1,
            y: 1,
            width: 2,
            height: 2,
        }];
        let mut acc = Accumulator::new(&rois, LumaWeights::Bt601);
        acc.push(&FrameView {
            pixels: Pixels::Grey8(&px),
            origin: (0, 0),
            width: 4,
        });
        let (luma, rgb) = acc.finish();
        assert_eq!(luma[0], vec![(11.0 + 12.0 + 21.0 + 22.0) / 4.0]);
        assert!(rgb.is_none());
    }
}
