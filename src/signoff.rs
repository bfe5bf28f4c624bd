//! Sign-off: Ed25519 signatures over a canonical manifest of a report
//! directory, stored in `signoff.json` next to the report.
//!
//! Sits after the report stage. A signatory signs the SHA-256 of every file
//! in the report directory (results.json, report.html, report.pdf, charts,
//! traces, exports) and of every input named in results.json. Signing first
//! renders the report again with the signatory on its sign-off block, so
//! the HTML and PDF show who signed; signatures are chained (each names
//! the one before), and each later signature covers the re-rendered HTML
//! and PDF. `verify` accepts an earlier signature whose only changed files
//! are those two renderings, as long as the last signature covers the
//! directory exactly.
//!
//! Keys: the private key is a hex seed in a file that must not lie inside a
//! report directory; only public keys are written into signoff.json.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use ed25519_dalek::{Signature, Signer, SigningKey, VerifyingKey};
use serde::{Deserialize, Serialize};

use crate::report::document::{Document, Signatory};
use crate::report::{self, ReportError, SIGNOFF_FILE};
use crate::util::{sha256_hex, write_atomic};

/// Schema id of signoff.json.
pub const SIGNOFF_SCHEMA: &str = "ledflicker.signoff/1";
const PRIVATE_HEADER: &str =
    "ledflicker ed25519 private key (keep secret; never put in a report directory)";
const PUBLIC_HEADER: &str = "ledflicker ed25519 public key";
/// The renderings, which signing re-renders with the new signatory.
const RENDERINGS: [&str; 2] = ["report.html", "report.pdf"];

