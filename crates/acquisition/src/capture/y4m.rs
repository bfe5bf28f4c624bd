//! YUV4MPEG2 (Y4M) files: 8-bit and high-bit-depth (`p10`, `p12`, `p16`,
//! little-endian) mono, 4:2:0, 4:2:2 and 4:4:4. Only the Y' rows that hold
//! ROIs are read; chroma and other rows are skipped with a seek.

use ledflicker_plan::trace::TimestampSource;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use super::{
    Accumulator, CaptureError, CaptureTrace, FrameView, Pixels, Ratio, ReadOptions, RoiRect,
    VideoRange, bounding_box, check_interrupt, check_rois, limited_to_full_lut, open_file,
    times_from_fps,
};

struct Header {
    width: u32,
    height: u32,
    fps: Option<f64>,
    /// The header's frame rate `F<num>:<den>`, exactly.
    stated_fps: Option<Ratio>,
    /// Bytes per sample (1 or 2).
    bytes: usize,
    bits: u32,
    /// Chroma bytes per frame.
    chroma_bytes: u64,
    full_range: Option<bool>,
}

fn parse_header(line: &str, path: &Path) -> Result<Header, CaptureError> {
    let bad = |message: String| CaptureError::Invalid {
        path: path.to_path_buf(),
        message,
        hint: "a Y4M file starts with `YUV4MPEG2 W<width> H<height> F<num>:<den> C<colourspace>`"
            .to_string(),
    };
    let mut tokens = line.split_ascii_whitespace();
    if tokens.next() != Some("YUV4MPEG2") {
        return Err(bad("not a Y4M file (no YUV4MPEG2 signature)".to_string()));
    }
    let (mut width, mut height, mut fps, mut cs, mut full_range) =
        (None, None, None, "420jpeg".to_string(), None);
    let mut stated_fps = None;
    for t in tokens {
        // The tag is the first character, which need not be ASCII in a
        // damaged header (found by the read_y4m fuzz target).
        let mut chars = t.chars();
        let tag = chars.next();
        let val = chars.as_str();
        match tag {
            Some('W') => width = val.parse::<u32>().ok(),
            Some('H') => height = val.parse::<u32>().ok(),
            Some('F') => {
                if let Some((n, d)) = val.split_once(':')
                    && let (Ok(n), Ok(d)) = (n.parse::<f64>(), d.parse::<f64>())
                    && n > 0.0
                    && d > 0.0
                {
                    fps = Some(n / d);
                }
                stated_fps = Ratio::parse(&val.replacen(':', "/", 1));
            }
            Some('C') => cs = val.to_string(),
            Some('X') => {
                if let Some(r) = val.strip_prefix("COLORRANGE=") {
                    full_range = Some(r.eq_ignore_ascii_case("FULL"));
                }
            }
            _ => {}
        }
    }
    let (width, height) = match (width, height) {
        (Some(w), Some(h)) if w > 0 && h > 0 => (w, h),
        _ => return Err(bad("missing or zero W/H".to_string())),
    };
    let (sub, depth) = match cs.find('p') {
        Some(i) if cs.starts_with("mono") || cs[i + 1..].chars().all(|c| c.is_ascii_digit()) => {
            (&cs[..i], cs[i + 1..].parse::<u32>().unwrap_or(8))
        }
        _ => (cs.as_str(), 8),
    };
    let (sub, depth) = if let Some(d) = sub.strip_prefix("mono") {
        ("mono", d.parse::<u32>().unwrap_or(depth))
    } else {
        (sub, depth)
    };
    if !(8..=16).contains(&depth) {
        return Err(bad(format!("unsupported bit depth in colourspace `C{cs}`")));
    }
    let bytes = if depth > 8 { 2 } else { 1 };
    let (w, h) = (width as u64, height as u64);
    let chroma_samples = match sub {
        "mono" => 0,
        // Saturating: a huge header is refused by `check_frame_size`.
        s if s.starts_with("420") => 2u64.saturating_mul(w.div_ceil(2) * h.div_ceil(2)),
        "422" => 2u64.saturating_mul(w.div_ceil(2) * h),
        "444" => 2u64.saturating_mul(w * h),
        "444alpha" => 3u64.saturating_mul(w * h),
        _ => return Err(bad(format!("unsupported colourspace `C{cs}`"))),
    };
    Ok(Header {
        width,
        height,
        fps,
        stated_fps,
        bytes,
        bits: depth,
        chroma_bytes: chroma_samples.saturating_mul(bytes as u64),
        full_range,
    })
}

