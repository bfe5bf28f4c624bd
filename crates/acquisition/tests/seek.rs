//! A video frame read by seeking (`capture::read_video_frames_seeking`) is
//! the frame a read from the start hands over, pixel for pixel, or the
//! seek says it landed elsewhere; alone or with other frames in one
//! process. Checked on the P2020 sample videos (one
//! of them seeks to the wrong key frame near its start) and on videos made
//! here from them: B-frames, and a file whose timeline starts at 10 s.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use ledflicker_acquisition::capture::{
    self, CaptureTrace, ColourTransfer, FrameSeek, FrameSink, GreyFrame, LumaWeights, ReadOptions,
    RoiRect, SeekTo, VideoDecode, VideoRange,
};

fn reference(name: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("reference-data/p2020-flicker-videos")
        .join(name)
}

/// The integer ROIs of the samples' rois.csv.
fn rois() -> Vec<RoiRect> {
    let text = std::fs::read_to_string(reference("rois.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let v: Vec<u32> = l.split(',').skip(5).map(|x| x.parse().unwrap()).collect();
            RoiRect {
                x: v[0],
                y: v[1],
                width: v[2],
                height: v[3],
            }
        })
        .collect()
}

fn opts(video_decode: VideoDecode) -> ReadOptions {
    ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode,
        range: VideoRange::Auto,
        colour_transfer: ColourTransfer::Linear,
        fps: None,
        decoder_threads: Some(1),
    }
}

/// Keeps the frames it is asked for, whole.
#[derive(Default)]
struct Keep {
    want: Vec<u64>,
    pictures: BTreeMap<u64, Vec<u32>>,
}

impl FrameSink for Keep {
    fn frame(&mut self, f: &GreyFrame<'_>) {
        if !self.want.contains(&f.index) {
            return;
        }
        let mut row = vec![0u32; f.width() as usize];
        let mut picture = Vec::new();
        for y in 0..f.height() {
            f.row(y, &mut row);
            picture.extend_from_slice(&row);
        }
        self.pictures.insert(f.index, picture);
    }
}

/// Seeks to every frame in `frames` of `path` and checks each one that
/// lands against the read from the start; returns how many landed.
/// The trace of the video at `path` over [`rois`], read from the start,
/// and the time its seeks count from.
fn read_trace(path: &Path, opts: &ReadOptions) -> (CaptureTrace, f64) {
    let rects = rois();
    let names: Vec<String> = (0..rects.len()).map(|i| format!("roi{i}")).collect();
    let trace = capture::read_captures(&[path], &rects, &names, opts)
        .unwrap()
        .remove(0);
    let origin = trace
        .video
        .as_ref()
        .expect("a video says how it was read")
        .origin_s
        .expect("a video with times has a seek origin");
    (trace, origin)
}

fn check(path: &Path, decode: VideoDecode, frames: &[u64]) -> usize {
    let rects = rois();
    let opts = opts(decode);
    let (trace, origin) = read_trace(path, &opts);
    let video = trace.video.unwrap();
    let mut whole = Keep {
        want: frames.to_vec(),
        ..Keep::default()
    };
    capture::read_grey_frames(path, &opts, &mut whole).unwrap();
    let means: Vec<Vec<f64>> = frames
        .iter()
        .map(|&k| trace.luma.iter().map(|roi| roi[k as usize]).collect())
        .collect();
    let wanted: Vec<SeekTo<'_>> = frames
        .iter()
        .zip(&means)
        .map(|(&k, means)| {
            let i = k as usize;
            SeekTo {
                frame: k,
                at_s: origin + (trace.time_s[i - 1] + trace.time_s[i]) / 2.0,
                means,
            }
        })
        .collect();
    let seek = |frames: &[SeekTo<'_>], sink: &mut Keep| {
        let seek = FrameSeek {
            size: trace.frame_size,
            video,
            rois: &rects,
            frames,
        };
        capture::read_video_frames_seeking(path, &opts, &seek, sink).unwrap()
    };
    // All at once, in one process, and each alone.
    let mut together = Keep {
        want: frames.to_vec(),
        ..Keep::default()
    };
    let landed_together = seek(&wanted, &mut together);
    let mut landed = 0;
    for (i, (one_seek, &k)) in wanted.iter().zip(frames).enumerate() {
        let mut one = Keep {
            want: vec![k],
            ..Keep::default()
        };
        let ok = seek(std::slice::from_ref(one_seek), &mut one) == [true];
        assert_eq!(
            ok,
            landed_together[i],
            "{}: frame {k} lands alone: {ok}, with the others: {}",
            path.display(),
            landed_together[i]
        );
        if ok {
            landed += 1;
            for (how, got) in [("alone", &one), ("with the others", &together)] {
                assert_eq!(
                    got.pictures.get(&k),
                    whole.pictures.get(&k),
                    "{}: frame {k} by seeking {how} differs from the read from the start",
                    path.display()
                );
            }
        }
    }
    landed
}

