//! Tests of the band estimator.

use super::*;
use ledflicker_physics::pwm::on_fraction;

/// Row profile of a PWM light: duty `d`, period `p` rows, exposure
/// `e` rows, phase `phi` cycles.
fn bands(n: usize, p: f64, d: f64, e: f64, phi: f64) -> Vec<f64> {
    (0..n)
        .map(|r| 20.0 + 200.0 * on_fraction(phi + r as f64 / p, e / p, d))
        .collect()
}

#[test]
fn square_wave_gives_its_fundamental_at_any_duty() {
    for (p, d, e) in [
        (68.66, 0.5, 4.3),
        (37.3, 0.1, 0.5),
        (120.7, 0.9, 2.0),
        (11.2, 0.3, 1.0),
        (250.0, 0.05, 3.0),
        (15.0, 0.5, 7.0),
    ] {
        let est = estimate_profile(&bands(1080, p, d, e, 0.3)).unwrap();
        let err = est.period_rows - p;
        assert!(
            (err / p).abs() < 5e-4 && err.abs() < 3.0 * est.period_sigma_rows,
            "p={p} d={d}: {est:?}"
        );
        assert!(est.period_sigma_rows < 0.01 * p, "{est:?}");
    }
}

/// Deterministic noise in [-0.5, 0.5).
fn noise(i: usize) -> f64 {
    let x = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    ((x >> 11) as f64 / (1u64 << 53) as f64) - 0.5
}

