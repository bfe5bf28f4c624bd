//! Raw plan -> validated [`Plan`]: defaults, ranges and cross-checks.
//!
//! Every check pushes a [`Diagnostic`] and carries on, so the user sees all
//! the problems of a file in one run.

use std::path::Path;

use std::path::PathBuf;

use super::raw::{RawCamera, RawPlan, RawProfile, RawRange};
use super::spans::SpanIndex;
use super::{
    BackendKind, CameraConfig, Diagnostic, Dut, MAX_CASES, PhysicalCamera, Plan, Roi, RoiKind,
    Scene, Sequence, ShutterKind,
};
use crate::physics::ae::AutoExposure;
use crate::physics::hdr::{Capture, CaptureExposure, HdrMode, MergeRule, Tone, ToneCurve};
use crate::physics::sensor::Sensor;

/// Default ROI size from Deegan 2018: 100 px wide, 2 rows high (a taller ROI
/// mixes ON and OFF rows of a rolling shutter).
const DEFAULT_ROI_WIDTH_PX: u32 = 100;
const DEFAULT_ROI_HEIGHT_PX: u32 = 2;
/// Largest grid along one axis.
const MAX_GRID_POINTS: usize = 10_000;
/// Longest capture the simulator will make for one case, in frames.
const MAX_FRAMES: f64 = 10_000_000.0;

pub(super) struct Checker<'a> {
    index: &'a SpanIndex,
    diags: &'a mut Vec<Diagnostic>,
    /// Set while checking a file other than the plan (a camera profile).
    file: Option<PathBuf>,
}

impl Checker<'_> {
    pub(super) fn error(&mut self, key: &str, message: impl Into<String>, hint: Option<&str>) {
        // A key that is absent from the file is reported at its table.
        let location = self.index.location(key).or_else(|| {
            let mut k = key;
            while let Some(i) = k.rfind(['.', '[']) {
                k = &k[..i];
                if let Some(loc) = self.index.location(k) {
                    return Some(loc);
                }
            }
            None
        });
        self.diags.push(Diagnostic {
            file: self.file.clone(),
            key: key.to_string(),
            location,
            message: message.into(),
            hint: hint.map(str::to_string),
        });
    }

    pub(super) fn required<T>(&mut self, value: Option<T>, key: &str, hint: &str) -> Option<T> {
        if value.is_none() {
            self.error(key, "missing required key", Some(hint));
        }
        value
    }

    /// `value` must be finite and > 0.
    pub(super) fn positive(&mut self, value: f64, key: &str, hint: &str) -> Option<f64> {
        if value.is_finite() && value > 0.0 {
            Some(value)
        } else {
            self.error(key, format!("must be > 0, got {value}"), Some(hint));
            None
        }
    }

    /// `value` must be finite and >= 0.
    pub(super) fn non_negative(&mut self, value: f64, key: &str, hint: &str) -> Option<f64> {
        if value.is_finite() && value >= 0.0 {
            Some(value)
        } else {
            self.error(key, format!("must be >= 0, got {value}"), Some(hint));
            None
        }
    }

    pub(super) fn duty(&mut self, value: f64, key: &str) -> Option<f64> {
        if value.is_finite() && value > 0.0 && value <= 1.0 {
            Some(value)
        } else {
            self.error(
                key,
                format!("duty cycle {value} is outside (0, 1]"),
                Some("a duty cycle is a fraction: write 0.05 for 5% and 1.0 for steady ON"),
            );
            None
        }
    }

    pub(super) fn pixels(&mut self, value: i64, key: &str, min: i64) -> Option<u32> {
        if value >= min && value <= u32::MAX as i64 {
            Some(value as u32)
        } else {
            self.error(
                key,
                format!("must be an integer >= {min}, got {value}"),
                Some("pixel coordinates are 0-based columns and rows of the sensor"),
            );
            None
        }
    }

    /// A grid given either as an explicit list or as a start/stop/step range.
    fn grid(
        &mut self,
        list: Option<Vec<f64>>,
        range: Option<RawRange>,
        list_key: &str,
        range_key: &str,
        check: &mut dyn FnMut(&mut Self, f64, &str) -> Option<f64>,
    ) -> Option<Vec<f64>> {
        let values = match (list, range) {
            (Some(_), Some(_)) => {
                self.error(
                    range_key,
                    format!("give either `{list_key}` or `{range_key}`, not both"),
                    Some("remove one of the two"),
                );
                return None;
            }
            (None, None) => {
                self.error(
                    list_key,
                    "missing required key",
                    Some(&format!(
                        "give a list, `{list_key} = [...]`, or a range, `{range_key} = {{ start = .., stop = .., step = .. }}`"
                    )),
                );
                return None;
            }
            (Some(list), None) => {
                if list.is_empty() {
                    self.error(
                        list_key,
                        "the grid is empty",
                        Some("list at least one value"),
                    );
                    return None;
                }
                if list.len() > MAX_GRID_POINTS {
                    self.error(
                        list_key,
                        format!("{} values; at most {MAX_GRID_POINTS}", list.len()),
                        Some("split the plan"),
                    );
                    return None;
                }
                let mut ok = Vec::with_capacity(list.len());
                for (i, v) in list.iter().enumerate() {
                    ok.push(check(self, *v, &format!("{list_key}[{i}]")));
                }
                ok.into_iter().collect::<Option<Vec<f64>>>()?
            }
            (None, Some(range)) => self.range(range, range_key, check)?,
        };
        for (i, v) in values.iter().enumerate() {
            if values[..i].contains(v) {
                self.error(
                    &format!("{list_key}[{i}]"),
                    format!("{v} appears twice in the grid"),
                    Some("each grid value makes its own cases; list it once"),
                );
                return None;
            }
        }
        Some(values)
    }

    fn range(
        &mut self,
        range: RawRange,
        key: &str,
        check: &mut dyn FnMut(&mut Self, f64, &str) -> Option<f64>,
    ) -> Option<Vec<f64>> {
        let hint =
            "a range is { start = .., stop = .., step = .. } with stop >= start and step > 0";
        let start = self.required(range.start, &format!("{key}.start"), hint);
        let stop = self.required(range.stop, &format!("{key}.stop"), hint);
        let step = self.required(range.step, &format!("{key}.step"), hint);
        let (start, stop, step) = (start?, stop?, step?);
        let start = check(self, start, &format!("{key}.start"))?;
        let stop = check(self, stop, &format!("{key}.stop"))?;
        let step = self.positive(step, &format!("{key}.step"), hint)?;
        if stop < start {
            self.error(
                &format!("{key}.stop"),
                format!("stop {stop} is below start {start}; the grid is empty"),
                Some(hint),
            );
            return None;
        }
        // Count points by division, not by repeated addition; a stop within
        // 1e-9 steps of a grid point is included.
        let count = ((stop - start) / step + 1e-9).floor() + 1.0;
        if count > MAX_GRID_POINTS as f64 {
            self.error(
                &format!("{key}.step"),
                format!("the range has {count} points; at most {MAX_GRID_POINTS}"),
                Some("use a larger step"),
            );
            return None;
        }
        Some(
            (0..count as usize)
                .map(|i| start + i as f64 * step)
                .collect(),
        )
    }
}

