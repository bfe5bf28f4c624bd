//! A case that a report does not list, as results.json holds it: one
//! summary row (conditions, verdict, each ROI's metrics and the checks),
//! with the rest of its record in the report's case store. A sweep of
//! thousands of cases then writes what its reader uses (the every-case
//! figures: counts, matrices, summary.csv) and not the analyses of cases
//! nobody opens; `ledflicker export` writes a row's trace and frames from
//! the store (docs/report.md, "Large runs").
//!
//! A row read back becomes a [`CaseInfo`] whose figures are the row's and
//! whose analyses are empty, so that every reader of results.json reads
//! both kinds of entry with one type; [`Cases::is_detailed`](super::Cases::is_detailed)
//! tells them apart.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{
    Beat, CaseInfo, Check, DriveFlicker, HazardClass, Levels, RoiAnalysis, RoiInfo, RoiKind,
    Verdict, positive_or_null, zero_if_null,
};
use crate::analysis::PhaseCoverage;
use crate::analysis::apparent::{ApparentMethod, SpectrumError};
use crate::analysis::drive::Ieee1789Region;

/// The value of a row's `full_record` key: where the rest of the case is.
pub const FULL_RECORD: &str = "cases.sqlite";

/// A summary row as written.
#[derive(Serialize)]
struct RowOut<'a> {
    id: &'a str,
    #[serde(serialize_with = "positive_or_null")]
    light_lux: f64,
    #[serde(serialize_with = "positive_or_null")]
    frequency_hz: f64,
    #[serde(serialize_with = "positive_or_null")]
    duty: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    source: Option<&'a String>,
    seed: u64,
    verdict: Verdict,
    not_judged: Option<&'a String>,
    not_checked: &'a [String],
    in_mitigation_range: bool,
    frames: usize,
    apparent_frequency_hz: f64,
    hazard_class: HazardClass,
    rois: Vec<RoiRowOut<'a>>,
    checks: &'a [Check],
    full_record: &'static str,
}

#[derive(Serialize)]
struct RoiRowOut<'a> {
    name: &'a str,
    kind: RoiKind,
    metrics: &'a BTreeMap<String, Option<f64>>,
    reasons: BTreeMap<&'a str, &'a str>,
    saturated: bool,
    contrast_unbounded: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    signal_colour: Option<&'a String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    delta_uv_reference: Option<&'a String>,
}

/// A summary row as read back.
#[derive(Deserialize)]
pub(super) struct RowIn {
    id: String,
    #[serde(deserialize_with = "zero_if_null")]
    light_lux: f64,
    #[serde(deserialize_with = "zero_if_null")]
    frequency_hz: f64,
    #[serde(deserialize_with = "zero_if_null")]
    duty: f64,
    #[serde(default)]
    source: Option<String>,
    seed: u64,
    verdict: Verdict,
    not_judged: Option<String>,
    not_checked: Vec<String>,
    in_mitigation_range: bool,
    frames: usize,
    apparent_frequency_hz: f64,
    hazard_class: HazardClass,
    rois: Vec<RoiRowIn>,
    checks: Vec<Check>,
    // Required: it is what tells a row from a full case.
    #[allow(dead_code)]
    full_record: String,
}

#[derive(Deserialize)]
struct RoiRowIn {
    name: String,
    kind: RoiKind,
    metrics: BTreeMap<String, Option<f64>>,
    reasons: BTreeMap<String, String>,
    saturated: bool,
    contrast_unbounded: bool,
    #[serde(default)]
    signal_colour: Option<String>,
    #[serde(default)]
    delta_uv_reference: Option<String>,
}

/// One entry of results.json's `cases`: a summary row (it has
/// `full_record`, which no whole case has) or a whole case.
pub(super) enum Entry {
    Row(Box<RowIn>),
    Full(Box<CaseInfo>),
}

