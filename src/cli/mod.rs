//! Command-line interface: `plan`, `merge`, `plans`, `validate`, `simulate`, `advise`,
//! `bench`, `linetime`, `render`, `rig`, `roi`, `bands`, `calibrate`, `light`, `keygen`, `sign`,
//! `verify`, `import`, `history`, `compare` and `export`, one module each (`linetime`, `bands` and `calibrate` share
//! `calibrate`; `keygen`, `sign` and `verify` share `sign`; `import` and `history`
//! share `campaign`; `plan --shard`
//! is `shard`). This module holds the clap `Command` list, the exit codes
//! and [`main`]; `failure` the error every command returns and its map to
//! the exit codes; `args` the flags several commands share. The CLI sits
//! on top: it may import any module, and no module imports it.
//!
//! Exit codes (stable; CI scripts depend on them; [`ExitCode`] gives each
//! meaning its number):
//!
//! | code | meaning |
//! |---|---|
//! | 0 | every judged case passed and at least one was judged (informational cases do not count); `plan --shard`: the shard ran and wrote its directory (verdicts are the merge's); `verify`: every hash and signature matched and every signer is trusted (`--trust`) |
//! | 1 | the run completed and some case failed, or `--golden` found drift beyond tolerance; `compare`: a KPI regressed beyond its measurement uncertainty; `verify`: a hash, signature or input mismatch, an untrusted signer, or no signature |
//! | 2 | invalid plan, input or usage, including a missing file, a bad key or a signed report in the way; `merge`: shards that do not fit together (missing, duplicated, of another plan, tool or seed, damaged) |
//! | 3 | internal or backend error |
//! | 4 | `plan`, `merge`: the run completed but no case was judged (the summary says NOT JUDGED) |
//! | 5 | `compare`: the two runs are different tests (a setting differs, unaccepted), or share no case or no gated KPI |
//! | 6 | `verify` without `--trust`: every hash and signature matched, but the signers' identity was not checked |
//! | 7 | `linetime`, `bands`, `calibrate`: no confident estimate, the reason (flat rows, no periodic banding, fewer than 3 bands, regions band at different periods, too uncertain; with `--out`, exposure and duty that cannot be told apart) is printed |
//! | 130, 143 | `plan` stopped by SIGINT (Ctrl-C) or SIGTERM (128 + signal); the old report is left as it was |

#![deny(clippy::print_stdout)]

use clap::{Parser, Subcommand};

pub use crate::error::UsageError;

mod advise;
mod args;
mod bench;
mod calibrate;
mod campaign;
pub mod compare;
mod compare_report;
mod endtoend;
mod export;
mod failure;
mod light;
mod manual;
mod merge;
pub(crate) mod output;
mod plan;
mod plans;
mod render;
mod rig;
mod roi;
mod shard;
#[cfg(feature = "signoff")]
mod sign;
#[cfg(not(feature = "signoff"))]
#[path = "sign_disabled.rs"]
mod sign;
pub mod simulate;
mod sweeps;
mod trend;
mod validate;

pub use args::{CameraArgs, DetailArg, LimitArgs, PwmArgs, ShutterArg, report_date};
pub use campaign::check_database_outside;
pub use failure::Failure;

pub use crate::exit::ExitCode;

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

