//! `ledflicker plan PLAN --shard K/N --out DIR` (a shard run) and
//! `ledflicker merge --out DIR SHARD_DIR...`; `cli.rs` dispatches to them.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

use super::record::{self, CASES, MANIFEST, Manifest, ShardCase};
use super::{ShardSpec, assign};
use crate::backend::Backend;
use crate::backend::captured::Captured;
use crate::backend::command::CommandRig;
use crate::backend::sim::Simulator;
use crate::cli::UsageError;
use crate::metrics::Verdict;
use crate::plan::{self, BackendKind, Plan};
use crate::report::{self, WriteOptions};
use crate::runner::{self, CaseResult};

/// `ledflicker merge` arguments.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Shard directories written by `plan --shard`, or a quoted glob of
    /// them such as 'shards/*' (`*` and `?` in the last path component).
    #[arg(required = true)]
    pub shards: Vec<String>,
    /// Output directory [default: reports/<plan-id>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The plan, when it is no longer where the shards read it [default:
    /// the shards' plan path, as given, else as an absolute path].
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// Report date, YYYY-MM-DD [default: $SOURCE_DATE_EPOCH, else today].
    #[arg(long)]
    pub date: Option<String>,
    /// Replace a signed report in the output directory.
    #[arg(long)]
    pub force: bool,
    /// Print no summary table.
    #[arg(long, short)]
    pub quiet: bool,
    /// How much of each case the report shows (as for `plan`).
    #[arg(long, value_enum, default_value_t = crate::cli::DetailArg::Standard)]
    pub detail: crate::cli::DetailArg,
}

/// A shard run of `plan` (read from `path`).
pub struct ShardRun<'a> {
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

/// Runs one shard and writes its directory. Exit 0 whatever the verdicts:
/// the merge judges (a failing case must not stop a dependent merge job).
pub fn run_shard(r: &ShardRun<'_>) -> anyhow::Result<i32> {
    let plan = r.plan;
    if r.threads == Some(0) {
        return Err(UsageError("--threads must be at least 1".into()).into());
    }
    // As `plan`: never a signed report without --force, never a user's folder.
    crate::outdir::check_overwrite(r.out, r.force)?;
    let generation = crate::outdir::Generation::begin(r.out)?;
    crate::interrupt::install();
    let all = plan::expand_cases(plan);
    let mine = assign::cases_of(plan, &all, r.spec);
    let sim;
    let mut captured = None;
    let mut rig = None;
    let backend: &dyn Backend = match plan.dut.backend {
        BackendKind::Simulator => {
            sim = Simulator::new(plan);
            &sim
        }
        BackendKind::Captured => {
            // Read only this shard's captures.
            let mut own = plan.clone();
            if let Some(c) = &mut own.capture {
                c.cases.retain(|k| mine.iter().any(|m| m.id == k.id));
            }
            &*captured.insert(
                Captured::load(&own)
                    .with_context(|| format!("cannot read the captures of plan `{}`", plan.id))?,
            )
        }
        BackendKind::Command => &*rig.insert(
            CommandRig::new(plan)
                .ok_or_else(|| UsageError("the plan has no [capture] command".into()))?,
        ),
    };
    let inputs = crate::inputs::collect(plan).map_err(|e| UsageError(e.to_string()))?;
    let mut results = runner::run(plan, &mine, backend, r.threads, &|_| {})
        .with_context(|| format!("run of shard {} of plan `{}` failed", r.spec, plan.id))?;
    runner::render_sample_frames(plan, &mut results, backend)
        .with_context(|| format!("cannot render the sample frames of plan `{}`", plan.id))?;
    let backend_id = backend.id().to_string();
    let traces: Vec<(String, String)> = results
        .iter()
        .map(|c| (format!("{}.csv", c.case.id), report::trace_csv(c)))
        .collect();
    let records: Vec<ShardCase> = results
        .into_iter()
        .map(|mut result| {
            let capture_signal = result
                .acquisition
                .capture
                .as_mut()
                .map(|s| std::mem::take(&mut s.segments.signal))
                .unwrap_or_default();
            ShardCase {
                result,
                capture_signal,
            }
        })
        .collect();
    let bytes = record::encode_cases(&records)
        .map_err(|e| anyhow::anyhow!("cannot encode the case results: {e}"))?;
    let manifest = Manifest {
        schema: record::SCHEMA.to_string(),
        tool: tool(),
        plan_id: plan.id.clone(),
        plan_path: plan.path.display().to_string(),
        plan_path_absolute: std::path::absolute(&plan.path)
            .unwrap_or_else(|_| plan.path.clone())
            .display()
            .to_string(),
        plan_hash: record::plan_hash(&inputs),
        seed: plan.seed,
        backend: backend_id,
        shard: r.spec,
        case_count: all.len(),
        cases: mine.iter().map(|c| c.index).collect(),
        inputs: inputs.iter().map(Into::into).collect(),
        cases_sha256: record::sha256(&bytes),
    };
    write_shard_dir(generation.path(), &manifest, &bytes, &traces)?;
    crate::interrupt::check()?;
    generation.commit()?;
    if !r.quiet {
        println!(
            "shard {} of plan `{}`: {} of {} cases written to {}; merge with `ledflicker merge --out DIR SHARD_DIR...`",
            r.spec,
            plan.id,
            manifest.cases.len(),
            manifest.case_count,
            r.out.display()
        );
    }
    Ok(crate::cli::EXIT_PASS)
}

