//! Just enough PDF syntax (ISO 32000-1 section 7) to add an incremental
//! update to a PDF with a classic cross-reference table, as typst writes:
//! objects, the cross-reference sections and the trailer.

use std::collections::BTreeMap;

/// A PDF object. Strings and names keep their bytes as written, so that
/// writing an object back gives what was read.
#[derive(Debug, Clone, PartialEq)]
pub enum Obj {
    /// `null`
    Null,
    /// `true` / `false`
    Bool(bool),
    /// An integer or real number, as written.
    Num(String),
    /// A name without its slash, as written (escapes kept).
    Name(String),
    /// A literal string's bytes between the parentheses, as written.
    Str(Vec<u8>),
    /// A hexadecimal string's digits.
    Hex(String),
    /// `[ ... ]`
    Array(Vec<Obj>),
    /// `<< ... >>`, keys without their slash, in file order.
    Dict(Vec<(String, Obj)>),
    /// `N G R`
    Ref(u32, u16),
}

impl Obj {
    /// The value of `key` in a dictionary.
    pub fn get(&self, key: &str) -> Option<&Obj> {
        match self {
            Obj::Dict(entries) => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// Sets `key` of a dictionary (replacing it, or appending it).
    pub fn set(&mut self, key: &str, value: Obj) {
        if let Obj::Dict(entries) = self {
            match entries.iter_mut().find(|(k, _)| k == key) {
                Some(entry) => entry.1 = value,
                None => entries.push((key.to_string(), value)),
            }
        }
    }

    /// The object number of a reference.
    pub fn as_ref_id(&self) -> Option<u32> {
        match self {
            Obj::Ref(n, _) => Some(*n),
            _ => None,
        }
    }

    /// Appends the PDF syntax of this object to `out`.
    pub fn write(&self, out: &mut Vec<u8>) {
        match self {
            Obj::Null => out.extend_from_slice(b"null"),
            Obj::Bool(b) => out.extend_from_slice(if *b { b"true" } else { b"false" }),
            Obj::Num(n) => out.extend_from_slice(n.as_bytes()),
            Obj::Name(n) => {
                out.push(b'/');
                out.extend_from_slice(n.as_bytes());
            }
            Obj::Str(s) => {
                out.push(b'(');
                out.extend_from_slice(s);
                out.push(b')');
            }
            Obj::Hex(h) => {
                out.push(b'<');
                out.extend_from_slice(h.as_bytes());
                out.push(b'>');
            }
            Obj::Array(items) => {
                out.push(b'[');
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(b' ');
                    }
                    item.write(out);
                }
                out.push(b']');
            }
            Obj::Dict(entries) => {
                out.extend_from_slice(b"<<");
                for (k, v) in entries {
                    out.push(b'/');
                    out.extend_from_slice(k.as_bytes());
                    out.push(b' ');
                    v.write(out);
                    out.push(b'\n');
                }
                out.extend_from_slice(b">>");
            }
            Obj::Ref(n, g) => out.extend_from_slice(format!("{n} {g} R").as_bytes()),
        }
    }
}

fn is_white(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | b'\x0c' | b'\0')
}

fn is_delim(b: u8) -> bool {
    matches!(
        b,
        b'(' | b')' | b'<' | b'>' | b'[' | b']' | b'{' | b'}' | b'/' | b'%'
    )
}

/// A reader over the bytes of a PDF.
pub struct Parser<'a> {
    data: &'a [u8],
    /// Current byte offset.
    pub pos: usize,
}

impl<'a> Parser<'a> {
    /// A parser at `pos`.
    pub fn new(data: &'a [u8], pos: usize) -> Self {
        Parser { data, pos }
    }

    fn peek(&self) -> Option<u8> {
        self.data.get(self.pos).copied()
    }

    /// Skips white space and comments.
    pub fn skip_white(&mut self) {
        while let Some(b) = self.peek() {
            if is_white(b) {
                self.pos += 1;
            } else if b == b'%' {
                while let Some(c) = self.peek() {
                    if c == b'\n' || c == b'\r' {
                        break;
                    }
                    self.pos += 1;
                }
            } else {
                break;
            }
        }
    }

