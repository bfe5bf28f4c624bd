//! `ledflicker light WAVEFORM.csv`: a photodiode's or an oscilloscope's
//! record of a light source, analysed as the light itself: IEEE 1789
//! risk, fundamental, Percent Flicker, Flicker Index, SVM and PstLM
//! (docs/light.md). A table, or with `--json` the versioned object of
//! [`crate::analysis::light::FORMAT`].

use std::path::PathBuf;

use clap::Args;

use super::output::outln;
use super::{ExitCode, Failure};
use crate::analysis::light::{self, Figure, LightFigures};
use crate::calibrate::frames::FrameError;
use crate::capture::{Column, read_waveform};

#[derive(Args, Debug)]
pub(super) struct LightArgs {
    /// CSV file: optional header lines, then one row per sample with the
    /// time and the light's level (0 for dark), evenly sampled; fields
    /// separated by `,`, `;` or tabs. The time is in seconds, or in the
    /// unit its header names: `Time (ms)`, `t [us]`, `time_ns`.
    waveform: PathBuf,
    /// The time column: its header name, or its number from 1.
    #[arg(long, default_value = "1", value_name = "NAME|N")]
    time_column: String,
    /// The intensity column: its header name, or its number from 1.
    #[arg(long, default_value = "2", value_name = "NAME|N")]
    intensity_column: String,
    /// Band limit of Percent Flicker and the Flicker Index, Hz (a Gaussian
    /// low-pass, -3 dB there), or `none` for the raw samples. The SVM,
    /// PstLM and the fundamental read the raw samples.
    #[arg(long, default_value = "10000", value_name = "HZ|none", value_parser = parse_bandwidth)]
    bandwidth: Bandwidth,
    /// The detector's dark reading, in the file's unit, subtracted from
    /// every sample (a scope's offset); 0 unless given.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "LEVEL",
        allow_hyphen_values = true
    )]
    dark: f64,
    /// Print one JSON object (`format` "ledflicker.light/2") instead of the table.
    #[arg(long)]
    json: bool,
}

/// `--bandwidth`: a frequency, or none.
#[derive(Debug, Clone, Copy)]
struct Bandwidth(Option<f64>);

fn parse_bandwidth(text: &str) -> Result<Bandwidth, String> {
    if text.eq_ignore_ascii_case("none") {
        return Ok(Bandwidth(None));
    }
    match text.trim().parse::<f64>() {
        Ok(hz) if hz.is_finite() && hz > 0.0 => Ok(Bandwidth(Some(hz))),
        _ => Err(format!(
            "`{text}` is not a band limit; give a frequency in Hz above 0 (e.g. 10000 for 10 kHz), or `none` for the raw samples"
        )),
    }
}

/// The JSON form: the format, the file and its columns, then the figures.
#[derive(serde::Serialize)]
struct Report<'a> {
    format: &'static str,
    file: String,
    time_column: &'a str,
    intensity_column: &'a str,
    #[serde(flatten)]
    figures: &'a LightFigures,
}

pub(super) fn light(args: LightArgs) -> Result<ExitCode, Failure> {
    if !args.dark.is_finite() {
        return Err(crate::error::UsageError(format!(
            "--dark {} is not a level\n    hint: give the detector's dark reading in the file's unit, e.g. --dark -0.008",
            args.dark
        ))
        .into());
    }
    let wave = read_waveform(
        &args.waveform,
        &Column::parse(&args.time_column),
        &Column::parse(&args.intensity_column),
        args.dark,
    )
    .map_err(|e| Failure::Frames(FrameError::Capture(e)))?;
    if wave.intensity.iter().sum::<f64>() <= 0.0 {
        return Err(crate::error::UsageError(format!(
            "waveform `{}`: the intensities average 0 or less, no light to analyse\n    hint: the intensity column ({}) holds the light's level",
            args.waveform.display(),
            wave.columns[1]
        ))
        .into());
    }
    let options = light::LightOptions {
        bandwidth_hz: args.bandwidth.0,
    };
    let figures = light::analyse(&wave.intensity, wave.rate_hz, &options);
    if args.json {
        let report = Report {
            format: light::FORMAT,
            file: args.waveform.display().to_string(),
            time_column: &wave.columns[0],
            intensity_column: &wave.columns[1],
            figures: &figures,
        };
        outln!("{}", serde_json::to_string_pretty(&report)?)?;
        return Ok(ExitCode::Pass);
    }
    for line in table(
        &args.waveform.display().to_string(),
        &wave.columns,
        wave.time_unit,
        &figures,
    ) {
        outln!("{line}")?;
    }
    Ok(ExitCode::Pass)
}

