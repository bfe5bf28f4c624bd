//! `ledflicker plan`: runs a test plan and writes its report directory
//! (results.json, traces, charts, report.html, report.pdf, junit.xml,
//! summary.csv), optionally signed and compared with a golden run. With
//! `--shard` it hands over to [`super::shard`].
//!
//! The run goes in stages, one function each: load the plan, prepare the
//! output (refusals before any work), build the backend, run the cases;
//! then [`crate::pipeline::report`] analyses, writes, signs and swaps the
//! report in, and this module prints its outcome.

use super::output::{out, outln};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::args::{ReportArgs, report_date};
use super::sign::signing;
use super::{ExitCode, Failure};
use crate::backend::PlanBackend;
use crate::error::UsageError;
use crate::pipeline::{
    self, Golden, Outcome, PlanRunError, Progress, ReportOptions, RunProgress, Status,
};
use crate::plan::{self, Plan};
use crate::report;

#[derive(Args, Debug)]
pub(super) struct PlanArgs {
    /// Plan file, or a plan name from test-plans/ (e.g. `daylight`).
    plan: String,
    #[command(flatten)]
    report: ReportArgs,
    #[command(flatten)]
    record: super::campaign::RecordArgs,
    /// Worker threads [default: one per core]. Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
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
    /// Print where the wall time went (plan, run, report parts), each part
    /// with the process's peak memory so far, to stderr.
    #[arg(long)]
    timings: bool,
    /// Run only shard K of N (numbered from 0) and write a shard directory
    /// to --out for `ledflicker merge`, no report; `auto` reads a Slurm
    /// array task or a Kubernetes Indexed Job (docs/scale-out.md).
    #[arg(long, requires = "out", conflicts_with_all = ["golden", "sign_key"])]
    shard: Option<String>,
    /// Continue the interrupted or killed run whose report was to go to
    /// DIR, from the cases it stored (docs/store.md); the plan and its
    /// inputs must be those of that run.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["out", "shard"])]
    resume: Option<PathBuf>,
    /// Report profile: a TOML file with a `[report]` table (company, logo,
    /// document number, labels, sections, templates), whose keys win over
    /// the plan's `[report]` one by one (docs/plan-format.md).
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// Print the cases and every line the light source (`[source]`) would
    /// be sent, with the planned times; connect to nothing, run nothing.
    #[arg(long, conflicts_with_all = ["shard", "resume"])]
    dry_run: bool,
    /// Keep each case's recording (a command plan's frames or capture
    /// file) in the report directory's `captures/<case id>/`, named in
    /// results.json; by default it is removed after the analysis.
    #[arg(long, conflicts_with = "shard")]
    keep_captures: bool,
}

/// The folder of the report directory that `--keep-captures` fills, one
/// folder per case.
const CAPTURES_DIR: &str = "captures";

pub(super) fn run_plan(args: PlanArgs) -> Result<ExitCode, Failure> {
    if args.timings {
        crate::timings::enable();
    }
    let total = crate::timings::span("total");
    let (plan, date) = load(&args)?;
    if args.dry_run {
        return super::rig::dry_run(&plan);
    }
    if let Some(spec) = &args.shard {
        return shard(&args, &plan, spec);
    }
    let out = args
        .resume
        .clone()
        .or_else(|| args.report.out.clone())
        .unwrap_or_else(|| PathBuf::from("reports").join(&plan.id));
    let (generation, options) = prepare(&args, &out, date)?;
    let (backend, inputs, generation) = set_up(&args, &plan, generation, &out)?;
    let outcome = run_and_report(&args, &out, &plan, &backend, inputs, options, generation)?;
    finish(&args, &outcome, total)
}

