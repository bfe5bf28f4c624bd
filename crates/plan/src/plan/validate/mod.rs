//! Raw plan -> validated [`Plan`]: defaults, ranges and cross-checks, one
//! function per TOML table, each in its own module:
//!
//! - `meta`: `format-version`, `[plan]`, `[sequence]`;
//! - `grid`: `[light]`, `[grid]`;
//! - `capture`: `[capture]`, `[[case]]` (captured and command backends);
//! - `p2020`: `[p2020]`; `display`: `[display]`;
//! - `dut`: `[dut]` and camera profiles; `camera`: `[dut.camera]`;
//!   `sensor`: its `[sensor]`, `[[capture]]`, `[hdr]`, `[tone]` and gains;
//!   `ae`: its `[auto-exposure]`;
//! - `roi`: `[[roi]]`; `scene`: `[scene]`; `thresholds`: `[thresholds]`;
//!   `source`: `[source]` (the command backend's SCPI light source);
//! - `report`: `[report]` (also of a report profile file).
//!
//! Every check pushes a [`Diagnostic`] into the shared collector
//! (`plan::check::Checker`) and carries on, so the user sees all the
//! problems of a file in one run. The tables are checked in a fixed order,
//! which is the order of diagnostics on the same line. Plausibility
//! warnings (a valid value most likely in another unit) are pushed the same
//! way into a list of their own, by the module of the table that holds
//! the key.

mod ae;
mod camera;
mod capture;
mod colour;
mod display;
mod dut;
mod grid;
mod meta;
mod p2020;
mod recorder;
mod report;
mod roi;
mod scene;
mod sensor;
mod source;
mod thresholds;

use std::path::Path;

pub(crate) use report::report_table;

use super::check::Checker;
use super::raw::{RawCaptureTable, RawCaseEntry, RawDut, RawGrid, RawLight, RawPlan};
use super::spans::SpanIndex;
use super::{CaptureConfig, Diagnostic, FrameSize, MAX_CASES, Plan, Sequence};

/// Longest capture the simulator will make for one case, in frames.
const MAX_FRAMES: f64 = 10_000_000.0;

/// Where validation reports, and how it reads a capture's frame size.
pub(super) struct Checked<'a> {
    /// Errors: the plan is invalid when one is pushed.
    pub diags: &'a mut Vec<Diagnostic>,
    /// Plausibility warnings.
    pub warnings: &'a mut Vec<Diagnostic>,
    /// Reads a capture's frame size; `None`: captures are not opened.
    pub frame_size: Option<FrameSize<'a>>,
}

