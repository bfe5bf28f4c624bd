//! `format-version`, `[plan]` (identity of the plan) and `[sequence]`
//! (ON / OFF / PWM durations).

use crate::plan::check::Checker;
use crate::plan::raw::{RawMeta, RawSequence};

/// `[plan]`, checked; a missing or invalid id or title is `None`.
pub(super) struct Meta {
    pub(super) id: Option<String>,
    pub(super) title: Option<String>,
    pub(super) standard: String,
    pub(super) description: String,
    pub(super) lab: String,
    pub(super) seed: u64,
}

/// `format-version`: 1 or 2 when given.
pub(super) fn format_version(c: &mut Checker<'_>, version: Option<i64>) {
    if let Some(v) = version
        && !(1..=2).contains(&v)
    {
        c.error(
            "format-version",
            format!("unsupported plan format version {v}"),
            Some("this ledflicker reads format-version = 1 or 2 (see docs/changes.md)"),
        );
    }
}

/// Validates `[plan]`, which is required.
pub(super) fn plan_table(c: &mut Checker<'_>, raw: Option<RawMeta>) -> Meta {
    let mut out = Meta {
        id: None,
        title: None,
        standard: String::new(),
        description: String::new(),
        lab: String::new(),
        seed: 0,
    };
    let Some(meta) = c.required(raw, "plan", "add a [plan] table with id and title") else {
        return out;
    };
    out.id = c.required(meta.id, "plan.id", "e.g. id = \"daylight\"");
    if let Some(v) = &out.id
        && (v.is_empty()
            || !v
                .chars()
                .all(|ch| ch.is_ascii_lowercase() || ch.is_ascii_digit() || ch == '-' || ch == '_'))
    {
        c.error(
            "plan.id",
            format!("id `{v}` must be non-empty lowercase letters, digits, `-` or `_`"),
            Some("the id names the report directory, e.g. id = \"daylight-2000lux\""),
        );
        out.id = None;
    }
    out.title = c.required(
        meta.title,
        "plan.title",
        "a human title for the report cover",
    );
    out.standard = meta
        .standard
        .unwrap_or_else(|| "Deegan 2018 (IS&T EI AVM-146)".to_string());
    out.description = meta.description.unwrap_or_default();
    out.lab = meta.lab.unwrap_or_default();
    out.seed = match meta.seed {
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
    out
}

/// `[sequence]` durations in seconds, ON, OFF and PWM; the paper's 2 s,
/// 2 s and 60 s by default. An invalid one is `None`.
pub(super) fn sequence_table(
    c: &mut Checker<'_>,
    raw: Option<RawSequence>,
) -> (Option<f64>, Option<f64>, Option<f64>) {
    let hint_seq = "durations in seconds; the paper uses 2 s ON, 2 s OFF, 60 s PWM";
    let (mut on_s, mut off_s, mut pwm_s) = (Some(2.0), Some(2.0), Some(60.0));
    if let Some(s) = raw {
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
    (on_s, off_s, pwm_s)
}
