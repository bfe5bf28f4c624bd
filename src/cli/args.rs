//! Arguments that several subcommands share: the LED's PWM drive and the
//! ideal camera (`simulate`, `render`), the report flags (`plan`,
//! `merge`) and the report date (`plan`, `merge`, `sign`).

use clap::{Args, ValueEnum};

use crate::error::UsageError;
use crate::physics::{Shutter, ShutterModel};

/// `--detail` of `plan` and `merge`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum DetailArg {
    /// No case pages.
    Summary,
    /// A page for each failing case; not judged cases are one table row
    /// each.
    Standard,
    /// A page for every case.
    Full,
}

impl From<DetailArg> for crate::model::Detail {
    fn from(d: DetailArg) -> Self {
        match d {
            DetailArg::Summary => Self::Summary,
            DetailArg::Standard => Self::Standard,
            DetailArg::Full => Self::Full,
        }
    }
}

/// The report flags `plan` and `merge` share: where the report goes,
/// its date, what it shows and the work it may take. (The recording
/// flags, `campaign::RecordArgs`, sit beside it: the recording module
/// reads the report date from here.)
#[derive(Args, Debug)]
pub(super) struct ReportArgs {
    /// Output directory [default: reports/<plan-id>/].
    #[arg(long)]
    pub(super) out: Option<std::path::PathBuf>,
    /// Report date, YYYY-MM-DD [default: $SOURCE_DATE_EPOCH, else today].
    #[arg(long)]
    pub(super) date: Option<String>,
    /// Replace a signed report in the output directory.
    #[arg(long)]
    pub(super) force: bool,
    /// Print no summary table and no progress.
    #[arg(long, short)]
    pub(super) quiet: bool,
    /// List every case in the summary table; without it a run of more
    /// than 50 cases lists its failing cases only (at most 50).
    #[arg(long)]
    pub(super) all_cases: bool,
    /// How much of each case the report shows: `summary` (no case pages),
    /// `standard` (a page for each failing case; not judged cases one row
    /// each in a table, passing cases one line each in the appendix) or
    /// `full` (a page for every case).
    #[arg(long, value_enum, default_value_t = DetailArg::Standard)]
    pub(super) detail: DetailArg,
    #[command(flatten)]
    pub(super) limits: LimitArgs,
}

impl ReportArgs {
    /// The limits of `--max-memory` and `--max-report`, for the report
    /// `--detail` asks for.
    pub(super) fn limits(&self) -> crate::plan::ResourceLimits {
        self.limits.limits(matches!(self.detail, DetailArg::Full))
    }
}

/// `--max-memory` and `--max-report` of `validate`, `plan` and `merge`: the limits
/// a plan's work estimate must fit.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct LimitArgs {
    /// Largest estimated peak memory to accept, e.g. `4GB` [default: 1 GB].
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    max_memory: Option<f64>,
    /// Largest estimated report directory to accept, e.g. `20GB` [default: 2 GB].
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    max_report: Option<f64>,
}

impl LimitArgs {
    /// The limits, the defaults where a flag is not given, for a report
    /// that gives `every_case` a page or not.
    pub fn limits(self, every_case: bool) -> crate::plan::ResourceLimits {
        let d = crate::plan::ResourceLimits::default();
        crate::plan::ResourceLimits {
            memory_bytes: self.max_memory.unwrap_or(d.memory_bytes),
            output_bytes: self.max_report.unwrap_or(d.output_bytes),
            scratch_free_bytes: free_bytes(&std::env::temp_dir()).unwrap_or(f64::INFINITY),
            every_case,
        }
    }
}

/// Bytes an unprivileged process may still write on the filesystem of
/// `dir`; `None` when it cannot be read.
fn free_bytes(dir: &std::path::Path) -> Option<f64> {
    use std::os::unix::ffi::OsStrExt;
    let path = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `path` is NUL-terminated and `st` is written by statvfs
    // before it is read, which happens only when the call succeeded.
    let st = unsafe {
        if libc::statvfs(path.as_ptr(), st.as_mut_ptr()) != 0 {
            return None;
        }
        st.assume_init()
    };
    Some(st.f_bavail as f64 * st.f_frsize as f64)
}

fn parse_size(text: &str) -> Result<f64, String> {
    crate::plan::bounds::parse_bytes(text)
}

/// `--shutter`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ShutterArg {
    /// Every row exposed at once.
    Global,
    /// Row `r` starts `r` line times after row 0.
    Rolling,
}

/// `--duty`: a share of the period in (0, 1]; a percentage (1 to 100) is
/// refused with the share it likely meant, never read as a duty over 1.
pub(super) fn parse_duty(text: &str) -> Result<f64, String> {
    let duty: f64 = text.trim().parse().map_err(|_| {
        format!(
            "`{text}` is not a number; give the duty as a share of the period, e.g. 0.2 for 20 %"
        )
    })?;
    if duty.is_finite() && duty > 0.0 && duty <= 1.0 {
        Ok(duty)
    } else if duty > 1.0 && duty <= 100.0 {
        Err(format!(
            "the duty is a share of the period in (0, 1], not a percentage: for {duty} % give --duty {}",
            duty / 100.0
        ))
    } else {
        Err(format!(
            "the duty must be in (0, 1], e.g. 0.2 for 20 %; got {text}"
        ))
    }
}

