//! The results model: every struct of results.json, typed both ways
//! (written with serde, read back with serde), and the analysis stage that
//! fills it from the run's case results ([`assemble`]). The report renders
//! this model and imports nothing else of the pipeline; the types it shows
//! from lower modules are re-exported here (docs/architecture.md).
//!
//! Contract `ledflicker.results/5` (see docs/changes.md; fields may be added,
//! never renamed):
//! `schema`, `plan {id, title, path, sha256}`, `verdict`, and `cases[]` with
//! `id, light_lux, frequency_hz, duty, verdict` and
//! `rois[] {name, metrics {fdi_2018, percent_flicker, ...}}`. A metric that
//! cannot be defined is `null` in `metrics`, with its reason under the same
//! name in `reasons`.
//!
//! Beyond the paper (docs/beyond-the-paper.md): per case `apparent_frequency_hz`,
//! `hazard_class`, `beat`, `drive` (IEEE 1789, IES Flicker Index) and
//! `banding`; per ROI the metrics `apparent_frequency_spectrum_hz` and
//! `phase_coverage` and an `analysis` object; at the top `fine_maps` and
//! `advice`.
//!
//! `conditions` holds the conditions the report states (sequence as used,
//! frame rate, exposure, light levels, PWM grid and clock, scene, ROIs),
//! each computed from what was run ([`conditions`]).
//!
//! A captured or rig case also has `frame_timing` (the rate fitted to its
//! frame times, its uncertainty, the times' resolution, the stated rate
//! and the drops), and its `capture` the container's `time_base_s` and
//! `stated_frame_rate_fps`.

pub mod cases;
pub mod conditions;
pub mod evidence;
pub mod frame;
pub mod limits;
pub mod listing;
pub mod method;
pub mod plane;
pub mod row;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

pub use crate::advise::{Advice, Candidate};
pub use crate::analysis::finemap::FineMap;
pub use crate::analysis::{
    Banding, Beat, DriveFlicker, FineMapInfo, FrameBanding, FrameTiming, HazardClass, RoiAnalysis,
};
pub use crate::cases::{CaseReadError, CaseResult, CaseSource, for_each_chunk};
pub use crate::inputs::InputFile;
pub use crate::metrics::chromaticity::{ColourFigures, SPECTRUM_LOCUS, SignalColour, uv_of_xy};
pub use crate::metrics::verdict::{Comparison, VERDICT_TOLERANCE};
pub use crate::metrics::{
    Check, GLOSSARY, Levels, Metric, MetricName, VISIBILITY_GLOSSARY, Verdict, human_name,
    short_name,
};
pub use crate::plan::profile::{LABELS, Logo, ReportProfile, SECTIONS, TemplateOverrides};
pub use crate::plan::{RoiKind, Thresholds, VerdictBasis};
pub use crate::trace::{
    Acquisition, CaptureSummary, DetectionRule, FrameInfo, RenderedFrame, Run, Segment,
    SegmentMethod, SegmentsFound, StepKind, StepSource, TRACE_COLUMNS, TimestampSource,
};

pub use cases::{Cases, CasesBuilder, MapChoice};

/// Schema id of results.json.
pub const RESULTS_SCHEMA: &str = "ledflicker.results/5";