/// The subcommands; each variant's doc comment is its `--help` summary.
#[derive(Subcommand, Debug)]
enum Command {
    /// Run a test plan and write results.json, traces, charts, report.html,
    /// report.pdf, junit.xml and summary.csv.
    Plan(plan::PlanArgs),
    /// Check the shard directories of a sharded run (`plan --shard`) and
    /// write the whole plan's report, as one `plan` run would have.
    Merge(merge::MergeArgs),
    /// List the plans built into ledflicker; `plans show NAME` prints one
    /// as TOML, to save and edit (`ledflicker plans show daylight >
    /// my-camera.toml`).
    Plans(plans::PlansArgs),
    /// Check a test plan without running it.
    Validate {
        /// Plan file, or a plan name from test-plans/ (e.g. `daylight`).
        plan: String,
        #[command(flatten)]
        limits: args::LimitArgs,
    },
    /// Probe the ideal camera for one condition; prints a CSV trace, or with
    /// --summary one JSON object of metrics.
    Simulate(simulate::SimulateArgs),
    /// Shortest exposure that never loses a PWM LED over a frequency and a
    /// duty range, the flicker it leaves and its motion-blur cost.
    Advise(advise::AdviseArgs),
    /// Speed against error of the integration methods, whole-plan times, and
    /// the time of the analytic fine map (worst-phase FDI and Percent Flicker
    /// over 50 Hz..2 kHz x 1..100 % duty) for a plan's camera.
    Bench(bench::BenchArgs),
    /// Estimate a rolling shutter's line time from frames of a diffusely
    /// lit PWM scene; prints the line time in microseconds on the first line.
    /// Exit code 7 when the frames give no confident estimate.
    Linetime(calibrate::LinetimeArgs),
    /// Render ideal-camera frames (ON, OFF, PWM) as grey PNG files.
    Render(render::RenderArgs),
    /// A lab rig's light source: `rig check PLAN` connects, prints its
    /// identity, error queue and settings, and lights nothing.
    Rig(rig::RigArgs),
    /// Draw a plan's ROIs, named, on the first frame of each capture (PNG,
    /// full resolution) and print them as a table; with --detect CAPTURE,
    /// propose LED ROIs from the capture's ON -> OFF step as `[[roi]]` blocks.
    Roi(roi::RoiArgs),
    /// Write one case's trace CSV and frames from a report directory's
    /// case store (cases.sqlite), as a `--detail full` run writes them: a
    /// large run's report writes them for its listed cases only.
    Export(export::ExportArgs),
    /// Estimate a PWM frequency from the band spacing of rolling-shutter
    /// frames with a known line time; prints JSON. Exit code 7 when the
    /// frames give no confident estimate.
    Bands(calibrate::BandsArgs),
    /// Fit a rolling-shutter camera model (line time, exposure, duty, black
    /// level, saturation, tone curve) to banding frames of a PWM light;
    /// writes a camera profile with --out. Exit code 7 when the frames give
    /// no confident estimate.
    Calibrate(calibrate::CalibrateArgs),
    /// A light source's flicker from a photodiode or oscilloscope record
    /// (CSV: time in seconds, intensity): IEEE 1789 risk, fundamental,
    /// Percent Flicker, Flicker Index, SVM and PstLM.
    Light(light::LightArgs),
    /// Make an ECDSA P-256 private key (FILE, PKCS#8 PEM, mode 0600) and a
    /// self-signed X.509 certificate (FILE with `.crt`, PEM) for signing.
    Keygen(sign::KeygenArgs),
    /// Sign a report directory: a PDF signature in report.pdf and a CMS
    /// signature (signoff.p7s) of manifest.txt.
    Sign(sign::SignArgs),
    /// Check every hash and signature of a signed report directory.
    Verify(sign::VerifyArgs),
    /// Record existing report directories in the results database
    /// (docs/campaigns.md); a signed one is verified and marked `intact`
    /// or `broken`.
    Import(campaign::ImportArgs),
    /// List the runs in the results database as a table, or JSON with
    /// --json, filtered by camera, serial, firmware, plan, date or verdict.
    History(campaign::HistoryArgs),
    /// Compare two runs, case by case and ROI by ROI: each KPI's change,
    /// verdict flips, and a noise-aware regression gate. Exit code 1 on a
    /// regression.
    Compare(compare::CompareArgs),
    /// One KPI over the recorded runs, per case and ROI, filtered by
    /// camera, firmware and plan: a table, JSON, or an SVG chart.
    Trend(trend::TrendArgs),
    /// Print a shell completion script, e.g. `ledflicker completions bash >
    /// ~/.local/share/bash-completion/completions/ledflicker`.
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff), e.g. `ledflicker man | man -l -`, or
    /// a subcommand's page (`ledflicker man plan`, the page `ledflicker-plan(1)`).
    Man {
        /// A subcommand, and a subcommand of it (`rig check`); without
        /// it, the page of `ledflicker` itself.
        subcommand: Vec<String>,
    },
}

/// The command line's definition, for completions and the manual page;
/// `--version` prints `version`.
fn command(version: &'static str) -> clap::Command {
    <Cli as clap::CommandFactory>::command().version(version)
}

/// The run's inputs, hashed ([`crate::inputs::collect`]): a file that
/// cannot be read is the user's input error (exit 2); hashing stopped by
/// Ctrl-C is the signal's exit.
pub fn collect_inputs(plan: &crate::plan::Plan) -> Result<Vec<crate::inputs::InputFile>, Failure> {
    crate::inputs::collect(plan).map_err(|e| match crate::interrupt::check() {
        Err(stop) => Failure::from(stop),
        Ok(()) => Failure::from(UsageError(e.to_string())),
    })
}

/// Runs the CLI and returns the process exit code; `--version` prints
/// `version`.
pub fn main(version: &'static str) -> i32 {
    let matches = command(version).get_matches();
    let cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    match run(cli, version) {
        Ok(code) => code.code(),
        Err(err) => {
            eprintln!("error: {}", err.message());
            err.exit_code().code()
        }
    }
}

fn run(cli: Cli, version: &'static str) -> Result<ExitCode, Failure> {
    match cli.command {
        Command::Plan(args) => plan::run_plan(args),
        Command::Merge(args) => merge::merge(args),
        Command::Plans(args) => plans::plans(args),
        Command::Validate { plan, limits } => validate::validate(&plan, limits.limits(false)),
        Command::Simulate(args) => simulate::simulate(args),
        Command::Advise(args) => advise::advise(args),
        Command::Bench(args) => bench::bench(args),
        Command::Linetime(args) => calibrate::linetime(args),
        Command::Render(args) => render::render(args),
        Command::Rig(args) => rig::rig(args),
        Command::Roi(args) => roi::roi(args),
        Command::Export(args) => export::export(args),
        Command::Bands(args) => calibrate::bands(args),
        Command::Calibrate(args) => calibrate::calibrate(args),
        Command::Light(args) => light::light(args),
        Command::Keygen(args) => sign::keygen(args),
        Command::Sign(args) => sign::sign(args),
        Command::Verify(args) => sign::verify(args),
        Command::Import(args) => campaign::import(args),
        Command::History(args) => campaign::history(args),
        Command::Compare(args) => compare::compare(args),
        Command::Trend(args) => trend::trend(args),
        Command::Completions { shell } => {
            clap_complete::generate(
                shell,
                &mut command(version),
                "ledflicker",
                &mut output::Stdout,
            );
            Ok(ExitCode::Pass)
        }
        Command::Man { subcommand } => manual::man(command(version), &subcommand),
    }
}
