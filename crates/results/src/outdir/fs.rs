//! The file-system steps of a generation: comparing, linking, listing
//! and removing trees, swapping two directories, and syncing.

use std::collections::BTreeSet;
use std::path::Path;

/// Whether `a` and `b` are the same tree: the same files (by inode: the
/// carried copies are hard links), symbolic links to the same target, and
/// folders of the same names, recursively. A copy (where a link failed)
/// compares by its bytes.
pub(super) fn same_tree(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let (Ok(ma), Ok(mb)) = (std::fs::symlink_metadata(a), std::fs::symlink_metadata(b)) else {
        return false;
    };
    let (ta, tb) = (ma.file_type(), mb.file_type());
    if ta.is_symlink() || tb.is_symlink() {
        return ta.is_symlink()
            && tb.is_symlink()
            && std::fs::read_link(a).ok() == std::fs::read_link(b).ok();
    }
    if ta.is_dir() || tb.is_dir() {
        if !(ta.is_dir() && tb.is_dir()) {
            return false;
        }
        let names = |d: &Path| -> Option<BTreeSet<std::ffi::OsString>> {
            std::fs::read_dir(d)
                .ok()
                .map(|it| it.flatten().map(|e| e.file_name()).collect())
        };
        let (Some(na), Some(nb)) = (names(a), names(b)) else {
            return false;
        };
        return na == nb && na.iter().all(|n| same_tree(&a.join(n), &b.join(n)));
    }
    if (ma.dev(), ma.ino()) == (mb.dev(), mb.ino()) {
        return true;
    }
    ma.len() == mb.len()
        && ta.is_file()
        && tb.is_file()
        && std::fs::read(a)
            .ok()
            .is_some_and(|x| std::fs::read(b).ok() == Some(x))
}

/// Removes a file, a symbolic link or a whole folder.
pub(super) fn remove_tree(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(path),
        Ok(_) => std::fs::remove_file(path),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Every entry but folders under `path` (a folder; nothing when it is
/// not one), as `rel/...` paths, into `out`.
pub(super) fn list_files(path: &Path, rel: &str, out: &mut Vec<String>) -> std::io::Result<()> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e),
    };
    if !meta.is_dir() {
        return Ok(());
    }
    for e in std::fs::read_dir(path)? {
        let e = e?;
        let name = e.file_name().to_string_lossy().into_owned();
        let child = format!("{rel}/{name}");
        if e.file_type()?.is_dir() {
            list_files(&e.path(), &child, out)?;
        } else {
            out.push(child);
        }
    }
    Ok(())
}

/// Swaps two directories atomically (Linux `renameat2(RENAME_EXCHANGE)`).
pub(super) fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| {
        std::ffi::CString::new(p.as_os_str().as_bytes())
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))
    };
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: two NUL-terminated paths that live across the call.
    let r = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Hard-links the file or tree `from` to `to`; copies where links fail.
pub(super) fn link_tree(from: &Path, to: &Path) -> std::io::Result<()> {
    let meta = std::fs::symlink_metadata(from)?;
    if meta.file_type().is_symlink() {
        let target = std::fs::read_link(from)?;
        return std::os::unix::fs::symlink(target, to);
    }
    if meta.is_dir() {
        std::fs::create_dir(to)?;
        std::fs::set_permissions(to, meta.permissions())?;
        for e in std::fs::read_dir(from)? {
            let e = e?;
            link_tree(&e.path(), &to.join(e.file_name()))?;
        }
        return Ok(());
    }
    if std::fs::hard_link(from, to).is_err() {
        std::fs::copy(from, to)?;
    }
    Ok(())
}

pub(super) fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}

pub(super) fn sync_parent(path: &Path) {
    if let Some(p) = path.parent() {
        sync_dir(if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        });
    }
}
