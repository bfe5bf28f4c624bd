//! ffprobe on a video: its size, pixel format, frame rate and packet
//! times, read with bounded output under a watchdog; and the helpers the
//! FFmpeg subprocesses share (stderr drained on a thread, tool errors).

use std::io::Read;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::thread::JoinHandle;

use super::CaptureError;
use super::watch::{Fired, STALL, Watchdog};
use ledflicker_plan::trace::Ratio;

pub(super) fn tool_error(path: &Path, tool: &str, e: std::io::Error) -> CaptureError {
    CaptureError::Tool {
        path: path.to_path_buf(),
        message: format!(
            "cannot run `{tool}`: {e}\n    hint: video is decoded by FFmpeg; install it, e.g. `apt-get install ffmpeg`"
        ),
    }
}

/// What ffprobe says about a video.
pub(super) struct Probe {
    pub width: u32,
    pub height: u32,
    pub codec: String,
    pub pix_fmt: String,
    pub full_range: Option<bool>,
    pub fps: Option<f64>,
    /// The stream's time base, seconds: the unit of its packets' times.
    pub time_base_s: Option<Ratio>,
    /// The frame rate the stream states: `r_frame_rate`, else `avg_frame_rate`.
    pub stated_fps: Option<Ratio>,
    /// Presentation times of the video packets, sorted, seconds from the first.
    pub packet_times: Vec<f64>,
    /// Where the first packet is on ffmpeg's `-ss` timeline: its
    /// presentation time less the file's start time, seconds.
    pub seek_origin_s: Option<f64>,
}

/// Most bytes of ffprobe's stdout read (about 10 million packet times);
/// more is an error rather than unbounded memory.
const PROBE_STDOUT_MAX: u64 = 256 << 20;

/// Most bytes of an FFmpeg tool's stderr kept (the start of it).
const STDERR_MAX: u64 = 64 << 10;

/// Reads at most [`STDERR_MAX`] bytes of `pipe` on a thread, and discards
/// the rest, so that a chatty tool can neither block nor fill memory.
pub(super) fn drain_stderr(pipe: Option<impl Read + Send + 'static>) -> JoinHandle<String> {
    std::thread::spawn(move || {
        let mut kept = Vec::new();
        if let Some(mut p) = pipe {
            let _ = p.by_ref().take(STDERR_MAX).read_to_end(&mut kept);
            let _ = std::io::copy(&mut p, &mut std::io::sink());
        }
        String::from_utf8_lossy(&kept).into_owned()
    })
}

/// The output of one ffprobe run: exit status, stdout, stderr.
struct ProbeOutput {
    status: ExitStatus,
    stdout: Vec<u8>,
    stderr: String,
}

/// What [`probe`] asks ffprobe for: the stream's facts and every packet's time.
const PROBE_ENTRIES: &str = "stream=width,height,codec_name,pix_fmt,color_range,avg_frame_rate,r_frame_rate,time_base:packet=pts:format=start_time";

/// Longest wait for [`frame_size`]'s ffprobe: reading a stream's header
/// takes well under a second, and a video whose header does not come
/// within this (a FIFO behind a concat list, a stalled mount) is left to
/// the run, which waits [`STALL`] and says why, so that validation never
/// hangs on it.
const SIZE_STALL: std::time::Duration = std::time::Duration::from_secs(10);

/// Runs ffprobe on `path` for `entries` (of the first video stream), with
/// bounded output, stopped after `stall` without finishing.
fn run_ffprobe(
    path: &Path,
    entries: &str,
    stall: std::time::Duration,
) -> Result<ProbeOutput, CaptureError> {
    let mut child = Command::new("ffprobe")
        .args([
            "-v",
            "error",
            "-select_streams",
            "v:0",
            "-show_entries",
            entries,
            "-of",
            "default=noprint_wrappers=1",
        ])
        .arg(path)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .map_err(|e| tool_error(path, "ffprobe", e))?;
    let dog = Watchdog::start(child.id(), stall);
    let err_thread = drain_stderr(child.stderr.take());
    let mut stdout = Vec::new();
    let read = match child.stdout.take() {
        Some(out) => out.take(PROBE_STDOUT_MAX + 1).read_to_end(&mut stdout),
        None => Ok(0),
    };
    let too_long = stdout.len() as u64 > PROBE_STDOUT_MAX;
    if too_long || read.is_err() {
        let _ = child.kill();
    }
    let status = child.wait().map_err(|e| tool_error(path, "ffprobe", e))?;
    let stderr = err_thread.join().unwrap_or_default();
    if let Some(fired) = dog.finish() {
        return Err(stopped(path, fired, "ffprobe"));
    }
    if let Err(e) = read {
        return Err(tool_error(path, "ffprobe", e));
    }
    if too_long {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "ffprobe lists more than {} MB of stream facts and packet times",
                PROBE_STDOUT_MAX >> 20
            ),
            hint: "split the recording into shorter files".to_string(),
        });
    }
    Ok(ProbeOutput {
        status,
        stdout,
        stderr,
    })
}

