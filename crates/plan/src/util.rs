//! Small helpers shared across the pipeline: hashing, dates, atomic writes.

use std::io::Write;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

/// SHA-256 of `bytes` as lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// Gives the memory freed since the last call back to the system, where
/// the allocator keeps it otherwise: glibc keeps freed memory in the arena
/// of the thread that used it, so memory one stage freed on the PDF
/// engine's or the analyses' threads is not reused by the next stage on
/// another thread, and the process's peak would be the sum of the stages
/// instead of the largest.
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks the allocator's own free lists and
    // is safe to call from any thread at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// `bytes` as lowercase hex, e.g. a digest.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// `x` with `digits` decimals, never "-0.000": a value that rounds to zero
/// prints as zero whatever the sign of its rounding error.
pub fn fixed(x: f64, digits: usize) -> String {
    let s = format!("{x:.digits$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// Civil date `YYYY-MM-DD` (UTC) of a Unix time in seconds, from 0 to
/// [`MAX_UNIX_S`] (clamped to that range).
pub fn utc_date(unix_s: i64) -> String {
    // Whole days from the epoch: jiff's timestamps stop a day short of
    // 9999-12-31 (they leave room for any UTC offset); civil dates do not.
    let days = unix_s.clamp(0, MAX_UNIX_S).div_euclid(86_400);
    jiff::civil::date(1970, 1, 1)
        .checked_add(jiff::Span::new().days(days))
        .map_or_else(|_| "9999-12-31".to_string(), |d| d.to_string())
}

/// Last second of 9999-12-31, UTC: the largest Unix time a `YYYY-MM-DD`
/// date can show.
pub const MAX_UNIX_S: i64 = 253_402_300_799;

/// True when `d` is `YYYY-MM-DD` in ASCII digits and a real Gregorian
/// date, years 0001 to 9999.
pub fn is_calendar_date(d: &str) -> bool {
    let shape = d.len() == 10
        && d.bytes().enumerate().all(|(i, c)| {
            if i == 4 || i == 7 {
                c == b'-'
            } else {
                c.is_ascii_digit()
            }
        });
    shape && jiff::civil::Date::strptime("%Y-%m-%d", d).is_ok_and(|date| date.year() >= 1)
}

/// Opens a file the user named as input, for reading, without ever
/// waiting on it: non-blocking, so that a FIFO or a device in its place
/// does not hang the tool, then refused unless it is a regular file
/// (symbolic links are followed; the target must be a regular file). The
/// returned handle reads normally (blocking mode is restored).
///
/// The error is `InvalidInput` with "is a FIFO, not a regular file" (or a
/// directory, device, socket) for anything but a regular file.
pub fn open_input(path: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
    use std::os::unix::io::AsRawFd;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_CLOEXEC)
        .open(path)?;
    let kind = file.metadata()?.file_type();
    if !kind.is_file() {
        let what = if kind.is_fifo() {
            "a FIFO (named pipe)"
        } else if kind.is_dir() {
            "a directory"
        } else if kind.is_char_device() || kind.is_block_device() {
            "a device"
        } else if kind.is_socket() {
            "a socket"
        } else {
            "not a file"
        };
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            NotRegularFile(what),
        ));
    }
    // SAFETY: fcntl on a descriptor this function owns; clearing
    // O_NONBLOCK has no effect on a regular file's reads but keeps the
    // handle ordinary for the code that reads it.
    unsafe {
        let fd = file.as_raw_fd();
        let flags = libc::fcntl(fd, libc::F_GETFL);
        if flags >= 0 {
            libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK);
        }
    }
    Ok(file)
}

/// What [`open_input`] refuses: an input that is not a regular file (the
/// payload of its `io::Error`; see [`is_not_regular`]).
#[derive(Debug, thiserror::Error)]
#[error("is {0}, not a regular file; give a regular file")]
pub struct NotRegularFile(pub &'static str);

/// True when `e` is [`open_input`]'s refusal of a FIFO, device, socket or
/// directory: the user's input, not the tool, is at fault (exit code 2).
pub fn is_not_regular(e: &std::io::Error) -> bool {
    e.get_ref()
        .is_some_and(|inner| inner.is::<NotRegularFile>())
}

/// [`std::fs::read`] through [`open_input`]: the whole of a regular file.
pub fn read_input(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut file = open_input(path)?;
    let mut bytes = Vec::new();
    file.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// [`std::fs::read_to_string`] through [`open_input`].
pub fn read_input_to_string(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_input(path)?)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error()))
}

/// True when `path` names something other than a regular file (a FIFO, a
/// device, a socket or a directory), without opening it. Use before
/// handing a path to another program (ffmpeg) that would block on it.
pub fn is_special_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.file_type().is_file())
}

/// Writes `bytes` to `path` atomically: a temporary file in the same
/// directory, flushed to disk, then renamed over `path`. A reader sees the
/// old file or the new one, never half of one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    Staged::write(path, bytes)?.commit()
}

