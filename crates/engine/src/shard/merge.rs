//! Reading back a sharded run for `ledflicker merge`: the shard
//! directories (globs expanded), their manifests checked against each other
//! and the plan they ran, checked against the plan hash; then every case
//! result, one shard at a time. The CLI's `merge` puts them into the case
//! store and writes the report from it as `plan` does.

use std::path::{Path, PathBuf};

use super::record::{self, CASES, MANIFEST, Manifest};
use super::write::tool;
use ledflicker_core::error::UsageError;
use ledflicker_core::plan::{self, Plan, PlanError};
use ledflicker_core::runner::CaseResult;

/// Why the shard directories cannot be merged. Both are the user's input
/// (exit code 2).
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// The shards do not fit together: missing, duplicated, damaged, or of
    /// another plan, tool or seed.
    #[error(transparent)]
    Unfit(#[from] UsageError),
    /// The plan the shards ran cannot be loaded.
    #[error(transparent)]
    Plan(#[from] PlanError),
}

/// A sharded run whose manifests were read and checked; its cases are read
/// by [`Merged::read_cases`].
pub struct Merged {
    /// The plan the shards ran (its path as the shards recorded it).
    pub plan: Plan,
    /// How many shard directories were read.
    pub shards: usize,
    /// The first shard's manifest (every shard agrees on what a report uses).
    pub manifest: Manifest,
    /// The plan's cases, in case order.
    all: Vec<ledflicker_core::plan::TestCase>,
    /// Each shard directory and its manifest.
    read: Vec<(PathBuf, Manifest)>,
}

/// Reads and checks the shard directories `args` (globs allowed) and the
/// plan (`plan`, else where the shards read it). Every shard file is input:
/// its manifest is checked against the plan here, and its cases are checked
/// and evaluated again from their traces ([`super::check`]) as
/// [`Merged::read_cases`] reads them.
pub fn gather(args: &[String], plan: Option<&Path>) -> Result<Merged, MergeError> {
    let dirs = expand_globs(args)?;
    let shards = dirs
        .iter()
        .map(|d| read_manifest(d))
        .collect::<Result<Vec<_>, _>>()?;
    check_shards(&shards)?;
    let first = &shards[0].1;
    let (plan, inputs) = load_plan(plan, first)?;
    let all = plan::expand_cases(&plan);
    // Every shard has the first one's count (checked above), so one
    // assignment serves them all.
    let owners = super::assign::assign(&super::assign::weights(&plan, &all), first.shard.count);
    for (dir, m) in &shards {
        check_manifest(&plan, &all, &owners, &inputs, dir, m)?;
    }
    Ok(Merged {
        manifest: first.clone(),
        plan,
        shards: shards.len(),
        all,
        read: shards,
    })
}

impl Merged {
    /// The number of cases of the largest shard: the most the merge holds
    /// at once.
    pub fn largest_shard(&self) -> usize {
        self.read
            .iter()
            .map(|(_, m)| m.cases.len())
            .max()
            .unwrap_or(0)
    }

    /// Reads every shard's cases and hands each to `put` (the merge puts
    /// them into its case store). One shard's cases are held at a time, so
    /// the merge needs the memory of its largest shard, not of the whole
    /// plan. Duplicated and missing cases are refused.
    pub fn read_cases<E: From<MergeError>>(
        &self,
        mut put: impl FnMut(CaseResult) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut from: Vec<Option<&Path>> = vec![None; self.all.len()];
        for (shard_dir, m) in &self.read {
            for c in shard_cases_checked(&self.plan, &self.all, shard_dir, m)? {
                let i = c.case.index;
                if let Some(other) = from[i] {
                    return Err(MergeError::from(UsageError(format!(
                        "case {i} (`{}`) is in both `{}` and `{}`",
                        c.case.id,
                        other.display(),
                        shard_dir.display()
                    )))
                    .into());
                }
                from[i] = Some(shard_dir);
                put(c)?;
            }
        }
        let missing: Vec<String> = (0..from.len())
            .filter(|&i| from[i].is_none())
            .map(|i| i.to_string())
            .collect();
        if !missing.is_empty() {
            return Err(MergeError::from(UsageError(format!(
                "no shard ran case{} {} of {}\n    hint: run every shard with the same plan and N",
                if missing.len() == 1 { "" } else { "s" },
                missing.join(", "),
                from.len()
            )))
            .into());
        }
        Ok(())
    }
}

/// What a manifest (of the shard directory `dir`) says that the report
/// uses or that picks the cases, against the plan, its cases `all`, the
/// shard of each case `owners` ([`super::assign::assign`] for the
/// manifest's shard count) and the plan's `inputs`: the plan id, seed,
/// backend and case count, the cases assigned to this shard, and the
/// inputs (role, SHA-256 and size; the paths are as the shard saw them).
pub fn check_manifest(
    plan: &Plan,
    all: &[ledflicker_core::plan::TestCase],
    owners: &[usize],
    inputs: &[ledflicker_core::inputs::InputFile],
    dir: &Path,
    m: &Manifest,
) -> Result<(), UsageError> {
    let mut problems = Vec::new();
    let mut differ = |what: &str, shard: String, plan: String| {
        if shard != plan {
            problems.push(format!("{what} {shard}, the plan's is {plan}"));
        }
    };
    differ("plan id", m.plan_id.clone(), plan.id.clone());
    differ("seed", m.seed.to_string(), plan.seed.to_string());
    differ("backend", m.backend.clone(), super::check::backend_id(plan));
    differ(
        "case count",
        m.case_count.to_string(),
        all.len().to_string(),
    );
    if m.case_count == all.len() {
        let mine: Vec<usize> = all
            .iter()
            .zip(owners)
            .filter(|&(_, &k)| k == m.shard.index)
            .map(|(c, _)| c.index)
            .collect();
        differ("case list", format!("{:?}", m.cases), format!("{mine:?}"));
    }
    let recorded: Vec<(&str, &str, u64)> = m
        .inputs
        .iter()
        .map(|i| (i.role.as_str(), i.sha256.as_str(), i.size))
        .collect();
    let now: Vec<(&str, &str, u64)> = inputs
        .iter()
        .map(|i| (i.role.as_str(), i.sha256.as_str(), i.size))
        .collect();
    if recorded != now {
        problems.push("its list of inputs differs from the plan's (role, SHA-256 or size)".into());
    }
    if problems.is_empty() {
        return Ok(());
    }
    Err(UsageError(format!(
        "`{}` does not describe shard {} of this plan:\n  - {}\n    hint: the manifest is damaged or was edited; re-run shard {} with `ledflicker plan PLAN --shard {} --out DIR`",
        dir.join(MANIFEST).display(),
        m.shard,
        problems.join("\n  - "),
        m.shard,
        m.shard
    )))
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
    let text = ledflicker_core::util::read_input_to_string(&path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::InvalidInput {
            UsageError(format!(
                "`{}` {e}\n    hint: a shard's {MANIFEST} is a file written by `ledflicker plan PLAN --shard K/N --out DIR`",
                path.display()
            ))
        } else {
            UsageError(format!(
                "`{}` is not a shard directory: cannot read {MANIFEST}: {e}\n    hint: shard directories are written by `ledflicker plan PLAN --shard K/N --out DIR`",
                dir.display()
            ))
        }
    })?;
    Ok((dir.to_path_buf(), parse_manifest(&text, &path)?))
}

