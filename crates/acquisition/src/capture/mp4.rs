//! The frame size of an MP4 or QuickTime file, read from its header boxes
//! in this process.
//!
//! Plan validation needs only each video's width and height, to check the
//! ROIs. Asking ffprobe costs a process per video (about 0.05-0.08 s of
//! wall time each, before anything else can start); the ISO base media
//! file format (ISO/IEC 14496-12) states the size in the first video
//! track's sample description, a few hundred bytes into the `moov` box.
//! A muxer may write a size there that is not the stream's (ffprobe and
//! the decoder go by the stream), so the size is taken only where the
//! stream's own statement agrees: for H.264, the sequence parameter sets in
//! the same sample description and in the first sample. Anything else
//! (another codec, not an ISO file, no video track, a layout in which
//! FFmpeg might read another track or sample description, a box that does
//! not fit, sizes that disagree) gives `None`, and the caller asks
//! ffprobe.

mod sps;

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Largest `moov` box read whole. A `moov` holds the sample tables of every
/// track (a few bytes per frame): an hour at 60 frames/s is about 3 MB.
const MOOV_MAX: u64 = 64 << 20;

/// Most top-level boxes looked at before giving up: an ISO file has a
/// handful (`ftyp`, `moov`, `mdat`, maybe `free`, `uuid`, fragments).
const TOP_LEVEL_MAX: usize = 4096;

/// Width and height of the video track of the ISO base media file at
/// `path`, from its sample description; `None` when the file is not one
/// (its first box is not `ftyp`, or QuickTime's `wide`, `free`, `mdat`,
/// `moov`), its header cannot be read, or its layout is not the plain one
/// [`video_size`] reads.
pub(super) fn frame_size(path: &Path) -> Option<(u32, u32)> {
    let mut file = File::open(path).ok()?;
    let len = file.metadata().ok()?.len();
    let moov = find_top_level(&mut file, len, *b"moov")?;
    let video = video_size(&moov)?;
    // A stream may carry parameter sets in its samples too, and a decoder
    // (and ffprobe) goes by those: the first sample's must agree as well.
    let (offset, bytes) = video.first_sample;
    if bytes > SAMPLE_MAX || offset.checked_add(bytes)? > len {
        return None;
    }
    file.seek(SeekFrom::Start(offset)).ok()?;
    let mut sample = vec![0u8; usize::try_from(bytes).ok()?];
    file.read_exact(&mut sample).ok()?;
    let mut rest = sample.as_slice();
    while !rest.is_empty() {
        let (head, body) = rest.split_at_checked(video.length_bytes)?;
        let n = head.iter().fold(0usize, |n, &b| (n << 8) | usize::from(b));
        let (nal, after) = body.split_at_checked(n)?;
        if nal.first().is_some_and(|b| b & 0x1f == 7) && sps::picture_size(nal)? != video.size {
            return None;
        }
        rest = after;
    }
    Some(video.size)
}

/// Largest first sample read, bytes: a key frame of an 8K stream is a few
/// megabytes.
const SAMPLE_MAX: u64 = 16 << 20;