/// `ledflicker <version>`.
fn tool() -> String {
    format!("ledflicker {}", env!("CARGO_PKG_VERSION"))
}

fn write_shard_dir(
    dir: &Path,
    manifest: &Manifest,
    cases: &[u8],
    traces: &[(String, String)],
) -> anyhow::Result<()> {
    let write = |path: PathBuf, bytes: &[u8]| {
        std::fs::write(&path, bytes).with_context(|| format!("cannot write `{}`", path.display()))
    };
    write(dir.join(CASES), cases)?;
    let json = serde_json::to_string_pretty(manifest)?;
    write(dir.join(MANIFEST), format!("{json}\n").as_bytes())?;
    let traces_dir = dir.join("traces");
    std::fs::create_dir_all(&traces_dir)
        .with_context(|| format!("cannot create `{}`", traces_dir.display()))?;
    for (name, text) in traces {
        write(traces_dir.join(name), text.as_bytes())?;
    }
    Ok(())
}

/// `ledflicker merge`: checks the shards, then writes the report of the
/// whole plan through the same report stage as `plan`.
pub fn merge(a: MergeArgs) -> anyhow::Result<i32> {
    let date = crate::cli::report_date(a.date.as_deref())?;
    let dirs = expand_globs(&a.shards)?;
    let shards = dirs
        .iter()
        .map(|d| read_manifest(d))
        .collect::<Result<Vec<_>, _>>()?;
    check_shards(&shards)?;
    let first = &shards[0].1;
    let results = read_cases(&shards)?;
    let plan = load_plan(a.plan.as_deref(), first)?;
    let expected = plan::expand_cases(&plan);
    if let Some((want, got)) = expected.iter().zip(&results).find(|(w, g)| **w != g.case) {
        return Err(UsageError(format!(
            "case {} of the plan is `{}` but the shards ran `{}` there\n    hint: run every shard and the merge with the same plan",
            want.index, want.id, got.case.id
        ))
        .into());
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports").join(&plan.id));
    crate::outdir::check_overwrite(&out, a.force)?;
    let generation = crate::outdir::Generation::begin(&out)?;
    crate::interrupt::install();
    let model = crate::model::assemble(&plan, &first.backend, &results);
    crate::interrupt::check()?;
    report::write_report(
        generation.path(),
        &model,
        &results,
        &WriteOptions {
            date,
            force: a.force,
            signatories: Vec::new(),
            inputs: first.inputs.iter().map(Into::into).collect(),
            detail: a.detail.into(),
        },
    )
    .with_context(|| format!("cannot write the report to `{}`", out.display()))?;
    crate::interrupt::check()?;
    generation.commit()?;
    if !a.quiet {
        println!(
            "merged {} shards ({} cases) of plan `{}`",
            shards.len(),
            results.len(),
            plan.id
        );
        print!("{}", report::terminal::summary(&model, &out));
    }
    Ok(match model.verdict {
        Verdict::Fail => crate::cli::EXIT_FAIL,
        Verdict::Info => crate::cli::EXIT_NOT_JUDGED,
        Verdict::Pass => crate::cli::EXIT_PASS,
    })
}

/// Expands `*` and `?` in the last component of each argument; an argument
/// without them is taken as it is.
fn expand_globs(args: &[String]) -> Result<Vec<PathBuf>, UsageError> {
    let mut out = Vec::new();
    for arg in args {
        let path = Path::new(arg);
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        let Some(pattern) = name.filter(|n| n.contains(['*', '?']) && !path.exists()) else {
            out.push(path.to_path_buf());
            continue;
        };
        let parent = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let mut found: Vec<PathBuf> = std::fs::read_dir(parent)
            .map_err(|e| UsageError(format!("`{arg}`: cannot list `{}`: {e}", parent.display())))?
            .filter_map(|e| e.ok())
            .filter(|e| glob_match(&pattern, &e.file_name().to_string_lossy()))
            .filter(|e| e.path().join(MANIFEST).is_file())
            .map(|e| {
                if path.parent().is_some_and(|p| p.as_os_str().is_empty()) {
                    PathBuf::from(e.file_name())
                } else {
                    e.path()
                }
            })
            .collect();
        if found.is_empty() {
            return Err(UsageError(format!(
                "`{arg}` matches no shard directory (a directory with {MANIFEST})"
            )));
        }
        found.sort();
        out.extend(found);
    }
    Ok(out)
}

/// Shell-style match of `*` (any run) and `?` (one character).
fn glob_match(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    // matched[j]: the pattern so far matches name[..j].
    let mut matched = vec![false; n.len() + 1];
    matched[0] = true;
    for &c in &p {
        let mut next = vec![false; n.len() + 1];
        for j in 0..=n.len() {
            next[j] = match c {
                '*' => matched[j] || (j > 0 && next[j - 1]),
                '?' => j > 0 && matched[j - 1],
                _ => j > 0 && matched[j - 1] && n[j - 1] == c,
            };
        }
        matched = next;
    }
    matched[n.len()]
}

fn read_manifest(dir: &Path) -> Result<(PathBuf, Manifest), UsageError> {
    let path = dir.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        UsageError(format!(
            "`{}` is not a shard directory: cannot read {MANIFEST}: {e}\n    hint: shard directories are written by `ledflicker plan PLAN --shard K/N --out DIR`",
            dir.display()
        ))
    })?;
    let manifest: Manifest = serde_json::from_str(&text)
        .map_err(|e| UsageError(format!("`{}`: not a shard manifest: {e}", path.display())))?;
    if manifest.schema != record::SCHEMA {
        return Err(UsageError(format!(
            "`{}`: schema `{}`, this ledflicker reads `{}`",
            path.display(),
            manifest.schema,
            record::SCHEMA
        )));
    }
    Ok((dir.to_path_buf(), manifest))
}