/// The run and report stages ([`pipeline::run_plan`]) with their progress
/// on the terminal; a run that stopped with cases stored keeps them for
/// `--resume`.
fn run_and_report(
    args: &PlanArgs,
    out: &Path,
    plan: &Plan,
    backend: &PlanBackend,
    inputs: Vec<crate::inputs::InputFile>,
    options: ReportOptions,
    generation: crate::outdir::Generation,
) -> Result<Outcome, Failure> {
    // Made on the report stage's first progress: it ticks from its start.
    let stage = std::sync::OnceLock::new();
    let resume_hint = |stored: usize| {
        format!(
            "the {stored} cases of the run are kept beside `{}`; continue with `ledflicker plan {} --resume {}` (it goes straight to the report)",
            out.display(),
            args.plan,
            out.display()
        )
    };
    let run = pipeline::PlanRun {
        plan,
        backend,
        inputs,
        threads: args.threads,
        resume: args.resume.is_some(),
        options,
        resume_hint: Some(&resume_hint),
    };
    let bar = case_bar(0, args.report.quiet);
    let progress = run_progress(&bar, plan, args);
    let outcome = pipeline::run_plan(run, generation, &progress, &|p| {
        show_progress(stage.get_or_init(|| report_spinner(args.report.quiet)), p)
    });
    match outcome {
        Ok(outcome) => Ok(outcome),
        Err(PlanRunError::Stopped(run)) => {
            let (error, kept) = run.keep_for_resume();
            match (kept, error.store_refused()) {
                (Some(kept), Some(refused)) => say_refused(&kept, refused, args),
                (Some(kept), None) => say_kept(&kept, args, out),
                (None, _) => {}
            }
            Err(error.into())
        }
        Err(PlanRunError::Report(e)) => Err(e.into()),
    }
}

/// `--shard K/N`: this shard's cases into a shard directory, no report.
fn shard(args: &PlanArgs, plan: &Plan, spec: &str) -> Result<ExitCode, Failure> {
    let spec = crate::shard::ShardSpec::parse(spec, &|k| std::env::var(k).ok())?;
    super::shard::check_share(plan, spec, args.report.limits.limits(false))?;
    super::shard::run_shard(&super::shard::ShardRun {
        plan,
        spec,
        out: args.report.out.as_deref().unwrap_or(Path::new(".")),
        threads: args.threads,
        force: args.report.force,
        quiet: args.report.quiet,
    })
}

/// Everything refused before any time goes into the run: the output
/// directory (a new generation, or the one to resume), the golden results
/// and the signing key; gives the new generation and the report options.
fn prepare(
    args: &PlanArgs,
    out: &Path,
    date: String,
) -> Result<(crate::outdir::Generation, ReportOptions), Failure> {
    args.record.check_outside(out)?;
    let generation = match &args.resume {
        None => pipeline::begin_output(out, args.report.force)?,
        Some(dir) => pipeline::resume_output(dir, args.report.force)?,
    };
    let golden = golden(args)?;
    let signing = signing(
        &super::args::SignOptions {
            key: args.sign_key.as_deref(),
            cert: args.sign_cert.as_deref(),
            signer: args.signer.as_deref(),
        },
        out,
    )?;
    let options = ReportOptions {
        date,
        force: args.report.force,
        detail: args.report.detail.into(),
        signing,
        golden,
        resume_hint: None,
    };
    Ok((generation, options))
}

/// The backend and the inputs of the run. A failure keeps what a resumed
/// run had stored for another `--resume`.
fn set_up(
    args: &PlanArgs,
    plan: &Plan,
    generation: crate::outdir::Generation,
    out: &Path,
) -> Result<
    (
        PlanBackend,
        Vec<crate::inputs::InputFile>,
        crate::outdir::Generation,
    ),
    Failure,
> {
    let resuming = args.resume.is_some();
    let stop = |failure: Failure, generation| {
        Err(keep_for_resume(failure, resuming, generation, args, out))
    };
    let mut backend = match build_backend(plan, args.report.quiet) {
        Ok(backend) => backend,
        Err(e) => return stop(e, generation),
    };
    if args.keep_captures
        && let Err(e) = keep_captures(plan, &mut backend, generation.path())
    {
        return stop(e, generation);
    }
    // After the backend has checked that the captures exist.
    match super::collect_inputs(plan) {
        Ok(inputs) => Ok((backend, inputs, generation)),
        Err(e) => stop(e, generation),
    }
}

