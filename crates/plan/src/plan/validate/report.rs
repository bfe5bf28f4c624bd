//! `[report]`: the report's look (docs/plan-format.md, "Report profile").
//! The files it names (logo, template folder) are resolved relative to
//! the file that names them and read here.

use std::collections::BTreeMap;
use std::path::Path;

use crate::plan::check::Checker;
use crate::plan::profile::{
    LABELS, Logo, REQUIRED_SECTIONS, ReportProfile, SECTIONS, TEMPLATE_NAMES, TemplateOverrides,
};
use crate::plan::raw::RawReport;

/// Longest logo file read, in bytes: a logo is a small picture, and the
/// report embeds it in every output.
const MAX_LOGO_BYTES: u64 = 4 << 20;

/// Validates a `[report]` table of the file at `file` (a plan or a
/// report profile); `None` when a key is invalid.
pub(crate) fn report_table(
    c: &mut Checker<'_>,
    raw: Option<RawReport>,
    file: &Path,
) -> Option<ReportProfile> {
    let Some(r) = raw else {
        return Some(ReportProfile::default());
    };
    let base = file.parent().unwrap_or(Path::new("."));
    let mut ok = true;
    let mut text = |value: Option<String>, key: &str, ok: &mut bool| {
        let v = value?;
        if v.trim().is_empty() {
            c.error(key, "is empty", Some("leave the key out for the default"));
            *ok = false;
            return None;
        }
        Some(v)
    };
    let company = text(r.company, "report.company", &mut ok);
    let document_number = text(r.document_number, "report.document-number", &mut ok);
    let mut labels = BTreeMap::new();
    for (key, value) in r.labels.unwrap_or_default() {
        let at = format!("report.labels.{key}");
        if !LABELS.contains(&key.as_str()) {
            c.error(
                &at,
                format!("unknown label `{key}`"),
                Some(&format!("labels: {}", LABELS.join(", "))),
            );
            ok = false;
        } else if value.trim().is_empty() {
            c.error(&at, "is empty", Some("leave the label out for the default"));
            ok = false;
        } else {
            labels.insert(key, value);
        }
    }
    let sections = r.sections.and_then(|s| {
        let checked = sections(c, s);
        ok &= checked.is_some();
        checked
    });
    let logo = r.logo.and_then(|name| {
        let logo = logo(c, &name, base);
        ok &= logo.is_some();
        logo
    });
    let templates = r.templates.and_then(|name| {
        let t = templates(c, &name, base);
        ok &= t.is_some();
        t
    });
    ok.then_some(ReportProfile {
        company,
        document_number,
        logo,
        labels,
        sections,
        templates,
    })
}

fn sections(c: &mut Checker<'_>, names: Vec<String>) -> Option<Vec<String>> {
    let mut ok = true;
    for (i, name) in names.iter().enumerate() {
        let key = format!("report.sections[{i}]");
        if !SECTIONS.contains(&name.as_str()) {
            c.error(
                &key,
                format!("unknown section `{name}`"),
                Some(&format!("sections: {}", SECTIONS.join(", "))),
            );
            ok = false;
        } else if names[..i].contains(name) {
            c.error(&key, format!("section `{name}` is listed twice"), None);
            ok = false;
        }
    }
    for required in REQUIRED_SECTIONS {
        if !names.iter().any(|n| n == required) {
            c.error(
                "report.sections",
                format!("lacks `{required}`"),
                Some("a report always has its executive summary and its sign-off: list \"summary\" and \"signoff\""),
            );
            ok = false;
        }
    }
    // Shown in the report's own order, whatever the order listed.
    ok.then(|| {
        SECTIONS
            .iter()
            .filter(|s| names.iter().any(|n| n == *s))
            .map(|s| s.to_string())
            .collect()
    })
}

fn logo(c: &mut Checker<'_>, name: &str, base: &Path) -> Option<Logo> {
    let key = "report.logo";
    let path = base.join(name);
    let hint = "a PNG or SVG file, relative to the file that names it";
    let format = match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") => "png",
        Some(e) if e.eq_ignore_ascii_case("svg") => "svg",
        _ => {
            c.error(
                key,
                format!("logo `{}` is not a .png or .svg file", path.display()),
                Some(hint),
            );
            return None;
        }
    };
    let size = std::fs::metadata(&path).map(|m| m.len());
    if let Ok(size) = size
        && size > MAX_LOGO_BYTES
    {
        c.error(
            key,
            format!("logo `{}` is {size} bytes, more than 4 MiB", path.display()),
            Some("a logo is embedded in every output: use a smaller picture"),
        );
        return None;
    }
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            c.error(
                key,
                format!("cannot read logo `{}`: {e}", path.display()),
                Some(hint),
            );
            return None;
        }
    };
    let looks_right = match format {
        "png" => bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
        _ => std::str::from_utf8(&bytes).is_ok_and(|t| t.contains("<svg")),
    };
    if !looks_right {
        c.error(
            key,
            format!(
                "logo `{}` is not a {} picture",
                path.display(),
                format.to_uppercase()
            ),
            Some(hint),
        );
        return None;
    }
    Some(Logo {
        path,
        format,
        bytes,
    })
}

fn templates(c: &mut Checker<'_>, name: &str, base: &Path) -> Option<TemplateOverrides> {
    let key = "report.templates";
    let dir = base.join(name);
    if !dir.is_dir() {
        c.error(
            key,
            format!("template folder `{}` does not exist", dir.display()),
            Some("a folder, relative to the file that names it, holding base.html.j2, report.html.j2 or report.typ.j2"),
        );
        return None;
    }
    let mut sources = BTreeMap::new();
    for template in TEMPLATE_NAMES {
        let path = dir.join(template);
        if !path.exists() {
            continue;
        }
        match std::fs::read_to_string(&path) {
            Ok(text) => {
                sources.insert(template.to_string(), text);
            }
            Err(e) => {
                c.error(
                    key,
                    format!("cannot read template `{}`: {e}", path.display()),
                    None,
                );
                return None;
            }
        }
    }
    if sources.is_empty() {
        c.error(
            key,
            format!(
                "template folder `{}` holds no template of the report",
                dir.display()
            ),
            Some(&format!(
                "a file named {} replaces the built-in one",
                TEMPLATE_NAMES.join(", ")
            )),
        );
        return None;
    }
    Some(TemplateOverrides { dir, sources })
}
