//! Keys and certificates in standard formats: an ECDSA P-256 private key as
//! PKCS#8 PEM and an X.509 certificate as PEM, from `ledflicker keygen` or
//! from the company's PKI.

use std::path::{Path, PathBuf};
use std::time::{Duration, UNIX_EPOCH};

use der::{Any, Decode, Encode, EncodePem, Tag};
use p256::ecdsa::{SigningKey, VerifyingKey};
use p256::pkcs8::{DecodePrivateKey, EncodePrivateKey, LineEnding};
use spki::{SubjectPublicKeyInfoOwned, SubjectPublicKeyInfoRef};
use x509_cert::Certificate;
use x509_cert::builder::profile::BuilderProfile;
use x509_cert::builder::{Builder, CertificateBuilder};
use x509_cert::certificate::TbsCertificate;
use x509_cert::ext::pkix::{BasicConstraints, KeyUsage, KeyUsages, SubjectKeyIdentifier};
use x509_cert::ext::{Extension, ToExtension};
use x509_cert::name::{Name, RdnSequence, RelativeDistinguishedName};
use x509_cert::serial_number::SerialNumber;
use x509_cert::time::{Time, Validity};

use super::SignoffError;

/// Validity of a certificate made by `keygen`, days.
pub const VALIDITY_DAYS: u64 = 5 * 365;

/// A private key and its certificate, ready to sign.
pub struct SignerKey {
    /// ECDSA P-256 private key.
    pub key: SigningKey,
    /// The signer's certificate; its public key is `key`'s.
    pub cert: Certificate,
}