    /// The next regular token (a keyword or number), without consuming
    /// delimiters.
    pub fn word(&mut self) -> &'a [u8] {
        self.skip_white();
        let start = self.pos;
        while let Some(b) = self.peek() {
            if is_white(b) || is_delim(b) {
                break;
            }
            self.pos += 1;
        }
        &self.data[start..self.pos]
    }

    /// Consumes `keyword` or fails.
    pub fn expect(&mut self, keyword: &str) -> Result<(), String> {
        let at = self.pos;
        let w = self.word();
        if w == keyword.as_bytes() {
            Ok(())
        } else {
            Err(format!(
                "expected `{keyword}` at byte {at}, found `{}`",
                String::from_utf8_lossy(w)
            ))
        }
    }

    /// Reads an unsigned integer token.
    pub fn uint(&mut self) -> Result<u64, String> {
        let at = self.pos;
        let w = self.word();
        std::str::from_utf8(w)
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| format!("expected a number at byte {at}"))
    }

    /// Reads one object.
    pub fn object(&mut self) -> Result<Obj, String> {
        self.skip_white();
        let at = self.pos;
        let rest = &self.data[self.pos..];
        if rest.starts_with(b"<<") {
            self.pos += 2;
            let mut entries = Vec::new();
            loop {
                self.skip_white();
                if self.data[self.pos..].starts_with(b">>") {
                    self.pos += 2;
                    return Ok(Obj::Dict(entries));
                }
                match self.object()? {
                    Obj::Name(k) => {
                        let v = self.object()?;
                        entries.push((k, v));
                    }
                    _ => return Err(format!("dictionary key expected near byte {}", self.pos)),
                }
            }
        }
        match rest.first() {
            None => Err("unexpected end of the file".to_string()),
            Some(b'[') => {
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    self.skip_white();
                    if self.peek() == Some(b']') {
                        self.pos += 1;
                        return Ok(Obj::Array(items));
                    }
                    items.push(self.object()?);
                }
            }
            Some(b'<') => {
                let end = rest
                    .iter()
                    .position(|&b| b == b'>')
                    .ok_or_else(|| format!("unterminated hex string at byte {at}"))?;
                self.pos += end + 1;
                Ok(Obj::Hex(
                    String::from_utf8_lossy(&rest[1..end]).into_owned(),
                ))
            }
            Some(b'(') => {
                let mut depth = 0usize;
                let mut i = 0;
                while i < rest.len() {
                    match rest[i] {
                        b'\\' => i += 1,
                        b'(' => depth += 1,
                        b')' => {
                            depth -= 1;
                            if depth == 0 {
                                self.pos += i + 1;
                                return Ok(Obj::Str(rest[1..i].to_vec()));
                            }
                        }
                        _ => {}
                    }
                    i += 1;
                }
                Err(format!("unterminated string at byte {at}"))
            }
            Some(b'/') => {
                self.pos += 1;
                let start = self.pos;
                while let Some(b) = self.peek() {
                    if is_white(b) || is_delim(b) {
                        break;
                    }
                    self.pos += 1;
                }
                Ok(Obj::Name(
                    String::from_utf8_lossy(&self.data[start..self.pos]).into_owned(),
                ))
            }
            Some(_) => self.word_object(at),
        }
    }

    fn word_object(&mut self, at: usize) -> Result<Obj, String> {
        let w = self.word();
        match w {
            b"true" => return Ok(Obj::Bool(true)),
            b"false" => return Ok(Obj::Bool(false)),
            b"null" => return Ok(Obj::Null),
            _ => {}
        }
        let text = std::str::from_utf8(w).unwrap_or("");
        if text.is_empty() || text.parse::<f64>().is_err() {
            return Err(format!("unexpected `{text}` at byte {at}"));
        }
        // `N G R` is a reference.
        if let Ok(n) = text.parse::<u32>() {
            let save = self.pos;
            let g = self.word();
            if let Ok(g) = std::str::from_utf8(g).unwrap_or("").parse::<u16>()
                && self.word() == b"R"
            {
                return Ok(Obj::Ref(n, g));
            }
            self.pos = save;
        }
        Ok(Obj::Num(text.to_string()))
    }
}

/// The cross-reference data of a PDF: where each object's newest version
/// starts, and the newest trailer.
pub struct XRef {
    /// Object number -> byte offset of `N G obj`.
    pub offsets: BTreeMap<u32, usize>,
    /// The last trailer dictionary.
    pub trailer: Obj,
    /// Offset of the last cross-reference section.
    pub startxref: usize,
}