/// Top of results.json.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Results {
    /// Always [`RESULTS_SCHEMA`].
    pub schema: String,
    /// Tool that made it.
    pub tool: Tool,
    /// The plan.
    pub plan: PlanInfo,
    /// Device under test and backend.
    pub dut: DutInfo,
    /// The light sequence of the plan (`[sequence]`); what was run is in
    /// `conditions.sequence`.
    pub sequence: SequenceInfo,
    /// The conditions the report states, each from what was run.
    pub conditions: conditions::Conditions,
    /// Pass criteria; `basis` is the one actually used (as captured for
    /// captures and rigs).
    pub thresholds: Thresholds,
    /// How the frames were acquired and which verdict basis was used.
    pub method: method::Method,
    /// IEEE P2020 KPI settings (`[p2020]`).
    pub p2020: crate::metrics::p2020::P2020Options,
    /// The CMS monitor the visibility of each ROI is computed for
    /// (`[display]`); absent when the plan has none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub display: Option<crate::plan::display::Display>,
    /// Overall verdict: fail if any case failed, else pass if any case was
    /// judged, else info (no case judged: never pass).
    pub verdict: Verdict,
    /// Number of cases per verdict.
    pub counts: Counts,
    /// Every case, in plan order (a large run's spilled to disk:
    /// [`cases`]).
    pub cases: Cases,
    /// Worst-phase FDI and Percent Flicker over the frequency x duty plane,
    /// one per light level, for the plan's camera and first LED ROI.
    pub fine_maps: Vec<FineMapInfo>,
    /// Why there are no fine maps, when there are none.
    pub fine_maps_note: Option<String>,
    /// `ledflicker advise` for the plan's frequencies in the mitigation range
    /// and its duty cycles; `null` when every duty is 100 %.
    pub advice: Option<PlanAdvice>,
    /// Date and input files; set when the report is written, absent in
    /// models built in memory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<ReportMeta>,
    /// Deviations from the method of Deegan 2018 and notes a reader of the
    /// report must see, one sentence each ([`method::notes`], filled by
    /// [`assemble`]). results.json holds them as `report.notes`, written
    /// with the report, so they are not serialised here: a model read back
    /// is empty here and has them in `report.notes`.
    #[serde(skip)]
    pub notes: Vec<String>,
}

impl Results {
    /// A copy of everything but the cases (left empty): the frame of a
    /// large run's model, without the memory of its every case.
    pub fn without_cases(&self) -> Results {
        // Named field by field, so that a field added to the model cannot
        // be left out of the copy.
        let Results {
            schema,
            tool,
            plan,
            dut,
            sequence,
            conditions,
            thresholds,
            method,
            p2020,
            display,
            verdict,
            counts,
            cases: _,
            fine_maps,
            fine_maps_note,
            advice,
            report,
            notes,
        } = self;
        Results {
            schema: schema.clone(),
            tool: tool.clone(),
            plan: plan.clone(),
            dut: dut.clone(),
            sequence: sequence.clone(),
            conditions: conditions.clone(),
            thresholds: thresholds.clone(),
            method: method.clone(),
            p2020: *p2020,
            display: *display,
            verdict: *verdict,
            counts: counts.clone(),
            cases: Cases::default(),
            fine_maps: fine_maps.clone(),
            fine_maps_note: fine_maps_note.clone(),
            advice: advice.clone(),
            report: report.clone(),
            notes: notes.clone(),
        }
    }
}

/// Exposure advice for a plan's range.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlanAdvice {
    /// The request's ranges and grid.
    pub frequency_hz: (f64, f64),
    /// Duty range.
    pub duty: (f64, f64),
    /// The advice.
    pub advice: crate::advise::Advice,
    /// Residual against exposure, for the chart (not serialised).
    #[serde(skip)]
    pub curve: Vec<crate::advise::Candidate>,
}

/// Tool name and version.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Tool {
    /// "ledflicker".
    pub name: String,
    /// Crate version.
    pub version: String,
}

/// Plan identity.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlanInfo {
    /// Plan id.
    pub id: String,
    /// Title.
    pub title: String,
    /// Path as given on the command line.
    pub path: String,
    /// SHA-256 of the plan file.
    pub sha256: String,
    /// Standard followed.
    pub standard: String,
    /// Description.
    pub description: String,
    /// Test lab.
    pub lab: String,
    /// Random seed.
    pub seed: u64,
}

/// Device under test.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DutInfo {
    /// Backend id, e.g. "sim-ideal".
    pub backend: String,
    /// Supplier.
    pub supplier: String,
    /// Model.
    pub model: String,
    /// Serial number.
    pub serial: String,
    /// Firmware.
    pub firmware: String,
    /// Simulated camera, when the backend is the simulator.
    pub camera: Option<CameraInfo>,
}

crate::trace::words! {
    /// A simulated camera's shutter.
    ShutterName {
        /// Every row exposed at once.
        Global = "global",
        /// Row `r` starts `r` line times after row 0.
        Rolling = "rolling",
    }
}

crate::trace::words! {
    /// Where a run's frames came from.
    BackendName {
        /// The built-in simulator.
        Simulator = "simulator",
        /// Captured files.
        Captured = "captured",
        /// A lab rig's command.
        Command = "command",
    }
}