/// What the header says of the video track.
struct Video {
    /// The size its sample description and parameter sets agree on.
    size: (u32, u32),
    /// Where its first sample is: file offset and length, bytes.
    first_sample: (u64, u64),
    /// Bytes of each NAL unit's length in a sample (1, 2 or 4).
    length_bytes: usize,
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

/// Width and height in the sample entry of the video track of `moov`,
/// where its H.264 parameter sets state the same; and where its first
/// sample is.
///
/// Only a plain layout is read, so that the track is surely the stream
/// FFmpeg calls `v:0` and the entry surely the one its samples use: every
/// track but one is sound (FFmpeg makes a track of any other handler a
/// video stream when its sample entry is a video codec's), that one's
/// handler is `vide`, it has one sample entry, no user data or metadata
/// comes before it, and the file is not fragmented (no `mvex`: its samples
/// are in fragments the header does not describe).
fn video_size(moov: &[u8]) -> Option<Video> {
    if child(moov, b"mvex").is_some() {
        return None;
    }
    // FFmpeg numbers its streams as it meets them: a cover picture (`covr`,
    // in a `udta` or `meta` box) met before the video track is `v:0`.
    let mut video = None;
    for (kind, body) in boxes(moov) {
        match &kind {
            b"udta" | b"meta" if video.is_none() => return None,
            b"trak" => {
                let mdia = child(body, b"mdia")?;
                if handler(mdia) == Some(b"soun") {
                    continue;
                }
                if video.replace(mdia).is_some() || handler(mdia) != Some(b"vide") {
                    return None;
                }
            }
            _ => {}
        }
    }
    let mdia = video?;
    let stbl = child(child(mdia, b"minf")?, b"stbl")?;
    // stsd: version and flags (4), entry_count (4), then the entries.
    let stsd = child(stbl, b"stsd")?;
    if stsd.get(4..8)? != 1u32.to_be_bytes() {
        return None;
    }
    let (kind, entry) = boxes(stsd.get(8..)?).next()?;
    // A visual sample entry: reserved (6), data_reference_index (2),
    // pre_defined and reserved (16), then width and height (2 each).
    let width = u16::from_be_bytes(entry.get(24..26)?.try_into().ok()?);
    let height = u16::from_be_bytes(entry.get(26..28)?.try_into().ok()?);
    let size = (u32::from(width), u32::from(height));
    let (stated, length_bytes) = stream_size(&kind, entry)?;
    (stated == size).then_some(Video {
        size,
        first_sample: first_sample(stbl)?,
        length_bytes,
    })
}

/// The handler type of the track of `mdia`: `vide`, `soun` and so on.
fn handler(mdia: &[u8]) -> Option<&[u8]> {
    // hdlr: version and flags (4), pre_defined (4), handler_type (4).
    child(mdia, b"hdlr")?.get(8..12)
}

/// File offset and length of the first sample of the track of `stbl`:
/// the first chunk's offset (`stco` or `co64`) and the first sample's size
/// (`stsz`). None without one (a fragmented file's samples are in its
/// fragments).
fn first_sample(stbl: &[u8]) -> Option<(u64, u64)> {
    // stsz: version and flags (4), sample_size (4), sample_count (4), then
    // each sample's size when sample_size is 0.
    let stsz = child(stbl, b"stsz")?;
    let be32 = |b: &[u8], at: usize| Some(u32::from_be_bytes(b.get(at..at + 4)?.try_into().ok()?));
    if be32(stsz, 8)? == 0 {
        return None;
    }
    let bytes = match be32(stsz, 4)? {
        0 => be32(stsz, 12)?,
        all => all,
    };
    // stco / co64: version and flags (4), entry_count (4), then offsets.
    let offset = match child(stbl, b"stco") {
        Some(stco) => u64::from(be32(stco, 8)?),
        None => u64::from_be_bytes(child(stbl, b"co64")?.get(8..16)?.try_into().ok()?),
    };
    Some((offset, u64::from(bytes)))
}

/// The picture size the stream itself states, from the sample entry's
/// decoder configuration, and the bytes of a NAL unit's length in its
/// samples: for H.264 (`avc1`, `avc3`), the sequence parameter sets of its
/// `avcC` box (ISO/IEC 14496-15), which must all agree. None for other
/// codecs: their size is left to ffprobe.
fn stream_size(kind: &[u8; 4], entry: &[u8]) -> Option<((u32, u32), usize)> {
    if !matches!(kind, b"avc1" | b"avc3") {
        return None;
    }
    // The visual sample entry's fields take 78 bytes; its boxes follow.
    let avcc = child(entry.get(78..)?, b"avcC")?;
    // configurationVersion, profile, compatibility, level, lengthSizeMinusOne
    // (low 2 bits), then the number of sequence parameter sets (low 5 bits),
    // each after its 2-byte length.
    let length_bytes = usize::from(avcc.get(4)? & 3) + 1;
    if length_bytes == 3 {
        return None;
    }
    let mut rest = avcc.get(6..)?;
    let mut size = None;
    for _ in 0..avcc.get(5)? & 0x1f {
        let (len, after) = rest.split_at_checked(2)?;
        let len = usize::from(u16::from_be_bytes(len.try_into().ok()?));
        let (nal, after) = after.split_at_checked(len)?;
        let this = sps::picture_size(nal)?;
        if size.is_some_and(|s| s != this) {
            return None;
        }
        size = Some(this);
        rest = after;
    }
    Some((size?, length_bytes))
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

    /// Writes Exp-Golomb codes and bits, most significant first.
    #[derive(Default)]
    struct Writer(Vec<bool>);

    impl Writer {
        fn bits(&mut self, v: u32, n: u32) {
            (0..n).rev().for_each(|i| self.0.push((v >> i) & 1 == 1));
        }

        fn ue(&mut self, v: u32) {
            let n = 32 - (v + 1).leading_zeros();
            self.bits(0, n - 1);
            self.bits(v + 1, n);
        }

        fn bytes(mut self) -> Vec<u8> {
            self.0.push(true); // rbsp_stop_one_bit
            self.0
                .chunks(8)
                .map(|c| {
                    c.iter()
                        .enumerate()
                        .fold(0u8, |b, (i, &x)| b | (u8::from(x) << (7 - i)))
                })
                .collect()
        }
    }

    /// A Baseline-profile sequence parameter set for `w` x `h` pictures
    /// (even sizes), cropped from whole macroblocks at the right and bottom.
    fn sps(w: u32, h: u32) -> Vec<u8> {
        sps_of(66, None, (w, h))
    }

    /// A sequence parameter set of profile `profile` (with 4:2:0 chroma
    /// fields where FFmpeg reads them) and, with `poc_cycle`, picture order
    /// count type 1 with that many reference frame offsets.
    fn sps_of(profile: u32, poc_cycle: Option<u32>, (w, h): (u32, u32)) -> Vec<u8> {
        let mut b = Writer::default();
        b.bits(profile, 8);
        b.bits(0, 8);
        b.bits(30, 8);
        b.ue(0); // seq_parameter_set_id
        if matches!(
            profile,
            100 | 110 | 122 | 244 | 44 | 83 | 86 | 118 | 128 | 138 | 144
        ) {
            [1, 0, 0].into_iter().for_each(|v| b.ue(v)); // 4:2:0, 8-bit luma and chroma
            b.bits(0, 2); // no transform bypass, no scaling matrix
        }
        b.ue(0); // log2_max_frame_num_minus4
        match poc_cycle {
            None => b.ue(2),
            Some(n) => {
                b.ue(1);
                b.bits(0, 1); // delta_pic_order_always_zero_flag
                [0, 0, n].into_iter().for_each(|v| b.ue(v)); // two offsets, the cycle's length
                (0..n).for_each(|_| b.ue(0)); // offset_for_ref_frame
            }
        }
        b.ue(1); // max_num_ref_frames
        b.bits(0, 1); // gaps
        let (mbs_w, mbs_h) = (w.div_ceil(16), h.div_ceil(16));
        b.ue(mbs_w - 1);
        b.ue(mbs_h - 1);
        b.bits(0b11, 2); // frame_mbs_only, direct_8x8_inference
        let (right, bottom) = ((16 * mbs_w - w) / 2, (16 * mbs_h - h) / 2);
        b.bits(u32::from(right + bottom > 0), 1);
        if right + bottom > 0 {
            [0, right, 0, bottom].into_iter().for_each(|v| b.ue(v));
        }
        b.bits(0, 1); // no VUI
        [vec![0x67], b.bytes()].concat()
    }

    /// A `moov` with one track of handler `handler` whose sample entry
    /// states `w` x `h` and its stream `stream`, and whose first sample of
    /// `bytes` bytes is at file offset `at`.
    fn moov(
        handler: &[u8; 4],
        header: (u16, u16),
        stream: (u32, u32),
        first_sample: (u32, u32),
    ) -> Vec<u8> {
        boxed(b"moov", &trak(handler, &[(header, stream)], first_sample))
    }

    /// An `avc1` sample entry: the size its header states, its stream's size.
    type Entry = ((u16, u16), (u32, u32));

    /// A track of handler `handler` with one `avc1` sample entry per
    /// `entries` item (the size its header states, its stream's size),
    /// whose first sample of `bytes` bytes is at file offset `at`.
    fn trak(handler: &[u8; 4], entries: &[Entry], (at, bytes): (u32, u32)) -> Vec<u8> {
        let mut hdlr = vec![0u8; 8];
        hdlr.extend_from_slice(handler);
        hdlr.extend_from_slice(&[0u8; 12]);
        let mut stsd = [
            [0u8; 4],
            u32::try_from(entries.len()).unwrap().to_be_bytes(),
        ]
        .concat();
        for &((w, h), stream) in entries {
            let mut entry = vec![0u8; 24];
            entry.extend_from_slice(&w.to_be_bytes());
            entry.extend_from_slice(&h.to_be_bytes());
            entry.extend_from_slice(&[0u8; 50]);
            let nal = sps(stream.0, stream.1);
            let mut avcc = vec![1, 66, 0, 30, 0xff, 0xe1];
            avcc.extend_from_slice(&u16::try_from(nal.len()).unwrap().to_be_bytes());
            avcc.extend_from_slice(&nal);
            avcc.push(0); // no picture parameter set
            entry.extend(boxed(b"avcC", &avcc));
            stsd.extend(boxed(b"avc1", &entry));
        }
        let stsz = [[0u8; 4], bytes.to_be_bytes(), 1u32.to_be_bytes()].concat();
        let stco = [[0u8; 4], 1u32.to_be_bytes(), at.to_be_bytes()].concat();
        let stbl = boxed(
            b"stbl",
            &[
                boxed(b"stsd", &stsd),
                boxed(b"stsz", &stsz),
                boxed(b"stco", &stco),
            ]
            .concat(),
        );
        let minf = boxed(b"minf", &stbl);
        let mdia = boxed(b"mdia", &[boxed(b"hdlr", &hdlr), minf].concat());
        boxed(b"trak", &mdia)
    }

    /// An MP4 file: `ftyp`, then an `mdat` holding one sample of the NAL
    /// units `nals` (each after its 4-byte length) and the `moov` of
    /// [`moov`], or the `moov` first when `fast_start`.
    fn mp4(
        handler: &[u8; 4],
        header: (u16, u16),
        stream: (u32, u32),
        nals: &[Vec<u8>],
        fast_start: bool,
    ) -> Vec<u8> {
        let ftyp = boxed(b"ftyp", b"isom\0\0\x02\0");
        let sample: Vec<u8> = nals
            .iter()
            .flat_map(|n| {
                [
                    u32::try_from(n.len()).unwrap().to_be_bytes().to_vec(),
                    n.clone(),
                ]
                .concat()
            })
            .collect();
        let bytes = u32::try_from(sample.len()).unwrap();
        let moov_len = moov(handler, header, stream, (0, bytes)).len();
        let at = ftyp.len() + if fast_start { moov_len } else { 0 } + 8;
        let moov = moov(handler, header, stream, (u32::try_from(at).unwrap(), bytes));
        let mdat = boxed(b"mdat", &sample);
        if fast_start {
            [ftyp, moov, mdat].concat()
        } else {
            [ftyp, mdat, moov].concat()
        }
    }

    fn size_of_file(bytes: &[u8]) -> Option<(u32, u32)> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.mp4");
        std::fs::write(&path, bytes).unwrap();
        frame_size(&path)
    }