/// Validates `raw`, pushing every problem into `diags`. Returns `None` when
/// something required is missing or invalid.
pub(super) fn validate(
    mut raw: RawPlan,
    index: &SpanIndex,
    diags: &mut Vec<Diagnostic>,
    path: &Path,
    sha256: String,
) -> Option<Plan> {
    let mut c = Checker {
        index,
        diags,
        file: None,
    };

    if let Some(v) = raw.format_version
        && !(1..=2).contains(&v)
    {
        c.error(
            "format-version",
            format!("unsupported plan format version {v}"),
            Some("this ledflicker reads format-version = 1 or 2 (see docs/changes.md)"),
        );
    }

    // [plan]
    let meta = c.required(raw.plan, "plan", "add a [plan] table with id and title");
    let (mut id, mut title, mut standard, mut description, mut lab, mut seed) = (
        None,
        None,
        String::new(),
        String::new(),
        String::new(),
        0u64,
    );
    if let Some(meta) = meta {
        id = c.required(meta.id, "plan.id", "e.g. id = \"daylight\"");
        if let Some(v) = &id
            && (v.is_empty()
                || !v.chars().all(|ch| {
                    ch.is_ascii_lowercase() || ch.is_ascii_digit() || ch == '-' || ch == '_'
                }))
        {
            c.error(
                "plan.id",
                format!("id `{v}` must be non-empty lowercase letters, digits, `-` or `_`"),
                Some("the id names the report directory, e.g. id = \"daylight-2000lux\""),
            );
            id = None;
        }
        title = c.required(
            meta.title,
            "plan.title",
            "a human title for the report cover",
        );
        standard = meta
            .standard
            .unwrap_or_else(|| "Deegan 2018 (IS&T EI AVM-146)".to_string());
        description = meta.description.unwrap_or_default();
        lab = meta.lab.unwrap_or_default();
        seed = match meta.seed {
            Some(s) if s >= 0 => s as u64,
            Some(s) => {
                c.error(
                    "plan.seed",
                    format!("must be >= 0, got {s}"),
                    Some("any non-negative integer"),
                );
                0
            }
            None => 0,
        };
    }

    // [sequence]
    let hint_seq = "durations in seconds; the paper uses 2 s ON, 2 s OFF, 60 s PWM";
    let (mut on_s, mut off_s, mut pwm_s) = (Some(2.0), Some(2.0), Some(60.0));
    if let Some(s) = raw.sequence {
        if let Some(v) = s.on_s {
            on_s = c.non_negative(v, "sequence.on-s", hint_seq);
        }
        if let Some(v) = s.off_s {
            off_s = c.non_negative(v, "sequence.off-s", hint_seq);
        }
        if let Some(v) = s.pwm_s {
            pwm_s = c.positive(v, "sequence.pwm-s", hint_seq);
        }
    }

    // A captured plan takes its cases from [[case]], not from [light] and [grid].
    let captured = raw
        .dut
        .as_ref()
        .is_some_and(|d| d.backend.as_deref() == Some("captured"));
    // An unknown backend is reported under [dut] and checked as a simulator.
    let is_sim = !raw
        .dut
        .as_ref()
        .is_some_and(|d| matches!(d.backend.as_deref(), Some("captured" | "command")));
    for (present, key) in [(raw.light.is_some(), "light"), (raw.grid.is_some(), "grid")] {
        if captured && present {
            c.error(
                key,
                "a captured plan lists its cases in [[case]], not in [light] and [grid]",
                Some("give each [[case]] its light-lux, frequency-hz and duty-cycle"),
            );
        }
    }
    let mut capture_failed = false;
    let capture = if is_sim {
        for (present, key) in [
            (raw.capture.is_some(), "capture"),
            (!raw.case.is_empty(), "case"),
        ] {
            if present {
                c.error(
                    key,
                    "only the captured and command backends read this table",
                    Some("set [dut] backend = \"captured\" or \"command\", or remove it"),
                );
            }
        }
        None
    } else {
        let cap = super::capture::capture_config(
            &mut c,
            raw.capture,
            std::mem::take(&mut raw.case),
            captured,
            path,
        );
        capture_failed = cap.is_none();
        cap
    };
    let p2020 = super::capture::p2020_options(&mut c, raw.p2020);

    // [light]
    let light = if captured {
        None
    } else {
        c.required(raw.light, "light", "add [light] with levels-lux = [2000.0]")
    };
    let levels = light.and_then(|l| {
        let list = c.required(
            l.levels_lux,
            "light.levels-lux",
            "e.g. levels-lux = [40.0, 2000.0]",
        )?;
        c.grid(
            Some(list),
            None,
            "light.levels-lux",
            "light.levels-lux",
            &mut |c, v, k| {
                c.positive(
                    v,
                    k,
                    "illuminance in lux: 40 for low light, 2000 for daylight",
                )
            },
        )
    });

    // [grid]
    let grid = if captured {
        None
    } else {
        c.required(
            raw.grid,
            "grid",
            "add [grid] with frequencies-hz and duty-cycles",
        )
    };
    let (levels, grid_ok) = if captured {
        (Some(Vec::new()), true)
    } else {
        (levels, true)
    };
    let (mut freqs, mut duties) = (None, None);
    if let Some(g) = grid {
        freqs = c.grid(
            g.frequencies_hz,
            g.frequency_range_hz,
            "grid.frequencies-hz",
            "grid.frequency-range-hz",
            &mut |c, v, k| c.positive(v, k, "PWM frequency in Hz, e.g. 90.0"),
        );
        duties = c.grid(
            g.duty_cycles,
            g.duty_cycle_range,
            "grid.duty-cycles",
            "grid.duty-cycle-range",
            &mut |c, v, k| c.duty(v, k),
        );
    }
    if captured && grid_ok {
        freqs = Some(Vec::new());
        duties = Some(Vec::new());
    }
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

    // [dut]
    let dut = c.required(
        raw.dut,
        "dut",
        "add [dut] with backend = \"simulator\" and [dut.camera]",
    );
    let mut dut_v = None;
    if let Some(d) = dut {
        let backend = match d.backend.as_deref() {
            None | Some("simulator") => Some(BackendKind::Simulator),
            Some("captured") => Some(BackendKind::Captured),
            Some("command") => Some(BackendKind::Command),
            Some(other) => {
                c.error(
                    "dut.backend",
                    format!("unknown backend `{other}`"),
                    Some("use backend = \"simulator\", \"captured\" or \"command\""),
                );
                None
            }
        };
        let camera = match (d.camera_profile, d.camera, is_sim) {
            (Some(_), Some(_), _) => {
                c.error(
                    "dut.camera-profile",
                    "give either `camera-profile` or a [dut.camera] table, not both",
                    Some("copy the profile and edit it to change a parameter"),
                );
                None
            }
            (Some(profile), None, _) => load_profile(&mut c, &profile, path),
            (None, Some(cam), _) => camera_config(&mut c, cam, "dut.camera", "plan"),
            // Captured data has no simulated camera; ROIs are checked
            // against each capture's frame size when it is read.
            (None, None, false) => Some(super::capture::no_camera()),
            (None, None, true) => {
                c.error(
                    "dut.camera",
                    "missing camera",
                    Some("add camera-profile = \"reference-data/cameras/<name>.toml\" or a [dut.camera] table"),
                );
                None
            }
        };
        if let (Some(backend), Some(camera)) = (backend, camera) {
            dut_v = Some(Dut {
                backend,
                supplier: d.supplier.unwrap_or_default(),
                model: d.model.unwrap_or_default(),
                serial: d.serial.unwrap_or_default(),
                firmware: d.firmware.unwrap_or_default(),
                camera,
            });
        }
    }

    // [[roi]]
    let rois = rois(&mut c, raw.roi, dut_v.as_ref().map(|d| &d.camera));

    // [scene]
    let hint_scene = "see docs/plan-format.md, [scene]";
    let mut scene = Some(Scene {
        background_reflectance: 0.18,
        led_luminance_cd_m2: 1000.0,
        led_fill: 1.0,
        led_frame_fraction: 0.0,
        pwm_clock_offset_ppm: 0.0,
    });
    if let Some(s) = raw.scene {
        let mut sc = scene.take()?;
        let mut ok = true;
        if let Some(v) = s.background_reflectance {
            match c.non_negative(v, "scene.background-reflectance", hint_scene) {
                Some(v) if v <= 1.0 => sc.background_reflectance = v,
                Some(v) => {
                    c.error(
                        "scene.background-reflectance",
                        format!("reflectance {v} is above 1"),
                        Some("a fraction: 0.18 for 18% grey"),
                    );
                    ok = false;
                }
                None => ok = false,
            }
        }
        if let Some(v) = s.led_luminance_cd_m2 {
            match c.non_negative(v, "scene.led-luminance-cd-m2", hint_scene) {
                Some(v) => sc.led_luminance_cd_m2 = v,
                None => ok = false,
            }
        }
        if let Some(v) = s.led_fill {
            match c.positive(v, "scene.led-fill", "a fraction of the ROI in (0, 1]") {
                Some(v) if v <= 1.0 => sc.led_fill = v,
                Some(v) => {
                    c.error(
                        "scene.led-fill",
                        format!("{v} is above 1"),
                        Some("a fraction of the ROI in (0, 1]"),
                    );
                    ok = false;
                }
                None => ok = false,
            }
        }
        if let Some(v) = s.led_frame_fraction {
            match c.non_negative(
                v,
                "scene.led-frame-fraction",
                "a fraction of the metering area in [0, 1)",
            ) {
                Some(v) if v < 1.0 => sc.led_frame_fraction = v,
                Some(v) => {
                    c.error(
                        "scene.led-frame-fraction",
                        format!("{v} is not below 1"),
                        Some("a fraction of the metering area in [0, 1)"),
                    );
                    ok = false;
                }
                None => ok = false,
            }
        }
        if let Some(v) = s.pwm_clock_offset_ppm {
            if v.is_finite() && v.abs() < 1e5 {
                sc.pwm_clock_offset_ppm = v;
            } else {
                c.error(
                    "scene.pwm-clock-offset-ppm",
                    format!("{v} ppm is out of range"),
                    Some("crystal clocks differ by tens of ppm; |ppm| must be < 100000"),
                );
                ok = false;
            }
        }
        scene = ok.then_some(sc);
    }

    // [thresholds]
    let known_lux: Option<Vec<f64>> = if captured {
        capture
            .as_ref()
            .map(|cap| cap.cases.iter().filter_map(|k| k.light_lux).collect())
    } else {
        levels.clone()
    };
    let thresholds = super::thresholds::thresholds(&mut c, raw.thresholds, known_lux.as_deref());

    let sequence = Sequence {
        on_s: on_s?,
        off_s: off_s?,
        pwm_s: pwm_s?,
    };
    let dut = dut_v?;
    if capture_failed {
        return None;
    }
    let total_frames = (sequence.on_s + sequence.off_s + sequence.pwm_s) * dut.camera.fps;
    if total_frames > MAX_FRAMES {
        c.error(
            "sequence.pwm-s",
            format!("the sequence is {total_frames:.0} frames long; at most {MAX_FRAMES:.0}"),
            Some("shorten the PWM segment"),
        );
        return None;
    }
    if (sequence.pwm_s * dut.camera.fps).round() < 2.0 {
        c.error(
            "sequence.pwm-s",
            "the PWM segment holds fewer than 2 frames",
            Some("make pwm-s at least 2 frame times long"),
        );
        return None;
    }
    Some(Plan {
        id: id?,
        title: title?,
        standard,
        description,
        lab,
        seed,
        path: path.to_path_buf(),
        sha256,
        sequence,
        light_levels_lux: levels?,
        frequencies_hz: freqs?,
        duty_cycles: duties?,
        rois: rois?,
        dut,
        scene: scene?,
        thresholds: thresholds?,
        capture,
        p2020: p2020?,
    })
}

