//! The light source itself: IEEE 1789-2015 risk region and IES Flicker
//! Index of the PWM drive, before any camera.
//!
//! The drive is a square wave switching between 0 and a peak (PWM with the
//! LED fully off between pulses), so both are exact:
//! - Percent Flicker (IEEE 1789 "modulation %"): `100 (max - min) / (max + min)`
//!   = 100 for duty < 1, 0 for duty 1;
//! - IES Flicker Index (IES Lighting Handbook, 10th ed.): area above the mean
//!   over the total area of one period. The mean is `D * peak`; the area
//!   above it is `(peak - D peak) * D P`, the total `D peak P`, so
//!   `FI = 1 - D`.
//!
//! IEEE 1789-2015, Recommended Practices 1 and 2 (figure 20), as modulation
//! limits against frequency f:
//! - low risk: `0.025 f` % below 90 Hz, `0.08 f` % from 90 Hz to 1250 Hz,
//!   no limit above 1250 Hz;
//! - no observable effect (NOEL): `0.01 f` % below 90 Hz, `0.0333 f` %
//!   (taken as `f / 30`, reaching 100 % at 3 kHz) up to 3 kHz, no limit above.

pub use ledflicker_results::analysis::drive::{DriveFlicker, Ieee1789Region};

use ledflicker_metrics::metrics::visibility::svm;

/// IEEE 1789 low-risk limit on modulation (%) at `frequency_hz`; `None` when exempt.
pub fn low_risk_limit_percent(frequency_hz: f64) -> Option<f64> {
    if frequency_hz < 90.0 {
        Some(0.025 * frequency_hz)
    } else if frequency_hz <= 1250.0 {
        Some(0.08 * frequency_hz)
    } else {
        None
    }
}

/// IEEE 1789 no-observable-effect limit on modulation (%) at
/// `frequency_hz`; `None` when exempt.
pub fn noel_limit_percent(frequency_hz: f64) -> Option<f64> {
    if frequency_hz < 90.0 {
        Some(0.01 * frequency_hz)
    } else if frequency_hz <= 3000.0 {
        Some(frequency_hz / 30.0)
    } else {
        None
    }
}

/// The IEEE 1789 region of a source modulated `percent` % at `frequency_hz`.
pub fn region(frequency_hz: f64, percent: f64) -> Ieee1789Region {
    // A limit met within 1e-9 % counts as met (e.g. 100 % at exactly 1250 Hz).
    let within = |limit: Option<f64>| limit.is_none_or(|l| percent <= l + 1e-9);
    if within(noel_limit_percent(frequency_hz)) {
        Ieee1789Region::NoObservableEffect
    } else if within(low_risk_limit_percent(frequency_hz)) {
        Ieee1789Region::LowRisk
    } else {
        Ieee1789Region::ElevatedRisk
    }
}

