//! The evidence a run judged: every input file with its size and SHA-256,
//! for results.json `report.inputs`, the report's Environment section and
//! the signed manifest; and the check that they are still the same.
//!
//! Inputs are the plan, the camera profile it names, every capture source
//! of a captured plan (a video or Y4M file, every frame file of a frame
//! directory, CSV traces, `<source>.timestamps.csv` sidecars) and the
//! files the rig command of a command plan names (its program or script).

use std::io::Read;
use std::path::{Path, PathBuf};

pub use ledflicker_results::inputs::InputFile;
use sha2::{Digest, Sha256};

use crate::capture::{SourceKind, source_kind};
use ledflicker_plan::plan::{BackendKind, Plan, shipped};

/// Why an input could not be hashed.
#[derive(Debug, thiserror::Error)]
#[error("cannot read input `{path}`: {source}")]
pub struct InputError {
    /// The input.
    pub path: PathBuf,
    /// Cause.
    pub source: std::io::Error,
}

/// SHA-256 (lowercase hex) and size in bytes of a file, read in chunks.
/// Anything but a regular file (a FIFO, a device) is refused at once
/// ([`ledflicker_plan::util::open_input`]); Ctrl-C stops the hashing of a large file
/// between chunks, with an `Interrupted` error.
pub fn hash_file(path: &Path) -> std::io::Result<(String, u64)> {
    let mut f = ledflicker_plan::util::open_input(path)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut size = 0u64;
    loop {
        if let Err(stop) = crate::interrupt::check() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::Interrupted,
                stop.to_string(),
            ));
        }
        let n = f.read(&mut buf)?;
        if n == 0 {
            break;
        }
        size += n as u64;
        hasher.update(&buf[..n]);
    }
    Ok((ledflicker_plan::util::hex(&hasher.finalize()), size))
}

fn input(role: &str, path: &Path) -> Result<InputFile, InputError> {
    let (sha256, size) = hash_file(path).map_err(|source| InputError {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(InputFile {
        role: role.to_string(),
        path: path.display().to_string(),
        sha256,
        size,
    })
}

/// A file built into the binary, named by its path in the source tree and
/// [`shipped::BUILT_IN`].
fn built_in_input(role: &str, file: &shipped::Shipped) -> InputFile {
    InputFile {
        role: role.to_string(),
        path: shipped::label(file.path),
        sha256: ledflicker_plan::util::sha256_hex(file.text.as_bytes()),
        size: file.text.len() as u64,
    }
}

/// The frame files of a frame directory, as the capture reader takes
/// them: `.png`, `.tif` and `.tiff` files, in name order.
fn frame_files(dir: &Path) -> Result<Vec<PathBuf>, InputError> {
    let err = |source| InputError {
        path: dir.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(err)? {
        let path = entry.map_err(err)?.path();
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if matches!(ext.as_str(), "png" | "tif" | "tiff") {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

fn capture_inputs(source: &Path, out: &mut Vec<InputFile>) -> Result<(), InputError> {
    let role = match source_kind(source) {
        SourceKind::ImageDir => {
            for f in frame_files(source)? {
                out.push(input("frame", &f)?);
            }
            None
        }
        SourceKind::Image => Some("frame"),
        SourceKind::Y4m => Some("y4m"),
        SourceKind::Video => Some("video"),
        SourceKind::Csv => Some("csv-trace"),
    };
    // As the capture reader: a capture built into the binary is read when
    // nothing is on disk at its path.
    let built_in = std::fs::symlink_metadata(source)
        .is_err()
        .then(|| shipped::data_at(source))
        .flatten();
    match (role, built_in) {
        (Some(role), Some(data)) => out.push(InputFile {
            role: role.to_string(),
            path: shipped::label(&source.display().to_string()),
            sha256: ledflicker_plan::util::sha256_hex(data.bytes),
            size: data.bytes.len() as u64,
        }),
        (Some(role), None) => out.push(input(role, source)?),
        (None, _) => {}
    }
    // As the capture reader: whatever stands at the sidecar's name is an
    // input (a FIFO there is refused when hashed).
    let sidecar = crate::capture::sidecar_path(source);
    if std::fs::symlink_metadata(&sidecar).is_ok() {
        out.push(input("timestamps", &sidecar)?);
    }
    Ok(())
}

/// The files a rig command names, resolved as the command backend resolves
/// them (relative to the plan's directory when they exist there).
fn rig_files(argv: &[String], plan_dir: &Path) -> Vec<PathBuf> {
    argv.iter()
        .filter(|a| a.contains('/'))
        .filter_map(|a| {
            let p = Path::new(a);
            let local = plan_dir.join(p);
            if p.is_relative() && local.is_file() {
                Some(local)
            } else if p.is_absolute() && p.is_file() {
                Some(p.to_path_buf())
            } else {
                None
            }
        })
        .collect()
}

/// Every input of `plan`, plan first. Fails when one cannot be read.
pub fn collect(plan: &Plan) -> Result<Vec<InputFile>, InputError> {
    let built_in_plan = plan
        .built_in
        .then(|| shipped::plan_at(&plan.path.display().to_string()))
        .flatten();
    let mut out = vec![match built_in_plan {
        Some(p) => built_in_input("plan", p),
        None => input("plan", &plan.path)?,
    }];
    let source = &plan.dut.camera.source;
    let profile = Path::new(source);
    let built_in_profile = source
        .strip_suffix(shipped::BUILT_IN)
        .and_then(shipped::profile);
    if let Some(p) = built_in_profile {
        out.push(built_in_input("camera-profile", p));
    } else if source != "plan" && profile.is_file() {
        out.push(input("camera-profile", profile)?);
    }
    let plan_dir = plan
        .path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if let Some(capture) = &plan.capture {
        if plan.dut.backend == BackendKind::Captured {
            for case in &capture.cases {
                capture_inputs(&case.source, &mut out)?;
            }
        }
        if let Some(cmd) = &capture.command {
            for f in rig_files(&cmd.argv, plan_dir) {
                out.push(input("rig-script", &f)?);
            }
        }
    }
    // A source named by two cases is listed once.
    let mut seen = std::collections::HashSet::new();
    out.retain(|i| seen.insert((i.role.clone(), i.path.clone())));
    Ok(out)
}

/// What re-hashing one recorded input found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum InputCheck {
    /// Same size and SHA-256.
    Same,
    /// The file is not there (or not readable).
    Missing(String),
    /// Size or SHA-256 differ.
    Changed {
        /// Size now, bytes.
        size: u64,
        /// SHA-256 now.
        sha256: String,
    },
}

/// Re-hashes `recorded` at its path, or under `root` when given (a
/// relative path is joined to it; an absolute one is used as is).
pub fn check(recorded: &InputFile, root: Option<&Path>) -> (PathBuf, InputCheck) {
    let path = match root {
        Some(r) if Path::new(&recorded.path).is_relative() => r.join(&recorded.path),
        _ => PathBuf::from(&recorded.path),
    };
    let result = match std::fs::symlink_metadata(&path) {
        Ok(m) if !m.is_file() && !m.file_type().is_symlink() => {
            InputCheck::Missing("not a regular file".to_string())
        }
        Ok(_) => match hash_file(&path) {
            Ok((sha256, size)) if sha256 == recorded.sha256 && size == recorded.size => {
                InputCheck::Same
            }
            Ok((sha256, size)) => InputCheck::Changed { size, sha256 },
            Err(e) => InputCheck::Missing(e.to_string()),
        },
        Err(e) => InputCheck::Missing(e.to_string()),
    };
    (path, result)
}
