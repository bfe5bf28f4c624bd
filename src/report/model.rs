//! The report model: results.json. HTML and PDF are rendered from it.
//!
//! Contract `ledflicker.results/1` (fields may be added, never renamed):
//! `schema`, `plan {id, title, path, sha256}`, `verdict`, and `cases[]` with
//! `id, light_lux, frequency_hz, duty, verdict` and
//! `rois[] {name, metrics {fdi_2018, percent_flicker, ...}}`. A metric that
//! cannot be defined is `null` in `metrics`, with its reason under the same
//! name in `reasons`.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::metrics::verdict::{in_mitigation_range, overall};
use crate::metrics::{Check, Levels, Metric, Verdict};
use crate::plan::{Plan, RoiKind, Sequence, ShutterKind, Thresholds};
use crate::runner::CaseResult;

/// Schema id of results.json.
pub const RESULTS_SCHEMA: &str = "ledflicker.results/1";

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
    /// Pass criteria.
    pub thresholds: Thresholds,
    /// Overall verdict: fail if any case failed.
    pub verdict: Verdict,
    /// Number of cases per verdict.
    pub counts: Counts,
    /// Every case, in plan order.
    pub cases: Vec<CaseInfo>,
    /// Date and input files; set when the report is written, absent in
    /// models built in memory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<super::document::ReportMeta>,
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
    /// Illuminance, lux.
    pub light_lux: f64,
    /// PWM frequency, Hz.
    pub frequency_hz: f64,
    /// Duty cycle, 0..1.
    pub duty: f64,
    /// Case seed.
    pub seed: u64,
    /// pass, fail or info.
    pub verdict: Verdict,
    /// Whether the frequency is in the claimed mitigation range.
    pub in_mitigation_range: bool,
    /// Frames acquired.
    pub frames: usize,
    /// Trace CSV, relative to the report directory.
    pub trace: String,
    /// Per-ROI results.
    pub rois: Vec<RoiInfo>,
    /// Threshold checks.
    pub checks: Vec<Check>,
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
    let cases = results
        .iter()
        .map(|r| {
            match r.verdict {
                Verdict::Pass => counts.pass += 1,
                Verdict::Fail => counts.fail += 1,
                Verdict::Info => counts.info += 1,
            }
            let rois = plan
                .rois
                .iter()
                .zip(&r.metrics)
                .map(|(roi, m)| {
                    let mut info = RoiInfo {
                        name: roi.name.clone(),
                        kind: roi.kind,
                        metrics: BTreeMap::new(),
                        reasons: BTreeMap::new(),
                        levels: m.levels.clone(),
                        saturated: m.saturated,
                        contrast_unbounded: false,
                    };
                    insert(&mut info, "fdi_2018", &m.fdi_2018);
                    insert(&mut info, "percent_flicker", &m.percent_flicker);
                    if let Some(x) = &m.fdi_2018_worst_phase {
                        insert(&mut info, "fdi_2018_worst_phase", x);
                    }
                    if let Some(x) = &m.percent_flicker_worst_phase {
                        insert(&mut info, "percent_flicker_worst_phase", x);
                    }
                    info
                })
                .collect();
            CaseInfo {
                id: r.case.id.clone(),
                light_lux: r.case.light_lux,
                frequency_hz: r.case.frequency_hz,
                duty: r.case.duty,
                seed: r.case.seed,
                verdict: r.verdict,
                in_mitigation_range: in_mitigation_range(r.case.frequency_hz, &plan.thresholds),
                frames: r.acquisition.frames.len(),
                trace: trace_path(&r.case.id),
                rois,
                checks: r.checks.clone(),
            }
        })
        .collect();
    let Sequence { on_s, off_s, pwm_s } = plan.sequence;
    Results {
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
            camera: Some(CameraInfo {
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
            }),
        },
        sequence: SequenceInfo { on_s, off_s, pwm_s },
        thresholds: plan.thresholds,
        verdict: overall(results.iter().map(|r| r.verdict)),
        counts,
        cases,
        report: None,
    }
}
