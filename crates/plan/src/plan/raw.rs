//! Serde mirror of the TOML test plan, format version 1.
//!
//! Every field is optional or defaulted here so that `validate` can report
//! all missing and out-of-range values of a file together. Unknown keys are
//! collected by `serde_ignored` in `plan::load` rather than rejected by
//! `deny_unknown_fields`, which would stop at the first one.
//! The documented format is in docs/plan-format.md.

use serde::Deserialize;

/// The whole plan file.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawPlan {
    /// Plan format version: 1 or 2 (2 adds optional keys only; docs/changes.md).
    pub format_version: Option<i64>,
    /// `[plan]`: identity of the plan.
    pub plan: Option<RawMeta>,
    /// `[sequence]`: ON / OFF / PWM durations.
    pub sequence: Option<RawSequence>,
    /// `[light]`: ambient light levels.
    pub light: Option<RawLight>,
    /// `[grid]`: PWM frequencies and duty cycles.
    pub grid: Option<RawGrid>,
    /// `[[roi]]`: regions of interest.
    #[serde(default)]
    pub roi: Vec<RawRoi>,
    /// `[dut]`: the device under test.
    pub dut: Option<RawDut>,
    /// `[scene]`: what the camera looks at.
    pub scene: Option<RawScene>,
    /// `[thresholds]`: pass criteria.
    pub thresholds: Option<RawThresholds>,
    /// `[capture]`: how captured data is read.
    pub capture: Option<RawCaptureTable>,
    /// `[[case]]`: captures of a captured plan.
    #[serde(default)]
    pub case: Vec<RawCaseEntry>,
    /// `[p2020]`: IEEE P2020 KPI settings.
    pub p2020: Option<RawP2020>,
    /// `[report]`: the report's look (company, logo, sections, templates).
    pub report: Option<RawReport>,
    /// `[display]`: the CMS monitor and viewing geometry.
    pub display: Option<RawDisplay>,
    /// `[source]`: the light source driven over SCPI.
    pub source: Option<RawSource>,
    /// `[recorder]`: the camera recorder of a plan with a light source.
    pub recorder: Option<RawRecorder>,
}

/// `[plan]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawMeta {
    pub id: Option<String>,
    pub title: Option<String>,
    pub standard: Option<String>,
    pub description: Option<String>,
    pub lab: Option<String>,
    pub seed: Option<i64>,
}

/// `[sequence]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawSequence {
    pub on_s: Option<f64>,
    pub off_s: Option<f64>,
    pub pwm_s: Option<f64>,
}

/// `[light]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawLight {
    pub levels_lux: Option<Vec<f64>>,
}

/// An evenly spaced grid, `start` to `stop` inclusive.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawRange {
    pub start: Option<f64>,
    pub stop: Option<f64>,
    pub step: Option<f64>,
}

/// `[grid]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawGrid {
    pub frequencies_hz: Option<Vec<f64>>,
    pub frequency_range_hz: Option<RawRange>,
    pub duty_cycles: Option<Vec<f64>>,
    pub duty_cycle_range: Option<RawRange>,
}

/// `[[roi]]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawRoi {
    pub name: Option<String>,
    pub kind: Option<String>,
    pub x_px: Option<i64>,
    pub y_px: Option<i64>,
    pub width_px: Option<i64>,
    pub height_px: Option<i64>,
}

/// `[dut]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawDut {
    pub backend: Option<String>,
    pub supplier: Option<String>,
    pub model: Option<String>,
    pub serial: Option<String>,
    pub firmware: Option<String>,
    pub camera_profile: Option<String>,
    pub camera: Option<RawCamera>,
}

/// A camera profile file: `[camera]` with the keys of `[dut.camera]`.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawProfile {
    pub camera: Option<RawCamera>,
}

/// `[dut.camera]`: the simulator's camera.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawCamera {
    pub name: Option<String>,
    pub description: Option<String>,
    pub shutter: Option<String>,
    pub sensor_rows: Option<i64>,
    pub sensor_columns: Option<i64>,
    pub line_time_us: Option<f64>,
    pub exposure_ms: Option<f64>,
    pub frame_rate_fps: Option<f64>,
    pub pwm_delay_ms: Option<f64>,
    pub response_dn_per_cd_m2_s: Option<f64>,
    pub black_level_dn: Option<f64>,
    pub full_scale_dn: Option<f64>,
    pub saturation_dn: Option<f64>,
    pub analog_gain: Option<f64>,
    pub digital_gain: Option<f64>,
    pub sensor: Option<RawSensor>,
    #[serde(default)]
    pub capture: Vec<RawCapture>,
    pub hdr: Option<RawHdr>,
    pub tone: Option<RawTone>,
    pub auto_exposure: Option<RawAutoExposure>,
    pub colour_plane_offset_ms: Option<Vec<f64>>,
    pub camera_to_xyz: Option<Vec<Vec<f64>>>,
}

