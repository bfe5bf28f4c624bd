use super::*;
use crate::capture::LumaWeights;
use crate::capture::bounding_box;
use crate::capture::layout::tests::{rect, spread_rois};
use crate::capture::layout::with_margin;

/// Cutting tiles changes no pixel: the same means, bit for bit, as the
/// bounding box, on a real H.264 capture, in both decode paths.
#[test]
fn tiles_read_the_same_means_as_the_bounding_box() {
    // Like the integration tests: fail, never skip, without ffmpeg.
    assert!(
        ffmpeg_available(),
        "this test needs `ffmpeg` and `ffprobe` (scripts/test.sh installs them)"
    );
    let path = sample_video();
    let rois = spread_rois();
    for video_decode in [VideoDecode::Rgb, VideoDecode::LumaPlane] {
        let opts = ReadOptions {
            luma: LumaWeights::Bt601,
            video_decode,
            range: VideoRange::Auto,
            colour_transfer: super::super::ColourTransfer::Linear,
            fps: None,
            decoder_threads: None,
        };
        let tiled =
            read_with(&path, probe(&path).unwrap(), &rois, &opts, Layout::for_rois).unwrap();
        let boxed = read_with(&path, probe(&path).unwrap(), &rois, &opts, |rois, frame| {
            Layout::single(with_margin(&bounding_box(rois).unwrap(), frame), rois)
        })
        .unwrap();
        assert_eq!(tiled.luma[0].len(), 369);
        assert_eq!(tiled, boxed, "{video_decode:?}");
        // One decoder thread and a one-thread filter graph (captures
        // read together), and two decoder threads, decode the same
        // pixels as FFmpeg's own choice.
        let one = ReadOptions {
            decoder_threads: Some(1),
            ..opts
        };
        let single =
            read_with(&path, probe(&path).unwrap(), &rois, &one, Layout::for_rois).unwrap();
        assert_eq!(single, tiled, "{video_decode:?}, one decoder thread");
        let two = ReadOptions {
            decoder_threads: Some(2),
            ..opts
        };
        let pair = read_with(&path, probe(&path).unwrap(), &rois, &two, Layout::for_rois).unwrap();
        assert_eq!(pair, tiled, "{video_decode:?}, two decoder threads");
    }
}

fn sample_video() -> std::path::PathBuf {
    crate::capture::tests::p2020_sample("test_vid3.mp4")
}

fn rgb_opts() -> ReadOptions {
    ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: VideoDecode::Rgb,
        range: VideoRange::Auto,
        colour_transfer: super::super::ColourTransfer::Linear,
        fps: None,
        decoder_threads: Some(1),
    }
}

/// Keeps frame `want` whole and counts the frames it was handed.
struct Keep {
    want: u64,
    seen: u64,
    picture: Vec<u32>,
}

impl FrameSink for Keep {
    fn frame(&mut self, f: &super::super::GreyFrame<'_>) {
        self.seen += 1;
        if f.index == self.want {
            let mut row = vec![0u32; f.width() as usize];
            for y in 0..f.height() {
                f.row(y, &mut row);
                self.picture.extend_from_slice(&row);
            }
        }
    }
}

/// A sample frame read by stopping after it is the frame a whole read
/// hands over, pixel for pixel, and the read stops there.
#[test]
fn reading_until_a_frame_gives_that_frame_and_stops() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let path = sample_video();
    let opts = rgb_opts();
    let keep = |want| Keep {
        want,
        seen: 0,
        picture: Vec::new(),
    };
    let mut whole = keep(40);
    read_whole(&path, &opts, &mut whole).unwrap();
    assert_eq!(whole.seen, 369);
    let mut until = keep(40);
    read_until(&path, &opts, &mut until, 40).unwrap();
    assert_eq!(until.seen, 41);
    assert_eq!(until.picture.len(), 1280 * 800);
    assert!(until.picture == whole.picture, "frame 40 differs");
    // Beyond the last frame: every frame, and no error.
    let mut beyond = keep(1000);
    read_until(&path, &opts, &mut beyond, 1000).unwrap();
    assert_eq!((beyond.seen, beyond.picture.len()), (369, 0));
}

