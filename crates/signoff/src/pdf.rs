//! PDF signatures: each signatory appends an incremental update (ISO
//! 32000-1 section 7.5.6) holding a signature field with a visible widget
//! on the sign-off page (the last page) and a CMS signature
//! (`adbe.pkcs7.detached`, section 12.8) over every byte of the file but
//! the signature itself. Earlier signatures stay valid: their byte ranges
//! are a prefix of the file.

use super::SignoffError;
use super::cms;
use super::keys::SignerKey;
use super::pdf_syntax::{Obj, Parser, XRef, read_xref};

/// Room for the DER signature, bytes (hex-encoded in the file: twice this).
const SIGNATURE_ROOM: usize = 8192;
/// The reason written into every signature.
pub const REASON: &str = "Conformance test report approved";
/// At most this many visible signature blocks fit on the sign-off page.
pub const MAX_SIGNATURES: usize = 6;

/// Who signs and when.
#[derive(Clone)]
pub struct PdfSigner<'a> {
    /// "Name, Role".
    pub name: &'a str,
    /// Signing time, Unix seconds.
    pub time_unix_s: u64,
    /// Date shown in the signature block, `YYYY-MM-DD`.
    pub date: &'a str,
    /// Key and certificate.
    pub key: &'a SignerKey,
}

fn pdf_err(message: impl Into<String>) -> SignoffError {
    SignoffError::Pdf(message.into())
}

/// A PDF text string: literal for ASCII, UTF-16BE with a byte-order mark
/// (hex) otherwise.
fn text_string(s: &str) -> Obj {
    if s.chars().all(|c| (' '..='~').contains(&c)) {
        Obj::Str(escape(s.as_bytes()))
    } else {
        let mut hex = String::from("FEFF");
        for unit in s.encode_utf16() {
            hex.push_str(&format!("{unit:04X}"));
        }
        Obj::Hex(hex)
    }
}

fn escape(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    for &b in bytes {
        if matches!(b, b'(' | b')' | b'\\') {
            out.push(b'\\');
        }
        out.push(b);
    }
    out
}

/// Text for Helvetica with WinAnsiEncoding: Latin-1 characters as they
/// are, anything else as `?`.
fn latin1(s: &str) -> Vec<u8> {
    let bytes: Vec<u8> = s
        .chars()
        .map(|c| match u32::from(c) {
            0x20..=0x7e | 0xa0..=0xff => c as u32 as u8,
            _ => b'?',
        })
        .collect();
    escape(&bytes)
}

/// PDF date `D:YYYYMMDDHHmmSSZ` of a Unix time.
fn pdf_date(unix_s: u64) -> String {
    let date = crate::util::utc_date(unix_s as i64).replace('-', "");
    let s = unix_s % 86_400;
    format!("D:{date}{:02}{:02}{:02}Z", s / 3600, s / 60 % 60, s % 60)
}

/// Where the `index`-th signature block goes on an A4 page, in points:
/// two columns, bottom up, inside the margins of the report template.
fn block_rect(index: usize) -> [f64; 4] {
    let (left, width, height, gap, bottom) = (51.0, 240.0, 62.0, 8.0, 64.0);
    let x = left + (index % 2) as f64 * (width + 12.0);
    let y = bottom + (index / 2) as f64 * (height + gap);
    [x, y, x + width, y + height]
}

fn appearance(signer: &PdfSigner<'_>, cert_cn: &str, width: f64, height: f64) -> Vec<u8> {
    let mut s = Vec::new();
    s.extend_from_slice(
        format!(
            "q 0.96 0.97 1 rg 0 0 {width} {height} re f 0.2 0.3 0.5 RG 0.8 w 0.4 0.4 {} {} re S Q\n",
            width - 0.8,
            height - 0.8
        )
        .as_bytes(),
    );
    let lines = [
        (8.5, format!("Digitally signed by {}", signer.name)),
        (7.0, format!("Reason: {REASON}")),
        (7.0, format!("Date: {}", signer.date)),
        (7.0, format!("Certificate: {cert_cn}")),
    ];
    s.extend_from_slice(format!("BT 0 g 6 {} Td\n", height - 14.0).as_bytes());
    for (i, (size, text)) in lines.iter().enumerate() {
        if i > 0 {
            s.extend_from_slice(b"0 -12.5 Td\n");
        }
        s.extend_from_slice(format!("/F1 {size} Tf (").as_bytes());
        s.extend_from_slice(&latin1(text));
        s.extend_from_slice(b") Tj\n");
    }
    s.extend_from_slice(b"ET\n");
    s
}

