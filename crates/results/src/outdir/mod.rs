//! Report directories: a new generation is written beside the old one and
//! swapped in whole, so that nothing a user put there is lost and a killed
//! run leaves the old complete report or the new complete one.
//!
//! Last stage of `ledflicker plan`, around [`crate::report::write_report`]:
//!
//! 1. [`Generation::begin`] checks `--out`: missing, empty, or an earlier
//!    ledflicker report (marked by [`MARKER`], or by a results.json of a
//!    `ledflicker.results/` schema) is fine; anything else is refused. It
//!    removes what killed runs left beside it (`.<name>.ledflicker-*` of a
//!    process that is gone) and creates the staging directory
//!    `.<name>.ledflicker-new-<pid>` next to `--out`. Files of the old
//!    report that ledflicker did not write are hard-linked (or copied) into
//!    the staging directory, so they survive the swap.
//! 2. The report is written into [`Generation::path`]. Unchanged files of
//!    the earlier report ([`Generation::previous`]) may be hard-linked
//!    into it instead of written (`report::link_if_same`: only files that
//!    report alone holds; nothing is written through a link).
//! 3. [`Generation::commit`] writes [`MARKER`] (the list of what this run
//!    wrote) and exchanges the staging directory with `--out` in one
//!    `renameat2(RENAME_EXCHANGE)`; where the file system cannot, two
//!    renames, and the next run puts the old report back if it was killed
//!    between them. The old generation is then removed.
//!
//! Dropping an uncommitted [`Generation`] removes its staging directory.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Marker file of a report directory written by ledflicker: one line of
/// text, then the top-level entries the run wrote, one per line.
pub const MARKER: &str = ".ledflicker";

const MARKER_HEADER: &str = "ledflicker report directory; entries written by `ledflicker plan`:";

/// Top-level names every report run writes (`crate::report::write_report`):
/// an entry of one of these names that the earlier report did not write is
/// a user's, and is never replaced (see [`Generation::begin`]).
pub const REPORT_ENTRIES: &[&str] = &[
    "results.json",
    "traces",
    "charts",
    "frames",
    "report.html",
    "report.pdf",
    "junit.xml",
    "summary.csv",
    "cases.sqlite",
    "profile",
];

/// A file in a report directory that marks it as signed (the CMS signature
/// of its manifest); such a directory is never overwritten without `--force`.
pub const SIGNOFF_FILE: &str = "signoff.p7s";

/// Every file and folder the sign-off writes (see `crate::signoff`),
/// including `signoff.json` of the old format; `--force` removes them.
pub const SIGNOFF_FILES: [&str; 4] = ["signoff.p7s", "manifest.txt", "signatures", "signoff.json"];

/// Whether `dir` holds a signed report, of the current format or the old one.
pub fn is_signed(dir: &Path) -> bool {
    SIGNOFF_FILES.iter().any(|f| dir.join(f).exists())
}

/// Fails if `dir` holds a signed report and `force` is off.
pub fn check_overwrite(dir: &Path, force: bool) -> Result<(), OutDirError> {
    if !force && is_signed(dir) {
        return Err(OutDirError::Signed {
            dir: dir.to_path_buf(),
        });
    }
    Ok(())
}

