//! Sharded runs (docs/scale-out.md): `ledflicker plan PLAN --shard K/N`
//! runs one share of the cases and writes a shard directory (typed case
//! results, traces, a manifest with the plan hash); `ledflicker merge`
//! checks the shards and writes the report a single run would have written,
//! byte for byte.
//!
//! - [`ShardSpec`]: which share, from `--shard K/N` or `--shard auto`
//!   (a Slurm array task or a Kubernetes Indexed Job).
//! - [`assign`]: the deterministic case-to-shard assignment.
//! - [`record`]: the on-disk shard format, read back typed.
//! - [`write`]: a shard run's directory, written from its case results.
//! - [`merge`]: the shard directories read back and checked, for `merge`.
//! - [`check`]: a shard's cases checked as input and evaluated again from
//!   their traces: a shard carries data, never conclusions.
//! - [`report_model`]: the report model `plan` and `merge` both write.

pub mod assign;
pub mod check;
pub mod merge;
pub mod record;
pub mod write;

use serde::{Deserialize, Serialize};

use ledflicker_core::error::UsageError;

/// Largest shard count: more shards than this is a mistake, not a cluster.
pub const MAX_SHARDS: usize = 100_000;

/// Environment variable a Kubernetes Indexed Job sets to the shard count
/// (`spec.completions`) for `--shard auto`; Kubernetes itself only sets
/// `JOB_COMPLETION_INDEX`.
pub const COUNT_VAR: &str = "LEDFLICKER_SHARD_COUNT";

