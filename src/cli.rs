//! Command-line interface: `plan`, `merge`, `validate`, `simulate`, `advise`,
//! `bench`, `linetime`, `render`, `bands`, `calibrate`, `keygen`, `sign` and
//! `verify`. `linetime`, `bands` and `calibrate` live in
//! [`crate::calibrate::command`].
//!
//! Exit codes (stable; CI scripts depend on them):
//!
//! | code | meaning |
//! |---|---|
//! | 0 | every judged case passed and at least one was judged (informational cases do not count); `plan --shard`: the shard ran and wrote its directory (verdicts are the merge's); `verify`: every hash and signature matched and every signer is trusted (`--trust`) |
//! | 1 | the run completed and some case failed, or `--golden` found drift beyond tolerance; `verify`: a hash, signature or input mismatch, an untrusted signer, or no signature |
//! | 2 | invalid plan, input or usage, including a missing file, a bad key or a signed report in the way; `merge`: shards that do not fit together (missing, duplicated, of another plan, tool or seed, damaged) |
//! | 3 | internal or backend error |
//! | 4 | per command: `plan`, `merge`: the run completed but no case was judged (the summary says NOT JUDGED); `verify` without `--trust`: every hash and signature matched, but the signers' identity was not checked; `linetime`, `bands`, `calibrate`: no confident estimate, the reason (flat rows, no periodic banding, fewer than 3 bands, column strips disagree, too uncertain) is printed |
//! | 130, 143 | `plan` stopped by SIGINT (Ctrl-C) or SIGTERM (128 + signal); the old report is left as it was |

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::backend::Backend;
use crate::backend::captured::Captured;
use crate::backend::command::CommandRig;
use crate::backend::sim::Simulator;
use crate::metrics::Verdict;
use crate::physics::{PwmDrive, Shutter, ShutterModel};
use crate::plan::{self, PlanError};
use crate::report::{self, WriteOptions};
use crate::runner::{self, RunEvent};

/// Every case passed.
pub const EXIT_PASS: i32 = 0;
/// Some case failed.
pub const EXIT_FAIL: i32 = 1;
/// Invalid plan, input or usage.
pub const EXIT_INVALID: i32 = 2;
/// Internal or backend error.
pub const EXIT_INTERNAL: i32 = 3;
/// `plan`: the run completed but no case was judged (every case informational).
pub const EXIT_NOT_JUDGED: i32 = 4;
/// `verify` without `--trust`: intact, but nobody vouched for the signers.
/// Same number as [`EXIT_NOT_JUDGED`]: each command documents its own use.
pub const EXIT_IDENTITY_UNCHECKED: i32 = 4;
/// `linetime`, `bands`, `calibrate`: the input gives no confident estimate.
/// Same number as [`EXIT_NOT_JUDGED`]: each command documents its own use.
pub const EXIT_NO_CONFIDENCE: i32 = 4;

#[derive(Parser, Debug)]
#[command(
    name = "ledflicker",
    version,
    about = "LED flicker conformance tests for automotive cameras"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a test plan and write results.json, traces, charts, report.html,
    /// report.pdf, junit.xml and summary.csv.
    Plan(PlanArgs),
    /// Check the shard directories of a sharded run (`plan --shard`) and
    /// write the whole plan's report, as one `plan` run would have.
    Merge(crate::shard::command::MergeArgs),
    /// Check a test plan without running it.
    Validate {
        /// Plan file, or a plan name from test-plans/ (e.g. `daylight`).
        plan: String,
    },
    /// Probe the ideal camera for one condition; prints a CSV trace, or with
    /// --summary one JSON object of metrics.
    Simulate(SimulateArgs),
    /// Shortest exposure that never loses a PWM LED over a frequency and a
    /// duty range, the flicker it leaves and its motion-blur cost.
    Advise(AdviseArgs),
    /// Speed against error of the integration methods, whole-plan times, and
    /// the time of the analytic fine map (worst-phase FDI and Percent Flicker
    /// over 50 Hz..2 kHz x 1..100 % duty) for a plan's camera.
    Bench(BenchArgs),
    /// Estimate a rolling shutter's line time from frames of a diffusely
    /// lit PWM scene; prints the line time in microseconds on the first line.
    /// Exit code 4 when the frames give no confident estimate.
    Linetime(crate::calibrate::command::LinetimeArgs),
    /// Render ideal-camera frames (ON, OFF, PWM) as grey PNG files.
    Render(RenderArgs),
    /// Estimate a PWM frequency from the band spacing of rolling-shutter
    /// frames with a known line time; prints JSON. Exit code 4 when the
    /// frames give no confident estimate.
    Bands(crate::calibrate::command::BandsArgs),
    /// Fit a rolling-shutter camera model (line time, exposure, duty, black
    /// level, saturation, tone curve) to banding frames of a PWM light;
    /// writes a camera profile with --out. Exit code 4 when the frames give
    /// no confident estimate.
    Calibrate(crate::calibrate::command::CalibrateArgs),
    /// Make an ECDSA P-256 private key (FILE, PKCS#8 PEM, mode 0600) and a
    /// self-signed X.509 certificate (FILE with `.crt`, PEM) for signing.
    Keygen {
        /// Who signs, "Name, Role": the certificate's common name.
        #[arg(long)]
        signer: String,
        /// Organisation: the certificate's O.
        #[arg(long, default_value = "")]
        org: String,
        /// Private key file, e.g. ~/keys/ada.key (certificate: ~/keys/ada.crt).
        #[arg(long)]
        out: PathBuf,
    },
    /// Sign a report directory: a PDF signature in report.pdf and a CMS
    /// signature (signoff.p7s) of manifest.txt.
    Sign(SignArgs),
    /// Check every hash and signature of a signed report directory.
    Verify {
        /// Report directory.
        dir: PathBuf,
        /// Trusted certificate (PEM or DER), or a directory of them;
        /// repeatable. Without it the signers' identity is not checked
        /// (exit 4).
        #[arg(long = "trust")]
        trust: Vec<PathBuf>,
        /// Also hash every input again at its recorded path.
        #[arg(long)]
        inputs: bool,
        /// Look for relative input paths under this directory (implies --inputs).
        #[arg(long)]
        inputs_root: Option<PathBuf>,
    },
}