/// Reads the cross-reference tables of `pdf`, newest first along `/Prev`.
pub fn read_xref(pdf: &[u8]) -> Result<XRef, String> {
    let tail_from = pdf.len().saturating_sub(1024);
    let tail = &pdf[tail_from..];
    let at = tail
        .windows(9)
        .rposition(|w| w == b"startxref")
        .ok_or("no `startxref` at the end: not a complete PDF")?;
    let mut p = Parser::new(pdf, tail_from + at + 9);
    let startxref = p.uint()? as usize;
    let mut offsets = BTreeMap::new();
    let mut trailer = None;
    let mut next = Some(startxref);
    let mut seen = 0;
    while let Some(at) = next {
        seen += 1;
        if seen > 1000 || at >= pdf.len() {
            return Err(format!("broken cross-reference chain at byte {at}"));
        }
        let mut p = Parser::new(pdf, at);
        if p.word() != b"xref" {
            return Err(format!(
                "no cross-reference table at byte {at} (cross-reference streams are not supported)"
            ));
        }
        loop {
            let save = p.pos;
            if p.word() == b"trailer" {
                break;
            }
            p.pos = save;
            let first = p.uint()? as u32;
            let count = p.uint()? as u32;
            for k in 0..count {
                let offset = p.uint()? as usize;
                let _gen = p.uint()?;
                let kind = p.word();
                if kind == b"n" {
                    offsets.entry(first + k).or_insert(offset);
                }
            }
        }
        let t = p.object()?;
        next = match t.get("Prev") {
            Some(Obj::Num(n)) => Some(n.parse().map_err(|_| "bad /Prev".to_string())?),
            _ => None,
        };
        if trailer.is_none() {
            trailer = Some(t);
        }
    }
    Ok(XRef {
        offsets,
        trailer: trailer.ok_or("no trailer")?,
        startxref,
    })
}

impl XRef {
    /// The newest version of object `id` (its dictionary or value).
    pub fn object(&self, pdf: &[u8], id: u32) -> Result<Obj, String> {
        let at = *self
            .offsets
            .get(&id)
            .ok_or_else(|| format!("object {id} is not in the cross-reference table"))?;
        let mut p = Parser::new(pdf, at);
        let n = p.uint()?;
        let _gen = p.uint()?;
        p.expect("obj")?;
        if n != u64::from(id) {
            return Err(format!("object {id} is not at byte {at}"));
        }
        p.object()
    }

    /// Resolves a reference (or returns a direct object as is).
    pub fn resolve(&self, pdf: &[u8], obj: &Obj) -> Result<Obj, String> {
        match obj {
            Obj::Ref(n, _) => self.object(pdf, *n),
            other => Ok(other.clone()),
        }
    }

    /// Object ids of the pages in order.
    pub fn pages(&self, pdf: &[u8]) -> Result<Vec<u32>, String> {
        let root = self.trailer.get("Root").ok_or("the trailer has no /Root")?;
        let catalog = self.resolve(pdf, root)?;
        let pages = catalog.get("Pages").ok_or("the catalog has no /Pages")?;
        let mut out = Vec::new();
        self.collect_pages(pdf, pages, &mut out, 0)?;
        Ok(out)
    }

    fn collect_pages(
        &self,
        pdf: &[u8],
        node: &Obj,
        out: &mut Vec<u32>,
        depth: usize,
    ) -> Result<(), String> {
        if depth > 64 {
            return Err("the page tree is too deep".to_string());
        }
        let id = node
            .as_ref_id()
            .ok_or("a page tree node is not a reference")?;
        let dict = self.object(pdf, id)?;
        match dict.get("Kids") {
            Some(Obj::Array(kids)) => {
                for kid in kids {
                    self.collect_pages(pdf, kid, out, depth + 1)?;
                }
            }
            _ => out.push(id),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_round_trip() {
        let src = b"<< /Type /Page /Kids [1 0 R 2 0 R] /A (x\\)y(z)) /B <00ff> /C -1.5 /D true /E null >>";
        let obj = Parser::new(src, 0).object().unwrap();
        assert_eq!(
            obj.get("Kids"),
            Some(&Obj::Array(vec![Obj::Ref(1, 0), Obj::Ref(2, 0)]))
        );
        assert_eq!(obj.get("A"), Some(&Obj::Str(b"x\\)y(z)".to_vec())));
        let mut out = Vec::new();
        obj.write(&mut out);
        assert_eq!(Parser::new(&out, 0).object().unwrap(), obj);
    }
}
