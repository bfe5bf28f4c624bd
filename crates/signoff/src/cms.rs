//! Detached CMS signatures (RFC 5652 SignedData) with ECDSA P-256 and
//! SHA-256, built from the `cms` crate's types and encoded with `der`.
//!
//! The same structure serves both uses: the PDF signature
//! (`adbe.pkcs7.detached`, over the PDF's byte range) and the manifest
//! signature (`signoff.p7s`, over manifest.txt). Signed attributes are
//! content type, signing time and message digest (RFC 5652 section 11).

use std::time::{Duration, UNIX_EPOCH};

use cms::cert::CertificateChoices;
use cms::content_info::{CmsVersion, ContentInfo};
use cms::signed_data::{
    CertificateSet, EncapsulatedContentInfo, SignedData, SignerIdentifier, SignerInfo, SignerInfos,
};
use const_oid::db::{rfc5911, rfc5912};
use der::asn1::{OctetString, SetOfVec};
use der::{Any, Decode, Encode, Tag, Tagged};
use p256::ecdsa::signature::{Signer, Verifier};
use sha2::{Digest, Sha256};
use spki::AlgorithmIdentifierOwned;
use x509_cert::Certificate;
use x509_cert::attr::Attribute;
use x509_cert::time::Time;

use super::SignoffError;
use super::keys::{SignerKey, p256_key_of};

fn crypto(what: &str) -> impl FnOnce(der::Error) -> SignoffError + '_ {
    move |e| SignoffError::Crypto(format!("{what}: {e}"))
}

fn attribute(oid: der::oid::ObjectIdentifier, value: Any) -> Result<Attribute, der::Error> {
    let mut values = SetOfVec::new();
    values.insert(value)?;
    Ok(Attribute { oid, values })
}

fn sha256_alg() -> AlgorithmIdentifierOwned {
    AlgorithmIdentifierOwned {
        oid: rfc5912::ID_SHA_256,
        parameters: None,
    }
}

/// Signs `content` (detached: the content is not embedded) at
/// `signing_time_unix_s`; returns the DER of a ContentInfo of SignedData
/// that carries the signer's certificate.
pub fn sign_detached(
    content: &[u8],
    signer: &SignerKey,
    signing_time_unix_s: u64,
) -> Result<Vec<u8>, SignoffError> {
    let digest = Sha256::digest(content);
    let time = Time::try_from(UNIX_EPOCH + Duration::from_secs(signing_time_unix_s))
        .map_err(crypto("signing time"))?;
    let attrs = [
        attribute(
            rfc5911::ID_CONTENT_TYPE,
            Any::new(Tag::ObjectIdentifier, rfc5911::ID_DATA.as_bytes())
                .map_err(crypto("content type"))?,
        ),
        attribute(
            rfc5911::ID_SIGNING_TIME,
            Any::from_der(&time.to_der().map_err(crypto("signing time"))?)
                .map_err(crypto("signing time"))?,
        ),
        attribute(
            rfc5911::ID_MESSAGE_DIGEST,
            Any::new(Tag::OctetString, digest.as_slice()).map_err(crypto("message digest"))?,
        ),
    ];
    let mut signed_attrs = SetOfVec::new();
    for a in attrs {
        signed_attrs
            .insert(a.map_err(crypto("signed attributes"))?)
            .map_err(crypto("signed attributes"))?;
    }
    // RFC 5652 section 5.4: the signature covers the DER of the SET OF.
    let to_sign = signed_attrs.to_der().map_err(crypto("signed attributes"))?;
    let signature: p256::ecdsa::DerSignature = signer.key.sign(&to_sign);
    let signer_info = SignerInfo {
        version: CmsVersion::V1,
        sid: SignerIdentifier::IssuerAndSerialNumber(cms::cert::IssuerAndSerialNumber {
            issuer: signer.cert.tbs_certificate().issuer().clone(),
            serial_number: signer.cert.tbs_certificate().serial_number().clone(),
        }),
        digest_alg: sha256_alg(),
        signed_attrs: Some(signed_attrs),
        signature_algorithm: AlgorithmIdentifierOwned {
            oid: rfc5912::ECDSA_WITH_SHA_256,
            parameters: None,
        },
        signature: OctetString::new(signature.as_bytes()).map_err(crypto("signature"))?,
        unsigned_attrs: None,
    };
    let mut digest_algorithms = SetOfVec::new();
    digest_algorithms
        .insert(sha256_alg())
        .map_err(crypto("digest algorithms"))?;
    let mut certs = SetOfVec::new();
    certs
        .insert(CertificateChoices::Certificate(signer.cert.clone()))
        .map_err(crypto("certificates"))?;
    let mut infos = SetOfVec::new();
    infos.insert(signer_info).map_err(crypto("signer info"))?;
    let signed_data = SignedData {
        version: CmsVersion::V1,
        digest_algorithms,
        encap_content_info: EncapsulatedContentInfo {
            econtent_type: rfc5911::ID_DATA,
            econtent: None,
        },
        certificates: Some(CertificateSet(certs)),
        crls: None,
        signer_infos: SignerInfos(infos),
    };
    let content = Any::from_der(&signed_data.to_der().map_err(crypto("signed data"))?)
        .map_err(crypto("signed data"))?;
    ContentInfo {
        content_type: rfc5911::ID_SIGNED_DATA,
        content,
    }
    .to_der()
    .map_err(crypto("content info"))
}

/// A signature that matched its content.
#[derive(Debug, Clone)]
pub struct Verified {
    /// The signer's certificate, as carried in the signature.
    pub cert: Certificate,
    /// Signing time from the signed attributes, Unix seconds.
    pub signing_time_unix_s: Option<u64>,
}

