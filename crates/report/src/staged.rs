//! The report's folders (traces/, charts/, frames/), each filled aside
//! and renamed into place whole, reusing the earlier report's unchanged
//! files by hard link where that is safe.

use std::path::{Path, PathBuf};

use super::{ReportError, io_err};

/// Replaces `dir/name` by a directory holding `files` (name -> bytes),
/// built aside and renamed into place, so readers never see half of it
/// ([`StagedDir`]).
pub(crate) fn replace_dir(
    dir: &Path,
    name: &str,
    files: impl IntoIterator<Item = Result<(String, Vec<u8>), ReportError>>,
    reuse: Option<&Path>,
) -> Result<(), ReportError> {
    let mut staged = StagedDir::begin(dir, name, reuse)?;
    for made in files {
        let (file, bytes) = made?;
        staged.put(&file, &bytes)?;
    }
    staged.finish()
}

/// A directory of the report being filled aside, file by file, then
/// renamed over `dir/name` whole. A file whose bytes are those of the same
/// file in the earlier report's `name/` is hard-linked from there
/// ([`link_if_same`]) instead of written; every other file is created
/// anew, never written through an existing name.
pub(crate) struct StagedDir {
    staging: PathBuf,
    target: PathBuf,
    earlier: Option<EarlierDir>,
    fresh: FileIdentity,
}

impl StagedDir {
    pub(crate) fn begin(
        dir: &Path,
        name: &str,
        reuse: Option<&Path>,
    ) -> Result<StagedDir, ReportError> {
        let staging = dir.join(format!(".{name}.tmp-{}", std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
        }
        std::fs::create_dir_all(&staging).map_err(io_err(&staging))?;
        // The earlier report's folder, opened once, when it is a real
        // folder (a symbolic link may lead to a user's files), and what a
        // file written now would be: our owner, and the mode the umask
        // leaves (read off the folder just made, 0o777 less the umask).
        let earlier = reuse.and_then(|r| EarlierDir::open(r, name));
        let fresh = std::fs::metadata(&staging).map_err(io_err(&staging))?;
        let fresh = FileIdentity {
            uid: std::os::unix::fs::MetadataExt::uid(&fresh),
            mode: std::os::unix::fs::MetadataExt::mode(&fresh) & 0o666,
        };
        Ok(StagedDir {
            staging,
            target: dir.join(name),
            earlier,
            fresh,
        })
    }

    pub(crate) fn put(&mut self, file: &str, bytes: &[u8]) -> Result<(), ReportError> {
        let path = self.staging.join(file);
        if let Some(earlier) = &self.earlier
            && link_if_same(earlier, file, bytes, &path, self.fresh)
        {
            return Ok(());
        }
        write_new(&path, bytes).map_err(io_err(&path))
    }

    pub(crate) fn finish(self) -> Result<(), ReportError> {
        if self.target.exists() {
            std::fs::remove_dir_all(&self.target).map_err(io_err(&self.target))?;
        }
        std::fs::rename(&self.staging, &self.target).map_err(io_err(&self.target))
    }
}

/// Creates `path` holding `bytes`; a file already there (a name given
/// twice, or a link) is unlinked first, never written through: the last
/// bytes win, and a linked earlier file is left as it was.
fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    let create = || {
        std::fs::File::options()
            .write(true)
            .create_new(true)
            .open(path)
    };
    let mut file = match create() {
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            std::fs::remove_file(path)?;
            create()?
        }
        other => other?,
    };
    file.write_all(bytes)
}

/// Owner and permission bits a file created now gets.
#[derive(Debug, Clone, Copy)]
struct FileIdentity {
    uid: u32,
    mode: u32,
}

/// A folder of the earlier report (`traces/`, `charts/`, `frames/`),
/// opened once as a directory handle: every file is then opened and
/// linked relative to it, never by a path, so a folder swapped for a
/// symbolic link (to a user's own folder, say) while the run goes on
/// cannot make the new report share a user's file.
#[derive(Debug)]
struct EarlierDir(std::os::fd::OwnedFd);