/// Why a report directory cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum OutDirError {
    /// `--out` is unusable: not a directory, a foreign directory, or a
    /// place where nothing can be created.
    #[error("output directory `{dir}`: {message}\n    hint: {hint}")]
    Refused {
        /// The `--out` directory.
        dir: PathBuf,
        /// What is wrong.
        message: String,
        /// How to fix it.
        hint: String,
    },
    /// The directory holds a signed report.
    #[error(
        "`{dir}` holds a signed report ({SIGNOFF_FILE}); refusing to overwrite it\n    hint: choose another --out directory, or pass --force to replace it"
    )]
    Signed {
        /// Report directory.
        dir: PathBuf,
    },
    /// File system error while swapping generations.
    #[error("output directory `{dir}`: cannot {action} `{path}`: {source}")]
    Io {
        /// The `--out` directory.
        dir: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

impl OutDirError {
    /// True when the user can fix it by choosing another directory (exit
    /// code 2); false for a file-system failure mid-swap (exit code 3).
    pub fn is_usage_error(&self) -> bool {
        match self {
            OutDirError::Refused { .. } | OutDirError::Signed { .. } => true,
            OutDirError::Io { source, .. } => matches!(
                source.kind(),
                std::io::ErrorKind::PermissionDenied
                    | std::io::ErrorKind::ReadOnlyFilesystem
                    | std::io::ErrorKind::NotADirectory
                    | std::io::ErrorKind::AlreadyExists
                    | std::io::ErrorKind::InvalidFilename
            ),
        }
    }
}

/// A report generation being written beside `--out`.
#[derive(Debug)]
pub struct Generation {
    out: PathBuf,
    staging: PathBuf,
    /// Entries carried over from the old report (not ours).
    carried: BTreeSet<String>,
    /// Top-level entries the earlier report wrote (empty when there was
    /// none): everything else in `out` is a user's.
    owned: BTreeSet<String>,
    /// The files the earlier report wrote inside its folders, when its
    /// marker lists them: any other file there is a user's.
    owned_files: Option<BTreeSet<String>>,
    /// Whether `out` holds an earlier report (see [`Generation::previous`]).
    has_previous: bool,
    /// The device and inode of `out` when the run began, when it existed:
    /// the directory swapped out must be that one, not whatever (a symbolic
    /// link to a user's folder, say) was put at its path during the run.
    identity: Option<(u64, u64)>,
    committed: bool,
}

/// The device and inode of the entry at `path` itself (a symbolic link is
/// not followed), or None when there is none.
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::symlink_metadata(path)
        .ok()
        .map(|m| (m.dev(), m.ino()))
}

/// What a directory holds, for [`Generation::begin`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DirKind {
    /// Nothing there yet.
    Missing,
    /// An empty directory.
    Empty,
    /// A report written by ledflicker; `owned` are its entries.
    Report {
        /// Top-level entries ledflicker wrote.
        owned: BTreeSet<String>,
        /// Every file it wrote inside those folders (`traces/a.csv`), when
        /// its marker lists them (markers of older versions do not).
        files: Option<BTreeSet<String>>,
    },
    /// Something else.
    Foreign,
}

/// Classifies `dir`. Errors when it exists but is not a directory.
pub fn classify(dir: &Path) -> Result<DirKind, OutDirError> {
    let meta = match std::fs::symlink_metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(DirKind::Missing),
        Err(source) => return Err(io_err(dir, "read", dir, source)),
    };
    if !meta.is_dir() {
        return Err(OutDirError::Refused {
            dir: dir.to_path_buf(),
            message: if meta.file_type().is_symlink() {
                "is a symbolic link; a report directory is replaced whole, so it must be a real directory".to_string()
            } else {
                "exists and is not a directory".to_string()
            },
            hint: "give --out a new or empty directory, or an earlier report directory".to_string(),
        });
    }
    let mut entries = std::fs::read_dir(dir).map_err(|e| io_err(dir, "list", dir, e))?;
    if entries.next().is_none() {
        return Ok(DirKind::Empty);
    }
    for name in [MARKER, "results.json"] {
        let path = dir.join(name);
        if let Err(e) = crate::util::open_input(&path)
            && e.kind() == std::io::ErrorKind::InvalidInput
        {
            // Never read (a FIFO would block the run on it), never replaced.
            return Err(OutDirError::Refused {
                dir: dir.to_path_buf(),
                message: format!("`{name}` {e}"),
                hint: format!(
                    "remove `{}` or give --out another directory",
                    path.display()
                ),
            });
        }
    }
    if let Ok(text) = crate::util::read_input_to_string(&dir.join(MARKER))
        && let Some(rest) = text.strip_prefix(MARKER_HEADER)
    {
        let mut owned: BTreeSet<String> = rest
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.contains('/') && *l != "." && *l != "..")
            .map(str::to_string)
            .collect();
        let files: BTreeSet<String> = rest
            .lines()
            .map(str::trim)
            .filter(|l| {
                l.contains('/')
                    && !l.starts_with('/')
                    && !l
                        .split('/')
                        .any(|part| part.is_empty() || part == "." || part == "..")
            })
            .map(str::to_string)
            .collect();
        owned.insert(MARKER.to_string());
        // `ledflicker sign` adds these after the marker was written.
        owned.extend(SIGNOFF_FILES.iter().map(|s| s.to_string()));
        let files = (!files.is_empty()).then_some(files);
        return Ok(DirKind::Report { owned, files });
    }
    if results_schema_is_ours(&dir.join("results.json")) {
        // Written before the marker existed: what a report has held.
        let owned = REPORT_ENTRIES
            .iter()
            .chain(&SIGNOFF_FILES)
            .chain(&[MARKER])
            .map(|s| s.to_string())
            .collect();
        return Ok(DirKind::Report { owned, files: None });
    }
    Ok(DirKind::Foreign)
}

