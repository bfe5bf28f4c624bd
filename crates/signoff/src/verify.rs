//! `ledflicker verify`: checks every signature (manifest and PDF), every
//! file hash and, on request, every input; names each mismatch and the
//! signer each signature claims.

use std::path::{Path, PathBuf};

use x509_cert::Certificate;

use super::manifest::{Manifest, scan};
use super::{
    HISTORY_DIR, LEGACY_FILE, MANIFEST_FILE, SIGNATURE_FILE, SignoffError, cms, keys, pdf, policy,
};
use crate::model::InputFile;
use crate::report::document::{Document, Signatory};
use crate::util::sha256_hex;

/// One signatory whose manifest signature is sound.
#[derive(Debug, Clone, PartialEq)]
pub struct SignatureInfo {
    /// 1-based, in signing order.
    pub index: usize,
    /// "Name, Role" as signed.
    pub signer: String,
    /// Subject of the certificate (common name).
    pub subject: String,
    /// SHA-256 of the certificate (DER), hex.
    pub fingerprint: String,
    /// Date the report shows for the signature, `YYYY-MM-DD`.
    pub date: String,
    /// Signing time the signature carries, Unix seconds (now when it
    /// carries none): the time its certificate is checked at.
    pub signed_at: u64,
    /// Whether the certificate chains to one of `--trust` at the signing
    /// time (None: not asked).
    pub trusted: Option<bool>,
}

/// The result of [`verify`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Verification {
    /// Signatures whose manifest signature matched.
    pub signatures: Vec<SignatureInfo>,
    /// PDF signatures that matched their byte ranges.
    pub pdf_signatures: usize,
    /// Every mismatch, naming the file, input or signature.
    pub problems: Vec<String>,
    /// Report files checked.
    pub files: usize,
    /// Inputs re-hashed (`--inputs`).
    pub inputs_checked: usize,
    /// Whether the signers were checked against trusted certificates.
    pub identity_checked: bool,
}

impl Verification {
    /// Every hash and signature matched, and there is at least one signature.
    pub fn ok(&self) -> bool {
        self.problems.is_empty() && !self.signatures.is_empty()
    }
}

/// The message for a report signed in the old format.
pub fn legacy_message(dir: &Path) -> String {
    format!(
        "`{}` carries a sign-off of the old format ({LEGACY_FILE}, Ed25519 keys), which this version no longer verifies\n    hint: run the plan again with `ledflicker plan PLAN --out {} --force` and sign the new report with `ledflicker sign` (keys and certificates from `ledflicker keygen`)",
        dir.display(),
        dir.display()
    )
}

/// The (manifest, signature) file pairs of `dir` in signing order.
fn chain(dir: &Path) -> Vec<(PathBuf, PathBuf)> {
    let history = dir.join(HISTORY_DIR);
    let mut out: Vec<(PathBuf, PathBuf)> = (1..)
        .map(|k| {
            (
                history.join(format!("{k}.manifest.txt")),
                history.join(format!("{k}.p7s")),
            )
        })
        .take_while(|(m, s)| m.exists() || s.exists())
        .collect();
    out.push((dir.join(MANIFEST_FILE), dir.join(SIGNATURE_FILE)));
    out
}

/// Signatories recorded in the manifests of `dir`, in signing order
/// (unverified; for the sign-off block of the HTML report).
pub fn signatories(dir: &Path) -> Vec<Signatory> {
    if !dir.join(MANIFEST_FILE).exists() {
        return Vec::new();
    }
    chain(dir)
        .into_iter()
        .filter_map(|(m, _)| crate::util::read_input_to_string(&m).ok())
        .filter_map(|t| Manifest::parse(&t).ok())
        .map(|m| Signatory {
            signer: m.signer,
            date: m.date,
            key_id: m.certificate_sha256.chars().take(16).collect(),
        })
        .collect()
}

/// The inputs recorded in results.json.
pub fn recorded_inputs(doc: &Document) -> Vec<InputFile> {
    doc.results
        .report
        .as_ref()
        .map(|r| r.inputs.clone())
        .unwrap_or_default()
}

