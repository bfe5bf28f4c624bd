//! Test plans: TOML on disk -> [`raw::RawPlan`] (serde) -> validated [`Plan`]
//! -> [`TestCase`]s (grid expansion).
//!
//! First stage of the pipeline. Loading reads the file, records its SHA-256,
//! collects every unknown key and every out-of-range value with its line,
//! and fails with all of them at once.

pub mod bounds;
mod capture;
mod check;
pub mod colour;
pub mod display;
mod grid;
mod p2020;
pub mod profile;
mod raw;
pub mod recorder;
pub mod shipped;
pub mod source;
mod spans;
mod validate;

use std::fmt;
use std::path::{Path, PathBuf};

pub use bounds::{ResourceLimits, WorkEstimate};
pub use capture::{
    BlackLevel, CaptureCase, CaptureConfig, ColourTransfer, CommandSpec, DEFAULT_SETTLE_S,
    LumaWeights, SegmentSpec, Span, VideoDecode, VideoRange,
};
pub use grid::{TestCase, expand_cases};
pub use p2020::{MmpReference, P2020Options};
pub use profile::{ReportProfile, load_report_profile};

/// Upper bound on cases in one plan, whatever the limits: the list of
/// cases itself is held in memory (about 200 bytes a case). The practical
/// bound is the memory and disk estimate ([`WorkEstimate`]) against the
/// run's [`ResourceLimits`].
pub const MAX_CASES: usize = 10_000_000;

/// A validated test plan. All values are in range and in SI-prefixed units
/// named in the field.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Short id, `[a-z0-9_-]+`; names the report directory.
    pub id: String,
    /// Human title.
    pub title: String,
    /// Standard or method followed, e.g. "Deegan 2018 (IS&T EI AVM-146)".
    pub standard: String,
    /// Free text.
    pub description: String,
    /// Test lab, for the report cover.
    pub lab: String,
    /// Random seed; each case derives its own from this and its id.
    pub seed: u64,
    /// Path the plan was read from; for a built-in plan, its path in the
    /// source tree (`test-plans/daylight.toml`).
    pub path: PathBuf,
    /// Read from the copy built into the binary ([`shipped`]), not a file.
    pub built_in: bool,
    /// SHA-256 of the plan file, lowercase hex.
    pub sha256: String,
    /// ON / OFF / PWM durations.
    pub sequence: Sequence,
    /// Ambient illuminance levels in lux (> 0), in plan order.
    pub light_levels_lux: Vec<f64>,
    /// PWM frequencies in Hz (> 0), in plan order.
    pub frequencies_hz: Vec<f64>,
    /// Duty cycles in (0, 1], in plan order.
    pub duty_cycles: Vec<f64>,
    /// Regions of interest, at least one.
    pub rois: Vec<Roi>,
    /// Device under test.
    pub dut: Dut,
    /// Scene radiometry.
    pub scene: Scene,
    /// Pass criteria.
    pub thresholds: Thresholds,
    /// Captured data and lab-rig settings (`[capture]`, `[[case]]`);
    /// `Some` for the captured and command backends.
    pub capture: Option<CaptureConfig>,
    /// IEEE P2020 KPI settings (`[p2020]`).
    pub p2020: P2020Options,
    /// The report's look (`[report]`, and `--profile`, which
    /// [`profile::ReportProfile::overridden_by`] puts over it).
    pub report: profile::ReportProfile,
    /// The CMS monitor (`[display]`); `None` when the plan has none, and
    /// then no visibility is computed.
    pub display: Option<display::Display>,
    /// The LED's colour and the camera's colour planes; `None` when the
    /// plan gives no `scene.led-chromaticity-xy`, and then no colour is
    /// simulated or reported.
    pub colour: Option<colour::ColourConfig>,
    /// The light source driven over SCPI (`[source]`); only a command
    /// plan has one.
    pub source: Option<source::SourceConfig>,
    /// The camera recorder (`[recorder]`); only a command plan with a
    /// light source has one, and then its command is the plan's
    /// `capture.command`.
    pub recorder: Option<recorder::RecorderConfig>,
    /// Plausibility warnings, in file order: values that are valid but
    /// most likely in another unit (docs/plan-format.md, "Plausibility
    /// warnings"). They never stop a run; [`Plan::warnings_text`] words them.
    pub warnings: Vec<Diagnostic>,
}

