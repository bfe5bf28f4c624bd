//! HTML report: results model + charts -> minijinja templates in templates/.
//!
//! The templates are compiled into the binary, so a report needs nothing at
//! run time. The page is self-contained: CSS inline, charts as inline SVG.

use std::collections::BTreeMap;

use minijinja::value::{Serde, Value};
use minijinja::{Environment, UndefinedBehavior};

use super::ReportError;
use super::charts;
use super::model::Results;
use crate::runner::CaseResult;

const BASE: &str = include_str!("../../templates/base.html.j2");
const REPORT: &str = include_str!("../../templates/report.html.j2");

/// Formats an optional number with `digits` decimals; `None` -> "n/a".
fn num(value: Option<f64>, digits: Option<usize>) -> String {
    match value {
        Some(v) if v.is_finite() => crate::util::fixed(v, digits.unwrap_or(3)),
        Some(_) | None => "n/a".to_string(),
    }
}

fn environment() -> Result<Environment<'static>, ReportError> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    let add = |env: &mut Environment<'static>, name: &'static str, src: &'static str| {
        env.add_template(name, src)
            .map_err(|e| ReportError::Template {
                template: name.to_string(),
                message: format!("{e:#}"),
            })
    };
    add(&mut env, "base.html.j2", BASE)?;
    add(&mut env, "report.html.j2", REPORT)?;
    env.add_filter("num", |v: Serde<Option<f64>>, digits: Option<usize>| {
        num(v.0, digits)
    });
    Ok(env)
}

/// Renders report.html.
pub fn render(model: &Results, results: &[CaseResult], date: &str) -> Result<String, ReportError> {
    let env = environment()?;
    let mut charts = BTreeMap::new();
    let mut frames = BTreeMap::new();
    for r in results {
        charts.insert(
            r.case.id.clone(),
            Value::from_safe_string(charts::luma_trace_svg(r)?),
        );
        if let Some(frame) = &r.sample_frame {
            let png = super::frames::png_bytes(&super::frames::thumbnail(
                frame,
                super::frames::THUMBNAIL_WIDTH,
            ))?;
            frames.insert(
                r.case.id.clone(),
                Value::from_safe_string(format!(
                    "data:image/png;base64,{}",
                    super::frames::base64(&png)
                )),
            );
        }
    }
    let template = env
        .get_template("report.html.j2")
        .map_err(|e| ReportError::Template {
            template: "report.html.j2".to_string(),
            message: format!("{e:#}"),
        })?;
    template
        .render(minijinja::context! {
            r => Serde(model),
            charts => charts,
            frames => frames,
            date => date,
        })
        .map_err(|e| ReportError::Template {
            template: "report.html.j2".to_string(),
            message: format!("{e:#}"),
        })
}
