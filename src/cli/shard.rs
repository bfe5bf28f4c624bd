//! `ledflicker plan PLAN --shard K/N --out DIR`: runs one share of the
//! cases and writes a shard directory for `merge` (crate::shard::write).

use super::output::outln;
use std::path::Path;

use super::failure::Context;

use super::{ExitCode, Failure};
use crate::error::UsageError;
use crate::plan::{self, Plan};
use crate::runner;
use crate::shard::write::{ShardOutput, write_dir};
use crate::shard::{ShardSpec, assign};

/// A shard run of `plan`.
pub(super) struct ShardRun<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Which share of its cases.
    pub spec: ShardSpec,
    /// The shard directory.
    pub out: &'a Path,
    /// Worker threads.
    pub threads: Option<usize>,
    /// Replace a signed report at `out`.
    pub force: bool,
    /// Print nothing on success.
    pub quiet: bool,
}

/// Refuses a shard whose own share of `plan`'s cases does not fit
/// `limits` (a plan too large for one machine is split into shards, so
/// each is held to what it runs), naming the figure and the flag.
pub(super) fn check_share(
    plan: &Plan,
    spec: ShardSpec,
    limits: plan::ResourceLimits,
) -> Result<(), Failure> {
    let all = plan::expand_cases(plan);
    let mine = assign::cases_of(plan, &all, spec).len();
    match plan::WorkEstimate::shard_too_large(plan, mine, limits) {
        None => Ok(()),
        Some(message) => Err(plan::PlanError::Invalid {
            path: plan.source_label().into(),
            diagnostics: vec![plan::Diagnostic {
                file: None,
                key: "grid".to_string(),
                location: None,
                message: format!("shard {spec} ({mine} of {} cases): {message}", all.len()),
                hint: Some("split the plan into more shards, or raise the limit".to_string()),
            }],
        }
        .into()),
    }
}

/// Runs one shard and writes its directory. Exit 0 whatever the verdicts:
/// the merge judges (a failing case must not stop a dependent merge job).
pub(super) fn run_shard(r: &ShardRun<'_>) -> Result<ExitCode, Failure> {
    let plan = r.plan;
    if r.threads == Some(0) {
        return Err(UsageError("--threads must be at least 1".into()).into());
    }
    // As `plan`: never a signed report without --force, never a user's folder.
    let generation = crate::pipeline::begin_output(r.out, r.force)?;
    let all = plan::expand_cases(plan);
    let mine = assign::cases_of(plan, &all, r.spec);
    // Read only this shard's captures.
    let backend = crate::backend::for_plan(plan, Some(&mine))?;
    let inputs = super::collect_inputs(plan)?;
    let mut results = runner::run(plan, &mine, &backend, r.threads, &|_| {})
        .with_context(|| format!("run of shard {} of plan `{}` failed", r.spec, plan.id))?;
    runner::render_sample_frames(plan, &mut results, &backend)
        .with_context(|| format!("cannot render the sample frames of plan `{}`", plan.id))?;
    let manifest = write_dir(
        generation.path(),
        ShardOutput {
            plan,
            spec: r.spec,
            case_count: all.len(),
            cases: mine.iter().map(|c| c.index).collect(),
            inputs: &inputs,
            backend_id: crate::backend::Backend::id(&backend).to_string(),
            results,
        },
    )?;
    crate::interrupt::check()?;
    if let Some(warning) = generation.commit()?.warning() {
        eprintln!("{warning}");
    }
    if !r.quiet {
        outln!(
            "shard {} of plan `{}`: {} of {} cases written to {}; merge with `ledflicker merge --out DIR SHARD_DIR...`",
            r.spec,
            plan.id,
            manifest.cases.len(),
            manifest.case_count,
            r.out.display()
        )?;
    }
    Ok(ExitCode::Pass)
}
