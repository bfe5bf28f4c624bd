//! The manifest: a plain text file in `sha256sum` format, one line per
//! report file (`<sha256>  <relative path>`), with `#` comment lines that
//! `sha256sum -c` skips: who signed, the certificate, the date, the size of
//! report.pdf at signing, and every input with its size and SHA-256.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::inputs::InputFile;

/// First line of every manifest.
pub const HEADER: &str = "# ledflicker sign-off manifest 1; check the files with `sha256sum -c manifest.txt` in the report directory";

/// A parsed manifest.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Manifest {
    /// "Name, Role".
    pub signer: String,
    /// `YYYY-MM-DD`.
    pub date: String,
    /// SHA-256 of the signer's certificate (DER), hex.
    pub certificate_sha256: String,
    /// Size of report.pdf when this manifest was signed, bytes.
    pub pdf_bytes: Option<u64>,
    /// Relative path (with `/`) -> SHA-256, hex.
    pub files: BTreeMap<String, String>,
    /// The run's inputs.
    pub inputs: Vec<InputFile>,
}

impl Manifest {
    /// The text of the manifest.
    pub fn to_text(&self) -> String {
        let mut t = format!("{HEADER}\n");
        t.push_str(&format!("# signer: {}\n", self.signer));
        t.push_str(&format!("# date: {}\n", self.date));
        t.push_str(&format!(
            "# certificate-sha256: {}\n",
            self.certificate_sha256
        ));
        if let Some(n) = self.pdf_bytes {
            t.push_str(&format!("# report.pdf-bytes: {n}\n"));
        }
        for i in &self.inputs {
            t.push_str(&format!(
                "# input {} {} {} {}\n",
                i.role, i.size, i.sha256, i.path
            ));
        }
        for (path, sha) in &self.files {
            t.push_str(&format!("{sha}  {path}\n"));
        }
        t
    }

    /// Parses a manifest; `Err` names the first bad line.
    pub fn parse(text: &str) -> Result<Manifest, String> {
        let mut m = Manifest::default();
        let mut lines = text.lines().enumerate();
        if lines.next().map(|(_, l)| l) != Some(HEADER) {
            return Err("the first line is not the ledflicker manifest header".to_string());
        }
        for (i, line) in lines {
            let bad = || format!("line {} is malformed: `{line}`", i + 1);
            if let Some(c) = line.strip_prefix("# ") {
                let (key, value) = c.split_once(' ').ok_or_else(bad)?;
                match key {
                    "signer:" => m.signer = value.to_string(),
                    "date:" => m.date = value.to_string(),
                    "certificate-sha256:" => m.certificate_sha256 = value.to_string(),
                    "report.pdf-bytes:" => m.pdf_bytes = Some(value.parse().map_err(|_| bad())?),
                    "input" => m.inputs.push(parse_input(value).ok_or_else(bad)?),
                    _ => return Err(bad()),
                }
                continue;
            }
            let (sha, path) = line.split_once("  ").ok_or_else(bad)?;
            if sha.len() != 64 || !sha.bytes().all(|b| b.is_ascii_hexdigit()) || path.is_empty() {
                return Err(bad());
            }
            m.files.insert(path.to_string(), sha.to_ascii_lowercase());
        }
        if m.signer.is_empty() || m.certificate_sha256.is_empty() {
            return Err("the manifest names no signer or certificate".to_string());
        }
        Ok(m)
    }
}

fn parse_input(value: &str) -> Option<InputFile> {
    let mut parts = value.splitn(4, ' ');
    let role = parts.next()?.to_string();
    let size = parts.next()?.parse().ok()?;
    let sha256 = parts.next()?.to_string();
    let path = parts.next()?.to_string();
    (sha256.len() == 64).then_some(InputFile {
        role,
        path,
        sha256,
        size,
    })
}