/// Reads and checks a camera profile file, `[camera]` with the keys of
/// `[dut.camera]`. Relative paths are tried from the plan's directory, the
/// current directory and this source tree.
fn load_profile(c: &mut Checker<'_>, name: &str, plan_path: &Path) -> Option<CameraConfig> {
    let candidates = [
        plan_path.parent().unwrap_or(Path::new(".")).join(name),
        PathBuf::from(name),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(name),
    ];
    let Some(path) = candidates.iter().find(|p| p.is_file()) else {
        c.error(
            "dut.camera-profile",
            format!("camera profile `{name}` not found"),
            Some("give a path relative to the plan, e.g. \"../reference-data/cameras/ideal-global.toml\""),
        );
        return None;
    };
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => {
            c.error(
                "dut.camera-profile",
                format!("cannot read `{}`: {e}", path.display()),
                None,
            );
            return None;
        }
    };
    let parsed = SpanIndex::build(&text).and_then(|index| {
        let de = toml::Deserializer::parse(&text)?;
        let mut unknown = Vec::new();
        let raw: RawProfile =
            serde_ignored::deserialize(de, |p| unknown.push(super::spans::path_string(&p)))?;
        Ok((index, raw, unknown))
    });
    let (index, raw, unknown) = match parsed {
        Ok(x) => x,
        Err(e) => {
            c.error(
                "dut.camera-profile",
                profile_error(path, &text, &e),
                Some("a camera profile is a TOML file with one [camera] table (reference-data/cameras/)"),
            );
            return None;
        }
    };
    if raw.camera.is_none() {
        // Not a profile at all: name it, but echo none of its keys.
        c.error(
            "dut.camera-profile",
            format!(
                "`{}` is not a camera profile (no [camera] table)",
                path.display()
            ),
            Some(
                "a camera profile is a TOML file with one [camera] table (reference-data/cameras/)",
            ),
        );
        return None;
    }
    let mut pc = Checker {
        index: &index,
        diags: c.diags,
        file: Some(path.clone()),
    };
    for key in unknown {
        let hint = super::spans::unknown_key_hint(&key);
        pc.error(&key, "unknown key", Some(&hint));
    }
    let Some(cam) = raw.camera else {
        pc.error(
            "camera",
            "missing [camera] table",
            Some("a profile holds one [camera] table"),
        );
        return None;
    };
    camera_config(&mut pc, cam, "camera", &path.display().to_string())
}

