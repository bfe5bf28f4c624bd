//! Reads a signing key and certificate from a PKCS#12 file (RFC 7292), as
//! company PKIs and `openssl pkcs12 -export` write them: PBES2-encrypted
//! bags (PBKDF2 with HMAC-SHA-256, AES-CBC), which is OpenSSL 3's default.
//!
//! The integrity MAC is not checked: a wrong passphrase is caught by the
//! decryption, and the key found must match the certificate found.

use std::path::Path;

use cms::content_info::ContentInfo;
use cms::encrypted_data::EncryptedData;
use der::asn1::{ContextSpecific, OctetString};
use der::{Decode, Encode};
use p256::ecdsa::SigningKey;
use p256::pkcs8::DecodePrivateKey;
use pkcs12::AuthenticatedSafe;
use pkcs12::CertBag;
use pkcs12::Pfx;
use pkcs12::safe_bag::SafeContents;
use x509_cert::Certificate;

use super::SignoffError;
use super::keys::{SignerKey, p256_key_of};

const ID_DATA: der::oid::ObjectIdentifier = const_oid::db::rfc5911::ID_DATA;
const ID_ENCRYPTED_DATA: der::oid::ObjectIdentifier = const_oid::db::rfc5911::ID_ENCRYPTED_DATA;

fn octets(content: &der::Any) -> Result<Vec<u8>, der::Error> {
    Ok(OctetString::from_der(&content.to_der()?)?
        .into_bytes()
        .into_vec())
}

/// Bags found so far.
#[derive(Default)]
struct Found {
    keys: Vec<SigningKey>,
    certs: Vec<Certificate>,
}

fn read_bags(bags: &[u8], password: &str, found: &mut Found) -> Result<(), String> {
    let bags = SafeContents::from_der(bags).map_err(|e| format!("malformed safe contents: {e}"))?;
    for bag in bags {
        match bag.bag_id {
            pkcs12::PKCS_12_CERT_BAG_OID => {
                let cs: ContextSpecific<CertBag> = ContextSpecific::from_der(&bag.bag_value)
                    .map_err(|e| format!("malformed certificate bag: {e}"))?;
                if cs.value.cert_id == pkcs12::PKCS_12_X509_CERT_OID {
                    let cert = Certificate::from_der(cs.value.cert_value.as_bytes())
                        .map_err(|e| format!("malformed certificate: {e}"))?;
                    found.certs.push(cert);
                }
            }
            pkcs12::PKCS_12_PKCS8_KEY_BAG_OID => {
                let cs: ContextSpecific<pkcs8::EncryptedPrivateKeyInfoRef<'_>> =
                    ContextSpecific::from_der(&bag.bag_value)
                        .map_err(|e| format!("malformed key bag: {e}"))?;
                let plain = cs
                    .value
                    .decrypt(password)
                    .map_err(|_| "cannot decrypt the private key: wrong passphrase?".to_string())?;
                let key = SigningKey::from_pkcs8_der(plain.as_bytes())
                    .map_err(|e| format!("the private key is not ECDSA P-256 ({e})"))?;
                found.keys.push(key);
            }
            pkcs12::PKCS_12_KEY_BAG_OID => {
                let cs: ContextSpecific<der::Any> = ContextSpecific::from_der(&bag.bag_value)
                    .map_err(|e| format!("malformed key bag: {e}"))?;
                let der_bytes = cs.value.to_der().map_err(|e| e.to_string())?;
                let key = SigningKey::from_pkcs8_der(&der_bytes)
                    .map_err(|e| format!("the private key is not ECDSA P-256 ({e})"))?;
                found.keys.push(key);
            }
            _ => {}
        }
    }
    Ok(())
}

fn decrypt(info: &ContentInfo, password: &str) -> Result<Vec<u8>, String> {
    let data = EncryptedData::from_der(&info.content.to_der().map_err(|e| e.to_string())?)
        .map_err(|e| format!("malformed encrypted data: {e}"))?;
    let alg = data
        .enc_content_info
        .content_enc_alg
        .to_der()
        .map_err(|e| e.to_string())?;
    let scheme = pkcs5::EncryptionScheme::from_der(&alg).map_err(|e| {
        format!("unsupported encryption ({e}); export with OpenSSL 3 defaults (PBES2, AES)")
    })?;
    let cipher = data
        .enc_content_info
        .encrypted_content
        .ok_or("encrypted data without content")?;
    scheme
        .decrypt(password, cipher.as_bytes())
        .map_err(|_| "cannot decrypt the certificates: wrong passphrase?".to_string())
}

fn parse(bytes: &[u8], password: &str) -> Result<SignerKey, String> {
    let pfx = Pfx::from_der(bytes).map_err(|e| format!("not a PKCS#12 file ({e})"))?;
    if pfx.auth_safe.content_type != ID_DATA {
        return Err("public-key integrity mode is not supported".to_string());
    }
    let safes = octets(&pfx.auth_safe.content).map_err(|e| e.to_string())?;
    let safes =
        AuthenticatedSafe::from_der(&safes).map_err(|e| format!("malformed PKCS#12: {e}"))?;
    let mut found = Found::default();
    for info in &safes {
        let bags = match info.content_type {
            ID_DATA => octets(&info.content).map_err(|e| e.to_string())?,
            ID_ENCRYPTED_DATA => decrypt(info, password)?,
            other => return Err(format!("unsupported content type {other}")),
        };
        read_bags(&bags, password, &mut found)?;
    }
    let key = found
        .keys
        .into_iter()
        .next()
        .ok_or("holds no private key")?;
    let cert = found
        .certs
        .into_iter()
        .find(|c| p256_key_of(c).as_ref() == Some(key.verifying_key()))
        .ok_or("holds no certificate for its private key")?;
    Ok(SignerKey { key, cert })
}

/// Reads the key and its certificate from the PKCS#12 file at `path`.
pub fn load(path: &Path, password: &str) -> Result<SignerKey, SignoffError> {
    let bytes = super::keys::read(path)?;
    parse(&bytes, password).map_err(|message| SignoffError::Key {
        path: path.to_path_buf(),
        message,
    })
}