/// Same plan, tool, seed and shard count everywhere; every shard `0..N`
/// exactly once. Every problem is listed, each naming its shards.
fn check_shards(shards: &[(PathBuf, Manifest)]) -> Result<(), UsageError> {
    let (dir0, m0) = &shards[0];
    let mut problems = Vec::new();
    let here = tool();
    if m0.tool != here {
        problems.push(format!(
            "`{}` was written by {}, this is {here}; merge with the version that ran the shards",
            dir0.display(),
            m0.tool
        ));
    }
    for (dir, m) in &shards[1..] {
        let mut differ = |what: &str, a: String, b: String| {
            if a != b {
                problems.push(format!(
                    "`{}` has {what} {b}, `{}` has {a}",
                    dir.display(),
                    dir0.display()
                ));
            }
        };
        differ("plan hash", m0.plan_hash.clone(), m.plan_hash.clone());
        differ("plan id", m0.plan_id.clone(), m.plan_id.clone());
        differ("tool", m0.tool.clone(), m.tool.clone());
        differ("seed", m0.seed.to_string(), m.seed.to_string());
        differ(
            "shard count",
            m0.shard.count.to_string(),
            m.shard.count.to_string(),
        );
        differ(
            "case count",
            m0.case_count.to_string(),
            m.case_count.to_string(),
        );
    }
    let n = m0.shard.count;
    let mut seen: Vec<Vec<&Path>> = vec![Vec::new(); n];
    for (dir, m) in shards {
        if m.shard.index < n && m.shard.count == n {
            seen[m.shard.index].push(dir);
        }
    }
    for (k, dirs) in seen.iter().enumerate().filter(|(_, d)| d.len() > 1) {
        let names: Vec<String> = dirs.iter().map(|d| format!("`{}`", d.display())).collect();
        problems.push(format!(
            "shard {k}/{n} is given {} times: {}",
            dirs.len(),
            names.join(", ")
        ));
    }
    let missing: Vec<String> = (0..n)
        .filter(|&k| seen[k].is_empty())
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        problems.push(format!(
            "missing shard{} {} of {n} (numbered from 0)",
            if missing.len() == 1 { "" } else { "s" },
            missing.join(", ")
        ));
    }
    if problems.is_empty() {
        return Ok(());
    }
    Err(UsageError(format!(
        "cannot merge these {} shard directories:\n  - {}\n    hint: give every shard of one run exactly once; re-run a missing shard with `ledflicker plan PLAN --shard K/{n} --out DIR` (or its array task) and merge again",
        shards.len(),
        problems.join("\n  - ")
    )))
}

