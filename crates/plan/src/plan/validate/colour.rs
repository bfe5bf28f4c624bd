//! The colour keys: `scene.led-chromaticity-xy` or `[[scene.led-die]]`,
//! and `scene.signal-colour` (the light), `dut.camera.colour-plane-offset-ms`
//! and `dut.camera.camera-to-xyz` (the camera's planes). All optional;
//! without a chromaticity or dies the plan has no colour and the camera
//! keys are refused.

use crate::plan::check::{Checker, number};
use crate::plan::colour::{
    ColourConfig, DEFAULT_CAMERA_TO_XYZ, LedDie, SignalColourName, apply, invert,
};
use crate::plan::raw::RawLedDie;
use crate::plan::{BlackLevel, CaptureConfig, ColourTransfer, VideoDecode};

/// The colour keys as read, before validation.
#[derive(Debug, Default)]
pub(super) struct RawColour {
    pub led_xy: Option<Vec<f64>>,
    pub signal: Option<String>,
    pub offsets_ms: Option<Vec<f64>>,
    pub camera_to_xyz: Option<Vec<Vec<f64>>>,
    pub dies: Vec<RawLedDie>,
}

/// Most dies an LED may have: an RGB or RGBW package has three or four.
pub const MAX_DIES: usize = 8;

/// How far the dies' luminance shares may sum from 1 (their rounding to
/// a few decimals); they are then scaled to sum to 1 exactly.
const SHARE_SUM_TOLERANCE: f64 = 1e-3;

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

/// `scene.signal-colour`, when given; `ok` turns false when it is not a
/// region the tool knows.
fn signal_colour(
    c: &mut Checker<'_>,
    given: Option<String>,
    ok: &mut bool,
) -> Option<SignalColourName> {
    given.and_then(|s| {
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
            *ok = false;
            None
        })
    })
}

/// Validates the colour keys: `Some(None)` without them, `None` after an
/// error.
pub(super) fn colour(
    c: &mut Checker<'_>,
    raw: RawColour,
    planes: Planes,
) -> Option<Option<ColourConfig>> {
    if raw.led_xy.is_some() && !raw.dies.is_empty() {
        c.error(
            "scene.led-die",
            "and scene.led-chromaticity-xy both give the LED's colour",
            Some("give one colour (led-chromaticity-xy) or the dies' own colours ([[scene.led-die]]), not both"),
        );
        return None;
    }
    if !raw.dies.is_empty() {
        return dies_colour(c, raw, planes);
    }
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
                "colour planes come from the simulator's ideal camera or from recorded RGB frames only",
                Some("use backend = \"simulator\" without [dut.camera.sensor], or backend = \"captured\" or \"command\", or remove the colour keys"),
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
    let signal = signal_colour(c, raw.signal, &mut ok);
    let offsets = plane_offsets(c, raw.offsets_ms.as_deref());
    let matrix = camera_matrix(c, raw.camera_to_xyz);
    let (led_xy, offsets, matrix) = (led_xy?, offsets?, matrix?);
    let Some(inverse) = invert(&matrix) else {
        c.error("dut.camera.camera-to-xyz", "is singular", Some(HINT));
        return None;
    };
    let led_rgb = in_gamut(c, "scene.led-chromaticity-xy", led_xy, &inverse)?;
    ok.then_some(Some(ColourConfig {
        led_xy,
        signal,
        plane_offsets_s: offsets,
        camera_to_xyz: matrix,
        led_rgb,
        white_rgb: white_rgb(&inverse),
        dies: Vec::new(),
    }))
}

/// D65 white's camera RGB at `Y = 1` through `inverse`.
fn white_rgb(inverse: &[[f64; 3]; 3]) -> [f64; 3] {
    apply(
        inverse,
        [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290],
    )
}

/// The camera RGB at `Y = 1` of the chromaticity `xy` given at `key`:
/// `None` (an error) when it is outside the camera's gamut.
fn in_gamut(
    c: &mut Checker<'_>,
    key: &str,
    [x, y]: [f64; 2],
    inverse: &[[f64; 3]; 3],
) -> Option<[f64; 3]> {
    let rgb = apply(inverse, [x / y, 1.0, (1.0 - x - y) / y]);
    // A plane may come out a little below 0 from the rounding of `(x, y)`
    // for an LED on the gamut's edge (a saturated primary).
    let largest = rgb.iter().fold(0.0f64, |m, v| m.max(*v));
    if rgb.iter().any(|v| *v < -1e-3 * largest) {
        c.error(
            key,
            format!("({x}, {y}) is outside the camera's gamut: its planes would see {rgb:.3?}"),
            Some("give the camera's own matrix, dut.camera.camera-to-xyz, whose primaries enclose the LED's colour"),
        );
        return None;
    }
    Some(rgb.map(|v| v.max(0.0)))
}