/// A file tagged to be shown rotated (as phones write them) is read as
/// stored, the size ffprobe gives: the same ROI means and the same
/// whole frames as the untagged file.
#[test]
fn a_video_tagged_with_a_rotation_is_read_as_stored() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let dir = tempfile::tempdir().unwrap();
    let rotated = dir.path().join("rotated.mp4");
    // FFmpeg 5 tags a stream copy through its `rotate` metadata; FFmpeg 6
    // and later through the input option `-display_rotation`.
    let tag = |before: &[&str], after: &[&str]| {
        Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-y"])
            .args(before)
            .arg("-i")
            .arg(sample_video())
            .args(["-c", "copy"])
            .args(after)
            .arg(&rotated)
            .status()
            .is_ok_and(|s| s.success())
    };
    let rotation = || {
        let out = Command::new("ffprobe")
            .args(["-v", "error", "-select_streams", "v:0"])
            .args(["-show_entries", "stream_side_data=rotation"])
            .args(["-of", "default=noprint_wrappers=1"])
            .arg(&rotated)
            .output()
            .unwrap();
        String::from_utf8_lossy(&out.stdout).contains("rotation=")
    };
    let tagged = (tag(&[], &["-metadata:s:v:0", "rotate=90"]) && rotation())
        || (tag(&["-display_rotation", "90"], &[]) && rotation());
    assert!(
        tagged,
        "ffmpeg could not make a copy tagged with a rotation"
    );
    let p = probe(&rotated).unwrap();
    assert_eq!((p.width, p.height), (1280, 800));
    let rois = [
        rect(10, 10, 20, 2),
        rect(1200, 700, 40, 30),
        rect(450, 240, 30, 20),
    ];
    let opts = rgb_opts();
    let read = |path: &Path| probe_and_read(path, &rois, &opts).unwrap();
    let (stored, tagged) = (read(&sample_video()), read(&rotated));
    assert!(tagged.luma == stored.luma, "the ROI means differ");
    assert_eq!(tagged.frame_size, (1280, 800));
    let keep = || Keep {
        want: 200,
        seen: 0,
        picture: Vec::new(),
    };
    let (mut a, mut b) = (keep(), keep());
    read_until(&sample_video(), &opts, &mut a, 200).unwrap();
    read_until(&rotated, &opts, &mut b, 200).unwrap();
    assert!(a.picture == b.picture, "frame 200 differs");
}

/// A stream cropped from the left is read as cropped: ffprobe's width,
/// and ROI means equal to the uncropped file's 14 columns to the right
/// (on a picture that changes from column to column).
#[test]
fn a_stream_cropped_from_the_left_is_read_as_cropped() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let dir = tempfile::tempdir().unwrap();
    let (whole, cropped) = (dir.path().join("whole.mp4"), dir.path().join("cropped.mp4"));
    let ffmpeg = |args: &[&str], out: &Path| {
        let status = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error"])
            .args(args)
            .arg(out)
            .status()
            .unwrap();
        assert!(status.success(), "ffmpeg could not write {}", out.display());
    };
    ffmpeg(
        &[
            "-f",
            "lavfi",
            "-i",
            "testsrc2=size=320x240:rate=10:duration=1",
        ]
        .into_iter()
        .chain(["-c:v", "libx264", "-pix_fmt", "yuv420p"])
        .collect::<Vec<_>>(),
        &whole,
    );
    let whole_arg = whole.to_string_lossy().into_owned();
    ffmpeg(
        &[
            "-i",
            &whole_arg,
            "-c",
            "copy",
            "-bsf:v",
            "h264_metadata=crop_left=14",
        ],
        &cropped,
    );
    let p = probe(&cropped).unwrap();
    assert_eq!((p.width, p.height), (306, 240));
    let rois = [
        rect(0, 10, 20, 2),
        rect(100, 100, 30, 20),
        rect(280, 200, 26, 30),
    ];
    let moved: Vec<RoiRect> = rois
        .iter()
        .map(|r| rect(r.x + 14, r.y, r.width, r.height))
        .collect();
    let opts = rgb_opts();
    let left = probe_and_read(&cropped, &rois, &opts).unwrap();
    let shifted = probe_and_read(&whole, &moved, &opts).unwrap();
    let unshifted = probe_and_read(&whole, &rois, &opts).unwrap();
    assert_eq!(left.frame_size, (306, 240));
    assert!(
        shifted.luma != unshifted.luma,
        "the picture does not change across columns"
    );
    assert!(
        left.luma == shifted.luma,
        "the ROI means are not the cropped picture's"
    );
}