#[derive(Args, Debug)]
struct AdviseArgs {
    /// Lowest PWM frequency, Hz (> 0).
    #[arg(long)]
    min_hz: f64,
    /// Highest PWM frequency, Hz (>= --min-hz).
    #[arg(long)]
    max_hz: f64,
    /// Lowest duty cycle, (0, 1).
    #[arg(long)]
    min_duty: f64,
    /// Highest duty cycle, (0, 1] (>= --min-duty).
    #[arg(long, default_value_t = 1.0)]
    max_duty: f64,
    /// Frequency step of the residual grid, Hz.
    #[arg(long, default_value_t = 1.0)]
    hz_step: f64,
    /// Duty step of the residual grid.
    #[arg(long, default_value_t = 0.01)]
    duty_step: f64,
    /// Image speed of a moving object in pixels per second: adds motion blur.
    #[arg(long)]
    speed_px_per_s: Option<f64>,
    /// Exposure ratio of a shorter HDR capture (repeatable), e.g. 4 and 16.
    #[arg(long)]
    hdr_ratio: Vec<f64>,
    /// The camera's frame rate: no exposure beyond its frame time (less the
    /// shorter HDR captures, taken one after the other) is offered.
    #[arg(long)]
    fps: Option<f64>,
    /// Also write a plot of residual flicker against exposure to this SVG.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Print the advice as JSON instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct BenchArgs {
    /// A CI-sized run (a few seconds).
    #[arg(long)]
    quick: bool,
    /// Plan file or name whose camera and first LED ROI the fine map uses.
    #[arg(default_value = "daylight")]
    plan: String,
    /// Timed repetitions of the fine map (>= 1); the median is reported.
    #[arg(long, default_value_t = 11)]
    repeat: usize,
    /// Also time `calibrate` on a synthetic 8K frame (7680 x 4320, 16-bit
    /// PNG; read, band estimate, fit, profile, closed loop), 5 runs.
    #[arg(long = "calibrate-8k")]
    calibrate_8k: bool,
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// The condition and camera, as for `simulate` (--frames is ignored).
    #[command(flatten)]
    sim: SimulateArgs,
    /// Steady-ON duration, seconds.
    #[arg(long, default_value_t = 0.0)]
    on_s: f64,
    /// OFF duration, seconds.
    #[arg(long, default_value_t = 1.0)]
    off_s: f64,
    /// PWM duration, seconds.
    #[arg(long, default_value_t = 2.0)]
    pwm_s: f64,
    /// Frame width, pixels.
    #[arg(long, default_value_t = 64)]
    width: u32,
    /// Frame height, rows.
    #[arg(long, default_value_t = 48)]
    height: u32,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct SignArgs {
    /// Report directory.
    dir: PathBuf,
    /// Private key, PKCS#8 PEM (ECDSA P-256), e.g. from `ledflicker keygen`.
    #[arg(long, required_unless_present = "p12", conflicts_with = "p12")]
    key: Option<PathBuf>,
    /// Certificate of the key, PEM [default: the key file with `.crt`].
    #[arg(long, requires = "key")]
    cert: Option<PathBuf>,
    /// Key and certificate in one PKCS#12 file; the passphrase comes from
    /// $LEDFLICKER_P12_PASSPHRASE, else from a prompt.
    #[arg(long)]
    p12: Option<PathBuf>,
    /// Who signs, "Name, Role" (e.g. "Jane Doe, Approved by").
    #[arg(long)]
    signer: String,
    /// Signing date, YYYY-MM-DD [default: $SOURCE_DATE_EPOCH, else today].
    #[arg(long)]
    date: Option<String>,
}

#[derive(Args, Debug)]
struct PlanArgs {
    /// Plan file, or a plan name from test-plans/ (e.g. `daylight`).
    plan: String,
    /// Output directory [default: reports/<plan-id>/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads [default: one per core]. Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Report date, YYYY-MM-DD [default: $SOURCE_DATE_EPOCH, else today].
    #[arg(long)]
    date: Option<String>,
    /// Replace a signed report in the output directory.
    #[arg(long)]
    force: bool,
    /// Print no summary table and no progress.
    #[arg(long, short)]
    quiet: bool,
    /// How much of each case the report shows: `summary` (no case pages),
    /// `standard` (a page for each failing or not judged case; passing
    /// cases one line each in the appendix) or `full` (a page for every case).
    #[arg(long, value_enum, default_value_t = DetailArg::Standard)]
    detail: DetailArg,
    /// Sign the report with this private key (PKCS#8 PEM, from `ledflicker keygen`).
    #[arg(long, requires = "signer")]
    sign_key: Option<PathBuf>,
    /// Certificate of --sign-key [default: the key file with `.crt`].
    #[arg(long, requires = "sign_key")]
    sign_cert: Option<PathBuf>,
    /// Who signs, "Name, Role"; with --sign-key.
    #[arg(long, requires = "sign_key")]
    signer: Option<String>,
    /// Compare with a stored results.json and report the drift; exit 1 on
    /// drift beyond tolerance.
    #[arg(long)]
    golden: Option<PathBuf>,
    /// Per-metric tolerance, METRIC=VALUE (repeatable), e.g. fdi_2018=0.05.
    #[arg(long = "golden-tolerance", requires = "golden")]
    golden_tolerance: Vec<String>,
    /// Print where the wall time went (plan, run, report parts) to stderr.
    #[arg(long)]
    timings: bool,
    /// Run only shard K of N (numbered from 0) and write a shard directory
    /// to --out for `ledflicker merge`, no report; `auto` reads a Slurm
    /// array task or a Kubernetes Indexed Job (docs/scale-out.md).
    #[arg(long, requires = "out", conflicts_with_all = ["golden", "sign_key"])]
    shard: Option<String>,
}

/// `--detail` of `plan` and `merge`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum DetailArg {
    /// No case pages.
    Summary,
    /// A page for each failing or not judged case.
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

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum ShutterArg {
    Global,
    Rolling,
}

#[derive(Args, Debug)]
struct SimulateArgs {
    /// PWM frequency in Hz (> 0).
    #[arg(long)]
    frequency_hz: f64,
    /// Duty cycle in (0, 1].
    #[arg(long)]
    duty: f64,
    /// Exposure time in milliseconds (> 0).
    #[arg(long)]
    exposure_ms: f64,
    /// Frame rate in frames per second (> 0).
    #[arg(long)]
    fps: f64,
    /// Number of frames (>= 1).
    #[arg(long, default_value_t = 30)]
    frames: u64,
    /// Time of the first PWM rising edge after the start of frame 0's
    /// exposure (row 0), in milliseconds.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pwm_delay_ms: f64,
    /// Shutter type.
    #[arg(long, value_enum, default_value_t = ShutterArg::Global)]
    shutter: ShutterArg,
    /// Rolling-shutter line time in microseconds (>= 0).
    #[arg(long, default_value_t = 0.0)]
    line_time_us: f64,
    /// ROI rows `A:B`, A inclusive, B exclusive.
    #[arg(long, default_value = "0:1")]
    rows: String,
    /// Print one JSON object with this condition's metrics (results.json
    /// names) instead of the CSV trace.
    #[arg(long)]
    summary: bool,
    /// With --summary: steady light in the ROI (also the OFF reference), in
    /// units of the LED's full ON level (>= 0). 0 leaves FDI unbounded.
    #[arg(long, default_value_t = 0.0)]
    background: f64,
    /// With --summary: sensor rows rendered for the banding KPIs.
    #[arg(long, default_value_t = 800)]
    sensor_rows: u32,
    /// With --summary: an RGB LED whose red, green and blue dies run at these
    /// duties (`R,G,B`, each in (0, 1]) on common rising edges; adds colour KPIs.
    #[arg(long)]
    rgb_duty: Option<String>,
    /// With --summary: a white LED of this linear camera RGB (`R,G,B`) at
    /// --duty; adds colour KPIs.
    #[arg(long)]
    led_rgb: Option<String>,
    /// With --summary: background linear RGB (`R,G,B`) [default: --background
    /// in every channel].
    #[arg(long)]
    background_rgb: Option<String>,
}

fn parse_rgb(flag: &str, s: &str) -> Result<[f64; 3], UsageError> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| UsageError(format!("{flag} `{s}` is not three numbers R,G,B")))?;
    match v.as_slice() {
        [r, g, b] if v.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok([*r, *g, *b]),
        _ => Err(UsageError(format!(
            "{flag} `{s}` is not three numbers R,G,B, each >= 0"
        ))),
    }
}

