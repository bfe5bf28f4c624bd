//! Command-line interface: `plan`, `validate`, `simulate`, `keygen`, `sign`
//! and `verify`.
//!
//! Exit codes (stable; CI scripts depend on them):
//!
//! | code | meaning |
//! |---|---|
//! | 0 | every case passed (informational cases do not count); `verify`: every hash and signature matched |
//! | 1 | the run completed and some case failed, or `--golden` found drift beyond tolerance; `verify`: a hash or signature mismatch, or no signature |
//! | 2 | invalid plan, input or usage, including a missing file, a bad key or a signed report in the way |
//! | 3 | internal or backend error |

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::backend::Backend;
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
    /// Check a test plan without running it.
    Validate {
        /// Plan file, or a plan name from test-plans/ (e.g. `daylight`).
        plan: String,
    },
    /// Probe the ideal camera for one condition; prints a CSV trace.
    Simulate(SimulateArgs),
    /// Make an Ed25519 key pair for signing reports: FILE (private) and FILE.pub.
    Keygen {
        /// Private key file; the public key goes to FILE.pub.
        #[arg(long)]
        out: PathBuf,
    },
    /// Sign a report directory (adds a signature to signoff.json).
    Sign(SignArgs),
    /// Check every hash and signature of a signed report directory.
    Verify {
        /// Report directory.
        dir: PathBuf,
        /// Trusted public key (FILE.pub from keygen); repeatable. Without it,
        /// signatures are checked against the keys in signoff.json.
        #[arg(long = "key")]
        keys: Vec<PathBuf>,
    },
}

#[derive(Args, Debug)]
struct SignArgs {
    /// Report directory.
    dir: PathBuf,
    /// Private key file from `ledflicker keygen`.
    #[arg(long)]
    key: PathBuf,
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
    /// Print no summary table.
    #[arg(long, short)]
    quiet: bool,
    /// Sign the report with this private key (from `ledflicker keygen`).
    #[arg(long, requires = "signer")]
    sign_key: Option<PathBuf>,
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
}