/// The light sequence of one case: steady ON (luminance matched to the PWM
/// average), OFF (reference level), then PWM. Durations in seconds (>= 0,
/// PWM > 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sequence {
    /// Steady-ON duration in seconds.
    pub on_s: f64,
    /// OFF duration in seconds.
    pub off_s: f64,
    /// PWM duration in seconds.
    pub pwm_s: f64,
}

/// Frame counts of the three segments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SegmentFrames {
    /// Steady-ON frames.
    pub on: u64,
    /// OFF frames.
    pub off: u64,
    /// PWM frames.
    pub pwm: u64,
}

impl SegmentFrames {
    /// Frames per segment at `fps`, each duration rounded to whole frames.
    pub fn new(sequence: &Sequence, fps: f64) -> Self {
        let frames = |s: f64| (s * fps).round() as u64;
        Self {
            on: frames(sequence.on_s),
            off: frames(sequence.off_s),
            pwm: frames(sequence.pwm_s),
        }
    }

    /// Total frames.
    pub fn total(&self) -> u64 {
        self.on + self.off + self.pwm
    }
}

/// What an ROI looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RoiKind {
    /// On the LED source: flicker metrics and verdicts apply.
    Led,
    /// On the grey background: informational (and, later, auto exposure).
    Background,
}

/// A rectangular region of interest in sensor pixels.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Roi {
    /// Unique name; also the trace CSV column.
    pub name: String,
    /// LED or background.
    pub kind: RoiKind,
    /// Left column, 0-based.
    pub x_px: u32,
    /// Top row, 0-based.
    pub y_px: u32,
    /// Width in pixels (>= 1).
    pub width_px: u32,
    /// Height in rows (>= 1).
    pub height_px: u32,
}

impl Roi {
    /// Rows covered, start inclusive, end exclusive.
    pub fn rows(&self) -> std::ops::Range<u32> {
        self.y_px..self.y_px + self.height_px
    }
}

/// Which backend acquires the frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackendKind {
    /// The built-in physics simulator.
    Simulator,
    /// Captured data: one file per `[[case]]`.
    Captured,
    /// A lab-rig command run for each case.
    Command,
}

/// Device under test.
#[derive(Debug, Clone)]
pub struct Dut {
    /// Backend.
    pub backend: BackendKind,
    /// Supplier, for the report.
    pub supplier: String,
    /// Camera model.
    pub model: String,
    /// Serial number.
    pub serial: String,
    /// Firmware version.
    pub firmware: String,
    /// Simulated camera parameters.
    pub camera: CameraConfig,
}

/// Shutter type of the simulated camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShutterKind {
    /// All rows exposed together.
    Global,
    /// Rows exposed one line time apart.
    Rolling,
}