/// Every case of every shard, in case order; each `cases.cbor` checked
/// against its manifest.
fn read_cases(shards: &[(PathBuf, Manifest)]) -> anyhow::Result<Vec<CaseResult>> {
    let total = shards[0].1.case_count;
    let mut slots: Vec<Option<(ShardCase, &Path)>> = vec![None; total];
    for (dir, m) in shards {
        let path = dir.join(CASES);
        let bytes = std::fs::read(&path)
            .map_err(|e| UsageError(format!("cannot read `{}`: {e}", path.display())))?;
        if record::sha256(&bytes) != m.cases_sha256 {
            return Err(UsageError(format!(
                "`{}` does not match the SHA-256 in its {MANIFEST}: the file is damaged or from another run\n    hint: re-run shard {}",
                path.display(),
                m.shard
            ))
            .into());
        }
        let cases = record::decode_cases(&bytes, &path).map_err(UsageError)?;
        let indices: Vec<usize> = cases.iter().map(|c| c.result.case.index).collect();
        if indices != m.cases || indices.iter().any(|&i| i >= total) {
            return Err(UsageError(format!(
                "`{}` holds cases {indices:?}, its {MANIFEST} lists {:?}",
                path.display(),
                m.cases
            ))
            .into());
        }
        for c in cases {
            let i = c.result.case.index;
            if let Some((_, other)) = &slots[i] {
                return Err(UsageError(format!(
                    "case {i} (`{}`) is in both `{}` and `{}`",
                    c.result.case.id,
                    other.display(),
                    dir.display()
                ))
                .into());
            }
            slots[i] = Some((c, dir));
        }
    }
    let missing: Vec<String> = (0..total)
        .filter(|&i| slots[i].is_none())
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(UsageError(format!(
            "no shard ran case{} {} of {total}\n    hint: run every shard with the same plan and N",
            if missing.len() == 1 { "" } else { "s" },
            missing.join(", ")
        ))
        .into());
    }
    Ok(slots.into_iter().flatten().map(|(c, _)| c.result).collect())
}

/// The plan the shards ran, checked against their plan hash; its path
/// reads as the shards recorded it, so results.json is the same.
fn load_plan(given: Option<&Path>, m: &Manifest) -> anyhow::Result<Plan> {
    let as_given = PathBuf::from(&m.plan_path);
    let path = match given {
        Some(p) => p.to_path_buf(),
        None if as_given.is_file() => as_given.clone(),
        None => PathBuf::from(&m.plan_path_absolute),
    };
    let mut plan = plan::load(&path)?;
    let inputs = crate::inputs::collect(&plan).map_err(|e| UsageError(e.to_string()))?;
    if record::plan_hash(&inputs) != m.plan_hash {
        let now: Vec<record::InputRecord> = inputs.iter().map(Into::into).collect();
        let changed: Vec<String> = now
            .iter()
            .filter(|i| {
                !m.inputs
                    .iter()
                    .any(|r| r.sha256 == i.sha256 && r.role == i.role)
            })
            .map(|i| format!("{} `{}`", i.role, i.path))
            .collect();
        return Err(UsageError(format!(
            "plan `{}` or its inputs changed since the shards ran (plan hash differs; changed or new: {})\n    hint: merge with the plan the shards ran (--plan), or re-run the shards",
            path.display(),
            if changed.is_empty() { "the list of inputs".to_string() } else { changed.join(", ") }
        ))
        .into());
    }
    plan.path = as_given;
    Ok(plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs_match_like_a_shell() {
        assert!(glob_match("shard-*", "shard-0"));
        assert!(glob_match("shard-?", "shard-3"));
        assert!(glob_match("*", ""));
        assert!(glob_match("a*b*c", "aXXbYc"));
        assert!(!glob_match("shard-?", "shard-10"));
        assert!(!glob_match("shard-*", "other"));
    }
}