/// A TOML error in a camera profile, located by line and column, with
/// every quoted fragment of the file left out: the file named may be any
/// file (issue 10), and its contents must never reach the terminal or a log.
fn profile_error(path: &Path, text: &str, e: &toml::de::Error) -> String {
    let mut message = String::new();
    let mut quoted = None;
    for ch in e.message().trim_end().chars() {
        match (quoted, ch) {
            (None, '"' | '`' | '\'') => {
                quoted = Some(ch);
                message.push_str("`...`");
            }
            (Some(q), _) if ch == q => quoted = None,
            (Some(_), _) => {}
            (None, '\n') => message.push_str("; "),
            (None, _) => message.push(ch),
        }
    }
    let at = e.span().map_or(String::new(), |span| {
        let before = &text.as_bytes()[..span.start.min(text.len())];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let col = before.iter().rev().take_while(|&&b| b != b'\n').count() + 1;
        format!(" at line {line}, column {col}")
    });
    format!(
        "`{}` is not a valid camera profile{at}: {message}",
        path.display()
    )
}

fn camera_config(
    c: &mut Checker<'_>,
    cam: RawCamera,
    prefix: &str,
    source: &str,
) -> Option<CameraConfig> {
    let k = |s: &str| format!("{prefix}.{s}");
    let shutter = match cam.shutter.as_deref() {
        Some("global") => Some(ShutterKind::Global),
        Some("rolling") => Some(ShutterKind::Rolling),
        Some(other) => {
            c.error(
                &k("shutter"),
                format!("unknown shutter `{other}`"),
                Some("use \"global\" or \"rolling\""),
            );
            None
        }
        None => {
            c.error(
                &k("shutter"),
                "missing required key",
                Some("shutter = \"global\" or \"rolling\""),
            );
            None
        }
    };
    let rows = c
        .required(
            cam.sensor_rows,
            &k("sensor-rows"),
            "sensor height in rows, e.g. 800",
        )
        .and_then(|v| c.pixels(v, &k("sensor-rows"), 1));
    let cols = c
        .required(
            cam.sensor_columns,
            &k("sensor-columns"),
            "sensor width in columns, e.g. 1280",
        )
        .and_then(|v| c.pixels(v, &k("sensor-columns"), 1));
    let fps = c
        .required(
            cam.frame_rate_fps,
            &k("frame-rate-fps"),
            "e.g. frame-rate-fps = 30.0",
        )
        .and_then(|v| c.positive(v, &k("frame-rate-fps"), "frames per second, e.g. 30.0"));
    let exposure_s = c
        .required(
            cam.exposure_ms,
            &k("exposure-ms"),
            "exposure time in milliseconds, e.g. 11.111",
        )
        .and_then(|v| c.positive(v, &k("exposure-ms"), "exposure time in milliseconds"))
        .map(|ms| ms * 1e-3);
    if let (Some(t), Some(fps)) = (exposure_s, fps)
        && t > 1.0 / fps * (1.0 + 1e-12)
    {
        c.error(
            &k("exposure-ms"),
            format!(
                "exposure {} ms is longer than the frame time {:.3} ms",
                t * 1e3,
                1e3 / fps
            ),
            Some("lower exposure-ms or frame-rate-fps"),
        );
    }
    let line_time_s = match (shutter, cam.line_time_us) {
        (Some(ShutterKind::Rolling), None) => {
            c.error(
                &k("line-time-us"),
                "missing required key for a rolling shutter",
                Some("the time between row starts in microseconds, e.g. 14.565"),
            );
            None
        }
        (_, Some(v)) => c
            .non_negative(v, &k("line-time-us"), "line time in microseconds")
            .map(|us| us * 1e-6),
        (_, None) => Some(0.0),
    };
    if let (Some(ShutterKind::Rolling), Some(lt), Some(rows), Some(fps)) =
        (shutter, line_time_s, rows, fps)
        && lt * rows as f64 > 1.0 / fps * (1.0 + 1e-12)
    {
        c.error(
            &k("line-time-us"),
            format!(
                "readout of {rows} rows takes {:.3} ms, longer than the frame time {:.3} ms",
                lt * rows as f64 * 1e3,
                1e3 / fps
            ),
            Some("check line-time-us and sensor-rows"),
        );
    }
    let pwm_delay_s = match cam.pwm_delay_ms {
        Some(v) if v.is_finite() => Some(v * 1e-3),
        Some(v) => {
            c.error(&k("pwm-delay-ms"), format!("must be finite, got {v}"), None);
            None
        }
        None => Some(0.0),
    };
    let response = if cam.sensor.is_some() {
        if cam.response_dn_per_cd_m2_s.is_some() {
            c.error(
                &k("response-dn-per-cd-m2-s"),
                "the ideal camera's response does not apply to a camera with a [sensor] table",
                Some("remove it; the sensor's sensitivity sets the response"),
            );
        }
        Some(0.0)
    } else {
        c.required(
            cam.response_dn_per_cd_m2_s,
            &k("response-dn-per-cd-m2-s"),
            "output DN per cd/m^2 per second of exposure, e.g. 20.0",
        )
        .and_then(|v| c.positive(v, &k("response-dn-per-cd-m2-s"), "a linear gain > 0"))
    };
    let physical = match cam.sensor {
        Some(_) => Some(physical_camera(c, &cam, prefix, exposure_s, fps)?),
        None => None,
    };
    let black = c.non_negative(
        cam.black_level_dn.unwrap_or(0.0),
        &k("black-level-dn"),
        "DN for no light",
    );
    let full_default = physical.as_ref().map_or(255.0, |p| p.tone.output_max);
    let full = c.positive(
        cam.full_scale_dn.unwrap_or(full_default),
        &k("full-scale-dn"),
        "255 for 8-bit output",
    );
    let sat_default = full.map(|f| f * 240.0 / 255.0).unwrap_or(240.0);
    let sat = c.positive(
        cam.saturation_dn.unwrap_or(sat_default),
        &k("saturation-dn"),
        "the P2020 reference code flags 240 of 255",
    );
    if let (Some(b), Some(f)) = (black, full)
        && b >= f
    {
        c.error(
            &k("black-level-dn"),
            format!("black level {b} is not below full scale {f}"),
            None,
        );
        return None;
    }
    Some(CameraConfig {
        name: cam.name.clone().unwrap_or_else(|| "inline".to_string()),
        description: cam.description.clone().unwrap_or_default(),
        source: source.to_string(),
        physical,
        shutter: shutter?,
        sensor_rows: rows?,
        sensor_columns: cols?,
        line_time_s: line_time_s?,
        exposure_s: exposure_s?,
        fps: fps?,
        pwm_delay_s: pwm_delay_s?,
        response_dn_per_cd_m2_s: response?,
        black_level_dn: black?,
        full_scale_dn: full?,
        saturation_dn: sat?,
    })
}

