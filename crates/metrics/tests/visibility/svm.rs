//! The stroboscopic visibility measure (SVM, CIE TN 006:2016) against an
//! independent reference: the TN's formula written again here, with its
//! Fourier components found by brute force (numerical integration of the
//! continuous waveform over a period, or the discrete Fourier sum of a
//! record term by term), on square waves at several duties, sines, a
//! rectified sine, a triangle and two real lamps' waveforms
//! (tests/data/lamps, MIT). docs/visibility.md states the tolerance.

use ledflicker_metrics::metrics::visibility::svm;
use std::f64::consts::PI;

/// The TN's threshold modulation of the stroboscopic effect.
fn reference_threshold(f: f64) -> f64 {
    let logistic = 1.0 / (1.0 + (-0.00518 * (f - 306.6)).exp());
    logistic + 20.0 * (-f / 10.0).exp()
}

/// The TN's pooling of relative amplitudes `c[k]` at `f[k]` (<= 2 kHz).
fn reference_pool(components: &[(f64, f64)]) -> f64 {
    let mut sum = 0.0;
    for &(f, c) in components {
        if f > 0.0 && f <= 2000.0 {
            sum += (c / reference_threshold(f)).powf(3.7);
        }
    }
    sum.powf(1.0 / 3.7)
}

/// The SVM of the periodic waveform `w` (one period on `t` in [0, 1),
/// fundamental `f0` Hz): each harmonic's complex amplitude by the
/// midpoint rule on `m` points of the period.
fn reference_continuous(w: impl Fn(f64) -> f64, f0: f64, m: usize) -> f64 {
    let values: Vec<f64> = (0..m).map(|j| w((j as f64 + 0.5) / m as f64)).collect();
    let mean = values.iter().sum::<f64>() / m as f64;
    let mut components = Vec::new();
    let mut k = 1;
    while k as f64 * f0 <= 2000.0 {
        let (mut re, mut im) = (0.0, 0.0);
        for (j, v) in values.iter().enumerate() {
            let phase = 2.0 * PI * k as f64 * (j as f64 + 0.5) / m as f64;
            re += v * phase.cos();
            im -= v * phase.sin();
        }
        let amplitude = 2.0 * (re * re + im * im).sqrt() / m as f64;
        components.push((k as f64 * f0, amplitude / mean));
        k += 1;
    }
    reference_pool(&components)
}

/// The SVM of a record `x` sampled at `rate`, as one period: the discrete
/// Fourier sum of each bin up to 2 kHz, term by term.
fn reference_record(x: &[f64], rate: f64) -> f64 {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let mut components = Vec::new();
    let mut k = 1;
    while (k as f64) * rate / (n as f64) <= 2000.0 && 2 * k < n {
        let (mut re, mut im) = (0.0, 0.0);
        for (j, v) in x.iter().enumerate() {
            let phase = 2.0 * PI * (k * j % n) as f64 / n as f64;
            re += v * phase.cos();
            im -= v * phase.sin();
        }
        components.push((
            k as f64 * rate / n as f64,
            2.0 * (re * re + im * im).sqrt() / (n as f64 * mean),
        ));
        k += 1;
    }
    reference_pool(&components)
}

/// One period of a waveform on `t` in [0, 1).
type Waveform = Box<dyn Fn(f64) -> f64>;

/// `w` (one period on [0, 1)) sampled at `rate` for `periods` periods of `f0`.
fn sampled(w: &dyn Fn(f64) -> f64, f0: f64, rate: f64, periods: usize) -> Vec<f64> {
    let n = (periods as f64 * rate / f0).round() as usize;
    (0..n).map(|i| w((i as f64 * f0 / rate).fract())).collect()
}

fn assert_close(name: &str, ours: f64, reference: f64, rel: f64) {
    let err = (ours - reference).abs() / reference.abs().max(1e-12);
    assert!(
        err <= rel,
        "{name}: ours {ours:.9}, reference {reference:.9} (relative error {err:.2e} > {rel:.0e})"
    );
    eprintln!("{name}: SVM {ours:.6} (reference {reference:.6}, relative error {err:.1e})");
}