/// The colour of an LED of dies (`[[scene.led-die]]`), each with its own
/// chromaticity, luminance share, duty and phase. Simulated only: a
/// captured plan's frames carry the lamp's own colour.
fn dies_colour(
    c: &mut Checker<'_>,
    raw: RawColour,
    planes: Planes,
) -> Option<Option<ColourConfig>> {
    let mut ok = true;
    match planes {
        Planes::Simulated => {}
        Planes::Captured(..) => {
            c.error(
                "scene.led-die",
                "is simulated: a captured plan's frames carry the lamp's own colour and timing",
                Some("give the lamp's stated colour as scene.led-chromaticity-xy instead"),
            );
            ok = false;
        }
        Planes::Unavailable => {
            c.error(
                "scene.led-die",
                "colour planes come from the simulator's ideal camera only for an LED of dies",
                Some("use backend = \"simulator\" without [dut.camera.sensor], or remove the [[scene.led-die]] tables"),
            );
            ok = false;
        }
    }
    if raw.dies.len() > MAX_DIES {
        c.error(
            "scene.led-die",
            format!("{} dies; at most {MAX_DIES}", raw.dies.len()),
            Some("an RGB LED has three dies, an RGBW one four"),
        );
        return None;
    }
    let signal = signal_colour(c, raw.signal, &mut ok);
    let offsets = plane_offsets(c, raw.offsets_ms.as_deref());
    let matrix = camera_matrix(c, raw.camera_to_xyz);
    let inverse = match matrix.map(|m| invert(&m)) {
        Some(None) => {
            c.error("dut.camera.camera-to-xyz", "is singular", Some(HINT));
            None
        }
        Some(inv) => inv,
        None => None,
    };
    let mut dies = Vec::with_capacity(raw.dies.len());
    for (i, d) in raw.dies.into_iter().enumerate() {
        match die(c, i, d, inverse.as_ref()) {
            Some(d) => dies.push(d),
            None => ok = false,
        }
    }
    let (offsets, matrix, inverse) = (offsets?, matrix?, inverse?);
    if !ok {
        return None;
    }
    let sum: f64 = dies.iter().map(|d| d.share).sum();
    if (sum - 1.0).abs() > SHARE_SUM_TOLERANCE {
        c.error(
            "scene.led-die",
            format!(
                "the dies' luminance-share values sum to {}, not 1",
                number(sum)
            ),
            Some("each share is the die's fraction of led-luminance-cd-m2 while every die is ON: e.g. 0.6 and 0.4"),
        );
        return None;
    }
    for d in &mut dies {
        d.share /= sum;
    }
    // The colour the dies fuse to: their XYZ (at Y = 1 each) weighted by
    // share and duty; its camera RGB at Y = 1 follows by linearity.
    let weight: f64 = dies.iter().map(|d| d.share * d.duty).sum();
    let mut xyz = [0.0; 3];
    let mut rgb = [0.0; 3];
    for d in &dies {
        let [x, y] = d.xy;
        let w = d.share * d.duty / weight;
        for (t, v) in xyz.iter_mut().zip([x / y, 1.0, (1.0 - x - y) / y]) {
            *t += w * v;
        }
        for (t, v) in rgb.iter_mut().zip(d.rgb) {
            *t += w * v;
        }
    }
    let total = xyz[0] + xyz[1] + xyz[2];
    Some(Some(ColourConfig {
        led_xy: [xyz[0] / total, xyz[1] / total],
        signal,
        plane_offsets_s: offsets,
        camera_to_xyz: matrix,
        led_rgb: rgb,
        white_rgb: white_rgb(&inverse),
        dies,
    }))
}

/// One `[[scene.led-die]]` table, the `i`th: `None` after an error (the
/// gamut is checked when the camera's `inverse` matrix is known).
fn die(
    c: &mut Checker<'_>,
    i: usize,
    d: RawLedDie,
    inverse: Option<&[[f64; 3]; 3]>,
) -> Option<LedDie> {
    let key = |k: &str| format!("scene.led-die[{i}].{k}");
    let xy = c
        .required(
            d.chromaticity_xy,
            &key("chromaticity-xy"),
            "the die's CIE 1931 [x, y], e.g. [0.70, 0.295] for a red die",
        )
        .and_then(|xy| match xy.as_slice() {
            &[x, y] if x > 0.0 && y > 0.0 && x + y < 1.0 => Some([x, y]),
            _ => {
                c.error(
                    &key("chromaticity-xy"),
                    format!("{xy:?} is not a chromaticity"),
                    Some("two numbers [x, y], each > 0 and x + y < 1 (CIE 1931)"),
                );
                None
            }
        });
    let share = c
        .required(
            d.luminance_share,
            &key("luminance-share"),
            "the die's share of led-luminance-cd-m2 while every die is ON, e.g. 0.5; the shares sum to 1",
        )
        .and_then(|v| {
            c.positive(
                v,
                &key("luminance-share"),
                "a die that gives no light is no die: remove its table",
            )
        });
    let duty = c
        .required(
            d.duty_cycle,
            &key("duty-cycle"),
            "the die's duty at a case duty of 1, in (0, 1], e.g. 0.5",
        )
        .and_then(|v| c.duty(v, &key("duty-cycle")));
    let phase = match d.phase_deg {
        None => Some(0.0),
        Some(v) if v.is_finite() && (0.0..360.0).contains(&v) => Some(v),
        Some(v) => {
            c.error(
                &key("phase-deg"),
                format!("{} is not a phase in [0, 360) degrees", number(v)),
                Some("the die's rising edge after the LED's common one, in degrees of the PWM period: 180 is half a period late"),
            );
            None
        }
    };
    let rgb = match (xy, inverse) {
        (Some(xy), Some(inv)) => in_gamut(c, &key("chromaticity-xy"), xy, inv),
        _ => None,
    };
    Some(LedDie {
        xy: xy?,
        share: share?,
        duty: duty?,
        phase_cycles: phase? / 360.0,
        rgb: rgb?,
    })
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

/// `capture.black-level = "off-segment"` sets the black of the colour
/// planes: without colour it would change nothing, so it is an error.
pub(super) fn black_level_needs_colour(
    c: &mut Checker<'_>,
    capture: Option<&CaptureConfig>,
    colour: Option<&ColourConfig>,
) -> Option<()> {
    let asked = capture.is_some_and(|cap| cap.black_level == BlackLevel::OffSegment);
    if asked && colour.is_none() {
        c.error(
            "capture.black-level",
            "\"off-segment\" sets the black of the colour planes, and the plan has no colour (scene.led-chromaticity-xy)",
            Some("give the lamp's colour, or remove the key: the luma's figures take no black level"),
        );
        return None;
    }
    Some(())
}
