//! `keygen`, `sign`, `verify` and `plan --sign-key` in a build without the
//! `signoff` feature: the commands and options are there, so that scripts
//! and `--help` read the same, and each says that this build lacks them
//! (exit 2).

use std::ffi::OsString;
use std::path::Path;

use clap::Args;

use super::{ExitCode, Failure};

use super::args::{SignOptions, signing_time};
use crate::error::NotBuiltIn;

/// What the missing part is called in messages.
const SIGNOFF: &str = "the sign-off (feature `signoff`)";

/// Arguments of a command this build lacks: any are taken, none are read.
#[derive(Args, Debug)]
pub(super) struct Absent {
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, hide = true)]
    _args: Vec<OsString>,
}

pub(super) type KeygenArgs = Absent;
pub(super) type SignArgs = Absent;
pub(super) type VerifyArgs = Absent;

fn absent(what: &str) -> Failure {
    NotBuiltIn {
        what: what.to_string(),
        part: SIGNOFF,
    }
    .into()
}

pub(super) fn keygen(_: KeygenArgs) -> Result<ExitCode, Failure> {
    Err(absent("`keygen`"))
}

pub(super) fn sign(_: SignArgs) -> Result<ExitCode, Failure> {
    Err(absent("`sign`"))
}

pub(super) fn verify(_: VerifyArgs) -> Result<ExitCode, Failure> {
    Err(absent("`verify`"))
}

/// `plan --sign-key` is refused before the run; without it the signing
/// time is still checked, as in a full build.
pub(super) fn signing(
    asked: &SignOptions<'_>,
    _out: &Path,
) -> Result<Option<crate::pipeline::Signing>, Failure> {
    signing_time()?;
    if asked.key.is_some() || asked.cert.is_some() || asked.signer.is_some() {
        return Err(absent("`plan --sign-key`"));
    }
    Ok(None)
}

/// `import --trust` in a build without the sign-off: nothing to load.
pub(super) fn trusted(_paths: &[std::path::PathBuf]) -> Result<Trusted, Failure> {
    Ok(Trusted)
}

/// No certificates: this build checks no signature.
pub(super) struct Trusted;

/// A build without the sign-off cannot check a signature: a signed report
/// is imported as `unchecked`.
pub(super) fn signature_of(
    dir: &Path,
    _trusted: &Trusted,
) -> (crate::campaign::record::Signature, Option<String>) {
    use crate::campaign::record::Signature;
    if dir.join("signoff.p7s").is_file() {
        (Signature::Unchecked, None)
    } else {
        (Signature::Unsigned, None)
    }
}