/// results.json of a `ledflicker.results/N` schema (any N).
fn results_schema_is_ours(path: &Path) -> bool {
    let Ok(text) = crate::util::read_input_to_string(path) else {
        return false;
    };
    /// The one field that says whose file it is (any schema version).
    #[derive(serde::Deserialize)]
    struct Head {
        schema: Option<String>,
    }
    serde_json::from_str::<Head>(&text).is_ok_and(|h| {
        h.schema
            .is_some_and(|s| s.starts_with("ledflicker.results/"))
    })
}

fn io_err(dir: &Path, action: &'static str, path: &Path, source: std::io::Error) -> OutDirError {
    OutDirError::Io {
        dir: dir.to_path_buf(),
        action,
        path: path.to_path_buf(),
        source,
    }
}

/// Parent directory and file name of `out`.
fn split(out: &Path) -> Result<(PathBuf, String), OutDirError> {
    let refused = |message: &str| OutDirError::Refused {
        dir: out.to_path_buf(),
        message: message.to_string(),
        hint: "give --out a directory name, e.g. --out reports/daylight".to_string(),
    };
    let abs = std::path::absolute(out).map_err(|e| io_err(out, "resolve", out, e))?;
    let name = abs
        .file_name()
        .ok_or_else(|| refused("has no directory name"))?
        .to_string_lossy()
        .into_owned();
    if name == "." || name == ".." {
        return Err(refused("has no directory name"));
    }
    // The generations beside it are named `.<name>.ledflicker-new-<pid>`,
    // and a file name has at most 255 bytes (NAME_MAX on Linux).
    if name.len() + temp_prefix("").len() + "new-4294967295".len() > 255 {
        return Err(OutDirError::Refused {
            dir: out.to_path_buf(),
            message: format!(
                "its name is {} bytes long; a report directory's name may have at most {} (its generations are written beside it under longer names)",
                name.len(),
                255 - temp_prefix("").len() - "new-4294967295".len()
            ),
            hint: "give --out a shorter directory name".to_string(),
        });
    }
    let parent = abs
        .parent()
        .ok_or_else(|| refused("has no parent directory"))?;
    Ok((parent.to_path_buf(), name))
}

/// Name prefix of the generations of `name` beside it.
fn temp_prefix(name: &str) -> String {
    format!(".{name}.ledflicker-")
}

/// Removes what killed runs left beside `out`, and puts an old report back
/// when a run died between the two renames of a non-atomic swap. Returns
/// the number of directories removed.
pub fn clean_stale(out: &Path) -> Result<usize, OutDirError> {
    let (parent, name) = split(out)?;
    let prefix = temp_prefix(&name);
    let Ok(entries) = std::fs::read_dir(&parent) else {
        return Ok(0);
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix(&prefix) else {
            continue;
        };
        let Some((kind, pid)) = rest.split_once('-') else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if crate::util::alive(pid) {
            continue;
        }
        let path = e.path();
        if kind == "old" && !out.exists() {
            std::fs::rename(&path, out).map_err(|err| io_err(out, "restore", &path, err))?;
            continue;
        }
        std::fs::remove_dir_all(&path).map_err(|err| io_err(out, "remove", &path, err))?;
        removed += 1;
    }
    Ok(removed)
}