/// Serialises `c` as its summary row.
pub(super) fn serialize_row<S: serde::Serializer>(c: &CaseInfo, s: S) -> Result<S::Ok, S::Error> {
    RowOut {
        id: &c.id,
        light_lux: c.light_lux,
        frequency_hz: c.frequency_hz,
        duty: c.duty,
        source: c.source.as_ref(),
        seed: c.seed,
        verdict: c.verdict,
        not_judged: c.not_judged.as_ref(),
        not_checked: &c.not_checked,
        in_mitigation_range: c.in_mitigation_range,
        frames: c.frames,
        apparent_frequency_hz: c.apparent_frequency_hz,
        hazard_class: c.hazard_class,
        rois: c
            .rois
            .iter()
            .map(|r| RoiRowOut {
                name: &r.name,
                kind: r.kind,
                metrics: &r.metrics,
                // Why a metric is null; a defined metric's caveat (its
                // phase coverage, a sentence of hundreds of characters
                // per case) is for the cases a reader opens.
                reasons: r
                    .reasons
                    .iter()
                    .filter(|(k, _)| r.metrics.get(*k).is_none_or(Option::is_none))
                    .map(|(k, v)| (k.as_str(), v.as_str()))
                    .collect(),
                saturated: r.saturated,
                contrast_unbounded: r.contrast_unbounded,
                signal_colour: r.signal_colour.as_ref(),
                delta_uv_reference: r.delta_uv_reference.as_ref(),
            })
            .collect(),
        checks: &c.checks,
        full_record: FULL_RECORD,
    }
    .serialize(s)
}

impl RowIn {
    /// The case the row stands for: its own figures, and analyses that
    /// say nothing (no levels, no trace, no frame), which only the pages
    /// and charts of a listed case read.
    pub(super) fn into_case(self) -> CaseInfo {
        let r = self;
        let rois = r
            .rois
            .into_iter()
            .map(|roi| {
                let spectrum = roi
                    .metrics
                    .get("apparent_frequency_spectrum_hz")
                    .copied()
                    .flatten();
                let coverage = roi.metrics.get("phase_coverage").copied().flatten();
                RoiInfo {
                    analysis: RoiAnalysis {
                        apparent_frequency_spectrum_hz: spectrum,
                        spectrum_reason: roi.reasons.get("apparent_frequency_spectrum_hz").cloned(),
                        apparent_frequency_hz: r.apparent_frequency_hz,
                        apparent_method: ApparentMethod::FrameTimes,
                        hazard_class: r.hazard_class,
                        hazard_matches: Vec::new(),
                        phase_coverage: PhaseCoverage {
                            bins: 0,
                            covered_bins: 0,
                            coverage: coverage.unwrap_or(0.0),
                            capture_s: 0.0,
                            needed_capture_s: None,
                            worst_case_seen: None,
                            warning: roi.reasons.get("phase_coverage").cloned(),
                        },
                        folded_bins: Vec::new(),
                        envelope: None,
                        spectrum: Err(SpectrumError::TooShort(0)),
                    },
                    name: roi.name,
                    kind: roi.kind,
                    metrics: roi.metrics,
                    reasons: roi.reasons,
                    levels: Levels {
                        off: None,
                        on: None,
                        min: 0.0,
                        max: 0.0,
                        mean: 0.0,
                    },
                    saturated: roi.saturated,
                    contrast_unbounded: roi.contrast_unbounded,
                    signal_colour: roi.signal_colour,
                    delta_uv_reference: roi.delta_uv_reference,
                }
            })
            .collect();
        CaseInfo {
            id: r.id,
            light_lux: r.light_lux,
            frequency_hz: r.frequency_hz,
            duty: r.duty,
            source: r.source,
            capture: None,
            seed: r.seed,
            verdict: r.verdict,
            not_judged: r.not_judged,
            not_checked: r.not_checked,
            acquisition: String::new(),
            in_mitigation_range: r.in_mitigation_range,
            frames: r.frames,
            trace: String::new(),
            sample_frame: None,
            rois,
            checks: r.checks,
            apparent_frequency_hz: r.apparent_frequency_hz,
            hazard_class: r.hazard_class,
            beat: Beat {
                apparent_frequency_hz: r.apparent_frequency_hz,
                method: ApparentMethod::FrameTimes,
                frame_rate_fps: 0.0,
                resolution_hz: None,
                period_s: None,
                capture_s: 0.0,
                longer_than_capture: false,
                note: String::new(),
            },
            drive: DriveFlicker {
                percent_flicker: 0.0,
                flicker_index: 0.0,
                ieee1789_low_risk_max_percent: None,
                ieee1789_noel_max_percent: None,
                ieee1789_region: Ieee1789Region::NoObservableEffect,
                svm: None,
            },
            banding: None,
            frame_timing: None,
            worst_phase: None,
        }
    }
}