/// A usage or input error (exit code 2) that is not a plan error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// Maps an error to its exit code.
pub fn exit_code(err: &anyhow::Error) -> i32 {
    for cause in err.chain() {
        if let Some(i) = cause.downcast_ref::<crate::interrupt::Interrupted>() {
            return i.exit_code();
        }
        if let Some(runner::RunError::Interrupted(i)) = cause.downcast_ref() {
            return i.exit_code();
        }
        if let Some(e) = cause.downcast_ref::<crate::outdir::OutDirError>() {
            return if e.is_usage_error() {
                EXIT_INVALID
            } else {
                EXIT_INTERNAL
            };
        }
        if cause.is::<PlanError>() || cause.is::<UsageError>() {
            return EXIT_INVALID;
        }
        if let Some(e) = cause.downcast_ref::<crate::capture::CaptureError>() {
            return if e.is_input_error() {
                EXIT_INVALID
            } else {
                EXIT_INTERNAL
            };
        }
        if cause.is::<crate::calibrate::command::NoEstimate>() {
            return EXIT_NO_CONFIDENCE;
        }
        if let Some(e) = cause.downcast_ref::<crate::calibrate::frames::FrameError>() {
            return match e {
                crate::calibrate::frames::FrameError::Capture(c) if !c.is_input_error() => {
                    EXIT_INTERNAL
                }
                _ => EXIT_INVALID,
            };
        }
        if let Some(report::ReportError::Invalid { .. }) = cause.downcast_ref() {
            return EXIT_INVALID;
        }
        if let Some(report::ReportError::OutDir(e)) = cause.downcast_ref() {
            return if e.is_usage_error() {
                EXIT_INVALID
            } else {
                EXIT_INTERNAL
            };
        }
        if let Some(e) = cause.downcast_ref::<crate::signoff::SignoffError>() {
            return match e {
                crate::signoff::SignoffError::Report(
                    report::ReportError::Invalid { .. }
                    | report::ReportError::OutDir(crate::outdir::OutDirError::Signed { .. }),
                )
                | crate::signoff::SignoffError::Io { .. }
                | crate::signoff::SignoffError::Key { .. }
                | crate::signoff::SignoffError::Pdf(_)
                | crate::signoff::SignoffError::Refused(_) => EXIT_INVALID,
                crate::signoff::SignoffError::Report(_)
                | crate::signoff::SignoffError::Crypto(_) => EXIT_INTERNAL,
            };
        }
    }
    EXIT_INTERNAL
}

