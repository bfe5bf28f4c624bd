//! Cheaper chart SVGs for the PDF: fewer shapes, and no transparency
//! groups.
//!
//! plotters writes one element per marker, tick, grid line and dash: the
//! zoom chart of a P2020 capture holds 9,720 `circle` elements (one marker
//! per frame and ROI), a phase fold about 90 `polyline`s. Typst parses each
//! SVG with usvg and its PDF export (krilla) writes each shape as a path
//! with its own graphics state. A shape with `opacity` below 1 costs far
//! more: usvg makes it a group, and krilla an isolated transparency group,
//! a form XObject with its own compressed stream.
//!
//! Two rewrites paint the same picture more cheaply:
//! - **Merged runs.** Consecutive opaque shapes of one colour become one
//!   `path` per style (stroke width, filled or stroked), whose subpaths are
//!   those shapes in order: a filled `circle` as four cubic Béziers (the
//!   usual quarter-circle approximation, within 0.03 % of the radius; usvg
//!   too turns a circle into cubics), a filled `rect` as a closed
//!   rectangle, a stroked `line` or `polyline` as an open subpath. Opaque
//!   paint of one colour gives the same pixels in any order, so the styles
//!   of a run may be regrouped. Every closed subpath winds the same way
//!   (clockwise on screen), so under the non-zero rule a merged fill covers
//!   the union of its shapes, and a merged stroke is the union of its
//!   subpaths' outlines; only the anti-aliased edge where two shapes of one
//!   colour overlap can come out a shade different.
//! - **Opacity on the paint.** A translucent shape painted one way only
//!   (filled with no stroke, or stroked with no fill) gets `fill-opacity`
//!   or `stroke-opacity` for its `opacity`: a single fill or stroke covers
//!   each point once, so that is the same compositing without a group.
//!   Translucent shapes are never merged, since overlaps would then be
//!   painted once instead of twice.
//!
//! Only elements whose every attribute is one this module knows, with plain
//! numbers, are touched; anything else (text, polygons when opaque,
//! transforms, rounded corners, dashes) is left exactly as written, and so
//! is a style that a run holds only once. The chart files in `charts/` and
//! the HTML report keep plotters' SVG.

/// Style attributes a shape may carry.
const STYLE: [&str; 4] = ["fill", "stroke", "stroke-width", "opacity"];

/// The quarter-circle control distance of a cubic Bézier, as a share of the
/// radius: 4/3 (sqrt 2 - 1).
const KAPPA: f64 = 0.552_284_749_830_793_4;

/// `svg` with each run of opaque shapes of one colour merged into one path
/// per style, and translucent shapes' opacity moved onto their paint.
pub fn simplify(svg: &str) -> String {
    // A style sheet may select shapes by element name, and a comment or
    // character data may hold what looks like a tag: left as they are.
    if ["<style", "<!--", "<![CDATA["]
        .iter()
        .any(|s| svg.contains(s))
    {
        return svg.to_string();
    }
    let mut out = String::with_capacity(svg.len());
    let mut run = Run::default();
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        let (between, from) = rest.split_at(start);
        let Some(len) = tag_len(from) else { break };
        let (tag, after) = from.split_at(len);
        rest = after;
        let shape = Shape::parse(tag).filter(|_| between.trim().is_empty());
        match shape {
            Some(shape) if shape.opacity.is_none() => {
                if !run.takes(&shape) {
                    run.flush(&mut out);
                    out.push_str(between);
                }
                run.push(tag, shape);
            }
            Some(shape) => {
                run.flush(&mut out);
                out.push_str(between);
                shape.write_translucent(&mut out);
            }
            None => {
                run.flush(&mut out);
                out.push_str(between);
                out.push_str(tag);
            }
        }
    }
    run.flush(&mut out);
    out.push_str(rest);
    out
}

