//! The frame size of an MP4 or QuickTime file, read from its header boxes
//! in this process.
//!
//! Plan validation needs only each video's width and height, to check the
//! ROIs. Asking ffprobe costs a process per video (about 0.05-0.08 s of
//! wall time each, before anything else can start); the ISO base media
//! file format (ISO/IEC 14496-12) states the size in the first video
//! track's sample description, a few hundred bytes into the `moov` box.
//! Anything this reader does not recognise (not an ISO file, no video
//! track, a box that does not fit) gives `None`, and the caller asks
//! ffprobe. The run reads the size again from ffprobe and checks the ROIs
//! against that, so a file whose header disagrees with its stream is still
//! refused with the run's own message.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Largest `moov` box read whole. A `moov` holds the sample tables of every
/// track (a few bytes per frame): an hour at 60 frames/s is about 3 MB.
const MOOV_MAX: u64 = 64 << 20;

/// Most top-level boxes looked at before giving up: an ISO file has a
/// handful (`ftyp`, `moov`, `mdat`, maybe `free`, `uuid`, fragments).
const TOP_LEVEL_MAX: usize = 4096;

/// Width and height of the first video track of the ISO base media file
/// at `path`, from its sample description; `None` when the file is not one
/// (its first box is not `ftyp`, or QuickTime's `wide`, `free`, `mdat`,
/// `moov`) or its header cannot be read.
pub(super) fn frame_size(path: &Path) -> Option<(u32, u32)> {
    let mut file = File::open(path).ok()?;
    let len = file.metadata().ok()?.len();
    let moov = find_top_level(&mut file, len, *b"moov")?;
    video_size(&moov)
}

/// The body of the first top-level box of type `want`, read whole.
fn find_top_level(file: &mut File, len: u64, want: [u8; 4]) -> Option<Vec<u8>> {
    let mut at = 0u64;
    for n in 0..TOP_LEVEL_MAX {
        if at >= len {
            return None;
        }
        file.seek(SeekFrom::Start(at)).ok()?;
        let mut head = [0u8; 16];
        file.read_exact(&mut head[..8]).ok()?;
        let kind: [u8; 4] = head[4..8].try_into().ok()?;
        if n == 0 && !matches!(&kind, b"ftyp" | b"wide" | b"free" | b"mdat" | b"moov") {
            return None;
        }
        let (size, header) = match u32::from_be_bytes(head[..4].try_into().ok()?) {
            0 => (len - at, 8),
            1 => {
                file.read_exact(&mut head[8..16]).ok()?;
                (u64::from_be_bytes(head[8..16].try_into().ok()?), 16)
            }
            s => (u64::from(s), 8),
        };
        if size < header || size > len - at {
            return None;
        }
        if kind == want {
            let body = size - header;
            if body > MOOV_MAX {
                return None;
            }
            let mut buf = vec![0u8; usize::try_from(body).ok()?];
            file.read_exact(&mut buf).ok()?;
            return Some(buf);
        }
        at += size;
    }
    None
}

/// The child boxes of `body`, as (type, body); stops at the first box that
/// does not fit.
fn boxes(body: &[u8]) -> impl Iterator<Item = ([u8; 4], &[u8])> {
    let mut rest = body;
    std::iter::from_fn(move || {
        let size = u32::from_be_bytes(rest.get(..4)?.try_into().ok()?);
        let kind: [u8; 4] = rest.get(4..8)?.try_into().ok()?;
        let (size, header) = match size {
            0 => (rest.len(), 8),
            1 => (
                usize::try_from(u64::from_be_bytes(rest.get(8..16)?.try_into().ok()?)).ok()?,
                16,
            ),
            s => (usize::try_from(s).ok()?, 8),
        };
        if size < header || size > rest.len() {
            return None;
        }
        let child = (kind, &rest[header..size]);
        rest = &rest[size..];
        Some(child)
    })
}

/// The body of the first child of `body` of type `want`.
fn child<'a>(body: &'a [u8], want: &[u8; 4]) -> Option<&'a [u8]> {
    boxes(body).find(|(k, _)| k == want).map(|(_, b)| b)
}

