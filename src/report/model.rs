//! The report model: results.json. HTML and PDF are rendered from it.
//!
//! Contract `ledflicker.results/2` (see docs/changes.md; fields may be added,
//! never renamed):
//! `schema`, `plan {id, title, path, sha256}`, `verdict`, and `cases[]` with
//! `id, light_lux, frequency_hz, duty, verdict` and
//! `rois[] {name, metrics {fdi_2018, percent_flicker, ...}}`. A metric that
//! cannot be defined is `null` in `metrics`, with its reason under the same
//! name in `reasons`.
//!
//! Added by issue 6 (beyond the paper): per case `apparent_frequency_hz`,
//! `hazard_class`, `beat`, `drive` (IEEE 1789, IES Flicker Index) and
//! `banding`; per ROI the metrics `apparent_frequency_spectrum_hz` and
//! `phase_coverage` and an `analysis` object; at the top `fine_maps` and
//! `advice`.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::analysis::{self, Banding, Beat, DriveFlicker, FineMapInfo, HazardClass, RoiAnalysis};
use crate::metrics::verdict::{effective_basis, in_mitigation_range, overall};
use crate::metrics::{Check, Levels, Metric, Verdict};
use crate::plan::{Plan, RoiKind, Sequence, ShutterKind, Thresholds};
use crate::runner::CaseResult;

/// Schema id of results.json.
pub const RESULTS_SCHEMA: &str = "ledflicker.results/2";

/// Top of results.json.
#[derive(Debug, Clone, Serialize)]
pub struct Results {
    /// Always [`RESULTS_SCHEMA`].
    pub schema: &'static str,
    /// Tool that made it.
    pub tool: Tool,
    /// The plan.
    pub plan: PlanInfo,
    /// Device under test and backend.
    pub dut: DutInfo,
    /// The light sequence.
    pub sequence: SequenceInfo,
    /// Pass criteria; `basis` is the one actually used (as captured for
    /// captures and rigs).
    pub thresholds: Thresholds,
    /// How the frames were acquired and which verdict basis was used.
    pub method: super::method::Method,
    /// IEEE P2020 KPI settings (`[p2020]`).
    pub p2020: crate::metrics::p2020::P2020Options,
    /// Overall verdict: fail if any case failed, else pass if any case was
    /// judged, else info (no case judged: never pass).
    pub verdict: Verdict,
    /// Number of cases per verdict.
    pub counts: Counts,
    /// Every case, in plan order.
    pub cases: Vec<CaseInfo>,
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
    pub report: Option<super::document::ReportMeta>,
}

/// Exposure advice for a plan's range.
#[derive(Debug, Clone, Serialize)]
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

/// Grid of the report's advice: coarser than `ledflicker advise`'s default
/// so that a report stays quick to build.
const ADVICE_STEP_HZ: f64 = 5.0;
const ADVICE_STEP_DUTY: f64 = 0.01;