/// A file written and flushed to disk under a temporary name beside
/// `path`, not yet renamed over it: [`write_atomic`] in two steps, so that
/// the slow part (the flush) can run early or beside other work and the
/// renames come in the order the caller needs. Dropped without
/// [`Staged::commit`], it removes its temporary file.
///
/// The temporary file is `tempfile`'s: a new random name (`.NAME.XXXXXX.tmp`)
/// created exclusively, so a file or link already there under that name is
/// never written through.
#[derive(Debug)]
pub struct Staged {
    tmp: tempfile::NamedTempFile,
    path: PathBuf,
}

impl Staged {
    /// Writes `bytes` under a temporary name in `path`'s directory and
    /// flushes them to disk.
    pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<Staged> {
        Self::write_with(path, |out| out.write_all(bytes))
    }

    /// [`Self::write`] with the bytes from `fill`, through a buffer, so
    /// that a large file need not be held whole in memory first.
    pub fn write_with(
        path: &Path,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> std::io::Result<Staged> {
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = path.file_name().ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "path has no file name")
        })?;
        // Mode 0666 less the umask, as `File::create` gives: a report's
        // files are for its readers, not the 0600 of a private scratch file.
        let mut tmp = tempfile::Builder::new()
            .prefix(&format!(".{}.", name.to_string_lossy()))
            .suffix(".tmp")
            .permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666))
            .tempfile_in(dir)?;
        {
            let mut out = std::io::BufWriter::new(tmp.as_file_mut());
            fill(&mut out)?;
            out.flush()?;
        }
        tmp.as_file().sync_all()?;
        Ok(Staged {
            tmp,
            path: path.to_path_buf(),
        })
    }

    /// The path the file is renamed to.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renames the file over its path.
    pub fn commit(self) -> std::io::Result<()> {
        self.tmp.persist(&self.path).map(drop).map_err(|e| e.error)
    }
}

/// True while process `pid` exists (it may belong to another user).
pub fn alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: kill with signal 0 only checks that the process exists.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// Sends SIGKILL to every process of group `pgid`: a command this process
/// started with `process_group(0)` (its pid is the group id) and whatever
/// it started.
pub fn kill_group(pgid: u32) {
    let Ok(pgid) = libc::pid_t::try_from(pgid) else {
        return;
    };
    if pgid <= 1 {
        return;
    }
    // SAFETY: kill(2) on a negative pid signals that process group; callers
    // pass the pid of a child they started as a group leader.
    unsafe {
        libc::kill(-pgid, libc::SIGKILL);
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn an_input_that_is_a_fifo_is_refused_at_once_not_waited_on() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("frames.y4m");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo on a path in a fresh temporary directory.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let err = super::read_input(&fifo).unwrap_err();
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
        assert!(super::is_not_regular(&err));
        assert!(err.to_string().contains("FIFO"), "{err}");
        let err = super::read_input(dir.path()).unwrap_err();
        assert!(err.to_string().contains("directory"), "{err}");
        let err = super::read_input(std::path::Path::new("/dev/null")).unwrap_err();
        assert!(err.to_string().contains("device"), "{err}");
        let file = dir.path().join("plan.toml");
        std::fs::write(&file, "x = 1").unwrap();
        assert_eq!(super::read_input_to_string(&file).unwrap(), "x = 1");
    }

    #[test]
    fn a_staged_file_is_renamed_on_commit_and_removed_if_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results.json");
        std::fs::write(&path, "old").unwrap();
        let names = || {
            let mut n: Vec<String> = std::fs::read_dir(dir.path())
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            n.sort();
            n
        };
        // Written and flushed, not yet in place: the old file stands.
        let staged = Staged::write(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(names().len(), 2);
        drop(staged);
        assert_eq!(names(), ["results.json"], "a dropped file leaves nothing");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        Staged::write(&path, b"new").unwrap().commit().unwrap();
        assert_eq!(names(), ["results.json"]);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
    }

    use super::*;

    #[test]
    fn sha256_of_abc_is_the_fips_vector() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn calendar_dates_are_checked_by_month_and_leap_year() {
        assert!(is_calendar_date("2024-02-29"));
        assert!(is_calendar_date("2000-02-29"));
        assert!(!is_calendar_date("1900-02-29"));
        assert!(!is_calendar_date("2026-13-01"));
        assert!(!is_calendar_date("2026-04-31"));
        assert!(!is_calendar_date("2026-00-10"));
        assert!(!is_calendar_date("0000-01-01"));
        assert_eq!(utc_date(MAX_UNIX_S), "9999-12-31");
    }

    #[test]
    fn utc_dates_match_known_days() {
        assert_eq!(utc_date(0), "1970-01-01");
        assert_eq!(utc_date(951_782_400), "2000-02-29");
        assert_eq!(utc_date(1_795_305_600), "2026-11-22");
    }

    /// A staged file lands with the mode `File::create` gives, holds the
    /// bytes, and leaves nothing behind when dropped uncommitted.
    #[test]
    fn staged_files_commit_with_the_usual_mode_and_vanish_when_dropped() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        std::fs::File::create(&plain).unwrap();
        let path = dir.path().join("results.json");
        write_atomic(&path, b"{}").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"{}");
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&path), mode(&plain));
        drop(Staged::write(&dir.path().join("other"), b"x").unwrap());
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["plain", "results.json"]);
    }
}
