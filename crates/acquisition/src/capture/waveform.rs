//! A light source's waveform from a photodiode or an oscilloscope: a CSV
//! file of time (seconds) and intensity (the light's level, 0 for dark),
//! evenly sampled; what `ledflicker light` analyses (docs/light.md).
//!
//! Oscilloscopes export in many layouts, so the reader takes what they
//! share: fields separated by `,`, `;` (then a decimal comma is read too)
//! or tabs, found from the first line; any number of lines before the
//! data (an instrument's preamble), the last of them the header that
//! names the columns; the time and intensity columns by name or by
//! number, the first two by default; other columns ignored. The data
//! begin at the first row whose time field is a number; from there every
//! row must hold a number in both columns.

use std::path::Path;

use super::csv_trace::{Rows, shown, text_of};
use super::{CaptureError, check_interrupt, read_file};

/// Fewest samples of a waveform: two periods of four samples each, the
/// least in which a fundamental can be told from the record's length.
pub const MIN_SAMPLES: usize = 8;

/// Largest distance of a sample's time from its place on the even grid
/// `t0 + i dt`, in sampling intervals. Below a half, each sample is
/// nearer its own slot than a neighbour's; time stamps printed with few
/// digits (an oscilloscope's `%.6g`) stay well within it, and one missing
/// or doubled sample moves every later one a whole interval.
pub const MAX_GRID_DEVIATION: f64 = 0.5;

/// Rows parsed between checks for Ctrl-C.
const ROWS_PER_CHECK: usize = 1 << 14;

/// How the file is laid out, for messages.
const WAVEFORM_HINT: &str = "a waveform is CSV text: optional header lines, then one row per sample with the time in seconds and the light's level";

/// A column of the waveform file, as the user names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// 1-based position.
    Number(usize),
    /// Header name, compared without case and surrounding spaces.
    Name(String),
}

impl Column {
    /// A number (`3`) is a position, anything else a header name.
    pub fn parse(text: &str) -> Column {
        match text.trim().parse::<usize>() {
            Ok(n) => Column::Number(n),
            Err(_) => Column::Name(text.trim().to_string()),
        }
    }
}

/// An evenly sampled light waveform.
#[derive(Debug, Clone, PartialEq)]
pub struct Waveform {
    /// The light's level at each sample (>= 0, finite), in the file's unit.
    pub intensity: Vec<f64>,
    /// Sampling rate, Hz: `(n - 1) / (t_last - t_first)`.
    pub rate_hz: f64,
    /// Time of the first sample, s.
    pub start_s: f64,
    /// The time and intensity columns' names (the header's, or `column N`).
    pub columns: [String; 2],
    /// The unit the time column's header names (`s` when it names none),
    /// its times read in it and converted to seconds.
    pub time_unit: &'static str,
    /// 1-based line of the first sample.
    pub first_line: u64,
}

/// The field separator: `;` or tab when the first line that is not a
/// comment holds one, else `,`.
fn delimiter(text: &str) -> u8 {
    let first = text
        .lines()
        .find(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    if first.contains(';') {
        b';'
    } else if first.contains('\t') && !first.contains(',') {
        b'\t'
    } else {
        b','
    }
}

/// A field as a number; with `;` separating fields, a decimal comma too.
fn number(field: &str, delimiter: u8) -> Option<f64> {
    let field = field.trim();
    let parsed = match field.parse::<f64>() {
        Err(_) if delimiter == b';' && !field.contains('.') => field.replace(',', ".").parse(),
        other => other,
    };
    parsed.ok()
}

/// Column `c` of `header` (its fields, trimmed), 0-based.
fn locate(c: &Column, header: &[String], path: &Path, role: &str) -> Result<usize, CaptureError> {
    let invalid = |message: String, hint: String| CaptureError::Invalid {
        path: path.to_path_buf(),
        message,
        hint,
    };
    match c {
        Column::Number(0) => Err(invalid(
            format!("the {role} column 0 does not exist"),
            "columns are numbered from 1".to_string(),
        )),
        Column::Number(n) => Ok(n - 1),
        Column::Name(name) => header
            .iter()
            .position(|h| h.eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                let has = if header.is_empty() {
                    "the file has no header line; give the column's number (1, 2, ...)".to_string()
                } else {
                    format!("the header has: {}", shown(&header.join(", ")))
                };
                invalid(format!("no {role} column named {}", shown(name)), has)
            }),
    }
}

