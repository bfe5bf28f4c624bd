//! `[light]` (ambient light levels) and `[grid]` (PWM frequencies and duty
//! cycles): the axes a simulator or command plan expands into cases.

use crate::plan::check::Checker;
use crate::plan::raw::{RawGrid, RawLight};

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
        &mut |c, v, k| {
            c.positive(
                v,
                k,
                "illuminance in lux: 40 for low light, 2000 for daylight",
            )
        },
    )
}

/// Validates `[grid]`, which is required: PWM frequencies in Hz and duty
/// cycles, each a list or a range.
pub(super) fn grid_table(
    c: &mut Checker<'_>,
    raw: Option<RawGrid>,
) -> (Option<Vec<f64>>, Option<Vec<f64>>) {
    let Some(g) = c.required(
        raw,
        "grid",
        "add [grid] with frequencies-hz and duty-cycles",
    ) else {
        return (None, None);
    };
    let freqs = c.grid(
        g.frequencies_hz,
        g.frequency_range_hz,
        "grid.frequencies-hz",
        "grid.frequency-range-hz",
        &mut |c, v, k| c.positive(v, k, "PWM frequency in Hz, e.g. 90.0"),
    );
    let duties = c.grid(
        g.duty_cycles,
        g.duty_cycle_range,
        "grid.duty-cycles",
        "grid.duty-cycle-range",
        &mut |c, v, k| c.duty(v, k),
    );
    (freqs, duties)
}