impl EarlierDir {
    /// `report/name` when both are real directories (neither a symbolic
    /// link); `None` otherwise, and then nothing is reused.
    fn open(report: &Path, name: &str) -> Option<EarlierDir> {
        use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
        use std::os::unix::ffi::OsStrExt;
        let flags = libc::O_RDONLY | libc::O_DIRECTORY | libc::O_NOFOLLOW | libc::O_CLOEXEC;
        let open_at = |at: libc::c_int, p: &[u8]| -> Option<OwnedFd> {
            let c = std::ffi::CString::new(p).ok()?;
            // SAFETY: a NUL-terminated path and a descriptor that outlives
            // the call; a non-negative result is a new descriptor we own.
            let fd = unsafe { libc::openat(at, c.as_ptr(), flags) };
            (fd >= 0).then(|| unsafe { OwnedFd::from_raw_fd(fd) })
        };
        if name.contains('/') {
            return None;
        }
        let report = open_at(libc::AT_FDCWD, report.as_os_str().as_bytes())?;
        open_at(report.as_raw_fd(), name.as_bytes()).map(EarlierDir)
    }

    /// `file` of this folder, opened for reading without following a
    /// symbolic link and without waiting on a FIFO or device.
    fn open_file(&self, file: &str) -> Option<std::fs::File> {
        use std::os::fd::{AsRawFd, FromRawFd};
        if file.contains('/') {
            return None;
        }
        let c = std::ffi::CString::new(file).ok()?;
        let flags = libc::O_RDONLY | libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_CLOEXEC;
        // SAFETY: as in `open`.
        let fd = unsafe { libc::openat(self.0.as_raw_fd(), c.as_ptr(), flags) };
        (fd >= 0).then(|| unsafe { std::fs::File::from_raw_fd(fd) })
    }

    /// Hard-links `file` of this folder to `to` (`linkat` without
    /// following a symbolic link).
    fn link(&self, file: &str, to: &Path) -> std::io::Result<()> {
        use std::os::fd::AsRawFd;
        use std::os::unix::ffi::OsStrExt;
        let c = |b: &[u8]| {
            std::ffi::CString::new(b)
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))
        };
        let (from, to) = (c(file.as_bytes())?, c(to.as_os_str().as_bytes())?);
        // SAFETY: two NUL-terminated paths that live across the call.
        let r = unsafe {
            libc::linkat(
                self.0.as_raw_fd(),
                from.as_ptr(),
                libc::AT_FDCWD,
                to.as_ptr(),
                0,
            )
        };
        if r == 0 {
            Ok(())
        } else {
            Err(std::io::Error::last_os_error())
        }
    }
}