    #[test]
    fn the_size_is_taken_where_the_header_and_the_stream_agree() {
        let slice = vec![0x65, 0x88, 0x84, 0x00];
        let at = |w: u16, h: u16, fast_start| {
            let stream = (u32::from(w), u32::from(h));
            mp4(
                b"vide",
                (w, h),
                stream,
                std::slice::from_ref(&slice),
                fast_start,
            )
        };
        assert_eq!(size_of_file(&at(1280, 800, false)), Some((1280, 800)));
        // moov before mdat (a "fast start" file); cropped macroblocks.
        assert_eq!(size_of_file(&at(642, 362, true)), Some((642, 362)));
        // A sound track is not the video.
        let sound = mp4(
            b"soun",
            (640, 480),
            (640, 480),
            std::slice::from_ref(&slice),
            false,
        );
        assert_eq!(size_of_file(&sound), None);
        // A header that states another size than its stream, either way.
        for stream in [(640, 496), (640, 464), (642, 480)] {
            let file = mp4(
                b"vide",
                (640, 480),
                stream,
                std::slice::from_ref(&slice),
                false,
            );
            assert_eq!(size_of_file(&file), None, "stream {stream:?}");
        }
        // Parameter sets in the first sample: they must agree too.
        let same = mp4(
            b"vide",
            (640, 480),
            (640, 480),
            &[sps(640, 480), slice.clone()],
            false,
        );
        assert_eq!(size_of_file(&same), Some((640, 480)));
        let other = mp4(
            b"vide",
            (640, 480),
            (640, 480),
            &[sps(624, 352), slice.clone()],
            false,
        );
        assert_eq!(size_of_file(&other), None);
    }