/// The simulated camera, in the plan's units.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CameraInfo {
    /// "global" or "rolling".
    pub shutter: ShutterName,
    /// Sensor rows.
    pub sensor_rows: u32,
    /// Sensor columns.
    pub sensor_columns: u32,
    /// Line time, microseconds.
    pub line_time_us: f64,
    /// Exposure, milliseconds.
    pub exposure_ms: f64,
    /// Frame rate.
    pub frame_rate_fps: f64,
    /// First PWM rising edge after frame 0 starts, milliseconds.
    pub pwm_delay_ms: f64,
}

/// Sequence durations and frame counts.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SequenceInfo {
    /// Steady ON, seconds.
    pub on_s: f64,
    /// OFF, seconds.
    pub off_s: f64,
    /// PWM, seconds.
    pub pwm_s: f64,
}

/// Case counts.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Counts {
    /// All cases.
    pub total: usize,
    /// Passed.
    pub pass: usize,
    /// Failed.
    pub fail: usize,
    /// Informational.
    pub info: usize,
}

impl Counts {
    /// Each verdict that some case has.
    pub fn verdicts(&self) -> impl Iterator<Item = Verdict> + use<> {
        [
            (self.fail, Verdict::Fail),
            (self.pass, Verdict::Pass),
            (self.info, Verdict::Info),
        ]
        .into_iter()
        .filter(|(n, _)| *n > 0)
        .map(|(_, v)| v)
    }
}

/// One case.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseInfo {
    /// Case id.
    pub id: String,
    /// Illuminance, lux; `null` when unknown (a capture without conditions).
    #[serde(serialize_with = "positive_or_null", deserialize_with = "zero_if_null")]
    pub light_lux: f64,
    /// PWM frequency, Hz; `null` when unknown.
    #[serde(serialize_with = "positive_or_null", deserialize_with = "zero_if_null")]
    pub frequency_hz: f64,
    /// Duty cycle, 0..1; `null` when unknown.
    #[serde(serialize_with = "positive_or_null", deserialize_with = "zero_if_null")]
    pub duty: f64,
    /// Capture file of a captured case, as written in the plan.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// What was read from the capture and the segments used (captured and
    /// command backends).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub capture: Option<Box<CaptureSummary>>,
    /// Case seed.
    pub seed: u64,
    /// pass, fail or info.
    pub verdict: Verdict,
    /// Why the case was not judged (verdict info); `null` when judged.
    pub not_judged: Option<String>,
    /// Limits that could not apply to this case, and why.
    pub not_checked: Vec<String>,
    /// What was done to acquire the frames, in words.
    pub acquisition: String,
    /// Whether the frequency is in the claimed mitigation range (false when
    /// the frequency is unknown).
    pub in_mitigation_range: bool,
    /// Frames acquired.
    pub frames: usize,
    /// Trace CSV, relative to the report directory.
    pub trace: String,
    /// Picture of the darkest PWM frame, when the backend renders one.
    pub sample_frame: Option<SampleFrameInfo>,
    /// Per-ROI results.
    pub rois: Vec<RoiInfo>,
    /// Threshold checks.
    pub checks: Vec<Check>,
    /// Apparent flicker frequency in the video, Hz: `|f - fps round(f/fps)|`
    /// (0 when phase locked).
    pub apparent_frequency_hz: f64,
    /// What the flicker looks like to a driver: the most salient class over
    /// the LED ROIs (see the report's method section for the sources).
    pub hazard_class: HazardClass,
    /// Beat period and whether the capture is shorter than one beat.
    pub beat: Beat,
    /// The PWM drive itself: IEEE 1789 region, IES Flicker Index.
    pub drive: DriveFlicker,
    /// Banding KPIs of a rolling shutter; `null` for a global shutter.
    pub banding: Option<Banding>,
    /// Frame rate, its uncertainty, resolution, stated rate and drops
    /// fitted to a captured or rig case's PWM frame times (absent for the
    /// simulator).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_timing: Option<Box<FrameTiming>>,
    /// The trace and frame at the worst PWM phase that a failing or
    /// informational worst-phase verdict rests on (simulator only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worst_phase: Option<Box<evidence::WorstPhaseInfo>>,
}