/// Checks a detached signature (DER ContentInfo) over `content`: the
/// message digest, and the signature over the signed attributes with the
/// public key of the certificate it names. `Err` carries the reason.
pub fn verify_detached(der_bytes: &[u8], content: &[u8]) -> Result<Verified, String> {
    let info = ContentInfo::from_der(der_bytes).map_err(|e| format!("not a CMS structure: {e}"))?;
    if info.content_type != rfc5911::ID_SIGNED_DATA {
        return Err(format!(
            "CMS content type {} is not signedData",
            info.content_type
        ));
    }
    let sd: SignedData = info
        .content
        .decode_as()
        .map_err(|e| format!("malformed SignedData: {e}"))?;
    if sd.encap_content_info.econtent.is_some() {
        return Err("the signature is not detached".to_string());
    }
    let [si] = sd.signer_infos.0.as_slice() else {
        return Err(format!(
            "{} signer infos, expected 1",
            sd.signer_infos.0.len()
        ));
    };
    let certs: Vec<&Certificate> = sd
        .certificates
        .as_ref()
        .map(|c| {
            c.0.iter()
                .filter_map(|c| match c {
                    CertificateChoices::Certificate(c) => Some(c),
                    _ => None,
                })
                .collect()
        })
        .unwrap_or_default();
    let cert = certs
        .into_iter()
        .find(|c| SignerIdentifier::from(*c) == si.sid || matches_isn(c, &si.sid))
        .ok_or("the signer's certificate is not in the signature")?;
    if si.digest_alg.oid != rfc5912::ID_SHA_256 {
        return Err(format!(
            "digest algorithm {} is not SHA-256",
            si.digest_alg.oid
        ));
    }
    if si.signature_algorithm.oid != rfc5912::ECDSA_WITH_SHA_256
        && si.signature_algorithm.oid != rfc5912::ID_EC_PUBLIC_KEY
    {
        return Err(format!(
            "signature algorithm {} is not ECDSA with SHA-256",
            si.signature_algorithm.oid
        ));
    }
    let attrs = si.signed_attrs.as_ref().ok_or("no signed attributes")?;
    let value_of = |oid| {
        attrs
            .iter()
            .find(|a| a.oid == oid)
            .and_then(|a| a.values.get(0))
    };
    let digest = value_of(rfc5911::ID_MESSAGE_DIGEST).ok_or("no message digest attribute")?;
    if digest.tag() != Tag::OctetString || digest.value() != Sha256::digest(content).as_slice() {
        return Err("the content does not match the message digest (it was changed)".to_string());
    }
    let signing_time_unix_s = value_of(rfc5911::ID_SIGNING_TIME)
        .and_then(|v| v.to_der().ok())
        .and_then(|d| Time::from_der(&d).ok())
        .map(|t| t.to_unix_duration().as_secs());
    let key = p256_key_of(cert).ok_or("the signer's key is not ECDSA P-256")?;
    let signed = attrs
        .to_der()
        .map_err(|e| format!("signed attributes: {e}"))?;
    let sig = p256::ecdsa::DerSignature::from_bytes(si.signature.as_bytes())
        .map_err(|_| "malformed ECDSA signature".to_string())?;
    key.verify(&signed, &sig).map_err(|_| {
        "the signature does not match (the signed attributes or the certificate were changed)"
            .to_string()
    })?;
    Ok(Verified {
        cert: cert.clone(),
        signing_time_unix_s,
    })
}

fn matches_isn(cert: &Certificate, sid: &SignerIdentifier) -> bool {
    match sid {
        SignerIdentifier::IssuerAndSerialNumber(isn) => {
            isn.issuer == *cert.tbs_certificate().issuer()
                && isn.serial_number == *cert.tbs_certificate().serial_number()
        }
        SignerIdentifier::SubjectKeyIdentifier(_) => false,
    }
}

/// PEM text (`-----BEGIN CMS-----`) of a DER CMS structure, as OpenSSL
/// writes it.
pub fn to_pem(der_bytes: &[u8]) -> Result<String, SignoffError> {
    der::pem::encode_string("CMS", der::pem::LineEnding::LF, der_bytes)
        .map_err(|e| SignoffError::Crypto(format!("cannot encode the signature as PEM: {e}")))
}

/// DER of a PEM CMS (`CMS` or `PKCS7` label).
pub fn from_pem(text: &str) -> Result<Vec<u8>, String> {
    let (label, der_bytes) =
        der::pem::decode_vec(text.as_bytes()).map_err(|e| format!("not PEM: {e}"))?;
    if label != "CMS" && label != "PKCS7" {
        return Err(format!("PEM label `{label}`, expected CMS"));
    }
    Ok(der_bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detached_signatures_verify_and_catch_a_changed_content() {
        let key = super::super::keys::generate("A B, Tested by", "Lab", 1_768_435_200).unwrap();
        let der = sign_detached(b"manifest\n", &key, 1_768_435_200).unwrap();
        let v = verify_detached(&der, b"manifest\n").unwrap();
        assert_eq!(v.cert, key.cert);
        assert_eq!(v.signing_time_unix_s, Some(1_768_435_200));
        let e = verify_detached(&der, b"manifesT\n").unwrap_err();
        assert!(e.contains("message digest"), "{e}");
        let pem = to_pem(&der).unwrap();
        assert!(pem.starts_with("-----BEGIN CMS-----"));
        assert_eq!(from_pem(&pem).unwrap(), der);
        // A signature byte changed: the signature fails.
        let mut bad = der.clone();
        let n = bad.len();
        bad[n - 5] ^= 0x01;
        assert!(verify_detached(&bad, b"manifest\n").is_err());
    }
}