/// Validates `raw`, pushing every problem into `out.diags` and every
/// plausibility warning into `out.warnings`. Returns `None` when something
/// required is missing or invalid.
pub(super) fn validate(
    mut raw: RawPlan,
    index: &SpanIndex,
    out: Checked<'_>,
    path: &Path,
    sha256: String,
) -> Option<Plan> {
    let mut c = Checker::new(index, out.diags, out.warnings);
    let role = Role::of(raw.dut.as_ref());
    let raw_colour = take_colour(&mut raw, role.captured);
    meta::format_version(&mut c, raw.format_version);
    let meta = meta::plan_table(&mut c, raw.plan);
    let (on_s, off_s, pwm_s) = meta::sequence_table(&mut c, raw.sequence);
    // The default ROI sits in the middle of the camera's sensor; a plan
    // whose frames come from files or a rig has a sensor only when it
    // describes the camera.
    let has_sensor = role.is_sim
        || raw
            .dut
            .as_ref()
            .is_some_and(|d| d.camera.is_some() || d.camera_profile.is_some());
    let (light, grid) = (raw.light, raw.grid);
    let recorder_given = raw.recorder.is_some();
    let (mut capture, capture_failed) = case_sources(
        &mut c,
        role,
        (light.is_some(), grid.is_some()),
        (raw.capture, raw.case, recorder_given),
        path,
        pwm_s,
    );
    let p2020 = p2020::p2020_options(&mut c, raw.p2020);
    let command = !role.is_sim && !role.captured;
    let source_given = raw.source.is_some();
    let (source, source_failed) = source::source_table(&mut c, raw.source, command);
    let (levels, freqs, duties) = conditions(&mut c, light, grid, role.captured, pwm_s);
    let dut = dut::dut_table(&mut c, raw.dut, role.is_sim, path);
    let (recorder, recorder_failed) = recorder::recorder_table(
        &mut c,
        raw.recorder,
        recorder::RecorderContext {
            command,
            source_given,
            source: source.as_ref(),
            sequence: match (on_s, off_s, pwm_s) {
                (Some(on_s), Some(off_s), Some(pwm_s)) => Some(Sequence { on_s, off_s, pwm_s }),
                _ => None,
            },
            fps: dut.as_ref().map(|d| d.camera.fps),
        },
    );
    // The recorder is the command the backend runs for each case.
    if let (Some(rec), Some(cmd)) = (&recorder, capture.as_mut().and_then(|c| c.command.as_mut())) {
        cmd.argv = rec.argv.clone();
    }
    let rois = roi::rois(&mut c, raw.roi, dut.as_ref().map(|d| &d.camera), has_sensor);
    if let (true, Some(read), Some(cap), Some(rois)) =
        (role.captured, out.frame_size, &capture, &rois)
    {
        roi::fit_captures(&mut c, rois, &cap.cases, read);
    }
    let scene = scene::scene_table(&mut c, raw.scene);
    let camera = dut.as_ref().filter(|_| has_sensor).map(|d| &d.camera);
    let display = display::display(&mut c, raw.display, camera);
    let known_lux: Option<Vec<f64>> = if role.captured {
        capture
            .as_ref()
            .map(|cap| cap.cases.iter().filter_map(|k| k.light_lux).collect())
    } else {
        levels.clone()
    };
    let thresholds = thresholds::thresholds(&mut c, raw.thresholds, known_lux.as_deref());
    let report = report::report_table(&mut c, raw.report, path);
    let sequence = Sequence {
        on_s: on_s?,
        off_s: off_s?,
        pwm_s: pwm_s?,
    };
    let dut = dut?;
    if capture_failed || source_failed || recorder_failed {
        return None;
    }
    sequence_fits(&mut c, &sequence, dut.camera.fps)?;
    let colour = colour::colour(&mut c, raw_colour, role.planes(&dut, capture.as_ref()));
    let (thresholds, display) = (thresholds?, display?);
    let colour = colour?;
    display::limit_needs_display(&mut c, &thresholds, display.as_ref())?;
    colour::limit_needs_colour(&mut c, &thresholds, colour.as_ref())?;
    colour::black_level_needs_colour(&mut c, capture.as_ref(), colour.as_ref())?;
    Some(Plan {
        id: meta.id?,
        title: meta.title?,
        standard: meta.standard,
        description: meta.description,
        lab: meta.lab,
        seed: meta.seed,
        path: path.to_path_buf(),
        sha256,
        built_in: false,
        sequence,
        light_levels_lux: levels?,
        frequencies_hz: freqs?,
        duty_cycles: duties?,
        rois: rois?,
        dut,
        scene: scene?,
        thresholds,
        capture,
        p2020: p2020?,
        report: report?,
        display,
        colour,
        source,
        recorder,
        warnings: Vec::new(),
    })
}

/// The colour keys of `[scene]` and `[dut.camera]`, taken out of `raw`
/// before those tables are validated. A captured plan's `[dut.camera]`
/// that held nothing else goes with them: such a plan describes no
/// camera, only its colour matrix.
fn take_colour(raw: &mut RawPlan, captured: bool) -> colour::RawColour {
    let scene = raw.scene.as_mut();
    let dut = raw.dut.as_mut();
    let (led_xy, signal, dies) = scene.map_or((None, None, Vec::new()), |s| {
        (
            s.led_chromaticity_xy.take(),
            s.signal_colour.take(),
            std::mem::take(&mut s.led_die),
        )
    });
    let (mut offsets_ms, mut camera_to_xyz) = (None, None);
    if let Some(d) = dut
        && let Some(c) = d.camera.as_mut()
    {
        offsets_ms = c.colour_plane_offset_ms.take();
        camera_to_xyz = c.camera_to_xyz.take();
        if captured && (offsets_ms.is_some() || camera_to_xyz.is_some()) && c.is_empty() {
            d.camera = None;
        }
    }
    colour::RawColour {
        led_xy,
        signal,
        offsets_ms,
        camera_to_xyz,
        dies,
    }
}

/// Which tables the backend named in `[dut]` reads.
#[derive(Debug, Clone, Copy)]
struct Role {
    /// `backend = "captured"`: cases from `[[case]]`, not `[light]` and `[grid]`.
    captured: bool,
    /// The simulator, or an unknown backend (reported under `[dut]` and
    /// checked as a simulator): no `[capture]` or `[[case]]`.
    is_sim: bool,
}

