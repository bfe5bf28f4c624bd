//! Decode + ROI throughput and peak memory of the capture readers.
//!
//! ```sh
//! cargo run --release --example capture_bench            # samples + 1080p 60 s Y4M
//! cargo run --release --example capture_bench -- --no-y4m
//! ```
//!
//! Prints frames per second for: the OpenCV reference pipeline
//! (scripts/opencv_bench.py, when Python has cv2), FFmpeg decode only
//! (`ffmpeg -f null`), the
//! RGB path (the P2020 reference conversion) and the Y'-plane path on the
//! three P2020 sample videos with their 36 ROIs, on 1 and 2 threads (the
//! videos in parallel, as `ledflicker plan` runs cases); then a generated
//! 1920x1080 4:2:0 Y4M of 60 s at 30 fps (5.6 GB, written under target/)
//! with the same 36 ROIs, and the process's peak resident memory (VmHWM;
//! the ffmpeg child processes are not included).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use ledflicker::capture::{
    LumaWeights, ReadOptions, RoiRect, VideoDecode, VideoRange, read_capture,
};
use rayon::prelude::*;

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn rois(root: &Path) -> Vec<RoiRect> {
    let text = std::fs::read_to_string(root.join("reference-data/p2020-flicker-videos/rois.csv"))
        .expect("rois.csv");
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<u32> = l
                .split(',')
                .skip(5)
                .map(|v| v.parse().expect("int"))
                .collect();
            RoiRect {
                x: f[0],
                y: f[1],
                width: f[2],
                height: f[3],
            }
        })
        .collect()
}

fn opts(decode: VideoDecode) -> ReadOptions {
    ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: decode,
        range: VideoRange::Auto,
        colour_transfer: ledflicker::capture::ColourTransfer::Linear,
        fps: None,
        decoder_threads: None,
    }
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let no_y4m = std::env::args().any(|a| a == "--no-y4m");
    let rois = rois(&root);
    let videos: Vec<PathBuf> = ["test_vid1", "test_vid2", "test_vid3"]
        .iter()
        .map(|v| root.join(format!("reference-data/p2020-flicker-videos/{v}.mp4")))
        .collect();

    if !no_y4m {
        y4m_bench(&root, &rois);
    }

    // The OpenCV reference pipeline, when Python has cv2.
    match std::process::Command::new("python3")
        .arg(root.join("scripts/opencv_bench.py"))
        .output()
    {
        Ok(o) if o.status.success() => print!("{}", String::from_utf8_lossy(&o.stdout)),
        _ => println!("opencv pipeline: skipped (pip install numpy opencv-python-headless)"),
    }
    // FFmpeg decode only (its default threading), one video after another.
    let t = Instant::now();
    for v in &videos {
        let s = std::process::Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-i"])
            .arg(v)
            .args(["-f", "null", "-"])
            .status()
            .expect("ffmpeg");
        assert!(s.success());
    }
    let decode_s = t.elapsed().as_secs_f64();
    let frames: usize = videos
        .iter()
        .map(|v| {
            read_capture(v, &rois, &[], &opts(VideoDecode::LumaPlane))
                .expect("read")
                .time_s
                .len()
        })
        .sum();
    println!("samples: {frames} frames, 36 ROIs");
    println!(
        "  ffmpeg decode only (serial): {:.0} frames/s",
        frames as f64 / decode_s
    );
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        for decode in [VideoDecode::Rgb, VideoDecode::LumaPlane] {
            let t = Instant::now();
            let n: usize = pool.install(|| {
                videos
                    .par_iter()
                    .map(|v| {
                        read_capture(v, &rois, &[], &opts(decode))
                            .expect("read")
                            .time_s
                            .len()
                    })
                    .sum()
            });
            println!(
                "  {threads} thread(s), {decode:?}: {:.0} frames/s (decode + ROI, incl. ffprobe)",
                n as f64 / t.elapsed().as_secs_f64()
            );
        }
    }
    println!("peak memory (VmHWM): {:.1} MB", peak_rss_mb());
}

fn y4m_bench(root: &Path, rois: &[RoiRect]) {
    let (w, h, fps, secs) = (1920usize, 1080usize, 30usize, 60usize);
    let dir = root.join("target/bench");
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("1080p-60s.y4m");
    let n = fps * secs;
    let frame_bytes = w * h * 3 / 2 + 6;
    let want = (format!("YUV4MPEG2 W{w} H{h} F{fps}:1 C420jpeg\n").len() + n * frame_bytes) as u64;
    if std::fs::metadata(&path).map(|m| m.len()).ok() != Some(want) {
        eprintln!(
            "writing {} ({:.1} GB)...",
            path.display(),
            want as f64 / 1e9
        );
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
        writeln!(f, "YUV4MPEG2 W{w} H{h} F{fps}:1 C420jpeg").expect("write");
        let mut frame = vec![128u8; w * h * 3 / 2];
        for k in 0..n {
            let y = 16 + (k * 7 % 200) as u8;
            frame[..w * h].fill(y);
            f.write_all(b"FRAME\n").expect("write");
            f.write_all(&frame).expect("write");
        }
        f.flush().expect("flush");
    }
    let before = peak_rss_mb();
    let t = Instant::now();
    let tr = read_capture(&path, rois, &[], &opts(VideoDecode::Rgb)).expect("y4m");
    let s = t.elapsed().as_secs_f64();
    println!(
        "y4m 1920x1080 4:2:0, {} frames ({} s at {fps} fps), 36 ROIs: {:.0} frames/s, peak memory {:.1} MB (before: {:.1} MB)",
        tr.time_s.len(),
        secs,
        tr.time_s.len() as f64 / s,
        peak_rss_mb(),
        before
    );
}