/// Parameters of the simulated camera: timing, and either the ideal linear
/// response (`physical: None`) or a physical sensor with HDR captures, tone
/// curve and auto exposure.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraConfig {
    /// Profile name, e.g. "deegan2018-hdr3".
    pub name: String,
    /// What the profile says the camera is.
    pub description: String,
    /// Where the camera came from: the profile path, or "plan".
    pub source: String,
    /// Global or rolling shutter.
    pub shutter: ShutterKind,
    /// Sensor height in rows (>= 1).
    pub sensor_rows: u32,
    /// Sensor width in columns (>= 1).
    pub sensor_columns: u32,
    /// Line time in seconds (>= 0); 0 for a global shutter.
    pub line_time_s: f64,
    /// Exposure time in seconds (> 0, <= frame time); with auto exposure,
    /// the value before the run settles it.
    pub exposure_s: f64,
    /// Frame rate in frames per second (> 0).
    pub fps: f64,
    /// First PWM rising edge after the start of frame 0's exposure, seconds.
    pub pwm_delay_s: f64,
    /// Linear response: output DN per (cd/m^2 x second of exposure) (> 0).
    pub response_dn_per_cd_m2_s: f64,
    /// Output for no light, DN (>= 0).
    pub black_level_dn: f64,
    /// Largest output value, DN; the output clips here.
    pub full_scale_dn: f64,
    /// An ROI whose luma reaches this is flagged saturated, DN.
    pub saturation_dn: f64,
    /// The physical model, when the camera has a `[sensor]` table.
    pub physical: Option<PhysicalCamera>,
}

impl CameraConfig {
    /// Exposure timing of this camera: shutter model, exposure and frame
    /// rate. The one mapping from the plan's camera to the physics; the
    /// simulator and the analyses both use it.
    pub fn exposure_timing(&self) -> ledflicker_physics::Shutter {
        use ledflicker_physics::{Shutter, ShutterModel};
        Shutter {
            model: match self.shutter {
                ShutterKind::Global => ShutterModel::Global,
                ShutterKind::Rolling => ShutterModel::Rolling {
                    line_time_s: self.line_time_s,
                },
            },
            exposure_s: self.exposure_s,
            fps: self.fps,
        }
    }
}

/// A physical camera: sensor, HDR captures, merge, tone curve, auto exposure.
#[derive(Debug, Clone, PartialEq)]
pub struct PhysicalCamera {
    /// Sensor.
    pub sensor: ledflicker_physics::sensor::Sensor,
    /// Captures, at least one; the first is the reference (L).
    pub captures: Vec<ledflicker_physics::hdr::Capture>,
    /// Sequential or split-pixel.
    pub hdr_mode: ledflicker_physics::hdr::HdrMode,
    /// Merge rule.
    pub merge: ledflicker_physics::hdr::MergeRule,
    /// Tone curve and white point.
    pub tone: ledflicker_physics::hdr::Tone,
    /// Auto exposure; `None` keeps exposure and gains fixed.
    pub auto_exposure: Option<ledflicker_physics::ae::AutoExposure>,
    /// Analogue gain when auto exposure is off (>= 1).
    pub analog_gain: f64,
    /// Digital gain when auto exposure is off (> 0).
    pub digital_gain: f64,
}

/// Scene radiometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scene {
    /// Reflectance of the grey background (0..1]; 0.18 for 18% grey.
    pub background_reflectance: f64,
    /// Luminance of the LED while ON, cd/m^2 (>= 0).
    pub led_luminance_cd_m2: f64,
    /// Share of an LED ROI covered by the LED (0..1].
    pub led_fill: f64,
    /// Share of the auto-exposure metering area covered by the lamp (0..1).
    pub led_frame_fraction: f64,
    /// PWM clock error against the camera clock, parts per million: the
    /// actual frequency is `f (1 + ppm 1e-6)`.
    pub pwm_clock_offset_ppm: f64,
}

impl Scene {
    /// Luminance of a Lambertian background: `L = rho * E / pi` (cd/m^2).
    pub fn background_luminance_cd_m2(&self, illuminance_lux: f64) -> f64 {
        self.background_reflectance * illuminance_lux / std::f64::consts::PI
    }
}

/// Which figure the verdict is taken from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VerdictBasis {
    /// The worst case over PWM phase (conservative; default).
    WorstPhase,
    /// The trace as captured, at the plan's PWM phase.
    AsCaptured,
}

