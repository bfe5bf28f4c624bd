//! The colour keys: `scene.led-chromaticity-xy` and `scene.signal-colour`
//! (the light), `dut.camera.colour-plane-offset-ms` and
//! `dut.camera.camera-to-xyz` (the camera's planes). All optional; without
//! a chromaticity the plan has no colour and the camera keys are refused.

use crate::plan::check::Checker;
use crate::plan::colour::{ColourConfig, DEFAULT_CAMERA_TO_XYZ, SignalColourName, apply, invert};
use crate::plan::{ColourTransfer, VideoDecode};

/// The colour keys as read, before validation.
#[derive(Debug, Default)]
pub(super) struct RawColour {
    pub led_xy: Option<Vec<f64>>,
    pub signal: Option<String>,
    pub offsets_ms: Option<Vec<f64>>,
    pub camera_to_xyz: Option<Vec<Vec<f64>>>,
}

const HINT: &str = "see docs/plan-format.md, \"Colour\"";

/// Where a plan's colour planes come from.
#[derive(Debug, Clone, Copy)]
pub(super) enum Planes {
    /// The simulator's ideal camera (no `[sensor]` table) makes them.
    Simulated,
    /// A captured plan reads them from RGB frames, its video decoded so,
    /// its codes decoded with the transfer the plan gives (if it does).
    Captured(VideoDecode, Option<ColourTransfer>),
    /// Any other backend or camera: no colour planes.
    Unavailable,
}

/// The colour keys of a captured plan, whose planes are read from its
/// frames decoded as `decode` (`offsets`: whether the plan gives
/// `colour-plane-offset-ms`): false after an error.
fn captured(
    c: &mut Checker<'_>,
    offsets: bool,
    decode: VideoDecode,
    transfer: Option<ColourTransfer>,
) -> bool {
    let mut ok = true;
    // A recording's codes are rarely linear; a chromaticity of
    // encoded codes is wrong, so the plan must say which they are.
    if transfer.is_none() {
        c.error(
            "capture.colour-transfer",
            "is needed in a captured plan with colour (scene.led-chromaticity-xy): the R, G and B codes must be turned into light before their chromaticity is computed",
            Some("\"srgb\" for most still images, \"bt709\" for most video, \"linear\" for raw or linear sensor output"),
        );
        ok = false;
    }
    // The recording carries its planes' timing: nothing to simulate.
    if offsets {
        c.error(
            "dut.camera.colour-plane-offset-ms",
            "is simulated, not read: a captured plan's planes are as recorded",
            Some("remove it; the recording's own chroma shift is measured"),
        );
        ok = false;
    }
    if decode == VideoDecode::LumaPlane {
        c.error(
            "capture.video-decode",
            "\"luma-plane\" reads no R, G, B, and the plan has colour (scene.led-chromaticity-xy)",
            Some("use video-decode = \"rgb\" (the default), or remove the colour keys"),
        );
        ok = false;
    }
    ok
}