/// One share of a plan's cases: shard `index` of `count`, numbered from 0
/// like Slurm array task ids and Kubernetes completion indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardSpec {
    /// Shard number, `0..count`.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl std::fmt::Display for ShardSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl ShardSpec {
    /// Parses `--shard`: `K/N` (0 <= K < N) or `auto`, which reads the
    /// environment through `env`.
    pub fn parse(arg: &str, env: &dyn Fn(&str) -> Option<String>) -> Result<Self, UsageError> {
        if arg.trim() == "auto" {
            return Self::from_env(env);
        }
        let bad = |why: &str| {
            UsageError(format!(
                "--shard `{arg}`: {why}\n    hint: give K/N with shards numbered from 0, e.g. --shard 0/4 .. --shard 3/4, or --shard auto inside a Slurm array or a Kubernetes Indexed Job"
            ))
        };
        let (k, n) = arg
            .split_once('/')
            .ok_or_else(|| bad("not of the form K/N"))?;
        let k: usize = k
            .trim()
            .parse()
            .map_err(|_| bad("K is not a whole number"))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| bad("N is not a whole number"))?;
        Self::new(k, n).map_err(|why| bad(&why))
    }

    /// Shard `index` of `count`, checked.
    pub fn new(index: usize, count: usize) -> Result<Self, String> {
        if count == 0 || count > MAX_SHARDS {
            return Err(format!("N must be 1 to {MAX_SHARDS}, got {count}"));
        }
        if index >= count {
            return Err(format!(
                "K must be 0 to {} for {count} shards (shards are numbered from 0), got {index}",
                count - 1
            ));
        }
        Ok(Self { index, count })
    }

    /// `--shard auto`: a Slurm array task (`SLURM_ARRAY_TASK_ID`,
    /// `SLURM_ARRAY_TASK_COUNT`, and `SLURM_ARRAY_TASK_MIN` and
    /// `SLURM_ARRAY_TASK_STEP` when the array does not run 0, 1, 2, ...), or
    /// a Kubernetes Indexed Job (`JOB_COMPLETION_INDEX` and
    /// [`COUNT_VAR`]).
    pub fn from_env(env: &dyn Fn(&str) -> Option<String>) -> Result<Self, UsageError> {
        let num = |name: &str, default: Option<usize>| -> Result<usize, UsageError> {
            match env(name) {
                Some(v) => v.trim().parse().map_err(|_| {
                    UsageError(format!("--shard auto: {name}=`{v}` is not a whole number"))
                }),
                None => {
                    default.ok_or_else(|| UsageError(format!("--shard auto: {name} is not set")))
                }
            }
        };
        let hint_slurm = "\n    hint: submit with a contiguous array, e.g. sbatch --array=0-3, and run ledflicker in each task";
        if env("SLURM_ARRAY_TASK_ID").is_some() {
            let id = num("SLURM_ARRAY_TASK_ID", None)?;
            let count = num("SLURM_ARRAY_TASK_COUNT", None)?;
            let min = num("SLURM_ARRAY_TASK_MIN", Some(0))?;
            let step = num("SLURM_ARRAY_TASK_STEP", Some(1))?.max(1);
            if id < min || (id - min) % step != 0 {
                return Err(UsageError(format!(
                    "--shard auto: SLURM_ARRAY_TASK_ID {id} is not min {min} + a multiple of step {step}{hint_slurm}"
                )));
            }
            return Self::new((id - min) / step, count).map_err(|why| {
                UsageError(format!(
                    "--shard auto: Slurm array task {id} (min {min}, step {step}, count {count}): {why}{hint_slurm}"
                ))
            });
        }
        if env("JOB_COMPLETION_INDEX").is_some() {
            let index = num("JOB_COMPLETION_INDEX", None).map_err(|e| UsageError(e.0))?;
            let count = num(COUNT_VAR, None).map_err(|e| {
                UsageError(format!(
                    "{}\n    hint: set it in the Job's container env to the Job's spec.completions (examples/kubernetes/)",
                    e.0
                ))
            })?;
            return Self::new(index, count).map_err(|why| {
                UsageError(format!(
                    "--shard auto: JOB_COMPLETION_INDEX {index} of {COUNT_VAR} {count}: {why}"
                ))
            });
        }
        Err(UsageError(
            "--shard auto: neither SLURM_ARRAY_TASK_ID (a Slurm array task) nor JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set\n    hint: outside those, give the shard explicitly, e.g. --shard 0/4".to_string(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env_of(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn explicit_shards_are_numbered_from_zero() {
        let none = env_of(&[]);
        assert_eq!(
            ShardSpec::parse("0/4", &none).unwrap(),
            ShardSpec { index: 0, count: 4 }
        );
        assert_eq!(ShardSpec::parse(" 3 / 4 ", &none).unwrap().index, 3);
        for bad in ["4/4", "1/0", "x/4", "1", "-1/4", "1/4/2"] {
            let e = ShardSpec::parse(bad, &none).unwrap_err().0;
            assert!(e.contains(bad) && e.contains("hint"), "{bad}: {e}");
        }
    }

    #[test]
    fn slurm_array_offsets_and_steps() {
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ]);
        assert_eq!(
            ShardSpec::parse("auto", &env).unwrap(),
            ShardSpec { index: 3, count: 4 }
        );
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert_eq!(ShardSpec::parse("auto", &env).unwrap().index, 2);
        // A task outside 0..count (an array of 1-4 without the min) fails.
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        let e = ShardSpec::parse("auto", &env).unwrap_err().0;
        assert!(e.contains("Slurm array task 4"), "{e}");
        let env = env_of(&[("SLURM_ARRAY_TASK_ID", "1")]);
        let e = ShardSpec::parse("auto", &env).unwrap_err().0;
        assert!(e.contains("SLURM_ARRAY_TASK_COUNT is not set"), "{e}");
    }

    #[test]
    fn kubernetes_indexed_job_needs_the_count() {
        let env = env_of(&[("JOB_COMPLETION_INDEX", "2"), (COUNT_VAR, "3")]);
        assert_eq!(
            ShardSpec::parse("auto", &env).unwrap(),
            ShardSpec { index: 2, count: 3 }
        );
        let env = env_of(&[("JOB_COMPLETION_INDEX", "2")]);
        let e = ShardSpec::parse("auto", &env).unwrap_err().0;
        assert!(e.contains(COUNT_VAR) && e.contains("completions"), "{e}");
        let e = ShardSpec::parse("auto", &env_of(&[])).unwrap_err().0;
        assert!(e.contains("SLURM_ARRAY_TASK_ID"), "{e}");
    }
}
