//! Video (MP4, MOV, MKV, ... with H.264 and anything else FFmpeg decodes)
//! through the `ffmpeg` and `ffprobe` binaries as subprocesses.
//!
//! FFmpeg crops each frame to the ROIs' bounding box (aligned to even
//! pixels, so 4:2:0 chroma sites stay where they were) and pipes raw frames;
//! this process reads one frame at a time, so memory stays bounded.
//! - `rgb` decode: `-pix_fmt rgb24`, the same swscale conversion OpenCV uses in
//!   the P2020 reference pipeline, then per-pixel luma;
//! - `luma-plane` decode: `extractplanes=y` (Y' as stored, no conversion),
//!   then the limited-to-full range expansion in a lookup table.
//!
//! Timestamps are the container's presentation times (ffprobe, packet PTS
//! sorted), with the frame rate as a fallback.

use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, Stdio};

use super::{
    Accumulator, CaptureError, CaptureTrace, FrameView, Pixels, ReadOptions, RoiRect, VideoDecode,
    VideoRange, bounding_box, check_rois, limited_to_full_lut, times_from_fps,
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

fn tool_error(path: &Path, tool: &str, e: std::io::Error) -> CaptureError {
    CaptureError::Tool {
        path: path.to_path_buf(),
        message: format!(
            "cannot run `{tool}`: {e}\n    hint: video is decoded by FFmpeg; install it, e.g. `apt-get install ffmpeg`"
        ),
    }
}

struct Probe {
    width: u32,
    height: u32,
    codec: String,
    pix_fmt: String,
    full_range: Option<bool>,
    fps: Option<f64>,
    /// Presentation times of the video packets, sorted, seconds from the first.
    packet_times: Vec<f64>,
}

fn probe(path: &Path) -> Result<Probe, CaptureError> {
    let out = Command::new("ffprobe")
        .args([
            "-v",
            "error",
            "-select_streams",
            "v:0",
            "-show_entries",
            "stream=width,height,codec_name,pix_fmt,color_range,avg_frame_rate:packet=pts_time",
            "-of",
            "default=noprint_wrappers=1",
        ])
        .arg(path)
        .output()
        .map_err(|e| tool_error(path, "ffprobe", e))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let get = |k: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(k).and_then(|v| v.strip_prefix('=')))
            .map(str::trim)
    };
    let invalid = |message: String| CaptureError::Invalid {
        path: path.to_path_buf(),
        message,
        hint: "check that the file is a complete video (MP4, MOV, MKV) with a video stream"
            .to_string(),
    };
    if !out.status.success() {
        return Err(invalid(format!(
            "ffprobe cannot read it: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let (Some(w), Some(h)) = (
        get("width").and_then(|v| v.parse::<u32>().ok()),
        get("height").and_then(|v| v.parse::<u32>().ok()),
    ) else {
        return Err(invalid("no video stream".to_string()));
    };
    let fps = get("avg_frame_rate").and_then(|v| {
        let (n, d) = v.split_once('/')?;
        let (n, d) = (n.parse::<f64>().ok()?, d.parse::<f64>().ok()?);
        (n > 0.0 && d > 0.0).then_some(n / d)
    });
    let mut packet_times: Vec<f64> = text
        .lines()
        .filter_map(|l| l.strip_prefix("pts_time=")?.trim().parse::<f64>().ok())
        .filter(|x| x.is_finite())
        .collect();
    packet_times.sort_by(f64::total_cmp);
    if let Some(&t0) = packet_times.first() {
        for x in &mut packet_times {
            *x -= t0;
        }
    }
    Ok(Probe {
        packet_times,
        width: w,
        height: h,
        codec: get("codec_name").unwrap_or("?").to_string(),
        pix_fmt: get("pix_fmt").unwrap_or("?").to_string(),
        full_range: match get("color_range") {
            Some("pc") => Some(true),
            Some("tv") => Some(false),
            _ => None,
        },
        fps,
    })
}

pub(super) fn read(
    path: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    let p = probe(path)?;
    check_rois(path, 0, rois, p.width, p.height)?;
    let crop = Crop::around(rois, &p);
    let crop_filter = format!(
        "crop={}:{}:{}:{}",
        crop.width, crop.height, crop.x0, crop.y0
    );
    let (filter, pix_fmt, bpp) = match opts.video_decode {
        VideoDecode::Rgb => (crop_filter, "rgb24", 3usize),
        // Crop first (no copy), so extractplanes copies only the box.
        VideoDecode::LumaPlane => (format!("{crop_filter},extractplanes=y"), "gray", 1usize),
    };
    let mut child = spawn_ffmpeg(path, &filter, pix_fmt)?;
    // Drain stderr on a thread so that a chatty ffmpeg cannot block.
    let mut stderr = child.stderr.take();
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(e) = stderr.as_mut() {
            let _ = e.read_to_string(&mut s);
        }
        s
    });
    let mut acc = Accumulator::new(rois, opts.luma);
    let full = match opts.range {
        VideoRange::Full => true,
        VideoRange::Limited => false,
        VideoRange::Auto => p.full_range.unwrap_or(false),
    };
    if opts.video_decode == VideoDecode::LumaPlane && !full {
        acc.expand = Some(limited_to_full_lut(8));
    }
    let frame_bytes = crop.width as usize * crop.height as usize * bpp;
    let (frame, partial) = read_frames(path, &mut child, &mut acc, &crop, frame_bytes, opts)?;
    let status = child.wait().map_err(|e| tool_error(path, "ffmpeg", e))?;
    let stderr_text = err_thread.join().unwrap_or_default();
    if !status.success() || partial {
        return Err(undecodable(path, frame, &stderr_text));
    }
    Ok(trace(acc, p, opts, full))
}

