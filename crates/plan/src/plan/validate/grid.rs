//! `[light]` (ambient light levels) and `[grid]` (PWM frequencies and duty
//! cycles): the axes a simulator or command plan expands into cases.

use crate::plan::bounds::{MAX_FREQUENCY_HZ, MAX_LIGHT_LUX, MIN_DUTY, MIN_LIGHT_LUX};
use crate::plan::check::{Checker, approx};
use crate::plan::raw::{RawGrid, RawLight};

/// A light level in lux, in `MIN_LIGHT_LUX ..= MAX_LIGHT_LUX`.
pub(super) fn light_lux(c: &mut Checker<'_>, v: f64, key: &str) -> Option<f64> {
    let v = c.positive(
        v,
        key,
        "illuminance in lux: 40 for low light, 2000 for daylight",
    )?;
    let hint = "a moonless overcast night is about 0.0001 lux, direct sunlight about 100000";
    c.within(v, key, (MIN_LIGHT_LUX, MAX_LIGHT_LUX), " lux", hint)
}

/// The range of a PWM frequency when the PWM segment lasts `pwm_s`
/// seconds (`None`: invalid, and reported already; then only > 0 is
/// checked below): at least one period in the segment, at most
/// [`MAX_FREQUENCY_HZ`].
pub(super) fn frequency_range(pwm_s: Option<f64>) -> (f64, f64) {
    let lowest = pwm_s.map_or(0.0, |s| 1.0 / s);
    (lowest, MAX_FREQUENCY_HZ)
}

/// A PWM frequency in Hz, within `range` ([`frequency_range`]).
pub(super) fn frequency_hz(
    c: &mut Checker<'_>,
    v: f64,
    key: &str,
    range: (f64, f64),
) -> Option<f64> {
    let v = c.positive(v, key, "PWM frequency in Hz, e.g. 90.0")?;
    let hint = "at least one PWM period in [sequence] pwm-s; lamps' PWM runs below 100 kHz";
    c.within(v, key, range, " Hz", hint)
}

/// Lowest PWM frequency taken at face value, Hz. Below a few hertz a
/// light blinks visibly rather than dims: LED PWM runs from the mains
/// multiples (50 to 120 Hz) to tens of kHz, and a value under 5 is far more
/// likely one in kHz (0.09 for 90 Hz, 2 for 2 kHz).
pub(super) const MIN_PLAUSIBLE_PWM_HZ: f64 = 5.0;

/// Warns at `key` of `what` (e.g. "a PWM frequency") of `v` Hz when it
/// is below [`MIN_PLAUSIBLE_PWM_HZ`]; `name` is the key as the user
/// writes it, `note` ends the message (what the slip leads to).
pub(super) fn warn_low_frequency(
    c: &mut Checker<'_>,
    (key, name): (&str, &str),
    what: &str,
    v: f64,
    note: &str,
) {
    if v > 0.0 && v < MIN_PLAUSIBLE_PWM_HZ {
        c.warn(
            key,
            format!(
                "{what} of {} Hz is below 5 Hz{note}: likely given in kHz",
                approx(v)
            ),
            &format!(
                "{name} is in hertz: {} kHz is {} Hz; LED PWM runs from 50 Hz to tens of kHz",
                approx(v),
                approx(v * 1e3)
            ),
        );
    }
}

/// A duty cycle in `MIN_DUTY ..= 1`.
pub(super) fn duty(c: &mut Checker<'_>, v: f64, key: &str) -> Option<f64> {
    let d = c.duty(v, key)?;
    c.within(
        d,
        key,
        (MIN_DUTY, 1.0),
        "",
        "a duty cycle is a fraction: 0.05 for 5%; PWM counters do not resolve less than 1e-6",
    )
}

/// Validates `[light]`, which is required: the light levels in lux.
pub(super) fn light_table(c: &mut Checker<'_>, raw: Option<RawLight>) -> Option<Vec<f64>> {
    let light = c.required(raw, "light", "add [light] with levels-lux = [2000.0]")?;
    let list = c.required(
        light.levels_lux,
        "light.levels-lux",
        "e.g. levels-lux = [40.0, 2000.0]",
    )?;
    c.grid(
        Some(list),
        None,
        "light.levels-lux",
        "light.levels-lux",
        &mut light_lux,
    )
}

/// Validates `[grid]`, which is required: PWM frequencies in Hz and duty
/// cycles, each a list or a range. `pwm_s` is the PWM segment's length,
/// `None` when invalid.
pub(super) fn grid_table(
    c: &mut Checker<'_>,
    raw: Option<RawGrid>,
    pwm_s: Option<f64>,
) -> (Option<Vec<f64>>, Option<Vec<f64>>) {
    let Some(g) = c.required(
        raw,
        "grid",
        "add [grid] with frequencies-hz and duty-cycles",
    ) else {
        return (None, None);
    };
    let list_key = match &g.frequencies_hz {
        Some(_) => "grid.frequencies-hz",
        None => "grid.frequency-range-hz",
    };
    let freqs = c.grid(
        g.frequencies_hz,
        g.frequency_range_hz,
        "grid.frequencies-hz",
        "grid.frequency-range-hz",
        &mut |c, v, k| frequency_hz(c, v, k, frequency_range(pwm_s)),
    );
    let duties = c.grid(
        g.duty_cycles,
        g.duty_cycle_range,
        "grid.duty-cycles",
        "grid.duty-cycle-range",
        &mut duty,
    );
    if let Some(f) = &freqs
        && let Some(i) = f.iter().position(|&v| v < MIN_PLAUSIBLE_PWM_HZ)
    {
        // One warning for the grid, at its first low value: a grid
        // written in kHz is low throughout.
        let low = f.iter().filter(|&&v| v < MIN_PLAUSIBLE_PWM_HZ).count();
        let key = match list_key {
            "grid.frequencies-hz" => format!("{list_key}[{i}]"),
            _ => format!("{list_key}.start"),
        };
        let note = format!(
            " ({low} of the grid's {} frequencies, each run at every duty cycle)",
            f.len()
        );
        let name = list_key.trim_start_matches("grid.");
        warn_low_frequency(c, (&key, name), "a PWM frequency", f[i], &note);
    }
    (freqs, duties)
}