/// Length of the markup item at the start of `from` (which starts with
/// `<`), up to and including its `>`, skipping quoted attribute values.
fn tag_len(from: &str) -> Option<usize> {
    // Plotters' tags: double quotes only, none of them around a `>`.
    let end = from.find('>')? + 1;
    let tag = &from.as_bytes()[..end];
    if !tag.contains(&b'\'') && tag.iter().filter(|&&b| b == b'"').count() % 2 == 0 {
        return Some(end);
    }
    let mut quote = None;
    for (i, b) in from.bytes().enumerate() {
        match (quote, b) {
            (None, b'"' | b'\'') => quote = Some(b),
            (Some(q), _) if q == b => quote = None,
            (None, b'>') => return Some(i + 1),
            _ => {}
        }
    }
    None
}

/// How a shape is painted: stroked or filled, and its style attributes as
/// written, `opacity` and a stroked shape's `fill` left out.
#[derive(PartialEq)]
struct Style<'a> {
    stroked: bool,
    attributes: Vec<(&'a str, &'a str)>,
}

/// Consecutive opaque shapes of one colour, by style in order of first
/// appearance.
#[derive(Default)]
struct Run<'a> {
    colour: Option<&'a str>,
    groups: Vec<Group<'a>>,
    arcs: Option<(&'a str, String)>,
}

/// The shapes of one style in a run.
struct Group<'a> {
    style: Style<'a>,
    /// The first shape's tag as written, kept when the group stays alone.
    first: &'a str,
    count: usize,
    data: String,
}

impl<'a> Run<'a> {
    fn takes(&self, shape: &Shape<'a>) -> bool {
        self.colour.is_some() && self.colour == Some(shape.colour())
    }

    fn push(&mut self, tag: &'a str, shape: Shape<'a>) {
        self.colour = Some(shape.colour());
        if let Some(group) = self.groups.iter_mut().find(|g| g.style == shape.style) {
            group.count += 1;
            shape.write_subpath(&mut group.data, &mut self.arcs);
            return;
        }
        let mut data = String::with_capacity(256);
        shape.write_subpath(&mut data, &mut self.arcs);
        self.groups.push(Group {
            style: shape.style,
            first: tag,
            count: 1,
            data,
        });
    }

    fn flush(&mut self, out: &mut String) {
        self.colour = None;
        for group in self.groups.drain(..) {
            if group.count == 1 {
                out.push_str(group.first);
                continue;
            }
            out.push_str("<path");
            if group.style.stroked {
                out.push_str(" fill=\"none\"");
            }
            for (name, value) in &group.style.attributes {
                push_all(out, &[" ", name, "=\"", value, "\""]);
            }
            push_all(out, &[" d=\"", &group.data, "\"/>"]);
        }
    }
}

/// One shape a tag draws: its style, opacity below 1 (if any) and
/// geometry, as written.
struct Shape<'a> {
    name: &'a str,
    style: Style<'a>,
    opacity: Option<&'a str>,
    geometry: [&'a str; 4],
}

