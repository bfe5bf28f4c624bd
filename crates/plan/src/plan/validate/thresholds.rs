//! `[thresholds]` and `[[thresholds.light-level]]`: pass limits, from the
//! serde mirror to a validated [`Thresholds`].
//!
//! Limits on the Deegan 2018 metrics (`fdi-2018-min`, `percent-flicker-max`)
//! and the IEEE P2020 KPIs (`fmi-max`, `fdi-p2020-min`, `mmp-min`), and on the
//! visibility of the displayed flicker (`visibility-max`, with `[display]`)
//! and on the chromaticity excursion (`delta-uv-max`, with colour), are set
//! globally and may be overridden per light level. Every problem is reported
//! with its key, line and a hint, as for the rest of the plan.

use super::grid::warn_low_frequency;
use crate::plan::check::{Checker, approx};
use crate::plan::raw::{RawLevelThresholds, RawThresholds};
use crate::plan::{LevelLimits, Limits, Thresholds, VerdictBasis};

/// Defaults: FDI (2018) >= 0.1 (Deegan 2018), nothing else checked, every
/// frequency in the mitigation range, verdicts on the worst phase.
fn defaults() -> Thresholds {
    Thresholds {
        limits: Limits {
            fdi_2018_min: Some(0.1),
            ..Limits::default()
        },
        light_levels: Vec::new(),
        mitigation_min_hz: 0.0,
        mitigation_max_hz: None,
        basis: VerdictBasis::WorstPhase,
    }
}

/// Checks one limit: finite, and inside `range` when given.
fn limit(
    c: &mut Checker<'_>,
    value: Option<f64>,
    key: &str,
    range: Option<(f64, f64)>,
    hint: &str,
    ok: &mut bool,
) -> Option<f64> {
    let v = value?;
    let in_range = v.is_finite() && range.is_none_or(|(lo, hi)| (lo..=hi).contains(&v));
    if in_range {
        return Some(v);
    }
    let message = match range {
        Some((lo, hi)) if v.is_finite() => format!("{v} is outside [{lo}, {hi}]"),
        _ => format!("must be a finite number, got {v}"),
    };
    c.error(key, message, Some(hint));
    *ok = false;
    None
}

/// Warns of a Percent Flicker limit in (0, 1): the metric is in percent,
/// and a limit under 1 % is far stricter than any in use (IEEE 1789's
/// low-risk line is 8 % at 100 Hz), so it is most likely a fraction
/// (0.15 for 15 %). 0 is kept silent: it asks for no flicker at all.
fn warn_fraction_of_percent(c: &mut Checker<'_>, key: &str, v: Option<f64>) {
    if let Some(v) = v
        && v > 0.0
        && v < 1.0
    {
        c.warn(
            key,
            format!(
                "a Percent Flicker limit of {} % is below 1 %: likely given as a fraction",
                approx(v)
            ),
            &format!(
                "percent-flicker-max is in percent: the fraction {} is {} %; write {}",
                approx(v),
                approx(v * 100.0),
                approx(v * 100.0)
            ),
        );
    }
}

/// The limit keys of a table as written (`raw`), checked. `prefix` is the
/// table's key path.
fn limits(c: &mut Checker<'_>, raw: Limits, prefix: &str, ok: &mut bool) -> Limits {
    let k = |name: &str| format!("{prefix}.{name}");
    let pf_key = k("percent-flicker-max");
    let share = Some((0.0, 1.0));
    let limits = Limits {
        fdi_2018_min: limit(
            c,
            raw.fdi_2018_min,
            &k("fdi-2018-min"),
            None,
            "Deegan 2018 uses 0.1: below it the light appears OFF",
            ok,
        ),
        percent_flicker_max: limit(
            c,
            raw.percent_flicker_max,
            &k("percent-flicker-max"),
            Some((0.0, f64::INFINITY)),
            "a percentage, e.g. 10.0",
            ok,
        ),
        fmi_max: limit(
            c,
            raw.fmi_max,
            &k("fmi-max"),
            share,
            "FMI is (max - min) / (max + min), 0..1; e.g. 0.1",
            ok,
        ),
        fdi_p2020_min: limit(
            c,
            raw.fdi_p2020_min,
            &k("fdi-p2020-min"),
            share,
            "the share of PWM frames in which the light is seen, 0..1; e.g. 0.95",
            ok,
        ),
        mmp_min: limit(
            c,
            raw.mmp_min,
            &k("mmp-min"),
            share,
            "the share of PWM frames within the band around the reference, 0..1; e.g. 0.9",
            ok,
        ),
        visibility_max: limit(
            c,
            raw.visibility_max,
            &k("visibility-max"),
            Some((0.0, f64::INFINITY)),
            "1 is the standard observer's threshold; e.g. 1.0",
            ok,
        ),
        delta_uv_max: limit(
            c,
            raw.delta_uv_max,
            &k("delta-uv-max"),
            Some((0.0, f64::INFINITY)),
            "a distance in CIE 1976 u'v', >= 0; e.g. 0.01",
            ok,
        ),
    };
    warn_fraction_of_percent(c, &pf_key, limits.percent_flicker_max);
    limits
}