/// The time units a header may name, with their length in seconds.
const TIME_UNITS: [(&str, f64); 10] = [
    ("s", 1.0),
    ("sec", 1.0),
    ("ms", 1e-3),
    ("msec", 1e-3),
    ("us", 1e-6),
    ("µs", 1e-6),
    ("μs", 1e-6),
    ("usec", 1e-6),
    ("ns", 1e-9),
    ("nsec", 1e-9),
];

/// The unit a time column's header names, and its length in seconds:
/// `Time (ms)`, `t [us]`, `time_ms`, `Time/s`. `None` when it names none
/// (the time is then in seconds); an error for a unit in brackets that is
/// not a time unit, which would otherwise be read as seconds.
fn time_unit(header: &str) -> Result<Option<(&'static str, f64)>, String> {
    let h = header.trim();
    let bracketed = h
        .rfind(['(', '['])
        .filter(|&open| h.ends_with([')', ']']) && open + 1 < h.len())
        .map(|open| h[open + 1..h.len() - 1].trim());
    let suffix = h
        .rsplit(['_', '/', ' '])
        .next()
        .filter(|t| t.len() < h.len());
    let Some(named) = bracketed.or(suffix) else {
        return Ok(None);
    };
    match TIME_UNITS
        .iter()
        .find(|(u, _)| named.eq_ignore_ascii_case(u))
    {
        Some(&(unit, seconds)) => Ok(Some((
            match unit {
                "sec" => "s",
                "msec" => "ms",
                "usec" => "us",
                "nsec" => "ns",
                _ => unit,
            },
            seconds,
        ))),
        None if bracketed.is_some() => Err(named.to_string()),
        None => Ok(None),
    }
}

/// A scope's offset and noise put a dark level a little either side of
/// 0; a reading far below it is a wrong column or an offset not taken off.
fn check_dark(
    values: &[f64],
    row: &dyn Fn(usize) -> String,
    path: &Path,
) -> Result<(), CaptureError> {
    let top = values.iter().cloned().fold(0.0f64, f64::max);
    if let Some((i, &low)) = values.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))
        && low < -NEGATIVE_SHARE * top
    {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "{}: the intensity {low} is below 0 by more than {:.0} % of the largest ({top})",
                row(i),
                100.0 * NEGATIVE_SHARE
            ),
            hint: "give the light's level, 0 for dark: the detector's dark reading with --dark (noise a little below 0 is fine)".to_string(),
        });
    }
    Ok(())
}

/// [`time_unit`] of the time column's header, if it has one, refused
/// with a hint when it names a unit that is not a time.
fn header_unit(
    name: Option<&String>,
    path: &Path,
) -> Result<Option<(&'static str, f64)>, CaptureError> {
    let Some(name) = name else { return Ok(None) };
    time_unit(name).map_err(|named| CaptureError::Invalid {
        path: path.to_path_buf(),
        message: format!(
            "the time column {} names the unit {}, which is not one ledflicker reads",
            shown(name),
            shown(&named)
        ),
        hint: "name the time column's unit as s, ms, us or ns (e.g. `Time (ms)`), or convert the time to seconds".to_string(),
    })
}

/// How far below 0 a reading may be, as a share of the largest: a scope's
/// offset and noise around the dark level. `light` reads the band-limited
/// levels below 0 as 0.
pub const NEGATIVE_SHARE: f64 = 0.10;