fn key_err(path: &Path, message: impl Into<String>) -> SignoffError {
    SignoffError::Key {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// The X.509 name `CN=<common_name>, O=<org>` (O left out when empty).
pub fn subject_name(common_name: &str, org: &str) -> Result<Name, der::Error> {
    let mut seq = RdnSequence::default();
    let mut push = |oid, value: &str| -> Result<(), der::Error> {
        let atv = x509_cert::attr::AttributeTypeAndValue {
            oid,
            value: Any::new(Tag::Utf8String, value.as_bytes())?,
        };
        seq.push(RelativeDistinguishedName::try_from(vec![atv])?);
        Ok(())
    };
    if !org.is_empty() {
        push(const_oid::db::rfc4519::O, org)?;
    }
    push(const_oid::db::rfc4519::CN, common_name)?;
    Name::from_der(&seq.to_der()?)
}

/// The profile of a self-signed signing certificate: an end entity (not a
/// CA) whose key signs documents (digitalSignature, nonRepudiation).
struct SelfSignedSigner {
    subject: Name,
}

impl BuilderProfile for SelfSignedSigner {
    fn get_issuer(&self, subject: &Name) -> Name {
        subject.clone()
    }

    fn get_subject(&self) -> Name {
        self.subject.clone()
    }

    fn build_extensions(
        &self,
        spk: SubjectPublicKeyInfoRef<'_>,
        _issuer_spk: SubjectPublicKeyInfoRef<'_>,
        tbs: &TbsCertificate,
    ) -> x509_cert::builder::Result<Vec<Extension>> {
        let mut ext = Vec::new();
        let ski = SubjectKeyIdentifier::try_from(spk)?;
        ext.push(ski.to_extension(tbs.subject(), &ext)?);
        let basic = BasicConstraints {
            ca: false,
            path_len_constraint: None,
        };
        ext.push(basic.to_extension(tbs.subject(), &ext)?);
        let usage = KeyUsage(KeyUsages::DigitalSignature | KeyUsages::NonRepudiation);
        ext.push(usage.to_extension(tbs.subject(), &ext)?);
        Ok(ext)
    }
}

fn time_at(unix_s: u64) -> Result<Time, der::Error> {
    Time::try_from(UNIX_EPOCH + Duration::from_secs(unix_s))
}

/// Makes a new P-256 key and a self-signed certificate for `CN=signer,
/// O=org`, valid from `now_unix_s` for [`VALIDITY_DAYS`].
pub fn generate(signer: &str, org: &str, now_unix_s: u64) -> Result<SignerKey, SignoffError> {
    use p256::elliptic_curve::Generate;
    let crypto = |e: String| SignoffError::Crypto(format!("cannot make the certificate: {e}"));
    let key = SigningKey::try_generate()
        .map_err(|e| crypto(format!("the operating system gave no random bytes: {e}")))?;
    let mut serial = [0u8; 16];
    getrandom::fill(&mut serial)
        .map_err(|e| crypto(format!("the operating system gave no random bytes: {e}")))?;
    serial[0] &= 0x7f; // positive
    serial[0] |= 0x40; // and of full length
    let subject = subject_name(signer, org).map_err(|e| crypto(e.to_string()))?;
    let validity = Validity::new(
        time_at(now_unix_s).map_err(|e| crypto(e.to_string()))?,
        time_at(now_unix_s + VALIDITY_DAYS * 86_400).map_err(|e| crypto(e.to_string()))?,
    );
    let spki = SubjectPublicKeyInfoOwned::from_key(key.verifying_key())
        .map_err(|e| crypto(e.to_string()))?;
    let builder = CertificateBuilder::new(
        SelfSignedSigner { subject },
        SerialNumber::new(&serial).map_err(|e| crypto(e.to_string()))?,
        validity,
        spki,
    )
    .map_err(|e| crypto(e.to_string()))?;
    let cert = builder
        .build::<_, p256::ecdsa::DerSignature>(&key)
        .map_err(|e| crypto(e.to_string()))?;
    Ok(SignerKey { key, cert })
}

/// PKCS#8 PEM text of `key`.
pub fn private_key_pem(key: &SigningKey) -> Result<String, SignoffError> {
    key.to_pkcs8_pem(LineEnding::LF)
        .map(|pem| pem.to_string())
        .map_err(|e| SignoffError::Crypto(format!("cannot encode the private key: {e}")))
}

/// PEM text of `cert`.
pub fn certificate_pem(cert: &Certificate) -> Result<String, SignoffError> {
    cert.to_pem(LineEnding::LF)
        .map_err(|e| SignoffError::Crypto(format!("cannot encode the certificate: {e}")))
}

/// The certificate file that goes with a key file: `NAME.key` ->
/// `NAME.crt`, any other `FILE` -> `FILE.crt`.
pub fn certificate_path(key: &Path) -> PathBuf {
    if key.extension().is_some_and(|e| e == "key") {
        return key.with_extension("crt");
    }
    let mut s = key.as_os_str().to_owned();
    s.push(".crt");
    PathBuf::from(s)
}

/// Reads a key or certificate file the user named; a FIFO or device in
/// its place is refused at once instead of waited on.
pub(super) fn read(path: &Path) -> Result<Vec<u8>, SignoffError> {
    crate::util::read_input(path).map_err(|source| SignoffError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a PKCS#8 PEM private key (ECDSA P-256).
pub fn load_private_key(path: &Path) -> Result<SigningKey, SignoffError> {
    let bytes = read(path)?;
    let text = std::str::from_utf8(&bytes).map_err(|_| key_err(path, "not a PEM text file"))?;
    if text.contains("ledflicker ed25519 private key") {
        return Err(key_err(
            path,
            "an Ed25519 key of ledflicker's old sign-off format, no longer used\n    hint: make a key and certificate with `ledflicker keygen --signer \"Name, Role\" --org \"Company\" --out FILE`",
        ));
    }
    if text.contains("ENCRYPTED PRIVATE KEY") {
        return Err(key_err(
            path,
            "an encrypted PKCS#8 key\n    hint: pass the key and certificate as a PKCS#12 file (--p12) or decrypt it with `openssl pkcs8 -in KEY -out PLAIN.key`",
        ));
    }
    SigningKey::from_pkcs8_pem(text).map_err(|e| {
        let e = e.to_string();
        if e.contains("1.2.840.113549.1.1.1") || text.contains("BEGIN RSA PRIVATE KEY") {
            return key_err(
                path,
                "an RSA key; only ECDSA P-256 keys are supported\n    hint: ask for a P-256 certificate, or make one with `ledflicker keygen`",
            );
        }
        key_err(
            path,
            format!("not a PKCS#8 PEM ECDSA P-256 private key ({e})\n    hint: make one with `ledflicker keygen`, or convert with `openssl pkcs8 -topk8 -nocrypt`"),
        )
    })
}

/// Reads every certificate of a PEM file (or one DER certificate).
pub fn load_certificates(path: &Path) -> Result<Vec<Certificate>, SignoffError> {
    let bytes = read(path)?;
    if bytes.starts_with(b"-----") || bytes.windows(11).any(|w| w == b"-----BEGIN ") {
        let certs = Certificate::load_pem_chain(&bytes)
            .map_err(|e| key_err(path, format!("not a PEM certificate file ({e})")))?;
        if certs.is_empty() {
            return Err(key_err(path, "holds no certificate"));
        }
        return Ok(certs);
    }
    Certificate::from_der(&bytes)
        .map(|c| vec![c])
        .map_err(|e| key_err(path, format!("not an X.509 certificate, PEM or DER ({e})")))
}

/// The P-256 public key of a certificate, or `None` for another algorithm.
pub fn p256_key_of(cert: &Certificate) -> Option<VerifyingKey> {
    let spki = cert.tbs_certificate().subject_public_key_info();
    let der = spki.to_der().ok()?;
    <p256::PublicKey as spki::DecodePublicKey>::from_public_key_der(&der)
        .ok()
        .map(VerifyingKey::from)
}

/// Loads the signing key and its certificate and checks that they match.
pub fn load_signer(key_path: &Path, cert_path: &Path) -> Result<SignerKey, SignoffError> {
    let key = load_private_key(key_path)?;
    let cert = load_certificates(cert_path)?.remove(0);
    if p256_key_of(&cert).as_ref() != Some(key.verifying_key()) {
        return Err(key_err(
            cert_path,
            format!(
                "the certificate does not belong to the private key `{}`\n    hint: pass the certificate made with that key",
                key_path.display()
            ),
        ));
    }
    Ok(SignerKey { key, cert })
}

/// Common name of a certificate's subject, or the whole subject.
pub fn subject_cn(cert: &Certificate) -> String {
    let subject = cert.tbs_certificate().subject();
    match subject.common_name() {
        Ok(Some(cn)) => cn.value().into_owned(),
        _ => subject.to_string(),
    }
}

/// SHA-256 of a certificate's DER, lowercase hex (its fingerprint).
pub fn fingerprint(cert: &Certificate) -> String {
    let der = cert.to_der().unwrap_or_default();
    crate::util::sha256_hex(&der)
}