/// Pass limits on the metrics of one case; `None`: not checked. Every
/// metric is the verdict basis's figure (worst phase or as captured).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Limits {
    /// FDI (2018) must be >= this (Deegan 2018: the light appears OFF below 0.1).
    pub fdi_2018_min: Option<f64>,
    /// Percent Flicker must be <= this, percent.
    pub percent_flicker_max: Option<f64>,
    /// IEEE P2020 Flicker Modulation Index must be <= this (0..1).
    pub fmi_max: Option<f64>,
    /// IEEE P2020 Flicker Detection Index (share of PWM frames in which the
    /// light is told from OFF) must be >= this (0..1).
    pub fdi_p2020_min: Option<f64>,
    /// IEEE P2020 Modulation Mitigation Probability (share of PWM frames
    /// within the band around the reference) must be >= this (0..1).
    pub mmp_min: Option<f64>,
    /// Visibility index of the displayed flicker (1 = at the standard
    /// observer's threshold) must be <= this (>= 0); needs `[display]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visibility_max: Option<f64>,
    /// Chromaticity excursion of an LED ROI over the PWM segment (Δu′v′,
    /// CIE 1976) must be <= this (>= 0); needs `scene.led-chromaticity-xy`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delta_uv_max: Option<f64>,
}

impl Limits {
    /// `self`'s limits where set, else `base`'s.
    pub fn over(self, base: Limits) -> Limits {
        Limits {
            fdi_2018_min: self.fdi_2018_min.or(base.fdi_2018_min),
            percent_flicker_max: self.percent_flicker_max.or(base.percent_flicker_max),
            fmi_max: self.fmi_max.or(base.fmi_max),
            fdi_p2020_min: self.fdi_p2020_min.or(base.fdi_p2020_min),
            mmp_min: self.mmp_min.or(base.mmp_min),
            visibility_max: self.visibility_max.or(base.visibility_max),
            delta_uv_max: self.delta_uv_max.or(base.delta_uv_max),
        }
    }
}

/// Limits for one light level, over the global ones.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LevelLimits {
    /// The light level, lux (> 0); a level of `[light]` or a case's `light-lux`.
    pub light_lux: f64,
    /// Limits set for this level; unset ones come from `[thresholds]`.
    #[serde(flatten)]
    pub limits: Limits,
}

/// Pass criteria: the global [`Limits`] of `[thresholds]`, the overrides
/// per light level, the mitigation range and the verdict basis. A case
/// whose frequency lies outside the mitigation range is informational.
/// The global limits read as fields of the thresholds themselves
/// (`thresholds.fdi_2018_min`, through `Deref`), as results.json has them.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Thresholds {
    /// The limits set in `[thresholds]` itself, over the defaults; in
    /// results.json its keys are the thresholds' own.
    #[serde(flatten)]
    pub limits: Limits,
    /// Per light level overrides (`[[thresholds.light-level]]`), in plan order.
    pub light_levels: Vec<LevelLimits>,
    /// Lowest frequency (Hz) at which the camera claims mitigation.
    pub mitigation_min_hz: f64,
    /// Highest frequency (Hz) at which the camera claims mitigation.
    pub mitigation_max_hz: Option<f64>,
    /// Which figure the verdict uses.
    pub basis: VerdictBasis,
}

impl std::ops::Deref for Thresholds {
    type Target = Limits;
    fn deref(&self) -> &Limits {
        &self.limits
    }
}

impl Thresholds {
    /// The global limits of `[thresholds]`.
    pub fn global(&self) -> Limits {
        self.limits
    }

    /// The limits of a case at `light_lux` (`None`: unknown): the level's
    /// own limits over the global ones.
    pub fn limits_for(&self, light_lux: Option<f64>) -> Limits {
        let level = light_lux.and_then(|lux| self.light_levels.iter().find(|l| l.light_lux == lux));
        match level {
            Some(l) => l.limits.over(self.global()),
            None => self.global(),
        }
    }
}

