//! Auto exposure: a damped controller with a deadband, acting on exposure
//! time first, then analogue gain, then digital gain.
//!
//! Each frame the camera meters a linear level `m` (a fraction of the tone
//! curve's white), compares it with `target`, and moves its total brightness
//! `B = T x Ga x Gd` by `(target / m)^damping` unless the error is inside
//! the deadband. The deadband is why exposure does not return to the same
//! value after the light toggles: the hysteresis Deegan 2018 observed (a
//! negative FDI at 60 Hz).

/// Auto-exposure parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoExposure {
    /// Target metered level, as a fraction of white (0..1).
    pub target: f64,
    /// Fraction (0..1] of the log error corrected per frame.
    pub damping: f64,
    /// Relative error inside which nothing changes (>= 0), e.g. 0.1 = 10 %.
    pub deadband: f64,
    /// Shortest exposure, seconds: the flicker-mitigation floor (e.g. 1/90 s).
    pub min_exposure_s: f64,
    /// Longest exposure, seconds (at most the frame time).
    pub max_exposure_s: f64,
    /// Largest analogue gain (>= 1).
    pub max_analog_gain: f64,
    /// Smallest digital gain (> 0; below 1 lets a long LFM exposure be
    /// scaled down after the HDR merge).
    pub min_digital_gain: f64,
    /// Largest digital gain.
    pub max_digital_gain: f64,
}

/// Exposure settings of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExposureState {
    /// Exposure of the first capture, seconds.
    pub exposure_s: f64,
    /// Analogue gain (>= 1).
    pub analog_gain: f64,
    /// Digital gain applied to the merged linear signal.
    pub digital_gain: f64,
}

impl ExposureState {
    /// Total brightness `T x Ga x Gd`.
    pub fn brightness(&self) -> f64 {
        self.exposure_s * self.analog_gain * self.digital_gain
    }
}

impl AutoExposure {
    /// Splits a total brightness into exposure, then analogue gain, then
    /// digital gain, each within its limits.
    pub fn split(&self, brightness: f64) -> ExposureState {
        let t = brightness.clamp(self.min_exposure_s, self.max_exposure_s);
        let rest = brightness / t;
        let ga = rest.clamp(1.0, self.max_analog_gain);
        let gd = (rest / ga).clamp(self.min_digital_gain, self.max_digital_gain);
        ExposureState {
            exposure_s: t,
            analog_gain: ga,
            digital_gain: gd,
        }
    }

    /// The next frame's settings after metering `metered` (fraction of white)
    /// with settings `state`.
    pub fn update(&self, state: ExposureState, metered: f64) -> ExposureState {
        let metered = metered.max(1e-9);
        let ratio = self.target / metered;
        if (ratio.ln()).abs() <= (1.0 + self.deadband).ln() {
            return state;
        }
        self.split(state.brightness() * ratio.powf(self.damping))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ae() -> AutoExposure {
        AutoExposure {
            target: 0.2,
            damping: 0.5,
            deadband: 0.05,
            min_exposure_s: 1.0 / 90.0,
            max_exposure_s: 1.0 / 30.0,
            max_analog_gain: 8.0,
            min_digital_gain: 0.05,
            max_digital_gain: 4.0,
        }
    }

    #[test]
    fn exposure_is_used_before_gain_and_respects_the_lfm_floor() {
        let a = ae();
        let s = a.split(0.02);
        assert_eq!(
            (s.exposure_s, s.analog_gain, s.digital_gain),
            (0.02, 1.0, 1.0)
        );
        let s = a.split(0.1);
        assert!((s.exposure_s - 1.0 / 30.0).abs() < 1e-15 && (s.analog_gain - 3.0).abs() < 1e-12);
        let s = a.split(0.001);
        assert_eq!(s.exposure_s, 1.0 / 90.0);
        assert!(
            (s.digital_gain - 0.09).abs() < 1e-12,
            "bright scenes scale down digitally"
        );
    }

    #[test]
    fn controller_converges_into_the_deadband_and_then_holds() {
        let a = ae();
        // Metered level proportional to brightness: m = 10 * B.
        let mut s = a.split(0.012);
        for _ in 0..100 {
            s = a.update(s, 10.0 * s.brightness());
        }
        let m = 10.0 * s.brightness();
        assert!((m / a.target).ln().abs() <= (1.05f64).ln() + 1e-12, "{m}");
        assert_eq!(a.update(s, m), s);
    }
}