/// Validates the colour keys: `Some(None)` without them, `None` after an
/// error.
pub(super) fn colour(
    c: &mut Checker<'_>,
    raw: RawColour,
    planes: Planes,
) -> Option<Option<ColourConfig>> {
    let Some(xy) = raw.led_xy else {
        let transfer = matches!(planes, Planes::Captured(_, Some(_)));
        for (given, key) in [
            (transfer, "capture.colour-transfer"),
            (raw.signal.is_some(), "scene.signal-colour"),
            (
                raw.offsets_ms.is_some(),
                "dut.camera.colour-plane-offset-ms",
            ),
            (raw.camera_to_xyz.is_some(), "dut.camera.camera-to-xyz"),
        ] {
            if given {
                c.error(
                    key,
                    "needs the LED's colour, `scene.led-chromaticity-xy`",
                    Some("give the chromaticity, e.g. led-chromaticity-xy = [0.70, 0.295] for a signal red"),
                );
            }
        }
        return if transfer
            || raw.signal.is_some()
            || raw.offsets_ms.is_some()
            || raw.camera_to_xyz.is_some()
        {
            None
        } else {
            Some(None)
        };
    };
    let mut ok = true;
    match planes {
        Planes::Simulated => {}
        Planes::Captured(decode, transfer) => {
            ok &= captured(c, raw.offsets_ms.is_some(), decode, transfer)
        }
        Planes::Unavailable => {
            c.error(
                "scene.led-chromaticity-xy",
                "colour planes come from the simulator's ideal camera or from captured RGB frames only",
                Some("use backend = \"simulator\" without [dut.camera.sensor], or backend = \"captured\", or remove the colour keys"),
            );
            ok = false;
        }
    }
    let led_xy = match xy.as_slice() {
        &[x, y] if x > 0.0 && y > 0.0 && x + y < 1.0 => Some([x, y]),
        _ => {
            c.error(
                "scene.led-chromaticity-xy",
                format!("{xy:?} is not a chromaticity"),
                Some("two numbers [x, y], each > 0 and x + y < 1 (CIE 1931)"),
            );
            None
        }
    };
    let signal = raw.signal.and_then(|s| {
        c.choice(
            Some(s),
            "scene.signal-colour",
            SignalColourName::Red,
            &[
                ("red", SignalColourName::Red),
                ("amber", SignalColourName::Amber),
            ],
        )
        .or_else(|| {
            ok = false;
            None
        })
    });
    let offsets = plane_offsets(c, raw.offsets_ms.as_deref());
    let matrix = camera_matrix(c, raw.camera_to_xyz);
    let (led_xy, offsets, matrix) = (led_xy?, offsets?, matrix?);
    let Some(inverse) = invert(&matrix) else {
        c.error("dut.camera.camera-to-xyz", "is singular", Some(HINT));
        return None;
    };
    let [x, y] = led_xy;
    let led_rgb = apply(&inverse, [x / y, 1.0, (1.0 - x - y) / y]);
    // A plane may come out a little below 0 from the rounding of `(x, y)`
    // for an LED on the gamut's edge (a saturated primary).
    let largest = led_rgb.iter().fold(0.0f64, |m, v| m.max(*v));
    if led_rgb.iter().any(|v| *v < -1e-3 * largest) {
        c.error(
            "scene.led-chromaticity-xy",
            format!("({x}, {y}) is outside the camera's gamut: its planes would see {led_rgb:.3?}"),
            Some("give the camera's own matrix, dut.camera.camera-to-xyz, whose primaries enclose the LED's colour"),
        );
        return None;
    }
    let white_rgb = apply(
        &inverse,
        [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290],
    );
    ok.then_some(Some(ColourConfig {
        led_xy,
        signal,
        plane_offsets_s: offsets,
        camera_to_xyz: matrix,
        led_rgb: led_rgb.map(|v| v.max(0.0)),
        white_rgb,
    }))
}

/// `dut.camera.colour-plane-offset-ms`: three offsets, ms, as seconds.
fn plane_offsets(c: &mut Checker<'_>, offsets_ms: Option<&[f64]>) -> Option<[f64; 3]> {
    match offsets_ms {
        None => Some([0.0; 3]),
        Some(&[r, g, b])
            if [r, g, b]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0 && *v < 1000.0) =>
        {
            Some([r * 1e-3, g * 1e-3, b * 1e-3])
        }
        Some(v) => {
            c.error(
                "dut.camera.colour-plane-offset-ms",
                format!("{v:?} is not three offsets"),
                Some("three numbers [R, G, B], ms >= 0: when each plane's exposure starts after the frame's"),
            );
            None
        }
    }
}

/// `dut.camera.camera-to-xyz`: three rows of three numbers.
fn camera_matrix(c: &mut Checker<'_>, rows: Option<Vec<Vec<f64>>>) -> Option<[[f64; 3]; 3]> {
    match rows {
        None => Some(DEFAULT_CAMERA_TO_XYZ),
        Some(rows) => {
            let m = (rows.len() == 3
                && rows
                    .iter()
                    .all(|r| r.len() == 3 && r.iter().all(|v| v.is_finite())))
            .then(|| [0, 1, 2].map(|i| [rows[i][0], rows[i][1], rows[i][2]]));
            if m.is_none() {
                c.error(
                    "dut.camera.camera-to-xyz",
                    "is not a 3 x 3 matrix of numbers",
                    Some("three rows X, Y, Z of three numbers, linear camera R, G, B to CIE XYZ"),
                );
            }
            m
        }
    }
}

/// A `delta-uv-max` needs the colour the excursion is computed from:
/// without `scene.led-chromaticity-xy` it is an error, not a limit
/// silently never checked.
pub(super) fn limit_needs_colour(
    c: &mut Checker<'_>,
    t: &crate::plan::Thresholds,
    colour: Option<&ColourConfig>,
) -> Option<()> {
    if colour.is_some() {
        return Some(());
    }
    let levels = t.light_levels.iter().enumerate();
    let mut keys: Vec<String> = levels
        .filter(|(_, l)| l.limits.delta_uv_max.is_some())
        .map(|(i, _)| format!("thresholds.light-level[{i}].delta-uv-max"))
        .collect();
    if t.delta_uv_max.is_some() {
        keys.insert(0, "thresholds.delta-uv-max".to_string());
    }
    for key in &keys {
        c.error(
            key,
            "needs scene.led-chromaticity-xy: the excursion is of the LED's colour",
            Some("give the LED's chromaticity (e.g. led-chromaticity-xy = [0.69, 0.30]), or remove the limit"),
        );
    }
    keys.is_empty().then_some(())
}