fn level(
    c: &mut Checker<'_>,
    raw: RawLevelThresholds,
    i: usize,
    known_lux: Option<&[f64]>,
    seen: &mut Vec<f64>,
    ok: &mut bool,
) -> Option<LevelLimits> {
    let prefix = format!("thresholds.light-level[{i}]");
    let lux_key = format!("{prefix}.light-lux");
    let lux = c.required(
        raw.light_lux,
        &lux_key,
        "the light level these limits apply to, e.g. light-lux = 40.0",
    );
    let lim = limits(
        c,
        Limits {
            fdi_2018_min: raw.fdi_2018_min,
            percent_flicker_max: raw.percent_flicker_max,
            fmi_max: raw.fmi_max,
            fdi_p2020_min: raw.fdi_p2020_min,
            mmp_min: raw.mmp_min,
            visibility_max: raw.visibility_max,
            delta_uv_max: raw.delta_uv_max,
        },
        &prefix,
        ok,
    );
    let lux = lux.and_then(|v| c.positive(v, &lux_key, "illuminance in lux, e.g. 40.0"));
    let Some(lux) = lux else {
        *ok = false;
        return None;
    };
    if seen.contains(&lux) {
        c.error(
            &lux_key,
            format!("{lux} lux has limits already"),
            Some("give each light level one [[thresholds.light-level]] table"),
        );
        *ok = false;
    }
    seen.push(lux);
    if let Some(known) = known_lux
        && !known.contains(&lux)
    {
        let list: Vec<String> = known.iter().map(|l| format!("{l}")).collect();
        c.error(
            &lux_key,
            format!("no case is at {lux} lux"),
            Some(&format!(
                "the plan's light levels are: {}",
                if list.is_empty() {
                    "none (no case declares light-lux)".to_string()
                } else {
                    list.join(", ")
                }
            )),
        );
        *ok = false;
    }
    Some(LevelLimits {
        light_lux: lux,
        limits: lim,
    })
}

/// Validates `[thresholds]`. `known_lux` holds the plan's light levels
/// (`[light]`, or the cases' `light-lux`), `None` when they are invalid.
/// Returns `None` after reporting an error.
pub(super) fn thresholds(
    c: &mut Checker<'_>,
    raw: Option<RawThresholds>,
    known_lux: Option<&[f64]>,
) -> Option<Thresholds> {
    let mut th = defaults();
    let Some(t) = raw else {
        return Some(th);
    };
    let mut ok = true;
    let global = limits(
        c,
        Limits {
            fdi_2018_min: t.fdi_2018_min,
            percent_flicker_max: t.percent_flicker_max,
            fmi_max: t.fmi_max,
            fdi_p2020_min: t.fdi_p2020_min,
            mmp_min: t.mmp_min,
            visibility_max: t.visibility_max,
            delta_uv_max: t.delta_uv_max,
        },
        "thresholds",
        &mut ok,
    );
    th.limits = global.over(th.global());
    let mut seen = Vec::new();
    for (i, raw) in t.light_level.into_iter().enumerate() {
        if let Some(l) = level(c, raw, i, known_lux, &mut seen, &mut ok) {
            th.light_levels.push(l);
        }
    }
    if let Some(v) = t.mitigation_min_hz {
        match c.non_negative(
            v,
            "thresholds.mitigation-min-hz",
            "e.g. 90.0: cases below are informational",
        ) {
            Some(v) => {
                th.mitigation_min_hz = v;
                let key = "thresholds.mitigation-min-hz";
                let note = ", so cases from there up are judged";
                warn_low_frequency(
                    c,
                    (key, "mitigation-min-hz"),
                    "the mitigation range's lower end",
                    v,
                    note,
                );
            }
            None => ok = false,
        }
    }
    if let Some(v) = t.mitigation_max_hz {
        match c.positive(
            v,
            "thresholds.mitigation-max-hz",
            "omit it for no upper limit",
        ) {
            Some(v) if v >= th.mitigation_min_hz => {
                th.mitigation_max_hz = Some(v);
                let key = "thresholds.mitigation-max-hz";
                let note = ", so every case above it is not judged";
                warn_low_frequency(
                    c,
                    (key, "mitigation-max-hz"),
                    "the mitigation range's upper end",
                    v,
                    note,
                );
            }
            Some(v) => {
                c.error(
                    "thresholds.mitigation-max-hz",
                    format!(
                        "{v} Hz is below mitigation-min-hz {} Hz",
                        th.mitigation_min_hz
                    ),
                    Some("the range is mitigation-min-hz ..= mitigation-max-hz"),
                );
                ok = false;
            }
            None => ok = false,
        }
    }
    match t.basis.as_deref() {
        None | Some("worst-phase") => {}
        Some("as-captured") => th.basis = VerdictBasis::AsCaptured,
        Some(other) => {
            c.error(
                "thresholds.basis",
                format!("unknown basis `{other}`"),
                Some("use \"worst-phase\" (default) or \"as-captured\""),
            );
            ok = false;
        }
    }
    ok.then_some(th)
}