/// Flicker of an ideal PWM drive (LED fully off between pulses) at
/// `frequency_hz` (> 0) with `duty` in (0, 1]. A frequency or duty of 0
/// (unknown, as for a capture without conditions) has no SVM.
pub fn drive_flicker(frequency_hz: f64, duty: f64) -> DriveFlicker {
    let percent_flicker = if duty >= 1.0 { 0.0 } else { 100.0 };
    let known = frequency_hz > 0.0 && duty > 0.0 && duty <= 1.0;
    // A steady light (duty 1) has no harmonics: exactly 0, where the sum
    // of sin(pi k) would leave rounding noise.
    let svm = known.then(|| {
        if duty >= 1.0 {
            0.0
        } else {
            svm::of_pwm(frequency_hz, duty)
        }
    });
    DriveFlicker {
        svm,
        percent_flicker,
        flicker_index: (1.0 - duty).clamp(0.0, 1.0),
        ieee1789_low_risk_max_percent: low_risk_limit_percent(frequency_hz),
        ieee1789_noel_max_percent: noel_limit_percent(frequency_hz),
        ieee1789_region: region(frequency_hz, percent_flicker),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SVM of a PWM drive from the TN's formula written again here,
    /// each harmonic's amplitude by the midpoint rule over one period.
    fn svm_brute(f: f64, duty: f64) -> f64 {
        let n = 20_000;
        let t = |f_hz: f64| {
            1.0 / (1.0 + (-0.00518 * (f_hz - 306.6)).exp()) + 20.0 * (-f_hz / 10.0).exp()
        };
        let mut sum = 0.0;
        let mut k = 1;
        while k as f64 * f <= 2000.0 {
            let (mut re, mut im) = (0.0, 0.0);
            for i in 0..n {
                let u = (i as f64 + 0.5) / n as f64;
                let x = if u < duty { 1.0 } else { 0.0 };
                let a = 2.0 * std::f64::consts::PI * k as f64 * u;
                re += x * a.cos();
                im += x * a.sin();
            }
            // Amplitude over the mean (duty): 2 |X_k| / (N D).
            let c = 2.0 * re.hypot(im) / (n as f64 * duty);
            sum += (c / t(k as f64 * f)).powf(3.7);
            k += 1;
        }
        sum.powf(1.0 / 3.7)
    }

    #[test]
    fn the_drive_has_the_svm_of_its_pwm_and_none_when_unknown() {
        for (f, duty) in [(90.0, 0.2), (100.0, 0.05), (500.0, 0.5), (1000.0, 0.1)] {
            let svm = drive_flicker(f, duty).svm.unwrap();
            let brute = svm_brute(f, duty);
            assert!(
                (svm - brute).abs() < 1e-6 * brute,
                "{f} Hz {duty}: {svm} vs {brute}"
            );
        }
        assert_eq!(drive_flicker(90.0, 1.0).svm, Some(0.0));
        assert_eq!(drive_flicker(0.0, 0.5).svm, None);
        assert_eq!(drive_flicker(90.0, 0.0).svm, None);
        // Above 2 kHz no harmonic is summed: nothing is seen.
        assert_eq!(drive_flicker(2500.0, 0.5).svm, Some(0.0));
    }

    /// Flicker Index of a sampled waveform, from its definition.
    fn flicker_index_brute(duty: f64, steps: usize) -> f64 {
        let x: Vec<f64> = (0..steps)
            .map(|i| {
                let u = (i as f64 + 0.5) / steps as f64;
                if u < duty { 1.0 } else { 0.0 }
            })
            .collect();
        let mean = x.iter().sum::<f64>() / steps as f64;
        let above: f64 = x.iter().map(|&v| (v - mean).max(0.0)).sum();
        let total: f64 = x.iter().sum();
        above / total
    }

    #[test]
    fn flicker_index_matches_its_definition() {
        for duty in [0.05, 0.1, 0.33, 0.5, 0.9, 1.0] {
            let exact = drive_flicker(500.0, duty).flicker_index;
            let brute = flicker_index_brute(duty, 100_000);
            assert!((exact - brute).abs() < 1e-4, "D={duty}: {exact} vs {brute}");
        }
    }

    #[test]
    fn pwm_regions_follow_the_ieee_1789_limits() {
        use Ieee1789Region::*;
        // 100 % modulation is low risk from 1250 Hz and NOEL from 3 kHz.
        assert_eq!(drive_flicker(1000.0, 0.5).ieee1789_region, ElevatedRisk);
        assert_eq!(drive_flicker(1250.0, 0.5).ieee1789_region, LowRisk);
        assert_eq!(drive_flicker(2999.0, 0.5).ieee1789_region, LowRisk);
        assert_eq!(
            drive_flicker(3000.0, 0.5).ieee1789_region,
            NoObservableEffect
        );
        assert_eq!(drive_flicker(50.0, 1.0).ieee1789_region, NoObservableEffect);
        assert_eq!(region(100.0, 8.0), LowRisk);
        assert_eq!(region(100.0, 3.3), NoObservableEffect);
        assert_eq!(region(60.0, 1.5), LowRisk);
        assert_eq!(region(60.0, 1.6), ElevatedRisk);
        assert_eq!(
            drive_flicker(1300.0, 0.2).ieee1789_low_risk_max_percent,
            None
        );
    }
}
