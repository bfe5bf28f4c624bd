//! Reading back a sharded run for `ledflicker merge`: the shard
//! directories (globs expanded), their manifests checked against each other,
//! every case result in case order and the plan they ran, checked against
//! the plan hash. The CLI's `merge` then writes the report as `plan` does.

use std::path::{Path, PathBuf};

use super::record::{self, CASES, MANIFEST, Manifest, ShardCase};
use super::write::tool;
use crate::error::UsageError;
use crate::plan::{self, Plan};
use crate::runner::CaseResult;

/// A sharded run read back whole.
pub struct Merged {
    /// The plan the shards ran (its path as the shards recorded it).
    pub plan: Plan,
    /// How many shard directories were read.
    pub shards: usize,
    /// The first shard's manifest (every shard agrees on what a report uses).
    pub manifest: Manifest,
    /// Every case result, in case order.
    pub results: Vec<CaseResult>,
}

/// Reads and checks the shard directories `args` (globs allowed) and the
/// plan (`plan`, else where the shards read it).
pub fn gather(args: &[String], plan: Option<&Path>) -> anyhow::Result<Merged> {
    let dirs = expand_globs(args)?;
    let shards = dirs
        .iter()
        .map(|d| read_manifest(d))
        .collect::<Result<Vec<_>, _>>()?;
    check_shards(&shards)?;
    let first = &shards[0].1;
    let results = read_cases(&shards)?;
    let plan = load_plan(plan, first)?;
    let expected = plan::expand_cases(&plan);
    if let Some((want, got)) = expected.iter().zip(&results).find(|(w, g)| **w != g.case) {
        return Err(UsageError(format!(
            "case {} of the plan is `{}` but the shards ran `{}` there\n    hint: run every shard and the merge with the same plan",
            want.index, want.id, got.case.id
        ))
        .into());
    }
    Ok(Merged {
        manifest: first.clone(),
        plan,
        shards: shards.len(),
        results,
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