/// Probes the first video stream of `path`: size, format, packet times.
pub(super) fn probe(path: &Path) -> Result<Probe, CaptureError> {
    let out = run_ffprobe(path, PROBE_ENTRIES, STALL)?;
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
            out.stderr.trim()
        )));
    }
    let (Some(w), Some(h)) = (
        get("width").and_then(|v| v.parse::<u32>().ok()),
        get("height").and_then(|v| v.parse::<u32>().ok()),
    ) else {
        return Err(invalid("no video stream".to_string()));
    };
    let avg = get("avg_frame_rate").and_then(Ratio::parse);
    let time_base_s = get("time_base").and_then(Ratio::parse);
    let start_s = get("start_time").and_then(|v| v.parse::<f64>().ok());
    Ok(Probe {
        seek_origin_s: time_base_s.and_then(|tb| Some(first_pts(&text)? * tb.value() - start_s?)),
        packet_times: time_base_s.map_or_else(Vec::new, |tb| packet_times(&text, tb)),
        time_base_s,
        stated_fps: get("r_frame_rate").and_then(Ratio::parse).or(avg),
        fps: avg.map(Ratio::value),
        width: w,
        height: h,
        codec: get("codec_name").unwrap_or("?").to_string(),
        pix_fmt: get("pix_fmt").unwrap_or("?").to_string(),
        full_range: match get("color_range") {
            Some("pc") => Some(true),
            Some("tv") => Some(false),
            _ => None,
        },
    })
}

/// The frame size (width, height) of the first video stream of `path`,
/// from the stream's header alone: no packet is listed or decoded. `None`
/// when ffprobe cannot run, finds no video stream or lists it at 0 x 0.
pub(super) fn frame_size(path: &Path) -> Option<(u32, u32)> {
    let out = run_ffprobe(path, "stream=width,height", SIZE_STALL).ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let get = |k: &str| {
        text.lines().find_map(|l| {
            l.strip_prefix(k)?
                .strip_prefix('=')?
                .trim()
                .parse::<u32>()
                .ok()
        })
    };
    // A damaged file's stream can be listed at 0 x 0: left to the run.
    Some((get("width")?, get("height")?)).filter(|&(w, h)| w > 0 && h > 0)
}

/// The earliest packet presentation time in `text`, in time-base units.
fn first_pts(text: &str) -> Option<f64> {
    text.lines()
        .filter_map(|l| l.strip_prefix("pts=")?.trim().parse::<i64>().ok())
        .min()
        .map(|p| p as f64)
}

/// The packets' presentation times in `text` (ffprobe's `pts=` lines, in
/// units of `time_base`), sorted, seconds from the first. Each is the
/// exact integer difference scaled once, so times keep the time base's
/// grid (ffprobe's `pts_time` is rounded to the microsecond).
fn packet_times(text: &str, time_base: Ratio) -> Vec<f64> {
    let mut pts: Vec<i64> = text
        .lines()
        .filter_map(|l| l.strip_prefix("pts=")?.trim().parse().ok())
        .collect();
    pts.sort_unstable();
    let first = pts.first().copied().unwrap_or(0);
    pts.iter()
        .map(|&p| {
            (i128::from(p) - i128::from(first)) as f64 * time_base.num as f64 / time_base.den as f64
        })
        .collect()
}

/// The watchdog stopped `tool` on `path` ([`Fired`]).
pub(super) fn stopped(path: &Path, fired: Fired, tool: &str) -> CaptureError {
    match fired {
        Fired::Interrupted(signal) => CaptureError::Interrupted {
            path: path.to_path_buf(),
            source: crate::interrupt::Interrupted { signal },
        },
        Fired::Stalled(_) => CaptureError::Tool {
            path: path.to_path_buf(),
            message: fired.message(tool),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Packet times are the integer PTS differences times the time base:
    /// 1/90000 s ticks of 30000/1001 fps stay on the exact frame times,
    /// where ffprobe's `pts_time` would round them to the microsecond.
    #[test]
    fn packet_times_are_whole_ticks_of_the_time_base() {
        let text = "time_base=1/90000\npts=906006\npts=900000\npts=903003\npts=N/A\n";
        let tb = Ratio::parse("1/90000").unwrap();
        let t = packet_times(text, tb);
        assert_eq!(t, vec![0.0, 3003.0 / 90000.0, 6006.0 / 90000.0]);
        assert_eq!(Ratio::parse("30000/1001"), Ratio::new(30000, 1001));
        for bad in ["0/0", "-1/25", "25", "x/1", "25/0"] {
            assert_eq!(Ratio::parse(bad), None, "{bad}");
        }
    }
}
