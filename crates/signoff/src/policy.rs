//! What a signing certificate must be, for `sign` and `verify` alike.
//!
//! The rules are those the customer's `openssl cms -verify -CAfile`
//! applies (OpenSSL's S/MIME signing purpose, its default for CMS), so that
//! `verify --trust` and OpenSSL give the same answer:
//!
//! - the signer's certificate: keyUsage, when present, holds
//!   digitalSignature or nonRepudiation; extendedKeyUsage, when present,
//!   holds emailProtection (serverAuth, codeSigning or
//!   anyExtendedKeyUsage alone are refused by OpenSSL too);
//! - each issuer on the way to a trust anchor: a CA (basicConstraints
//!   CA:TRUE, or a version 1 self-signed root, or no basicConstraints but
//!   a keyUsage with keyCertSign); keyUsage, when present, holds
//!   keyCertSign; extendedKeyUsage, when present, holds emailProtection;
//!   its ECDSA P-256 signature on the certificate below it checks;
//! - the chain ends at a self-issued certificate given with `--trust`
//!   (OpenSSL takes the certificates of `-CAfile` as trust anchors only
//!   when they are self-signed);
//! - every certificate of the chain is valid (notBefore <= t <= notAfter)
//!   at the time t of the check.
//!
//! OpenSSL checks at the time it runs; `verify` checks at the signing time
//! the signature carries, so that a report stays verifiable after its
//! certificate expires (`openssl cms -verify -attime` does the same).

use x509_cert::Certificate;
use x509_cert::ext::pkix::{BasicConstraints, ExtendedKeyUsage, KeyUsage};

use const_oid::db::rfc5280::{ANY_EXTENDED_KEY_USAGE, ID_KP_EMAIL_PROTECTION};

/// How many issuers a chain may climb before it is given up; company PKIs
/// have two or three levels.
const MAX_DEPTH: usize = 8;

/// `t` (Unix seconds) as `YYYY-MM-DDTHH:MM:SSZ`.
pub fn utc_time(t: u64) -> String {
    der::DateTime::from_unix_duration(std::time::Duration::from_secs(t))
        .map_or_else(|_| format!("{t} s after 1970"), |d| d.to_string())
}

/// The subject of `cert` for messages, e.g. `CN=Root CA,O=Lab`.
fn subject(cert: &Certificate) -> String {
    cert.tbs_certificate().subject().to_string()
}

/// The validity problem of `cert` at `at_unix_s`, naming the field.
fn validity_problem(cert: &Certificate, at_unix_s: u64) -> Option<String> {
    let v = cert.tbs_certificate().validity();
    let (from, to) = (
        v.not_before.to_unix_duration().as_secs(),
        v.not_after.to_unix_duration().as_secs(),
    );
    if at_unix_s < from {
        return Some(format!(
            "notBefore {} is after {} (the certificate was not yet valid)",
            v.not_before,
            utc_time(at_unix_s)
        ));
    }
    if at_unix_s > to {
        return Some(format!(
            "notAfter {} is before {} (the certificate had expired)",
            v.not_after,
            utc_time(at_unix_s)
        ));
    }
    None
}

/// The key usages of `cert`, `Ok(None)` when it has no keyUsage extension.
fn key_usage(cert: &Certificate) -> Result<Option<KeyUsage>, String> {
    cert.tbs_certificate()
        .get_extension::<KeyUsage>()
        .map(|e| e.map(|(_, ku)| ku))
        .map_err(|e| format!("keyUsage cannot be read ({e})"))
}

/// The names of the usages set in `ku`, e.g. "keyEncipherment".
fn usage_names(ku: &KeyUsage) -> String {
    let names = [
        (ku.digital_signature(), "digitalSignature"),
        (ku.non_repudiation(), "nonRepudiation"),
        (ku.key_encipherment(), "keyEncipherment"),
        (ku.data_encipherment(), "dataEncipherment"),
        (ku.key_agreement(), "keyAgreement"),
        (ku.key_cert_sign(), "keyCertSign"),
        (ku.crl_sign(), "cRLSign"),
        (ku.encipher_only(), "encipherOnly"),
        (ku.decipher_only(), "decipherOnly"),
    ];
    let set: Vec<&str> = names
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, n)| *n)
        .collect();
    if set.is_empty() {
        "none".to_string()
    } else {
        set.join(", ")
    }
}

/// The extendedKeyUsage problem of `cert`: present without
/// emailProtection.
fn extended_usage_problem(cert: &Certificate) -> Option<String> {
    let eku = match cert.tbs_certificate().get_extension::<ExtendedKeyUsage>() {
        Ok(None) => return None,
        Ok(Some((_, eku))) => eku,
        Err(e) => return Some(format!("extendedKeyUsage cannot be read ({e})")),
    };
    if eku.0.contains(&ID_KP_EMAIL_PROTECTION) {
        return None;
    }
    let names: Vec<String> = eku
        .0
        .iter()
        .map(|oid| {
            if *oid == ANY_EXTENDED_KEY_USAGE {
                return "anyExtendedKeyUsage".to_string();
            }
            const_oid::db::DB.by_oid(oid).map_or_else(
                || oid.to_string(),
                |n| n.trim_start_matches("id-kp-").to_string(),
            )
        })
        .collect();
    Some(format!(
        "extendedKeyUsage is {} without emailProtection, so OpenSSL refuses it for signing (S/MIME signing purpose)",
        names.join(", ")
    ))
}