impl Role {
    fn of(dut: Option<&RawDut>) -> Role {
        let backend = dut.and_then(|d| d.backend.as_deref());
        Role {
            captured: backend == Some("captured"),
            is_sim: !matches!(backend, Some("captured" | "command")),
        }
    }

    /// Where the plan's colour planes would come from.
    fn planes(self, dut: &super::Dut, capture: Option<&CaptureConfig>) -> colour::Planes {
        match (self.is_sim, self.captured, capture) {
            (true, _, _) if dut.camera.physical.is_none() => colour::Planes::Simulated,
            // A rig's recording is read as a captured plan's is.
            (false, _, Some(cap)) => {
                colour::Planes::Captured(cap.video_decode, cap.colour_transfer)
            }
            _ => colour::Planes::Unavailable,
        }
    }
}

/// The tables that say where the cases come from: refuses `[light]` and
/// `[grid]` (`present`) in a captured plan and `[capture]` and `[[case]]`
/// in a simulator plan, and validates the latter two otherwise (`pwm_s`,
/// the PWM segment's length, bounds the cases' frequencies). The flag is
/// true when they were given and are invalid.
fn case_sources(
    c: &mut Checker<'_>,
    role: Role,
    present: (bool, bool),
    (raw_capture, cases, recorder): (Option<RawCaptureTable>, Vec<RawCaseEntry>, bool),
    path: &Path,
    pwm_s: Option<f64>,
) -> (Option<CaptureConfig>, bool) {
    for (present, key) in [(present.0, "light"), (present.1, "grid")] {
        if role.captured && present {
            c.error(
                key,
                "a captured plan lists its cases in [[case]], not in [light] and [grid]",
                Some("give each [[case]] its light-lux, frequency-hz and duty-cycle"),
            );
        }
    }
    if !role.is_sim {
        let cap = capture::capture_config(
            c,
            raw_capture,
            cases,
            (role.captured, recorder),
            path,
            pwm_s,
        );
        let failed = cap.is_none();
        return (cap, failed);
    }
    for (present, key) in [
        (raw_capture.is_some(), "capture"),
        (!cases.is_empty(), "case"),
    ] {
        if present {
            c.error(
                key,
                "only the captured and command backends read this table",
                Some("set [dut] backend = \"captured\" or \"command\", or remove it"),
            );
        }
    }
    (None, false)
}

/// Light levels, frequencies and duty cycles of the grid; all empty for a
/// captured plan, whose cases come from `[[case]]`. The grid may expand to
/// at most [`MAX_CASES`] cases.
type Conditions = (Option<Vec<f64>>, Option<Vec<f64>>, Option<Vec<f64>>);

fn conditions(
    c: &mut Checker<'_>,
    light: Option<RawLight>,
    grid: Option<RawGrid>,
    captured: bool,
    pwm_s: Option<f64>,
) -> Conditions {
    if captured {
        return (Some(Vec::new()), Some(Vec::new()), Some(Vec::new()));
    }
    let levels = grid::light_table(c, light);
    let (freqs, duties) = grid::grid_table(c, grid, pwm_s);
    if let (Some(l), Some(f), Some(d)) = (&levels, &freqs, &duties) {
        let n = l.len() * f.len() * d.len();
        if n > MAX_CASES {
            c.error(
                "grid",
                format!("the plan expands to {n} cases; at most {MAX_CASES}"),
                Some("use coarser grids or split the plan"),
            );
        }
    }
    (levels, freqs, duties)
}

/// The sequence at the camera's frame rate `fps`: at most [`MAX_FRAMES`]
/// frames, and at least 2 in the PWM segment.
fn sequence_fits(c: &mut Checker<'_>, sequence: &Sequence, fps: f64) -> Option<()> {
    let total_frames = (sequence.on_s + sequence.off_s + sequence.pwm_s) * fps;
    if total_frames > MAX_FRAMES {
        c.error(
            "sequence.pwm-s",
            format!("the sequence is {total_frames:.0} frames long; at most {MAX_FRAMES:.0}"),
            Some("shorten the PWM segment"),
        );
        return None;
    }
    if (sequence.pwm_s * fps).round() < 2.0 {
        c.error(
            "sequence.pwm-s",
            "the PWM segment holds fewer than 2 frames",
            Some("make pwm-s at least 2 frame times long"),
        );
        return None;
    }
    Some(())
}