fn name(n: &str) -> Obj {
    Obj::Name(n.to_string())
}

fn num(x: impl std::fmt::Display) -> Obj {
    Obj::Num(x.to_string())
}

/// The objects an update writes: (object id, bytes of `N 0 obj ... endobj`).
struct Update {
    objects: Vec<(u32, Vec<u8>)>,
}

impl Update {
    fn add(&mut self, id: u32, body: &[u8]) {
        let mut bytes = format!("{id} 0 obj\n").into_bytes();
        bytes.extend_from_slice(body);
        bytes.extend_from_slice(b"\nendobj\n");
        self.objects.push((id, bytes));
    }

    fn add_obj(&mut self, id: u32, obj: &Obj) {
        let mut body = Vec::new();
        obj.write(&mut body);
        self.add(id, &body);
    }
}

/// Signs `pdf` as `signer`: returns the PDF with one more incremental
/// update carrying the signature.
pub fn sign(pdf: &[u8], signer: &PdfSigner<'_>) -> Result<Vec<u8>, SignoffError> {
    let xref = read_xref(pdf).map_err(pdf_err)?;
    let existing = signatures(pdf).len();
    if existing >= MAX_SIGNATURES {
        return Err(SignoffError::Refused(format!(
            "report.pdf already holds {existing} signatures, the most the sign-off page shows"
        )));
    }
    let size: u32 = match xref.trailer.get("Size") {
        Some(Obj::Num(n)) => n.parse().map_err(|_| pdf_err("bad /Size in the trailer"))?,
        _ => return Err(pdf_err("the trailer has no /Size")),
    };
    let root = xref
        .trailer
        .get("Root")
        .and_then(Obj::as_ref_id)
        .ok_or_else(|| pdf_err("the trailer has no /Root"))?;
    let page = *xref
        .pages(pdf)
        .map_err(pdf_err)?
        .last()
        .ok_or_else(|| pdf_err("the PDF has no page"))?;
    let (sig_id, ap_id, field_id) = (size, size + 1, size + 2);
    let rect = block_rect(existing);
    let (w, h) = (rect[2] - rect[0], rect[3] - rect[1]);
    let cert_cn = super::keys::subject_cn(&signer.key.cert);

    let mut update = Update {
        objects: Vec::new(),
    };
    // The signature dictionary; /ByteRange and /Contents are filled in below.
    let placeholder = "0".repeat(2 * SIGNATURE_ROOM);
    let mut sig = Vec::new();
    sig.extend_from_slice(
        b"<</Type /Sig /Filter /Adobe.PPKLite /SubFilter /adbe.pkcs7.detached\n/Name ",
    );
    text_string(signer.name).write(&mut sig);
    sig.extend_from_slice(b"\n/Reason ");
    text_string(REASON).write(&mut sig);
    sig.extend_from_slice(b"\n/M ");
    Obj::Str(pdf_date(signer.time_unix_s).into_bytes()).write(&mut sig);
    sig.extend_from_slice(b"\n/ByteRange [0 0000000000 0000000000 0000000000]\n/Contents <");
    sig.extend_from_slice(placeholder.as_bytes());
    sig.extend_from_slice(b">>>");
    update.add(sig_id, &sig);

    let stream = appearance(signer, &cert_cn, w, h);
    let mut ap = format!(
        "<</Type /XObject /Subtype /Form /BBox [0 0 {w} {h}] /Resources <</Font <</F1 <</Type /Font /Subtype /Type1 /BaseFont /Helvetica /Encoding /WinAnsiEncoding>>>>>> /Length {}>>\nstream\n",
        stream.len()
    )
    .into_bytes();
    ap.extend_from_slice(&stream);
    ap.extend_from_slice(b"\nendstream");
    update.add(ap_id, &ap);

    let field = Obj::Dict(vec![
        ("Type".into(), name("Annot")),
        ("Subtype".into(), name("Widget")),
        ("FT".into(), name("Sig")),
        (
            "T".into(),
            text_string(&format!("Signature{}", existing + 1)),
        ),
        ("TU".into(), text_string(signer.name)),
        ("V".into(), Obj::Ref(sig_id, 0)),
        ("F".into(), num(132)), // print, locked
        ("Rect".into(), Obj::Array(rect.iter().map(num).collect())),
        ("P".into(), Obj::Ref(page, 0)),
        (
            "AP".into(),
            Obj::Dict(vec![("N".into(), Obj::Ref(ap_id, 0))]),
        ),
    ]);
    update.add_obj(field_id, &field);

    let mut page_dict = xref.object(pdf, page).map_err(pdf_err)?;
    let mut annots = match page_dict.get("Annots") {
        Some(a) => match xref.resolve(pdf, a).map_err(pdf_err)? {
            Obj::Array(items) => items,
            _ => return Err(pdf_err("the sign-off page's /Annots is not an array")),
        },
        None => Vec::new(),
    };
    annots.push(Obj::Ref(field_id, 0));
    page_dict.set("Annots", Obj::Array(annots));
    update.add_obj(page, &page_dict);

    let mut catalog = xref.object(pdf, root).map_err(pdf_err)?;
    let mut form = match catalog.get("AcroForm") {
        Some(f) => xref.resolve(pdf, f).map_err(pdf_err)?,
        None => Obj::Dict(Vec::new()),
    };
    let mut fields = match form.get("Fields") {
        Some(f) => match xref.resolve(pdf, f).map_err(pdf_err)? {
            Obj::Array(items) => items,
            _ => return Err(pdf_err("/AcroForm /Fields is not an array")),
        },
        None => Vec::new(),
    };
    fields.push(Obj::Ref(field_id, 0));
    form.set("Fields", Obj::Array(fields));
    form.set("SigFlags", num(3));
    catalog.set("AcroForm", form);
    update.add_obj(root, &catalog);

    let mut out = write_update(pdf, &xref, update, size + 3)?;
    fill_signature(&mut out, pdf.len(), signer)?;
    Ok(out)
}

