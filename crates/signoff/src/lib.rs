//! Sign-off in standard formats: X.509 certificates, CMS signatures, PDF
//! signatures and a `sha256sum` manifest, bound to the run's inputs.
//!
//! Sits after the report stage. A signatory signs a report directory in
//! turn (tested by, approved by, ...):
//! 1. the first signature renders report.html and report.pdf again without
//!    the DRAFT mark; later ones render only report.html again (the PDF
//!    keeps its earlier signatures and gets an incremental update);
//! 2. report.pdf gets a PDF signature (CMS, `adbe.pkcs7.detached`) with a
//!    visible block on the sign-off page ([`pdf`]);
//! 3. manifest.txt lists the SHA-256 of every file of the directory and of
//!    every input ([`manifest`]) and signoff.p7s is its detached CMS
//!    signature ([`cms`]); the previous signatory's pair moves to
//!    `signatures/N.manifest.txt` and `signatures/N.p7s`.
//!
//! [`verify`](verify::verify) checks all of it. Keys and certificates are
//! in [`keys`]; docs/signoff.md describes the formats and the customer's
//! commands.

#![warn(missing_docs)]

use ledflicker_core::{inputs, model, outdir, util};
use ledflicker_report as report;

pub mod cms;
pub mod keys;
pub mod manifest;
pub mod pdf;
pub mod pdf_syntax;
pub mod pkcs12;
pub mod policy;
pub mod verify;

use std::path::{Path, PathBuf};

use crate::report::ReportError;
use crate::report::document::{Document, Signatory};
use crate::util::write_atomic;

pub use keys::SignerKey;
pub use verify::{Verification, verify};
/// A certificate, as `verify` takes the trusted ones.
pub use x509_cert::Certificate;

/// The current manifest, in `sha256sum` format.
pub const MANIFEST_FILE: &str = "manifest.txt";
/// The detached CMS signature (PEM) of manifest.txt.
pub const SIGNATURE_FILE: &str = "signoff.p7s";
/// Earlier signatories' manifests and signatures.
pub const HISTORY_DIR: &str = "signatures";
/// The sign-off file of the old Ed25519 format (no longer verified).
pub const LEGACY_FILE: &str = "signoff.json";

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
    /// A key or certificate file is missing parts or malformed.
    #[error("bad key or certificate file `{path}`: {message}")]
    Key {
        /// Key or certificate file.
        path: PathBuf,
        /// What is wrong, with a hint.
        message: String,
    },
    /// A cryptographic encoding step failed (internal error).
    #[error("{0}")]
    Crypto(String),
    /// report.pdf cannot take a signature.
    #[error("cannot sign report.pdf: {0}")]
    Pdf(String),
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

/// `path` with symbolic links resolved, also when its last parts do not
/// exist yet (they are appended to the canonical existing ancestor).
pub fn canonical(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut tail = Vec::new();
    let mut cur = abs.as_path();
    loop {
        if let Ok(c) = cur.canonicalize() {
            return tail
                .iter()
                .rev()
                .fold(c, |acc: PathBuf, part| acc.join(part));
        }
        match (cur.parent(), cur.file_name()) {
            (Some(parent), Some(name)) => {
                tail.push(name.to_owned());
                cur = parent;
            }
            _ => return abs,
        }
    }
}

