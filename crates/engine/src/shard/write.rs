//! Writing a shard directory (`record`'s format) from the case results of
//! a shard run: the typed case records, the manifest and the traces. The
//! CLI's `plan --shard` runs the cases and calls [`write_dir`].

use std::path::{Path, PathBuf};

use super::ShardSpec;
use super::record::{self, CASES, MANIFEST, Manifest, ShardCase};
use ledflicker_core::inputs::InputFile;
use ledflicker_core::plan::Plan;
use ledflicker_core::runner::CaseResult;

/// What one shard ran and measured.
pub struct ShardOutput<'a> {
    /// The whole plan.
    pub plan: &'a Plan,
    /// Which share of its cases.
    pub spec: ShardSpec,
    /// Cases in the whole plan.
    pub case_count: usize,
    /// Indices of this shard's cases, ascending.
    pub cases: Vec<usize>,
    /// Every input of the plan (for the plan hash and the merged report).
    pub inputs: &'a [InputFile],
    /// Backend id.
    pub backend_id: String,
    /// This shard's case results, in case order.
    pub results: Vec<CaseResult>,
}

/// Why a shard directory could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The case results could not be encoded as CBOR.
    #[error("cannot encode the case results: {0}")]
    Encode(String),
    /// The manifest could not be serialised.
    #[error(transparent)]
    Manifest(#[from] serde_json::Error),
    /// A file or the traces directory could not be written.
    #[error("cannot {action} `{}`", path.display())]
    Io {
        /// What was being done: "write" or "create".
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// `ledflicker <version>`: the tool every shard of one merge must share.
pub fn tool() -> String {
    format!("ledflicker {}", env!("CARGO_PKG_VERSION"))
}

/// Writes `cases.cbor`, `shard.json` and `traces/` into `dir` (which
/// exists); returns the manifest written.
pub fn write_dir(dir: &Path, out: ShardOutput<'_>) -> Result<Manifest, WriteError> {
    let plan = out.plan;
    let traces: Vec<(String, String)> = out
        .results
        .iter()
        .map(|c| {
            (
                format!("{}.csv", c.case.id),
                ledflicker_report::trace_csv(c),
            )
        })
        .collect();
    let records: Vec<ShardCase> = out
        .results
        .into_iter()
        .map(ShardCase::from_result)
        .collect();
    let bytes = record::encode_cases(&records).map_err(WriteError::Encode)?;
    let manifest = Manifest {
        schema: record::SCHEMA.to_string(),
        tool: tool(),
        plan_id: plan.id.clone(),
        plan_path: plan.path.display().to_string(),
        plan_path_absolute: std::path::absolute(&plan.path)
            .unwrap_or_else(|_| plan.path.clone())
            .display()
            .to_string(),
        plan_hash: record::plan_hash(out.inputs),
        seed: plan.seed,
        backend: out.backend_id,
        shard: out.spec,
        case_count: out.case_count,
        cases: out.cases,
        inputs: out.inputs.iter().map(Into::into).collect(),
        cases_sha256: ledflicker_core::util::sha256_hex(&bytes),
    };
    write_files(dir, &manifest, &bytes, &traces)?;
    Ok(manifest)
}

fn write_files(
    dir: &Path,
    manifest: &Manifest,
    cases: &[u8],
    traces: &[(String, String)],
) -> Result<(), WriteError> {
    let write = |path: PathBuf, bytes: &[u8]| {
        std::fs::write(&path, bytes).map_err(|source| WriteError::Io {
            action: "write",
            path,
            source,
        })
    };
    write(dir.join(CASES), cases)?;
    let json = serde_json::to_string_pretty(manifest)?;
    write(dir.join(MANIFEST), format!("{json}\n").as_bytes())?;
    let traces_dir = dir.join("traces");
    std::fs::create_dir_all(&traces_dir).map_err(|source| WriteError::Io {
        action: "create",
        path: traces_dir.clone(),
        source,
    })?;
    for (name, text) in traces {
        write(traces_dir.join(name), text.as_bytes())?;
    }
    Ok(())
}
