//! The values the HTML and the PDF template are rendered with, built once
//! for both. They differ only in how a picture goes in: the HTML inlines
//! it (an SVG as markup, a PNG as a data URI), the PDF names its path in
//! the document's world; `picture` makes that choice for every chart and
//! image, and `look` is the report profile's look with the logo made the
//! same way.

use std::collections::BTreeMap;

use minijinja::value::{Serde, Value};

use super::ReportError;
use super::document::{
    ADVICE_CHART, Document, finemap_chart_path, fold_chart_prefix, frame_image_path,
    matrix_chart_path, trace_chart_path, visibility_matrix_chart_path, worst_phase_chart_path,
    worst_phase_image_path, zoom_chart_path,
};

/// The template context of `doc`: results.json as the templates see it
/// (`r`), every picture by case, and the report's tables and notes.
pub(crate) fn shared(
    doc: &Document,
    picture: &dyn Fn(&str) -> Value,
    look: Value,
) -> Result<Value, ReportError> {
    let has = |path: &str| doc.charts.contains_key(path) || doc.images.contains_key(path);
    // One map per kind of picture, by case id, of the cases that have one.
    let by_case = |path_of: &dyn Fn(&str) -> String| -> BTreeMap<String, Value> {
        doc.case_ids()
            .into_iter()
            .filter_map(|case| {
                let path = path_of(&case);
                has(&path).then(|| (case, picture(&path)))
            })
            .collect()
    };
    // The flicker signal folded by phase, one chart per LED ROI.
    let folds: BTreeMap<String, Vec<Value>> = doc
        .case_ids()
        .into_iter()
        .map(|case| {
            let prefix = fold_chart_prefix(&case);
            let charts = doc
                .charts
                .range(prefix.clone()..)
                .take_while(|(path, _)| path.starts_with(&prefix))
                .map(|(path, _)| picture(path))
                .collect();
            (case, charts)
        })
        .collect();
    let finemaps: Vec<Value> = (0..)
        .map_while(|i| {
            let fdi = finemap_chart_path(i, "fdi");
            let pf = finemap_chart_path(i, "pf");
            (has(&fdi) && has(&pf)).then(|| {
                minijinja::context! { fdi => picture(&fdi), pf => picture(&pf) }
            })
        })
        .collect();
    // The u'v' diagrams of the driver section, by path.
    let uv_charts: BTreeMap<String, Value> = doc
        .charts
        .range("charts/uv-".to_string()..)
        .take_while(|(path, _)| path.starts_with("charts/uv-"))
        .map(|(path, _)| (path.clone(), picture(path)))
        .collect();
    let advice_chart = if has(ADVICE_CHART) {
        picture(ADVICE_CHART)
    } else {
        Value::from(())
    };
    let listing = doc.listing();
    Ok(minijinja::context! {
        r => Serde(&doc.json()?),
        charts => by_case(&|c| trace_chart_path(c)),
        zooms => by_case(&|c| zoom_chart_path(c)),
        frames => by_case(&|c| frame_image_path(c)),
        worst_charts => by_case(&|c| worst_phase_chart_path(c)),
        worst_frames => by_case(&|c| worst_phase_image_path(c)),
        folds => folds,
        finemaps => finemaps,
        advice_chart => advice_chart,
        matrices => matrices(doc, picture),
        driver => Serde(doc.driver()),
        uv_charts => uv_charts,
        roi_maps => roi_maps(doc, picture),
        signatories => Serde(&doc.signatories),
        pages => listing.pages.clone(),
        listed => listed_ids(&listing),
        unlisted => listing.unlisted,
        pages_omitted => listing.pages_omitted,
        listed_max => crate::model::listing::LISTED_CASES_MAX,
        info_rows => Serde(doc.info_rows()),
        glossary => Serde(doc.glossary()),
        caveats => doc.caveats(),
        fold_notes => doc.fold_notes(),
        common => Serde(doc.common_notes()),
        frame_key => doc.frame_key(),
        frame_captions => doc.frame_captions(false),
        worst_captions => doc.frame_captions(true),
        limit_tables => Serde(doc.limit_tables()),
        detail => doc.detail().as_str(),
        draft => doc.is_draft(),
        date => doc.date(),
        look => look,
    })
}

/// Per light level ([`crate::model::Results::light_levels`]; the matrix of
/// the `i`-th is [`matrix_chart_path`]`(i)`): `{lux, chart}`, where `chart`
/// is what `chart_for` makes of the matrix's chart path (missing charts are
/// skipped).
fn matrices(doc: &Document, chart_for: impl Fn(&str) -> Value) -> Vec<Value> {
    doc.results
        .light_levels()
        .into_iter()
        .enumerate()
        .flat_map(|(i, lux)| {
            // A plan with `[display]` has a visibility matrix after each
            // level's verdict matrix.
            [matrix_chart_path(i), visibility_matrix_chart_path(i)]
                .into_iter()
                .filter(|path| doc.charts.contains_key(path))
                .map(|path| minijinja::context! { lux => lux, chart => chart_for(&path) })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The ROI maps ([`super::document::roi_map_chart_path`]), in case order:
/// `{case, frame, which, chart}`, where `chart` is what `chart_for` makes
/// of the map's chart path, `frame` the frame number shown and `which`
/// says which frame of the case it is.
fn roi_maps(doc: &Document, chart_for: impl Fn(&str) -> Value) -> Vec<Value> {
    use crate::model::Segment;
    let captured = doc.results.method.backend == crate::model::BackendName::Captured;
    // The mapped cases are among those the model keeps in memory.
    doc.results
        .cases
        .resident()
        .filter_map(|c| {
            let path = super::document::roi_map_chart_path(&c.id);
            // A capture's map shows its lit frame, as the chart's job
            // ([`super::document::ChartJobs`]) draws it.
            let lit = c
                .capture
                .as_ref()
                .and_then(|s| s.lit_frame)
                .filter(|_| captured);
            let (frame, which) = match lit {
                Some(l) if l.segment == Segment::On => (
                    Some(l.frame),
                    "its ON-segment frame of highest LED-ROI luma",
                ),
                Some(l) => (Some(l.frame), "its PWM frame of highest LED-ROI luma"),
                None => (
                    c.sample_frame.as_ref().map(|f| f.frame),
                    "its PWM frame of lowest LED-ROI luma",
                ),
            };
            doc.charts.contains_key(&path).then(|| {
                minijinja::context! {
                    case => c.id.clone(),
                    frame => frame,
                    which => which,
                    chart => chart_for(&path),
                }
            })
        })
        .collect()
}

/// The listed cases' ids as a map to `true`, for the templates' `c.id in
/// listed` (a key lookup, where a list would be searched).
fn listed_ids(listing: &crate::model::listing::Listing) -> BTreeMap<String, bool> {
    listing.listed.iter().map(|id| (id.clone(), true)).collect()
}