    /// Where the header reader answers, it gives ffprobe's size: on the real
    /// P2020 recordings and on H.264 files FFmpeg writes (the `moov` at the
    /// end and at the start, sizes that are not whole macroblocks, 4:4:4,
    /// 4:2:2, grey, 10-bit, interlaced, scaling matrices). It answers for
    /// every H.264 MP4 or MOV, and for nothing else: MPEG-4 Part 2, Motion
    /// JPEG, Matroska and AVI are left to ffprobe.
    #[test]
    fn the_header_agrees_with_ffprobe() {
        // Like the integration tests: fail, never skip, without ffmpeg.
        assert!(
            super::super::ffmpeg_available(),
            "this test needs `ffmpeg` and `ffprobe` (scripts/test.sh installs them)"
        );
        let mut h264: Vec<std::path::PathBuf> = (1..=3)
            .map(|i| super::super::tests::p2020_sample(&format!("test_vid{i}.mp4")))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        // Codec, pixel format, further options.
        type How = (&'static str, &'static str, &'static [&'static str]);
        let x264 =
            |pix: &'static str, extra: &'static [&'static str]| -> How { ("libx264", pix, extra) };
        let made: [(&str, &str, How); 12] = [
            ("end.mp4", "642x362", x264("yuv420p", &[])),
            (
                "start.mp4",
                "1282x722",
                x264("yuv420p", &["-movflags", "+faststart"]),
            ),
            ("hd.mov", "1920x1080", x264("yuv420p", &[])),
            ("444.mp4", "322x242", x264("yuv444p", &[])),
            ("422.mp4", "322x242", x264("yuv422p", &[])),
            ("grey.mp4", "322x242", x264("gray", &[])),
            ("10bit.mp4", "322x242", x264("yuv420p10le", &[])),
            (
                "fields.mp4",
                "640x480",
                x264("yuv420p", &["-flags", "+ildct+ilme"]),
            ),
            (
                "cqm.mp4",
                "322x242",
                x264("yuv420p", &["-x264-params", "cqm=jvt"]),
            ),
            ("mpeg4.mp4", "320x240", ("mpeg4", "yuv420p", &[])),
            ("mjpeg.mov", "200x150", ("mjpeg", "yuvj420p", &[])),
            ("ffv1.mkv", "64x48", ("ffv1", "yuv420p", &[])),
        ];
        let mut other = Vec::new();
        for (name, size, (codec, pix, extra)) in made {
            let out = dir.path().join(name);
            let status = std::process::Command::new("ffmpeg")
                .args(["-nostdin", "-v", "error", "-f", "lavfi", "-i"])
                .arg(format!("testsrc=size={size}:rate=10:duration=0.5"))
                .args(["-c:v", codec, "-pix_fmt", pix])
                .args(extra)
                .arg(&out)
                .status()
                .unwrap();
            assert!(status.success(), "ffmpeg could not write {name}");
            if codec == "libx264" {
                h264.push(out)
            } else {
                other.push(out)
            }
        }
        for path in &h264 {
            let ours = frame_size(path);
            assert!(ours.is_some(), "{}", path.display());
            assert_eq!(
                ours,
                super::super::probe::frame_size(path),
                "{}",
                path.display()
            );
        }
        for path in &other {
            assert_eq!(frame_size(path), None, "{}", path.display());
        }
    }