/// `--keep-captures`: a command plan's recordings go to the report's
/// [`CAPTURES_DIR`]; any other backend records nothing to keep.
fn keep_captures(plan: &Plan, backend: &mut PlanBackend, dir: &Path) -> Result<(), Failure> {
    match backend {
        PlanBackend::Command(rig) => {
            rig.keep_captures(dir.join(CAPTURES_DIR), CAPTURES_DIR);
            Ok(())
        }
        _ => {
            let kind = match plan.dut.backend {
                plan::BackendKind::Captured => "captured",
                _ => "simulator",
            };
            Err(UsageError(format!(
                "--keep-captures: plan `{}` records nothing to keep (its backend is {kind})\n    hint: only a command plan (`[dut] backend = \"command\"`) records captures",
                plan.id
            ))
            .into())
        }
    }
}

/// The signature, the summary table, the drift from `--golden`, the
/// `--timings` table (after the "total" span ends) and the exit code.
fn finish(
    args: &PlanArgs,
    outcome: &Outcome,
    total: crate::timings::Guard,
) -> Result<ExitCode, Failure> {
    if let Some(s) = outcome.signed.as_ref().filter(|_| !args.report.quiet) {
        outln!(
            "signed by {} (certificate SHA-256 {})",
            s.signer,
            s.fingerprint
        )?;
    }
    if let Some(warning) = &outcome.warning {
        eprintln!("{warning}");
    }
    super::campaign::record_finished(
        &args.record,
        &outcome.model,
        &outcome.dir,
        crate::campaign::record::Source::Plan,
        outcome.signed.as_ref().map(|s| s.signer.as_str()),
    );
    if !args.report.quiet {
        print_summary(&outcome.model, &outcome.dir, args.report.all_cases)?;
    }
    let kept = outcome
        .model
        .cases
        .iter()
        .filter(|c| c.capture.as_ref().is_some_and(|s| s.kept.is_some()))
        .count();
    if kept > 0 {
        eprintln!(
            "kept {kept} recording(s) in `{}`",
            outcome.dir.join(CAPTURES_DIR).display()
        );
    }
    if let Some(cmp) = &outcome.golden {
        out!("{}", cmp.to_text())?;
    }
    drop(total);
    if args.timings {
        eprint!("{}", crate::timings::table(&crate::timings::take()));
    }
    Ok(exit_code(outcome.status()))
}

/// The exit code of a report's [`Status`] (`plan` and `merge`).
pub(super) fn exit_code(status: Status) -> ExitCode {
    match status {
        Status::Pass => ExitCode::Pass,
        Status::Fail => ExitCode::Fail,
        Status::NotJudged => ExitCode::NotJudged,
    }
}

/// The plan and the report date, checked with `--threads`.
fn load(args: &PlanArgs) -> Result<(Plan, String), Failure> {
    let t = crate::timings::span("load and validate plan");
    // A shard is checked against its own share once its spec is read
    // ([`super::shard::check_share`]), not against the whole plan.
    let limits = if args.shard.is_some() {
        plan::ResourceLimits::unbounded()
    } else {
        args.report.limits()
    };
    let mut plan = crate::pipeline::load_plan(&args.plan, limits)?;
    eprint!("{}", plan.warnings_text());
    if let Some(path) = &args.profile {
        let profile = plan::load_report_profile(path)?;
        plan.report = std::mem::take(&mut plan.report).overridden_by(profile);
    }
    drop(t);
    let date = report_date(args.report.date.as_deref())?;
    if args.threads == Some(0) {
        return Err(UsageError("--threads must be at least 1".into()).into());
    }
    Ok((plan, date))
}

/// `--golden`: the tolerances and the stored results, read now, so that a
/// bad file fails before the run.
fn golden(args: &PlanArgs) -> Result<Option<Golden>, Failure> {
    let mut tolerances = report::golden::Tolerances::default();
    for t in &args.golden_tolerance {
        tolerances.set(t).map_err(UsageError)?;
    }
    args.golden
        .as_deref()
        .map(|p| Golden::load(p, tolerances))
        .transpose()
        .map_err(Failure::from)
}