/// Frames 1-3, every 61st, and the last.
fn frames_of(n: u64) -> Vec<u64> {
    let mut f: Vec<u64> = (1..4).chain((61..n).step_by(61)).collect();
    f.push(n - 1);
    f
}

#[test]
fn a_seek_gives_the_frame_a_read_from_the_start_gives() {
    assert!(
        capture::ffmpeg_available(),
        "this test needs `ffmpeg` and `ffprobe`"
    );
    let cases = [
        ("test_vid1.mp4", 899, VideoDecode::Rgb),
        ("test_vid2.mp4", 429, VideoDecode::LumaPlane),
    ];
    for (video, n, decode) in cases {
        let frames = frames_of(n);
        let landed = check(&reference(video), decode, &frames);
        eprintln!("{video}: {landed} of {} seeks landed", frames.len());
        // The fast path is taken: the samples' index sends a seek before
        // the second key frame to that key frame, so the frames before it
        // come from a read from the start.
        assert!(
            landed * 10 >= frames.len() * 6,
            "{video}: {landed} of {} seeks landed",
            frames.len()
        );
    }
}

/// Re-encodes test_vid3 into `dir` with ffmpeg's `args`, as `name`.
fn remake(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let status = Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-i"])
        .arg(reference("test_vid3.mp4"))
        .args(args)
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success(), "ffmpeg could not make {name}");
    out
}

#[test]
fn a_seek_lands_in_videos_with_b_frames_and_a_late_start() {
    let dir = tempfile::tempdir().unwrap();
    let frames = frames_of(369);
    // B-frames: frames are decoded out of presentation order.
    let b = remake(
        dir.path(),
        "b.mp4",
        &["-c:v", "libx264", "-bf", "3", "-g", "50", "-crf", "18"],
    );
    let landed = check(&b, VideoDecode::Rgb, &frames);
    assert_eq!(landed, frames.len(), "B-frames: {landed} seeks landed");
    // A timeline that starts 10 s in: -ss counts from the file's start.
    let late = remake(
        dir.path(),
        "late.mkv",
        &["-c", "copy", "-output_ts_offset", "10"],
    );
    let landed = check(&late, VideoDecode::LumaPlane, &frames);
    eprintln!("late start: {landed} of {} seeks landed", frames.len());
    assert!(
        landed * 10 >= frames.len() * 6,
        "late start: {landed} of {} seeks landed",
        frames.len()
    );
}

/// A seek that brings no frame (past the end) makes the frames after it
/// come under the wrong numbers: none of the seeks is trusted, even when
/// the frame that came under the first number has that number's means.
#[test]
fn a_seek_that_brings_no_frame_leaves_every_frame_to_a_read_from_the_start() {
    let path = reference("test_vid3.mp4");
    let rects = rois();
    let opts = opts(VideoDecode::Rgb);
    let (trace, origin) = read_trace(&path, &opts);
    let video = trace.video.unwrap();
    let k = 300;
    let means: Vec<f64> = trace.luma.iter().map(|roi| roi[k]).collect();
    let at = origin + (trace.time_s[k - 1] + trace.time_s[k]) / 2.0;
    // Both entries carry frame 300's means: the past-the-end seek's would
    // pass the means check if frame 300 came under its number.
    let wanted = [
        SeekTo {
            frame: 10,
            at_s: origin + 1000.0,
            means: &means,
        },
        SeekTo {
            frame: k as u64,
            at_s: at,
            means: &means,
        },
    ];
    let seek = FrameSeek {
        size: trace.frame_size,
        video,
        rois: &rects,
        frames: &wanted,
    };
    let mut sink = Keep::default();
    let landed = capture::read_video_frames_seeking(&path, &opts, &seek, &mut sink).unwrap();
    assert_eq!(landed, [false, false]);
    // Alone, the second seek lands.
    let alone = FrameSeek {
        frames: &wanted[1..],
        ..seek
    };
    let landed = capture::read_video_frames_seeking(&path, &opts, &alone, &mut sink).unwrap();
    assert_eq!(landed, [true]);
}