/// A shard's `shard.json` (`text`, read from `path`): parsed, its schema
/// and shard K/N checked. What it says of the plan is checked by
/// [`check_manifest`].
pub fn parse_manifest(text: &str, path: &Path) -> Result<Manifest, UsageError> {
    let manifest: Manifest = serde_json::from_str(text)
        .map_err(|e| UsageError(format!("`{}`: not a shard manifest: {e}", path.display())))?;
    if manifest.schema != record::SCHEMA {
        return Err(UsageError(format!(
            "`{}`: schema `{}`, this ledflicker reads `{}`",
            path.display(),
            manifest.schema,
            record::SCHEMA
        )));
    }
    if let Err(why) = super::ShardSpec::new(manifest.shard.index, manifest.shard.count) {
        return Err(UsageError(format!(
            "`{}`: shard {}: {why}",
            path.display(),
            manifest.shard
        )));
    }
    Ok(manifest)
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

/// The cases of the shard in `dir`: its `cases.cbor` read as input,
/// matched against its manifest's SHA-256 (which tells damage, not trust),
/// then checked and evaluated again ([`super::check::shard_cases`]).
fn shard_cases_checked(
    plan: &Plan,
    all: &[ledflicker_core::plan::TestCase],
    dir: &Path,
    m: &Manifest,
) -> Result<Vec<CaseResult>, MergeError> {
    let path = dir.join(CASES);
    let bytes = ledflicker_core::util::read_input(&path).map_err(|e| {
        UsageError(format!(
            "cannot read `{}`: {e}\n    hint: re-run shard {} with `ledflicker plan PLAN --shard {} --out DIR`",
            path.display(),
            m.shard,
            m.shard
        ))
    })?;
    if ledflicker_core::util::sha256_hex(&bytes) != m.cases_sha256 {
        return Err(UsageError(format!(
            "`{}` does not match the SHA-256 in its {MANIFEST}: the file is damaged or from another run\n    hint: re-run shard {}",
            path.display(),
            m.shard
        ))
        .into());
    }
    Ok(super::check::shard_cases(
        plan, all, &m.cases, &bytes, &path, m.shard,
    )?)
}

/// The plan the shards ran, checked against their plan hash, and its
/// inputs; its path reads as the shards recorded it, so results.json is
/// the same.
fn load_plan(
    given: Option<&Path>,
    m: &Manifest,
) -> Result<(Plan, Vec<ledflicker_core::inputs::InputFile>), MergeError> {
    let as_given = PathBuf::from(&m.plan_path);
    let absolute = PathBuf::from(&m.plan_path_absolute);
    // A built-in plan's shards name its path in the source tree; when no
    // file is there, the built-in copy is the plan (its hash is checked
    // below like a file's).
    let built_in = plan::shipped::plan_at(&m.plan_path);
    // The shards checked the plan's work estimate against the limits they
    // ran with (`plan --max-memory`); the merge takes the plan they ran.
    let unbounded = plan::ResourceLimits::unbounded();
    let mut plan = match (given, built_in) {
        (Some(p), _) => plan::load_within(p, unbounded)?,
        (None, _) if as_given.is_file() => plan::load_within(&as_given, unbounded)?,
        (None, Some(b)) if !absolute.is_file() => plan::load_built_in(b)?,
        (None, _) => plan::load_within(&absolute, unbounded)?,
    };
    let inputs = ledflicker_core::inputs::collect(&plan).map_err(|e| UsageError(e.to_string()))?;
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
            plan.source_label(),
            if changed.is_empty() { "the list of inputs".to_string() } else { changed.join(", ") }
        ))
        .into());
    }
    plan.path = as_given;
    Ok((plan, inputs))
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