/// Width and height in the first sample entry of the first track of `moov`
/// whose handler is `vide`.
fn video_size(moov: &[u8]) -> Option<(u32, u32)> {
    boxes(moov)
        .filter(|(k, _)| k == b"trak")
        .filter_map(|(_, trak)| child(trak, b"mdia"))
        .find(|mdia| {
            // hdlr: version and flags (4), pre_defined (4), handler_type (4).
            child(mdia, b"hdlr").and_then(|h| h.get(8..12)) == Some(b"vide")
        })
        .and_then(|mdia| {
            let stbl = child(child(mdia, b"minf")?, b"stbl")?;
            // stsd: version and flags (4), entry_count (4), then the entries.
            let stsd = child(stbl, b"stsd")?;
            let (_, entry) = boxes(stsd.get(8..)?).next()?;
            // A visual sample entry: reserved (6), data_reference_index (2),
            // pre_defined and reserved (16), then width and height (2 each).
            let width = u16::from_be_bytes(entry.get(24..26)?.try_into().ok()?);
            let height = u16::from_be_bytes(entry.get(26..28)?.try_into().ok()?);
            (width > 0 && height > 0).then_some((u32::from(width), u32::from(height)))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxed(kind: &[u8; 4], body: &[u8]) -> Vec<u8> {
        let mut b = u32::try_from(body.len() + 8)
            .unwrap()
            .to_be_bytes()
            .to_vec();
        b.extend_from_slice(kind);
        b.extend_from_slice(body);
        b
    }

    /// A `moov` with one track of handler `handler` whose sample entry
    /// states `w` x `h`.
    fn moov(handler: &[u8; 4], w: u16, h: u16) -> Vec<u8> {
        let mut hdlr = vec![0u8; 8];
        hdlr.extend_from_slice(handler);
        hdlr.extend_from_slice(&[0u8; 12]);
        let mut entry = vec![0u8; 24];
        entry.extend_from_slice(&w.to_be_bytes());
        entry.extend_from_slice(&h.to_be_bytes());
        entry.extend_from_slice(&[0u8; 50]);
        let mut stsd = vec![0, 0, 0, 0, 0, 0, 0, 1];
        stsd.extend(boxed(b"avc1", &entry));
        let stbl = boxed(b"stbl", &boxed(b"stsd", &stsd));
        let minf = boxed(b"minf", &stbl);
        let mdia = boxed(b"mdia", &[boxed(b"hdlr", &hdlr), minf].concat());
        boxed(b"moov", &boxed(b"trak", &mdia))
    }

    fn size_of_file(bytes: &[u8]) -> Option<(u32, u32)> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.mp4");
        std::fs::write(&path, bytes).unwrap();
        frame_size(&path)
    }

    #[test]
    fn the_first_video_tracks_sample_entry_gives_the_size() {
        let ftyp = boxed(b"ftyp", b"isom\0\0\x02\0");
        let mdat = boxed(b"mdat", &[7u8; 100]);
        let file = [ftyp.clone(), mdat.clone(), moov(b"vide", 1280, 800)].concat();
        assert_eq!(size_of_file(&file), Some((1280, 800)));
        // moov before mdat (a "fast start" file).
        let file = [ftyp.clone(), moov(b"vide", 640, 480), mdat.clone()].concat();
        assert_eq!(size_of_file(&file), Some((640, 480)));
        // A sound track is not the video.
        let file = [ftyp.clone(), moov(b"soun", 640, 480), mdat].concat();
        assert_eq!(size_of_file(&file), None);
    }

    /// The header's size is ffprobe's, on the real P2020 recordings and on
    /// files FFmpeg writes: H.264 with the `moov` at the end and at the
    /// start, MPEG-4 Part 2, Motion JPEG in a QuickTime file, sizes that
    /// are not multiples of 16; and the files FFmpeg reads but this reader
    /// does not (Matroska, AVI) give None, so ffprobe answers for them.
    #[test]
    fn the_header_agrees_with_ffprobe() {
        // Like the integration tests: fail, never skip, without ffmpeg.
        assert!(
            super::super::ffmpeg_available(),
            "this test needs `ffmpeg` and `ffprobe` (scripts/test.sh installs them)"
        );
        let data = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("reference-data/p2020-flicker-videos");
        let mut iso: Vec<std::path::PathBuf> = (1..=3)
            .map(|i| data.join(format!("test_vid{i}.mp4")))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let made = [
            ("h264-end.mp4", "libx264", "642x362", &[][..]),
            (
                "h264-start.mp4",
                "libx264",
                "1282x722",
                &["-movflags", "+faststart"][..],
            ),
            ("mpeg4.mp4", "mpeg4", "320x240", &[][..]),
            ("mjpeg.mov", "mjpeg", "200x150", &[][..]),
            ("ffv1.mkv", "ffv1", "64x48", &[][..]),
            ("mpeg4.avi", "mpeg4", "64x48", &[][..]),
        ];
        for (name, codec, size, extra) in made {
            let out = dir.path().join(name);
            let status = std::process::Command::new("ffmpeg")
                .args(["-nostdin", "-v", "error", "-f", "lavfi", "-i"])
                .arg(format!("testsrc=size={size}:rate=10:duration=0.5"))
                .args(["-c:v", codec, "-pix_fmt"])
                .arg(if codec == "mjpeg" {
                    "yuvj420p"
                } else {
                    "yuv420p"
                })
                .args(extra)
                .arg(&out)
                .status()
                .unwrap();
            assert!(status.success(), "ffmpeg could not write {name}");
            if name.ends_with(".mkv") || name.ends_with(".avi") {
                assert_eq!(frame_size(&out), None, "{name}");
            } else {
                iso.push(out);
            }
        }
        for path in &iso {
            let ours = frame_size(path);
            assert!(ours.is_some(), "{}", path.display());
            assert_eq!(
                ours,
                super::super::probe::frame_size(path),
                "{}",
                path.display()
            );
        }
    }

    #[test]
    fn what_is_not_a_whole_iso_header_gives_none() {
        let ftyp = boxed(b"ftyp", b"isom\0\0\x02\0");
        let whole = [ftyp.clone(), moov(b"vide", 1280, 800)].concat();
        // Cut anywhere inside the moov box.
        for cut in ftyp.len()..whole.len() {
            assert_eq!(size_of_file(&whole[..cut]), None, "cut at {cut}");
        }
        // A Matroska file (EBML header), a text file, an empty file.
        assert_eq!(size_of_file(&[0x1a, 0x45, 0xdf, 0xa3, 0, 0, 0, 0]), None);
        assert_eq!(size_of_file(b"time,roi\n0,1\n"), None);
        assert_eq!(size_of_file(b""), None);
        // A box claiming more than the file holds, and a zero-size sample entry.
        let mut lying = whole.clone();
        lying[ftyp.len()..ftyp.len() + 4].copy_from_slice(&u32::MAX.to_be_bytes());
        assert_eq!(size_of_file(&lying), None);
        let file = [ftyp, moov(b"vide", 0, 800)].concat();
        assert_eq!(size_of_file(&file), None);
    }
}