    /// A file whose sample entry states another size than its stream (as a
    /// careless muxer writes) is left to ffprobe, whichever way it is off.
    #[test]
    fn a_header_that_disagrees_with_its_stream_is_left_to_ffprobe() {
        assert!(super::super::ffmpeg_available(), "this test needs `ffmpeg`");
        let path = super::super::tests::p2020_sample("test_vid3.mp4");
        let bytes = std::fs::read(&path).unwrap();
        // The sample entry, not the `avc1` brand of `ftyp`: its body starts
        // with six reserved zero bytes.
        let at = bytes
            .windows(10)
            .position(|w| w == b"avc1\0\0\0\0\0\0")
            .unwrap();
        // The entry's body starts after its type; its height is at 26..28.
        for height in [784u16, 816] {
            let mut edited = bytes.clone();
            edited[at + 4 + 26..at + 4 + 28].copy_from_slice(&height.to_be_bytes());
            assert_eq!(size_of_file(&edited), None, "height {height}");
        }
        assert_eq!(size_of_file(&bytes), Some((1280, 800)));
    }

    /// Where FFmpeg could read another stream or another sample entry than
    /// the header reader would, the size is left to ffprobe.
    #[test]
    fn only_a_plain_layout_is_read() {
        let ftyp = boxed(b"ftyp", b"isom\0\0\x02\0");
        let sample = [4u32.to_be_bytes().to_vec(), vec![0x65, 0x88, 0x84, 0x00]].concat();
        let first = (
            u32::try_from(ftyp.len() + 8).unwrap(),
            u32::try_from(sample.len()).unwrap(),
        );
        // A file whose `moov` holds the boxes `children`, in this order.
        let file = |children: &[&Vec<u8>]| {
            let moov: Vec<u8> = children.iter().copied().flatten().copied().collect();
            [ftyp.clone(), boxed(b"mdat", &sample), boxed(b"moov", &moov)].concat()
        };
        let vga = ((640, 480), (640, 480));
        let qvga = ((320, 240), (320, 240));
        let video = trak(b"vide", &[vga], first);
        assert_eq!(size_of_file(&file(&[&video])), Some((640, 480)));
        // Sound tracks never become video streams.
        let sound = trak(b"soun", &[qvga], first);
        assert_eq!(size_of_file(&file(&[&sound, &video])), Some((640, 480)));
        assert_eq!(size_of_file(&file(&[&video, &sound])), Some((640, 480)));
        // FFmpeg makes an `avc1` track of another handler a video stream,
        // which may come first; a second video track is as unclear.
        for other in [b"auxv", b"vide", b"meta"] {
            let other = trak(other, &[qvga], first);
            assert_eq!(size_of_file(&file(&[&other, &video])), None);
            assert_eq!(size_of_file(&file(&[&video, &other])), None);
        }
        assert_eq!(size_of_file(&file(&[&trak(b"auxv", &[vga], first)])), None);
        // Two sample entries: the samples may use the second.
        assert_eq!(
            size_of_file(&file(&[&trak(b"vide", &[qvga, vga], first)])),
            None
        );
        // A fragmented file, even with samples in its `moov`.
        assert_eq!(size_of_file(&file(&[&video, &boxed(b"mvex", &[])])), None);
        // User data or metadata (where a cover picture lives, a stream of
        // its own to FFmpeg) before the video track, not after it.
        for kind in [b"udta", b"meta"] {
            let data = boxed(kind, &boxed(b"covr", &[]));
            assert_eq!(size_of_file(&file(&[&data, &video])), None);
            assert_eq!(size_of_file(&file(&[&sound, &data, &video])), None);
            assert_eq!(size_of_file(&file(&[&video, &data])), Some((640, 480)));
        }
    }

