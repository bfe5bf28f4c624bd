//! CSV luma traces exported by other tools: a header row, then one row per
//! frame. Columns named like the plan's ROIs hold their luma (DN); an
//! optional `time_s` column holds the frame times (else the frame rate is
//! used); other columns (`frame`, `segment`, ...) are ignored. A trace
//! written by ledflicker (traces/<case>.csv) reads back as is.

use std::path::Path;

use super::{CaptureError, CaptureTrace, ReadOptions, check_interrupt, read_file, times_from_fps};

/// Largest luma a CSV trace may hold, DN. Far above any sensor's scale
/// (a 32-bit HDR sample is below 4.3e9), and low enough that the metrics'
/// sums and squares over any trace stay finite and exact to well below a
/// DN (values near 1e308 would overflow Percent Flicker to infinity).
pub const MAX_CSV_LUMA_DN: f64 = 1e12;

/// Rows parsed between checks for Ctrl-C.
const ROWS_PER_CHECK: usize = 1 << 14;

/// The file as text. Binary junk (bytes that are not UTF-8, or control
/// characters) is an error naming its line, and is never echoed.
fn text_of(path: &Path, bytes: Vec<u8>) -> Result<String, CaptureError> {
    let junk = |bytes: &[u8], at: usize| {
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!("line {line} holds binary data (byte {at}), not CSV text"),
            hint: "a CSV trace is UTF-8 text: a header row, then one row of numbers per frame"
                .to_string(),
        }
    };
    if let Some(at) = bytes
        .iter()
        .position(|&b| b < 0x20 && !matches!(b, b'\n' | b'\r' | b'\t'))
    {
        return Err(junk(&bytes, at));
    }
    String::from_utf8(bytes).map_err(|e| junk(e.as_bytes(), e.utf8_error().valid_up_to()))
}

/// A field or header for a message: quoted, at most 40 characters.
fn shown(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect();
    if out.len() < s.len() {
        out.push_str("...");
    }
    format!("`{out}`")
}

pub(super) fn read(
    path: &Path,
    roi_names: &[String],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    let bytes = read_file(path)?;
    let text = text_of(path, bytes)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let Some((_, header)) = lines.next() else {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: "the CSV trace is empty".to_string(),
            hint: "a header row, e.g. `frame,time_s,led`, then one row per frame".to_string(),
        });
    };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let time_col = cols.iter().position(|c| *c == "time_s");
    let mut roi_cols = Vec::with_capacity(roi_names.len());
    for name in roi_names {
        match cols.iter().position(|c| c == name) {
            Some(i) => roi_cols.push(i),
            None => {
                return Err(CaptureError::Invalid {
                    path: path.to_path_buf(),
                    message: format!("no column `{name}` for the plan's ROI `{name}`"),
                    hint: format!(
                        "the header has: {}; name the ROIs in the plan after the trace's columns",
                        shown(&cols.join(", "))
                    ),
                });
            }
        }
    }
    let mut luma = vec![Vec::new(); roi_names.len()];
    let mut times = Vec::new();
    for (frame, (line_no, line)) in lines.enumerate() {
        if frame % ROWS_PER_CHECK == 0 {
            check_interrupt(path)?;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let num = |i: usize| -> Result<f64, CaptureError> {
            let raw = fields.get(i).copied().unwrap_or("");
            raw.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| CaptureError::Frame {
                    path: path.to_path_buf(),
                    frame: frame as u64,
                    message: format!(
                        "line {}, column `{}`: {} is not a finite number",
                        line_no + 1,
                        shown(cols[i]),
                        shown(raw)
                    ),
                })
        };
        for (k, &i) in roi_cols.iter().enumerate() {
            let v = num(i)?;
            if !(0.0..=MAX_CSV_LUMA_DN).contains(&v) {
                return Err(CaptureError::Frame {
                    path: path.to_path_buf(),
                    frame: frame as u64,
                    message: format!(
                        "line {}, column {}: luma {} DN is outside 0..={MAX_CSV_LUMA_DN:e}\n    hint: a CSV trace holds ROI mean luma in DN, from 0 to 1e12",
                        line_no + 1,
                        shown(cols[i]),
                        shown(fields[i])
                    ),
                });
            }
            luma[k].push(v);
        }
        if let Some(i) = time_col {
            times.push(num(i)?);
        }
    }
    let n = luma.first().map_or(0, Vec::len);
    let (time_s, timestamps) = match (time_col, opts.fps) {
        (Some(_), _) => (times, crate::trace::TimestampSource::Csv),
        (None, Some(fps)) => (times_from_fps(n, fps), crate::trace::TimestampSource::Fps),
        (None, None) => (
            times_from_fps(n, f64::NAN),
            crate::trace::TimestampSource::None,
        ),
    };
    Ok(CaptureTrace {
        time_s,
        luma,
        rgb: None,
        full_scale_dn: 255.0,
        frame_size: (0, 0),
        timestamps,
        format: "csv luma trace".to_string(),
        time_base_s: None,
        stated_fps: None,
    })
}