impl Generation {
    /// Checks `out` and starts a new generation beside it (see the module
    /// documentation). The signed-report rule is checked by the caller.
    pub fn begin(out: &Path) -> Result<Generation, OutDirError> {
        Generation::begin_with(out, false)
    }

    /// Starts a generation from the staging directory that an interrupted
    /// or killed run of `out` left beside it with one of the files `keep`
    /// in it (the newest, when there are several); everything else in
    /// that directory is removed. Refused when there is none.
    pub fn resume(out: &Path, keep: &[&str]) -> Result<Generation, OutDirError> {
        let (parent, name) = split(out)?;
        let prefix = format!("{}new-", temp_prefix(&name));
        let mut left: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(&parent)
            .map(|entries| {
                entries
                    .flatten()
                    .filter(|e| {
                        let file = e.file_name().to_string_lossy().into_owned();
                        file.strip_prefix(&prefix)
                            .and_then(|pid| pid.parse::<u32>().ok())
                            .is_some_and(|pid| !crate::util::alive(pid))
                    })
                    .filter(|e| keep.iter().any(|k| e.path().join(k).is_file()))
                    .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
                    .collect()
            })
            .unwrap_or_default();
        left.sort();
        let Some((_, from)) = left.pop() else {
            return Err(OutDirError::Refused {
                dir: out.to_path_buf(),
                message: "has no interrupted run beside it to resume (no staging directory with a case store)".to_string(),
                hint: "run the plan without --resume".to_string(),
            });
        };
        let staging = parent.join(format!("{prefix}{}", std::process::id()));
        std::fs::rename(&from, &staging).map_err(|e| io_err(out, "take over", &from, e))?;
        for e in std::fs::read_dir(&staging)
            .map_err(|e| io_err(out, "list", &staging, e))?
            .flatten()
        {
            if !keep.contains(&e.file_name().to_string_lossy().as_ref()) {
                remove_tree(&e.path()).map_err(|err| io_err(out, "remove", &e.path(), err))?;
            }
        }
        Generation::begin_with(out, true)
    }

    /// Leaves the staging directory in place for a later
    /// [`Generation::resume`] (the run was interrupted); returns it.
    pub fn keep_for_resume(mut self) -> PathBuf {
        self.committed = true;
        self.staging.clone()
    }

    /// [`Generation::begin`], or with the staging directory already made
    /// (`staged`, by [`Generation::resume`]).
    fn begin_with(out: &Path, staged: bool) -> Result<Generation, OutDirError> {
        let (parent, name) = split(out)?;
        std::fs::create_dir_all(&parent).map_err(|e| OutDirError::Refused {
            dir: out.to_path_buf(),
            message: format!("cannot create its parent `{}`: {e}", parent.display()),
            hint: "choose an --out directory in a writable place".to_string(),
        })?;
        clean_stale(out)?;
        let kind = classify(out)?;
        if kind == DirKind::Foreign {
            return Err(OutDirError::Refused {
                dir: out.to_path_buf(),
                message: "is not empty and holds no ledflicker report (no `.ledflicker` marker or results.json); refusing to write into it".to_string(),
                hint: "give --out a new or empty directory; ledflicker only ever replaces reports it wrote".to_string(),
            });
        }
        let staging = parent.join(format!("{}new-{}", temp_prefix(&name), std::process::id()));
        // A staging directory taken over by `resume` is kept as it is.
        if !staged {
            if staging.exists() {
                std::fs::remove_dir_all(&staging)
                    .map_err(|e| io_err(out, "remove", &staging, e))?;
            }
            std::fs::create_dir(&staging).map_err(|e| OutDirError::Refused {
                dir: out.to_path_buf(),
                message: format!("cannot create `{}` next to it: {e}", staging.display()),
                hint: "choose an --out directory in a writable place".to_string(),
            })?;
        }
        let mut generation = Generation {
            out: out.to_path_buf(),
            staging,
            carried: BTreeSet::new(),
            owned: BTreeSet::new(),
            owned_files: None,
            has_previous: false,
            identity: identity(out),
            committed: false,
        };
        if let DirKind::Report { owned, files } = kind {
            generation.owned = owned;
            generation.owned_files = files;
            generation.carry_foreign()?;
            generation.has_previous = true;
        }
        Ok(generation)
    }