/// ffmpeg started before the probe reads the same trace as ffmpeg
/// started after it, whether its layout is kept (inner ROIs) or not (a
/// ROI at the frame's corner); an ROI outside the frame is the same
/// error as before.
#[test]
fn starting_ffmpeg_with_the_probe_reads_what_starting_after_it_reads() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let path = sample_video();
    let opts = rgb_opts();
    let inner = vec![rect(457, 247, 20, 2), rect(640, 500, 13, 9)];
    for (rois, kept) in [(inner, true), (spread_rois(), false)] {
        let spec = Layout::speculative(&rois).unwrap();
        assert_eq!(spec == Layout::for_rois(&rois, (1280, 800)), kept);
        let after = read_with(&path, probe(&path).unwrap(), &rois, &opts, Layout::for_rois);
        let with = probe_and_read(&path, &rois, &opts).unwrap();
        assert_eq!(with, after.unwrap());
        assert_eq!(with.luma[0].len(), 369);
    }
    let outside = [rect(457, 247, 20, 2), rect(1270, 0, 20, 2)];
    let e = probe_and_read(&path, &outside, &opts).unwrap_err();
    let before = read_with(
        &path,
        probe(&path).unwrap(),
        &outside,
        &opts,
        Layout::for_rois,
    );
    assert_eq!(e.to_string(), before.unwrap_err().to_string());
    assert!(e.to_string().contains("outside the 1280x800 frame"), "{e}");
}

/// A probe slower than the stall limit does not make ffmpeg's watchdog
/// fire: ffmpeg waits for it on a full pipe, and its watchdog starts
/// when the probe has answered.
#[test]
fn a_slow_probe_is_not_a_stall_of_ffmpeg() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let path = sample_video();
    let rois = [rect(457, 247, 20, 2), rect(640, 500, 13, 9)];
    let opts = rgb_opts();
    let stall = Duration::from_millis(400);
    let slow = |p: &Path| {
        std::thread::sleep(3 * stall);
        probe(p)
    };
    let got = probe_and_read_with(&path, &rois, &opts, slow, stall).unwrap();
    assert_eq!(got, probe_and_read(&path, &rois, &opts).unwrap());
}

/// ffmpeg's stdout pipe holds 1 MB, where the system allows that much.
#[test]
fn ffmpeg_pipe_holds_a_megabyte() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let rois = [rect(457, 247, 20, 2)];
    let layout = Layout::speculative(&rois).unwrap();
    let d = Decoder::start(&sample_video(), layout, &rgb_opts()).unwrap();
    let fd = std::os::fd::AsRawFd::as_raw_fd(d.child.stdout.as_ref().unwrap());
    // SAFETY: F_GETPIPE_SZ reads the size of a pipe this process owns.
    let size = unsafe { libc::fcntl(fd, libc::F_GETPIPE_SZ) };
    let max: libc::c_int = std::fs::read_to_string("/proc/sys/fs/pipe-max-size")
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert_eq!(size, PIPE_BYTES.min(max).max(64 << 10));
}

/// True while any process of group `pgid` exists.
fn group_exists(pgid: u32) -> bool {
    // SAFETY: signal 0 only checks that the group exists.
    unsafe { libc::kill(-(pgid as libc::pid_t), 0) == 0 }
}

/// A speculative ffmpeg that is not read is killed with its group and
/// reaped when dropped, as on a failed probe; one that is read is
/// reaped too.
#[test]
fn an_unused_ffmpeg_is_killed_and_reaped() {
    assert!(ffmpeg_available(), "this test needs `ffmpeg` and `ffprobe`");
    let path = sample_video();
    let rois = [rect(457, 247, 20, 2), rect(640, 500, 13, 9)];
    let layout = Layout::speculative(&rois).unwrap();
    let d = Decoder::start(&path, layout, &rgb_opts()).unwrap();
    let pgid = d.child.id();
    // It blocks on its full pipe: alive until dropped.
    std::thread::sleep(Duration::from_millis(300));
    assert!(group_exists(pgid));
    drop(d);
    assert!(!group_exists(pgid));
    // A probe error drops it the same way; the probe's error is returned.
    let failed = |p: &Path| {
        Err(CaptureError::Read {
            path: p.to_path_buf(),
            message: "probe failed".to_string(),
        })
    };
    let e = probe_and_read_with(&path, &rois, &rgb_opts(), failed, STALL).unwrap_err();
    assert!(e.to_string().contains("probe failed"), "{e}");
}