/// Reads the waveform of `path`, the time in column `time` and the light's
/// level in column `intensity`.
pub fn read_waveform(
    path: &Path,
    time: &Column,
    intensity: &Column,
    dark: f64,
) -> Result<Waveform, CaptureError> {
    let text = text_of(path, read_file(path)?)?;
    let delim = delimiter(&text);
    let mut rows = Rows::with_delimiter(&text, delim);
    let mut header: Vec<String> = Vec::new();
    let mut cols: Option<(usize, usize)> = None;
    let mut times = Vec::new();
    let mut values = Vec::new();
    let mut lines = Vec::new();
    let mut unit: Option<(&'static str, f64)> = None;
    while let Some((line, fields)) = rows.next(path, WAVEFORM_HINT)? {
        if values.len().is_multiple_of(ROWS_PER_CHECK) {
            check_interrupt(path)?;
        }
        let (ti, xi) = match cols {
            Some(c) => c,
            None => {
                // The time column by number, or by name in the line before.
                let at = match time {
                    Column::Number(n) => n.checked_sub(1),
                    Column::Name(name) => header.iter().position(|h| h.eq_ignore_ascii_case(name)),
                };
                if at
                    .and_then(|i| fields.get(i))
                    .and_then(|f| number(f, delim))
                    .is_none()
                {
                    // Not data yet: an instrument's preamble, or the header.
                    header = fields.iter().map(|f| f.trim().to_string()).collect();
                    continue;
                }
                let c = (
                    locate(time, &header, path, "time")?,
                    locate(intensity, &header, path, "intensity")?,
                );
                unit = header_unit(header.get(c.0), path)?;
                cols = Some(c);
                c
            }
        };
        let field = |i: usize, what: &str| -> Result<f64, CaptureError> {
            let raw = fields.get(i).map_or("", str::trim);
            number(raw, delim)
                .filter(|v| v.is_finite())
                .ok_or_else(|| CaptureError::Invalid {
                    path: path.to_path_buf(),
                    message: format!("line {line}: the {what} {} is not a finite number", shown(raw)),
                    hint: format!("every row after the header needs a number in the time column ({}) and the intensity column ({})", ti + 1, xi + 1),
                })
        };
        let t = field(ti, "time")? * unit.map_or(1.0, |u| u.1);
        let x = field(xi, "intensity")?;
        if let (Some(&prev), Some(&prev_line)) = (times.last(), lines.last())
            && t <= prev
        {
            return Err(CaptureError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "line {line}: the time {t} s is not after {prev} s of line {prev_line}"
                ),
                hint: "the rows must be in time order, one per sample, without repeats".to_string(),
            });
        }
        times.push(t);
        values.push(x - dark);
        lines.push(line);
    }
    let Some((ti, xi)) = cols else {
        locate(time, &header, path, "time")?;
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: "no data: no row has a number in the time column".to_string(),
            hint: WAVEFORM_HINT.to_string(),
        });
    };
    let line = |i: usize| format!("line {}", lines[i]);
    check_dark(&values, &line, path)?;
    if values.len() < MIN_SAMPLES {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "{} samples; the analysis needs at least {MIN_SAMPLES}",
                values.len()
            ),
            hint: "record several periods of the light, each of several samples".to_string(),
        });
    }
    let rate_hz = check_even(&times, &line, path)?;
    let name = |i: usize| {
        header
            .get(i)
            .filter(|h| !h.is_empty())
            .cloned()
            .unwrap_or_else(|| format!("column {}", i + 1))
    };
    Ok(Waveform {
        intensity: values,
        rate_hz,
        start_s: times[0],
        columns: [name(ti), name(xi)],
        time_unit: unit.map_or("s", |u| u.0),
        first_line: lines[0],
    })
}

