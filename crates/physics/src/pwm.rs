//! The PWM drive of an LED and its exact integral (docs/camera-model.md,
//! "3. Light on the row").
//!
//! Time is measured in PWM cycles from a rising edge, so the square wave is
//! ON on `[n, n + D)` for every integer `n`. Its integral from 0 to `u` is
//! `G(u) = floor(u) * D + min(frac(u), D)`, and one exposure collects
//! `G(u_end) - G(u_start)`: a closed form with no case analysis and no time
//! stepping.

/// A PWM-driven LED.
///
/// Invariants (checked by [`PwmDrive::new`]): `frequency_hz > 0`, finite;
/// `duty` in `(0, 1]`; `first_rise_s` finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PwmDrive {
    frequency_hz: f64,
    duty: f64,
    first_rise_s: f64,
}

impl PwmDrive {
    /// A drive at `frequency_hz` (> 0) with `duty` in (0, 1], whose first
    /// rising edge is at `first_rise_s` seconds after the start of frame 0's
    /// exposure (row 0). The LED is ON during `[X + kP, X + kP + D*P)`.
    pub fn new(frequency_hz: f64, duty: f64, first_rise_s: f64) -> Result<Self, String> {
        if !(frequency_hz.is_finite() && frequency_hz > 0.0) {
            return Err(format!("PWM frequency must be > 0 Hz, got {frequency_hz}"));
        }
        if !(duty.is_finite() && duty > 0.0 && duty <= 1.0) {
            return Err(format!("duty must be in (0, 1], got {duty}"));
        }
        if !first_rise_s.is_finite() {
            return Err(format!("PWM delay must be finite, got {first_rise_s}"));
        }
        Ok(Self {
            frequency_hz,
            duty,
            first_rise_s,
        })
    }

    /// PWM frequency in Hz.
    pub fn frequency_hz(&self) -> f64 {
        self.frequency_hz
    }

    /// Duty cycle in (0, 1].
    pub fn duty(&self) -> f64 {
        self.duty
    }

    /// Time of the first rising edge in seconds after frame 0 starts.
    pub fn first_rise_s(&self) -> f64 {
        self.first_rise_s
    }

    /// Phase, in cycles within `[0, 1)`, of the instant
    /// `frame / fps + offset_s`, measured from a rising edge.
    ///
    /// `frame / fps` is never formed as a running sum, and its cycle count
    /// `frame * f / fps` is reduced with an exact `fmod` before dividing, so
    /// frame 1 920 of a 64 s capture is as accurate as frame 1.
    pub fn phase_at(&self, frame: u64, fps: f64, offset_s: f64) -> f64 {
        let f = self.frequency_hz;
        // (frame * f) is exact while it stays below 2^53 for integer-valued
        // f; `rem` is the exact IEEE remainder.
        let whole = crate::remainder::rem(frame as f64 * f, fps) / fps;
        let rest = (offset_s - self.first_rise_s) * f;
        wrap_unit(whole + wrap_unit(rest))
    }

    /// Fraction (0..=1) of an exposure of `width_cycles` PWM cycles, starting
    /// at phase `phase` (cycles from a rising edge), during which the LED is ON.
    pub fn on_fraction_at_phase(&self, phase: f64, width_cycles: f64) -> f64 {
        on_fraction(phase, width_cycles, self.duty)
    }
}

/// Wraps `x` into `[0, 1)`.
#[inline]
pub fn wrap_unit(x: f64) -> f64 {
    let w = x - x.floor();
    // x.floor() can round so that w == 1.0 for tiny negative x.
    if w >= 1.0 { 0.0 } else { w }
}

/// Integral of the unit square wave (ON on `[n, n + duty)`) from 0 to `u`
/// cycles, in cycles of ON time.
#[inline]
pub fn on_cycles(u: f64, duty: f64) -> f64 {
    let n = u.floor();
    n * duty + (u - n).min(duty)
}

/// Fraction of `[phase, phase + width)` (cycles) during which a PWM of the
/// given duty is ON. `width` must be > 0. The result is clamped to `[0, 1]`
/// so that rounding in the subtraction never leaves the physical range.
#[inline]
pub fn on_fraction(phase: f64, width: f64, duty: f64) -> f64 {
    if duty >= 1.0 {
        return 1.0;
    }
    let on = on_cycles(phase + width, duty) - on_cycles(phase, duty);
    (on / width).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force midpoint integration with `steps` samples.
    fn brute_force(phase: f64, width: f64, duty: f64, steps: usize) -> f64 {
        let dt = width / steps as f64;
        let on = (0..steps)
            .filter(|&i| {
                let u = phase + (i as f64 + 0.5) * dt;
                u - u.floor() < duty
            })
            .count();
        on as f64 / steps as f64
    }

    #[test]
    fn closed_form_matches_brute_force_integration() {
        let mut worst: f64 = 0.0;
        for &duty in &[0.05, 0.2, 0.5, 0.75, 0.99] {
            for &width in &[0.013, 0.3, 0.95, 1.0, 1.7, 2.4, 7.25] {
                for i in 0..23 {
                    let phase = i as f64 / 23.0;
                    let exact = on_fraction(phase, width, duty);
                    let brute = brute_force(phase, width, duty, 200_000);
                    worst = worst.max((exact - brute).abs());
                }
            }
        }
        // Midpoint sampling of a step function errs by at most 2 samples.
        assert!(worst < 2.0 / 200_000.0 + 1e-12, "worst error {worst}");
    }

    #[test]
    fn exposure_of_whole_periods_sees_the_duty_at_every_phase() {
        for k in 1..5 {
            for i in 0..50 {
                let phase = i as f64 / 50.0;
                let got = on_fraction(phase, k as f64, 0.3);
                assert!((got - 0.3).abs() < 1e-12, "k={k} phase={phase}: {got}");
            }
        }
    }

    #[test]
    fn exposure_on_eq1_boundary_can_miss_the_pulse_entirely() {
        // T = (1 - D) / f, starting at the falling edge: exactly zero ON time.
        let duty = 0.25;
        let got = on_fraction(duty, 1.0 - duty, duty);
        assert!(got.abs() < 1e-12, "{got}");
    }

    #[test]
    fn full_duty_is_always_on() {
        assert_eq!(on_fraction(0.37, 0.01, 1.0), 1.0);
    }

    #[test]
    fn phase_of_late_frames_is_exact_for_locked_frequencies() {
        let pwm = PwmDrive::new(90.0, 0.5, 0.0).unwrap();
        // 90 Hz at 30 fps: every frame starts on a rising edge.
        for frame in [0, 1, 7, 1_919, 1_000_000] {
            assert_eq!(pwm.phase_at(frame, 30.0, 0.0), 0.0);
        }
    }

    #[test]
    fn invalid_drive_is_rejected() {
        assert!(PwmDrive::new(0.0, 0.5, 0.0).is_err());
        assert!(PwmDrive::new(100.0, 0.0, 0.0).is_err());
        assert!(PwmDrive::new(100.0, 1.01, 0.0).is_err());
        assert!(PwmDrive::new(f64::NAN, 0.5, 0.0).is_err());
    }
}
