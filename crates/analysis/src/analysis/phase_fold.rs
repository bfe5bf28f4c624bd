//! The flicker signal and phase coverage (after Sumner, "Describing and
//! sampling the LED flicker signal", IS&T EI 2020).
//!
//! The camera's response as a function of the PWM phase at which an
//! exposure starts is the whole story; a video only samples it. Folding a
//! trace by phase, `frac((t_n + row offset) * f)`, rebuilds that response
//! from simulated and captured data alike. The phase circle is cut into
//! [`PHASE_BINS`] bins; a capture "covers" the bins its frames fall in.

pub use ledflicker_results::analysis::phase_fold::PhaseCoverage;

use ledflicker_physics::pwm::wrap_unit;
use ledflicker_physics::remainder::rem;

/// Bins of the phase circle. With an exposure of `w` PWM cycles the ROI
/// mean changes by at most `2 / w` of its range per cycle, so a sample
/// anywhere in a bin is within `2 / (64 w)` of the bin's extreme.
pub const PHASE_BINS: usize = 64;

/// Longest capture considered when computing how long a capture must be,
/// seconds (one hour).
pub const MAX_NEEDED_CAPTURE_S: f64 = 3600.0;

/// (phase in cycles `[0, 1)`, luma) of every PWM frame: the start of frame
/// `frames[i]` (`frames[i] / fps` seconds) plus `row_offset_s` (rolling
/// shutter: the ROI's first row), times `frequency_hz`, modulo 1. Phase 0 is
/// frame 0's row 0. The cycle count is reduced exactly, as in
/// [`ledflicker_physics::PwmDrive::phase_at`], so phase-locked frames fold onto
/// one phase.
pub fn fold(
    frames: &[u64],
    luma: &[f64],
    frequency_hz: f64,
    fps: f64,
    row_offset_s: f64,
) -> Vec<(f64, f64)> {
    let offset = wrap_unit(row_offset_s * frequency_hz);
    frames
        .iter()
        .zip(luma)
        .map(|(&n, &y)| (frame_phase(n, frequency_hz, fps, offset), y))
        .collect()
}

/// (phase in cycles `[0, 1)`, luma) of frames starting at `times_s`
/// seconds: `frac((t + row_offset_s) * frequency_hz)`. Used for captures and
/// rigs, whose frames carry their own times (drops and a variable frame
/// rate fold where the frames really fell).
pub fn fold_times(
    times_s: &[f64],
    luma: &[f64],
    frequency_hz: f64,
    row_offset_s: f64,
) -> Vec<(f64, f64)> {
    let offset = wrap_unit(row_offset_s * frequency_hz);
    times_s
        .iter()
        .zip(luma)
        .map(|(&t, &y)| (wrap_unit((t * frequency_hz).rem_euclid(1.0) + offset), y))
        .collect()
}

fn frame_phase(n: u64, frequency_hz: f64, fps: f64, offset: f64) -> f64 {
    wrap_unit(rem(n as f64 * frequency_hz, fps) / fps + offset)
}

fn bin_of(phase: f64, bins: usize) -> usize {
    ((phase * bins as f64) as usize).min(bins - 1)
}

/// Number of the `bins` bins hit by `phases` (each in `[0, 1)`).
pub fn covered_bins(phases: impl IntoIterator<Item = f64>, bins: usize) -> usize {
    let mut hit = vec![false; bins];
    for p in phases {
        hit[bin_of(p, bins)] = true;
    }
    hit.iter().filter(|&&h| h).count()
}