/// A usage or input error (exit code 2) that is not a plan error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// Maps an error to its exit code.
pub fn exit_code(err: &anyhow::Error) -> i32 {
    for cause in err.chain() {
        if cause.is::<PlanError>() || cause.is::<UsageError>() {
            return EXIT_INVALID;
        }
        if let Some(report::ReportError::Signed { .. } | report::ReportError::Invalid { .. }) =
            cause.downcast_ref()
        {
            return EXIT_INVALID;
        }
        if let Some(e) = cause.downcast_ref::<crate::signoff::SignoffError>() {
            return match e {
                crate::signoff::SignoffError::Report(
                    report::ReportError::Invalid { .. } | report::ReportError::Signed { .. },
                )
                | crate::signoff::SignoffError::Io { .. }
                | crate::signoff::SignoffError::Key { .. }
                | crate::signoff::SignoffError::Refused(_) => EXIT_INVALID,
                crate::signoff::SignoffError::Report(_) => EXIT_INTERNAL,
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
        Command::Validate { plan } => validate(&plan),
        Command::Simulate(args) => simulate(args),
        Command::Keygen { out } => {
            let id = crate::signoff::keygen(&out)?;
            println!(
                "private key: {} (keep it secret, outside report directories)\npublic key:  {}\nkey id:      {id}",
                out.display(),
                crate::signoff::public_key_path(&out).display()
            );
            Ok(EXIT_PASS)
        }
        Command::Sign(args) => {
            let date = report_date(args.date.as_deref())?;
            let e = crate::signoff::sign(&args.dir, &args.key, &args.signer, &date)
                .with_context(|| format!("cannot sign `{}`", args.dir.display()))?;
            println!(
                "signed `{}` as {} (key {}), {} files",
                args.dir.display(),
                e.signer,
                e.key_id,
                e.files.len()
            );
            Ok(EXIT_PASS)
        }
        Command::Verify { dir, keys } => verify(&dir, &keys),
    }
}

fn verify(dir: &std::path::Path, keys: &[PathBuf]) -> anyhow::Result<i32> {
    let trusted = keys
        .iter()
        .map(|k| crate::signoff::load_verifying_key(k))
        .collect::<Result<Vec<_>, _>>()?;
    let v = crate::signoff::verify(dir, &trusted)
        .with_context(|| format!("cannot verify `{}`", dir.display()))?;
    for (signer, key) in &v.valid {
        println!("signature ok: {signer} (key {key})");
    }
    for p in &v.problems {
        println!("FAIL: {p}");
    }
    if v.ok() {
        println!(
            "verified: {} files, {} signature(s)",
            v.files,
            v.valid.len()
        );
        Ok(EXIT_PASS)
    } else {
        println!("NOT VERIFIED: {} problem(s)", v.problems.len());
        Ok(EXIT_FAIL)
    }
}

fn validate(arg: &str) -> anyhow::Result<i32> {
    let path = plan::resolve_plan_path(arg)?;
    let plan = plan::load(&path)?;
    let cases = plan::expand_cases(&plan);
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
    Ok(EXIT_PASS)
}

fn report_date(arg: Option<&str>) -> anyhow::Result<String> {
    if let Some(d) = arg {
        let ok = d.len() == 10
            && d.chars().enumerate().all(|(i, c)| {
                if i == 4 || i == 7 {
                    c == '-'
                } else {
                    c.is_ascii_digit()
                }
            });
        if !ok {
            return Err(UsageError(format!("--date `{d}` is not YYYY-MM-DD")).into());
        }
        return Ok(d.to_string());
    }
    if let Ok(s) = std::env::var("SOURCE_DATE_EPOCH") {
        let secs: i64 = s.trim().parse().map_err(|_| {
            UsageError(format!(
                "SOURCE_DATE_EPOCH `{s}` is not an integer number of seconds"
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

fn run_plan(args: PlanArgs) -> anyhow::Result<i32> {
    let path = plan::resolve_plan_path(&args.plan)?;
    let plan = plan::load(&path)?;
    let date = report_date(args.date.as_deref())?;
    if args.threads == Some(0) {
        return Err(UsageError("--threads must be at least 1".into()).into());
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports").join(&plan.id));
    // Refuse before spending time on the run.
    report::check_overwrite(&out, args.force)?;
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
    if let Some(key) = &args.sign_key {
        // Fail on a bad key before the run, not after it.
        crate::signoff::load_signing_key(key)?;
        crate::signoff::check_key_outside(&out, key)?;
    }

    let cases = plan::expand_cases(&plan);
    let backend = Simulator::new(&plan);
    let bar = if std::io::stderr().is_terminal() {
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
    let results = runner::run(&plan, &cases, &backend, args.threads, &on_event)
        .with_context(|| format!("run of plan `{}` failed", plan.id))?;
    bar.finish_and_clear();

    let model = report::build(&plan, backend.id(), &results);
    report::write_report(
        &out,
        &model,
        &results,
        &WriteOptions {
            date: date.clone(),
            force: args.force,
            signatories: Vec::new(),
        },
    )
    .with_context(|| format!("cannot write the report to `{}`", out.display()))?;
    if let (Some(key), Some(signer)) = (&args.sign_key, &args.signer) {
        let e = crate::signoff::sign(&out, key, signer, &date)
            .with_context(|| format!("cannot sign `{}`", out.display()))?;
        if !args.quiet {
            println!("signed by {} (key {})", e.signer, e.key_id);
        }
    }

    if !args.quiet {
        print_summary(&model, &out)?;
    }
    let mut drift = false;
    if let Some(g) = &golden {
        let cmp = report::golden::compare(g, &model, &tolerances);
        print!("{}", cmp.to_text());
        drift = !cmp.ok();
    }
    Ok(if model.verdict == Verdict::Fail || drift {
        EXIT_FAIL
    } else {
        EXIT_PASS
    })
}

fn print_summary(model: &report::Results, out: &std::path::Path) -> anyhow::Result<()> {
    let mut w = std::io::stdout().lock();
    let width = model
        .cases
        .iter()
        .map(|c| c.id.len())
        .max()
        .unwrap_or(4)
        .max(4);
    writeln!(
        w,
        "{:<width$}  {:<7}  {:>10}  {:>10}  {:>8}  {:>8}",
        "case", "verdict", "FDI", "FDI worst", "PF %", "PF worst"
    )?;
    let show = |v: Option<f64>, unbounded: bool, digits: usize| -> String {
        if unbounded {
            "+inf".to_string()
        } else {
            v.map_or("n/a".to_string(), |x| crate::util::fixed(x, digits))
        }
    };
    for c in &model.cases {
        // The first LED ROI stands for the case in the table; the report
        // has every ROI.
        let Some(roi) = c
            .rois
            .iter()
            .find(|r| r.kind == plan::RoiKind::Led)
            .or(c.rois.first())
        else {
            continue;
        };
        let m = |k: &str| roi.metrics.get(k).copied().flatten();
        writeln!(
            w,
            "{:<width$}  {:<7}  {:>10}  {:>10}  {:>8}  {:>8}",
            c.id,
            c.verdict.as_str(),
            show(m("fdi_2018"), roi.contrast_unbounded, 3),
            show(m("fdi_2018_worst_phase"), roi.contrast_unbounded, 3),
            show(m("percent_flicker"), false, 2),
            show(m("percent_flicker_worst_phase"), false, 2),
        )?;
    }
    writeln!(
        w,
        "\noverall: {} ({} pass, {} fail, {} info of {} cases)\nreport:  {}\n         {}",
        model.verdict.as_str().to_uppercase(),
        model.counts.pass,
        model.counts.fail,
        model.counts.info,
        model.counts.total,
        out.join("report.html").display(),
        out.join("report.pdf").display()
    )?;
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

fn simulate(a: SimulateArgs) -> anyhow::Result<i32> {
    let usage = |m: String| anyhow::Error::from(UsageError(m));
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
    let mut w = std::io::BufWriter::new(std::io::stdout().lock());
    writeln!(w, "frame,time_s,on_fraction")?;
    for k in 0..a.frames {
        let s = shutter.frame_on_fraction(&pwm, k, rows.clone());
        writeln!(w, "{k},{},{s}", k as f64 / a.fps)?;
    }
    w.flush()?;
    Ok(EXIT_PASS)
}