impl<'a> Shape<'a> {
    /// The shape a self-closing tag draws, when it is one this module may
    /// rewrite: painted one way only, with known attributes and plain
    /// numbers.
    fn parse(tag: &'a str) -> Option<Self> {
        let body = tag.strip_prefix('<')?.strip_suffix("/>")?;
        let (name, attributes) = body.split_once(' ')?;
        let geometry_names: &[&str] = match name {
            "line" => &["x1", "y1", "x2", "y2"],
            "polyline" | "polygon" => &["points"],
            "circle" => &["cx", "cy", "r"],
            "rect" => &["x", "y", "width", "height"],
            _ => return None,
        };
        let mut style = Vec::with_capacity(STYLE.len());
        let mut opacity = None;
        let mut geometry = [""; 4];
        let mut seen = 0u32;
        for (key, value) in attribute_pairs(attributes)? {
            if key == "opacity" {
                let o: f64 = value.parse().ok().filter(|o| (0.0..=1.0).contains(o))?;
                opacity = (o < 1.0).then_some(value);
            } else if STYLE.contains(&key) {
                let plain = |b: u8| b.is_ascii_alphanumeric() || b"#.-".contains(&b);
                if !value.bytes().all(plain) || style.iter().any(|(k, _)| *k == key) {
                    return None;
                }
                style.push((key, value));
            } else {
                let i = geometry_names.iter().position(|n| *n == key)?;
                if seen & (1 << i) != 0 {
                    return None;
                }
                geometry[i] = value;
                seen |= 1 << i;
            }
        }
        if seen != (1 << geometry_names.len()) - 1 || !geometry_ok(name, geometry) {
            return None;
        }
        let paint = |k: &str| style.iter().any(|(n, v)| *n == k && *v != "none");
        // `fill` defaults to black, `stroke` to none; a line has no fill.
        let fills = name != "line" && (paint("fill") || !style.iter().any(|(n, _)| *n == "fill"));
        let stroked = match (fills, paint("stroke")) {
            (false, true) => true,
            (true, false) => false,
            _ => return None,
        };
        if stroked {
            style.retain(|(n, _)| *n != "fill");
        }
        // Opaque polygons are left alone (their winding is arbitrary), and
        // so are opaque rectangles: adjacent cells of a map, merged, show
        // seams in PDF viewers that snap single rectangles to the pixel grid.
        if matches!(name, "polygon" | "rect") && opacity.is_none() {
            return None;
        }
        Some(Self {
            name,
            style: Style {
                stroked,
                attributes: style,
            },
            opacity,
            geometry,
        })
    }

    /// The value of the paint: the stroke of a stroked shape, else the fill
    /// (black when the tag has no `fill`).
    fn colour(&self) -> &'a str {
        let key = if self.style.stroked { "stroke" } else { "fill" };
        self.style
            .attributes
            .iter()
            .find(|(n, _)| *n == key)
            .map_or("#000000", |(_, v)| v)
    }

    /// Writes the tag with its opacity on its paint.
    fn write_translucent(&self, out: &mut String) {
        push_all(out, &["<", self.name]);
        for (name, value) in &self.style.attributes {
            push_all(out, &[" ", name, "=\"", value, "\""]);
        }
        let which = if self.style.stroked {
            " fill=\"none\" stroke-opacity=\""
        } else {
            " fill-opacity=\""
        };
        push_all(out, &[which, self.opacity.unwrap_or("1"), "\""]);
        let names: &[&str] = match self.name {
            "line" => &["x1", "y1", "x2", "y2"],
            "polyline" | "polygon" => &["points"],
            "circle" => &["cx", "cy", "r"],
            _ => &["x", "y", "width", "height"],
        };
        for (name, value) in names.iter().zip(self.geometry) {
            push_all(out, &[" ", name, "=\"", value, "\""]);
        }
        out.push_str("/>");
    }

    /// Appends the shape as one subpath; `arcs` keeps the last circle's
    /// radius and its four quarters, which plotters' markers share.
    fn write_subpath(&self, d: &mut String, arcs: &mut Option<(&'a str, String)>) {
        let [a, b, c, e] = self.geometry;
        match self.name {
            "line" => push_all(d, &["M", a, ",", b, "L", c, ",", e]),
            "polyline" => push_all(d, &["M", a.trim()]),
            "circle" => {
                // From the rightmost point, clockwise on screen (y down).
                push_all(d, &["M", a, ",", b, "m", c, ",0"]);
                match arcs {
                    Some((r, text)) if *r == c => d.push_str(text),
                    _ => {
                        let text = quarter_arcs(c.parse().unwrap_or(0.0));
                        d.push_str(&text);
                        *arcs = Some((c, text));
                    }
                }
            }
            _ => push_all(d, &["M", a, ",", b, "h", c, "v", e, "H", a, "z"]),
        }
    }
}

/// Whether the geometry is plain numbers: positive radius and sizes, an
/// even count (at least two) of point coordinates.
fn geometry_ok(name: &str, [a, b, c, d]: [&str; 4]) -> bool {
    match name {
        "line" => [a, b, c, d].into_iter().all(is_number),
        "polyline" | "polygon" => is_points(a),
        "circle" => is_number(a) && is_number(b) && is_positive(c),
        _ => is_number(a) && is_number(b) && is_positive(c) && is_positive(d),
    }
}