/// A figure's value by `show`, or `not computed: ` and its reason, the
/// reason's hint on a line of its own.
fn shown(f: &Figure, show: impl Fn(f64) -> String) -> String {
    match (f.value, &f.reason) {
        (Some(v), _) => show(v),
        (None, reason) => format!(
            "not computed: {}",
            reason
                .as_deref()
                .unwrap_or("undefined")
                .replace("\n    hint:", &format!("\n{:20}hint:", ""))
        ),
    }
}

/// The lines of the table.
fn table(file: &str, columns: &[String; 2], time_unit: &str, f: &LightFigures) -> Vec<String> {
    let row = |name: &str, value: String| format!("{name:<20}{value}");
    let rate = if f.sample_rate_hz >= 1000.0 {
        format!("{:.4} kHz", f.sample_rate_hz / 1000.0)
    } else {
        format!("{:.4} Hz", f.sample_rate_hz)
    };
    let analysed = match f.analysed_periods {
        Some(p) => format!(
            " ({p} whole periods, {} samples, analysed)",
            f.analysed_samples
        ),
        None => String::new(),
    };
    let i = &f.ieee1789;
    let limit = |l: Option<f64>| l.map_or("none".to_string(), |v| format!("{v:.2} %"));
    let ieee = match (i.region, &i.reason) {
        (Some(r), _) => {
            let name = serde_json::to_value(r)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            match f.fundamental_hz.value {
                Some(hz) => format!(
                    "{name} (at {hz:.2} Hz: low-risk limit {}, NOEL limit {})",
                    limit(i.low_risk_max_percent),
                    limit(i.noel_max_percent)
                ),
                None => format!("{name} (no modulation)"),
            }
        }
        (None, reason) => format!("not computed: {}", reason.as_deref().unwrap_or("undefined")),
    };
    let pst = Figure {
        value: f.pst_lm.value,
        reason: f.pst_lm.reason.clone(),
    };
    vec![
        format!(
            "light source `{file}`: columns `{}` ({time_unit}) and `{}`; {} samples at {rate}, {:.4} s",
            columns[0], columns[1], f.samples, f.duration_s
        ),
        row(
            "level",
            format!("mean {:.6}, min {:.6}, max {:.6}", f.mean, f.min, f.max),
        ),
        row(
            "fundamental",
            shown(&f.fundamental_hz, |v| {
                let within = f
                    .fundamental_resolution_hz
                    .map_or(String::new(), |r| format!(" +/- {r:.2e}"));
                format!("{v:.3}{within} Hz{analysed}")
            }),
        ),
        row("band limit", band(f)),
        row(
            "percent flicker",
            if f.bandwidth_hz.is_some() && (f.percent_flicker_raw - f.percent_flicker).abs() > 0.005
            {
                format!(
                    "{:.2} % (IEEE 1789 modulation; {:.2} % on the raw samples)",
                    f.percent_flicker, f.percent_flicker_raw
                )
            } else {
                format!("{:.2} % (IEEE 1789 modulation)", f.percent_flicker)
            },
        ),
        row("flicker index", format!("{:.4} (IES)", f.flicker_index)),
        row("IEEE 1789-2015", ieee),
        row(
            "SVM",
            shown(&f.svm, |v| {
                let how = match f.svm_components {
                    Some("spectral-peaks") => {
                        "; from the spectrum's peaks: the record holds components of another period"
                    }
                    _ => "",
                };
                format!("{v:.3} (CIE TN 006:2016; 1 = visible to the average observer{how})")
            }),
        ),
        row(
            "PstLM",
            shown(&pst, |v| {
                format!(
                    "{v:.3} (IEC TR 61547-1; 1 = the threshold of irritability; largest P_inst {:.3})",
                    f.pst_lm.p_inst_max.unwrap_or(0.0)
                )
            }),
        ),
    ]
}

/// The band limit line: what Percent Flicker and the Flicker Index read.
fn band(f: &LightFigures) -> String {
    let limit = match f.bandwidth_hz {
        Some(b) => format!(
            "{} (Gaussian, zero phase) for percent flicker and flicker index",
            hz(b)
        ),
        None => format!(
            "none: the raw samples ({} of sampling) for percent flicker and flicker index",
            hz(f.sample_rate_hz)
        ),
    };
    if f.read_as_dark == 0 {
        return limit;
    }
    format!(
        "{limit}; {} analysed samples below 0 (offset and noise around dark) read as 0 (a dark offset? --dark gives it)",
        f.read_as_dark
    )
}

fn hz(v: f64) -> String {
    if v >= 1000.0 {
        format!("{:.4} kHz", v / 1000.0)
    } else {
        format!("{v:.4} Hz")
    }
}