/// Frames needed, from frame 0, until the phases `frac(phase0 + n f / fps)`
/// have hit all `bins` bins; `None` if `max_frames` do not.
pub fn frames_to_cover(
    frequency_hz: f64,
    fps: f64,
    phase0: f64,
    bins: usize,
    max_frames: u64,
) -> Option<u64> {
    let mut hit = vec![false; bins];
    let mut left = bins;
    for n in 0..max_frames {
        // f / fps = p / n exactly: frame n repeats frame 0's phase, and so
        // does every later frame repeat an earlier one. Nothing new will come.
        if n > 0 && rem(n as f64 * frequency_hz, fps) == 0.0 {
            return None;
        }
        let b = bin_of(frame_phase(n, frequency_hz, fps, phase0), bins);
        if !hit[b] {
            hit[b] = true;
            left -= 1;
            if left == 0 {
                return Some(n + 1);
            }
        }
    }
    None
}

/// Per-bin (min, max) of folded samples; `None` for empty bins.
pub fn bin_extremes(points: &[(f64, f64)], bins: usize) -> Vec<Option<(f64, f64)>> {
    let mut out: Vec<Option<(f64, f64)>> = vec![None; bins];
    for &(p, y) in points {
        let slot = &mut out[bin_of(p, bins)];
        *slot = Some(match *slot {
            None => (y, y),
            Some((lo, hi)) => (lo.min(y), hi.max(y)),
        });
    }
    out
}

/// Phase coverage of a PWM-segment trace: `points` from [`fold`], the
/// frame rate `fps`, the PWM `frequency_hz`, the phase of the first point,
/// and the exact luma envelope over phase when known.
pub fn coverage(
    points: &[(f64, f64)],
    fps: f64,
    frequency_hz: f64,
    envelope: Option<(f64, f64)>,
) -> PhaseCoverage {
    coverage_over(
        points,
        fps,
        points.len() as f64 / fps,
        frequency_hz,
        envelope,
    )
}