fn rois(
    c: &mut Checker<'_>,
    raw: Vec<super::raw::RawRoi>,
    camera: Option<&CameraConfig>,
) -> Option<Vec<Roi>> {
    if raw.is_empty() {
        // Default: one LED ROI of 100 x 2 px in the middle of the sensor.
        let cam = camera?;
        let w = DEFAULT_ROI_WIDTH_PX.min(cam.sensor_columns);
        let h = DEFAULT_ROI_HEIGHT_PX.min(cam.sensor_rows);
        return Some(vec![Roi {
            name: "led".to_string(),
            kind: RoiKind::Led,
            x_px: (cam.sensor_columns - w) / 2,
            y_px: (cam.sensor_rows - h) / 2,
            width_px: w,
            height_px: h,
        }]);
    }
    let mut out = Vec::new();
    let mut ok = true;
    for (i, r) in raw.into_iter().enumerate() {
        let k = |s: &str| format!("roi[{i}].{s}");
        let name = r.name.unwrap_or_else(|| format!("roi{i}"));
        if name.is_empty()
            || !name
                .chars()
                .all(|ch| ch.is_ascii_alphanumeric() || ch == '-' || ch == '_')
        {
            c.error(
                &k("name"),
                format!("ROI name `{name}` must be letters, digits, `-` or `_`"),
                Some("the name is a CSV column header"),
            );
            ok = false;
        } else if out.iter().any(|o: &Roi| o.name == name) {
            c.error(
                &k("name"),
                format!("ROI name `{name}` is used twice"),
                Some("give each ROI its own name"),
            );
            ok = false;
        }
        let kind = match r.kind.as_deref() {
            None | Some("led") => Some(RoiKind::Led),
            Some("background") => Some(RoiKind::Background),
            Some(other) => {
                c.error(
                    &k("kind"),
                    format!("unknown ROI kind `{other}`"),
                    Some("use \"led\" or \"background\""),
                );
                None
            }
        };
        let hint = "ROI position in pixels, 0-based from the top-left corner";
        let x = c
            .required(r.x_px, &k("x-px"), hint)
            .and_then(|v| c.pixels(v, &k("x-px"), 0));
        let y = c
            .required(r.y_px, &k("y-px"), hint)
            .and_then(|v| c.pixels(v, &k("y-px"), 0));
        let w = c.pixels(
            r.width_px.unwrap_or(DEFAULT_ROI_WIDTH_PX as i64),
            &k("width-px"),
            1,
        );
        let h = c.pixels(
            r.height_px.unwrap_or(DEFAULT_ROI_HEIGHT_PX as i64),
            &k("height-px"),
            1,
        );
        let (Some(kind), Some(x), Some(y), Some(w), Some(h)) = (kind, x, y, w, h) else {
            ok = false;
            continue;
        };
        if let Some(cam) = camera {
            if x as u64 + w as u64 > cam.sensor_columns as u64 {
                c.error(
                    &k("x-px"),
                    format!(
                        "ROI columns {x}..{} fall outside the sensor's {} columns",
                        x as u64 + w as u64,
                        cam.sensor_columns
                    ),
                    Some("x-px + width-px must not exceed dut.camera.sensor-columns"),
                );
                ok = false;
            }
            if y as u64 + h as u64 > cam.sensor_rows as u64 {
                c.error(
                    &k("y-px"),
                    format!(
                        "ROI rows {y}..{} fall outside the sensor's {} rows",
                        y as u64 + h as u64,
                        cam.sensor_rows
                    ),
                    Some("y-px + height-px must not exceed dut.camera.sensor-rows"),
                );
                ok = false;
            }
        }
        out.push(Roi {
            name,
            kind,
            x_px: x,
            y_px: y,
            width_px: w,
            height_px: h,
        });
    }
    (ok && camera.is_some()).then_some(out)
}