/// Appends the objects of `update`, a cross-reference section and a
/// trailer to a copy of `pdf`.
fn write_update(
    pdf: &[u8],
    xref: &XRef,
    update: Update,
    size: u32,
) -> Result<Vec<u8>, SignoffError> {
    let mut out = pdf.to_vec();
    if !out.ends_with(b"\n") {
        out.push(b'\n');
    }
    let mut entries: Vec<(u32, usize)> = Vec::new();
    for (id, bytes) in &update.objects {
        entries.push((*id, out.len()));
        out.extend_from_slice(bytes);
    }
    entries.sort();
    let xref_at = out.len();
    out.extend_from_slice(b"xref\n0 1\n0000000000 65535 f \n");
    for (id, offset) in &entries {
        out.extend_from_slice(format!("{id} 1\n{offset:010} 00000 n \n").as_bytes());
    }
    let mut trailer = vec![
        ("Size".to_string(), num(size)),
        (
            "Root".to_string(),
            xref.trailer.get("Root").cloned().unwrap_or(Obj::Null),
        ),
        ("Prev".to_string(), num(xref.startxref)),
    ];
    for key in ["Info", "ID"] {
        if let Some(v) = xref.trailer.get(key) {
            trailer.push((key.to_string(), v.clone()));
        }
    }
    out.extend_from_slice(b"trailer\n");
    Obj::Dict(trailer).write(&mut out);
    out.extend_from_slice(format!("\nstartxref\n{xref_at}\n%%EOF\n").as_bytes());
    Ok(out)
}