/// The report stage's progress on the spinner of [`report_spinner`].
fn show_progress(stage: &ProgressBar, p: Progress) {
    match p {
        Progress::Analysing { cases } => stage.set_message(format!("analysing {cases} cases")),
        Progress::Writing => {
            stage.set_message("drawing charts, writing report.html and report.pdf".to_string());
        }
        Progress::Pictures { drawn, planned } => stage.set_message(if drawn < planned {
            format!("laying out report.pdf, writing report.html; pictures {drawn}/{planned} drawn")
        } else {
            format!("laying out report.pdf ({planned} pictures drawn)")
        }),
        Progress::Written => stage.finish_and_clear(),
    }
}

/// The plan's backend; a captured plan's captures are read now, under a
/// "frames decoded" spinner.
fn build_backend(plan: &Plan, quiet: bool) -> Result<PlanBackend, Failure> {
    let decoding = (plan.dut.backend == plan::BackendKind::Captured).then(|| decode_spinner(quiet));
    let backend = crate::backend::for_plan(plan, None);
    if let Some(d) = decoding {
        d.finish_and_clear();
    }
    Ok(backend?)
}

/// A run that stopped with cases stored (or a resumed run that stopped)
/// keeps its store for `--resume`; the error is passed on.
fn keep_for_resume(
    failure: Failure,
    stored: bool,
    generation: crate::outdir::Generation,
    args: &PlanArgs,
    out: &Path,
) -> Failure {
    if stored {
        say_kept(&generation.keep_for_resume(), args, out);
    }
    failure
}

/// Where the cases of a stopped run are kept, and how to continue it.
fn say_kept(kept: &Path, args: &PlanArgs, out: &Path) {
    eprintln!(
        "the cases stored so far are kept in `{}`; continue the run with `ledflicker plan {} --resume {}`",
        kept.display(),
        args.plan,
        out.display()
    );
}

/// Where the cases of a store that `--resume` refused are kept, and what
/// to do instead: resuming it again would fail the same way.
fn say_refused(kept: &Path, refused: &crate::store::StoreError, args: &PlanArgs) {
    let what = match refused {
        crate::store::StoreError::Mismatch { .. } => {
            "they are another run's (below): resume them with the plan that made them, or"
        }
        _ => "one cannot be read (below):",
    };
    eprintln!(
        "the stored cases are left as they were in `{}`; {what} run `ledflicker plan {}` without `--resume` to start afresh",
        kept.display(),
        args.plan,
    );
}

/// The run stage's progress on `bar`, and the number of cases a resumed
/// run kept, on stderr.
fn run_progress<'a>(
    bar: &'a ProgressBar,
    plan: &Plan,
    args: &'a PlanArgs,
) -> impl Fn(RunProgress) + Sync + 'a {
    // Its length comes with `Started`: the run stage expands the plan.
    bar.set_message(plan.id.clone());
    move |p: RunProgress| match p {
        RunProgress::Resumed { kept, total } if !args.report.quiet => eprintln!(
            "resumed: {kept} of {total} cases kept from the partial store (judged again from their data); {} to run",
            total - kept
        ),
        RunProgress::Resumed { .. } => {}
        RunProgress::Started { total, done } => {
            bar.set_length(total as u64);
            // The rate and ETA count from here: the stored cases took no
            // time now.
            bar.set_position(done as u64);
            bar.reset_eta();
        }
        RunProgress::CaseFinished => bar.inc(1),
        RunProgress::Finished => bar.finish_and_clear(),
    }
}

fn print_summary(model: &crate::model::Results, out: &Path, all: bool) -> Result<(), Failure> {
    let mut w = super::output::Stdout;
    w.write_all(report::terminal::summary(model, out, all).as_bytes())?;
    Ok(())
}

/// The cases' progress bar on a terminal; hidden with -q or off a terminal.
fn case_bar(cases: usize, quiet: bool) -> ProgressBar {
    let bar = if !quiet && std::io::stderr().is_terminal() {
        ProgressBar::with_draw_target(Some(cases as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} {msg:>10} [{bar:30}] {pos}/{len} cases, {elapsed}, {per_sec}, {eta} left",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar
}

/// "report: <stage> (elapsed)" on a terminal: the report stage takes
/// seconds on large plans, so say what it does.
fn report_spinner(quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let s = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    s.set_style(
        ProgressStyle::with_template("{spinner} report: {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    s.enable_steady_tick(std::time::Duration::from_millis(120));
    s
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