impl RawCamera {
    /// True when no key is set: what is left of a captured plan's
    /// `[dut.camera]` that held only the colour keys.
    pub fn is_empty(&self) -> bool {
        let numbers = [
            self.line_time_us,
            self.exposure_ms,
            self.frame_rate_fps,
            self.pwm_delay_ms,
            self.response_dn_per_cd_m2_s,
            self.black_level_dn,
            self.full_scale_dn,
            self.saturation_dn,
            self.analog_gain,
            self.digital_gain,
        ];
        self.name.is_none()
            && self.description.is_none()
            && self.shutter.is_none()
            && self.sensor_rows.is_none()
            && self.sensor_columns.is_none()
            && numbers.iter().all(Option::is_none)
            && self.sensor.is_none()
            && self.capture.is_empty()
            && self.hdr.is_none()
            && self.tone.is_none()
            && self.auto_exposure.is_none()
            && self.colour_plane_offset_ms.is_none()
            && self.camera_to_xyz.is_none()
    }
}

/// `[dut.camera.sensor]`: present for a physical sensor model.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawSensor {
    pub sensitivity_e_per_cd_m2_s: Option<f64>,
    pub full_well_e: Option<f64>,
    pub read_noise_e: Option<f64>,
    pub shot_noise: Option<bool>,
    pub adc_bits: Option<i64>,
    pub e_per_dn: Option<f64>,
}

/// `[[dut.camera.capture]]`: one HDR capture.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawCapture {
    pub name: Option<String>,
    pub exposure_ratio: Option<f64>,
    pub exposure_ms: Option<f64>,
    pub sensitivity_ratio: Option<f64>,
}

/// `[dut.camera.hdr]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawHdr {
    pub mode: Option<String>,
    pub merge: Option<String>,
    pub white_dn: Option<f64>,
}

/// `[dut.camera.tone]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawTone {
    pub curve: Option<String>,
    pub gamma: Option<f64>,
    pub log_a: Option<f64>,
    pub output_bits: Option<i64>,
}

/// `[dut.camera.auto-exposure]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawAutoExposure {
    pub target_luma: Option<f64>,
    pub target: Option<f64>,
    pub damping: Option<f64>,
    pub deadband: Option<f64>,
    pub min_exposure_ms: Option<f64>,
    pub max_exposure_ms: Option<f64>,
    pub max_analog_gain: Option<f64>,
    pub min_digital_gain: Option<f64>,
    pub max_digital_gain: Option<f64>,
}

/// `[scene]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawScene {
    pub background_reflectance: Option<f64>,
    pub led_luminance_cd_m2: Option<f64>,
    pub led_fill: Option<f64>,
    pub led_frame_fraction: Option<f64>,
    pub pwm_clock_offset_ppm: Option<f64>,
    pub led_chromaticity_xy: Option<Vec<f64>>,
    pub signal_colour: Option<String>,
    #[serde(default)]
    pub led_die: Vec<RawLedDie>,
}

/// `[[scene.led-die]]`: one die of an RGB (multi-die) LED.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawLedDie {
    pub chromaticity_xy: Option<Vec<f64>>,
    pub luminance_share: Option<f64>,
    pub duty_cycle: Option<f64>,
    pub phase_deg: Option<f64>,
}

/// `[thresholds]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawThresholds {
    pub fdi_2018_min: Option<f64>,
    pub percent_flicker_max: Option<f64>,
    pub fmi_max: Option<f64>,
    pub fdi_p2020_min: Option<f64>,
    pub mmp_min: Option<f64>,
    pub visibility_max: Option<f64>,
    pub delta_uv_max: Option<f64>,
    pub mitigation_min_hz: Option<f64>,
    pub mitigation_max_hz: Option<f64>,
    pub basis: Option<String>,
    #[serde(default)]
    pub light_level: Vec<RawLevelThresholds>,
}

/// `[[thresholds.light-level]]`: limits for one light level.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawLevelThresholds {
    pub light_lux: Option<f64>,
    pub fdi_2018_min: Option<f64>,
    pub percent_flicker_max: Option<f64>,
    pub fmi_max: Option<f64>,
    pub fdi_p2020_min: Option<f64>,
    pub mmp_min: Option<f64>,
    pub visibility_max: Option<f64>,
    pub delta_uv_max: Option<f64>,
}