impl CaseInfo {
    /// How lit the case's sample frame is, which picks the ROI map's case
    /// of a simulated run: its first LED ROI's lowest level (the sample
    /// frame is the darkest PWM frame), 0 without an LED ROI.
    pub fn sample_frame_led_level(&self) -> f64 {
        self.rois
            .iter()
            .find(|roi| roi.kind == RoiKind::Led)
            .map_or(0.0, |roi| roi.levels.min)
    }

    /// The LED ROI that stands for the case (the terminal summary's `roi`): the one whose checks come closest
    /// to failing, or fail worst (margins compared smallest first, so a tie on
    /// one limit is broken by the next); without checks, the one with the
    /// highest Percent Flicker; without LED ROIs, the first ROI. Ties go to the
    /// first in plan order.
    pub fn worst_roi(&self) -> Option<&RoiInfo> {
        let leds = || self.rois.iter().filter(|r| r.kind == RoiKind::Led);
        let margins = |r: &RoiInfo| {
            let mut m: Vec<f64> = self
                .checks
                .iter()
                .filter(|k| k.roi == r.name)
                .map(|k| k.margin())
                .collect();
            m.sort_by(f64::total_cmp);
            m
        };
        let by_margins = |a: &Vec<f64>, b: &Vec<f64>| {
            a.iter()
                .zip(b)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or_else(|| b.len().cmp(&a.len()))
        };
        if !self.checks.is_empty() {
            // min_by keeps the first of equals: plan order breaks ties.
            return leds()
                .map(|r| (r, margins(r)))
                .min_by(|a, b| by_margins(&a.1, &b.1))
                .map(|(r, _)| r);
        }
        let pf = |r: &RoiInfo| {
            r.metrics
                .get("percent_flicker")
                .copied()
                .flatten()
                .unwrap_or(f64::NEG_INFINITY)
        };
        leds()
            .rev()
            .max_by(|a, b| pf(a).total_cmp(&pf(b)))
            .or(self.rois.first())
    }
}

/// A rendered frame written next to the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SampleFrameInfo {
    /// PNG path, relative to the report directory.
    pub path: String,
    /// Frame number.
    pub frame: u64,
    /// The annotated view shown in the reports (display stretch, ROIs,
    /// 4x crop around the LED ROI), relative to the report directory.
    pub view: String,
    /// Display stretch of the view.
    pub stretch: frame::Stretch,
    /// ROIs as drawn and numbered on the view.
    pub rois: Vec<frame::RoiBox>,
    /// Source rectangle `[x, y, w, h]` of the 4x crop; `null` without ROIs.
    pub crop_px: Option<[u32; 4]>,
    /// Row analysis of this frame in the LED ROI's columns; `null` without
    /// an LED ROI or for an even frame.
    pub banding: Option<FrameBanding>,
    /// Caption of the view: stretch, ROI key, crop, banding of this frame.
    pub caption: String,
}

/// Relative path of a case's sample frame PNG.
pub fn frame_path(case_id: &str) -> String {
    format!("frames/{case_id}.png")
}

/// One ROI of one case.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RoiInfo {
    /// ROI name.
    pub name: String,
    /// led or background.
    pub kind: RoiKind,
    /// Metric name -> value; `null` when undefined (see `reasons`).
    pub metrics: BTreeMap<String, Option<f64>>,
    /// Metric name -> why it is null, or a caveat.
    pub reasons: BTreeMap<String, String>,
    /// Luma levels, DN.
    pub levels: Levels,
    /// Some frame reached the saturation level.
    pub saturated: bool,
    /// FDI is +infinity: the OFF reference is 0 and light is present.
    pub contrast_unbounded: bool,
    /// Spectrum, hazard class and phase coverage of this ROI's trace.
    pub analysis: RoiAnalysis,
    /// The signal colour (`"red"`, `"amber"`) an LED ROI's colour is
    /// judged against, for a plan with colour that names one; its figures
    /// are `delta_uv` and `frames_outside_signal_colour` in `metrics`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signal_colour: Option<String>,
    /// What `delta_uv` is measured from when it is not the PWM frames'
    /// mean colour: `"time-average"`, the colour an LED of dies
    /// (`[[scene.led-die]]`) fuses to over time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delta_uv_reference: Option<String>,
}

impl RoiInfo {
    /// `metric` is an FDI (2018) that this backend computed and that is
    /// +infinity (dark OFF reference, light present). A worst case over
    /// phase that a capture never has stays "not computed", not +inf.
    pub fn is_unbounded(&self, metric: &str) -> bool {
        self.contrast_unbounded
            && metric.starts_with("fdi_2018")
            && self.metrics.contains_key(metric)
    }
}