/// Fills in the byte range and the CMS signature of the signature
/// dictionary written after `from`.
fn fill_signature(out: &mut [u8], from: usize, signer: &PdfSigner<'_>) -> Result<(), SignoffError> {
    let find = |needle: &[u8]| {
        out[from..]
            .windows(needle.len())
            .position(|w| w == needle)
            .map(|i| from + i)
    };
    let range_at =
        find(b"/ByteRange [0 ").ok_or_else(|| pdf_err("no byte range placeholder"))? + 14;
    let contents = find(b"/Contents <").ok_or_else(|| pdf_err("no contents placeholder"))? + 10;
    let contents_end = contents + 2 * SIGNATURE_ROOM + 2;
    let len = out.len();
    let range = format!(
        "{:010} {:010} {:010}",
        contents,
        contents_end,
        len - contents_end
    );
    out[range_at..range_at + range.len()].copy_from_slice(range.as_bytes());
    let mut signed = out[..contents].to_vec();
    signed.extend_from_slice(&out[contents_end..]);
    let der = cms::sign_detached(&signed, signer.key, signer.time_unix_s)?;
    if der.len() > SIGNATURE_ROOM {
        return Err(pdf_err(format!(
            "the signature needs {} bytes, more than the {SIGNATURE_ROOM} reserved",
            der.len()
        )));
    }
    let hex: String = der.iter().map(|b| format!("{b:02x}")).collect();
    out[contents + 1..contents + 1 + hex.len()].copy_from_slice(hex.as_bytes());
    Ok(())
}

/// One signature found in a PDF.
#[derive(Debug, Clone)]
pub struct PdfSignature {
    /// `[a, b, c, d]`: bytes a..a+b and c..c+d are signed.
    pub byte_range: [usize; 4],
    /// The DER CMS signature, without the zero padding.
    pub cms: Vec<u8>,
}

impl PdfSignature {
    /// Bytes of the file this signature covers.
    pub fn signed_bytes(&self, pdf: &[u8]) -> Option<Vec<u8>> {
        let [a, b, c, d] = self.byte_range;
        let first = pdf.get(a..a.checked_add(b)?)?;
        let second = pdf.get(c..c.checked_add(d)?)?;
        Some([first, second].concat())
    }

    /// Length of the file revision this signature covers.
    pub fn revision_len(&self) -> usize {
        self.byte_range[2].saturating_add(self.byte_range[3])
    }
}

/// Every signature dictionary of `pdf`, in file order.
pub fn signatures(pdf: &[u8]) -> Vec<PdfSignature> {
    let mut out = Vec::new();
    let needle = b"/ByteRange";
    let mut i = 0;
    while let Some(k) = pdf[i..].windows(needle.len()).position(|w| w == needle) {
        let at = i + k + needle.len();
        i = at;
        let mut p = Parser::new(pdf, at);
        let Ok(Obj::Array(items)) = p.object() else {
            continue;
        };
        let nums: Vec<usize> = items
            .iter()
            .filter_map(|o| match o {
                Obj::Num(n) => n.parse().ok(),
                _ => None,
            })
            .collect();
        let [a, b, c, d] = nums[..] else {
            continue;
        };
        let Some(hex) = pdf.get(a + b..c) else {
            continue;
        };
        let hex = hex.strip_prefix(b"<").and_then(|h| h.strip_suffix(b">"));
        let Some(bytes) = hex.and_then(unhex) else {
            continue;
        };
        out.push(PdfSignature {
            byte_range: [a, b, c, d],
            cms: der_prefix(&bytes).to_vec(),
        });
    }
    out
}

fn unhex(h: &[u8]) -> Option<Vec<u8>> {
    if !h.len().is_multiple_of(2) {
        return None;
    }
    h.chunks(2)
        .map(|p| u8::from_str_radix(std::str::from_utf8(p).ok()?, 16).ok())
        .collect()
}