/// One manifest whose signature matched.
struct Checked {
    manifest: Manifest,
    cert: Certificate,
    /// When it was signed, Unix seconds: the signing time it carries, or
    /// now for a signature without one.
    signed_at: u64,
}

fn now_unix_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Every reason why `cert` could not make a signature at `at` that
/// `openssl cms -verify -CAfile` accepts: its own fields, and with
/// `trusted` the chain to one of them ([`policy`]). Also whether it
/// chains to `trusted` (None: no `trusted`).
fn certificate_problems(
    cert: &Certificate,
    trusted: &[Certificate],
    at: u64,
) -> (Vec<String>, Option<bool>) {
    let mut out: Vec<String> = policy::signer_problems(cert, at)
        .into_iter()
        .map(|p| format!("but its {p}"))
        .collect();
    let chain = (!trusted.is_empty()).then(|| policy::check_chain(cert, trusted, at));
    if let Some(Err(e)) = &chain {
        out.push(format!("which is not a trusted certificate (--trust): {e}"));
    }
    (out, chain.map(|c| c.is_ok()))
}

fn rel(dir: &Path, p: &Path) -> String {
    p.strip_prefix(dir).unwrap_or(p).display().to_string()
}

/// Reads and checks one (manifest, signature) pair.
fn check_pair(dir: &Path, manifest: &Path, signature: &Path) -> Result<Checked, String> {
    // Through `read_input`: a FIFO or device in the place of a manifest
    // or signature is refused at once, never waited on.
    let read = |p: &Path| crate::util::read_input(p).map_err(|e| format!("`{}` {e}", rel(dir, p)));
    let sig = read(signature)?;
    let text = read(manifest)?;
    let sig = std::str::from_utf8(&sig)
        .map_err(|_| format!("`{}` is not a PEM text file", rel(dir, signature)))?;
    let der = cms::from_pem(sig).map_err(|e| format!("`{}`: {e}", rel(dir, signature)))?;
    let v = cms::verify_detached(&der, &text)
        .map_err(|e| format!("`{}` does not verify: {e}", rel(dir, manifest)))?;
    let text = std::str::from_utf8(&text)
        .map_err(|_| format!("`{}` is not UTF-8 text", rel(dir, manifest)))?;
    let m = Manifest::parse(text).map_err(|e| format!("`{}`: {e}", rel(dir, manifest)))?;
    if m.certificate_sha256 != keys::fingerprint(&v.cert) {
        return Err(format!(
            "`{}` names another certificate than the one that signed it",
            rel(dir, manifest)
        ));
    }
    Ok(Checked {
        manifest: m,
        cert: v.cert,
        signed_at: v.signing_time_unix_s.unwrap_or_else(now_unix_s),
    })
}

fn describe(cert: &Certificate) -> String {
    format!(
        "certificate \"{}\", SHA-256 {}",
        keys::subject_cn(cert),
        &keys::fingerprint(cert)[..16]
    )
}