/// `[capture]`
#[derive(Debug, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawCaptureTable {
    pub luma: Option<String>,
    pub video_decode: Option<String>,
    pub video_range: Option<String>,
    pub colour_transfer: Option<String>,
    pub black_level: Option<String>,
    pub frame_rate_fps: Option<f64>,
    pub saturation_dn: Option<f64>,
    pub off_frames: Option<Vec<i64>>,
    pub on_frames: Option<Vec<i64>>,
    pub pwm_frames: Option<Vec<i64>>,
    pub off_time_s: Option<Vec<f64>>,
    pub on_time_s: Option<Vec<f64>>,
    pub pwm_time_s: Option<Vec<f64>>,
    pub command: Option<Vec<String>>,
    pub timeout_s: Option<f64>,
    pub settle_s: Option<f64>,
}

/// Segment keys, in `[capture]` (defaults) and in each `[[case]]` (no
/// `serde(flatten)`: it would hide unknown keys from the checks).
#[derive(Debug, Default)]
pub struct RawSegments {
    pub off_frames: Option<Vec<i64>>,
    pub on_frames: Option<Vec<i64>>,
    pub pwm_frames: Option<Vec<i64>>,
    pub off_time_s: Option<Vec<f64>>,
    pub on_time_s: Option<Vec<f64>>,
    pub pwm_time_s: Option<Vec<f64>>,
}

/// `[[case]]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawCaseEntry {
    pub id: Option<String>,
    pub source: Option<String>,
    pub light_lux: Option<f64>,
    pub frequency_hz: Option<f64>,
    pub duty_cycle: Option<f64>,
    pub off_frames: Option<Vec<i64>>,
    pub on_frames: Option<Vec<i64>>,
    pub pwm_frames: Option<Vec<i64>>,
    pub off_time_s: Option<Vec<f64>>,
    pub on_time_s: Option<Vec<f64>>,
    pub pwm_time_s: Option<Vec<f64>>,
    pub informative: Option<bool>,
}

/// `[p2020]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawP2020 {
    pub contrast_threshold: Option<f64>,
    pub mmp_delta: Option<f64>,
    pub mmp_reference: Option<String>,
}

/// `[report]`, in a plan or in a report profile file (`--profile`).
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawReport {
    pub company: Option<String>,
    pub logo: Option<String>,
    pub document_number: Option<String>,
    pub sections: Option<Vec<String>>,
    pub templates: Option<String>,
    /// Checked against `plan::profile::LABELS` by the validator, so that
    /// an unknown label gets the list of known ones.
    pub labels: Option<std::collections::BTreeMap<String, String>>,
}

/// A report profile file: `[report]` with the keys of a plan's `[report]`.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawReportFile {
    pub report: Option<RawReport>,
}

/// `[display]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawDisplay {
    pub preset: Option<String>,
    pub eotf: Option<String>,
    pub refresh_hz: Option<f64>,
    pub peak_cd_m2: Option<f64>,
    pub black_cd_m2: Option<f64>,
    pub image_width_mm: Option<f64>,
    pub distance_mm: Option<f64>,
    pub full_scale_dn: Option<f64>,
    pub image_width_px: Option<i64>,
}

/// `[source]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawSource {
    pub instrument: Option<String>,
    pub host: Option<String>,
    pub port: Option<i64>,
    pub channel: Option<i64>,
    pub amplitude_vpp: Option<f64>,
    pub offset_v: Option<f64>,
    pub timeout_s: Option<f64>,
    pub lead_in_s: Option<f64>,
    pub reconnects: Option<i64>,
    pub commands: Option<RawSourceCommands>,
}

/// `[source.commands]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawSourceCommands {
    pub identify: Option<String>,
    pub error_query: Option<String>,
    pub setup: Option<Vec<String>>,
    pub steady: Option<Vec<String>>,
    pub pwm: Option<Vec<String>>,
    pub output_on: Option<Vec<String>>,
    pub output_off: Option<Vec<String>>,
}

/// `[recorder]`
#[derive(Debug, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct RawRecorder {
    pub gstreamer: Option<String>,
    pub command: Option<Vec<String>>,
    pub tail_s: Option<f64>,
    pub exposure_us: Option<f64>,
    pub gain_db: Option<f64>,
    pub frame_rate_fps: Option<f64>,
}
