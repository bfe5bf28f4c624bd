//! `[display]`: the CMS monitor and the viewing geometry, from the serde
//! mirror to a validated [`Display`]. The camera's full scale and image
//! width are the defaults of the signal the monitor shows.

use crate::plan::CameraConfig;
use crate::plan::check::{Checker, keep};
use crate::plan::display::{
    DEFAULT_CONTRAST_RATIO, DEFAULT_DISTANCE_MM, DEFAULT_IMAGE_WIDTH_MM, DEFAULT_REFRESH_HZ,
    Display, DisplayPreset, Eotf,
};
use crate::plan::raw::RawDisplay;

/// Validates `[display]`: `None` (and no error) without the table, the
/// preset's values for each key the table leaves out.
pub(super) fn display(
    c: &mut Checker<'_>,
    raw: Option<RawDisplay>,
    camera: Option<&CameraConfig>,
) -> Option<Option<Display>> {
    let Some(raw) = raw else {
        return Some(None);
    };
    let mut ok = true;
    let preset = c.choice(
        raw.preset.clone(),
        "display.preset",
        DisplayPreset::Day,
        &[("day", DisplayPreset::Day), ("night", DisplayPreset::Night)],
    );
    let preset = preset.unwrap_or_else(|| {
        ok = false;
        DisplayPreset::Day
    });
    let mut d = Display {
        preset,
        eotf: Eotf::Srgb,
        refresh_hz: DEFAULT_REFRESH_HZ,
        peak_cd_m2: preset.peak_cd_m2(),
        black_cd_m2: preset.peak_cd_m2() / DEFAULT_CONTRAST_RATIO,
        image_width_mm: DEFAULT_IMAGE_WIDTH_MM,
        distance_mm: DEFAULT_DISTANCE_MM,
        full_scale_dn: camera.map_or(255.0, |k| k.full_scale_dn),
        image_width_px: camera.map_or(1, |k| k.sensor_columns),
    };
    let eotf = c.choice(
        raw.eotf.clone(),
        "display.eotf",
        Eotf::Srgb,
        &[("srgb", Eotf::Srgb), ("bt1886", Eotf::Bt1886)],
    );
    keep(&mut d.eotf, Some(eotf), &mut ok);
    let ok = &mut ok;
    ranged_keys(c, &mut d, &raw, ok);
    // A peak without a black level keeps the default contrast ratio.
    d.black_cd_m2 = d.peak_cd_m2 / DEFAULT_CONTRAST_RATIO;
    let hint = "a 1000:1 panel at 50 cd/m^2 has 0.05";
    let black = raw
        .black_cd_m2
        .map(|v| c.non_negative(v, "display.black-cd-m2", hint));
    keep(&mut d.black_cd_m2, black, ok);
    if let Some(w) = raw.image_width_px {
        keep(
            &mut d.image_width_px,
            Some(c.pixels(w, "display.image-width-px", 1)),
            ok,
        );
    } else if camera.is_none() {
        c.error(
            "display.image-width-px",
            "missing required key: the plan describes no camera whose width the image has",
            Some("give the width of the captured frames in pixels"),
        );
        *ok = false;
    }
    if *ok && d.black_cd_m2 >= d.peak_cd_m2 {
        c.error(
            "display.black-cd-m2",
            format!(
                "must be below the peak luminance ({} cd/m^2), got {}",
                d.peak_cd_m2, d.black_cd_m2
            ),
            Some("black is the luminance of code 0, e.g. peak / 1000"),
        );
        *ok = false;
    }
    (*ok).then_some(Some(d))
}