/// One problem found in a plan, located by key and line.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// The file, when it is not the plan itself (e.g. a camera profile).
    pub file: Option<PathBuf>,
    /// Dotted key path, e.g. `grid.duty-cycles[1]`.
    pub key: String,
    /// 1-based line and column, when the key is in the file.
    pub location: Option<(usize, usize)>,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: Option<String>,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use spans::{MESSAGE_CHARS, clip};
        if let Some(file) = &self.file {
            write!(f, "{}: ", file.display())?;
        }
        match self.location {
            Some((line, col)) => write!(f, "line {line}, column {col}: ")?,
            None => write!(f, "(not in file): ")?,
        }
        // Keys and messages may quote the file (an unknown key, a ROI
        // name), which may be megabytes long: each is cut.
        write!(
            f,
            "`{}`: {}",
            clip(&self.key, MESSAGE_CHARS),
            clip(&self.message, MESSAGE_CHARS)
        )?;
        if let Some(hint) = &self.hint {
            write!(f, "\n    hint: {}", clip(hint, MESSAGE_CHARS))?;
        }
        Ok(())
    }
}

/// Why a plan could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The file could not be found or read.
    #[error("cannot read test plan `{path}`")]
    Read {
        /// Path tried.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A bare plan name matched no file.
    #[error(
        "test plan `{name}` not found (looked in {tried})\n    hint: give a path to a .toml file, or a plan name from test-plans/"
    )]
    NotFound {
        /// Name given.
        name: String,
        /// Places looked, comma separated.
        tried: String,
    },
    /// TOML syntax or type error (the first one; parsing stops there).
    #[error("invalid test plan `{path}`:\n{message}")]
    Syntax {
        /// Path of the plan.
        path: PathBuf,
        /// toml's message, with line and column.
        message: String,
    },
    /// One or more keys are unknown, missing or out of range.
    #[error("invalid test plan `{path}`: {} error{}\n{}", .diagnostics.len(), if .diagnostics.len() == 1 { "" } else { "s" }, render_diagnostics(.diagnostics))]
    Invalid {
        /// Path of the plan.
        path: PathBuf,
        /// Every problem found, in file order.
        diagnostics: Vec<Diagnostic>,
    },
}

fn render_diagnostics(diagnostics: &[Diagnostic]) -> String {
    diagnostics
        .iter()
        .map(|d| format!("  - {d}"))
        .collect::<Vec<_>>()
        .join("\n")
}

impl Plan {
    /// Where the plan was read from, for messages: its path, or its path in
    /// the source tree and "(built in)".
    pub fn source_label(&self) -> String {
        if self.built_in {
            shipped::label(&self.path.display().to_string())
        } else {
            self.path.display().to_string()
        }
    }

    /// The plausibility warnings, one `warning: FILE: line L, column C:
    /// `key`: message` (and its hint) each, ending with a newline; empty
    /// when there are none. FILE is the plan, or the camera profile that
    /// holds the key.
    pub fn warnings_text(&self) -> String {
        let label = self.source_label();
        self.warnings
            .iter()
            .map(|d| match d.file {
                Some(_) => format!("warning: {d}\n"),
                None => format!("warning: {label}: {d}\n"),
            })
            .collect()
    }
}

/// Reads the frame size (width, height in pixels) of the capture at a
/// path without decoding its frames: `None` when the capture has no
/// frames of its own (a CSV trace) or cannot be read now (the run then
/// says why). The capture readers, a layer above the plan, provide one
/// (`capture::frame_size`); with it, validation checks that a captured
/// plan's ROIs lie on every capture's frame.
/// Called from several threads at once: a plan's videos are probed together.
pub type FrameSize<'a> = &'a (dyn Fn(&Path) -> Option<(u32, u32)> + Sync);

/// Where a plan comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum PlanSource {
    /// A file.
    File(PathBuf),
    /// A plan built into the binary.
    BuiltIn(&'static shipped::Shipped),
}