/// Runs the CLI and returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err:#}");
            exit_code(&err)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<i32> {
    match cli.command {
        Command::Plan(args) => run_plan(args),
        Command::Merge(args) => crate::shard::command::merge(args),
        Command::Validate { plan } => validate(&plan),
        Command::Simulate(args) => simulate(args),
        Command::Advise(args) => advise(args),
        Command::Bench(args) => bench(args),
        Command::Linetime(args) => crate::calibrate::command::linetime(args),
        Command::Render(args) => render(args),
        Command::Bands(args) => crate::calibrate::command::bands(args),
        Command::Calibrate(args) => crate::calibrate::command::calibrate(args),
        Command::Keygen { signer, org, out } => {
            let files = crate::signoff::keygen(&out, &signer, &org, now_unix_s())?;
            println!(
                "private key: {} (PKCS#8 PEM, mode 0600; keep it secret, outside report directories)\ncertificate: {} (self-signed X.509 PEM; give it to whoever verifies your reports)\nSHA-256:     {}",
                files.key.display(),
                files.cert.display(),
                files.fingerprint
            );
            Ok(EXIT_PASS)
        }
        Command::Sign(args) => sign_cmd(args),
        Command::Verify {
            dir,
            trust,
            inputs,
            inputs_root,
        } => {
            let inputs = (inputs || inputs_root.is_some()).then_some(inputs_root.as_deref());
            verify(&dir, &trust, inputs)
        }
    }
}

fn now_unix_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Signing time: $SOURCE_DATE_EPOCH, else midnight UTC of --date, else now.
fn signing_time(date_arg: Option<&str>) -> anyhow::Result<u64> {
    if let Ok(s) = std::env::var("SOURCE_DATE_EPOCH") {
        return s.trim().parse().map_err(|_| {
            UsageError(format!(
                "SOURCE_DATE_EPOCH `{s}` is not an integer number of seconds"
            ))
            .into()
        });
    }
    Ok(match date_arg {
        Some(d) => crate::signoff::unix_of_date(d)
            .ok_or_else(|| UsageError(format!("--date `{d}` is not a valid date")))?,
        None => now_unix_s(),
    })
}

/// Loads the signing key and certificate (PEM pair or PKCS#12).
fn load_signer(
    key: Option<&std::path::Path>,
    cert: Option<&std::path::Path>,
    p12: Option<&std::path::Path>,
) -> anyhow::Result<(crate::signoff::SignerKey, Vec<PathBuf>)> {
    if let Some(p12) = p12 {
        let pass = match std::env::var("LEDFLICKER_P12_PASSPHRASE") {
            Ok(p) => p,
            Err(_) => crate::signoff::prompt_passphrase(p12)?,
        };
        return Ok((
            crate::signoff::pkcs12::load(p12, &pass)?,
            vec![p12.to_path_buf()],
        ));
    }
    let key = key.ok_or_else(|| UsageError("give --key or --p12".into()))?;
    let cert = cert.map_or_else(
        || crate::signoff::keys::certificate_path(key),
        PathBuf::from,
    );
    let signer = crate::signoff::keys::load_signer(key, &cert)?;
    Ok((signer, vec![key.to_path_buf()]))
}

fn sign_cmd(args: SignArgs) -> anyhow::Result<i32> {
    let date = report_date(args.date.as_deref())?;
    let time = signing_time(args.date.as_deref())?;
    let (key, key_files) = load_signer(
        args.key.as_deref(),
        args.cert.as_deref(),
        args.p12.as_deref(),
    )?;
    let done = crate::signoff::sign(
        &args.dir,
        &crate::signoff::SignRequest {
            signer: &args.signer,
            date: &date,
            time_unix_s: time,
            key: &key,
            key_files,
        },
    )
    .with_context(|| format!("cannot sign `{}`", args.dir.display()))?;
    println!(
        "signed `{}` as {} (signature {}, certificate SHA-256 {}), {} files in manifest.txt",
        args.dir.display(),
        args.signer.trim(),
        done.index,
        done.fingerprint,
        done.files
    );
    Ok(EXIT_PASS)
}

fn verify(
    dir: &std::path::Path,
    trust: &[PathBuf],
    inputs: Option<Option<&std::path::Path>>,
) -> anyhow::Result<i32> {
    let trusted = crate::signoff::verify::load_trusted(trust)?;
    let v = crate::signoff::verify(dir, &trusted, inputs)
        .with_context(|| format!("cannot verify `{}`", dir.display()))?;
    let n = v.signatures.len();
    for s in &v.signatures {
        let trust = match s.trusted {
            Some(true) => "trusted certificate",
            Some(false) => "NOT a trusted certificate",
            None => "identity not checked",
        };
        println!(
            "signature {} of {n}: \"{}\" on {}, certificate \"{}\" SHA-256 {} ({trust})",
            s.index, s.signer, s.date, s.subject, s.fingerprint
        );
    }
    for p in &v.problems {
        println!("FAIL: {p}");
    }
    if !v.ok() {
        println!("NOT VERIFIED: {} problem(s)", v.problems.len());
        return Ok(EXIT_FAIL);
    }
    println!(
        "intact: {} files, {n} manifest signature(s), {} PDF signature(s){}",
        v.files,
        v.pdf_signatures,
        if inputs.is_some() {
            format!(", {} input(s) unchanged", v.inputs_checked)
        } else {
            String::new()
        }
    );
    if v.identity_checked {
        println!("verified: every signer holds a trusted certificate");
        Ok(EXIT_PASS)
    } else {
        println!(
            "IDENTITY NOT CHECKED: anyone can sign under any name; pass --trust CERT (the signers' certificates, obtained from them directly) to check who signed (exit {EXIT_IDENTITY_UNCHECKED})"
        );
        Ok(EXIT_IDENTITY_UNCHECKED)
    }
}

