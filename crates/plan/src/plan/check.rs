//! The all-errors collector shared by the checks of every table: a
//! [`Checker`] turns a failed check into a [`Diagnostic`] with the key's
//! file, line and column, and carries on, so that the user sees all the
//! problems of a file in one run. The generic checks (required, ranges,
//! grids, named choices) live here; each table's own checks are in
//! `validate/`. Plausibility warnings (a value that is valid but most
//! likely in the wrong unit) go to a second list: they are printed, and
//! never stop a run.

use std::path::PathBuf;

use super::Diagnostic;
use super::raw::RawRange;
use super::spans::SpanIndex;

/// Largest grid along one axis.
const MAX_GRID_POINTS: usize = 10_000;

/// Where a fraction's upper end lies: see [`Checker::up_to_one`].
#[derive(Debug, Clone, Copy)]
pub(super) enum One {
    /// `value <= 1`.
    AtMost,
    /// `value < 1`.
    Below,
}

/// A number for a message: plain in the range people write by hand,
/// else in exponent form (`5e-324`, not 324 digits).
pub(super) fn number(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e7).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A computed number for a message, to 6 significant digits with
/// trailing zeros dropped (`14.565`, not `14.565000000000001`); [`number`]
/// outside the range people write by hand.
pub(super) fn approx(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || !(1e-4..1e7).contains(&a) {
        return number(x);
    }
    let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Stores an optional key's checked value in `slot`: `checked` is `None`
/// when the key is absent (`slot` keeps its default), `Some(None)` when the
/// value was invalid (reported already; clears `ok`).
pub(super) fn keep<T>(slot: &mut T, checked: Option<Option<T>>, ok: &mut bool) {
    match checked {
        None => {}
        Some(Some(v)) => *slot = v,
        Some(None) => *ok = false,
    }
}

/// Collects the diagnostics of one file: every check reports here and
/// carries on.
pub(super) struct Checker<'a> {
    index: &'a SpanIndex,
    diags: &'a mut Vec<Diagnostic>,
    warnings: &'a mut Vec<Diagnostic>,
    /// Set while checking a file other than the plan (a camera profile).
    file: Option<PathBuf>,
}

impl<'a> Checker<'a> {
    /// A checker of the plan file itself, located by `index`; errors go
    /// to `diags`, plausibility warnings to `warnings`.
    pub(super) fn new(
        index: &'a SpanIndex,
        diags: &'a mut Vec<Diagnostic>,
        warnings: &'a mut Vec<Diagnostic>,
    ) -> Self {
        Checker {
            index,
            diags,
            warnings,
            file: None,
        }
    }

    /// A checker of another file (a camera profile) that reports into the
    /// same list, each diagnostic naming `file`.
    pub(super) fn for_file<'b>(&'b mut self, index: &'b SpanIndex, file: PathBuf) -> Checker<'b> {
        Checker {
            index,
            diags: &mut *self.diags,
            warnings: &mut *self.warnings,
            file: Some(file),
        }
    }

    /// Reports `message` at `key` (or at its nearest enclosing table in the
    /// file).
    pub(super) fn error(&mut self, key: &str, message: impl Into<String>, hint: Option<&str>) {
        let d = self.diagnostic(key, message.into(), hint);
        self.diags.push(d);
    }

    /// Warns at `key` of a value that is valid but implausible, most
    /// likely given in another unit: `message` names the likely unit and
    /// `hint` the value it would be. The plan stays valid.
    pub(super) fn warn(&mut self, key: &str, message: impl Into<String>, hint: &str) {
        let d = self.diagnostic(key, message.into(), Some(hint));
        self.warnings.push(d);
    }

    /// A diagnostic at `key`; a key that is absent from the file is
    /// located at its nearest enclosing table.
    fn diagnostic(&self, key: &str, message: String, hint: Option<&str>) -> Diagnostic {
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
        Diagnostic {
            file: self.file.clone(),
            key: key.to_string(),
            location,
            message,
            hint: hint.map(str::to_string),
        }
    }

