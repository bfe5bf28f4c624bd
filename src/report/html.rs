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
    // The flicker signal folded by phase, one chart per LED ROI.
    let mut folds: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    for c in &model.cases {
        let svgs = c
            .rois
            .iter()
            .filter(|roi| roi.kind == crate::plan::RoiKind::Led)
            .map(|roi| {
                charts::phase_fold_svg(
                    &format!("{}: {}", c.id, roi.name),
                    &roi.analysis.folded_bins,
                    roi.analysis.envelope,
                )
                .map(Value::from_safe_string)
            })
            .collect::<Result<Vec<_>, _>>()?;
        folds.insert(c.id.clone(), svgs);
    }
    let mut finemaps = Vec::new();
    for m in &model.fine_maps {
        let t = model.thresholds.fdi_2018_min;
        finemaps.push(minijinja::context! {
            fdi => Value::from_safe_string(charts::finemap_svg(&m.map, charts::FineMapKind::Fdi, t)?),
            pf => Value::from_safe_string(charts::finemap_svg(&m.map, charts::FineMapKind::PercentFlicker, t)?),
        });
    }
    let advice_chart = match &model.advice {
        Some(a) => Value::from_safe_string(charts::advise_svg(&a.curve, a.advice.min_exposure_s)?),
        None => Value::from(()),
    };
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
            folds => folds,
            finemaps => finemaps,
            advice_chart => advice_chart,
            date => date,
        })
        .map_err(|e| ReportError::Template {
            template: "report.html.j2".to_string(),
            message: format!("{e:#}"),
        })
}