/// The LED's PWM drive.
#[derive(Args, Debug)]
pub struct PwmArgs {
    /// PWM frequency in Hz (> 0).
    #[arg(long)]
    pub frequency_hz: f64,
    /// Duty cycle in (0, 1]: the share of each period the LED is ON
    /// (0.2 for 20 %).
    #[arg(long, value_parser = parse_duty)]
    pub duty: f64,
    /// Time of the first PWM rising edge after the start of frame 0's
    /// exposure (row 0), in milliseconds.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub pwm_delay_ms: f64,
}

/// The ideal camera: exposure, frame rate and shutter.
#[derive(Args, Debug)]
pub struct CameraArgs {
    /// Exposure time in milliseconds (> 0).
    #[arg(long)]
    pub exposure_ms: f64,
    /// Frame rate in frames per second (> 0).
    #[arg(long)]
    pub fps: f64,
    /// Shutter type.
    #[arg(long, value_enum, default_value_t = ShutterArg::Global)]
    pub shutter: ShutterArg,
    /// Rolling-shutter line time in microseconds (>= 0).
    #[arg(long, default_value_t = 0.0)]
    pub line_time_us: f64,
}

/// Physical bounds of the PWM drive and camera flags (docs/plan-format.md,
/// "Limits"): beyond them the arithmetic loses meaning or overflows. The
/// first flag out of bounds, with its bound.
pub fn check_drive_and_camera(p: &PwmArgs, c: &CameraArgs) -> Result<(), UsageError> {
    use crate::plan::bounds::{MAX_FPS, MAX_FREQUENCY_HZ, MIN_EXPOSURE_S};
    let problems = [
        (
            p.frequency_hz > MAX_FREQUENCY_HZ,
            format!("--frequency-hz must be at most {MAX_FREQUENCY_HZ:.0}"),
        ),
        (
            c.fps > MAX_FPS,
            format!("--fps must be at most {MAX_FPS:.0}"),
        ),
        (c.fps < 0.01, "--fps must be at least 0.01".to_string()),
        (
            c.exposure_ms * 1e-3 < MIN_EXPOSURE_S,
            "--exposure-ms must be at least 0.001".to_string(),
        ),
        (
            c.exposure_ms > 1e4,
            "--exposure-ms must be at most 10000".to_string(),
        ),
        (
            p.pwm_delay_ms.is_nan() || p.pwm_delay_ms.abs() > 1e6,
            "--pwm-delay-ms must be within +-1e6".to_string(),
        ),
        (
            c.line_time_us > 1e6,
            "--line-time-us must be at most 1e6".to_string(),
        ),
    ];
    match problems.into_iter().find(|(bad, _)| *bad) {
        Some((_, m)) => Err(UsageError(m)),
        None => Ok(()),
    }
}

impl CameraArgs {
    /// The shutter these flags describe (unchecked: callers check ranges).
    pub fn shutter(&self) -> Shutter {
        Shutter {
            model: match self.shutter {
                ShutterArg::Global => ShutterModel::Global,
                ShutterArg::Rolling => ShutterModel::Rolling {
                    line_time_s: self.line_time_us * 1e-6,
                },
            },
            exposure_s: self.exposure_ms * 1e-3,
            fps: self.fps,
        }
    }
}

/// The report date: `--date`, else $SOURCE_DATE_EPOCH, else today.
pub fn report_date(arg: Option<&str>) -> Result<String, UsageError> {
    if let Some(d) = arg {
        if !crate::util::is_calendar_date(d) {
            return Err(UsageError(format!(
                "--date `{d}` is not a date YYYY-MM-DD (e.g. 2026-11-23)"
            )));
        }
        return Ok(d.to_string());
    }
    if let Ok(s) = std::env::var("SOURCE_DATE_EPOCH") {
        let secs: i64 = s
            .trim()
            .parse()
            .ok()
            .filter(|v| (0..=crate::util::MAX_UNIX_S).contains(v))
            .ok_or_else(|| {
                UsageError(format!(
                    "SOURCE_DATE_EPOCH `{s}` is not a whole number of seconds between 0 and {} (years 1970 to 9999)\n    hint: unset it, or set it to e.g. $(date +%s)",
                    crate::util::MAX_UNIX_S
                ))
            })?;
        return Ok(crate::util::utc_date(secs));
    }
    Ok(crate::util::utc_date(now_unix_s() as i64))
}

pub(super) fn now_unix_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Signing time, the time the signatures carry: $SOURCE_DATE_EPOCH (for
/// reproducible output), else now. `--date` sets only the date the report
/// shows: the signing time is when the signature was made, which is what
/// `verify` checks the certificate's validity at.
pub(super) fn signing_time() -> Result<u64, UsageError> {
    if let Ok(s) = std::env::var("SOURCE_DATE_EPOCH") {
        return s.trim().parse().map_err(|_| {
            UsageError(format!(
                "SOURCE_DATE_EPOCH `{s}` is not an integer number of seconds"
            ))
        });
    }
    Ok(now_unix_s())
}

/// What `plan` asks of the sign-off: `--sign-key`, `--sign-cert` and
/// `--signer`.
pub struct SignOptions<'a> {
    /// The private key.
    pub key: Option<&'a std::path::Path>,
    /// Its certificate.
    pub cert: Option<&'a std::path::Path>,
    /// Who signs, "Name, Role".
    pub signer: Option<&'a str>,
}