/// The DER value at the start of `bytes` (without the zero padding after it).
fn der_prefix(bytes: &[u8]) -> &[u8] {
    use der::{Decode, Reader, SliceReader};
    let Ok(mut r) = SliceReader::new(bytes) else {
        return bytes;
    };
    match der::Header::decode(&mut r) {
        Ok(h) => {
            let total = usize::try_from(r.position()).unwrap_or(0)
                + usize::try_from(h.length()).unwrap_or(0);
            &bytes[..total.min(bytes.len())]
        }
        Err(_) => bytes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-page PDF with a classic cross-reference table, written by hand.
    fn tiny_pdf() -> Vec<u8> {
        let objects = [
            "<< /Type /Catalog /Pages 2 0 R >>",
            "<< /Type /Pages /Kids [3 0 R 4 0 R] /Count 2 >>",
            "<< /Type /Page /Parent 2 0 R /MediaBox [0 0 595 842] >>",
            "<< /Type /Page /Parent 2 0 R /MediaBox [0 0 595 842] /Annots [] >>",
        ];
        let mut pdf = b"%PDF-1.7\n".to_vec();
        let mut offsets = Vec::new();
        for (i, o) in objects.iter().enumerate() {
            offsets.push(pdf.len());
            pdf.extend_from_slice(format!("{} 0 obj\n{o}\nendobj\n", i + 1).as_bytes());
        }
        let xref = pdf.len();
        pdf.extend_from_slice(
            format!("xref\n0 {}\n0000000000 65535 f \n", objects.len() + 1).as_bytes(),
        );
        for o in offsets {
            pdf.extend_from_slice(format!("{o:010} 00000 n \n").as_bytes());
        }
        pdf.extend_from_slice(
            format!("trailer\n<< /Size 5 /Root 1 0 R >>\nstartxref\n{xref}\n%%EOF\n").as_bytes(),
        );
        pdf
    }

    #[test]
    fn signatures_chain_and_a_flipped_byte_breaks_them() {
        let k1 = super::super::keys::generate("A, Tested by", "Lab", 1_768_435_200).unwrap();
        let k2 = super::super::keys::generate("Bö, Approved by", "Lab", 1_768_435_200).unwrap();
        let mut pdf = tiny_pdf();
        for (name, key) in [("A, Tested by", &k1), ("Bö, Approved by", &k2)] {
            let signer = PdfSigner {
                name,
                time_unix_s: 1_768_435_200,
                date: "2026-01-15",
                key,
            };
            pdf = sign(&pdf, &signer).unwrap();
        }
        let sigs = signatures(&pdf);
        assert_eq!(sigs.len(), 2);
        assert!(sigs[0].revision_len() < sigs[1].revision_len());
        assert_eq!(
            sigs[1].revision_len(),
            pdf.len(),
            "the last covers the file"
        );
        for (s, key) in sigs.iter().zip([&k1, &k2]) {
            let v = cms::verify_detached(&s.cms, &s.signed_bytes(&pdf).unwrap()).unwrap();
            assert_eq!(v.cert, key.cert);
        }
        // Both widgets sit on the last page, in the form's fields.
        let xref = read_xref(&pdf).unwrap();
        let page = xref.object(&pdf, 4).unwrap();
        let Some(Obj::Array(annots)) = page.get("Annots") else {
            panic!("no annotations: {page:?}");
        };
        assert_eq!(annots.len(), 2);
        let mut flipped = pdf.clone();
        flipped[20] ^= 1;
        for s in signatures(&flipped) {
            assert!(cms::verify_detached(&s.cms, &s.signed_bytes(&flipped).unwrap()).is_err());
        }
    }

    #[test]
    fn pdf_dates_and_text_strings() {
        assert_eq!(pdf_date(1_768_435_200 + 3_723), "D:20260115010203Z");
        assert_eq!(text_string("a(b)"), Obj::Str(b"a\\(b\\)".to_vec()));
        assert_eq!(text_string("ö"), Obj::Hex("FEFF00F6".to_string()));
    }
}