/// Finds a plan: a path to a file, or a bare name (with or without `.toml`)
/// looked up in `./test-plans/` and then among the plans built into the
/// binary ([`shipped`]).
pub fn resolve_plan(arg: &str) -> Result<PlanSource, PlanError> {
    let direct = PathBuf::from(arg);
    // A file of any kind there by that name is what the user meant: a
    // FIFO or a device is refused when it is read, by name, not reported
    // missing. A folder of that name (say reports' `daylight/`) is not.
    if std::fs::metadata(&direct).is_ok_and(|m| !m.is_dir()) {
        return Ok(PlanSource::File(direct));
    }
    let bare = !arg.contains('/') && !arg.contains('\\');
    if !bare {
        let hint = shipped::hint_for_missing(&direct);
        return Err(PlanError::Read {
            path: direct,
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("no such file{hint}"),
            ),
        });
    }
    let names = if arg.ends_with(".toml") {
        vec![arg.to_string()]
    } else {
        vec![format!("{arg}.toml"), arg.to_string()]
    };
    let mut tried = vec![direct.display().to_string()];
    for name in &names {
        let candidate = Path::new("test-plans").join(name);
        if candidate.is_file() {
            return Ok(PlanSource::File(candidate));
        }
        tried.push(candidate.display().to_string());
    }
    if let Some(built_in) = shipped::plan(arg) {
        return Ok(PlanSource::BuiltIn(built_in));
    }
    tried.push("the built-in plans".to_string());
    Err(PlanError::NotFound {
        name: arg.to_string(),
        tried: tried.join(", "),
    })
}

/// Finds ([`resolve_plan`]), reads and validates a plan.
pub fn find_and_load(arg: &str) -> Result<Plan, PlanError> {
    find_and_load_inner(arg, None, ResourceLimits::default())
}

/// [`find_and_load`], also checking a captured plan's ROIs against the
/// frame size of each capture, read with `frame_size` (`validate` and
/// `plan` do, so that a ROI off the frame fails before a run), and its
/// work estimate against `limits` (`--max-memory`, `--max-report`).
pub fn find_and_load_with(
    arg: &str,
    frame_size: FrameSize<'_>,
    limits: ResourceLimits,
) -> Result<Plan, PlanError> {
    find_and_load_inner(arg, Some(frame_size), limits)
}

fn find_and_load_inner(
    arg: &str,
    frame_size: Option<FrameSize<'_>>,
    limits: ResourceLimits,
) -> Result<Plan, PlanError> {
    match resolve_plan(arg)? {
        PlanSource::File(path) => load_inner(&path, frame_size, limits),
        PlanSource::BuiltIn(built_in) => load_built_in_inner(built_in, frame_size, limits),
    }
}

/// Validates a plan built into the binary.
pub fn load_built_in(built_in: &shipped::Shipped) -> Result<Plan, PlanError> {
    load_built_in_inner(built_in, None, ResourceLimits::default())
}

fn load_built_in_inner(
    built_in: &shipped::Shipped,
    frame_size: Option<FrameSize<'_>>,
    limits: ResourceLimits,
) -> Result<Plan, PlanError> {
    let sha256 = crate::util::sha256_hex(built_in.text.as_bytes());
    // Its errors name it as built in: a capture it names "does not exist"
    // because the plan is not read from a folder that holds its files.
    let labelled = || PathBuf::from(shipped::label(built_in.path));
    let parsed = parse_inner(
        built_in.text,
        Path::new(built_in.path),
        sha256,
        Some(limits),
        frame_size,
    );
    let mut plan = parsed.map_err(|e| match e {
        PlanError::Invalid { diagnostics, .. } => PlanError::Invalid {
            path: labelled(),
            diagnostics,
        },
        PlanError::Syntax { message, .. } => PlanError::Syntax {
            path: labelled(),
            message,
        },
        other => other,
    })?;
    plan.built_in = true;
    Ok(plan)
}

/// Reads and validates the plan at `path`.
pub fn load(path: &Path) -> Result<Plan, PlanError> {
    load_inner(path, None, ResourceLimits::default())
}