/// The frame size (width, height) in the header line of the Y4M file
/// `path`; `None` when it cannot be read or parsed (the read says why).
pub(super) fn frame_size(path: &Path) -> Option<(u32, u32)> {
    let mut r = BufReader::new(open_file(path).ok()?);
    let mut line = Vec::new();
    read_line_bounded(&mut r, &mut line).ok()?;
    let hdr = parse_header(header_text(&line, path).ok()?.trim_end(), path).ok()?;
    Some((hdr.width, hdr.height))
}

/// Longest header or FRAME line read, bytes; the parameters take a few
/// dozen.
const MAX_LINE: u64 = 4096;

/// Bytes skipped at a time between checks for Ctrl-C (tens of
/// milliseconds of reading).
const SKIP_CHUNK: u64 = 64 << 20;

/// Reads one line (up to and including `\n`) of at most [`MAX_LINE`]
/// bytes into `line`; returns its length, 0 at the end of the file.
fn read_line_bounded(r: &mut impl BufRead, line: &mut Vec<u8>) -> std::io::Result<usize> {
    let n = r.by_ref().take(MAX_LINE).read_until(b'\n', line)?;
    if n as u64 == MAX_LINE && line.last() != Some(&b'\n') {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "no line end within {MAX_LINE} bytes (binary data where a text line should be)"
            ),
        ));
    }
    Ok(n)
}

/// The header line as text; binary junk is an error, never echoed.
fn header_text<'a>(line: &'a [u8], path: &Path) -> Result<&'a str, CaptureError> {
    std::str::from_utf8(line)
        .ok()
        .filter(|t| {
            t.chars()
                .all(|c| !c.is_control() || c == '\n' || c == '\r' || c == '\t')
        })
        .ok_or_else(|| CaptureError::Invalid {
            path: path.to_path_buf(),
            message: "the header line holds binary data, not `YUV4MPEG2 W.. H.. ..` text"
                .to_string(),
            hint: "the file is not a Y4M file, or its start is corrupt".to_string(),
        })
}

/// A frame must fit in the file: checked before a buffer is allocated, so a
/// header claiming a huge frame is an error, not an out-of-memory abort.
fn check_frame_size(path: &Path, hdr: &Header, body_len: u64) -> Result<(), CaptureError> {
    let frame_len = u64::from(hdr.width)
        .checked_mul(u64::from(hdr.height))
        .and_then(|p| p.checked_mul(hdr.bytes as u64))
        .and_then(|l| l.checked_add(hdr.chroma_bytes))
        .and_then(|l| l.checked_add(6)); // "FRAME\n"
    match frame_len {
        Some(l) if l <= body_len => Ok(()),
        _ => Err(CaptureError::Frame {
            path: path.to_path_buf(),
            frame: 0,
            message: format!(
                "truncated frame or wrong header: the header claims {}x{} frames ({} bytes each) but the file holds {body_len} bytes after the header",
                hdr.width,
                hdr.height,
                frame_len.map_or("more than 2^64".to_string(), |l| l.to_string())
            ),
        }),
    }
}

/// Reads and drops up to `n` bytes of `r`, in chunks of [`SKIP_CHUNK`]
/// with a check for Ctrl-C between them, so that a huge frame is no
/// exception; returns the bytes skipped (fewer at the end of the file).
fn skip(
    r: &mut impl Read,
    n: u64,
    path: &Path,
    io_err: impl Fn(std::io::Error) -> CaptureError,
) -> Result<u64, CaptureError> {
    let mut skipped = 0;
    while skipped < n {
        check_interrupt(path)?;
        let mut chunk = r.by_ref().take((n - skipped).min(SKIP_CHUNK));
        match std::io::copy(&mut chunk, &mut std::io::sink()).map_err(&io_err)? {
            0 => break,
            k => skipped += k,
        }
    }
    Ok(skipped)
}