/// Checks the signed report in `dir`. With `trusted` certificates, every
/// signature must come from one of them (or from a certificate one of them
/// issued). With `inputs` (`Some(root)`), every input recorded in the last
/// manifest is hashed again at its path, or under `root`.
pub fn verify(
    dir: &Path,
    trusted: &[Certificate],
    inputs: Option<Option<&Path>>,
) -> Result<Verification, SignoffError> {
    if !dir.is_dir() {
        return Err(SignoffError::Refused(format!(
            "`{}` is not a directory\n    hint: pass the --out directory of `ledflicker plan`",
            dir.display()
        )));
    }
    let mut out = Verification {
        identity_checked: !trusted.is_empty(),
        ..Verification::default()
    };
    let signed = dir.join(SIGNATURE_FILE).exists() || dir.join(MANIFEST_FILE).exists();
    if !signed {
        out.problems.push(if dir.join(LEGACY_FILE).exists() {
            legacy_message(dir)
        } else {
            format!("no {SIGNATURE_FILE}: the report is an unsigned DRAFT")
        });
        return Ok(out);
    }
    let pairs = chain(dir);
    let n = pairs.len();
    let mut checked: Vec<Option<Checked>> = Vec::new();
    for (i, (m, s)) in pairs.iter().enumerate() {
        match check_pair(dir, m, s) {
            Ok(c) => {
                let (problems, trusted_now) = certificate_problems(&c.cert, trusted, c.signed_at);
                for p in problems {
                    out.problems.push(format!(
                        "signature {} of {n} claims to be by \"{}\" ({}, signed {}), {p}",
                        i + 1,
                        c.manifest.signer,
                        describe(&c.cert),
                        policy::utc_time(c.signed_at)
                    ));
                }
                out.signatures.push(SignatureInfo {
                    index: i + 1,
                    signer: c.manifest.signer.clone(),
                    subject: keys::subject_cn(&c.cert),
                    fingerprint: keys::fingerprint(&c.cert),
                    date: c.manifest.date.clone(),
                    signed_at: c.signed_at,
                    trusted: trusted_now,
                });
                checked.push(Some(c));
            }
            Err(e) => {
                out.problems
                    .push(format!("signature {} of {n}: {e}", i + 1));
                checked.push(None);
            }
        }
    }
    check_files(dir, &checked, &mut out)?;
    check_pdf(dir, &checked, trusted, &mut out);
    if let (Some(root), Some(Some(last))) = (inputs, checked.last()) {
        for input in &last.manifest.inputs {
            out.inputs_checked += 1;
            let (path, result) = crate::inputs::check(input, root);
            match result {
                crate::inputs::InputCheck::Same => {}
                crate::inputs::InputCheck::Missing(why) => out.problems.push(format!(
                    "input `{}` ({}) is missing: {why}",
                    path.display(),
                    input.role
                )),
                crate::inputs::InputCheck::Changed { size, sha256 } => out.problems.push(format!(
                    "input `{}` ({}) has changed: {size} bytes, SHA-256 {sha256}; signed: {} bytes, SHA-256 {}",
                    path.display(),
                    input.role,
                    input.size,
                    input.sha256
                )),
            }
        }
    }
    Ok(out)
}