/// Why a key could not be made or used, or a report not signed.
#[derive(Debug, thiserror::Error)]
pub enum SignoffError {
    /// File system error.
    #[error("cannot access `{path}`: {source}")]
    Io {
        /// File or directory.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A key file is missing parts or malformed.
    #[error("bad key file `{path}`: {message}")]
    Key {
        /// Key file.
        path: PathBuf,
        /// What is wrong, with a hint.
        message: String,
    },
    /// The request is unsafe or inconsistent (exit code 2).
    #[error("{0}")]
    Refused(String),
    /// Re-rendering the report failed.
    #[error(transparent)]
    Report(#[from] ReportError),
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> SignoffError + '_ {
    move |source| SignoffError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex<const N: usize>(s: &str) -> Option<[u8; N]> {
    let s = s.trim();
    if s.len() != 2 * N || !s.is_ascii() {
        return None;
    }
    let mut out = [0u8; N];
    for (i, b) in out.iter_mut().enumerate() {
        *b = u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

/// Key id: the first 16 hex digits of the SHA-256 of the public key.
pub fn key_id(key: &VerifyingKey) -> String {
    sha256_hex(key.as_bytes())[..16].to_string()
}

/// Path of the public key that goes with the private key at `private`.
pub fn public_key_path(private: &Path) -> PathBuf {
    let mut s = private.as_os_str().to_owned();
    s.push(".pub");
    PathBuf::from(s)
}

/// Whether `dir` or one of its ancestors is a report directory.
fn inside_report_dir(path: &Path) -> Option<PathBuf> {
    let abs = std::path::absolute(path).ok()?;
    abs.ancestors()
        .skip(1)
        .find(|d| d.join("results.json").is_file() || d.join(SIGNOFF_FILE).is_file())
        .map(Path::to_path_buf)
}

/// Makes a key pair: the private key at `out` (mode 0600 on Unix) and the
/// public key at `out.pub`. Refuses to overwrite either, or to write into a
/// report directory. Returns the key id.
pub fn keygen(out: &Path) -> Result<String, SignoffError> {
    if let Some(dir) = inside_report_dir(out) {
        return Err(SignoffError::Refused(format!(
            "refusing to write a private key into the report directory `{}`\n    hint: keep keys outside report directories, e.g. ~/.config/ledflicker/",
            dir.display()
        )));
    }
    let public = public_key_path(out);
    for p in [out, public.as_path()] {
        if p.exists() {
            return Err(SignoffError::Refused(format!(
                "`{}` exists; refusing to overwrite a key\n    hint: choose another --out",
                p.display()
            )));
        }
    }
    let mut seed = [0u8; 32];
    getrandom::fill(&mut seed).map_err(|e| {
        SignoffError::Refused(format!("the operating system gave no random bytes: {e}"))
    })?;
    let key = SigningKey::from_bytes(&seed);
    let verifying = key.verifying_key();
    let private_text = format!("{PRIVATE_HEADER}\n{}\n", hex(&seed));
    {
        use std::io::Write;
        let mut opts = std::fs::OpenOptions::new();
        opts.write(true).create_new(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            opts.mode(0o600);
        }
        let mut f = opts.open(out).map_err(io(out))?;
        f.write_all(private_text.as_bytes()).map_err(io(out))?;
        f.sync_all().map_err(io(out))?;
    }
    let public_text = format!("{PUBLIC_HEADER}\n{}\n", hex(verifying.as_bytes()));
    write_atomic(&public, public_text.as_bytes()).map_err(io(&public))?;
    Ok(key_id(&verifying))
}

fn read_key_hex<const N: usize>(path: &Path, header: &str) -> Result<[u8; N], SignoffError> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    let mut lines = text.lines();
    if lines.next() != Some(header) {
        return Err(SignoffError::Key {
            path: path.to_path_buf(),
            message: format!(
                "the first line is not `{header}`\n    hint: make keys with `ledflicker keygen --out FILE`"
            ),
        });
    }
    lines
        .next()
        .and_then(unhex::<N>)
        .ok_or_else(|| SignoffError::Key {
            path: path.to_path_buf(),
            message: format!("the second line is not {} hex digits", 2 * N),
        })
}

/// Reads a private key written by [`keygen`].
pub fn load_signing_key(path: &Path) -> Result<SigningKey, SignoffError> {
    let seed = read_key_hex::<32>(path, PRIVATE_HEADER)?;
    Ok(SigningKey::from_bytes(&seed))
}

/// Reads a public key written by [`keygen`] (`FILE.pub`).
pub fn load_verifying_key(path: &Path) -> Result<VerifyingKey, SignoffError> {
    let bytes = read_key_hex::<32>(path, PUBLIC_HEADER)?;
    VerifyingKey::from_bytes(&bytes).map_err(|e| SignoffError::Key {
        path: path.to_path_buf(),
        message: format!("not an Ed25519 public key: {e}"),
    })
}

/// Fails when the private key `key_path` lies inside the report `dir`.
pub fn check_key_outside(dir: &Path, key_path: &Path) -> Result<(), SignoffError> {
    if let (Ok(k), Ok(d)) = (std::path::absolute(key_path), std::path::absolute(dir))
        && k.starts_with(&d)
    {
        return Err(SignoffError::Refused(format!(
            "the private key `{}` lies inside the report directory `{}`\n    hint: move it out; keys must never travel with a report",
            key_path.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// One input file of the run, as signed.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignedInput {
    /// E.g. "plan".
    pub role: String,
    /// Path as recorded in results.json.
    pub path: String,
    /// SHA-256, lowercase hex.
    pub sha256: String,
}

/// One signature in signoff.json.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignatureEntry {
    /// "Name, Role".
    pub signer: String,
    /// Date of signing, `YYYY-MM-DD`.
    pub date: String,
    /// Ed25519 public key, hex.
    pub public_key: String,
    /// See [`key_id`].
    pub key_id: String,
    /// SHA-256 of the previous entry's signature (hex), or "" for the first.
    pub previous: String,
    /// Inputs named in results.json.
    pub inputs: Vec<SignedInput>,
    /// Every file of the report directory but signoff.json: relative path
    /// (with `/`) -> SHA-256.
    pub files: BTreeMap<String, String>,
    /// Ed25519 signature of [`SignatureEntry::message`], hex.
    pub signature: String,
}

impl SignatureEntry {
    /// The exact bytes signed: a line-based canonical manifest.
    pub fn message(&self) -> String {
        let mut m = format!(
            "{SIGNOFF_SCHEMA}\nsigner: {}\ndate: {}\npublic-key: {}\nprevious: {}\n",
            self.signer, self.date, self.public_key, self.previous
        );
        for i in &self.inputs {
            m.push_str(&format!("input {}  {}:{}\n", i.sha256, i.role, i.path));
        }
        for (path, sha) in &self.files {
            m.push_str(&format!("file {sha}  {path}\n"));
        }
        m
    }

    fn signatory(&self) -> Signatory {
        Signatory {
            signer: self.signer.clone(),
            date: self.date.clone(),
            key_id: self.key_id.clone(),
        }
    }
}

/// signoff.json.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignoffFile {
    /// Always [`SIGNOFF_SCHEMA`].
    pub schema: String,
    /// In signing order.
    pub signatures: Vec<SignatureEntry>,
}

/// SHA-256 of every file under `dir` but signoff.json and hidden temporary
/// files, by relative path with `/`.
pub fn scan(dir: &Path) -> Result<BTreeMap<String, String>, SignoffError> {
    fn walk(
        dir: &Path,
        prefix: &str,
        out: &mut BTreeMap<String, String>,
    ) -> Result<(), SignoffError> {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .map_err(io(dir))?
            .collect::<Result<_, _>>()
            .map_err(io(dir))?;
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') || (prefix.is_empty() && name == SIGNOFF_FILE) {
                continue;
            }
            let rel = format!("{prefix}{name}");
            let path = e.path();
            if path.is_dir() {
                walk(&path, &format!("{rel}/"), out)?;
            } else {
                let bytes = std::fs::read(&path).map_err(io(&path))?;
                out.insert(rel, sha256_hex(&bytes));
            }
        }
        Ok(())
    }
    let mut out = BTreeMap::new();
    walk(dir, "", &mut out)?;
    Ok(out)
}

/// Reads signoff.json; `Ok(None)` when the report is unsigned.
pub fn read_signoff(dir: &Path) -> Result<Option<SignoffFile>, SignoffError> {
    let path = dir.join(SIGNOFF_FILE);
    if !path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(io(&path))?;
    let file: SignoffFile = serde_json::from_str(&text).map_err(|e| {
        SignoffError::Refused(format!(
            "`{}` is not a valid sign-off file: {e}",
            path.display()
        ))
    })?;
    Ok(Some(file))
}

fn inputs_of(doc: &Document) -> Vec<SignedInput> {
    doc.results["report"]["inputs"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|i| SignedInput {
            role: i["role"].as_str().unwrap_or("").to_string(),
            path: i["path"].as_str().unwrap_or("").to_string(),
            sha256: i["sha256"].as_str().unwrap_or("").to_string(),
        })
        .collect()
}

/// Signs the report in `dir` as `signer` ("Name, Role") on `date`: renders
/// the HTML and PDF again with the new signatory, hashes the directory and
/// appends a signature to signoff.json. Refuses when the report fails
/// verification (someone changed it since the last signature), or when the
/// key file lies in the report directory.
pub fn sign(
    dir: &Path,
    key_path: &Path,
    signer: &str,
    date: &str,
) -> Result<SignatureEntry, SignoffError> {
    let signer = signer.trim();
    if signer.is_empty() || signer.contains(['\n', '\r']) {
        return Err(SignoffError::Refused(
            "--signer must be one line, e.g. \"Jane Doe, Test engineer\"".to_string(),
        ));
    }
    check_key_outside(dir, key_path)?;
    if !dir.join("results.json").is_file() {
        return Err(SignoffError::Refused(format!(
            "`{}` is not a report directory (no results.json)\n    hint: pass the --out directory of `ledflicker plan`",
            dir.display()
        )));
    }
    let key = load_signing_key(key_path)?;
    let mut doc = Document::load(dir)?;
    let mut file = match read_signoff(dir)? {
        Some(f) => {
            let outcome = verify(dir, &[])?;
            if !outcome.ok() {
                return Err(SignoffError::Refused(format!(
                    "`{}` no longer matches its signatures; refusing to sign on top of it:\n  - {}",
                    dir.display(),
                    outcome.problems.join("\n  - ")
                )));
            }
            f
        }
        None => SignoffFile {
            schema: SIGNOFF_SCHEMA.to_string(),
            signatures: Vec::new(),
        },
    };
    let verifying = key.verifying_key();
    let entry_signatory = Signatory {
        signer: signer.to_string(),
        date: date.to_string(),
        key_id: key_id(&verifying),
    };
    doc.signatories = file
        .signatures
        .iter()
        .map(SignatureEntry::signatory)
        .chain(std::iter::once(entry_signatory))
        .collect();
    report::write_renderings(dir, &doc)?;

    let mut entry = SignatureEntry {
        signer: signer.to_string(),
        date: date.to_string(),
        public_key: hex(verifying.as_bytes()),
        key_id: key_id(&verifying),
        previous: file
            .signatures
            .last()
            .map(|p| sha256_hex(p.signature.as_bytes()))
            .unwrap_or_default(),
        inputs: inputs_of(&doc),
        files: scan(dir)?,
        signature: String::new(),
    };
    entry.signature = hex(&key.sign(entry.message().as_bytes()).to_bytes());
    file.signatures.push(entry.clone());
    let json = serde_json::to_string_pretty(&file).map_err(ReportError::from)?;
    let path = dir.join(SIGNOFF_FILE);
    write_atomic(&path, json.as_bytes()).map_err(io(&path))?;
    Ok(entry)
}

/// The result of [`verify`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Verification {
    /// Signatures whose cryptography and chain are sound: (signer, key id).
    pub valid: Vec<(String, String)>,
    /// Every mismatch, naming the file or signature.
    pub problems: Vec<String>,
    /// Number of files checked.
    pub files: usize,
}

impl Verification {
    /// Every hash and signature matched, and there is at least one signature.
    pub fn ok(&self) -> bool {
        self.problems.is_empty() && !self.valid.is_empty()
    }
}

/// Checks every signature in `dir`/signoff.json and every file hash. With
/// `trusted` keys, a signature by any other key is a problem too.
pub fn verify(dir: &Path, trusted: &[VerifyingKey]) -> Result<Verification, SignoffError> {
    if !dir.join("results.json").is_file() {
        return Err(SignoffError::Refused(format!(
            "`{}` is not a report directory (no results.json)\n    hint: pass the --out directory of `ledflicker plan`",
            dir.display()
        )));
    }
    let mut out = Verification::default();
    let file = match read_signoff(dir) {
        Ok(Some(f)) => f,
        Ok(None) => {
            out.problems.push(format!(
                "no {SIGNOFF_FILE}: the report is an unsigned DRAFT"
            ));
            return Ok(out);
        }
        Err(SignoffError::Refused(m)) => {
            out.problems.push(m);
            return Ok(out);
        }
        Err(e) => return Err(e),
    };
    if file.schema != SIGNOFF_SCHEMA {
        out.problems.push(format!(
            "{SIGNOFF_FILE}: schema `{}`, expected `{SIGNOFF_SCHEMA}`",
            file.schema
        ));
    }
    if file.signatures.is_empty() {
        out.problems
            .push(format!("{SIGNOFF_FILE} holds no signature"));
    }
    let current = scan(dir)?;
    out.files = current.len();
    let n = file.signatures.len();
    for (i, e) in file.signatures.iter().enumerate() {
        let who = format!(
            "signature {} of {n} ({}, key {})",
            i + 1,
            e.signer,
            e.key_id
        );
        let key = unhex::<32>(&e.public_key).and_then(|b| VerifyingKey::from_bytes(&b).ok());
        let sig = unhex::<64>(&e.signature).map(|b| Signature::from_bytes(&b));
        let mut sound = true;
        match (key, sig) {
            (Some(key), Some(sig)) => {
                if key.verify_strict(e.message().as_bytes(), &sig).is_err() {
                    out.problems.push(format!(
                        "{who}: the signature does not match its manifest ({SIGNOFF_FILE} was edited)"
                    ));
                    sound = false;
                }
                if key_id(&key) != e.key_id {
                    out.problems
                        .push(format!("{who}: key id does not match the public key"));
                    sound = false;
                }
                if !trusted.is_empty() && !trusted.contains(&key) {
                    out.problems.push(format!(
                        "{who}: the key is not one of the trusted keys (--key)"
                    ));
                    sound = false;
                }
            }
            _ => {
                out.problems
                    .push(format!("{who}: malformed public key or signature"));
                sound = false;
            }
        }
        let expected_previous = if i == 0 {
            String::new()
        } else {
            sha256_hex(file.signatures[i - 1].signature.as_bytes())
        };
        if e.previous != expected_previous {
            out.problems.push(format!(
                "{who}: does not follow signature {i} (signatures removed or reordered)"
            ));
            sound = false;
        }
        let last = i + 1 == n;
        for (path, sha) in &e.files {
            match current.get(path) {
                None => out
                    .problems
                    .push(format!("file `{path}` is missing (signed in {who})")),
                Some(now) if now != sha => {
                    // Later signatures re-render the HTML and PDF; the last
                    // one must cover them as they are.
                    if last || !RENDERINGS.contains(&path.as_str()) {
                        out.problems
                            .push(format!("file `{path}` has changed since {who}"));
                    }
                }
                Some(_) => {}
            }
        }
        if last {
            for path in current.keys() {
                if !e.files.contains_key(path) {
                    out.problems
                        .push(format!("file `{path}` was added after the last signature"));
                }
            }
        }
        if sound {
            out.valid.push((e.signer.clone(), e.key_id.clone()));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_round_trips() {
        let b: [u8; 4] = [0, 1, 0xab, 0xff];
        assert_eq!(unhex::<4>(&hex(&b)), Some(b));
        assert_eq!(unhex::<4>("00"), None);
        assert_eq!(unhex::<1>("zz"), None);
    }

    #[test]
    fn a_changed_manifest_fails_the_signature() {
        let key = SigningKey::from_bytes(&[7u8; 32]);
        let mut e = SignatureEntry {
            signer: "A, Tester".into(),
            date: "2026-01-01".into(),
            public_key: hex(key.verifying_key().as_bytes()),
            key_id: key_id(&key.verifying_key()),
            previous: String::new(),
            inputs: vec![],
            files: BTreeMap::from([("results.json".to_string(), "00".repeat(32))]),
            signature: String::new(),
        };
        let sig = key.sign(e.message().as_bytes());
        assert!(
            key.verifying_key()
                .verify_strict(e.message().as_bytes(), &sig)
                .is_ok()
        );
        e.files.insert("results.json".into(), "11".repeat(32));
        assert!(
            key.verifying_key()
                .verify_strict(e.message().as_bytes(), &sig)
                .is_err()
        );
    }
}