    /// The staging directory: write the report here.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The `--out` directory.
    pub fn out(&self) -> &Path {
        &self.out
    }

    /// The earlier report this generation replaces, when `--out` holds one:
    /// the writers may hard-link its unchanged files instead of writing
    /// them again ([`crate::report::WriteOptions::reuse_from`]).
    pub fn previous(&self) -> Option<&Path> {
        self.has_previous.then_some(self.out.as_path())
    }

    /// Links every entry of the old report that ledflicker did not write
    /// into the staging directory.
    fn carry_foreign(&mut self) -> Result<(), OutDirError> {
        // A user's file saved inside a folder the report writes (notes in
        // `traces/`) would go with the old generation: refused, named.
        if let Some(files) = &self.owned_files {
            for name in self
                .owned
                .iter()
                .filter(|n| REPORT_ENTRIES.contains(&n.as_str()))
            {
                let mut found = Vec::new();
                list_files(&self.out.join(name), name, &mut found)
                    .map_err(|e| io_err(&self.out, "list", &self.out.join(name), e))?;
                if let Some(theirs) = found.iter().find(|f| !files.contains(*f)) {
                    return Err(OutDirError::Refused {
                        dir: self.out.clone(),
                        message: format!(
                            "holds `{theirs}`, which ledflicker did not write there (its {MARKER} marker does not list it), in a folder the report replaces; refusing to lose it"
                        ),
                        hint: format!(
                            "move `{}` out of the report directory, then run again",
                            self.out.join(theirs).display()
                        ),
                    });
                }
            }
        }
        for (name, from) in self.foreign_entries()? {
            if REPORT_ENTRIES.contains(&name.as_str()) {
                // A user's file or folder under a name the report writes
                // (say a `frames/` made where the last run wrote none):
                // carried over, it would be replaced, and lost with the
                // old generation.
                return Err(OutDirError::Refused {
                    dir: self.out.clone(),
                    message: format!(
                        "holds `{name}`, which ledflicker did not write there (its {MARKER} marker does not list it), but a report writes `{name}`; refusing to replace it"
                    ),
                    hint: format!(
                        "move or rename `{}` out of the way, then run again",
                        from.display()
                    ),
                });
            }
            let to = self.staging.join(&name);
            link_tree(&from, &to).map_err(|err| io_err(&self.out, "keep", &from, err))?;
            self.carried.insert(name);
        }
        Ok(())
    }

    /// The entries of `out` now that ledflicker did not write, by name.
    fn foreign_entries(&self) -> Result<Vec<(String, PathBuf)>, OutDirError> {
        let entries = match std::fs::read_dir(&self.out) {
            Ok(entries) => entries,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(io_err(&self.out, "list", &self.out, e)),
        };
        let mut foreign = Vec::new();
        for e in entries {
            let e = e.map_err(|err| io_err(&self.out, "list", &self.out, err))?;
            let name = e.file_name().to_string_lossy().into_owned();
            if !self.owned.contains(&name) {
                foreign.push((name, e.path()));
            }
        }
        foreign.sort();
        Ok(foreign)
    }

