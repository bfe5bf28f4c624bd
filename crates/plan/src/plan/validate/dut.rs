//! `[dut]`: the device under test, its backend and its camera, given
//! inline (`[dut.camera]`) or as a camera profile file
//! (`camera-profile`, checked here with its own file name in every
//! diagnostic).

use std::path::{Path, PathBuf};

use super::camera;
use crate::plan::check::Checker;
use crate::plan::raw::{RawDut, RawProfile};
use crate::plan::spans::{SpanIndex, deserialize_noting_unknown, unknown_key_hint};
use crate::plan::{BackendKind, CameraConfig, Dut, ShutterKind};

/// Validates `[dut]`, which is required. `is_sim` is false for the
/// captured and command backends, which need no camera.
pub(super) fn dut_table(
    c: &mut Checker<'_>,
    raw: Option<RawDut>,
    is_sim: bool,
    plan_path: &Path,
) -> Option<Dut> {
    let d = c.required(
        raw,
        "dut",
        "add [dut] with backend = \"simulator\" and [dut.camera]",
    )?;
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
        (Some(profile), None, _) => load_profile(c, &profile, plan_path),
        (None, Some(cam), _) => camera::camera_config(c, cam, "dut.camera", "plan"),
        // Captured data has no simulated camera; ROIs are checked
        // against each capture's frame size when it is read.
        (None, None, false) => Some(no_camera()),
        (None, None, true) => {
            c.error(
                "dut.camera",
                "missing camera",
                Some("add camera-profile = \"reference-data/cameras/<name>.toml\" or a [dut.camera] table"),
            );
            None
        }
    };
    Some(Dut {
        backend: backend?,
        supplier: d.supplier.unwrap_or_default(),
        model: d.model.unwrap_or_default(),
        serial: d.serial.unwrap_or_default(),
        firmware: d.firmware.unwrap_or_default(),
        camera: camera?,
    })
}

/// Reads and checks a camera profile file, `[camera]` with the keys of
/// `[dut.camera]`. Relative paths are tried from the plan's directory and
/// the current directory, then among the profiles built into the binary
/// (`plan::shipped`).
fn load_profile(c: &mut Checker<'_>, name: &str, plan_path: &Path) -> Option<CameraConfig> {
    let candidates = [
        plan_path.parent().unwrap_or(Path::new(".")).join(name),
        PathBuf::from(name),
    ];
    let (path, text) = match candidates.iter().find(|p| p.is_file()) {
        Some(path) => match std::fs::read_to_string(path) {
            Ok(t) => (path.clone(), t),
            Err(e) => {
                c.error(
                    "dut.camera-profile",
                    format!("cannot read `{}`: {e}", path.display()),
                    None,
                );
                return None;
            }
        },
        None => match crate::plan::shipped::profile(name) {
            Some(built_in) => (
                PathBuf::from(crate::plan::shipped::label(built_in.path)),
                built_in.text.to_string(),
            ),
            None => {
                c.error(
                    "dut.camera-profile",
                    format!("camera profile `{name}` not found"),
                    Some("give a path relative to the plan, e.g. \"../reference-data/cameras/ideal-global.toml\""),
                );
                return None;
            }
        },
    };
    let path = &path;
    let parsed = SpanIndex::build(&text).and_then(|index| {
        let de = toml::Deserializer::parse(&text)?;
        let mut unknown = Vec::new();
        let raw: RawProfile = deserialize_noting_unknown(de, &mut unknown)?;
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
    let mut pc = c.for_file(&index, path.clone());
    for key in unknown {
        let hint = unknown_key_hint(&key);
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
    camera::camera_config(&mut pc, cam, "camera", &path.display().to_string())
}

/// A TOML error in a camera profile, located by line and column, with
/// every quoted fragment of the file left out: the file named may be any
/// file (say a private key), and its contents must never reach the terminal or a log.
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

/// The camera of a plan without `[dut.camera]` (captured data): unbounded
/// sensor, so ROIs are checked against each capture's frames instead.
fn no_camera() -> CameraConfig {
    CameraConfig {
        name: "captured".to_string(),
        description: "captured data: no simulated camera".to_string(),
        source: "plan".to_string(),
        physical: None,
        shutter: ShutterKind::Global,
        sensor_rows: u32::MAX / 2,
        sensor_columns: u32::MAX / 2,
        line_time_s: 0.0,
        exposure_s: 1.0 / 30.0,
        fps: 30.0,
        pwm_delay_s: 0.0,
        response_dn_per_cd_m2_s: 1.0,
        black_level_dn: 0.0,
        full_scale_dn: 255.0,
        saturation_dn: 240.0,
    }
}