/// The four quarters of a circle of radius `r` from its rightmost point,
/// clockwise on screen, as relative cubic Béziers, closed.
fn quarter_arcs(r: f64) -> String {
    let k = r * KAPPA;
    let m = r - k;
    let quarters = [
        [0.0, k, -m, r, -r, r],
        [-k, 0.0, -r, -m, -r, -r],
        [0.0, -k, m, -r, r, -r],
        [k, 0.0, r, m, r, r],
    ];
    let mut d = String::with_capacity(128);
    for q in quarters {
        d.push('c');
        for (i, v) in q.into_iter().enumerate() {
            if i > 0 {
                d.push(' ');
            }
            push_number(&mut d, v);
        }
    }
    d.push('z');
    d
}

fn push_all(d: &mut String, parts: &[&str]) {
    parts.iter().for_each(|p| d.push_str(p));
}

/// Writes `v` with at most four decimals (a ten-thousandth of a chart
/// pixel), without trailing zeros.
fn push_number(d: &mut String, v: f64) {
    let text = format!("{v:.4}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    d.push_str(if text == "-0" { "0" } else { text });
}

/// The `name="value"` pairs of a tag's attributes, or `None` when they are
/// not all of that form (single quotes, entities, a value-less name).
fn attribute_pairs(mut text: &str) -> Option<Vec<(&str, &str)>> {
    let mut pairs = Vec::with_capacity(8);
    loop {
        text = text.trim_start();
        if text.is_empty() {
            return Some(pairs);
        }
        let (name, rest) = text.split_once('=')?;
        let rest = rest.strip_prefix('"')?;
        let end = rest.find('"')?;
        let value = &rest[..end];
        // The values used are checked to be plain numbers or colours, so
        // an entity never gets through.
        if name.bytes().any(|b| b.is_ascii_whitespace()) {
            return None;
        }
        pairs.push((name, value));
        text = &rest[end + 1..];
    }
}

/// A plain decimal number as plotters writes them: an optional minus,
/// digits with at most one decimal point, no exponent, units or percent.
fn is_number(v: &str) -> bool {
    let digits = v.strip_prefix('-').unwrap_or(v);
    let mut points = 0;
    let mut any_digit = false;
    for b in digits.bytes() {
        match b {
            b'0'..=b'9' => any_digit = true,
            b'.' => points += 1,
            _ => return false,
        }
    }
    any_digit && points <= 1
}

fn is_positive(v: &str) -> bool {
    is_number(v) && !v.starts_with('-') && v.bytes().any(|b| matches!(b, b'1'..=b'9'))
}

/// A polyline's `points`: an even count (at least two) of plain numbers
/// (see [`is_number`]) separated by commas or spaces. One pass over the
/// bytes: a trace's points are most of a chart.
fn is_points(v: &str) -> bool {
    let mut count = 0usize;
    // Within a number: whether it has a digit, and a decimal point.
    let mut token: Option<(bool, bool)> = None;
    // A comma since the last number (at most one between two numbers).
    let mut comma = false;
    for b in v.bytes() {
        let start = token.is_none() && b != b',' && b != b' ';
        if start {
            count += 1;
            comma = false;
        }
        token = match (b, token) {
            (_, Some((false, _))) if matches!(b, b',' | b' ') => return false,
            (b',', _) if comma || count == 0 => return false,
            (b',', _) => {
                comma = true;
                None
            }
            (b' ', _) => None,
            (b'-', None) => Some((false, false)),
            (b'.', None) => Some((false, true)),
            (b'.', Some((digit, false))) => Some((digit, true)),
            (b'0'..=b'9', None) => Some((true, false)),
            (b'0'..=b'9', Some((_, point))) => Some((true, point)),
            _ => return false,
        };
    }
    !comma && token.is_none_or(|(digit, _)| digit) && count >= 2 && count.is_multiple_of(2)
}

#[cfg(test)]
mod tests;