    /// Carries the user's entries over again as they are now, just before
    /// the swap: a run can take hours, and in that time a user may save a
    /// new file into the directory, save an edit the usual editor way (a
    /// temporary file renamed over the original: a new file under the old
    /// name), or delete one. A user's entry under a name this run wrote is
    /// the one thing that cannot be carried: the swap is then refused.
    fn carry_foreign_again(&mut self) -> Result<(), OutDirError> {
        for name in std::mem::take(&mut self.carried) {
            let path = self.staging.join(&name);
            // Only links and copies this generation made: the user's own
            // files stay in `out`.
            remove_tree(&path).map_err(|e| io_err(&self.out, "refresh", &path, e))?;
        }
        for (name, from) in self.foreign_entries()? {
            let to = self.staging.join(&name);
            if std::fs::symlink_metadata(&to).is_ok() {
                return Err(self.keep_aside(&name, &from));
            }
            link_tree(&from, &to).map_err(|err| io_err(&self.out, "keep", &from, err))?;
            self.carried.insert(name);
        }
        Ok(())
    }

    /// Refuses the swap because the user's `name` (at `from`) sits where
    /// this run wrote an entry of that name: the new report is kept beside
    /// `out` under a visible name, and `out` is left as it is.
    fn keep_aside(&mut self, name: &str, from: &Path) -> OutDirError {
        let kept = aside_name(&self.out, "new");
        let error = |message: String, hint: String| OutDirError::Refused {
            dir: self.out.clone(),
            message,
            hint,
        };
        match std::fs::rename(&self.staging, &kept) {
            Ok(()) => {
                self.committed = true;
                error(
                    format!(
                        "`{name}` was put there during the run, and this run writes `{name}` too; the report was not swapped in, so nothing of yours is replaced. The new report is kept at `{}`",
                        kept.display()
                    ),
                    format!(
                        "move `{}` out of the way, then run again (or use the kept report as it is)",
                        from.display()
                    ),
                )
            }
            Err(e) => error(
                format!(
                    "`{name}` was put there during the run, and this run writes `{name}` too; the report was not swapped in (nor could it be kept aside: {e})"
                ),
                format!("move `{}` out of the way, then run again", from.display()),
            ),
        }
    }

    /// Writes the marker and swaps the new generation in; removes the old.
    ///
    /// The user's entries are carried over again first, as they are now.
    /// Should one change in the instant between that and the swap, the old
    /// generation is not removed but kept beside `out` under a visible
    /// name, returned in [`Committed::kept`]: nothing ledflicker did not
    /// write is ever deleted.
    pub fn commit(mut self) -> Result<Committed, OutDirError> {
        self.check_still_ours()?;
        self.carry_foreign_again()?;
        self.swap_in()
    }

    /// Refuses the swap when `out` is no longer the directory the run
    /// began with (replaced during the run, by a symbolic link to a
    /// user's folder or anything else): carrying "the user's entries" over
    /// from it would put another folder's files in the new report. The new
    /// report is kept beside `out`; nothing at `out` is touched.
    fn check_still_ours(&mut self) -> Result<(), OutDirError> {
        let now = identity(&self.out);
        if now == self.identity {
            return Ok(());
        }
        let kept = aside_name(&self.out, "new");
        let kept_note = match std::fs::rename(&self.staging, &kept) {
            Ok(()) => {
                self.committed = true;
                format!("; the new report is kept at `{}`", kept.display())
            }
            Err(e) => format!("; nor could the new report be kept aside: {e}"),
        };
        Err(OutDirError::Refused {
            dir: self.out.clone(),
            message: format!(
                "was replaced during the run (it is not the directory the run began with{}); the report was not swapped in, so nothing there is touched{kept_note}",
                match std::fs::symlink_metadata(&self.out) {
                    Ok(m) if m.file_type().is_symlink() => ": it is now a symbolic link",
                    Ok(_) => "",
                    Err(_) => ": it is gone",
                }
            ),
            hint: "let a run finish before moving or replacing its --out directory, then run again"
                .to_string(),
        })
    }