/// The sampling rate of a waveform given as samples rather than a file
/// (the Python package's `light(t, x)`), its `levels` checked as
/// [`read_waveform`] checks a file's, dark already subtracted: at least
/// [`MIN_SAMPLES`], times increasing on an even grid, no level far below
/// dark. `name` stands for the file in messages, which number the
/// samples from 1.
pub fn sample_rate(times: &[f64], levels: &[f64], name: &Path) -> Result<f64, CaptureError> {
    let invalid = |message: String, hint: &str| CaptureError::Invalid {
        path: name.to_path_buf(),
        message,
        hint: hint.to_string(),
    };
    if let Some(i) = (1..times.len()).find(|&i| times[i] <= times[i - 1]) {
        return Err(invalid(
            format!(
                "sample {}: the time {} s is not after {} s of sample {i}",
                i + 1,
                times[i],
                times[i - 1]
            ),
            "the times must increase, one per sample, without repeats",
        ));
    }
    let sample = |i: usize| format!("sample {}", i + 1);
    check_dark(levels, &sample, name)?;
    if levels.len() < MIN_SAMPLES {
        return Err(invalid(
            format!(
                "{} samples; the analysis needs at least {MIN_SAMPLES}",
                levels.len()
            ),
            "record several periods of the light, each of several samples",
        ));
    }
    check_even(times, &sample, name)
}