/// Top-level entries of a report directory outside the signature: the
/// manifest and its signature themselves. The `.ledflicker` marker is
/// signed like any file (`plan` writes it before it signs); a manifest
/// signed before it was covered does not list it (see
/// `verify::check_files`).
pub const UNSIGNED: [&str; 2] = [super::MANIFEST_FILE, super::SIGNATURE_FILE];

/// A private key file given to `sign`, to be recognised inside the report
/// directory by identity (same device and inode: a hard link) or by
/// content (a copy), whatever its format.
#[derive(Debug, Clone)]
pub struct KnownKey {
    /// As given on the command line.
    pub path: PathBuf,
    dev: u64,
    ino: u64,
    sha256: String,
}

impl KnownKey {
    /// Identity and SHA-256 of the key file at `path`.
    pub fn of(path: &Path) -> std::io::Result<KnownKey> {
        use std::os::unix::fs::MetadataExt;
        let file = crate::util::open_input(path)?;
        let meta = file.metadata()?;
        let seen = inspect(file, &mut Vec::new())?;
        Ok(KnownKey {
            path: path.to_path_buf(),
            dev: meta.dev(),
            ino: meta.ino(),
            sha256: seen.sha256,
        })
    }
}

/// What a scan of a report directory found.
#[derive(Debug, Clone, Default)]
pub struct Scan {
    /// Relative path (with `/`) -> SHA-256 of every regular file,
    /// dotfiles included.
    pub files: BTreeMap<String, String>,
    /// Entries refused without being read: special files (FIFO, device,
    /// socket), symbolic links, names that are not UTF-8 or hold a
    /// newline or backslash.
    pub refused: Vec<String>,
    /// Folders (with a trailing `/`) that hold no file at any depth: a
    /// manifest lists files only, so it cannot cover them. A folder of
    /// empty folders is named once, at its top.
    pub empty_dirs: Vec<String>,
    /// Files that are private keys, each as "`path`: what it is", among
    /// every regular file of the directory, the unsigned names included.
    pub keys: Vec<String>,
}

/// Hashes every file under `dir` but the top-level names in `skip`, and
/// looks at every file (those in `skip` too) for private keys: PEM, DER
/// PKCS#8 (plain or encrypted), PKCS#12, and the files of `known` by
/// identity or content. Special files are refused by their type and
/// never opened.
pub fn scan(dir: &Path, skip: &[&str], known: &[KnownKey]) -> std::io::Result<Scan> {
    let mut out = Scan::default();
    let mut buf = Vec::new();
    walk(dir, "", skip, known, &mut buf, &mut out)?;
    Ok(out)
}

/// Walks `dir`; true when it holds anything but folders, at any depth.
fn walk(
    dir: &Path,
    prefix: &str,
    skip: &[&str],
    known: &[KnownKey],
    buf: &mut Vec<u8>,
    out: &mut Scan,
) -> std::io::Result<bool> {
    let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<Result<_, _>>()?;
    entries.sort_by_key(|e| e.file_name());
    let mut holds_files = false;
    for e in entries {
        let raw = e.file_name();
        let shown = format!("{prefix}{}", raw.to_string_lossy());
        let kind = e.file_type()?;
        if !kind.is_dir() {
            holds_files = true;
        }
        let Some(name) = raw.to_str().filter(|n| !n.contains(['\n', '\r', '\\'])) else {
            out.refused
                .push(format!("`{shown}`: a file name sha256sum cannot list"));
            continue;
        };
        let skipped = prefix.is_empty() && skip.contains(&name);
        let rel = format!("{prefix}{name}");
        if kind.is_file() {
            let sha = look_at_file(&e.path(), &rel, known, buf, out)?;
            if !skipped {
                out.files.insert(rel, sha);
            }
        } else if skipped {
            continue;
        } else if kind.is_dir() {
            let named = out.empty_dirs.len();
            if walk(&e.path(), &format!("{rel}/"), skip, known, buf, out)? {
                holds_files = true;
            } else {
                out.empty_dirs.truncate(named);
                out.empty_dirs.push(format!("{rel}/"));
            }
        } else if kind.is_symlink() {
            out.refused
                .push(format!("`{rel}`: a symbolic link (not followed)"));
        } else {
            out.refused.push(format!(
                "`{rel}`: a special file (FIFO, device or socket), not read"
            ));
        }
    }
    Ok(holds_files)
}