pub(super) fn read(
    path: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
    sink: Option<&mut dyn super::FrameSink>,
) -> Result<CaptureTrace, CaptureError> {
    let read_err = |e: std::io::Error| CaptureError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let file = open_file(path)?;
    let file_len = file.metadata().map_err(read_err)?.len();
    let mut r = BufReader::with_capacity(1 << 16, file);
    let mut line = Vec::new();
    read_line_bounded(&mut r, &mut line).map_err(read_err)?;
    let header_len = line.len() as u64;
    let text = header_text(&line, path)?;
    let hdr = parse_header(text.trim_end(), path)?;
    check_rois(path, 0, rois, hdr.width, hdr.height)?;
    check_frame_size(path, &hdr, file_len.saturating_sub(header_len))?;
    let bbox = bounding_box(rois).unwrap_or(RoiRect {
        x: 0,
        y: 0,
        width: hdr.width,
        height: hdr.height,
    });
    let row_bytes = hdr.width as u64 * hdr.bytes as u64;
    let luma_bytes = row_bytes * hdr.height as u64;
    let full = match opts.range {
        VideoRange::Full => true,
        VideoRange::Limited => false,
        VideoRange::Auto => hdr.full_range.unwrap_or(false),
    };
    let mut acc = Accumulator::new(rois, opts.luma).with_sink(sink);
    if !full {
        acc.expand = Some(limited_to_full_lut(hdr.bits));
    }
    let mut buf = vec![0u8; (row_bytes * bbox.height as u64) as usize];
    let mut buf16: Vec<u16> = Vec::new();
    let mut frame: u64 = 0;
    loop {
        check_interrupt(path)?;
        let frame_err = |message: String| CaptureError::Frame {
            path: path.to_path_buf(),
            frame,
            message,
        };
        line.clear();
        let n = read_line_bounded(&mut r, &mut line)
            .map_err(|e| frame_err(format!("cannot read the FRAME line: {e}")))?;
        if n == 0 {
            break;
        }
        if !line.starts_with(b"FRAME") {
            return Err(frame_err(
                "no FRAME marker where a frame should start (corrupt file or wrong W/H/C in the header)"
                    .to_string(),
            ));
        }
        let truncated = |e: std::io::Error| {
            frame_err(format!("truncated frame ({e}); the file ends inside it"))
        };
        r.seek_relative((row_bytes * bbox.y as u64) as i64)
            .map_err(truncated)?;
        r.read_exact(&mut buf).map_err(truncated)?;
        let rest = luma_bytes - row_bytes * (bbox.y + bbox.height) as u64 + hdr.chroma_bytes;
        // Skip by reading, so that a truncated last frame is detected.
        let skipped = skip(&mut r, rest, path, truncated)?;
        if skipped != rest {
            return Err(frame_err(format!(
                "truncated frame: {} of {rest} bytes after the ROI rows are missing",
                rest - skipped
            )));
        }
        // The view covers whole rows bbox.y .. bbox.y + bbox.height.
        let pixels = if hdr.bytes == 1 {
            Pixels::Grey8(&buf)
        } else {
            buf16.clear();
            buf16.extend(
                buf.chunks_exact(2)
                    .map(|b| u16::from_le_bytes([b[0], b[1]])),
            );
            Pixels::Grey16(&buf16)
        };
        acc.push(&FrameView {
            pixels,
            origin: (0, bbox.y),
            width: hdr.width,
        });
        frame += 1;
    }
    let fps = hdr.fps.or(opts.fps);
    let n = acc.frames();
    let (luma, _) = acc.finish();
    let max_dn = if hdr.bytes == 2 {
        ((1u32 << hdr.bits) - 1) as f64
    } else {
        255.0
    };
    Ok(CaptureTrace {
        time_s: times_from_fps(n, fps.unwrap_or(f64::NAN)),
        luma,
        rgb: None,
        full_scale_dn: max_dn,
        frame_size: (hdr.width, hdr.height),
        timestamps: fps.map_or(TimestampSource::None, |_| TimestampSource::Fps),
        format: format!(
            "y4m {}x{} {}-bit, {} range",
            hdr.width,
            hdr.height,
            hdr.bits,
            if full { "full" } else { "limited" }
        ),
        time_base_s: None,
        stated_fps: hdr.stated_fps,
        video: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_token_starting_with_a_wide_character_is_skipped_not_a_panic() {
        // The first line of the input the read_y4m fuzz target found
        // (fuzz/README.md): a token that starts with a two-byte character.
        let path = Path::new("c.y4m");
        let e = parse_header("YUV4MPEG2 W8 \u{1fa} F31E", path)
            .err()
            .unwrap();
        assert!(e.to_string().contains("missing or zero W/H"), "{e}");
        let h = parse_header("YUV4MPEG2 W8 \u{1fa} H2 F30:1 Cmono", path).unwrap();
        assert_eq!((h.width, h.height, h.fps), (8, 2, Some(30.0)));
    }
}
