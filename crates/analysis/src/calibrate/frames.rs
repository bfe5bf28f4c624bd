//! Frames in, strip row profiles out: the input side of `linetime`, `bands`
//! and `calibrate`.
//!
//! Still frames (PNG, TIFF 8/16 bit, JPEG) are read with the `image` crate;
//! anything else (a video, a Y4M file, a directory of frames) through the
//! capture readers of [`ledflicker_acquisition::capture`], with one ROI per row and column
//! strip. Luma is BT.601 in the source's DN (0..255 or 0..65535).
//!
//! Each analysed row is split into [`STRIPS`] column strips and the mean of
//! each strip is kept. With several frames, static scene texture is divided
//! out: each strip cell is divided by its mean over the frames
//! (docs/calibration.md, "Real inputs").

use std::ops::Range;
use std::path::{Path, PathBuf};

use image::DynamicImage;

use super::bands::{Layout, StripProfiles};
use ledflicker_acquisition::capture::{
    self, CaptureError, LumaWeights, ReadOptions, RoiRect, VideoDecode, VideoRange,
};

/// Column strips per row.
pub const STRIPS: usize = 16;

/// Why frames could not be read. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// The file is missing or not a readable image.
    #[error("cannot read frame `{path}`: {message}")]
    Read {
        /// Path.
        path: PathBuf,
        /// Cause.
        message: String,
    },
    /// The input does not fit the request (ROI, frame range, sizes).
    #[error("{message}\n    hint: {hint}")]
    Invalid {
        /// What is wrong, naming the file or flag.
        message: String,
        /// How to fix it.
        hint: String,
    },
    /// A capture reader failed.
    #[error(transparent)]
    Capture(#[from] CaptureError),
}

/// One source file and its SHA-256.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Source {
    /// Path as given.
    pub path: String,
    /// SHA-256 of the file's bytes, lowercase hex ("" for a directory).
    pub sha256: String,
}

/// Row profiles of the analysed frames.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSet {
    /// The files read.
    pub sources: Vec<Source>,
    /// `[frame][strip][row]` strip means, DN.
    pub raw: StripProfiles,
    /// Largest value of the source's scale, DN (255 for 8-bit).
    pub full_scale_dn: f64,
    /// Frame width and height, pixels.
    pub frame_size: (u32, u32),
    /// The analysed rectangle.
    pub roi: RoiRect,
    /// Some input went through a block-transform codec (a JPEG still, or a
    /// video read through FFmpeg): its block grid is not banding.
    pub block_grid: bool,
}

impl FrameSet {
    /// Frames read.
    pub fn frames(&self) -> usize {
        self.raw.len()
    }

    /// With two or more frames, every strip cell divided by its mean over
    /// the frames: static texture cancels and the rolling bands remain.
    /// `None` for a single frame.
    pub fn flattened(&self) -> Option<StripProfiles> {
        if self.raw.len() < 2 {
            return None;
        }
        let frames = self.raw.len() as f64;
        let mut out = self.raw.clone();
        for s in 0..self.raw[0].len() {
            for r in 0..self.raw[0][s].len() {
                let mean = self.raw.iter().map(|f| f[s][r]).sum::<f64>() / frames;
                for f in out.iter_mut() {
                    // A black cell carries no texture to divide out.
                    f[s][r] = if mean > 1e-9 { f[s][r] / mean } else { 1.0 };
                }
            }
        }
        Some(out)
    }

    /// What the band estimator needs to know of the strips: their pixel
    /// columns and whether the source is block-coded.
    pub fn layout(&self) -> Layout {
        Layout {
            columns: strip_columns(&self.roi)
                .iter()
                .map(|c| [c.start, c.end])
                .collect(),
            block_grid: self.block_grid,
        }
    }

    /// Per-frame row profile: the median over strips of each row, DN.
    pub fn profiles(&self) -> Vec<Vec<f64>> {
        self.raw
            .iter()
            .map(|f| super::bands::combine_strips(f))
            .collect()
    }
}