/// Hard-links `file` of the earlier report's folder to `path` when it is
/// a file that a write now would make again: a regular file (not a
/// symbolic link), linked nowhere else, of this run's owner and permission
/// bits (`fresh`), holding exactly `bytes`. Returns false, with nothing
/// made, otherwise; the caller then writes the file.
///
/// Rewriting an unchanged file costs a new inode and, when the old report
/// is removed, a freed one; on ext4 without a journal each new inode is
/// searched for past the inodes freed in the last minutes, so a report
/// re-run in place got slower run after run (docs/speed.md, "Where the
/// time goes"). A file with other links (a user's
/// hard-linked copy of the report, say) is never shared. The file is read
/// and checked through one handle, and the link is kept only if it names
/// that same file, unchanged, with the one new link: a file replaced or
/// written between the check and the link is not taken. The linked file
/// keeps its modification time (it is the file of the earlier run).
fn link_if_same(
    earlier: &EarlierDir,
    file: &str,
    bytes: &[u8],
    path: &Path,
    fresh: FileIdentity,
) -> bool {
    use std::io::Read as _;
    use std::os::unix::fs::MetadataExt;
    let Some(mut handle) = earlier.open_file(file) else {
        return false;
    };
    let Ok(before) = handle.metadata() else {
        return false;
    };
    let ours = before.file_type().is_file()
        && before.nlink() == 1
        && before.uid() == fresh.uid
        && before.mode() & 0o7777 == fresh.mode
        && before.len() == bytes.len() as u64;
    let mut held = Vec::with_capacity(bytes.len());
    if !ours || handle.read_to_end(&mut held).is_err() || held != bytes {
        return false;
    }
    if earlier.link(file, path).is_err() {
        return false;
    }
    let unchanged = |m: &std::fs::Metadata| {
        m.dev() == before.dev()
            && m.ino() == before.ino()
            && m.nlink() == 2
            && m.len() == before.len()
            && (m.mtime(), m.mtime_nsec()) == (before.mtime(), before.mtime_nsec())
    };
    let kept = std::fs::symlink_metadata(path).is_ok_and(|m| unchanged(&m))
        && handle.metadata().is_ok_and(|m| unchanged(&m));
    if !kept {
        let _ = std::fs::remove_file(path);
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Replaces `dir/traces` by `files`, linking from `earlier/traces`.
    fn replace(dir: &Path, files: &[(String, Vec<u8>)], earlier: &Path) {
        replace_dir(dir, "traces", files.iter().cloned().map(Ok), Some(earlier)).unwrap();
    }

    /// A fresh scratch folder for one test.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("ledflicker-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn replace_dir_links_only_unchanged_files_the_earlier_report_alone_holds() {
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        let dir = scratch("link");
        let (earlier, new) = (dir.join("earlier"), dir.join("new"));
        let old = earlier.join("traces");
        std::fs::create_dir_all(&old).unwrap();
        std::fs::create_dir_all(&new).unwrap();
        let put = |path: &Path, bytes: &[u8]| write_new(path, bytes).unwrap();
        for name in [
            "same.csv",
            "changed.csv",
            "longer.csv",
            "shared.csv",
            "private.csv",
        ] {
            put(&old.join(name), b"1,2\n");
        }
        put(&old.join("dup.csv"), b"A\n");
        // A FIFO where a file was: opening it must not wait for a writer.
        let fifo =
            std::ffi::CString::new(old.join("fifo.csv").into_os_string().into_encoded_bytes())
                .unwrap();
        // SAFETY: a NUL-terminated path that lives across the call.
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
        // A user's hard-linked copy, a symbolic link to a user's file of
        // the same bytes, and a file of other permission bits.
        std::fs::hard_link(old.join("shared.csv"), dir.join("users-copy.csv")).unwrap();
        put(&dir.join("users.csv"), b"1,2\n");
        std::os::unix::fs::symlink(dir.join("users.csv"), old.join("link.csv")).unwrap();
        let mode = std::fs::metadata(old.join("private.csv")).unwrap().mode() & 0o7777;
        let other = std::fs::Permissions::from_mode(mode ^ 0o020);
        std::fs::set_permissions(old.join("private.csv"), other).unwrap();
        let ino = |p: &Path| std::fs::symlink_metadata(p).unwrap().ino();
        let before: Vec<(String, u64)> = std::fs::read_dir(&old)
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| {
                (
                    p.file_name().unwrap().to_string_lossy().into_owned(),
                    ino(&p),
                )
            })
            .collect();
        let files: Vec<(String, Vec<u8>)> = [
            ("same.csv", &b"1,2\n"[..]),
            ("changed.csv", b"1,3\n"),
            ("longer.csv", b"1,2,3\n"),
            ("shared.csv", b"1,2\n"),
            ("link.csv", b"1,2\n"),
            ("private.csv", b"1,2\n"),
            ("missing.csv", b"1,2\n"),
            ("fifo.csv", b""),
            // A name given twice: the second must not write through the
            // link the first made.
            ("dup.csv", b"A\n"),
            ("dup.csv", b"B\n"),
        ]
        .iter()
        .map(|(n, b)| (n.to_string(), b.to_vec()))
        .collect();
        replace(&new, &files, &earlier);

        let got = new.join("traces");
        let linked: Vec<&str> = [
            "same.csv",
            "changed.csv",
            "longer.csv",
            "shared.csv",
            "link.csv",
            "private.csv",
            "dup.csv",
        ]
        .into_iter()
        .filter(|n| ino(&got.join(n)) == ino(&old.join(n)))
        .collect();
        assert_eq!(linked, ["same.csv"]);
        // Every file holds its bytes (the last of a name given twice) ...
        for (name, bytes) in &files[..8] {
            assert_eq!(&std::fs::read(got.join(name)).unwrap(), bytes, "{name}");
        }
        assert_eq!(std::fs::read(got.join("dup.csv")).unwrap(), b"B\n");
        assert!(
            !std::fs::symlink_metadata(got.join("link.csv"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        // ... and the earlier report and the user's files are as they were.
        for (name, ino_before) in &before {
            assert_eq!(ino(&old.join(name)), *ino_before, "{name}");
        }
        assert_eq!(std::fs::read(old.join("dup.csv")).unwrap(), b"A\n");
        assert_eq!(std::fs::read(old.join("changed.csv")).unwrap(), b"1,2\n");
        assert_eq!(std::fs::metadata(dir.join("users.csv")).unwrap().nlink(), 1);
        assert_eq!(
            std::fs::metadata(dir.join("users-copy.csv"))
                .unwrap()
                .nlink(),
            2
        );

        // An earlier traces/ that is a symbolic link (to a user's folder of
        // the same files) is not looked into.
        let (earlier2, new2) = (dir.join("earlier2"), dir.join("new2"));
        std::fs::create_dir_all(&earlier2).unwrap();
        std::fs::create_dir_all(&new2).unwrap();
        std::os::unix::fs::symlink(&old, earlier2.join("traces")).unwrap();
        replace(&new2, &files[..1], &earlier2);
        assert_ne!(
            ino(&new2.join("traces/same.csv")),
            ino(&old.join("same.csv"))
        );
        assert_eq!(std::fs::metadata(old.join("same.csv")).unwrap().nlink(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_folder_swapped_for_a_link_to_a_users_folder_mid_run_shares_none_of_its_files() {
        use std::os::unix::fs::MetadataExt;
        let dir = scratch("swap");
        let (earlier, users, new) = (dir.join("earlier"), dir.join("users"), dir.join("new"));
        for d in [&earlier.join("traces"), &users, &new] {
            std::fs::create_dir_all(d).unwrap();
        }
        write_new(&earlier.join("traces/case.csv"), b"1,2\n").unwrap();
        write_new(&users.join("case.csv"), b"1,2\n").unwrap();
        let fresh = std::fs::metadata(earlier.join("traces/case.csv")).unwrap();
        let fresh = FileIdentity {
            uid: fresh.uid(),
            mode: fresh.mode() & 0o7777,
        };
        // The folder is opened when the report starts writing it; then,
        // while the run goes on, someone puts a link to the user's folder
        // in its place.
        let handle = EarlierDir::open(&earlier, "traces").unwrap();
        std::fs::rename(earlier.join("traces"), earlier.join("moved")).unwrap();
        std::os::unix::fs::symlink(&users, earlier.join("traces")).unwrap();
        let path = new.join("case.csv");
        link_if_same(&handle, "case.csv", b"1,2\n", &path, fresh);
        let ino = |p: &Path| std::fs::metadata(p).unwrap().ino();
        assert_ne!(ino(&path), ino(&users.join("case.csv")));
        assert_eq!(
            std::fs::metadata(users.join("case.csv")).unwrap().nlink(),
            1
        );
        // A folder that is a link when the report starts is not opened.
        assert!(EarlierDir::open(&earlier, "traces").is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