/// The sampling rate of the increasing `times`, or an error naming (by
/// `row`) the first row whose time is off the even grid by more than
/// [`MAX_GRID_DEVIATION`] intervals.
fn check_even(
    times: &[f64],
    row: &dyn Fn(usize) -> String,
    path: &Path,
) -> Result<f64, CaptureError> {
    let n = times.len();
    let (t0, span) = (times[0], times[n - 1] - times[0]);
    let dt = span / (n - 1) as f64;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!("the times span {span} s, too little for {n} samples"),
            hint: "the time column holds seconds".to_string(),
        });
    }
    for (i, &t) in times.iter().enumerate() {
        let off = (t - (t0 + i as f64 * dt)) / dt;
        if off.abs() > MAX_GRID_DEVIATION {
            return Err(CaptureError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "{}: the time {t} s is {:.2} sampling intervals off the even grid of {} samples every {dt:e} s",
                    row(i),
                    off.abs(),
                    n
                ),
                hint: "the samples must be evenly spaced (a gap or a change of rate is not): export one record at one rate".to_string(),
            });
        }
    }
    Ok(1.0 / dt)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, time: &str, intensity: &str) -> Result<Waveform, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.csv");
        std::fs::write(&path, text).unwrap();
        read_waveform(&path, &Column::parse(time), &Column::parse(intensity), 0.0)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn the_time_header_names_its_unit() {
        for (header, unit) in [
            ("Time (ms)", Some(("ms", 1e-3))),
            ("t [us]", Some(("us", 1e-6))),
            ("TIME(µs)", Some(("µs", 1e-6))),
            ("time_ns", Some(("ns", 1e-9))),
            ("Time/s", Some(("s", 1.0))),
            ("Time (sec)", Some(("s", 1.0))),
            ("Time (msec)", Some(("ms", 1e-3))),
            ("t [usec]", Some(("us", 1e-6))),
            ("Time", None),
            ("timestamps", None),
            ("time_since_start", None),
        ] {
            assert_eq!(time_unit(header), Ok(unit), "{header}");
        }
        assert_eq!(time_unit("Time (samples)"), Err("samples".to_string()));
    }

    #[test]
    fn times_in_milliseconds_are_read_as_milliseconds() {
        let ms: String = (0..16)
            .map(|i| format!("{:.3},{}\n", i as f64 * 0.1, i % 2))
            .collect();
        let w = read(&format!("Time (ms),V\n{ms}"), "1", "2").unwrap();
        assert_eq!(w.time_unit, "ms");
        assert!((w.rate_hz - 10_000.0).abs() < 1e-6, "{}", w.rate_hz);
        assert!((w.start_s - 0.0).abs() < 1e-15);
        let e = read(&format!("Time (samples),V\n{ms}"), "1", "2").unwrap_err();
        assert!(
            e.contains("not one ledflicker reads") && e.contains("samples"),
            "{e}"
        );
    }

    fn rows(n: usize, sep: &str) -> String {
        (0..n)
            .map(|i| format!("{:.4}{sep}{}\n", i as f64 * 1e-4, i % 2))
            .collect()
    }

    #[test]
    fn a_header_and_a_preamble_precede_the_data() {
        let text = format!("Model,DS1054\nx-axis,1\ntime_s,light\n{}", rows(10, ","));
        let w = read(&text, "1", "2").unwrap();
        assert_eq!(w.intensity.len(), 10);
        assert!((w.rate_hz - 1e4).abs() < 1e-6, "{}", w.rate_hz);
        assert_eq!(w.columns, ["time_s".to_string(), "light".to_string()]);
        assert_eq!(w.first_line, 4);
        assert_eq!(read(&text, "TIME_S", "light").unwrap(), w);
    }

    #[test]
    fn semicolons_with_decimal_commas_and_extra_columns_are_read() {
        let text: String = std::iter::once("t;ch1;ch2\n".to_string())
            .chain((0..10).map(|i| format!("{};0,5;{},25\n", i as f64 * 1e-3, i)))
            .collect();
        let w = read(&text.replace('.', ","), "t", "ch2").unwrap();
        assert!((w.intensity[3] - 3.25).abs() < 1e-12);
        assert!((w.rate_hz - 1e3).abs() < 1e-6);
        assert_eq!(read(&text, "1", "2").unwrap().intensity, vec![0.5; 10]);
    }

    #[test]
    fn bad_rows_are_named_by_line() {
        let good = format!("time,light\n{}", rows(10, ","));
        let cases = [
            (
                good.replace("\n0.0003,1", "\n0.0003,x"),
                "line 5: the intensity `x`",
            ),
            (
                good.replace("\n0.0003,1", "\n0.0003,NaN"),
                "line 5: the intensity `NaN`",
            ),
            (
                good.replace("\n0.0003,1", "\n0.0003,-0.2"),
                "line 5: the intensity -0.2 is below 0 by more than 10 %",
            ),
            (
                good.replace("\n0.0003,", "\n0.0001,"),
                "line 5: the time 0.0001 s is not after 0.0002 s of line 4",
            ),
            (
                good.replace("\n0.0003,", "\n0.00024,"),
                "line 5: the time 0.00024 s is 0.60 sampling intervals off",
            ),
            (
                format!("time,light\n{}", rows(7, ",")),
                "7 samples; the analysis needs at least 8",
            ),
            ("time,light\n".to_string(), "no data"),
        ];
        for (text, needle) in cases {
            let e = read(&text, "1", "2").unwrap_err();
            assert!(
                e.contains(needle) && e.contains("w.csv") && e.contains("hint"),
                "`{needle}` not in: {e}"
            );
        }
        // 0.4 intervals off the grid: a coarsely printed time, accepted.
        assert!(read(&good.replace("\n0.0003,", "\n0.00026,"), "1", "2").is_ok());
        let e = read(&good, "1", "volts").unwrap_err();
        assert!(
            e.contains("no intensity column named `volts`") && e.contains("`time, light`"),
            "{e}"
        );
        assert!(read(&good, "0", "2").unwrap_err().contains("column 0"));
    }

    #[test]
    fn coarsely_printed_times_still_lie_on_the_grid() {
        // 20 s at 4 kHz printed with 6 significant digits: steps of 0.0002
        // and 0.0003 s for a 0.00025 s interval.
        let text: String = (0..80_000)
            .map(|i| {
                format!(
                    "{},1\n",
                    format!("{:.5e}", i as f64 / 4000.0).parse::<f64>().unwrap()
                )
            })
            .collect();
        let w = read(&text, "1", "2").unwrap();
        // The last time, 19.9998 for 19.99975, sets the rate within 3e-6.
        assert!((w.rate_hz - 4000.0).abs() < 0.02, "{}", w.rate_hz);
    }
}
