//! HTML report: a [`Document`] -> minijinja templates in templates/.
//!
//! The templates are compiled into the binary, so a report needs nothing at
//! run time. The page is self-contained: CSS inline, charts as inline SVG.

use minijinja::value::{Serde, Value};
use minijinja::{Environment, UndefinedBehavior};

use super::ReportError;
use super::document::Document;

const BASE: &str = include_str!("../../../templates/base.html.j2");
const REPORT: &str = include_str!("../../../templates/report.html.j2");

/// Formats an optional number with `digits` decimals; `None` -> "n/a".
pub(crate) fn num(value: Option<f64>, digits: Option<usize>) -> String {
    match value {
        Some(v) if v.is_finite() => crate::util::fixed(v, digits.unwrap_or(3)),
        Some(_) | None => "n/a".to_string(),
    }
}

/// `text` cut at its Markdown code spans: (is code, piece), in order,
/// without the backticks. The model's prose marks names of files, cameras
/// and commands with backticks (`hdr3-1080p30`); the reports set those
/// pieces as code, so no backtick reaches a reader. A backtick without a
/// partner is dropped.
pub(crate) fn code_spans(text: &str) -> Vec<(bool, &str)> {
    let pieces: Vec<&str> = text.split('`').collect();
    let paired = pieces.len() % 2 == 1;
    pieces
        .iter()
        .enumerate()
        // With an odd number of backticks the last one has no partner:
        // the text after it is prose.
        .map(|(i, p)| (i % 2 == 1 && (paired || i + 1 < pieces.len()), *p))
        .filter(|(_, p)| !p.is_empty())
        .collect()
}

/// Writes a value into the HTML: escaped, its code spans as `<code>`.
/// Values marked safe (the inline SVG charts) are written as they are.
fn format_value(
    out: &mut minijinja::Output<'_>,
    state: &mut minijinja::State<'_, '_>,
    value: &Value,
) -> Result<(), minijinja::Error> {
    match value.as_str() {
        Some(text) if !value.is_safe() && text.contains('`') => {
            for (code, piece) in code_spans(text) {
                if code {
                    out.write_str("<code>")?;
                }
                minijinja::escape_formatter(out, state, &Value::from(piece))?;
                if code {
                    out.write_str("</code>")?;
                }
            }
            Ok(())
        }
        _ => minijinja::escape_formatter(out, state, value),
    }
}

/// A template's error, naming the file of a replaced template (else the
/// built-in template's name) and the line.
pub(crate) fn template_error(
    e: &minijinja::Error,
    fallback: &str,
    look: &super::document::profile::Look,
) -> ReportError {
    let name = e.name().unwrap_or(fallback);
    // A replaced template's error is the user's: its file, line and
    // message; a built-in one's is ours, with minijinja's whole account.
    let (template, text) = match look.templates.get(name) {
        Some(t) => (t.path.display().to_string(), format!("{e}")),
        None => (name.to_string(), format!("{e:#}")),
    };
    let message = match e.line() {
        Some(line) => format!("line {line}: {text}"),
        None => text,
    };
    ReportError::Template { template, message }
}

/// The templates: the built-in ones, each replaced by the profile's
/// template of its name, if any.
pub(crate) fn add_templates(
    env: &mut Environment<'static>,
    built_in: &[(&'static str, &'static str)],
    look: &super::document::profile::Look,
) -> Result<(), ReportError> {
    for (name, src) in built_in {
        let added = match look.templates.get(*name) {
            Some(t) => env.add_template_owned(name.to_string(), t.text.clone()),
            None => env.add_template(name, src),
        };
        added.map_err(|e| template_error(&e, name, look))?;
    }
    Ok(())
}

fn environment(look: &super::document::profile::Look) -> Result<Environment<'static>, ReportError> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    add_templates(
        &mut env,
        &[("base.html.j2", BASE), ("report.html.j2", REPORT)],
        look,
    )?;
    env.add_filter("num", |v: Serde<Option<f64>>, digits: Option<usize>| {
        num(v.0, digits)
    });
    env.add_filter("metric", |id: &str| {
        crate::model::human_name(id).to_string()
    });
    env.add_filter("metric_short", |id: &str| {
        crate::model::short_name(id).to_string()
    });
    env.set_formatter(format_value);
    Ok(env)
}

/// Renders report.html for a run in memory (a draft: no signatories).
pub fn render(
    model: &crate::model::Results,
    results: &[crate::model::CaseResult],
    date: &str,
) -> Result<String, ReportError> {
    render_document(&Document::build(model, results, date, Vec::new())?)
}

/// Renders report.html from a [`Document`]: every picture inline, an SVG
/// as markup and a PNG as a data URI, so that the file stands alone.
pub fn render_document(doc: &Document) -> Result<String, ReportError> {
    let env = environment(&doc.look)?;
    let picture = |path: &str| {
        if let Some(svg) = doc.charts.get(path) {
            Value::from_safe_string(svg.clone())
        } else if let Some(png) = doc.images.get(path) {
            let uri = format!("data:image/png;base64,{}", super::frames::base64(png));
            Value::from_safe_string(uri)
        } else {
            Value::from(())
        }
    };
    let look = doc.look_context(|path, bytes| {
        let mime = if path.ends_with(".svg") {
            "image/svg+xml"
        } else {
            "image/png"
        };
        let uri = format!("data:{mime};base64,{}", super::frames::base64(bytes));
        Value::from_safe_string(uri)
    });
    let context = super::context::shared(doc, &picture, look)?;
    let error = |e: minijinja::Error| template_error(&e, "report.html.j2", &doc.look);
    let template = env.get_template("report.html.j2").map_err(error)?;
    template.render(context).map_err(error)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn code_spans_are_cut_at_backtick_pairs() {
        assert_eq!(
            code_spans("camera `hdr3` and `x`."),
            [
                (false, "camera "),
                (true, "hdr3"),
                (false, " and "),
                (true, "x"),
                (false, ".")
            ]
        );
        assert_eq!(code_spans("a ` b"), [(false, "a "), (false, " b")]);
        assert_eq!(code_spans("plain"), [(false, "plain")]);
    }

    #[test]
    fn prose_with_code_spans_shows_code_and_no_backtick() {
        let (results, mut model) = super::super::document::small_run();
        model
            .notes
            .push("capture `<x>.mp4` read with `ffmpeg`".to_string());
        let doc = Document::build(&model, &results, "2026-01-01", Vec::new()).unwrap();
        let html = render_document(&doc).unwrap();
        assert!(html.contains("capture <code>&lt;x&gt;.mp4</code> read with <code>ffmpeg</code>"));
        let note = html.split("id=\"notes\"").nth(1).unwrap();
        let note = note.split("id=\"environment\"").next().unwrap();
        assert!(!note.contains('`'), "{note}");
    }
}