/// Fails when the private key `key_path` lies inside the report `dir`,
/// comparing canonical paths (symbolic links resolved).
pub fn check_key_outside(dir: &Path, key_path: &Path) -> Result<(), SignoffError> {
    if canonical(key_path).starts_with(canonical(dir)) {
        return Err(SignoffError::Refused(format!(
            "the private key `{}` lies inside the report directory `{}`\n    hint: move it out; keys must never travel with a report",
            key_path.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// The report directory `path` lies in, if any (it or an ancestor holds
/// results.json or a sign-off).
fn inside_report_dir(path: &Path) -> Option<PathBuf> {
    canonical(path)
        .ancestors()
        .skip(1)
        .find(|d| d.join("results.json").is_file() || crate::outdir::is_signed(d))
        .map(Path::to_path_buf)
}

/// Files written by [`keygen`].
#[derive(Debug, Clone)]
pub struct KeyFiles {
    /// PKCS#8 PEM private key (mode 0600).
    pub key: PathBuf,
    /// Self-signed X.509 certificate, PEM.
    pub cert: PathBuf,
    /// SHA-256 of the certificate (DER), hex.
    pub fingerprint: String,
}

/// Makes an ECDSA P-256 key (`out`, PKCS#8 PEM, mode 0600) and a
/// self-signed certificate for `CN=signer, O=org` ([`keys::certificate_path`]).
/// Refuses to overwrite either, or to write into a report directory.
pub fn keygen(
    out: &Path,
    signer: &str,
    org: &str,
    now_unix_s: u64,
) -> Result<KeyFiles, SignoffError> {
    check_one_line("--signer", signer)?;
    check_one_line("--org", org)?;
    if let Some(dir) = inside_report_dir(out) {
        return Err(SignoffError::Refused(format!(
            "refusing to write a private key into the report directory `{}`\n    hint: keep keys outside report directories, e.g. ~/.config/ledflicker/",
            dir.display()
        )));
    }
    let cert_path = keys::certificate_path(out);
    for p in [out, cert_path.as_path()] {
        if p.exists() {
            return Err(SignoffError::Refused(format!(
                "`{}` exists; refusing to overwrite a key or certificate\n    hint: choose another --out",
                p.display()
            )));
        }
    }
    let made = keys::generate(signer.trim(), org.trim(), now_unix_s)?;
    let key_pem = keys::private_key_pem(&made.key)?;
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
        f.write_all(key_pem.as_bytes()).map_err(io(out))?;
        f.sync_all().map_err(io(out))?;
    }
    let cert_pem = keys::certificate_pem(&made.cert)?;
    write_atomic(&cert_path, cert_pem.as_bytes()).map_err(io(&cert_path))?;
    Ok(KeyFiles {
        key: out.to_path_buf(),
        cert: cert_path,
        fingerprint: keys::fingerprint(&made.cert),
    })
}

fn check_one_line(flag: &str, value: &str) -> Result<(), SignoffError> {
    if value.contains(['\n', '\r']) {
        return Err(SignoffError::Refused(format!("{flag} must be one line")));
    }
    Ok(())
}

/// Who signs, when, and with which key.
pub struct SignRequest<'a> {
    /// "Name, Role".
    pub signer: &'a str,
    /// Date shown in the report, `YYYY-MM-DD`.
    pub date: &'a str,
    /// Signing time in the signatures, Unix seconds.
    pub time_unix_s: u64,
    /// Key and certificate.
    pub key: &'a SignerKey,
    /// Key files, which must lie outside the report directory.
    pub key_files: Vec<PathBuf>,
}

/// What [`sign`] did.
#[derive(Debug, Clone)]
pub struct Signed {
    /// 1 for the first signatory.
    pub index: usize,
    /// Files listed in the manifest.
    pub files: usize,
    /// SHA-256 of the signer's certificate.
    pub fingerprint: String,
}

/// Signs the report in `dir` (see the module documentation). Refuses a
/// report that no longer verifies, the old format, and keys inside `dir`.
pub fn sign(dir: &Path, req: &SignRequest<'_>) -> Result<Signed, SignoffError> {
    let signer = req.signer.trim();
    if signer.is_empty() || signer.contains(['\n', '\r']) {
        return Err(SignoffError::Refused(
            "--signer must be one line, e.g. \"Jane Doe, Test engineer\"".to_string(),
        ));
    }
    for k in &req.key_files {
        check_key_outside(dir, k)?;
    }
    check_certificate(&req.key.cert, None, req.time_unix_s)?;
    let known = req
        .key_files
        .iter()
        .map(|k| manifest::KnownKey::of(k).map_err(io(k)))
        .collect::<Result<Vec<_>, _>>()?;
    if !dir.join("results.json").is_file() {
        return Err(SignoffError::Refused(format!(
            "`{}` is not a report directory (no results.json)\n    hint: pass the --out directory of `ledflicker plan`",
            dir.display()
        )));
    }
    if dir.join(LEGACY_FILE).exists() {
        return Err(SignoffError::Refused(verify::legacy_message(dir)));
    }
    // Before the earlier signatures are checked: a key in the directory
    // is named as such, not as a file added after them.
    scan_signable(dir, &known)?;
    let earlier = verify::signatories(dir);
    if dir.join(SIGNATURE_FILE).exists() || dir.join(MANIFEST_FILE).exists() {
        let outcome = verify(dir, &[], None)?;
        if !outcome.problems.is_empty() {
            return Err(SignoffError::Refused(format!(
                "`{}` no longer matches its signatures; refusing to sign on top of it:\n  - {}",
                dir.display(),
                outcome.problems.join("\n  - ")
            )));
        }
    }
    let index = earlier.len() + 1;
    let fingerprint = keys::fingerprint(&req.key.cert);
    let me = Signatory {
        signer: signer.to_string(),
        date: req.date.to_string(),
        key_id: fingerprint[..16].to_string(),
    };
    let mut doc = Document::load(dir)?;
    doc.signatories = earlier.into_iter().chain(std::iter::once(me)).collect();
    // Everything is rendered and signed in memory first, so that a failure
    // leaves the directory as it was.
    let html = report::html::render_document(&doc)?;
    let pdf_path = dir.join("report.pdf");
    let pdf_bytes = if index == 1 {
        report::pdf::render(&doc)?.0
    } else {
        std::fs::read(&pdf_path).map_err(io(&pdf_path))?
    };
    let signed_pdf = pdf::sign(
        &pdf_bytes,
        &pdf::PdfSigner {
            name: signer,
            time_unix_s: req.time_unix_s,
            date: req.date,
            key: req.key,
        },
    )?;
    if index > 1 {
        archive_previous(dir, index - 1)?;
    }
    let html_path = dir.join("report.html");
    write_atomic(&html_path, html.as_bytes()).map_err(io(&html_path))?;
    write_atomic(&pdf_path, &signed_pdf).map_err(io(&pdf_path))?;
    let scan = scan_signable(dir, &known)?;
    let m = manifest::Manifest {
        signer: signer.to_string(),
        date: req.date.to_string(),
        certificate_sha256: fingerprint.clone(),
        pdf_bytes: Some(signed_pdf.len() as u64),
        files: scan.files,
        inputs: verify::recorded_inputs(&doc),
    };
    let text = m.to_text();
    let der = cms::sign_detached(text.as_bytes(), req.key, req.time_unix_s)?;
    let path = dir.join(MANIFEST_FILE);
    write_atomic(&path, text.as_bytes()).map_err(io(&path))?;
    let path = dir.join(SIGNATURE_FILE);
    write_atomic(&path, cms::to_pem(&der)?.as_bytes()).map_err(io(&path))?;
    Ok(Signed {
        index,
        files: m.files.len(),
        fingerprint,
    })
}

/// Scans `dir` for the manifest; refuses private keys (`known`: the
/// signing key files) and entries a manifest cannot cover.
fn scan_signable(dir: &Path, known: &[manifest::KnownKey]) -> Result<manifest::Scan, SignoffError> {
    let scan = manifest::scan(dir, &manifest::UNSIGNED, known).map_err(io(dir))?;
    if !scan.keys.is_empty() {
        return Err(SignoffError::Refused(format!(
            "`{}` holds private keys, which must never travel with a report:\n  - {}\n    hint: move them out of the report directory (and if a report with one was ever handed out, treat the key as known to others)",
            dir.display(),
            scan.keys.join("\n  - ")
        )));
    }
    let mut refused = scan.refused.clone();
    refused.extend(
        scan.empty_dirs
            .iter()
            .map(|d| format!("`{d}`: a folder without files (a manifest lists files only)")),
    );
    if !refused.is_empty() {
        return Err(SignoffError::Refused(format!(
            "`{}` holds entries a manifest cannot cover:\n  - {}\n    hint: remove them",
            dir.display(),
            refused.join("\n  - ")
        )));
    }
    Ok(scan)
}

/// Refuses a certificate that may not sign at `at_unix_s` (Unix seconds):
/// not valid then, or without the key usages a signature needs
/// ([`policy::signer_problems`]). `file` is where it came from, for the
/// message.
pub fn check_certificate(
    cert: &x509_cert::Certificate,
    file: Option<&Path>,
    at_unix_s: u64,
) -> Result<(), SignoffError> {
    let problems = policy::signer_problems(cert, at_unix_s);
    if problems.is_empty() {
        return Ok(());
    }
    let message = format!(
        "the certificate `{}` cannot sign at {}:\n  - {}\n    hint: the customer's `openssl cms -verify` would reject the signature; use a certificate valid now with keyUsage digitalSignature or nonRepudiation and, if it has an extendedKeyUsage, emailProtection (`ledflicker keygen` makes one)",
        cert.tbs_certificate().subject(),
        policy::utc_time(at_unix_s),
        problems.join("\n  - ")
    );
    Err(match file {
        Some(path) => SignoffError::Key {
            path: path.to_path_buf(),
            message,
        },
        None => SignoffError::Refused(message),
    })
}

/// Moves the current manifest and signature to `signatures/N.*`.
fn archive_previous(dir: &Path, n: usize) -> Result<(), SignoffError> {
    let history = dir.join(HISTORY_DIR);
    std::fs::create_dir_all(&history).map_err(io(&history))?;
    for (from, to) in [
        (MANIFEST_FILE, format!("{n}.manifest.txt")),
        (SIGNATURE_FILE, format!("{n}.p7s")),
    ] {
        let target = history.join(to);
        std::fs::rename(dir.join(from), &target).map_err(io(&target))?;
    }
    Ok(())
}

/// Asks for the passphrase of `file` on the terminal, without echo.
pub fn prompt_passphrase(file: &Path) -> Result<String, SignoffError> {
    use std::io::{BufRead, IsTerminal, Write};
    if !std::io::stdin().is_terminal() {
        return Err(SignoffError::Refused(format!(
            "`{}` needs a passphrase\n    hint: set LEDFLICKER_P12_PASSPHRASE, or run on a terminal to be asked",
            file.display()
        )));
    }
    eprint!("passphrase for `{}`: ", file.display());
    let _ = std::io::stderr().flush();
    let stty = |arg: &str| {
        std::process::Command::new("stty")
            .arg(arg)
            .stdin(std::process::Stdio::inherit())
            .status()
    };
    let _ = stty("-echo");
    let mut line = String::new();
    let read = std::io::stdin().lock().read_line(&mut line);
    let _ = stty("echo");
    eprintln!();
    read.map_err(io(file))?;
    Ok(line.trim_end_matches(['\n', '\r']).to_string())
}