/// Parses `X,Y,W,H` (pixels).
pub fn parse_roi(s: &str) -> Result<RoiRect, String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|x| x.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--roi `{s}` is not X,Y,W,H in whole pixels"))?;
    match v.as_slice() {
        &[x, y, width, height] if width > 0 && height > 0 => Ok(RoiRect {
            x,
            y,
            width,
            height,
        }),
        _ => Err(format!(
            "--roi `{s}` is not X,Y,W,H with W, H >= 1, e.g. 0,100,1920,600"
        )),
    }
}

/// Parses `A..B` (0-based, B exclusive).
pub fn parse_frames(s: &str) -> Result<Range<usize>, String> {
    let bad =
        || format!("--frames `{s}` is not A..B with A < B (0-based, B exclusive), e.g. 0..30");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a: usize = a.trim().parse().map_err(|_| bad())?;
    let b: usize = b.trim().parse().map_err(|_| bad())?;
    if a >= b {
        return Err(bad());
    }
    Ok(a..b)
}

/// True for the still-image extensions read with the `image` crate.
fn is_still(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    !path.is_dir() && matches!(ext.as_str(), "png" | "tif" | "tiff" | "jpg" | "jpeg")
}

/// Reads `paths` (still images, or videos/Y4M/frame directories through
/// the capture readers), keeps frames `frames` of the sequence (all when
/// `None`) and returns the strip profiles of `roi` (the whole frame when
/// `None`).
pub fn load(
    paths: &[PathBuf],
    frames: Option<Range<usize>>,
    roi: Option<RoiRect>,
) -> Result<FrameSet, FrameError> {
    let mut raw: StripProfiles = Vec::new();
    let mut sources = Vec::new();
    let mut size: Option<(u32, u32)> = None;
    let mut full_scale: Option<f64> = None;
    let mut area = None;
    let mut block_grid = false;
    for path in paths {
        capture::check_interrupt(path)?;
        sources.push(Source {
            path: path.display().to_string(),
            sha256: file_sha256(path)?,
        });
        let (w, h, fs, mut got) = if is_still(path) {
            let (read, jpeg) = read_still(path, roi)?;
            block_grid |= jpeg;
            read
        } else {
            block_grid |= capture::source_kind(path) == capture::SourceKind::Video;
            read_sequence(path, roi)?
        };
        if let Some(s) = size
            && s != (w, h)
        {
            return Err(FrameError::Invalid {
                message: format!(
                    "frame `{}` is {w}x{h}, the frames before it are {}x{}",
                    path.display(),
                    s.0,
                    s.1
                ),
                hint: "give frames of one camera mode".to_string(),
            });
        }
        // A DN means the same light only on one scale: 8-bit frames beside
        // 16-bit ones would read as nearly black.
        if let Some(f0) = full_scale
            && f0 != fs
        {
            return Err(FrameError::Invalid {
                message: format!(
                    "frame `{}` is {}-bit, the frames before it are {}-bit (mixed bit depths)",
                    path.display(),
                    bits(fs),
                    bits(f0)
                ),
                hint: "give frames of one bit depth".to_string(),
            });
        }
        size = Some((w, h));
        full_scale = Some(fs);
        area = Some(checked_roi(path, roi, w, h)?);
        raw.append(&mut got);
    }
    if let Some(r) = &frames {
        if r.end > raw.len() {
            return Err(FrameError::Invalid {
                message: format!(
                    "--frames {}..{} asks for frames the input does not have: it has {}",
                    r.start,
                    r.end,
                    raw.len()
                ),
                hint: format!("use a range within 0..{}", raw.len()),
            });
        }
        raw = raw.drain(r.clone()).collect();
    }
    let (Some(frame_size), Some(roi)) = (size, area) else {
        return Err(FrameError::Invalid {
            message: "no frame given".to_string(),
            hint: "give one or more frame files".to_string(),
        });
    };
    Ok(FrameSet {
        sources,
        raw,
        full_scale_dn: full_scale.unwrap_or(255.0),
        frame_size,
        roi,
        block_grid,
    })
}