/// The ROIs' bounding box (the whole frame without ROIs) plus a 2-pixel
/// margin, on even coordinates (4:2:0 chroma sites), so the crop does not
/// change pixels.
struct Crop {
    x0: u32,
    y0: u32,
    width: u32,
    height: u32,
}

impl Crop {
    fn around(rois: &[RoiRect], p: &Probe) -> Crop {
        let bbox = bounding_box(rois).unwrap_or(RoiRect {
            x: 0,
            y: 0,
            width: p.width,
            height: p.height,
        });
        let x0 = bbox.x.saturating_sub(2) & !1;
        let y0 = bbox.y.saturating_sub(2) & !1;
        let x1 = ((bbox.x + bbox.width + 3) & !1).min(p.width);
        let y1 = ((bbox.y + bbox.height + 3) & !1).min(p.height);
        Crop {
            x0,
            y0,
            width: x1 - x0,
            height: y1 - y0,
        }
    }
}

/// Starts ffmpeg decoding the first video stream of `path` through
/// `filter` to raw `pix_fmt` frames on its stdout.
fn spawn_ffmpeg(path: &Path, filter: &str, pix_fmt: &str) -> Result<Child, CaptureError> {
    Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-xerror", "-i"])
        .arg(path)
        .args([
            "-map",
            "0:v:0",
            "-fps_mode",
            "passthrough",
            "-vf",
            filter,
            "-f",
            "rawvideo",
            "-pix_fmt",
            pix_fmt,
            "-",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| tool_error(path, "ffmpeg", e))
}

/// Feeds every whole frame of ffmpeg's stdout to `acc`. Returns the frames
/// read and whether the stream ended inside a frame; a read error kills
/// ffmpeg and names the frame.
fn read_frames(
    path: &Path,
    child: &mut Child,
    acc: &mut Accumulator<'_>,
    crop: &Crop,
    frame_bytes: usize,
    opts: &ReadOptions,
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
                    origin: (crop.x0, crop.y0),
                    width: crop.width,
                });
                frame += 1;
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
    let (time_s, timestamps) = if p.packet_times.len() == n && n > 0 {
        (p.packet_times, "container")
    } else {
        match p.fps.or(opts.fps) {
            Some(fps) => (times_from_fps(n, fps), "fps"),
            None => (times_from_fps(n, f64::NAN), "none"),
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
