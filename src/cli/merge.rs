//! `ledflicker merge --out DIR SHARD_DIR...`: reads back the shard
//! directories of a sharded run (crate::shard::merge) and writes the whole
//! plan's report through the same [`crate::pipeline::report`] as `plan`.

use super::output::{out, outln};
use std::path::PathBuf;

use clap::Args;

use super::args::{ReportArgs, report_date};
use super::{ExitCode, Failure};
use crate::pipeline::{self, ReportOptions};
use crate::report;

/// `ledflicker merge` arguments.
#[derive(Args, Debug)]
pub(super) struct MergeArgs {
    /// Shard directories written by `plan --shard`, or a quoted glob of
    /// them such as 'shards/*' (`*` and `?` in the last path component).
    #[arg(required = true)]
    shards: Vec<String>,
    /// The plan, when it is no longer where the shards read it [default:
    /// the shards' plan path, as given, else as an absolute path].
    #[arg(long)]
    plan: Option<PathBuf>,
    #[command(flatten)]
    report: ReportArgs,
    #[command(flatten)]
    record: super::campaign::RecordArgs,
}

/// Checks the shards, then writes the report of the whole plan.
pub(super) fn merge(a: MergeArgs) -> Result<ExitCode, Failure> {
    let date = report_date(a.report.date.as_deref())?;
    let m = crate::shard::merge::gather(&a.shards, a.plan.as_deref())?;
    let limits = a.report.limits();
    if let Some(message) =
        crate::plan::WorkEstimate::merge_too_large(&m.plan, m.largest_shard(), limits)
    {
        return Err(crate::error::UsageError(format!(
            "cannot merge the {} shards of plan `{}`: {message}\n    hint: raise the limit, or run the plan in more shards (the largest holds {} cases)",
            m.shards,
            m.plan.id,
            m.largest_shard()
        ))
        .into());
    }
    let out = a
        .report
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports").join(&m.plan.id));
    a.record.check_outside(&out)?;
    let generation = pipeline::begin_output(&out, a.report.force)?;
    // The cases go from the shards to the store one shard at a time, and
    // the report stage reads them back from it, as `plan`'s does.
    let key = crate::store::RunKey {
        plan_id: m.plan.id.clone(),
        plan_hash: m.manifest.plan_hash.clone(),
        tool: m.manifest.tool.clone(),
        backend: m.manifest.backend.clone(),
        case_count: m.manifest.case_count,
    };
    let mut store = crate::store::Store::create(generation.path(), &key)?;
    m.read_cases(|c| store.put(c.case.index, c).map_err(Failure::from))?;
    let path = store.finish()?;
    let stored = crate::store::StoredCases::open(&path)?;
    let outcome = pipeline::report(
        pipeline::Run {
            plan: &m.plan,
            backend_id: &m.manifest.backend,
            results: &stored,
            inputs: m.manifest.inputs.iter().map(Into::into).collect(),
        },
        generation,
        ReportOptions {
            date,
            force: a.report.force,
            detail: a.report.detail.into(),
            signing: None,
            golden: None,
            resume_hint: None,
        },
        &|_| {},
    )?;
    if let Some(warning) = &outcome.warning {
        eprintln!("{warning}");
    }
    super::campaign::record_finished(
        &a.record,
        &outcome.model,
        &outcome.dir,
        crate::campaign::record::Source::Merge,
        None,
    );
    if !a.report.quiet {
        outln!(
            "merged {} shards ({} cases) of plan `{}`",
            m.shards,
            outcome.cases,
            m.plan.id
        )?;
        out!(
            "{}",
            report::terminal::summary(&outcome.model, &outcome.dir, a.report.all_cases)
        )?;
    }
    Ok(super::plan::exit_code(outcome.status()))
}