/// Bits per sample of a full scale (255 -> 8, 65535 -> 16).
fn bits(full_scale: f64) -> u32 {
    (full_scale + 1.0).log2().round() as u32
}

/// The ROI, or the whole frame; an ROI outside the frame is an error.
fn checked_roi(path: &Path, roi: Option<RoiRect>, w: u32, h: u32) -> Result<RoiRect, FrameError> {
    let r = roi.unwrap_or(RoiRect {
        x: 0,
        y: 0,
        width: w,
        height: h,
    });
    if r.x as u64 + r.width as u64 > w as u64 || r.y as u64 + r.height as u64 > h as u64 {
        return Err(FrameError::Invalid {
            message: format!(
                "--roi {},{},{},{} falls outside the {w}x{h} frame `{}`",
                r.x,
                r.y,
                r.width,
                r.height,
                path.display()
            ),
            hint: "X + W must be <= the width and Y + H <= the height".to_string(),
        });
    }
    Ok(r)
}

/// Column ranges of the strips of `roi` (fewer strips when it is narrow).
fn strip_columns(roi: &RoiRect) -> Vec<Range<u32>> {
    let k = (STRIPS as u32).min(roi.width).max(1);
    (0..k)
        .map(|i| roi.x + i * roi.width / k..roi.x + (i + 1) * roi.width / k)
        .collect()
}

/// Width, height, full scale and strip profiles of what was read.
type ReadOut = (u32, u32, f64, StripProfiles);

/// A still frame, and whether it is a JPEG.
fn read_still(path: &Path, roi: Option<RoiRect>) -> Result<(ReadOut, bool), FrameError> {
    let err = |message: String| FrameError::Read {
        path: path.to_path_buf(),
        message,
    };
    let reader = capture::image_reader(path).map_err(|e| match e {
        CaptureError::Read { message, .. } => err(message),
        other => FrameError::Capture(other),
    })?;
    let jpeg = reader.format() == Some(image::ImageFormat::Jpeg);
    let img = ledflicker_plan::image_io::decode(reader).map_err(|e| err(e.to_string()))?;
    let (w, h) = (img.width(), img.height());
    let roi = checked_roi(path, roi, w, h)?;
    let cols = strip_columns(&roi);
    // Luma in the source's DN, BT.601.
    let (full_scale, luma): (f64, Box<dyn Fn(u32, u32) -> f64 + '_>) = match &img {
        DynamicImage::ImageLuma8(b) => (255.0, Box::new(move |x, y| b.get_pixel(x, y)[0] as f64)),
        DynamicImage::ImageLuma16(b) => {
            (65535.0, Box::new(move |x, y| b.get_pixel(x, y)[0] as f64))
        }
        DynamicImage::ImageRgb8(b) => (
            255.0,
            Box::new(move |x, y| bt601(b.get_pixel(x, y).0.map(f64::from))),
        ),
        DynamicImage::ImageRgba8(b) => (
            255.0,
            Box::new(move |x, y| {
                let p = b.get_pixel(x, y).0;
                bt601([p[0] as f64, p[1] as f64, p[2] as f64])
            }),
        ),
        DynamicImage::ImageRgb16(b) => (
            65535.0,
            Box::new(move |x, y| bt601(b.get_pixel(x, y).0.map(f64::from))),
        ),
        other => {
            let deep =
                other.color().bytes_per_pixel() as usize > other.color().channel_count() as usize;
            let b = other.to_rgb16();
            let scale = if deep { 1.0 } else { 1.0 / 257.0 };
            let fs = if deep { 65535.0 } else { 255.0 };
            (
                fs,
                Box::new(move |x, y| scale * bt601(b.get_pixel(x, y).0.map(f64::from))),
            )
        }
    };
    let strips: Vec<Vec<f64>> = cols
        .iter()
        .map(|c| {
            let n = c.len() as f64;
            (roi.y..roi.y + roi.height)
                .map(|y| c.clone().map(|x| luma(x, y)).sum::<f64>() / n)
                .collect()
        })
        .collect();
    Ok(((w, h, full_scale, vec![strips]), jpeg))
}