/// The physical part of a camera: `sensor`, `capture`, `hdr`, `tone` and
/// `auto-exposure` tables.
fn physical_camera(
    c: &mut Checker<'_>,
    cam: &RawCamera,
    prefix: &str,
    exposure_s: Option<f64>,
    fps: Option<f64>,
) -> Option<PhysicalCamera> {
    let k = |s: &str| format!("{prefix}.{s}");
    let raw = cam.sensor.as_ref()?;
    let hint = "see docs/camera-model.md";
    let sens = c
        .required(
            raw.sensitivity_e_per_cd_m2_s,
            &k("sensor.sensitivity-e-per-cd-m2-s"),
            hint,
        )
        .and_then(|v| c.positive(v, &k("sensor.sensitivity-e-per-cd-m2-s"), hint));
    let full_well = c
        .required(
            raw.full_well_e,
            &k("sensor.full-well-e"),
            "full-well capacity in electrons, e.g. 10000",
        )
        .and_then(|v| c.positive(v, &k("sensor.full-well-e"), hint));
    let read_noise = c.non_negative(
        raw.read_noise_e.unwrap_or(0.0),
        &k("sensor.read-noise-e"),
        hint,
    );
    let bits = raw.adc_bits.unwrap_or(12);
    let bits = if (1..=24).contains(&bits) {
        Some(bits as u32)
    } else {
        c.error(
            &k("sensor.adc-bits"),
            format!("{bits} bits is outside 1..=24"),
            Some("e.g. 12"),
        );
        None
    };
    let e_per_dn = match (raw.e_per_dn, full_well, bits) {
        (Some(v), _, _) => c.positive(v, &k("sensor.e-per-dn"), "electrons per DN at gain 1"),
        (None, Some(fw), Some(b)) => Some(fw / ((2f64).powi(b as i32) - 1.0)),
        _ => None,
    };

    let mut captures = Vec::new();
    let mut ok = true;
    if cam.capture.is_empty() {
        captures.push(Capture {
            name: "L".to_string(),
            exposure: CaptureExposure::Ratio(1.0),
            sensitivity_ratio: 1.0,
        });
    }
    if cam.capture.len() > 4 {
        c.error(
            &k("capture"),
            format!("{} captures; at most 4", cam.capture.len()),
            Some("HDR schemes use 1 to 4 captures"),
        );
        ok = false;
    }
    for (i, cap) in cam.capture.iter().enumerate() {
        let kk = |s: &str| k(&format!("capture[{i}].{s}"));
        let exposure = match (cap.exposure_ratio, cap.exposure_ms) {
            (Some(_), Some(_)) | (None, None) => {
                c.error(
                    &kk("exposure-ratio"),
                    "give exactly one of `exposure-ratio` and `exposure-ms`",
                    Some("a ratio follows auto exposure; exposure-ms is fixed"),
                );
                None
            }
            (Some(r), None) => {
                match c.positive(r, &kk("exposure-ratio"), "a fraction of the L exposure") {
                    Some(r) if r <= 1.0 => Some(CaptureExposure::Ratio(r)),
                    Some(r) => {
                        c.error(
                            &kk("exposure-ratio"),
                            format!("{r} is above 1"),
                            Some("ratios are relative to the first, longest capture"),
                        );
                        None
                    }
                    None => None,
                }
            }
            (None, Some(ms)) => c
                .positive(ms, &kk("exposure-ms"), "milliseconds")
                .map(|ms| CaptureExposure::Fixed(ms * 1e-3)),
        };
        let sensitivity = c.positive(
            cap.sensitivity_ratio.unwrap_or(1.0),
            &kk("sensitivity-ratio"),
            "1 for a normal pixel, e.g. 0.0625 for a small split pixel",
        );
        match (exposure, sensitivity) {
            (Some(exposure), Some(sensitivity_ratio)) => captures.push(Capture {
                name: cap
                    .name
                    .clone()
                    .unwrap_or_else(|| ["L", "M", "S", "VS"][i.min(3)].to_string()),
                exposure,
                sensitivity_ratio,
            }),
            _ => ok = false,
        }
    }

    let hdr = cam.hdr.as_ref();
    let hdr_mode = match hdr.and_then(|h| h.mode.as_deref()) {
        None | Some("sequential") => Some(HdrMode::Sequential),
        Some("split-pixel") => Some(HdrMode::SplitPixel),
        Some(other) => {
            c.error(
                &k("hdr.mode"),
                format!("unknown HDR mode `{other}`"),
                Some("use \"sequential\" or \"split-pixel\""),
            );
            None
        }
    };
    let merge = match hdr.and_then(|h| h.merge.as_deref()) {
        None | Some("longest-unsaturated") => Some(MergeRule::LongestUnsaturated),
        Some("weighted") => Some(MergeRule::Weighted),
        Some(other) => {
            c.error(
                &k("hdr.merge"),
                format!("unknown merge rule `{other}`"),
                Some("use \"longest-unsaturated\" or \"weighted\""),
            );
            None
        }
    };

    let tone_raw = cam.tone.as_ref();
    let curve = match tone_raw.and_then(|t| t.curve.as_deref()) {
        None | Some("linear") => Some(ToneCurve::Linear),
        Some("gamma") => c
            .positive(
                tone_raw.and_then(|t| t.gamma).unwrap_or(2.2),
                &k("tone.gamma"),
                "e.g. 2.2",
            )
            .map(ToneCurve::Gamma),
        Some("log") => c
            .positive(
                tone_raw.and_then(|t| t.log_a).unwrap_or(1000.0),
                &k("tone.log-a"),
                "compression, e.g. 1000",
            )
            .map(ToneCurve::Log),
        Some(other) => {
            c.error(
                &k("tone.curve"),
                format!("unknown tone curve `{other}`"),
                Some("use \"linear\", \"gamma\" or \"log\""),
            );
            None
        }
    };
    let out_bits = tone_raw.and_then(|t| t.output_bits).unwrap_or(8);
    let out_bits = if (8..=16).contains(&out_bits) {
        Some(out_bits as u32)
    } else {
        c.error(
            &k("tone.output-bits"),
            format!("{out_bits} is outside 8..=16"),
            Some("8 or 16"),
        );
        None
    };

    let frame_s = fps.map(|f| 1.0 / f);
    let ae = match &cam.auto_exposure {
        None => None,
        Some(a) => {
            let kk = |s: &str| k(&format!("auto-exposure.{s}"));
            let target = ae_target(c, a.target_luma, a.target, curve, &kk);
            let damping = c.positive(
                a.damping.unwrap_or(0.5),
                &kk("damping"),
                "fraction of the error corrected per frame, in (0, 1]",
            );
            let deadband = c.non_negative(
                a.deadband.unwrap_or(0.05),
                &kk("deadband"),
                "relative error, e.g. 0.05",
            );
            let min_t = c
                .positive(
                    a.min_exposure_ms.unwrap_or(0.01),
                    &kk("min-exposure-ms"),
                    "e.g. 11.111 for flicker mitigation above 90 Hz",
                )
                .map(|v| v * 1e-3);
            let max_t = match (a.max_exposure_ms, frame_s) {
                (Some(v), _) => c
                    .positive(v, &kk("max-exposure-ms"), "at most the frame time")
                    .map(|v| v * 1e-3),
                (None, Some(f)) => Some(f),
                (None, None) => None,
            };
            let max_ga = c.positive(
                a.max_analog_gain.unwrap_or(16.0),
                &kk("max-analog-gain"),
                ">= 1",
            );
            let min_gd = c.positive(
                a.min_digital_gain.unwrap_or(1.0),
                &kk("min-digital-gain"),
                "> 0",
            );
            let max_gd = c.positive(
                a.max_digital_gain.unwrap_or(1.0),
                &kk("max-digital-gain"),
                ">= min-digital-gain",
            );
            if damping.is_some_and(|d| d > 1.0) {
                c.error(
                    &kk("damping"),
                    "must be at most 1",
                    Some("1 corrects the whole error in one frame"),
                );
            }
            if let (Some(lo), Some(hi)) = (min_t, max_t)
                && lo > hi
            {
                c.error(
                    &kk("min-exposure-ms"),
                    format!("{} ms is above max-exposure-ms {} ms", lo * 1e3, hi * 1e3),
                    None,
                );
            }
            if let (Some(hi), Some(f)) = (max_t, frame_s)
                && hi > f * (1.0 + 1e-12)
            {
                c.error(
                    &kk("max-exposure-ms"),
                    format!(
                        "{:.3} ms is longer than the frame time {:.3} ms",
                        hi * 1e3,
                        f * 1e3
                    ),
                    None,
                );
            }
            if max_ga.is_some_and(|g| g < 1.0) {
                c.error(&kk("max-analog-gain"), "must be >= 1", None);
            }
            if let (Some(lo), Some(hi)) = (min_gd, max_gd)
                && lo > hi
            {
                c.error(&kk("max-digital-gain"), "must be >= min-digital-gain", None);
            }
            match (
                target, damping, deadband, min_t, max_t, max_ga, min_gd, max_gd,
            ) {
                (
                    Some(target),
                    Some(damping),
                    Some(deadband),
                    Some(min_exposure_s),
                    Some(max_exposure_s),
                    Some(max_analog_gain),
                    Some(min_digital_gain),
                    Some(max_digital_gain),
                ) => Some(AutoExposure {
                    target,
                    damping,
                    deadband,
                    min_exposure_s,
                    max_exposure_s,
                    max_analog_gain,
                    min_digital_gain,
                    max_digital_gain,
                }),
                _ => {
                    ok = false;
                    None
                }
            }
        }
    };
    let analog_gain = c.positive(cam.analog_gain.unwrap_or(1.0), &k("analog-gain"), ">= 1");
    if analog_gain.is_some_and(|g| g < 1.0) {
        c.error(
            &k("analog-gain"),
            "must be >= 1",
            Some("analogue gain amplifies; use digital-gain to scale down"),
        );
    }
    let digital_gain = c.positive(cam.digital_gain.unwrap_or(1.0), &k("digital-gain"), "> 0");

    // Sequential captures must fit in the frame at the longest exposure.
    let longest_t = ae.map(|a| a.max_exposure_s).or(exposure_s);
    if let (Some(HdrMode::Sequential), Some(t), Some(f)) = (hdr_mode, longest_t, frame_s) {
        let total: f64 = captures.iter().map(|cap| cap.exposure_s(t)).sum();
        if total > f * (1.0 + 1e-9) {
            c.error(
                &k("capture"),
                format!("sequential captures take {:.3} ms at the longest exposure, more than the frame time {:.3} ms", total * 1e3, f * 1e3),
                Some("lower the exposure ratios or auto-exposure.max-exposure-ms"),
            );
            ok = false;
        }
    }

    let sensor = Sensor {
        sensitivity_e_per_cd_m2_s: sens?,
        full_well_e: full_well?,
        read_noise_e: read_noise?,
        shot_noise: raw.shot_noise.unwrap_or(true),
        adc_bits: bits?,
        e_per_dn: e_per_dn?,
    };
    let nominal_t = exposure_s?;
    let min_scale = captures
        .iter()
        .map(|cap| {
            cap.exposure_s(nominal_t) / captures[0].exposure_s(nominal_t) * cap.sensitivity_ratio
                / captures[0].sensitivity_ratio
        })
        .fold(f64::INFINITY, f64::min);
    let white = match hdr.and_then(|h| h.white_dn) {
        Some(w) => c.positive(w, &k("hdr.white-dn"), "L-equivalent DN mapped to white")?,
        None => sensor.dn_max() / min_scale.min(1.0),
    };
    if !ok {
        return None;
    }
    Some(PhysicalCamera {
        sensor,
        captures,
        hdr_mode: hdr_mode?,
        merge: merge?,
        tone: Tone {
            curve: curve?,
            white,
            output_max: (2f64).powi(out_bits? as i32) - 1.0,
        },
        auto_exposure: ae,
        analog_gain: analog_gain?,
        digital_gain: digital_gain?,
    })
}

