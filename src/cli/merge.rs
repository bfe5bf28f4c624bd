//! `ledflicker merge --out DIR SHARD_DIR...`: reads back the shard
//! directories of a sharded run (crate::shard::merge) and writes the whole
//! plan's report through the same report stage as `plan`.

use super::output::{out, outln};
use std::path::PathBuf;

use super::failure::Context;
use clap::Args;

use super::args::{DetailArg, report_date};
use super::{EXIT_FAIL, EXIT_NOT_JUDGED, EXIT_PASS, Failure};
use crate::metrics::Verdict;
use crate::report::{self, WriteOptions};

/// `ledflicker merge` arguments.
#[derive(Args, Debug)]
pub(super) struct MergeArgs {
    /// Shard directories written by `plan --shard`, or a quoted glob of
    /// them such as 'shards/*' (`*` and `?` in the last path component).
    #[arg(required = true)]
    shards: Vec<String>,
    /// Output directory [default: reports/<plan-id>/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// The plan, when it is no longer where the shards read it [default:
    /// the shards' plan path, as given, else as an absolute path].
    #[arg(long)]
    plan: Option<PathBuf>,
    /// Report date, YYYY-MM-DD [default: $SOURCE_DATE_EPOCH, else today].
    #[arg(long)]
    date: Option<String>,
    /// Replace a signed report in the output directory.
    #[arg(long)]
    force: bool,
    /// Print no summary table.
    #[arg(long, short)]
    quiet: bool,
    /// How much of each case the report shows (as for `plan`).
    #[arg(long, value_enum, default_value_t = DetailArg::Standard)]
    detail: DetailArg,
}

/// Checks the shards, then writes the report of the whole plan.
pub(super) fn merge(a: MergeArgs) -> Result<i32, Failure> {
    let date = report_date(a.date.as_deref())?;
    let m = crate::shard::merge::gather(&a.shards, a.plan.as_deref())?;
    let plan = &m.plan;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports").join(&plan.id));
    crate::outdir::check_overwrite(&out, a.force)?;
    let generation = crate::outdir::Generation::begin(&out)?;
    crate::interrupt::install();
    // Ctrl-C acts within a fraction of a second in the analyses and the
    // PDF layout too, where no loop of ours looks at it.
    let prompt = crate::interrupt::Prompt::start(generation.path().to_path_buf());
    let model = crate::model::assemble(plan, &m.manifest.backend, &m.results);
    crate::interrupt::check()?;
    report::write_report(
        generation.path(),
        &model,
        &m.results,
        &WriteOptions {
            date,
            force: a.force,
            signatories: Vec::new(),
            inputs: m.manifest.inputs.iter().map(Into::into).collect(),
            detail: a.detail.into(),
            reuse_from: generation.previous().map(std::path::Path::to_path_buf),
        },
    )
    .with_context(|| format!("cannot write the report to `{}`", out.display()))?;
    drop(prompt);
    crate::interrupt::check()?;
    if let Some(warning) = generation.commit()?.warning() {
        eprintln!("{warning}");
    }
    if !a.quiet {
        outln!(
            "merged {} shards ({} cases) of plan `{}`",
            m.shards,
            m.results.len(),
            plan.id
        )?;
        out!("{}", report::terminal::summary(&model, &out))?;
    }
    Ok(match model.verdict {
        Verdict::Fail => EXIT_FAIL,
        Verdict::Info => EXIT_NOT_JUDGED,
        Verdict::Pass => EXIT_PASS,
    })
}