#[test]
fn refined_frequency_is_the_least_residual_on_a_fine_grid() {
    // Candidates are located with at most CANDIDATE_HARMONICS
    // harmonics and coarsely; the estimate must still be the minimum
    // of the residual with its own harmonic count, found here by brute
    // force over 401 frequencies around it, in noise and without.
    for (p, d, e, amp) in [
        (68.66, 0.05, 1.0, 0.0),
        (137.3, 0.2, 4.0, 8.0),
        (41.7, 0.5, 0.7, 20.0),
        (250.0, 0.1, 30.0, 2.0),
    ] {
        let y: Vec<f64> = bands(800, p, d, e, 0.17)
            .iter()
            .enumerate()
            .map(|(i, v)| v + amp * noise(i))
            .collect();
        let est = estimate_profile(&y).unwrap();
        let fit = PeriodicFit::new(std::slice::from_ref(&y));
        let (f, h) = (1.0 / est.period_rows, est.harmonics);
        let best = fit.rss(f, h);
        let width = 0.2 / fit.padded as f64;
        let (grid_f, grid_rss) = (0..=400)
            .map(|k| f + width * (k as f64 / 200.0 - 1.0))
            .map(|g| (g, fit.rss(g, h)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let resolution = 800.0 * f64::EPSILON * fit.sum_squares;
        assert!(best <= grid_rss + resolution, "p={p}: {best} > {grid_rss}");
        assert!(
            (grid_f - f).abs() <= width / 200.0,
            "p={p}: grid minimum {grid_f} vs {f}"
        );
        assert!((est.period_rows - p).abs() < 3.0 * est.period_sigma_rows + 1e-6 * p);
    }
}

#[test]
fn brent_finds_smooth_and_kinked_minima_within_tolerance() {
    for (centre, tol) in [(0.3, 1e-9), (-2.0, 1e-7), (0.0146, 1e-12)] {
        let mut calls = 0;
        let x = brent_minimum(
            |x| {
                calls += 1;
                (x - centre).powi(2) * 3.0
            },
            (centre - 1.0, centre + 0.5),
            tol,
        );
        assert!((x - centre).abs() < 3.0 * tol, "{x} vs {centre}");
        assert!(calls <= 20, "a parabola takes few steps: {calls}");
    }
    // |x - c| has no parabola: golden-section steps still close in.
    let x = brent_minimum(|x| (x - 0.7).abs(), (0.0, 1.0), 1e-8);
    assert!((x - 0.7).abs() < 3e-8, "{x}");
    // A minimum at the bracket's edge.
    let x = brent_minimum(|x| x, (2.0, 3.0), 1e-9);
    assert!((x - 2.0).abs() < 3e-9, "{x}");
}

#[test]
fn design_phases_are_the_exact_ones_to_rounding() {
    let (n, h) = (4000, 10);
    let stride = 3 + 2 * h;
    for f in [1.0 / 68.66, 0.2499, 1.0 / 1373.0, 0.013_579] {
        let mut design = vec![0.0; n * stride];
        harmonic_design(&mut design, stride, n, f, h);
        for (i, r) in design.chunks_exact(stride).enumerate() {
            for k in 1..=h {
                let angle = 2.0 * std::f64::consts::PI * f * (k * i) as f64;
                let (s, c) = angle.sin_cos();
                let err = (r[1 + 2 * k] - c).abs().max((r[2 + 2 * k] - s).abs());
                // The exact phase's own argument is rounded to about
                // eps * angle.
                let bound = 1e-14 + 4.0 * f64::EPSILON * angle;
                assert!(err < bound, "f={f} row {i} harmonic {k}: {err:e}");
            }
        }
    }
}

#[test]
fn nested_residuals_are_the_separate_fits() {
    let y = bands(800, 68.66, 0.2, 3.0, 0.1);
    let fit = PeriodicFit::new(std::slice::from_ref(&y));
    let f = 1.0 / 68.7;
    let nested = fit.rss_upto(f, 6);
    for h in 1..=6 {
        let separate = lsq_rss(&y, 3 + 2 * h, |i, r| {
            trend_basis(i, 800, r);
            for k in 0..h {
                let w = 2.0 * std::f64::consts::PI * f * ((k + 1) * i) as f64;
                r[3 + 2 * k] = w.cos();
                r[4 + 2 * k] = w.sin();
            }
        })
        .unwrap();
        let rel = (nested[h - 1] - separate).abs() / separate;
        assert!(rel < 1e-8, "h={h}: {} vs {separate}", nested[h - 1]);
    }
    assert!(nested.windows(2).all(|w| w[1] <= w[0]), "{nested:?}");
}

#[test]
fn flat_rows_and_noise_are_not_banding() {
    assert!(matches!(
        estimate_profile(&[5.0; 200]),
        Err(NoConfidence::Flat { .. })
    ));
    let mut rng = ledflicker_physics::sensor::Rng::new(3);
    let noise: Vec<f64> = (0..1000).map(|_| rng.normal()).collect();
    assert!(matches!(
        estimate_profile(&noise),
        Err(NoConfidence::NoBanding { .. })
    ));
}

#[test]
fn fewer_than_three_bands_are_refused_with_the_reason() {
    let e = estimate_profile(&bands(500, 250.0, 0.5, 2.0, 0.1)).unwrap_err();
    assert!(matches!(e, NoConfidence::TooFewBands { .. }), "{e}");
    let ok = estimate_profile(&bands(500, 160.0, 0.5, 2.0, 0.1));
    assert!(ok.is_ok(), "{ok:?}");
}

#[test]
fn median_over_strips_ignores_an_overlay_in_one_strip() {
    let clean = bands(600, 40.0, 0.4, 2.0, 0.0);
    let mut strips = vec![clean.clone(); 5];
    // A bright caption over rows 100..160 in one strip.
    for v in &mut strips[1][100..160] {
        *v = 255.0;
    }
    assert_eq!(combine_strips(&strips), clean);
}

/// [`grid_choice`] as first written: the criterion of every bin and
/// harmonic count, each with its logarithm.
fn grid_choice_every_log(power: &[f64], n: usize, frames: usize, trend_rss: f64) -> (usize, usize) {
    let big_n = 2 * (power.len() - 1);
    let total = trend_rss.max(1e-300);
    let n_tot = (n * frames) as f64;
    let penalty = 2.0 * frames as f64 * n_tot.ln();
    let k_lo = ((1.5 * big_n as f64 / n as f64).ceil() as usize).max(1);
    let k_hi = (big_n as f64 / MIN_PERIOD_ROWS) as usize;
    let mut best = (f64::INFINITY, k_lo, 1);
    for k0 in k_lo..=k_hi {
        let h_max = MAX_HARMONICS.min(big_n / 2 / k0).max(1);
        let mut explained = 0.0;
        for h in 1..=h_max {
            let (c, w) = (h * k0, h / 2);
            let (lo, hi) = (c.saturating_sub(w), (c + w).min(big_n / 2));
            explained += power[lo..=hi].iter().fold(0.0f64, |a, &b| a.max(b));
            let rss = (total - explained).max(1e-12 * total);
            let bic = n_tot * (rss / n_tot).ln() + penalty * h as f64;
            if bic < best.0 {
                best = (bic, k0, h);
            }
        }
    }
    (best.1, best.2)
}

#[test]
fn the_grid_choice_skipping_logarithms_is_the_choice_of_every_logarithm() {
    let mut cases = 0;
    for (n, p, d, e, amp) in [
        (800, 68.66, 0.05, 1.0, 0.0),
        (800, 137.3, 0.2, 4.0, 8.0),
        (240, 41.7, 0.5, 0.7, 20.0),
        (1080, 250.0, 0.1, 30.0, 2.0),
        (500, 4.3, 0.5, 0.2, 0.5),
        (800, 763.0, 0.5, 500.0, 0.0),
    ] {
        for frames in [1, 3] {
            let profiles: Vec<Vec<f64>> = (0..frames)
                .map(|f| {
                    bands(n, p, d, e, 0.17 * f as f64)
                        .iter()
                        .enumerate()
                        .map(|(i, v)| v + amp * noise(i + 7 * f))
                        .collect()
                })
                .collect();
            let fit = PeriodicFit::new(&profiles);
            let big_n = fit.padded;
            // The periodogram of the profiles, as `coarse` forms it, and
            // a flat one where every bin ties.
            let mut power = vec![0.0; big_n / 2 + 1];
            for prof in &profiles {
                let d = detrend(prof);
                for (k, pw) in power.iter_mut().enumerate() {
                    let (mut re, mut im) = (0.0, 0.0);
                    for (i, v) in d.iter().enumerate() {
                        let a = 2.0 * std::f64::consts::PI * (k * i) as f64 / big_n as f64;
                        re += v * a.cos();
                        im -= v * a.sin();
                    }
                    *pw += 2.0 * (re * re + im * im) / n as f64;
                }
            }
            let flat = vec![1e-3 * fit.trend_rss / power.len() as f64; power.len()];
            for pw in [&power, &flat] {
                let fast = grid_choice(pw, n, frames, fit.trend_rss);
                let slow = grid_choice_every_log(pw, n, frames, fit.trend_rss);
                assert_eq!(fast, slow, "n={n} p={p} frames={frames}");
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 24);
}

#[test]
fn closed_form_residuals_are_the_row_sum_residuals() {
    // The fits with the Gram matrix in closed form against the same fits
    // summed row by row (the path taken where the closed form declines),
    // on a noisy banded profile: ordinary frequencies, the lowest searched,
    // near the closed form's limit (4 f within 0.7 cycles per frame of 1),
    // and where it declines (4 f within 0.3 cycles per frame of 1).
    let n = 800;
    let y: Vec<f64> = bands(n, 68.66, 0.2, 3.0, 0.1)
        .iter()
        .enumerate()
        .map(|(i, v)| v + 4.0 * noise(i))
        .collect();
    let fit = PeriodicFit::new(std::slice::from_ref(&y));
    let near = (1.0 - 0.7 / n as f64) / 4.0;
    let declined = (1.0 - 0.3 / n as f64) / 4.0;
    for (f, h) in [
        (1.0 / 68.66, 10),
        (1.0 / 68.7, 3),
        (1.5 / n as f64, 10),
        (near, 2),
        (declined, 2),
    ] {
        let w = 2.0 * std::f64::consts::PI * f;
        let closed = harmonic_gram(n, w, h, &fit.trend_sums).is_some();
        assert_eq!(closed, f != declined, "f={f}");
        let fast = fit.rss_upto(f, h);
        let rows = lsq_rss_nested(&y, 3 + 2 * h, 3, |d, s| harmonic_design(d, s, n, f, h));
        for k in 1..=h {
            let (a, b) = (fast[k - 1], rows[3 + 2 * k]);
            assert!(
                (a - b).abs() <= 1e-9 * b + 1e-12 * fit.trend_rss,
                "f={f} k={k}: {a} vs {b}"
            );
        }
    }
}

/// `frames` frames of `strips` strips of the same profile `y`.
fn strips_of(y: &[f64], strips: usize) -> StripProfiles {
    vec![vec![y.to_vec(); strips]]
}

#[test]
fn the_grid_suppression_takes_period_16_and_leaves_other_bands() {
    // A staircase of 8-row blocks over a gradient: all period 8 after its
    // trend; plus bands of 37.3 rows.
    let n = 480;
    let grid: Vec<f64> = (0..n).map(|r| 0.5 * (r / 8 * 8) as f64 / 8.0).collect();
    // The trend and the phase means are fitted in turn, not jointly: a
    // trace of the grid is left, far below anything the search sees.
    let rms = |y: &[f64]| (detrend(y).iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    let left = rms(&grid::suppress(&grid)) / rms(&grid);
    assert!(left < 1e-3, "{left} of the grid is left");
    let banded: Vec<f64> = bands(n, 37.3, 0.4, 2.0, 0.2)
        .iter()
        .zip(&grid)
        .map(|(b, g)| b + 40.0 * g)
        .collect();
    let layout = Layout {
        columns: Vec::new(),
        block_grid: true,
    };
    let est = estimate(&strips_of(&banded, 4), &layout).unwrap();
    assert!((est.period_rows / 37.3 - 1.0).abs() < 5e-4, "{est:?}");
    assert!(est.block_grid_suppressed);
    // The grid alone is refused, naming it.
    let e = estimate(&strips_of(&grid, 4), &layout).unwrap_err();
    assert!(matches!(e, NoConfidence::BlockGrid { .. }), "{e}");
}

#[test]
fn near_the_grid_is_within_two_cycles_per_frame_of_16_over_k_rows() {
    for (p, rows, near) in [
        (8.0, 480, true),
        (16.0, 480, true),
        (16.3, 480, true),
        (17.5, 480, false),
        (16.3, 1080, true),
        (17.0, 1080, false),
        (5.3333, 1080, true),
        (37.3, 480, false),
        (400.0, 480, false),
    ] {
        assert_eq!(grid::near_grid(p, rows), near, "{p} rows over {rows}");
    }
}

#[test]
fn a_disagreeing_group_or_two_halves_are_two_regions() {
    let n = 1080;
    let a = bands(n, 40.0, 0.4, 2.0, 0.1);
    let b = bands(n, 43.0, 0.3, 2.0, 0.6);
    let columns: Vec<[u32; 2]> = (0..16).map(|s| [40 * s, 40 * s + 40]).collect();
    let layout = Layout {
        columns,
        block_grid: false,
    };
    // The last group (strips 12..16, columns 480..640) sees the other light.
    let mut one: Vec<Vec<f64>> = vec![a.clone(); 16];
    one[12..].fill(b.clone());
    // A quarter lit by another light is refused too, naming both: the
    // frequency given may be that light's.
    let e = estimate(&vec![one], &layout).unwrap_err();
    let NoConfidence::StripsDisagree { regions } = &e else {
        panic!("{e}");
    };
    let quarter: Vec<([u32; 2], f64)> = regions
        .iter()
        .map(|r| (r.columns[0], r.period_rows.unwrap()))
        .collect();
    assert_eq!(quarter.len(), 2, "{e}");
    assert_eq!((quarter[0].0, quarter[1].0), ([0, 480], [480, 640]), "{e}");
    assert!((quarter[1].1 / 43.0 - 1.0).abs() < 1e-3, "{e}");
    // Half and half.
    let mut halves: Vec<Vec<f64>> = vec![a.clone(); 16];
    halves[8..].fill(b.clone());
    let e = estimate(&vec![halves], &layout).unwrap_err();
    let NoConfidence::StripsDisagree { regions } = &e else {
        panic!("{e}");
    };
    assert_eq!(regions.len(), 2, "{e}");
    let mut got: Vec<([u32; 2], f64)> = regions
        .iter()
        .map(|r| (r.columns[0], r.period_rows.unwrap()))
        .collect();
    got.sort_by_key(|g| g.0[0]);
    assert_eq!((got[0].0, got[1].0), ([0, 320], [320, 640]), "{e}");
    assert!((got[0].1 / 40.0 - 1.0).abs() < 1e-3 && (got[1].1 / 43.0 - 1.0).abs() < 1e-3);
}
