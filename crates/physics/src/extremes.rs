//! Extremes over phase of a response that is smooth between known
//! breakpoints.
//!
//! The physical camera's ROI luma, as a function of the PWM phase, is built
//! from capture ON times that are linear in phase between corners (a capture
//! window edge meets a PWM edge); the merge changes rule only where a
//! capture starts or stops saturating (or, for the weighted merge, crosses
//! its hat's knee); between those breakpoints each row's merged signal is
//! linear (longest-unsaturated) and the tone curve is concave (linear,
//! gamma >= 1, log), so the ROI mean is concave there. A concave function on
//! an interval takes its minimum at an end and its maximum either at an end
//! or at the single interior point where its slope changes sign.
//! [`extremes`] evaluates every breakpoint, probes the slope just inside
//! each end of every interval, and runs a golden-section search where the
//! slopes show an interior extreme, so the result is exact to the search's
//! tolerance ([`GOLDEN_TOL`] of a cycle) for such responses.

/// Width, in cycles, below which an interval is not probed further.
pub const MIN_INTERVAL: f64 = 1e-8;

/// Phase tolerance of the golden-section search, cycles.
pub const GOLDEN_TOL: f64 = 1e-10;

/// Lowest and highest `f(phase)` over `[0, 1)`, given every breakpoint of
/// `f` in `[0, 1)` (unsorted, duplicates allowed). `f` must be defined on
/// `[0, 1]` and periodic.
pub fn extremes(mut breaks: Vec<f64>, f: impl Fn(f64) -> f64) -> (f64, f64) {
    breaks.push(0.0);
    breaks.push(1.0);
    breaks.retain(|p| p.is_finite() && (0.0..=1.0).contains(p));
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();
    let values: Vec<f64> = breaks.iter().map(|&p| f(p)).collect();
    let mut lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let mut hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    for (w, v) in breaks.windows(2).zip(values.windows(2)) {
        let (a, b) = (w[0], w[1]);
        if b - a < MIN_INTERVAL {
            continue;
        }
        let h = ((b - a) * 1e-3).min(1e-7);
        let rise_a = f(a + h) - v[0];
        let rise_b = v[1] - f(b - h);
        if rise_a > 0.0 && rise_b < 0.0 {
            hi = hi.max(golden(a, b, &|p| f(p)));
        }
        if rise_a < 0.0 && rise_b > 0.0 {
            lo = lo.min(-golden(a, b, &|p| -f(p)));
        }
    }
    (lo, hi)
}

/// Maximum of a unimodal `f` on `[a, b]` by golden-section search.
fn golden(mut a: f64, mut b: f64, f: &dyn Fn(f64) -> f64) -> f64 {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut x1 = b - r * (b - a);
    let mut x2 = a + r * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    let mut best = f1.max(f2);
    while b - a > GOLDEN_TOL {
        if f1 < f2 {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + r * (b - a);
            f2 = f(x2);
        } else {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - r * (b - a);
            f1 = f(x1);
        }
        best = best.max(f1).max(f2);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A concave tone curve of a piecewise-linear signal: its interior
    /// maximum lies between breakpoints; a 1024-point grid misses it, the
    /// search does not.
    #[test]
    fn interior_maximum_of_a_concave_piece_is_found() {
        // Two rows: one rising, one falling with phase on [0.3, 0.7]; the
        // mean of their logs peaks where the signals meet.
        let row = |p: f64, up: bool| {
            let x = ((p - 0.3) / 0.4).clamp(0.0, 1.0);
            if up { 1.0 + 99.0 * x } else { 100.0 - 99.0 * x }
        };
        let f = |p: f64| 0.5 * ((1.0 + row(p, true)).ln() + (1.0 + row(p, false)).ln());
        let (lo, hi) = extremes(vec![0.3, 0.7], f);
        // Exact: ln(2 + 99x) + ln(101 - 99x) peaks where 2 + 99x = 101 - 99x.
        let x: f64 = 0.5;
        let want = 0.5 * ((2.0 + 99.0 * x).ln() + (101.0 - 99.0 * x).ln());
        assert!((hi - want).abs() < 1e-12, "{hi} vs {want}");
        assert!((lo - f(0.0)).abs() < 1e-15);
        let grid = (0..1024)
            .map(|i| f(0.3 + 0.4 * (i as f64 + 0.37) / 1024.0))
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(grid < want);
    }
}