fn validate(arg: &str) -> anyhow::Result<i32> {
    let path = plan::resolve_plan_path(arg)?;
    let plan = plan::load(&path)?;
    let cases = plan::expand_cases(&plan);
    if plan.dut.backend == plan::BackendKind::Captured {
        println!(
            "plan `{}` ({}) is valid: {} captured cases, {} ROIs",
            plan.id,
            path.display(),
            cases.len(),
            plan.rois.len()
        );
        println!("{}", plan::WorkEstimate::of(&plan).summary());
        return Ok(EXIT_PASS);
    }
    let frames = crate::backend::sim::SegmentFrames::new(&plan.sequence, plan.dut.camera.fps);
    println!(
        "plan `{}` ({}) is valid: {} cases ({} light levels x {} frequencies x {} duty cycles), {} ROIs, {} frames per case",
        plan.id,
        path.display(),
        cases.len(),
        plan.light_levels_lux.len(),
        plan.frequencies_hz.len(),
        plan.duty_cycles.len(),
        plan.rois.len(),
        frames.total()
    );
    println!("{}", plan::WorkEstimate::of(&plan).summary());
    Ok(EXIT_PASS)
}

/// The report date: `--date`, else $SOURCE_DATE_EPOCH, else today.
pub(crate) fn report_date(arg: Option<&str>) -> anyhow::Result<String> {
    if let Some(d) = arg {
        let ok = d.len() == 10
            && d.chars().enumerate().all(|(i, c)| {
                if i == 4 || i == 7 {
                    c == '-'
                } else {
                    c.is_ascii_digit()
                }
            });
        if !ok || !crate::util::is_calendar_date(d) {
            return Err(UsageError(format!(
                "--date `{d}` is not a date YYYY-MM-DD (e.g. 2026-11-23)"
            ))
            .into());
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
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    Ok(crate::util::utc_date(now))
}

/// "captures: 1234 frames decoded (617 frames/s)" on a terminal while a
/// captured plan's captures are read; hidden with -q or off a terminal.
fn decode_spinner(quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let start = crate::capture::frames_decoded();
    let style = ProgressStyle::with_template("{spinner} captures: {decoded}")
        .map(|s| {
            s.with_key(
                "decoded",
                move |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let n = crate::capture::frames_decoded().saturating_sub(start);
                    let _ = w.write_str(&crate::capture::decode_progress_text(n, state.elapsed()));
                },
            )
        })
        .unwrap_or_else(|_| ProgressStyle::default_spinner());
    let s = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    s.set_style(style);
    s.enable_steady_tick(std::time::Duration::from_millis(120));
    s
}

fn run_plan(args: PlanArgs) -> anyhow::Result<i32> {
    if args.timings {
        crate::timings::enable();
    }
    let total = crate::timings::span("total");
    let t = crate::timings::span("load and validate plan");
    let path = plan::resolve_plan_path(&args.plan)?;
    let plan = plan::load(&path)?;
    drop(t);
    let date = report_date(args.date.as_deref())?;
    if args.threads == Some(0) {
        return Err(UsageError("--threads must be at least 1".into()).into());
    }
    if let Some(spec) = &args.shard {
        let spec = crate::shard::ShardSpec::parse(spec, &|k| std::env::var(k).ok())?;
        return crate::shard::command::run_shard(&crate::shard::command::ShardRun {
            plan: &plan,
            spec,
            out: args.out.as_deref().unwrap_or(std::path::Path::new(".")),
            threads: args.threads,
            force: args.force,
            quiet: args.quiet,
        });
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports").join(&plan.id));
    // Refuse before spending time on the run: a signed report without
    // --force, a directory ledflicker did not write, an unwritable place.
    crate::outdir::check_overwrite(&out, args.force)?;
    let generation = crate::outdir::Generation::begin(&out)?;
    crate::interrupt::install();
    let mut tolerances = report::golden::Tolerances::default();
    for t in &args.golden_tolerance {
        tolerances.set(t).map_err(UsageError)?;
    }
    let golden = match &args.golden {
        Some(p) => Some(
            report::golden::load(p)
                .with_context(|| format!("cannot read the golden results `{}`", p.display()))?,
        ),
        None => None,
    };
    // Fail on a bad key before the run, not after it.
    let signer_key = match &args.sign_key {
        Some(key) => {
            let loaded = load_signer(Some(key), args.sign_cert.as_deref(), None)?;
            crate::signoff::check_key_outside(&out, key)?;
            Some(loaded)
        }
        None => None,
    };
    let sign_time = signing_time(args.date.as_deref())?;

    let cases = plan::expand_cases(&plan);
    let sim;
    let mut captured = None;
    let mut rig = None;
    let backend: &dyn Backend = match plan.dut.backend {
        plan::BackendKind::Simulator => {
            sim = Simulator::new(&plan);
            &sim
        }
        plan::BackendKind::Captured => {
            let decoding = decode_spinner(args.quiet);
            let t = crate::timings::span("read captures (decode and ROI means)");
            let loaded = Captured::load(&plan);
            drop(t);
            decoding.finish_and_clear();
            &*captured.insert(
                loaded
                    .with_context(|| format!("cannot read the captures of plan `{}`", plan.id))?,
            )
        }
        plan::BackendKind::Command => &*rig.insert(
            CommandRig::new(&plan)
                .ok_or_else(|| UsageError("the plan has no [capture] command".into()))?,
        ),
    };
    // After the backend has checked that the captures exist.
    let inputs = crate::inputs::collect(&plan).map_err(|e| UsageError(e.to_string()))?;
    let bar = if !args.quiet && std::io::stderr().is_terminal() {
        ProgressBar::with_draw_target(Some(cases.len() as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg:>10} [{bar:30}] {pos}/{len} cases, {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(plan.id.clone());
    let on_event = |ev: RunEvent<'_>| {
        if let RunEvent::CaseFinished { .. } = ev {
            bar.inc(1);
        }
    };
    let t = crate::timings::span("run cases");
    let mut results = runner::run(&plan, &cases, backend, args.threads, &on_event)
        .with_context(|| format!("run of plan `{}` failed", plan.id))?;
    drop(t);
    let t = crate::timings::span("render sample frames");
    runner::render_sample_frames(&plan, &mut results, backend)
        .with_context(|| format!("cannot render the sample frames of plan `{}`", plan.id))?;
    drop(t);
    bar.finish_and_clear();
    // The report stage takes seconds on large plans: say what it does.
    let stage = if !args.quiet && std::io::stderr().is_terminal() {
        let s = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        s.set_style(
            ProgressStyle::with_template("{spinner} report: {msg} ({elapsed})")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        s.enable_steady_tick(std::time::Duration::from_millis(120));
        s
    } else {
        ProgressBar::hidden()
    };
    stage.set_message(format!("analysing {} cases", results.len()));

    let backend_id = backend.id().to_string();
    let t = crate::timings::span("report model (analyses)");
    let model = crate::model::assemble(&plan, &backend_id, &results);
    drop(t);
    crate::interrupt::check()?;
    stage.set_message("drawing charts, writing report.html and report.pdf".to_string());
    let t = crate::timings::span("write report");
    report::write_report(
        generation.path(),
        &model,
        &results,
        &WriteOptions {
            date: date.clone(),
            force: args.force,
            signatories: Vec::new(),
            inputs,
            detail: args.detail.into(),
        },
    )
    .with_context(|| format!("cannot write the report to `{}`", out.display()))?;
    drop(t);
    if let (Some((key, key_files)), Some(signer)) = (signer_key, &args.signer) {
        let done = crate::signoff::sign(
            generation.path(),
            &crate::signoff::SignRequest {
                signer,
                date: &date,
                time_unix_s: sign_time,
                key: &key,
                key_files,
            },
        )
        .with_context(|| format!("cannot sign `{}`", out.display()))?;
        if !args.quiet {
            println!(
                "signed by {} (certificate SHA-256 {})",
                signer.trim(),
                done.fingerprint
            );
        }
    }

    stage.finish_and_clear();
    // The new generation replaces the old report in one step, or not at all.
    crate::interrupt::check()?;
    generation.commit()?;
    if !args.quiet {
        print_summary(&model, &out)?;
    }
    let mut drift = false;
    if let Some(g) = &golden {
        let cmp = report::golden::compare(g, &model, &tolerances);
        print!("{}", cmp.to_text());
        drift = !cmp.ok();
    }
    drop(total);
    if args.timings {
        eprint!("{}", crate::timings::table(&crate::timings::take()));
    }
    Ok(if model.verdict == Verdict::Fail || drift {
        EXIT_FAIL
    } else if model.verdict == Verdict::Info {
        EXIT_NOT_JUDGED
    } else {
        EXIT_PASS
    })
}

fn print_summary(model: &crate::model::Results, out: &std::path::Path) -> anyhow::Result<()> {
    let mut w = std::io::stdout().lock();
    w.write_all(report::terminal::summary(model, out).as_bytes())?;
    Ok(())
}

fn parse_rows(s: &str) -> Result<std::ops::Range<u32>, UsageError> {
    let bad = || {
        UsageError(format!(
            "--rows `{s}` is not A:B with A < B (A inclusive, B exclusive), e.g. 399:401"
        ))
    };
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let a: u32 = a.trim().parse().map_err(|_| bad())?;
    let b: u32 = b.trim().parse().map_err(|_| bad())?;
    if a >= b {
        return Err(bad());
    }
    Ok(a..b)
}

/// Physical bounds of `simulate` and `render` inputs (docs/plan-format.md,
/// "Limits"): beyond them the arithmetic loses meaning or overflows.
fn check_simulate_bounds(a: &SimulateArgs) -> Result<(), UsageError> {
    use crate::plan::bounds::{MAX_FPS, MAX_FRAMES_PER_CASE, MAX_FREQUENCY_HZ, MIN_EXPOSURE_S};
    let problems = [
        (
            a.frequency_hz > MAX_FREQUENCY_HZ,
            format!("--frequency-hz must be at most {MAX_FREQUENCY_HZ:.0}"),
        ),
        (
            a.fps > MAX_FPS,
            format!("--fps must be at most {MAX_FPS:.0}"),
        ),
        (a.fps < 0.01, "--fps must be at least 0.01".to_string()),
        (
            a.exposure_ms * 1e-3 < MIN_EXPOSURE_S,
            "--exposure-ms must be at least 0.001".to_string(),
        ),
        (
            a.exposure_ms > 1e4,
            "--exposure-ms must be at most 10000".to_string(),
        ),
        (
            a.frames > MAX_FRAMES_PER_CASE,
            format!("--frames must be at most {MAX_FRAMES_PER_CASE}"),
        ),
        (
            a.pwm_delay_ms.is_nan() || a.pwm_delay_ms.abs() > 1e6,
            "--pwm-delay-ms must be within +-1e6".to_string(),
        ),
        (
            a.line_time_us > 1e6,
            "--line-time-us must be at most 1e6".to_string(),
        ),
        (
            a.sensor_rows > crate::plan::bounds::MAX_SENSOR_SIDE,
            format!(
                "--sensor-rows must be at most {}",
                crate::plan::bounds::MAX_SENSOR_SIDE
            ),
        ),
    ];
    match problems.iter().find(|(bad, _)| *bad) {
        Some((_, m)) => Err(UsageError(m.clone())),
        None => Ok(()),
    }
}

fn simulate(a: SimulateArgs) -> anyhow::Result<i32> {
    let usage = |m: String| anyhow::Error::from(UsageError(m));
    check_simulate_bounds(&a)?;
    let pwm = PwmDrive::new(a.frequency_hz, a.duty, a.pwm_delay_ms * 1e-3).map_err(usage)?;
    if !(a.exposure_ms.is_finite() && a.exposure_ms > 0.0) {
        return Err(usage(format!(
            "--exposure-ms must be > 0, got {}",
            a.exposure_ms
        )));
    }
    if !(a.fps.is_finite() && a.fps > 0.0) {
        return Err(usage(format!("--fps must be > 0, got {}", a.fps)));
    }
    if a.frames == 0 {
        return Err(usage("--frames must be at least 1".into()));
    }
    if !(a.line_time_us.is_finite() && a.line_time_us >= 0.0) {
        return Err(usage(format!(
            "--line-time-us must be >= 0, got {}",
            a.line_time_us
        )));
    }
    let rows = parse_rows(&a.rows)?;
    let shutter = Shutter {
        model: match a.shutter {
            ShutterArg::Global => ShutterModel::Global,
            ShutterArg::Rolling => ShutterModel::Rolling {
                line_time_s: a.line_time_us * 1e-6,
            },
        },
        exposure_s: a.exposure_ms * 1e-3,
        fps: a.fps,
    };
    if a.summary {
        if !(a.background.is_finite() && a.background >= 0.0) {
            return Err(usage(format!(
                "--background must be >= 0, got {}",
                a.background
            )));
        }
        if a.sensor_rows == 0 {
            return Err(usage("--sensor-rows must be at least 1".into()));
        }
        use crate::analysis::colour::Die;
        let dies = match (&a.rgb_duty, &a.led_rgb) {
            (Some(_), Some(_)) => {
                return Err(usage("give --rgb-duty or --led-rgb, not both".into()));
            }
            (Some(d), None) => {
                let d = parse_rgb("--rgb-duty", d)?;
                if d.iter().any(|x| !(*x > 0.0 && *x <= 1.0)) {
                    return Err(usage(format!(
                        "--rgb-duty duties must be in (0, 1], got {d:?}"
                    )));
                }
                let primary = |k: usize| {
                    let mut c = [0.0; 3];
                    c[k] = 1.0;
                    Die {
                        rgb: c,
                        duty: d[k],
                        offset_cycles: 0.0,
                    }
                };
                Some(vec![primary(0), primary(1), primary(2)])
            }
            (None, Some(c)) => Some(vec![Die {
                rgb: parse_rgb("--led-rgb", c)?,
                duty: a.duty,
                offset_cycles: 0.0,
            }]),
            (None, None) => None,
        };
        let background_rgb = match &a.background_rgb {
            Some(b) => parse_rgb("--background-rgb", b)?,
            None => [a.background; 3],
        };
        let scene = dies.map(|dies| crate::analysis::summary::ColourScene {
            background: background_rgb,
            dies,
        });
        let summary = crate::analysis::summary::summarise(
            &shutter,
            &pwm,
            rows,
            a.frames,
            a.background,
            a.sensor_rows,
            scene.as_ref(),
        );
        // serde_json writes a non-finite number as null, never NaN.
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(EXIT_PASS);
    }
    let mut w = std::io::BufWriter::new(std::io::stdout().lock());
    writeln!(w, "frame,time_s,on_fraction")?;
    for k in 0..a.frames {
        let s = shutter.frame_on_fraction(&pwm, k, rows.clone());
        let t = k as f64 / a.fps;
        if !(s.is_finite() && t.is_finite()) {
            // Never print NaN: the inputs are beyond what the model covers.
            return Err(usage(format!(
                "frame {k} has no finite ON fraction for these inputs; check their ranges (`ledflicker simulate --help`)"
            )));
        }
        writeln!(w, "{k},{t},{s}")?;
    }
    w.flush()?;
    Ok(EXIT_PASS)
}

fn advise(a: AdviseArgs) -> anyhow::Result<i32> {
    use crate::advise::{AdviseRequest, advise, curve, table};
    if a.hdr_ratio.iter().any(|r| !(r.is_finite() && *r > 1.0)) {
        return Err(UsageError("--hdr-ratio must be > 1".into()).into());
    }
    if a.speed_px_per_s
        .is_some_and(|v| !(v.is_finite() && v >= 0.0))
    {
        return Err(UsageError("--speed-px-per-s must be >= 0".into()).into());
    }
    if a.fps
        .is_some_and(|f| !(f.is_finite() && f > 0.0 && f <= 1000.0))
    {
        return Err(UsageError("--fps must be > 0 and at most 1000".into()).into());
    }
    let req = AdviseRequest {
        frame: a
            .fps
            .map(|f| crate::advise::FrameBound::sequential(f, &a.hdr_ratio)),
        frequency_hz: (a.min_hz, a.max_hz),
        duty: (a.min_duty, a.max_duty),
        frequency_step_hz: a.hz_step,
        duty_step: a.duty_step,
        speed_px_per_s: a.speed_px_per_s,
        hdr_ratios: a.hdr_ratio.clone(),
    };
    let advice = advise(&req).map_err(|e| UsageError(e.to_string()))?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&advice)?);
    } else {
        print!("{}", table(&advice));
    }
    if let Some(path) = &a.svg {
        let points = curve(&req, 49).map_err(|e| UsageError(e.to_string()))?;
        let svg = report::charts::advise_svg(&points, advice.min_exposure_s)?;
        crate::util::write_atomic(path, svg.as_bytes())
            .with_context(|| format!("cannot write `{}`", path.display()))?;
    }
    Ok(EXIT_PASS)
}

/// The numpy peer's figure on the exact-core grid, measured now, and the
/// batched core's ratio to it; a missing Python or numpy is said, not fatal.
fn print_peer_ratio(rows: &[crate::bench::BenchRow]) {
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/peer_closedform.py");
    let Some(ours) = rows.iter().find(|r| r.method == "exact core, batched") else {
        return;
    };
    let ours = 1.0 / ours.time_s;
    match crate::bench::numpy_peer(&script, std::time::Duration::from_secs(120)) {
        Ok(peer) => println!(
            "numpy peer (scripts/peer_closedform.py, same grid): {peer:.2e} integrals/s; \
             exact core, batched: {ours:.2e} integrals/s = {:.1}x numpy",
            ours / peer
        ),
        Err(e) => println!("numpy peer not measured: {e} (pip install numpy to compare)"),
    }
}

fn bench(a: BenchArgs) -> anyhow::Result<i32> {
    use crate::analysis::{FINE_DUTY, FINE_FREQUENCY, finemap};
    if a.repeat == 0 {
        return Err(UsageError("--repeat must be at least 1".into()).into());
    }
    println!("{:<44} {:>14} {:>12}  note", "method", "time", "max error");
    let mut print_row = |r: &crate::bench::BenchRow| {
        let time = if r.time_s < 1e-6 {
            format!("{:.2} ns/{}", r.time_s * 1e9, r.per)
        } else if r.time_s < 1e-3 {
            format!("{:.3} us/{}", r.time_s * 1e6, r.per)
        } else {
            format!("{:.3} s/{}", r.time_s, r.per)
        };
        let err = r.max_error.map_or("-".to_string(), |e| format!("{e:.2e}"));
        println!("{:<44} {:>14} {:>12}  {}", r.method, time, err, r.note);
    };
    let rows = crate::bench::run(a.quick, &mut print_row)
        .map_err(|e| anyhow::anyhow!("bench failed: {e}"))?;
    print_peer_ratio(&rows);
    let repeat = if a.quick { a.repeat.min(3) } else { a.repeat };
    let path = plan::resolve_plan_path(&a.plan)?;
    let plan = plan::load(&path)?;
    let roi = plan
        .rois
        .iter()
        .find(|r| r.kind == plan::RoiKind::Led)
        .ok_or_else(|| UsageError(format!("plan `{}` has no LED ROI", plan.id)))?;
    let shutter = crate::backend::sim::shutter_of(&plan.dut.camera);
    let lux = plan.light_levels_lux.first().copied().unwrap_or(0.0);
    let luma = crate::analysis::ideal_luma_model(&plan, lux);
    let mut times: Vec<f64> = (0..repeat)
        .map(|_| {
            let t = std::time::Instant::now();
            let map = finemap::compute(&shutter, roi.rows(), luma, FINE_FREQUENCY, FINE_DUTY);
            std::hint::black_box(&map);
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let cells = FINE_FREQUENCY.count * FINE_DUTY.count;
    println!(
        "fine map `{}` ({} rows of ROI `{}`): {} x {} = {cells} cells, {} threads; median {:.1} ms (min {:.1}, max {:.1}) over {} runs",
        plan.id,
        roi.rows().len(),
        roi.name,
        FINE_FREQUENCY.count,
        FINE_DUTY.count,
        rayon::current_num_threads(),
        1e3 * times[times.len() / 2],
        1e3 * times[0],
        1e3 * times[times.len() - 1],
        repeat
    );
    if a.calibrate_8k {
        let (t, rms) = crate::bench::calibrate_8k(5)
            .map_err(|e| anyhow::anyhow!("bench of calibrate on an 8K frame failed: {e}"))?;
        println!(
            "calibrate, one 8K frame (7680 x 4320, 16-bit PNG), {} threads: median {:.2} s (min {:.2}, max {:.2}) over {} runs; closed-loop profile_rms {rms:.4}",
            rayon::current_num_threads(),
            t[t.len() / 2],
            t[0],
            t[t.len() - 1],
            t.len()
        );
    }
    Ok(EXIT_PASS)
}

fn render(a: RenderArgs) -> anyhow::Result<i32> {
    let usage = |m: String| anyhow::Error::from(UsageError(m));
    let s = &a.sim;
    let pwm = PwmDrive::new(s.frequency_hz, s.duty, s.pwm_delay_ms * 1e-3).map_err(usage)?;
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    if !(s.exposure_ms.is_finite() && s.exposure_ms > 0.0 && s.fps.is_finite() && s.fps > 0.0)
        || !(ok(a.on_s) && ok(a.off_s) && ok(a.pwm_s) && ok(s.line_time_us))
        || a.width == 0
        || a.height == 0
    {
        return Err(usage(
            "--exposure-ms and --fps must be > 0; durations, --line-time-us >= 0; --width, --height >= 1"
                .into(),
        ));
    }
    let shutter = Shutter {
        model: match s.shutter {
            ShutterArg::Global => ShutterModel::Global,
            ShutterArg::Rolling => ShutterModel::Rolling {
                line_time_s: s.line_time_us * 1e-6,
            },
        },
        exposure_s: s.exposure_ms * 1e-3,
        fps: s.fps,
    };
    let frames = |d: f64| (d * s.fps).round() as u64;
    let spec = crate::render::RenderSpec {
        shutter,
        width: a.width,
        height: a.height,
        frames: (frames(a.on_s), frames(a.off_s), frames(a.pwm_s)),
        background_dn: 20.0,
        gain_dn: 200.0,
    };
    let n = crate::render::render_frames(&spec, &pwm, &a.out).map_err(anyhow::Error::msg)?;
    eprintln!("wrote {n} frames to {}", a.out.display());
    Ok(EXIT_PASS)
}