    /// Reports `message` at `key`, located at `anchor` (or its nearest
    /// enclosing table): for a missing table, the key that makes it needed.
    pub(super) fn error_near(
        &mut self,
        key: &str,
        anchor: &str,
        message: impl Into<String>,
        hint: Option<&str>,
    ) {
        let before = self.diags.len();
        self.error(anchor, message, hint);
        if let Some(d) = self.diags.get_mut(before) {
            d.key = key.to_string();
        }
    }

    /// `value`, reporting a missing key when it is `None`.
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
            self.error(
                key,
                format!("must be > 0, got {}", number(value)),
                Some(hint),
            );
            None
        }
    }

    /// `value` must be finite and >= 0.
    pub(super) fn non_negative(&mut self, value: f64, key: &str, hint: &str) -> Option<f64> {
        if value.is_finite() && value >= 0.0 {
            Some(value)
        } else {
            self.error(
                key,
                format!("must be >= 0, got {}", number(value)),
                Some(hint),
            );
            None
        }
    }

    /// `value` must be finite and in `range` (both ends included); `unit`
    /// follows the numbers in the message, e.g. " Hz" or "".
    pub(super) fn within(
        &mut self,
        value: f64,
        key: &str,
        range: (f64, f64),
        unit: &str,
        hint: &str,
    ) -> Option<f64> {
        let (lo, hi) = range;
        let message = if value.is_nan() {
            "must be a number, got NaN".to_string()
        } else if value < lo {
            format!(
                "{}{unit} is below the {}{unit} limit",
                number(value),
                number(lo)
            )
        } else if value > hi {
            format!(
                "{}{unit} is above the {}{unit} limit",
                number(value),
                number(hi)
            )
        } else {
            return Some(value);
        };
        self.error(key, message, Some(hint));
        None
    }

    /// A duty cycle, in (0, 1].
    pub(super) fn duty(&mut self, value: f64, key: &str) -> Option<f64> {
        if value.is_finite() && value > 0.0 && value <= 1.0 {
            Some(value)
        } else {
            self.error(
                key,
                format!("duty cycle {} is outside (0, 1]", number(value)),
                Some("a duty cycle is a fraction: write 0.05 for 5% and 1.0 for steady ON"),
            );
            None
        }
    }

    /// A pixel count or coordinate, an integer in `min..=u32::MAX`.
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
    pub(super) fn grid(
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

    /// One of the named `options`; `default` when the key is absent.
    pub(super) fn choice<T: Copy>(
        &mut self,
        value: Option<String>,
        key: &str,
        default: T,
        options: &[(&str, T)],
    ) -> Option<T> {
        let Some(v) = value else {
            return Some(default);
        };
        if let Some((_, t)) = options.iter().find(|(name, _)| *name == v) {
            return Some(*t);
        }
        let names: Vec<String> = options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        self.error(
            key,
            format!("unknown value `{v}`"),
            Some(&format!("use {}", names.join(" or "))),
        );
        None
    }

    /// The upper end of a fraction, checked after its lower end: `value`
    /// (`None` when the lower check failed) must not exceed 1 (`AtMost`) or
    /// must stay below it (`Below`). `what` starts the message, e.g.
    /// "reflectance " or "".
    pub(super) fn up_to_one(
        &mut self,
        value: Option<f64>,
        bound: One,
        key: &str,
        what: &str,
        hint: &str,
    ) -> Option<f64> {
        let v = value?;
        let (within, message) = match bound {
            One::AtMost => (v <= 1.0, format!("{what}{v} is above 1")),
            One::Below => (v < 1.0, format!("{what}{v} is not below 1")),
        };
        if within {
            return Some(v);
        }
        self.error(key, message, Some(hint));
        None
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

#[cfg(test)]
mod tests {
    use super::approx;

    #[test]
    fn approx_keeps_six_significant_digits_and_drops_trailing_zeros() {
        assert_eq!(approx(0.014565 * 1e3), "14.565");
        assert_eq!(approx(0.1 + 0.2), "0.3");
        assert_eq!(approx(0.15 * 100.0), "15");
        assert_eq!(approx(2000.0), "2000");
        assert_eq!(approx(0.034_955_999_9), "0.034956");
        assert_eq!(approx(-1.5), "-1.5");
        // Outside the hand-written range: exponent form, as `number`.
        assert_eq!(approx(5e-324), "5e-324");
        assert_eq!(approx(0.0), "0");
    }
}