    /// [`Generation::commit`] after the user's entries were carried again.
    fn swap_in(mut self) -> Result<Committed, OutDirError> {
        self.write_marker()?;
        sync_dir(&self.staging);
        if !self.out.exists() {
            std::fs::rename(&self.staging, &self.out)
                .map_err(|e| io_err(&self.out, "rename", &self.staging, e))?;
            self.committed = true;
            sync_parent(&self.out);
            return Ok(Committed::default());
        }
        let old = match exchange(&self.staging, &self.out) {
            Ok(()) if identity(&self.staging) != self.identity => {
                // Replaced in the instant since the check: put it back.
                let _ = exchange(&self.staging, &self.out);
                return self.check_still_ours().map(|()| Committed::default());
            }
            Ok(()) => self.staging.clone(),
            Err(_) => {
                // Two renames; `clean_stale` restores `old` if we die between.
                let (parent, name) = split(&self.out)?;
                let old = parent.join(format!("{}old-{}", temp_prefix(&name), std::process::id()));
                std::fs::rename(&self.out, &old)
                    .map_err(|e| io_err(&self.out, "move aside", &self.out, e))?;
                if identity(&old) != self.identity {
                    let _ = std::fs::rename(&old, &self.out);
                    return self.check_still_ours().map(|()| Committed::default());
                }
                if let Err(e) = std::fs::rename(&self.staging, &self.out) {
                    let _ = std::fs::rename(&old, &self.out);
                    return Err(io_err(&self.out, "rename", &self.staging, e));
                }
                old
            }
        };
        self.committed = true;
        sync_parent(&self.out);
        let changed = self.changed_since_carried(&old);
        if !changed.is_empty() {
            let kept = aside_name(&self.out, "earlier");
            std::fs::rename(&old, &kept).map_err(|e| io_err(&self.out, "keep", &old, e))?;
            return Ok(Committed {
                kept: Some((kept, changed)),
            });
        }
        std::fs::remove_dir_all(&old).map_err(|e| io_err(&self.out, "remove", &old, e))?;
        Ok(Committed::default())
    }

    /// The user's entries of the old generation (now at `old`) that the
    /// new one does not hold as they are: changed after they were carried.
    fn changed_since_carried(&self, old: &Path) -> Vec<String> {
        let Ok(entries) = std::fs::read_dir(old) else {
            return Vec::new();
        };
        let mut changed: Vec<String> = entries
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|name| !self.owned.contains(name))
            .filter(|name| !same_tree(&old.join(name), &self.out.join(name)))
            .collect();
        changed.sort();
        changed
    }
}

/// What [`Generation::commit`] did beyond the swap.
#[derive(Debug, Default)]
pub struct Committed {
    /// The old generation, kept beside `--out` (and not removed) because
    /// these entries of the user's changed between their last carrying
    /// over and the swap.
    pub kept: Option<(PathBuf, Vec<String>)>,
}

impl Committed {
    /// A warning for the user, when the old generation was kept.
    pub fn warning(&self) -> Option<String> {
        let (dir, names) = self.kept.as_ref()?;
        Some(format!(
            "warning: {} changed while the report was swapped in; the earlier generation, with your version, is kept at `{}`: copy what you need from it, then remove it",
            names
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", "),
            dir.display()
        ))
    }
}

/// A visible name beside `out` that does not exist yet:
/// `<out>.<what>-<pid>`, then `-2`, `-3` ...
fn aside_name(out: &Path, what: &str) -> PathBuf {
    let base = format!("{}.{what}-{}", out.display(), std::process::id());
    let mut path = PathBuf::from(&base);
    let mut n = 2;
    while std::fs::symlink_metadata(&path).is_ok() {
        path = PathBuf::from(format!("{base}-{n}"));
        n += 1;
    }
    path
}

impl Drop for Generation {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

mod fs;
mod marker;
use fs::{exchange, link_tree, list_files, remove_tree, same_tree, sync_dir, sync_parent};

#[cfg(test)]
mod tests;