/// Every reason why `cert` may not sign at `at_unix_s` (Unix seconds),
/// each naming the certificate field: notBefore, notAfter, keyUsage,
/// extendedKeyUsage. Empty when it may.
pub fn signer_problems(cert: &Certificate, at_unix_s: u64) -> Vec<String> {
    let mut out = Vec::new();
    out.extend(validity_problem(cert, at_unix_s));
    match key_usage(cert) {
        Err(e) => out.push(e),
        Ok(Some(ku)) if !ku.digital_signature() && !ku.non_repudiation() => out.push(format!(
            "keyUsage is {} without digitalSignature or nonRepudiation, so the key may not sign",
            usage_names(&ku)
        )),
        Ok(_) => {}
    }
    out.extend(extended_usage_problem(cert));
    out
}

/// Why `ca` cannot issue certificates for signing at `at_unix_s`, if it
/// cannot (OpenSSL's `check_ca` and S/MIME purpose for issuers).
fn issuer_problem(ca: &Certificate, at_unix_s: u64) -> Option<String> {
    let who = subject(ca);
    let ku = match key_usage(ca) {
        Ok(ku) => ku,
        Err(e) => return Some(format!("issuer `{who}`: {e}")),
    };
    if let Some(ku) = &ku
        && !ku.key_cert_sign()
    {
        return Some(format!(
            "issuer `{who}`: keyUsage is {} without keyCertSign, so it may not issue certificates",
            usage_names(ku)
        ));
    }
    let is_ca = match ca.tbs_certificate().get_extension::<BasicConstraints>() {
        Ok(Some((_, bc))) => bc.ca,
        Ok(None) => {
            let v1_root = ca.tbs_certificate().version() == x509_cert::certificate::Version::V1
                && self_issued(ca);
            v1_root || ku.is_some()
        }
        Err(e) => {
            return Some(format!(
                "issuer `{who}`: basicConstraints cannot be read ({e})"
            ));
        }
    };
    if !is_ca {
        return Some(format!(
            "issuer `{who}`: basicConstraints does not say CA:TRUE, so it may not issue certificates"
        ));
    }
    if let Some(p) = extended_usage_problem(ca) {
        return Some(format!("issuer `{who}`: {p}"));
    }
    validity_problem(ca, at_unix_s).map(|p| format!("issuer `{who}`: {p}"))
}

fn self_issued(cert: &Certificate) -> bool {
    cert.tbs_certificate().issuer() == cert.tbs_certificate().subject()
}

/// Whether `issuer`'s key made the signature on `cert` (ECDSA P-256).
fn signed_by(cert: &Certificate, issuer: &Certificate) -> bool {
    use der::Encode;
    use p256::ecdsa::signature::Verifier;
    if cert.tbs_certificate().issuer() != issuer.tbs_certificate().subject() {
        return false;
    }
    let Some(key) = super::keys::p256_key_of(issuer) else {
        return false;
    };
    let Ok(tbs) = cert.tbs_certificate().to_der() else {
        return false;
    };
    let Some(sig) = cert.signature().as_bytes() else {
        return false;
    };
    let Ok(sig) = p256::ecdsa::DerSignature::from_bytes(sig) else {
        return false;
    };
    key.verify(&tbs, &sig).is_ok()
}

/// Checks that `cert` chains to one of the `trusted` certificates at
/// `at_unix_s` (see the module documentation). `Err` says why not: the
/// problem of the issuer found, or that none was found.
///
/// The signer's own usages and validity are [`signer_problems`]; this
/// checks the way from it to a trust anchor.
pub fn check_chain(
    cert: &Certificate,
    trusted: &[Certificate],
    at_unix_s: u64,
) -> Result<(), String> {
    climb(cert, trusted, at_unix_s, 0)
}

fn climb(cert: &Certificate, trusted: &[Certificate], at: u64, depth: usize) -> Result<(), String> {
    if self_issued(cert) && trusted.contains(cert) {
        return Ok(());
    }
    if depth >= MAX_DEPTH {
        return Err(format!("no trust anchor within {MAX_DEPTH} issuers"));
    }
    let mut why = None;
    for issuer in trusted.iter().filter(|t| *t != cert && signed_by(cert, t)) {
        let step = match issuer_problem(issuer, at) {
            Some(p) => Err(p),
            None => climb(issuer, trusted, at, depth + 1),
        };
        match step {
            Ok(()) => return Ok(()),
            Err(e) => why = why.or(Some(e)),
        }
    }
    Err(why.unwrap_or_else(|| {
        if self_issued(cert) {
            "it is self-signed and not one of the --trust certificates".to_string()
        } else {
            format!(
                "its issuer `{}` is not among the --trust certificates (give the CA certificate that issued it, as `openssl cms -verify -CAfile` needs it too)",
                cert.tbs_certificate().issuer()
            )
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keygen_certificates_may_sign_within_their_validity_only() {
        let t0 = 1_768_435_200;
        let k = super::super::keys::generate("A B, Tested by", "Lab", t0).unwrap();
        assert!(signer_problems(&k.cert, t0).is_empty());
        let before = signer_problems(&k.cert, t0 - 1);
        assert!(
            before.len() == 1 && before[0].starts_with("notBefore"),
            "{before:?}"
        );
        let end = t0 + super::super::keys::VALIDITY_DAYS * 86_400;
        assert!(signer_problems(&k.cert, end).is_empty());
        let after = signer_problems(&k.cert, end + 1);
        assert!(
            after.len() == 1 && after[0].starts_with("notAfter"),
            "{after:?}"
        );
        // A self-signed certificate is its own trust anchor, and no other
        // certificate's.
        assert!(check_chain(&k.cert, std::slice::from_ref(&k.cert), t0).is_ok());
        let other = super::super::keys::generate("A B, Tested by", "Lab", t0).unwrap();
        let e = check_chain(&k.cert, &[other.cert], t0).unwrap_err();
        assert!(e.contains("self-signed"), "{e}");
        assert_eq!(utc_time(t0), "2026-01-15T00:00:00Z");
    }
}
