//! `[scene]`: what the camera looks at (grey background, LED luminance and
//! fill, PWM clock offset).

use crate::plan::Scene;
use crate::plan::bounds::MAX_LUMINANCE_CD_M2;
use crate::plan::check::{Checker, One, keep};
use crate::plan::raw::RawScene;

/// Validates `[scene]`; every key has a default (18 % grey, 1000 cd/m^2,
/// full fill, no lamp in the metering area, no clock offset).
pub(super) fn scene_table(c: &mut Checker<'_>, raw: Option<RawScene>) -> Option<Scene> {
    let mut sc = Scene {
        background_reflectance: 0.18,
        led_luminance_cd_m2: 1000.0,
        led_fill: 1.0,
        led_frame_fraction: 0.0,
        pwm_clock_offset_ppm: 0.0,
    };
    let Some(s) = raw else {
        return Some(sc);
    };
    let hint_scene = "see docs/plan-format.md, [scene]";
    let mut ok = true;
    let reflectance = s.background_reflectance.map(|v| {
        let key = "scene.background-reflectance";
        let v = c.non_negative(v, key, hint_scene);
        c.up_to_one(
            v,
            One::AtMost,
            key,
            "reflectance ",
            "a fraction: 0.18 for 18% grey",
        )
    });
    keep(&mut sc.background_reflectance, reflectance, &mut ok);
    let luminance = s.led_luminance_cd_m2.map(|v| {
        c.within(
            v,
            "scene.led-luminance-cd-m2",
            (0.0, MAX_LUMINANCE_CD_M2),
            " cd/m^2",
            "LED luminance while ON: lamps are 1e3 to 1e6 cd/m^2, the sun's disc 1.6e9",
        )
    });
    keep(&mut sc.led_luminance_cd_m2, luminance, &mut ok);
    let fill = s.led_fill.map(|v| {
        let (key, hint) = ("scene.led-fill", "a fraction of the ROI in (0, 1]");
        let v = c.positive(v, key, hint);
        c.up_to_one(v, One::AtMost, key, "", hint)
    });
    keep(&mut sc.led_fill, fill, &mut ok);
    let frame_fraction = s.led_frame_fraction.map(|v| {
        let key = "scene.led-frame-fraction";
        let hint = "a fraction of the metering area in [0, 1)";
        let v = c.non_negative(v, key, hint);
        c.up_to_one(v, One::Below, key, "", hint)
    });
    keep(&mut sc.led_frame_fraction, frame_fraction, &mut ok);
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
    ok.then_some(sc)
}