/// Hashes the regular file `path` and records it in `out.keys` when it is
/// a private key; returns its SHA-256.
fn look_at_file(
    path: &Path,
    rel: &str,
    known: &[KnownKey],
    buf: &mut Vec<u8>,
    out: &mut Scan,
) -> std::io::Result<String> {
    use std::os::unix::fs::MetadataExt;
    // Opened without blocking: the entry may have been swapped for a FIFO
    // since it was listed.
    let file = crate::util::open_input(path)?;
    let meta = file.metadata()?;
    let seen = inspect(file, buf)?;
    let what = if let Some(k) = known
        .iter()
        .find(|k| (k.dev, k.ino) == (meta.dev(), meta.ino()))
    {
        Some(format!(
            "the signing key `{}` itself (a hard link to it)",
            k.path.display()
        ))
    } else if let Some(k) = known.iter().find(|k| k.sha256 == seen.sha256) {
        Some(format!("a copy of the signing key `{}`", k.path.display()))
    } else {
        key_format(&seen).map(str::to_string)
    };
    if let Some(what) = what {
        out.keys.push(format!("`{rel}`: {what}"));
    }
    Ok(seen.sha256)
}

/// Files larger than this are not parsed as DER keys. The largest DER key
/// in use is a PKCS#8 RSA-16384 key at about 9.3 KiB (RSA-4096: 2348
/// bytes; P-256: 138 bytes), and a PKCS#12 file holding a key and a chain
/// of a few certificates is a few KiB (`openssl pkcs12 -export` of a P-256
/// key and certificate: 1072 bytes; an RSA-4096 certificate adds about 2 KiB),
/// so 64 KiB leaves a wide margin while the report's large files (the PDF,
/// frames, traces) are never held in memory whole. PEM keys are found in
/// files of any size, while they are hashed.
const MAX_DER_KEY_BYTES: usize = 64 << 10;

/// The part of every PEM label of a private key: `PRIVATE KEY`,
/// `ENCRYPTED PRIVATE KEY`, `RSA PRIVATE KEY`, `EC PRIVATE KEY`,
/// `OPENSSH PRIVATE KEY`, ... at the end of its `-----BEGIN` line.
const PEM_KEY_MARK: &[u8] = b"PRIVATE KEY-----";

/// A file read once: its SHA-256, and what is needed to tell a key.
struct Seen {
    sha256: String,
    /// A PEM private key line occurs somewhere in the file.
    pem_key: bool,
    /// The whole file when it is at most [`MAX_DER_KEY_BYTES`] long.
    small: Option<Vec<u8>>,
}