    /// The chroma fields are read for FFmpeg's list of profiles, and a set
    /// FFmpeg refuses or would read otherwise gives no size.
    #[test]
    fn parameter_sets_are_read_as_ffmpeg_reads_them() {
        let size = (642, 362);
        for profile in [66, 77, 100, 110, 122, 244, 144] {
            assert_eq!(
                sps::picture_size(&sps_of(profile, None, size)),
                Some((642, 362)),
                "profile {profile}"
            );
        }
        for profile in [134, 135, 139] {
            assert_eq!(
                sps::picture_size(&sps_of(profile, None, size)),
                None,
                "profile {profile}"
            );
        }
        assert_eq!(
            sps::picture_size(&sps_of(100, Some(255), size)),
            Some((642, 362))
        );
        assert_eq!(sps::picture_size(&sps_of(100, Some(256), size)), None);
    }

    #[test]
    fn what_is_not_a_whole_iso_header_gives_none() {
        let slice = vec![0x65, 0x88, 0x84, 0x00];
        let whole = mp4(b"vide", (1280, 800), (1280, 800), &[slice], true);
        assert_eq!(size_of_file(&whole), Some((1280, 800)));
        // Cut anywhere after the ftyp box: in the moov, or in the sample.
        let ftyp = boxed(b"ftyp", b"isom\0\0\x02\0");
        for cut in ftyp.len()..whole.len() {
            assert_eq!(size_of_file(&whole[..cut]), None, "cut at {cut}");
        }
        // A Matroska file (EBML header), a text file, an empty file.
        assert_eq!(size_of_file(&[0x1a, 0x45, 0xdf, 0xa3, 0, 0, 0, 0]), None);
        assert_eq!(size_of_file(b"time,roi\n0,1\n"), None);
        assert_eq!(size_of_file(b""), None);
        // A box claiming more than the file holds.
        let mut lying = whole.clone();
        lying[ftyp.len()..ftyp.len() + 4].copy_from_slice(&u32::MAX.to_be_bytes());
        assert_eq!(size_of_file(&lying), None);
        // Garbage in place of the parameter set, of every length: no panic.
        for n in 0..64u8 {
            let nal: Vec<u8> = (0..n).map(|i| i.wrapping_mul(37) ^ 0x5a).collect();
            let _ = sps::picture_size(&[&[0x67][..], &nal].concat());
        }
    }
}
