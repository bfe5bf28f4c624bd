//! Where each key of a plan file is: dotted key path -> line and column.
//!
//! serde gives values without positions, so the file is parsed a second time
//! into toml's spanned document tree and every key path is indexed. Paths
//! look like `dut.camera.exposure-ms` and `roi[1].x-px`.

use std::collections::HashMap;

use toml::de::{DeTable, DeValue};

/// Key path -> byte offset of the key (or array element) in the file.
pub struct SpanIndex {
    offsets: HashMap<String, usize>,
    line_starts: Vec<usize>,
}

impl SpanIndex {
    /// Parses `text` and indexes every key and array element.
    pub fn build(text: &str) -> Result<Self, toml::de::Error> {
        let root = DeTable::parse(text)?;
        let mut offsets = HashMap::new();
        index_table(root.get_ref(), "", &mut offsets);
        let line_starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Ok(Self {
            offsets,
            line_starts,
        })
    }

    /// 1-based line and column of `key`, if it appears in the file.
    pub fn location(&self, key: &str) -> Option<(usize, usize)> {
        let offset = *self.offsets.get(key)?;
        let line = self.line_starts.partition_point(|&s| s <= offset);
        let col = offset - self.line_starts[line - 1] + 1;
        Some((line, col))
    }
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

fn index_table(table: &DeTable<'_>, prefix: &str, out: &mut HashMap<String, usize>) {
    for (key, value) in table.iter() {
        let path = join(prefix, key.get_ref());
        out.insert(path.clone(), key.span().start);
        index_value(value.get_ref(), &path, out);
    }
}

fn index_value(value: &DeValue<'_>, path: &str, out: &mut HashMap<String, usize>) {
    match value {
        DeValue::Table(t) => index_table(t, path, out),
        DeValue::Array(items) => {
            for (i, item) in items.into_iter().enumerate() {
                let item_path = format!("{path}[{i}]");
                out.insert(item_path.clone(), item.span().start);
                index_value(item.get_ref(), &item_path, out);
            }
        }
        _ => {}
    }
}

/// Deserialises a TOML file's raw table, adding to `unknown` each key no
/// field takes ([`path_string`]).
///
/// serde_ignored's deserialiser is generic over its callback, and so is
/// every raw type's deserialisation through it: a closure of its own at
/// each file kind (plan, DUT profile, report profile) compiled the raw
/// types they share (the camera, the report table) once per kind. One
/// callback type, a `dyn` one, compiles them once.
pub fn deserialize_noting_unknown<'de, T: serde::Deserialize<'de>>(
    de: toml::Deserializer<'de>,
    unknown: &mut Vec<String>,
) -> Result<T, toml::de::Error> {
    let mut note = |p: serde_ignored::Path<'_>| unknown.push(path_string(&p));
    serde_ignored::deserialize(de, &mut note as &mut dyn FnMut(serde_ignored::Path<'_>))
}

/// Formats a serde_ignored path in the same style as [`SpanIndex`] keys.
pub fn path_string(path: &serde_ignored::Path<'_>) -> String {
    use serde_ignored::Path;
    match path {
        Path::Root => String::new(),
        Path::Seq { parent, index } => format!("{}[{index}]", path_string(parent)),
        Path::Map { parent, key } => join(&path_string(parent), key),
        Path::Some { parent }
        | Path::NewtypeStruct { parent }
        | Path::NewtypeVariant { parent } => path_string(parent),
    }
}

/// Keys each table accepts; used for "did you mean" hints only (serde
/// decides what is unknown). A test checks this list against the structs.
pub(crate) const KNOWN_KEYS: &[(&str, &[&str])] = &[
    (
        "",
        &[
            "format-version",
            "plan",
            "sequence",
            "light",
            "grid",
            "roi",
            "dut",
            "scene",
            "thresholds",
            "capture",
            "case",
            "p2020",
            "report",
            "display",
            "source",
        ],
    ),
    (
        "source",
        &[
            "instrument",
            "host",
            "port",
            "channel",
            "amplitude-vpp",
            "offset-v",
            "timeout-s",
            "lead-in-s",
            "reconnects",
            "commands",
        ],
    ),
    (
        "source.commands",
        &[
            "identify",
            "error-query",
            "setup",
            "steady",
            "pwm",
            "output-on",
            "output-off",
        ],
    ),
    (
        "plan",
        &["id", "title", "standard", "description", "lab", "seed"],
    ),
    ("sequence", &["on-s", "off-s", "pwm-s"]),
    ("light", &["levels-lux"]),
    (
        "grid",
        &[
            "frequencies-hz",
            "frequency-range-hz",
            "duty-cycles",
            "duty-cycle-range",
        ],
    ),
    ("grid.frequency-range-hz", &["start", "stop", "step"]),
    ("grid.duty-cycle-range", &["start", "stop", "step"]),
    (
        "roi",
        &["name", "kind", "x-px", "y-px", "width-px", "height-px"],
    ),
    (
        "dut",
        &[
            "backend", "supplier", "model", "serial", "firmware", "camera",
        ],
    ),
    (
        "dut.camera",
        &[
            "name",
            "description",
            "shutter",
            "sensor-rows",
            "sensor-columns",
            "line-time-us",
            "exposure-ms",
            "frame-rate-fps",
            "pwm-delay-ms",
            "response-dn-per-cd-m2-s",
            "black-level-dn",
            "full-scale-dn",
            "saturation-dn",
            "analog-gain",
            "digital-gain",
            "sensor",
            "capture",
            "hdr",
            "tone",
            "auto-exposure",
            "colour-plane-offset-ms",
            "camera-to-xyz",
        ],
    ),
    (
        "dut.camera.sensor",
        &[
            "sensitivity-e-per-cd-m2-s",
            "full-well-e",
            "read-noise-e",
            "shot-noise",
            "adc-bits",
            "e-per-dn",
        ],
    ),
    (
        "dut.camera.capture",
        &["name", "exposure-ratio", "exposure-ms", "sensitivity-ratio"],
    ),
    ("dut.camera.hdr", &["mode", "merge", "white-dn"]),
    (
        "dut.camera.tone",
        &["curve", "gamma", "log-a", "output-bits"],
    ),
    (
        "dut.camera.auto-exposure",
        &[
            "target-luma",
            "target",
            "damping",
            "deadband",
            "min-exposure-ms",
            "max-exposure-ms",
            "max-analog-gain",
            "min-digital-gain",
            "max-digital-gain",
        ],
    ),
    (
        "scene",
        &[
            "background-reflectance",
            "led-luminance-cd-m2",
            "led-fill",
            "led-frame-fraction",
            "pwm-clock-offset-ppm",
            "led-chromaticity-xy",
            "signal-colour",
            "led-die",
        ],
    ),
    (
        "scene.led-die",
        &[
            "chromaticity-xy",
            "luminance-share",
            "duty-cycle",
            "phase-deg",
        ],
    ),
    (
        "thresholds",
        &[
            "fdi-2018-min",
            "percent-flicker-max",
            "fmi-max",
            "fdi-p2020-min",
            "mmp-min",
            "visibility-max",
            "delta-uv-max",
            "mitigation-min-hz",
            "mitigation-max-hz",
            "basis",
            "light-level",
        ],
    ),
    (
        "thresholds.light-level",
        &[
            "light-lux",
            "fdi-2018-min",
            "percent-flicker-max",
            "fmi-max",
            "fdi-p2020-min",
            "mmp-min",
            "visibility-max",
            "delta-uv-max",
        ],
    ),
    (
        "capture",
        &[
            "luma",
            "video-decode",
            "video-range",
            "colour-transfer",
            "black-level",
            "frame-rate-fps",
            "saturation-dn",
            "off-frames",
            "on-frames",
            "pwm-frames",
            "off-time-s",
            "on-time-s",
            "pwm-time-s",
            "command",
            "timeout-s",
            "settle-s",
        ],
    ),
    (
        "case",
        &[
            "id",
            "source",
            "light-lux",
            "frequency-hz",
            "duty-cycle",
            "off-frames",
            "on-frames",
            "pwm-frames",
            "off-time-s",
            "on-time-s",
            "pwm-time-s",
            "informative",
        ],
    ),
    (
        "p2020",
        &["contrast-threshold", "mmp-delta", "mmp-reference"],
    ),
    (
        "report",
        &[
            "company",
            "logo",
            "document-number",
            "sections",
            "templates",
            "labels",
        ],
    ),
    (
        "display",
        &[
            "preset",
            "eotf",
            "refresh-hz",
            "peak-cd-m2",
            "black-cd-m2",
            "image-width-mm",
            "distance-mm",
            "full-scale-dn",
            "image-width-px",
        ],
    ),
];

/// Most characters of a plan line that an error message quotes: a plan may
/// be a single line of megabytes, and echoing it whole (with as many
/// carets under it) would flood the terminal and any log.
pub const ECHO_CHARS: usize = 120;

/// Most characters of an error message, a key path or a hint: they may
/// quote a value of the file (a string of megabytes where a number belongs).
pub const MESSAGE_CHARS: usize = 400;

/// `s` cut to its first `max` characters, with `...` where it was cut.
pub fn clip(s: &str, max: usize) -> std::borrow::Cow<'_, str> {
    match s.char_indices().nth(max) {
        None => s.into(),
        Some((end, _)) => format!("{}...", &s[..end]).into(),
    }
}

/// A TOML syntax or type error of `text` as toml prints it (position, the
/// line with carets under the error, the message), but with the line cut to
/// [`ECHO_CHARS`] around the error column and each message line to
/// [`MESSAGE_CHARS`].
pub fn syntax_message(text: &str, e: &toml::de::Error) -> String {
    let clip_lines = |m: &str| {
        let lines: Vec<String> = m
            .trim_end()
            .lines()
            .map(|l| clip(l, MESSAGE_CHARS).into_owned())
            .collect();
        lines.join("\n")
    };
    let Some(span) = e.span() else {
        // No position: toml's text names the key instead.
        return clip_lines(&e.to_string());
    };
    let message = clip_lines(e.message());
    let mut start = span.start.min(text.len());
    while !text.is_char_boundary(start) {
        start -= 1;
    }
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let line = text[line_start..line_end].trim_end_matches('\r');
    let line_no = text[..line_start].matches('\n').count() + 1;
    let column = text[line_start..start].chars().count();
    let width = line.chars().count();
    // The window of the line shown: all of it when it is short, else
    // ECHO_CHARS characters with the error column a third of the way in.
    let from = if width <= ECHO_CHARS {
        0
    } else {
        column
            .saturating_sub(ECHO_CHARS / 3)
            .min(width - ECHO_CHARS)
    };
    let to = (from + ECHO_CHARS).min(width);
    let shown: String = line.chars().skip(from).take(to - from).collect();
    let (before, after) = (
        if from > 0 { "..." } else { "" },
        if to < width { "..." } else { "" },
    );
    // Carets under the span, at least one (the span is empty at the end
    // of the file), none past the window.
    let span_chars = text
        .get(start..span.end.clamp(start, line_end))
        .map_or(1, |s| s.chars().count());
    let carets = span_chars.min(to.saturating_sub(column)).max(1);
    let pad = before.len() + column - from;
    let gutter = " ".repeat(line_no.to_string().len() + 1);
    format!(
        "TOML parse error at line {line_no}, column {}\n{gutter}|\n{line_no} | {before}{shown}{after}\n{gutter}|{} {}\n{message}{}",
        column + 1,
        " ".repeat(pad),
        "^".repeat(carets),
        quoted_number_hint(e.message(), line)
    )
}

/// A number written in quotes (`exposure-ms = "11.111"`) reads as text;
/// the hint shows the line without them.
fn quoted_number_hint(message: &str, line: &str) -> String {
    let quoted = message
        .strip_prefix("invalid type: string \"")
        .and_then(|rest| rest.split_once('"'))
        .map(|(value, _)| value);
    match quoted {
        Some(value) if value.trim().parse::<f64>().is_ok() => format!(
            "\n    hint: a number is written without quotes: {}",
            line.trim()
                .replacen(&format!("\"{value}\""), value.trim(), 1)
        ),
        _ => String::new(),
    }
}

/// A hint for an unknown key: the closest known key of its table, or the list.
pub fn unknown_key_hint(key: &str) -> String {
    let (table, leaf) = match key.rfind('.') {
        Some(i) => (&key[..i], &key[i + 1..]),
        None => ("", key),
    };
    // `roi[3]` -> `roi`; a profile's `camera.x` is `dut.camera.x`.
    let mut table_name = strip_indices(table);
    if table_name == "camera" || table_name.starts_with("camera.") {
        table_name = format!("dut.{table_name}");
    }
    let Some((_, known)) = KNOWN_KEYS.iter().find(|(t, _)| *t == table_name) else {
        return "remove it; see docs/plan-format.md for the plan format".to_string();
    };
    // Known keys are at most 30 characters: a longer leaf is nothing like
    // any of them, and its edit distance would take time in its length.
    let best = known
        .iter()
        .filter(|_| leaf.len() <= 64)
        .map(|k| (edit_distance(leaf, k), *k))
        .min()
        .filter(|(d, k)| *d <= 3.max(k.len() / 3));
    let section = if table_name.is_empty() {
        "the top level".to_string()
    } else {
        format!("[{table_name}]")
    };
    match best {
        Some((_, k)) => format!("did you mean `{k}`? {section} takes: {}", known.join(", ")),
        None => format!("{section} takes: {}", known.join(", ")),
    }
}

fn strip_indices(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    let mut depth = 0;
    for c in path.chars() {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            _ if depth == 0 => out.push(c),
            _ => {}
        }
    }
    out
}

/// Levenshtein distance, for short key names.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, &cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The keys (as the diagnostics name them: `a.b`, `a[0].b`) of every
/// string under `v` that holds a NUL.
pub(super) fn nul_strings(key: &str, v: &toml::Value, out: &mut Vec<String>) {
    match v {
        toml::Value::String(s) if s.contains('\0') => out.push(key.to_string()),
        toml::Value::Table(t) => {
            for (k, x) in t {
                let key = if key.is_empty() {
                    k.clone()
                } else {
                    format!("{key}.{k}")
                };
                nul_strings(&key, x, out);
            }
        }
        toml::Value::Array(items) => {
            for (i, x) in items.iter().enumerate() {
                nul_strings(&format!("{key}[{i}]"), x, out);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locations_are_one_based_and_reach_array_tables() {
        let text = "[plan]\nid = \"x\"\n\n[[roi]]\nname = \"a\"\n[[roi]]\nx-px = 5\n";
        let index = SpanIndex::build(text).unwrap();
        assert_eq!(index.location("plan.id"), Some((2, 1)));
        assert_eq!(index.location("roi[1].x-px"), Some((7, 1)));
        assert_eq!(index.location("nope"), None);
    }

    #[test]
    fn a_quoted_number_is_shown_without_its_quotes() {
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Camera {
            #[serde(rename = "exposure-ms")]
            exposure_ms: f64,
        }
        let text = "exposure-ms = \"11.111\"\n";
        let e = toml::from_str::<Camera>(text).unwrap_err();
        let m = syntax_message(text, &e);
        assert!(
            m.ends_with("hint: a number is written without quotes: exposure-ms = 11.111"),
            "{m}"
        );
        // Text that is no number gets no such hint.
        let text = "exposure-ms = \"long\"\n";
        let m = syntax_message(text, &toml::from_str::<Camera>(text).unwrap_err());
        assert!(!m.contains("hint"), "{m}");
    }

    #[test]
    fn unknown_key_hint_suggests_the_nearest_key() {
        let hint = unknown_key_hint("dut.camera.exposure-us");
        assert!(hint.starts_with("did you mean `exposure-ms`?"), "{hint}");
        let hint = unknown_key_hint("roi[2].widht-px");
        assert!(hint.starts_with("did you mean `width-px`?"), "{hint}");
    }
}