/// Reads `file` in chunks, hashing it and looking for a PEM key line;
/// `buf` is the reusable read buffer.
fn inspect(mut file: std::fs::File, buf: &mut Vec<u8>) -> std::io::Result<Seen> {
    use sha2::{Digest, Sha256};
    use std::io::Read;
    buf.resize(1 << 20, 0);
    let finder = memchr::memmem::Finder::new(PEM_KEY_MARK);
    let mut hasher = Sha256::new();
    let mut small = Vec::new();
    let mut size = 0usize;
    let mut pem_key = false;
    // The end of the previous chunk, so that a mark split between two
    // reads is found too.
    let mut tail: Vec<u8> = Vec::with_capacity(2 * PEM_KEY_MARK.len());
    loop {
        let n = match file.read(buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        let chunk = &buf[..n];
        hasher.update(chunk);
        if small.len() <= MAX_DER_KEY_BYTES {
            let room = MAX_DER_KEY_BYTES + 1 - small.len();
            small.extend_from_slice(&chunk[..n.min(room)]);
        }
        size += n;
        if !pem_key {
            tail.extend_from_slice(&chunk[..n.min(PEM_KEY_MARK.len() - 1)]);
            pem_key = finder.find(&tail).is_some() || finder.find(chunk).is_some();
            tail.clear();
            tail.extend_from_slice(&chunk[n.saturating_sub(PEM_KEY_MARK.len() - 1)..]);
        }
    }
    Ok(Seen {
        sha256: hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
        pem_key,
        small: (size <= MAX_DER_KEY_BYTES).then_some(small),
    })
}

/// What kind of private key `seen` is, if it is one.
fn key_format(seen: &Seen) -> Option<&'static str> {
    use der::Decode;
    if seen.pem_key {
        return Some("a PEM private key");
    }
    let bytes = seen.small.as_deref()?;
    // `from_der` takes the whole file or fails, so a report file that only
    // starts like a key is not taken for one.
    if pkcs8::PrivateKeyInfoRef::from_der(bytes).is_ok() {
        return Some("a DER PKCS#8 private key");
    }
    if pkcs8::EncryptedPrivateKeyInfoRef::from_der(bytes).is_ok() {
        return Some("an encrypted DER PKCS#8 private key");
    }
    if pkcs12::Pfx::from_der(bytes).is_ok() {
        return Some("a PKCS#12 key store");
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifests_round_trip_and_bad_lines_are_named() {
        let m = Manifest {
            signer: "A B, Tested by".into(),
            date: "2026-01-15".into(),
            certificate_sha256: "ab".repeat(32),
            pdf_bytes: Some(1234),
            files: BTreeMap::from([("traces/.x.csv".to_string(), "0".repeat(64))]),
            inputs: vec![InputFile {
                role: "video".into(),
                path: "../v 1.mp4".into(),
                sha256: "1".repeat(64),
                size: 99,
            }],
        };
        let text = m.to_text();
        assert!(text.contains(&format!("{}  traces/.x.csv\n", "0".repeat(64))));
        assert_eq!(Manifest::parse(&text).unwrap(), m);
        let broken = text.replace("  traces", " traces");
        assert!(Manifest::parse(&broken).unwrap_err().contains("line 7"));
    }

    #[test]
    fn a_pem_key_line_is_found_across_read_chunks_and_large_files_are_not_parsed_as_der() {
        let dir = tempfile::tempdir().unwrap();
        let mut buf = Vec::new();
        let look = |bytes: &[u8], buf: &mut Vec<u8>| {
            let path = dir.path().join("f");
            std::fs::write(&path, bytes).unwrap();
            let seen = inspect(crate::util::open_input(&path).unwrap(), buf).unwrap();
            assert_eq!(seen.sha256, crate::util::sha256_hex(bytes));
            seen
        };
        // The mark split at every place across the 1 MiB read boundary.
        let line = b"-----BEGIN PRIVATE KEY-----\n";
        for split in 1..PEM_KEY_MARK.len() {
            let mut bytes = vec![b'x'; (1 << 20) - split - 11];
            bytes.extend_from_slice(line);
            bytes.extend_from_slice(&[b'y'; 100]);
            let seen = look(&bytes, &mut buf);
            assert!(seen.pem_key && seen.small.is_none(), "split {split}");
        }
        let seen = look(&vec![b'x'; 3 << 20], &mut buf);
        assert!(!seen.pem_key && seen.small.is_none());
        let small = vec![0x30; MAX_DER_KEY_BYTES];
        assert_eq!(look(&small, &mut buf).small.as_deref(), Some(&small[..]));
        let over = vec![0x30; MAX_DER_KEY_BYTES + 1];
        assert!(look(&over, &mut buf).small.is_none());
    }
}
