//! `[p2020]`: the IEEE P2020 KPI settings, from the serde mirror to
//! validated [`P2020Options`].

use crate::plan::check::{Checker, One, keep};
use crate::plan::raw::RawP2020;
use crate::plan::{MmpReference, P2020Options};

/// Validates `[p2020]`; the defaults are the P2020 reference code's.
pub(super) fn p2020_options(c: &mut Checker<'_>, raw: Option<RawP2020>) -> Option<P2020Options> {
    let mut o = P2020Options::default();
    let Some(raw) = raw else {
        return Some(o);
    };
    let mut ok = true;
    let contrast = raw
        .contrast_threshold
        .map(|v| c.positive(v, "p2020.contrast-threshold", "the reference code uses 0.1"));
    keep(&mut o.contrast_threshold, contrast, &mut ok);
    let delta = raw.mmp_delta.map(|v| {
        let key = "p2020.mmp-delta";
        let v = c.positive(v, key, "a fraction; the reference code uses 0.1");
        let hint = "a fraction of the reference level; the reference code uses 0.1";
        c.up_to_one(v, One::Below, key, "", hint)
    });
    keep(&mut o.mmp_delta, delta, &mut ok);
    let reference = c.choice(
        raw.mmp_reference,
        "p2020.mmp-reference",
        MmpReference::PwmMean,
        &[
            ("pwm-mean", MmpReference::PwmMean),
            ("on-level", MmpReference::OnLevel),
        ],
    );
    keep(&mut o.mmp_reference, Some(reference), &mut ok);
    ok.then_some(o)
}
