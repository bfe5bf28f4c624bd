use super::screen::Hold;
use super::*;
use ledflicker_plan::plan::display::{DisplayPreset, Eotf};

/// `n` equal holds over `period_s` with luminances `f(t_start)`.
fn sampled(n: usize, period_s: f64, f: impl Fn(f64) -> f64) -> Vec<Hold> {
    (0..n)
        .map(|j| {
            let (a, b) = (
                j as f64 * period_s / n as f64,
                (j + 1) as f64 * period_s / n as f64,
            );
            Hold {
                start_s: a,
                end_s: b,
                luminance_cd_m2: f(a),
            }
        })
        .collect()
}

#[test]
fn a_held_sinusoid_scores_its_modulation_times_the_csf() {
    // A sinusoid sampled at fs and held has, at f, the amplitude times
    // sinc(pi f / fs) exactly, and its images at k fs +- f lie above the
    // summed band: the index is m S(f) sinc(pi f / fs).
    let (fs, l0, radius) = (2000.0, 40.0, 0.8);
    for &(f, m) in &[(2.0, 0.05), (10.0, 0.01), (18.0, 0.2), (45.0, 0.5)] {
        let holds = sampled(2000, 1.0, |t| {
            l0 * (1.0 + m * (2.0 * std::f64::consts::PI * f * t).sin())
        });
        let (mean, comps) = spectrum(&holds, MAX_FREQUENCY_HZ);
        assert!((mean / l0 - 1.0).abs() < 1e-9, "mean {mean}");
        let x = std::f64::consts::PI * f / fs;
        let expected = m * x.sin() / x * tcsf::disk_sensitivity(f, radius, l0);
        let (v, peak) = index(&comps, mean, radius);
        assert!(
            (v / expected - 1.0).abs() < 1e-9,
            "f {f}: {v} vs {expected}"
        );
        assert_eq!(peak, Some(f));
    }
}

#[test]
fn the_step_spectrum_matches_brute_force_integration() {
    // Uneven holds; c_n by a midpoint sum of L(t) e^(-i w t) over 2e5 points.
    let edges = [0.0, 0.013, 0.05, 0.071, 0.12, 0.19, 0.2, 0.31, 0.4];
    let levels = [3.0, 9.0, 1.0, 7.5, 2.0, 8.0, 4.0, 6.0];
    let holds: Vec<Hold> = levels
        .iter()
        .enumerate()
        .map(|(k, &l)| Hold {
            start_s: edges[k],
            end_s: edges[k + 1],
            luminance_cd_m2: l,
        })
        .collect();
    let period = 0.4;
    let (mean, comps) = spectrum(&holds, 60.0);
    let level_at = |t: f64| {
        let k = edges.iter().rposition(|&e| e <= t).unwrap_or(0).min(7);
        levels[k]
    };
    let steps = 200_000;
    let dt = period / steps as f64;
    let brute_mean: f64 = (0..steps)
        .map(|i| level_at((i as f64 + 0.5) * dt))
        .sum::<f64>()
        / steps as f64;
    assert!(
        (mean - brute_mean).abs() < 1e-9 * mean,
        "{mean} {brute_mean}"
    );
    assert_eq!(comps.len(), 24);
    for &(f, m) in &comps {
        let w = 2.0 * std::f64::consts::PI * f;
        let (mut re, mut im) = (0.0, 0.0);
        for i in 0..steps {
            let t = (i as f64 + 0.5) * dt;
            re += level_at(t) * (w * t).cos() * dt;
            im -= level_at(t) * (w * t).sin() * dt;
        }
        let brute = 2.0 * re.hypot(im) / period / brute_mean;
        assert!((m - brute).abs() < 1e-4, "f {f}: {m} vs {brute}");
    }
}

#[test]
fn a_square_wave_has_its_odd_harmonics_at_four_over_pi_k() {
    // L0 (1 + a) then L0 (1 - a), 10 Hz: m_k = 4 a / (pi k) for odd k, 0 for even.
    let (l0, a) = (20.0, 0.3);
    let holds = sampled(20, 1.0, |t| {
        l0 * if (t * 10.0).fract() < 0.5 - 1e-9 {
            1.0 + a
        } else {
            1.0 - a
        }
    });
    // Each hold is a whole half period, so the steps are the square wave
    // itself and its series is exact.
    let (_, comps) = spectrum(&holds, MAX_FREQUENCY_HZ);
    let m1 = comps
        .iter()
        .find(|c| (c.0 - 10.0).abs() < 1e-9)
        .map(|c| c.1);
    let m3 = comps
        .iter()
        .find(|c| (c.0 - 30.0).abs() < 1e-9)
        .map(|c| c.1);
    let m2 = comps
        .iter()
        .find(|c| (c.0 - 20.0).abs() < 1e-9)
        .map(|c| c.1);
    let pi = std::f64::consts::PI;
    assert!((m1.unwrap_or(0.0) - 4.0 * a / pi).abs() < 1e-9);
    assert!((m3.unwrap_or(0.0) - 4.0 * a / (3.0 * pi)).abs() < 1e-9);
    assert!(m2.unwrap_or(1.0).abs() < 1e-9);
}

fn night() -> Display {
    Display {
        preset: DisplayPreset::Night,
        eotf: Eotf::Srgb,
        refresh_hz: 60.0,
        peak_cd_m2: 50.0,
        black_cd_m2: 0.05,
        image_width_mm: 155.0,
        distance_mm: 700.0,
        full_scale_dn: 255.0,
        image_width_px: 1920,
    }
}

#[test]
fn a_steady_light_is_invisible_and_a_dark_one_undefined() {
    let times: Vec<f64> = (0..60).map(|n| n as f64 / 30.0).collect();
    let v = evaluate(&night(), &times, &[128.0; 60], 1.0 / 30.0, (40, 40));
    assert_eq!(v.reason, None);
    assert!(v.index.is_some_and(|x| x.abs() < 1e-9), "{v:?}");
    assert_eq!(v.peak_frequency_hz, None);
    let dark = Display {
        black_cd_m2: 0.0,
        ..night()
    };
    let v = evaluate(&dark, &times, &[0.0; 60], 1.0 / 30.0, (40, 40));
    assert_eq!(v.index, None);
    assert!(v.reason.is_some_and(|r| r.contains("below")));
}

#[test]
fn a_full_on_off_beat_at_5_hz_is_far_above_threshold_and_rises_with_size() {
    // 30 fps frames alternating full scale and a third over 2 s: a 15 Hz
    // square wave of the displayed luminance.
    let times: Vec<f64> = (0..60).map(|n| n as f64 / 30.0).collect();
    let luma: Vec<f64> = (0..60)
        .map(|n| if n % 2 == 0 { 255.0 } else { 85.0 })
        .collect();
    let small = evaluate(&night(), &times, &luma, 1.0 / 30.0, (10, 10));
    let large = evaluate(&night(), &times, &luma, 1.0 / 30.0, (200, 200));
    let (s, l) = (small.index.unwrap_or(0.0), large.index.unwrap_or(0.0));
    assert!(s > 1.0 && l > s, "{s} {l}");
    assert!(
        small
            .peak_frequency_hz
            .is_some_and(|f| (f - 15.0).abs() < 1e-9)
    );
}