/// Compares the directory with the last manifest, and the files of earlier
/// manifests that later signatures leave alone.
fn check_files(
    dir: &Path,
    checked: &[Option<Checked>],
    out: &mut Verification,
) -> Result<(), SignoffError> {
    let now = scan(dir, &super::manifest::UNSIGNED, &[]).map_err(|source| SignoffError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    out.files = now.files.len();
    for r in &now.refused {
        out.problems.push(format!("refused {r}"));
    }
    for k in &now.keys {
        out.problems.push(format!(
            "{k}; a private key must never travel with a report (tell the signer: the key is no longer secret)"
        ));
    }
    for d in &now.empty_dirs {
        out.problems.push(format!(
            "folder `{d}` holds no file, so no manifest lists it: it was added after the last signature"
        ));
    }
    let n = checked.len();
    let Some(Some(last)) = checked.last() else {
        return Ok(());
    };
    for (path, sha) in &last.manifest.files {
        match now.files.get(path) {
            None => out.problems.push(format!("file `{path}` is missing")),
            Some(s) if s != sha => out.problems.push(format!("file `{path}` has changed")),
            Some(_) => {}
        }
    }
    for path in now.files.keys() {
        // Signed before the marker was covered: it is not in the manifest,
        // and tells only a later `plan` what it may replace.
        let uncovered_marker = path == crate::outdir::MARKER
            && checked
                .iter()
                .flatten()
                .all(|c| !c.manifest.files.contains_key(path));
        if !last.manifest.files.contains_key(path) && !uncovered_marker {
            out.problems
                .push(format!("file `{path}` was added after the last signature"));
        }
    }
    let pdf = std::fs::read(dir.join("report.pdf")).unwrap_or_default();
    for (i, c) in checked.iter().enumerate().take(n - 1) {
        let Some(c) = c else { continue };
        for (path, sha) in &c.manifest.files {
            // Later signatures render the HTML again and append to the PDF.
            let same = match path.as_str() {
                "report.html" => true,
                "report.pdf" => c
                    .manifest
                    .pdf_bytes
                    .and_then(|len| pdf.get(..usize::try_from(len).ok()?))
                    .is_some_and(|prefix| sha256_hex(prefix) == *sha),
                _ => now.files.get(path) == Some(sha),
            };
            if !same {
                out.problems.push(format!(
                    "file `{path}` has changed since signature {} of {n}",
                    i + 1
                ));
            }
        }
    }
    Ok(())
}

/// Checks every PDF signature of report.pdf against its byte range and the
/// manifest chain.
fn check_pdf(
    dir: &Path,
    checked: &[Option<Checked>],
    trusted: &[Certificate],
    out: &mut Verification,
) {
    let Ok(bytes) = std::fs::read(dir.join("report.pdf")) else {
        return; // named by the file check
    };
    let sigs = pdf::signatures(&bytes);
    if sigs.len() != checked.len() {
        out.problems.push(format!(
            "report.pdf holds {} PDF signature(s), the sign-off {}",
            sigs.len(),
            checked.len()
        ));
    }
    for (i, s) in sigs.iter().enumerate() {
        let who = format!("PDF signature {} of {}", i + 1, sigs.len());
        let Some(signed) = s.signed_bytes(&bytes) else {
            out.problems
                .push(format!("{who}: its byte range lies outside the file"));
            continue;
        };
        match cms::verify_detached(&s.cms, &signed) {
            Err(e) => out.problems.push(format!("{who}: {e}")),
            Ok(v) => {
                out.pdf_signatures += 1;
                let manifest_cert = checked.get(i).and_then(Option::as_ref).map(|c| &c.cert);
                // The certificate of a manifest signature is checked above;
                // only another one is checked here.
                if manifest_cert != Some(&v.cert) {
                    let at = v.signing_time_unix_s.unwrap_or_else(now_unix_s);
                    for p in certificate_problems(&v.cert, trusted, at).0 {
                        out.problems.push(format!(
                            "{who} is by {} (signed {}), {p}",
                            describe(&v.cert),
                            policy::utc_time(at)
                        ));
                    }
                }
                if let Some(Some(c)) = checked.get(i) {
                    if keys::fingerprint(&v.cert) != c.manifest.certificate_sha256 {
                        out.problems.push(format!(
                            "{who} is by {}, not by the certificate of signature {}",
                            describe(&v.cert),
                            i + 1
                        ));
                    }
                    if c.manifest.pdf_bytes != Some(s.revision_len() as u64) {
                        out.problems.push(format!(
                            "{who} covers {} bytes, the manifest of signature {} says {:?}",
                            s.revision_len(),
                            i + 1,
                            c.manifest.pdf_bytes
                        ));
                    }
                }
            }
        }
    }
    if let Some(last) = sigs.last()
        && last.revision_len() != bytes.len()
    {
        out.problems.push(format!(
            "report.pdf has {} bytes after its last signature",
            bytes.len().saturating_sub(last.revision_len())
        ));
    }
}

/// Loads trusted certificates: PEM or DER files, or directories of them
/// (`*.pem`, `*.crt`, `*.cer`, `*.der`).
pub fn load_trusted(paths: &[PathBuf]) -> Result<Vec<Certificate>, SignoffError> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|source| SignoffError::Io {
                    path: p.clone(),
                    source,
                })?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.extension()
                        .and_then(|e| e.to_str())
                        .is_some_and(|e| matches!(e, "pem" | "crt" | "cer" | "der"))
                })
                .collect();
            files.sort();
            if files.is_empty() {
                return Err(SignoffError::Refused(format!(
                    "--trust `{}` holds no certificate (*.pem, *.crt, *.cer, *.der)",
                    p.display()
                )));
            }
            for f in files {
                out.extend(keys::load_certificates(&f)?);
            }
        } else {
            out.extend(keys::load_certificates(p)?);
        }
    }
    Ok(out)
}
