//! `ledflicker keygen`, `sign` and `verify`: a signing key and its
//! certificate, the signatures of a report directory, and their check.
//! `plan --sign-key` loads its key through [`signing`]; the pipeline signs.

use super::output::outln;
use std::path::{Path, PathBuf};

use super::failure::Context;
use clap::Args;

use super::args::{SignOptions, now_unix_s, report_date, signing_time};
use super::{ExitCode, Failure};
use crate::error::UsageError;

#[derive(Args, Debug)]
pub(super) struct KeygenArgs {
    /// Who signs, "Name, Role": the certificate's common name.
    #[arg(long)]
    signer: String,
    /// Organisation: the certificate's O.
    #[arg(long, default_value = "")]
    org: String,
    /// Private key file, e.g. ~/keys/ada.key (certificate: ~/keys/ada.crt).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
pub(super) struct SignArgs {
    /// Report directory.
    dir: PathBuf,
    /// Private key, PKCS#8 PEM (ECDSA P-256), e.g. from `ledflicker keygen`.
    #[arg(long, required_unless_present = "p12", conflicts_with = "p12")]
    key: Option<PathBuf>,
    /// Certificate of the key, PEM [default: the key file with `.crt`].
    #[arg(long, requires = "key")]
    cert: Option<PathBuf>,
    /// Key and certificate in one PKCS#12 file; the passphrase comes from
    /// $LEDFLICKER_P12_PASSPHRASE, else from a prompt.
    #[arg(long)]
    p12: Option<PathBuf>,
    /// Who signs, "Name, Role" (e.g. "Jane Doe, Approved by").
    #[arg(long)]
    signer: String,
    /// Date the report shows for this signature, YYYY-MM-DD [default:
    /// $SOURCE_DATE_EPOCH, else today]; the signatures carry the time of
    /// signing.
    #[arg(long)]
    date: Option<String>,
}

#[derive(Args, Debug)]
pub(super) struct VerifyArgs {
    /// Report directory.
    dir: PathBuf,
    /// Trusted certificate (PEM or DER), or a directory of them;
    /// repeatable. Without it the signers' identity is not checked
    /// (exit 6).
    #[arg(long = "trust")]
    trust: Vec<PathBuf>,
    /// Also hash every input again at its recorded path.
    #[arg(long)]
    inputs: bool,
    /// Look for relative input paths under this directory (implies --inputs).
    #[arg(long)]
    inputs_root: Option<PathBuf>,
}

pub(super) fn keygen(a: KeygenArgs) -> Result<ExitCode, Failure> {
    let files = crate::signoff::keygen(&a.out, &a.signer, &a.org, now_unix_s())?;
    outln!(
        "private key: {} (PKCS#8 PEM, mode 0600; keep it secret, outside report directories)\ncertificate: {} (self-signed X.509 PEM; give it to whoever verifies your reports)\nSHA-256:     {}",
        files.key.display(),
        files.cert.display(),
        files.fingerprint
    )?;
    Ok(ExitCode::Pass)
}

/// Loads the signing key and certificate (PEM pair or PKCS#12), and
/// refuses a certificate that may not sign at `time_unix_s` (the signing
/// time) or now (when the customer's OpenSSL checks it).
pub(super) fn load_signer(
    key: Option<&Path>,
    cert: Option<&Path>,
    p12: Option<&Path>,
    time_unix_s: u64,
) -> Result<(crate::signoff::SignerKey, Vec<PathBuf>), Failure> {
    let (signer, cert_file, key_files) = if let Some(p12) = p12 {
        let pass = match std::env::var("LEDFLICKER_P12_PASSPHRASE") {
            Ok(p) => p,
            Err(_) => crate::signoff::prompt_passphrase(p12)?,
        };
        let signer = crate::signoff::pkcs12::load(p12, &pass)?;
        (signer, p12.to_path_buf(), vec![p12.to_path_buf()])
    } else {
        let key = key.ok_or_else(|| UsageError("give --key or --p12".into()))?;
        let cert = cert.map_or_else(
            || crate::signoff::keys::certificate_path(key),
            PathBuf::from,
        );
        let signer = crate::signoff::keys::load_signer(key, &cert)?;
        (signer, cert, vec![key.to_path_buf()])
    };
    let now = now_unix_s();
    for at in [time_unix_s, now] {
        crate::signoff::check_certificate(&signer.cert, Some(cert_file.as_path()), at)?;
    }
    Ok((signer, key_files))
}

pub(super) fn sign(args: SignArgs) -> Result<ExitCode, Failure> {
    // The signature vouches for the report as rendered from results.json:
    // one whose verdicts do not follow from its own values and limits was
    // edited, and is not signed (nor rendered again as it says).
    if let Ok(text) = crate::util::read_input_to_string(&args.dir.join("results.json"))
        && let Ok(results) = crate::model::read_results(&text)
    {
        crate::campaign::rejudge::refuse_edited(
            &args.dir,
            &results,
            ", so it is not signed",
            "run the plan again and sign its report",
        )?;
    }
    let date = report_date(args.date.as_deref())?;
    let time = signing_time()?;
    let (key, key_files) = load_signer(
        args.key.as_deref(),
        args.cert.as_deref(),
        args.p12.as_deref(),
        time,
    )?;
    let done = crate::signoff::sign(
        &args.dir,
        &crate::signoff::SignRequest {
            signer: &args.signer,
            date: &date,
            time_unix_s: time,
            key: &key,
            key_files,
        },
    )
    .with_context(|| format!("cannot sign `{}`", args.dir.display()))?;
    outln!(
        "signed `{}` as {} (signature {}, certificate SHA-256 {}), {} files in manifest.txt",
        args.dir.display(),
        args.signer.trim(),
        done.index,
        done.fingerprint,
        done.files
    )?;
    Ok(ExitCode::Pass)
}

pub(super) fn verify(a: VerifyArgs) -> Result<ExitCode, Failure> {
    let inputs = (a.inputs || a.inputs_root.is_some()).then_some(a.inputs_root.as_deref());
    let (dir, trust) = (a.dir.as_path(), a.trust.as_slice());
    let trusted = crate::signoff::verify::load_trusted(trust)?;
    let v = crate::signoff::verify(dir, &trusted, inputs)
        .with_context(|| format!("cannot verify `{}`", dir.display()))?;
    let n = v.signatures.len();
    for s in &v.signatures {
        let trust = match s.trusted {
            Some(true) => "trusted certificate",
            Some(false) => "NOT a trusted certificate",
            None => "identity not checked",
        };
        outln!(
            "signature {} of {n}: \"{}\" on {} (signed {}, Unix {}), certificate \"{}\" SHA-256 {} ({trust})",
            s.index,
            s.signer,
            s.date,
            crate::signoff::policy::utc_time(s.signed_at),
            s.signed_at,
            s.subject,
            s.fingerprint
        )?;
    }
    for p in &v.problems {
        outln!("FAIL: {p}")?;
    }
    if !v.ok() {
        outln!("NOT VERIFIED: {} problem(s)", v.problems.len())?;
        return Ok(ExitCode::Fail);
    }
    outln!(
        "intact: {} files, {n} manifest signature(s), {} PDF signature(s){}",
        v.files,
        v.pdf_signatures,
        if inputs.is_some() {
            format!(", {} input(s) unchanged", v.inputs_checked)
        } else {
            String::new()
        }
    )?;
    if v.identity_checked {
        outln!("verified: every signer holds a trusted certificate")?;
        Ok(ExitCode::Pass)
    } else {
        outln!(
            "IDENTITY NOT CHECKED: anyone can sign under any name; pass --trust CERT (the signers' certificates, obtained from them directly) to check who signed (exit {})",
            ExitCode::IdentityUnchecked.code()
        )?;
        Ok(ExitCode::IdentityUnchecked)
    }
}

/// `plan --sign-key`: the key is loaded now, so that a bad key fails
/// before the run, not after it. The signing time is checked even without
/// a key.
pub(super) fn signing(
    asked: &SignOptions<'_>,
    out: &Path,
) -> Result<Option<crate::pipeline::Signing>, Failure> {
    let time_unix_s = signing_time()?;
    let loaded = match asked.key {
        Some(key) => {
            let loaded = load_signer(Some(key), asked.cert, None, time_unix_s)?;
            crate::signoff::check_key_outside(out, key)?;
            Some(loaded)
        }
        None => None,
    };
    Ok(match (loaded, asked.signer) {
        (Some((key, key_files)), Some(signer)) => Some(crate::pipeline::Signing {
            signer: signer.to_string(),
            key,
            key_files,
            time_unix_s,
        }),
        _ => None,
    })
}

/// The certificates of `import --trust`, loaded as `verify --trust` loads
/// them.
pub(super) fn trusted(paths: &[PathBuf]) -> Result<Trusted, Failure> {
    Ok(Trusted(crate::signoff::verify::load_trusted(paths)?))
}

/// Certificates the user trusts to vouch for signers.
pub(super) struct Trusted(Vec<crate::signoff::Certificate>);

/// What `import` records of a report's signature: none, or the result of
/// [`crate::signoff::verify`] against the trusted certificates, with the
/// first signer it names: `intact` only when every signer's certificate
/// chains to one of them, as `verify --trust` says "verified".
pub(super) fn signature_of(
    dir: &Path,
    trusted: &Trusted,
) -> (crate::campaign::record::Signature, Option<String>) {
    use crate::campaign::record::Signature;
    if !dir.join(crate::signoff::SIGNATURE_FILE).is_file() {
        return (Signature::Unsigned, None);
    }
    // Whether the files are the ones signed, then, apart from it, whether
    // a trusted certificate vouches for every signer: a signature by
    // someone else's key is intact but untrusted, not broken.
    let v = match crate::signoff::verify(dir, &[], None) {
        Ok(v) if v.ok() => v,
        Ok(v) => {
            return (
                Signature::Broken,
                v.signatures.first().map(|s| s.signer.clone()),
            );
        }
        Err(_) => return (Signature::Broken, None),
    };
    let signer = v.signatures.first().map(|s| s.signer.clone());
    if trusted.0.is_empty() {
        return (Signature::Untrusted, signer);
    }
    let vouched = crate::signoff::verify(dir, &trusted.0, None).is_ok_and(|t| {
        t.identity_checked
            && !t.signatures.is_empty()
            && t.signatures.iter().all(|s| s.trusted == Some(true))
    });
    let state = if vouched {
        Signature::Intact
    } else {
        Signature::Untrusted
    };
    (state, signer)
}