/// [`coverage`] of a capture lasting `capture_s` seconds (its frames' own
/// times; frames may be missing).
pub fn coverage_over(
    points: &[(f64, f64)],
    fps: f64,
    capture_s: f64,
    frequency_hz: f64,
    envelope: Option<(f64, f64)>,
) -> PhaseCoverage {
    let bins = PHASE_BINS;
    let covered = covered_bins(points.iter().map(|p| p.0), bins);
    let phase0 = points.first().map_or(0.0, |p| p.0);
    let max_frames = (MAX_NEEDED_CAPTURE_S * fps).ceil() as u64;
    let needed_capture_s =
        frames_to_cover(frequency_hz, fps, phase0, bins, max_frames).map(|n| n as f64 / fps);
    let (tmin, tmax) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let worst_case_seen = envelope.map(|(lo, hi)| {
        let tol = 0.01 * (hi - lo) + 1e-9 * hi.abs().max(1.0);
        tmin <= lo + tol && tmax >= hi - tol
    });
    let coverage = covered as f64 / bins as f64;
    let short = match worst_case_seen {
        Some(seen) => !seen,
        None => covered < bins,
    };
    let warning = short.then(|| {
        let seen = match (worst_case_seen, envelope) {
            (Some(false), Some((lo, hi))) => format!(
                "; its luma spans {tmin:.3} to {tmax:.3} DN, but every phase spans {lo:.3} to {hi:.3} DN"
            ),
            _ => String::new(),
        };
        let need = match needed_capture_s {
            Some(s) => format!("covering every bin needs a capture of at least {s:.2} s at {fps} fps"),
            None => format!(
                "no capture up to {MAX_NEEDED_CAPTURE_S} s covers every bin: at or near phase lock, or f / fps is a ratio of small integers so frames revisit the same few phases; sweep the PWM phase or detune the PWM clock (a real clock drift of a few ppm does this slowly)"
            ),
        };
        format!(
            "the {capture_s:.2} s capture covered {:.1} % of the phase circle ({covered} of {bins} bins) and may not show the worst case{seen}; {need}",
            100.0 * coverage
        )
    });
    PhaseCoverage {
        bins,
        covered_bins: covered,
        coverage,
        capture_s,
        needed_capture_s,
        worst_case_seen,
        warning,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_physics::{PwmDrive, Shutter, ShutterModel};

    #[test]
    fn phase_locked_capture_covers_one_bin_and_never_more() {
        let frames: Vec<u64> = (0..1800).collect();
        let pts = fold(&frames, &vec![1.0; 1800], 90.0, 30.0, 0.0);
        assert_eq!(covered_bins(pts.iter().map(|p| p.0), PHASE_BINS), 1);
        let c = coverage(&pts, 30.0, 90.0, None);
        assert_eq!(c.needed_capture_s, None);
        assert!(c.warning.unwrap().contains("phase lock"));
    }

    #[test]
    fn frames_to_cover_matches_a_brute_force_count() {
        for (f, fps) in [(91.3, 30.0), (101.7, 30.0), (437.3, 29.97), (1000.3, 60.0)] {
            let n = frames_to_cover(f, fps, 0.0, 64, 1_000_000).unwrap();
            let count = |m: u64| covered_bins((0..m).map(|k| wrap_unit(k as f64 * f / fps)), 64);
            assert_eq!(count(n), 64, "f={f}");
            assert!(count(n - 1) < 64, "f={f}");
        }
        // 0.25 Hz beat at 30 fps: 1/120 cycle per frame; bin 63 starts at
        // 63/64 and is first hit by frame 119.
        assert_eq!(frames_to_cover(90.25, 30.0, 0.0, 64, 10_000), Some(120));
        // 91 Hz at 30 fps: f/fps = 91/30, so frames visit only 30 phases.
        assert_eq!(frames_to_cover(91.0, 30.0, 0.0, 64, 100_000), None);
    }

    /// Folding a simulated trace rebuilds the response: each sample equals
    /// the exposure's ON fraction at its folded phase.
    #[test]
    fn folded_trace_matches_the_response_at_each_phase() {
        let f = 151.3;
        let pwm = PwmDrive::new(f, 0.2, 0.0).unwrap();
        let shutter = Shutter {
            model: ShutterModel::Rolling { line_time_s: 20e-6 },
            exposure_s: 0.002,
            fps: 30.0,
        };
        let frames: Vec<u64> = (0..300).collect();
        let luma: Vec<f64> = frames
            .iter()
            .map(|&k| shutter.frame_on_fraction(&pwm, k, 100..101))
            .collect();
        let pts = fold(&frames, &luma, f, 30.0, shutter.row_offset_s(100));
        for (p, y) in pts {
            let want = pwm.on_fraction_at_phase(p, shutter.exposure_s * f);
            assert!((y - want).abs() < 1e-9, "phase {p}: {y} vs {want}");
        }
    }

    #[test]
    fn short_capture_near_lock_warns_and_says_how_long() {
        // 90.05 Hz at 30 fps: beat 20 s; a 4 s capture sees a fifth of it.
        let f = 90.05;
        // Frame 0 starts 0.3 cycles after a rising edge: the first 4 s sweep
        // phases 0.3..0.5, all in the OFF gap, and never see the maximum.
        let pwm = PwmDrive::new(f, 0.1, -0.3 / f).unwrap();
        let shutter = Shutter {
            model: ShutterModel::Global,
            exposure_s: 0.002,
            fps: 30.0,
        };
        let n = 120;
        let frames: Vec<u64> = (0..n).collect();
        let luma: Vec<f64> = (0..n)
            .map(|k| shutter.frame_on_fraction(&pwm, k, 0..1))
            .collect();
        let env = shutter.phase_envelope(&pwm, 0..1);
        let c = coverage(&fold(&frames, &luma, f, 30.0, 0.0), 30.0, f, Some(env));
        assert!(c.coverage < 0.3, "{c:?}");
        let need = c.needed_capture_s.unwrap();
        assert!((need - 20.0).abs() < 0.5, "{need}");
        assert!(c.warning.unwrap().contains("needs a capture"));
    }
}