/// The numeric keys with a range, each into its slot of `d`.
fn ranged_keys(c: &mut Checker<'_>, d: &mut Display, raw: &RawDisplay, ok: &mut bool) {
    // Ranges: a monitor refreshes at 1 to 1000 Hz; 0.01 to 1e5 cd/m^2
    // spans the dimmest night setting to a head-up display in sunlight;
    // images of 1 mm to 10 m, seen from 10 mm to 100 m.
    let ranged = [
        (
            &mut d.refresh_hz,
            raw.refresh_hz,
            "refresh-hz",
            (1.0, 1000.0),
            " Hz",
            "CMS monitors refresh at 60 Hz",
        ),
        (
            &mut d.peak_cd_m2,
            raw.peak_cd_m2,
            "peak-cd-m2",
            (0.01, 1e5),
            " cd/m^2",
            "the day preset is 500 cd/m^2, night 50",
        ),
        (
            &mut d.image_width_mm,
            raw.image_width_mm,
            "image-width-mm",
            (1.0, 1e4),
            " mm",
            "a 7-inch 16:9 panel is 155 mm wide",
        ),
        (
            &mut d.distance_mm,
            raw.distance_mm,
            "distance-mm",
            (10.0, 1e5),
            " mm",
            "a door-mounted monitor is about 700 mm from the eye",
        ),
        (
            &mut d.full_scale_dn,
            raw.full_scale_dn,
            "full-scale-dn",
            (1e-3, 1e9),
            " DN",
            "the camera code shown as white, e.g. 255 for 8 bits",
        ),
    ];
    for (slot, value, key, range, unit, hint) in ranged {
        let checked = value.map(|v| c.within(v, &format!("display.{key}"), range, unit, hint));
        keep(slot, checked, ok);
    }
}

/// A `visibility-max` needs the monitor the visibility is computed for:
/// without `[display]` it is an error, not a limit silently never checked.
pub(super) fn limit_needs_display(
    c: &mut Checker<'_>,
    t: &crate::plan::Thresholds,
    display: Option<&Display>,
) -> Option<()> {
    if display.is_some() {
        return Some(());
    }
    let levels = t.light_levels.iter().enumerate();
    let mut keys: Vec<String> = levels
        .filter(|(_, l)| l.limits.visibility_max.is_some())
        .map(|(i, _)| format!("thresholds.light-level[{i}].visibility-max"))
        .collect();
    if t.visibility_max.is_some() {
        keys.insert(0, "thresholds.visibility-max".to_string());
    }
    for key in &keys {
        c.error(
            key,
            "needs a [display] table: visibility is computed for a monitor",
            Some("add [display] (e.g. preset = \"night\"), or remove the limit"),
        );
    }
    keys.is_empty().then_some(())
}

#[cfg(test)]
mod tests {
    use crate::plan::display::{DisplayPreset, Eotf};

    const BASE: &str = include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/fixtures/plans/base.toml"
    ));

    fn parse(extra: &str) -> Result<crate::plan::Plan, String> {
        let text = format!("{BASE}\n{extra}\n");
        crate::plan::parse(&text, std::path::Path::new("p.toml"), String::new())
            .map_err(|e| e.to_string())
    }

    #[test]
    fn a_night_preset_fills_every_default_from_the_camera() {
        let p = parse("[display]\npreset = \"night\"\neotf = \"bt1886\"").unwrap();
        let d = p.display.unwrap();
        assert_eq!((d.preset, d.eotf), (DisplayPreset::Night, Eotf::Bt1886));
        assert_eq!((d.peak_cd_m2, d.black_cd_m2), (50.0, 0.05));
        assert_eq!(
            (d.refresh_hz, d.distance_mm, d.image_width_mm),
            (60.0, 700.0, 155.0)
        );
        assert_eq!((d.full_scale_dn, d.image_width_px), (255.0, 1280));
        assert!(parse("").unwrap().display.is_none());
    }

    #[test]
    fn a_peak_alone_keeps_the_contrast_ratio_and_a_black_above_it_is_refused() {
        let d = parse("[display]\npeak-cd-m2 = 200.0")
            .unwrap()
            .display
            .unwrap();
        assert!((d.black_cd_m2 - 0.2).abs() < 1e-12);
        let e = parse("[display]\npeak-cd-m2 = 200.0\nblack-cd-m2 = 300.0").unwrap_err();
        assert!(
            e.contains("display.black-cd-m2") && e.contains("below the peak"),
            "{e}"
        );
    }

    #[test]
    fn bad_display_keys_and_a_limit_without_display_are_named() {
        let e = parse("[display]\npreset = \"dusk\"\nrefresh-hz = 0.0\ndistance-mm = -1.0")
            .unwrap_err();
        for key in [
            "display.preset",
            "display.refresh-hz",
            "display.distance-mm",
        ] {
            assert!(e.contains(key), "{key}: {e}");
        }
        let text = BASE.replace("[thresholds]", "[thresholds]\nvisibility-max = 1.0");
        let e = crate::plan::parse(&text, std::path::Path::new("p.toml"), String::new())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("thresholds.visibility-max") && e.contains("[display]"),
            "{e}"
        );
    }
}