/// Reads a results.json back, typed. Checks the schema first, so a file of
/// another schema gets a clear message instead of a missing field.
pub fn read_results(text: &str) -> Result<Results, String> {
    #[derive(Deserialize)]
    struct Schema {
        schema: Option<String>,
    }
    let head: Schema = serde_json::from_str(text).map_err(|e| format!("not valid JSON: {e}"))?;
    if head.schema.as_deref() != Some(RESULTS_SCHEMA) {
        return Err(format!(
            "not a `{RESULTS_SCHEMA}` file (schema {})",
            head.schema
                .map_or("missing".to_string(), |s| format!("`{s}`"))
        ));
    }
    serde_json::from_str(text).map_err(|e| {
        format!("not a readable `{RESULTS_SCHEMA}` file: {e}\n    hint: write it again with this version of ledflicker")
    })
}

/// Reads [`positive_or_null`]'s `null` back as 0.
fn zero_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(0.0))
}

/// Conditions are > 0 when known; a captured case without conditions holds
/// 0, written as `null`.
fn positive_or_null<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if *v > 0.0 {
        s.serialize_f64(*v)
    } else {
        s.serialize_none()
    }
}

/// Relative path of a case's trace CSV.
pub fn trace_path(case_id: &str) -> String {
    format!("traces/{case_id}.csv")
}

/// How much of each case the report shows (`--detail`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Detail {
    /// Cover, summary, matrices and the one-line table of every case; no
    /// case pages.
    Summary,
    /// As `Summary`, plus a page for every failing case; the not judged
    /// (informational) cases are one row each in a table, not a page.
    #[default]
    Standard,
    /// A page for every case.
    Full,
}

impl Detail {
    /// Every level, in the order of `--detail`'s help.
    pub const ALL: [Detail; 3] = [Detail::Summary, Detail::Standard, Detail::Full];

    /// Its name in results.json and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Detail::Summary => "summary",
            Detail::Standard => "standard",
            Detail::Full => "full",
        }
    }

    /// Parses [`Detail::as_str`]'s names.
    pub fn parse(s: &str) -> Option<Detail> {
        Detail::ALL.into_iter().find(|d| d.as_str() == s)
    }

    /// Whether a case with this verdict gets its own page. At the default
    /// detail only failing cases do: an informational case cannot fail the
    /// plan, so its evidence is a table row, and a plan sweeping far beyond
    /// the mitigation range does not bury its failures under such pages.
    pub fn shows_case(self, verdict: &str) -> bool {
        match self {
            Detail::Summary => false,
            Detail::Standard => verdict == "fail",
            Detail::Full => true,
        }
    }
}

/// Report metadata kept in results.json under `report`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportMeta {
    /// Report date, `YYYY-MM-DD`.
    pub date: String,
    /// How much of each case the report shows: `summary`, `standard` or
    /// `full` (`--detail`).
    pub detail: String,
    /// Every input file, plan first.
    pub inputs: Vec<InputFile>,
    /// Deviations from the method of Deegan 2018 and other notes, one
    /// sentence each.
    pub notes: Vec<String>,
    /// The report profile it was written with (`[report]`, `--profile`);
    /// absent without one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<ProfileMeta>,
}

/// A report profile as results.json holds it: what the report shows, and
/// the files of the report directory that hold its logo and templates (so
/// that the report can be rendered again from its directory alone).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ProfileMeta {
    /// Company name shown on the cover and in the page header.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub company: Option<String>,
    /// Document number shown on the cover and in the page header.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub document_number: Option<String>,
    /// The logo, relative to the report directory (`profile/logo.png` or
    /// `profile/logo.svg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub logo: Option<String>,
    /// Renamed cover and sign-off fields: label key -> text.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub labels: std::collections::BTreeMap<String, String>,
    /// The sections shown, in report order; absent: every section.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sections: Option<Vec<String>>,
    /// Templates replaced, by name; their sources are in the report
    /// directory under `profile/templates/`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub templates: Vec<String>,
}

/// A case's annotated view, relative to the report directory.
pub fn view_path(case_id: &str) -> String {
    format!("frames/{case_id}-view.png")
}
