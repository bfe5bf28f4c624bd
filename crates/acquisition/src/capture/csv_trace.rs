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
pub(super) fn text_of(path: &Path, bytes: Vec<u8>) -> Result<String, CaptureError> {
    let junk = |bytes: &[u8], at: usize| {
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!("line {line} holds binary data (byte {at}), not CSV text"),
            hint: TRACE_HINT.to_string(),
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
pub(super) fn shown(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect();
    if out.len() < s.len() {
        out.push_str("...");
    }
    format!("`{out}`")
}

/// Rows of CSV text, read with the `csv` crate: a line starting with `#`
/// is a comment, quoted fields are unquoted, and a row may have fewer
/// fields than the header (a missing field is reported where it is
/// needed). Fields are not trimmed here: the reader's trim rebuilds every
/// row (a fifth of the instructions of a long trace, docs/speed.md), so
/// callers trim the few fields they read.
pub(super) struct Rows<'a> {
    text: &'a [u8],
    reader: csv::Reader<&'a [u8]>,
    row: csv::StringRecord,
    /// Line ends counted in `text[..counted]`.
    counted: usize,
    /// 1-based line of byte `counted`.
    line: u64,
}

impl<'a> Rows<'a> {
    pub(super) fn new(text: &'a str) -> Self {
        Self::with_delimiter(text, b',')
    }

    /// Rows whose fields are separated by `delimiter` (`,`, `;`, tab).
    pub(super) fn with_delimiter(text: &'a str, delimiter: u8) -> Self {
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .delimiter(delimiter)
            .comment(Some(b'#'))
            .flexible(true)
            .from_reader(text.as_bytes());
        Self {
            text: text.as_bytes(),
            reader,
            row: csv::StringRecord::new(),
            counted: 0,
            line: 1,
        }
    }

    /// The 1-based line of the last byte before `end` (the reader's
    /// offset just past a row). The row's own start offset would not do:
    /// `csv` gives the end of the row before, ahead of any comment or blank
    /// lines it skipped, and ahead of the `\n` of a `\r\n`.
    fn line_before(&mut self, end: u64) -> u64 {
        let end = usize::try_from(end)
            .unwrap_or(usize::MAX)
            .saturating_sub(1)
            .clamp(self.counted, self.text.len());
        let ends = self.text[self.counted..end].iter().filter(|&&b| b == b'\n');
        self.line += ends.count() as u64;
        self.counted = end;
        self.line
    }

    /// The next row that holds a field, and its 1-based line in the file
    /// (of its end, for a quoted field over several lines); blank lines
    /// are skipped.
    pub(super) fn next(
        &mut self,
        path: &Path,
        hint: &str,
    ) -> Result<Option<(u64, &csv::StringRecord)>, CaptureError> {
        loop {
            match self.reader.read_record(&mut self.row) {
                Ok(false) => return Ok(None),
                Ok(true) if self.row.iter().all(|f| f.trim().is_empty()) => {}
                Ok(true) => {
                    let line = self.line_before(self.reader.position().byte());
                    return Ok(Some((line, &self.row)));
                }
                // Text read from a `&str` with every row length allowed:
                // `csv` has nothing to refuse, but an error still says where.
                Err(e) => {
                    let at = e.position().map_or(0, csv::Position::byte);
                    let line = self.line_before(at + 1);
                    return Err(CaptureError::Invalid {
                        path: path.to_path_buf(),
                        message: format!("line {line} is not CSV: {e}"),
                        hint: hint.to_string(),
                    });
                }
            }
        }
    }
}

/// How a CSV trace is laid out, for messages.
const TRACE_HINT: &str =
    "a CSV trace is UTF-8 text: a header row, then one row of numbers per frame";

pub(super) fn read(
    path: &Path,
    roi_names: &[String],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    let bytes = read_file(path)?;
    let text = text_of(path, bytes)?;
    let mut rows = Rows::new(&text);
    let Some((_, header)) = rows.next(path, TRACE_HINT)? else {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: "the CSV trace is empty".to_string(),
            hint: "a header row, e.g. `frame,time_s,led`, then one row per frame".to_string(),
        });
    };
    let cols: Vec<String> = header.iter().map(|c| c.trim().to_string()).collect();
    let time_col = cols.iter().position(|c| c == "time_s");
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
    let mut frame = 0usize;
    while let Some((line, fields)) = rows.next(path, TRACE_HINT)? {
        if frame.is_multiple_of(ROWS_PER_CHECK) {
            check_interrupt(path)?;
        }
        let num = |i: usize| -> Result<f64, CaptureError> {
            let raw = fields.get(i).map_or("", str::trim);
            raw.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| CaptureError::Frame {
                    path: path.to_path_buf(),
                    frame: frame as u64,
                    message: format!(
                        "line {line}, column {}: {} is not a finite number\n    hint: every row needs a number in each ROI column and in `time_s`",
                        shown(&cols[i]),
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
                        "line {line}, column {}: luma {} DN is outside 0..={MAX_CSV_LUMA_DN:e}\n    hint: a CSV trace holds ROI mean luma in DN, from 0 to 1e12",
                        shown(&cols[i]),
                        shown(fields.get(i).map_or("", str::trim))
                    ),
                });
            }
            luma[k].push(v);
        }
        if let Some(i) = time_col {
            times.push(num(i)?);
        }
        frame += 1;
    }
    let n = luma.first().map_or(0, Vec::len);
    let (time_s, timestamps) = match (time_col, opts.fps) {
        (Some(_), _) => (times, ledflicker_plan::trace::TimestampSource::Csv),
        (None, Some(fps)) => (
            times_from_fps(n, fps),
            ledflicker_plan::trace::TimestampSource::Fps,
        ),
        (None, None) => (
            times_from_fps(n, f64::NAN),
            ledflicker_plan::trace::TimestampSource::None,
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
        video: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::{LumaWeights, VideoDecode, VideoRange};

    /// Each row's line and fields.
    fn rows_of(text: &str) -> Vec<(u64, Vec<String>)> {
        let mut rows = Rows::new(text);
        let mut out = Vec::new();
        while let Some((line, row)) = rows.next(Path::new("t.csv"), TRACE_HINT).unwrap() {
            out.push((line, row.iter().map(|f| f.trim().to_string()).collect()));
        }
        out
    }

    #[test]
    fn rows_know_their_line_after_comments_blank_lines_and_crlf() {
        let text = "frame,a\n0, 1\n\n# note\n  \n1,\"2\"\n2,3";
        let expected: Vec<(u64, Vec<String>)> = [
            (1, ["frame", "a"]),
            (2, ["0", "1"]),
            (6, ["1", "2"]),
            (7, ["2", "3"]),
        ]
        .into_iter()
        .map(|(line, row)| (line, row.map(str::to_string).to_vec()))
        .collect();
        assert_eq!(rows_of(text), expected);
        assert_eq!(rows_of(&text.replace('\n', "\r\n")), expected);
        assert_eq!(rows_of(&format!("{text}\n")), expected);
    }

    #[test]
    fn a_bad_value_is_reported_with_file_line_column_and_hint() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let text =
            "# from the rig\nframe,note,time_s,led\n\n0,\"warm, steady\",0,1\n# gap\n1,,0.04,x\n";
        std::fs::write(&path, text).unwrap();
        let opts = ReadOptions {
            luma: LumaWeights::Bt601,
            video_decode: VideoDecode::Rgb,
            range: VideoRange::Auto,
            colour_transfer: crate::capture::ColourTransfer::Linear,
            fps: None,
            decoder_threads: None,
        };
        let names = ["led".to_string()];
        let e = read(&path, &names, &opts).unwrap_err().to_string();
        for needle in [
            "t.csv",
            "frame 1",
            "line 6",
            "column `led`",
            "`x` is not a finite number",
            "hint:",
        ] {
            assert!(e.contains(needle), "`{needle}` not in: {e}");
        }
        // A quoted field holding a comma is one field: the columns after
        // it stay in place.
        std::fs::write(&path, text.replace(",x", ",7")).unwrap();
        let trace = read(&path, &names, &opts).unwrap();
        assert_eq!(trace.luma, vec![vec![1.0, 7.0]]);
        assert_eq!(trace.time_s, vec![0.0, 0.04]);
    }
}