fn bt601(p: [f64; 3]) -> f64 {
    0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]
}

/// A video, Y4M file or frame directory: one capture ROI per row and strip.
fn read_sequence(path: &Path, roi: Option<RoiRect>) -> Result<ReadOut, FrameError> {
    let opts = ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: VideoDecode::Rgb,
        range: VideoRange::Auto,
        colour_transfer: ledflicker_acquisition::capture::ColourTransfer::Linear,
        fps: Some(30.0),
        decoder_threads: None,
    };
    // The frame size first: one 1x1 ROI reads it.
    let probe = [RoiRect {
        x: 0,
        y: 0,
        width: 1,
        height: 1,
    }];
    let (w, h) = capture::read_capture(path, &probe, &[], &opts)?.frame_size;
    let area = checked_roi(path, roi, w, h)?;
    let cols = strip_columns(&area);
    let rois: Vec<RoiRect> = cols
        .iter()
        .flat_map(|c| {
            (area.y..area.y + area.height).map(move |y| RoiRect {
                x: c.start,
                y,
                width: c.end - c.start,
                height: 1,
            })
        })
        .collect();
    let trace = capture::read_capture(path, &rois, &[], &opts)?;
    let rows = area.height as usize;
    let frames = trace.time_s.len();
    let out = (0..frames)
        .map(|k| {
            (0..cols.len())
                .map(|s| (0..rows).map(|r| trace.luma[s * rows + r][k]).collect())
                .collect()
        })
        .collect();
    Ok((w, h, trace.full_scale_dn, out))
}

/// SHA-256 of a file, lowercase hex; "" for a directory. Read in chunks
/// ([`ledflicker_acquisition::inputs::hash_file`]): a FIFO or a device is refused at once.
fn file_sha256(path: &Path) -> Result<String, FrameError> {
    if path.is_dir() {
        return Ok(String::new());
    }
    match ledflicker_acquisition::inputs::hash_file(path) {
        Ok((sha256, _)) => Ok(sha256),
        // Stopped by Ctrl-C: the signal's error, not a read error.
        Err(e) => match capture::check_interrupt(path) {
            Err(stop) => Err(stop.into()),
            Ok(()) => Err(FrameError::Read {
                path: path.to_path_buf(),
                message: e.to_string(),
            }),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roi_and_frame_range_parse_or_explain() {
        assert_eq!(
            parse_roi("1, 2,30,40").unwrap(),
            RoiRect {
                x: 1,
                y: 2,
                width: 30,
                height: 40
            }
        );
        assert!(parse_roi("1,2,0,4").unwrap_err().contains("--roi"));
        assert!(parse_roi("1,2,3").is_err());
        assert_eq!(parse_frames("3..10").unwrap(), 3..10);
        assert!(parse_frames("10..3").unwrap_err().contains("--frames"));
    }

    #[test]
    fn texture_cancels_when_frames_are_flattened() {
        // Two frames, two strips of three rows: texture x moving bands.
        let texture = [[1.0, 2.0, 4.0], [3.0, 0.5, 1.0]];
        let band = [[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]];
        let raw: StripProfiles = (0..2)
            .map(|k| {
                (0..2)
                    .map(|s| (0..3).map(|r| texture[s][r] * (1.0 + band[k][r])).collect())
                    .collect()
            })
            .collect();
        let set = FrameSet {
            sources: Vec::new(),
            raw,
            full_scale_dn: 255.0,
            frame_size: (2, 3),
            roi: RoiRect {
                x: 0,
                y: 0,
                width: 2,
                height: 3,
            },
            block_grid: false,
        };
        let flat = set.flattened().unwrap();
        for (k, frame) in flat.iter().enumerate() {
            assert_eq!(frame[0], frame[1], "frame {k}: texture left over");
        }
    }
}