fn plan_advice(plan: &Plan) -> Option<PlanAdvice> {
    let fold = |xs: &[f64]| {
        xs.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    let (f0, f1) = fold(&plan.frequencies_hz);
    let f0 = f0.max(plan.thresholds.mitigation_min_hz);
    let f1 = plan.thresholds.mitigation_max_hz.map_or(f1, |m| f1.min(m));
    let duty = fold(&plan.duty_cycles);
    let req = crate::advise::AdviseRequest {
        frequency_hz: (f0, f1),
        duty,
        frequency_step_hz: ADVICE_STEP_HZ,
        duty_step: ADVICE_STEP_DUTY,
        speed_px_per_s: None,
        hdr_ratios: Vec::new(),
        frame: Some(frame_bound(plan)),
    };
    let advice = crate::advise::advise(&req).ok()?;
    let curve = crate::advise::curve(&req, 33).ok()?;
    Some(PlanAdvice {
        frequency_hz: (f0, f1),
        duty,
        advice,
        curve,
    })
}

/// What bounds the plan camera's (long) exposure: its frame time, less its
/// other captures when they run one after the other.
fn frame_bound(plan: &Plan) -> crate::advise::FrameBound {
    let cam = &plan.dut.camera;
    match &cam.physical {
        Some(p) => crate::advise::FrameBound::of_captures(cam.fps, &p.captures, p.hdr_mode),
        None => crate::advise::FrameBound::frame_time(cam.fps),
    }
}

/// Tool name and version.
#[derive(Debug, Clone, Serialize)]
pub struct Tool {
    /// "ledflicker".
    pub name: &'static str,
    /// Crate version.
    pub version: &'static str,
}

/// Plan identity.
#[derive(Debug, Clone, Serialize)]
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
#[derive(Debug, Clone, Serialize)]
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

/// The simulated camera, in the plan's units.
#[derive(Debug, Clone, Serialize)]
pub struct CameraInfo {
    /// "global" or "rolling".
    pub shutter: &'static str,
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
#[derive(Debug, Clone, Serialize)]
pub struct SequenceInfo {
    /// Steady ON, seconds.
    pub on_s: f64,
    /// OFF, seconds.
    pub off_s: f64,
    /// PWM, seconds.
    pub pwm_s: f64,
}

/// Case counts.
#[derive(Debug, Clone, Default, Serialize)]
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

/// One case.
#[derive(Debug, Clone, Serialize)]
pub struct CaseInfo {
    /// Case id.
    pub id: String,
    /// Illuminance, lux; `null` when unknown (a capture without conditions).
    #[serde(serialize_with = "positive_or_null")]
    pub light_lux: f64,
    /// PWM frequency, Hz; `null` when unknown.
    #[serde(serialize_with = "positive_or_null")]
    pub frequency_hz: f64,
    /// Duty cycle, 0..1; `null` when unknown.
    #[serde(serialize_with = "positive_or_null")]
    pub duty: f64,
    /// Capture file of a captured case, as written in the plan.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// What was read from the capture and the segments used (captured and
    /// command backends).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub capture: Option<crate::backend::captured::CaptureSummary>,
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
}

/// A rendered frame written next to the report.
#[derive(Debug, Clone, Serialize)]
pub struct SampleFrameInfo {
    /// PNG path, relative to the report directory.
    pub path: String,
    /// Frame number.
    pub frame: u64,
    /// The annotated view shown in the reports (display stretch, ROIs,
    /// 4x crop around the LED ROI), relative to the report directory.
    pub view: String,
    /// Display stretch of the view.
    pub stretch: super::frames::Stretch,
    /// ROIs as drawn and numbered on the view.
    pub rois: Vec<super::frames::RoiBox>,
    /// Source rectangle `[x, y, w, h]` of the 4x crop; `null` without ROIs.
    pub crop_px: Option<[u32; 4]>,
    /// Row analysis of this frame in the LED ROI's columns; `null` without
    /// an LED ROI or for an even frame.
    pub banding: Option<super::frames::FrameBanding>,
    /// Caption of the view: stretch, ROI key, crop, banding of this frame.
    pub caption: String,
}

/// Relative path of a case's sample frame PNG.
pub fn frame_path(case_id: &str) -> String {
    format!("frames/{case_id}.png")
}

/// One ROI of one case.
#[derive(Debug, Clone, Serialize)]
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

/// Conditions are > 0 when known; a captured case without conditions holds
/// 0, written as `null`.
fn positive_or_null<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if *v > 0.0 {
        s.serialize_f64(*v)
    } else {
        s.serialize_none()
    }
}

fn insert(roi: &mut RoiInfo, name: &str, m: &Metric) {
    roi.metrics.insert(name.to_string(), m.value);
    if let Some(r) = &m.reason {
        roi.reasons.insert(name.to_string(), r.clone());
    }
    roi.contrast_unbounded |= m.unbounded;
}

/// Relative path of a case's trace CSV.
pub fn trace_path(case_id: &str) -> String {
    format!("traces/{case_id}.csv")
}

/// Builds results.json's model. `plan_path` is the path as the user gave it.
pub fn build(plan: &Plan, backend_id: &str, results: &[CaseResult]) -> Results {
    let cam = &plan.dut.camera;
    let mut counts = Counts {
        total: results.len(),
        ..Counts::default()
    };
    // The analyses and the sample frames' banding are independent per
    // case: in parallel, collected in order.
    let analyses: Vec<_> = {
        use rayon::prelude::*;
        results
            .par_iter()
            .map(|r| {
                let frame = r
                    .sample_frame
                    .as_ref()
                    .map(|f| super::frames::sample_frame_info(&r.case.id, f, &plan.rois));
                (analysis::analyse_case(plan, r), frame)
            })
            .collect()
    };
    let cases = results
        .iter()
        .zip(analyses)
        .map(|(r, (a, sample_frame))| {
            match r.verdict {
                Verdict::Pass => counts.pass += 1,
                Verdict::Fail => counts.fail += 1,
                Verdict::Info => counts.info += 1,
            }
            let rois = plan
                .rois
                .iter()
                .zip(&r.metrics)
                .zip(a.rois)
                .enumerate()
                .map(|(i, ((roi, m), ra))| {
                    let mut info = RoiInfo {
                        name: roi.name.clone(),
                        kind: roi.kind,
                        metrics: BTreeMap::new(),
                        reasons: BTreeMap::new(),
                        levels: m.levels.clone(),
                        saturated: m.saturated,
                        contrast_unbounded: false,
                        analysis: ra,
                    };
                    insert(&mut info, "fdi_2018", &m.fdi_2018);
                    insert(&mut info, "percent_flicker", &m.percent_flicker);
                    if let Some(x) = &m.fdi_2018_worst_phase {
                        insert(&mut info, "fdi_2018_worst_phase", x);
                    }
                    if let Some(x) = &m.percent_flicker_worst_phase {
                        insert(&mut info, "percent_flicker_worst_phase", x);
                    }
                    let spectrum = Metric {
                        value: info.analysis.apparent_frequency_spectrum_hz,
                        unbounded: false,
                        reason: info.analysis.spectrum_reason.clone(),
                    };
                    insert(&mut info, "apparent_frequency_spectrum_hz", &spectrum);
                    let coverage = info.analysis.phase_coverage.coverage;
                    info.metrics
                        .insert("phase_coverage".to_string(), Some(coverage));
                    if let Some(w) = &info.analysis.phase_coverage.warning {
                        info.reasons.insert("phase_coverage".to_string(), w.clone());
                    }
                    if let Some(p) = r.p2020.get(i) {
                        insert(&mut info, "fmi", &p.fmi);
                        insert(&mut info, "fdi_p2020", &p.fdi);
                        insert(&mut info, "mmp", &p.mmp);
                    }
                    info
                })
                .collect();
            CaseInfo {
                id: r.case.id.clone(),
                light_lux: r.case.light_lux,
                frequency_hz: r.case.frequency_hz,
                duty: r.case.duty,
                source: None,
                capture: None,
                seed: r.case.seed,
                verdict: r.verdict,
                not_judged: r.not_judged.clone(),
                not_checked: r.not_checked.clone(),
                acquisition: String::new(),
                in_mitigation_range: r.case.frequency_hz > 0.0
                    && in_mitigation_range(r.case.frequency_hz, &plan.thresholds),
                frames: r.acquisition.frames.len(),
                trace: trace_path(&r.case.id),
                sample_frame,
                rois,
                checks: r.checks.clone(),
                apparent_frequency_hz: a.beat.apparent_frequency_hz,
                hazard_class: a.hazard_class,
                beat: a.beat,
                drive: a.drive,
                banding: a.banding,
            }
        })
        .collect();
    let Sequence { on_s, off_s, pwm_s } = plan.sequence;
    let mut thresholds = plan.thresholds.clone();
    thresholds.basis = effective_basis(plan.dut.backend, &plan.thresholds);
    let mut model = Results {
        schema: RESULTS_SCHEMA,
        tool: Tool {
            name: "ledflicker",
            version: env!("CARGO_PKG_VERSION"),
        },
        plan: PlanInfo {
            id: plan.id.clone(),
            title: plan.title.clone(),
            path: plan.path.display().to_string(),
            sha256: plan.sha256.clone(),
            standard: plan.standard.clone(),
            description: plan.description.clone(),
            lab: plan.lab.clone(),
            seed: plan.seed,
        },
        dut: DutInfo {
            backend: backend_id.to_string(),
            supplier: plan.dut.supplier.clone(),
            model: plan.dut.model.clone(),
            serial: plan.dut.serial.clone(),
            firmware: plan.dut.firmware.clone(),
            camera: (plan.dut.backend == crate::plan::BackendKind::Simulator).then_some(
                CameraInfo {
                    shutter: match cam.shutter {
                        ShutterKind::Global => "global",
                        ShutterKind::Rolling => "rolling",
                    },
                    sensor_rows: cam.sensor_rows,
                    sensor_columns: cam.sensor_columns,
                    line_time_us: cam.line_time_s * 1e6,
                    exposure_ms: cam.exposure_s * 1e3,
                    frame_rate_fps: cam.fps,
                    pwm_delay_ms: cam.pwm_delay_s * 1e3,
                },
            ),
        },
        sequence: SequenceInfo { on_s, off_s, pwm_s },
        thresholds,
        method: super::method::method(plan),
        p2020: plan.p2020,
        verdict: overall(results.iter().map(|r| r.verdict)),
        counts,
        cases,
        fine_maps: analysis::fine_maps(plan),
        fine_maps_note: analysis::fine_maps_note(plan),
        advice: plan_advice(plan),
        report: None,
    };
    super::method::describe(&mut model, plan);
    model
}
