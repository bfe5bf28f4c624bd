//! The manifest: a plain text file in `sha256sum` format, one line per
//! report file (`<sha256>  <relative path>`), with `#` comment lines that
//! `sha256sum -c` skips: who signed, the certificate, the date, the size of
//! report.pdf at signing, and every input with its size and SHA-256.

use std::collections::BTreeMap;
use std::path::Path;

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
/// manifest and its signature themselves, and the `.ledflicker` marker,
/// which `plan` writes when it swaps the report in (after signing) and
/// which only tells a later `plan` which entries it may replace.
pub const UNSIGNED: [&str; 3] = [
    super::MANIFEST_FILE,
    super::SIGNATURE_FILE,
    crate::outdir::MARKER,
];

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
}

/// Hashes every file under `dir` but the top-level names in `skip`.
/// Special files are refused by their type and never opened.
pub fn scan(dir: &Path, skip: &[&str]) -> std::io::Result<Scan> {
    let mut out = Scan::default();
    walk(dir, "", skip, &mut out)?;
    Ok(out)
}

fn walk(dir: &Path, prefix: &str, skip: &[&str], out: &mut Scan) -> std::io::Result<()> {
    let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<Result<_, _>>()?;
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let raw = e.file_name();
        let shown = format!("{prefix}{}", raw.to_string_lossy());
        let Some(name) = raw.to_str().filter(|n| !n.contains(['\n', '\r', '\\'])) else {
            out.refused
                .push(format!("`{shown}`: a file name sha256sum cannot list"));
            continue;
        };
        if prefix.is_empty() && skip.contains(&name) {
            continue;
        }
        let rel = format!("{prefix}{name}");
        let kind = e.file_type()?;
        if kind.is_dir() {
            walk(&e.path(), &format!("{rel}/"), skip, out)?;
        } else if kind.is_file() {
            let (sha, _) = crate::inputs::hash_file(&e.path())?;
            out.files.insert(rel, sha);
        } else if kind.is_symlink() {
            out.refused
                .push(format!("`{rel}`: a symbolic link (not followed)"));
        } else {
            out.refused.push(format!(
                "`{rel}`: a special file (FIFO, device or socket), not read"
            ));
        }
    }
    Ok(())
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
}