/// Square waves: the closed form against the integral, at duties from 5
/// to 80 % and at 100 to 500 Hz. With the edges on the integration grid,
/// the midpoint rule's error on harmonic `k` is a factor
/// `(pi k / m) / sin(pi k / m)`, below 2e-8 for `k <= 20`, `m = 200 000`.
#[test]
fn pwm_svm_matches_the_integrated_reference_at_every_duty() {
    for (f, duty) in [
        (100.0, 0.05),
        (100.0, 0.1),
        (100.0, 0.2),
        (100.0, 0.5),
        (100.0, 0.8),
        (200.0, 0.3),
        (500.0, 0.25),
    ] {
        let square = |t: f64| if t < duty { 1.0 } else { 0.0 };
        let reference = reference_continuous(square, f, 200_000);
        assert_close(
            &format!("PWM {f} Hz {duty}"),
            svm::of_pwm(f, duty),
            reference,
            1e-7,
        );
    }
}

/// Sampled waveforms through the FFT path against the integral of the
/// continuous waveform: band-limited ones (sines) to rounding; a
/// rectified sine and a triangle within the aliasing of their harmonics
/// above the sampling's Nyquist frequency (1e-5); a square wave within
/// 0.5 %, its edges sampled every 10 us (400 samples a period: the
/// discrete steps' harmonics differ from the continuous ones).
#[test]
fn sampled_svm_matches_the_integrated_reference_for_sines_and_shapes() {
    let rate = 100_000.0;
    let cases: Vec<(&str, Waveform, f64, f64)> = vec![
        (
            "sine 100 Hz, 100 %",
            Box::new(|t: f64| 1.0 + (2.0 * PI * t).sin()),
            100.0,
            1e-9,
        ),
        (
            "sine 120 Hz, 30 %",
            Box::new(|t: f64| 1.0 + 0.3 * (2.0 * PI * t).sin()),
            120.0,
            1e-9,
        ),
        (
            "sine 400 Hz, 60 %",
            Box::new(|t: f64| 1.0 + 0.6 * (2.0 * PI * t).cos()),
            400.0,
            1e-9,
        ),
        // A mains lamp without smoothing: |sin| of 50 Hz, a 100 Hz ripple.
        (
            "rectified 50 Hz mains",
            Box::new(|t: f64| (PI * t).sin().abs()),
            100.0,
            1e-5,
        ),
        (
            "triangle 150 Hz",
            Box::new(|t: f64| 1.0 - (2.0 * t - 1.0).abs()),
            150.0,
            1e-5,
        ),
        (
            "square 250 Hz, 40 % sampled",
            Box::new(|t: f64| if t < 0.4 { 1.0 } else { 0.0 }),
            250.0,
            5e-3,
        ),
    ];
    for (name, w, f0, tolerance) in cases {
        // Three periods: a whole number of samples for every f0 here.
        let x = sampled(&*w, f0, rate, 3);
        let ours = svm::of_samples(&x, rate).unwrap();
        let reference = reference_continuous(&*w, f0, 20_000);
        assert_close(name, ours, reference, tolerance);
    }
}

/// Reads a lamp record of tests/data/lamps: (sample rate, values).
fn lamp(name: &str) -> (f64, Vec<f64>) {
    let path = crate::root().join("tests/data/lamps").join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<(f64, f64)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let (t, v) = l.split_once(',').unwrap();
            (t.parse().unwrap(), v.parse().unwrap())
        })
        .collect();
    let step = (rows[rows.len() - 1].0 - rows[0].0) / (rows.len() - 1) as f64;
    (1.0 / step, rows.iter().map(|r| r.1).collect())
}

/// Two real lamps (an LED bulb and a CFL on 60 Hz mains, photodiode
/// records of the beautiful-flicker repository, 3 periods of their 120 Hz
/// ripple): the FFT path against the term-by-term Fourier sum of the same
/// record; the CFL, whose ripple is four times the LED bulb's (Percent
/// Flicker 19 % against 4.6 %), has the higher SVM.
#[test]
fn sampled_svm_of_real_lamps_matches_the_reference_sum() {
    let mut svms = Vec::new();
    for name in ["ge-classic-led.csv", "cfl.csv"] {
        let (rate, x) = lamp(name);
        assert!((rate - 100_000.0).abs() < 1.0, "{name}: {rate} Hz");
        let ours = svm::of_samples(&x, rate).unwrap();
        assert_close(name, ours, reference_record(&x, rate), 1e-9);
        svms.push(ours);
    }
    assert!(
        svms[0] > 0.01 && svms[1] > 2.0 * svms[0] && svms[1] < 5.0,
        "{svms:?}"
    );
}