/// [`load`], with the work estimate checked against `limits`.
pub fn load_within(path: &Path, limits: ResourceLimits) -> Result<Plan, PlanError> {
    load_inner(path, None, limits)
}

fn load_inner(
    path: &Path,
    frame_size: Option<FrameSize<'_>>,
    limits: ResourceLimits,
) -> Result<Plan, PlanError> {
    let bytes = crate::util::read_input(path).map_err(|source| PlanError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let text = String::from_utf8(bytes.clone()).map_err(|e| PlanError::Syntax {
        path: path.to_path_buf(),
        message: format!(
            "the file is not UTF-8 text (byte {})",
            e.utf8_error().valid_up_to()
        ),
    })?;
    let sha256 = crate::util::sha256_hex(&bytes);
    parse_inner(&text, path, sha256, Some(limits), frame_size)
}

/// Parses and validates plan text; `path` is used in messages only.
pub fn parse(text: &str, path: &Path, sha256: String) -> Result<Plan, PlanError> {
    parse_within(text, path, sha256, true)
}

/// [`parse`], with the work limits of a full run (report included) checked
/// only when `work_limits` is set. `ledflicker bench` runs cases without a
/// report and turns them off; physical bounds and unique ids always apply.
pub fn parse_within(
    text: &str,
    path: &Path,
    sha256: String,
    work_limits: bool,
) -> Result<Plan, PlanError> {
    parse_inner(
        text,
        path,
        sha256,
        work_limits.then(ResourceLimits::default),
        None,
    )
}

fn parse_inner(
    text: &str,
    path: &Path,
    sha256: String,
    work_limits: Option<ResourceLimits>,
    frame_size: Option<FrameSize<'_>>,
) -> Result<Plan, PlanError> {
    let syntax = |e: toml::de::Error| PlanError::Syntax {
        path: path.to_path_buf(),
        message: spans::syntax_message(text, &e),
    };
    let index = spans::SpanIndex::build(text).map_err(syntax)?;
    let deserializer = toml::Deserializer::parse(text).map_err(syntax)?;
    let mut unknown = Vec::new();
    let raw: raw::RawPlan =
        spans::deserialize_noting_unknown(deserializer, &mut unknown).map_err(syntax)?;
    let mut diags: Vec<Diagnostic> = unknown
        .into_iter()
        .map(|key| Diagnostic {
            file: None,
            location: index.location(&key),
            message: "unknown key".to_string(),
            hint: Some(spans::unknown_key_hint(&key)),
            key,
        })
        .collect();
    // A NUL in a string is refused: the results database records plan
    // strings, and PostgreSQL refuses a NUL in text where SQLite keeps
    // it, so the two would disagree on the same run.
    if let Ok(doc) = text.parse::<toml::Table>() {
        let mut with_nul = Vec::new();
        spans::nul_strings("", &toml::Value::Table(doc), &mut with_nul);
        diags.extend(with_nul.into_iter().map(|key| Diagnostic {
            file: None,
            location: index.location(&key),
            message: "the string holds a NUL character (\\u0000)".to_string(),
            hint: Some("remove it: no text field may hold NUL".to_string()),
            key,
        }));
    }
    let mut warnings = Vec::new();
    let checked = validate::Checked {
        diags: &mut diags,
        warnings: &mut warnings,
        frame_size,
    };
    let mut plan = validate::validate(raw, &index, checked, path, sha256);
    if let Some(p) = &plan
        && diags.is_empty()
    {
        bounds::check(p, &index, &mut diags, work_limits);
    }
    diags.sort_by_key(|d| d.location.unwrap_or((usize::MAX, 0)));
    warnings.sort_by_key(|d| d.location.unwrap_or((usize::MAX, 0)));
    if let Some(p) = &mut plan {
        p.warnings = warnings;
    }
    match plan {
        Some(plan) if diags.is_empty() => Ok(plan),
        _ => Err(PlanError::Invalid {
            path: path.to_path_buf(),
            diagnostics: diags,
        }),
    }
}