/// Default auto-exposure target: the output level of the metered area as a
/// fraction of full scale. 0.46 is where 18 % grey lands in sRGB
/// (IEC 61966-2-1): a mid-grey scene looks mid-grey.
pub const DEFAULT_TARGET_LUMA: f64 = 0.46;

/// The auto-exposure target as the controller uses it: a linear fraction of
/// white. `target-luma` (output level, 0..1 of full scale) goes through the
/// inverse tone curve; the older `target` is that linear fraction itself.
fn ae_target(
    c: &mut Checker<'_>,
    luma: Option<f64>,
    linear: Option<f64>,
    curve: Option<ToneCurve>,
    kk: &dyn Fn(&str) -> String,
) -> Option<f64> {
    let hint_luma =
        "the metered area's output level, 0..1 of full scale, e.g. 0.46 (18 % grey in sRGB)";
    match (luma, linear) {
        (Some(_), Some(_)) => {
            c.error(
                &kk("target"),
                "give target-luma or target, not both",
                Some("target-luma is the output level; target, the older key, a linear fraction of white"),
            );
            None
        }
        (None, Some(t)) => {
            let t = c.positive(t, &kk("target"), "a linear fraction of white, e.g. 0.0003")?;
            if t >= 1.0 {
                c.error(&kk("target"), "must be below 1 (white)", Some(hint_luma));
                return None;
            }
            Some(t)
        }
        (luma, None) => {
            let key = kk("target-luma");
            let y = luma.unwrap_or(DEFAULT_TARGET_LUMA);
            if !(y.is_finite() && y > 0.0 && y < 1.0) {
                c.error(&key, format!("{y} is outside (0, 1)"), Some(hint_luma));
                return None;
            }
            Some(curve?.inverse(y))
        }
    }
}
