//! Image sensor: photo-electrons, read and shot noise, analogue gain, ADC
//! and clipping; plus the seeded random numbers the noise uses.
//!
//! Noise is drawn for an ROI row mean of `pixels` pixels: the mean of
//! `pixels` independent Gaussian-approximated Poisson + read-noise samples
//! has variance `(e + read^2) / pixels`. Clipping of single noisy pixels
//! near full well is not modelled (the row mean is clipped).

/// Sensor parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensor {
    /// Photo-electrons per pixel per (cd/m^2 x second) of scene luminance at
    /// sensitivity ratio 1 (lens, QE and pixel area folded in). > 0.
    pub sensitivity_e_per_cd_m2_s: f64,
    /// Full-well capacity in electrons (> 0); a capture clips here.
    pub full_well_e: f64,
    /// Read noise, electrons RMS (>= 0).
    pub read_noise_e: f64,
    /// Photon shot noise on or off.
    pub shot_noise: bool,
    /// ADC bit depth (1..=24).
    pub adc_bits: u32,
    /// Electrons per DN at analogue gain 1 (> 0).
    pub e_per_dn: f64,
}

/// One capture of one ROI row, digitised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureSample {
    /// ADC output, DN (0..=dn_max), not rounded: the mean of a row.
    pub dn: f64,
    /// The capture clipped (full well or ADC maximum).
    pub saturated: bool,
}

impl Sensor {
    /// Largest ADC code.
    pub fn dn_max(&self) -> f64 {
        (2f64).powi(self.adc_bits as i32) - 1.0
    }

    /// Digitises a mean signal of `electrons` per pixel at `analog_gain`,
    /// adding noise for a row mean of `pixels` pixels when `rng` is given.
    pub fn capture(
        &self,
        electrons: f64,
        analog_gain: f64,
        noise: Option<(&mut Rng, u32)>,
    ) -> CaptureSample {
        let mut e = electrons.max(0.0);
        if let Some((rng, pixels)) = noise {
            let shot = if self.shot_noise { e } else { 0.0 };
            let sigma =
                ((shot + self.read_noise_e * self.read_noise_e) / pixels.max(1) as f64).sqrt();
            e += sigma * rng.normal();
        }
        let well_clipped = e >= self.full_well_e;
        let e = e.clamp(0.0, self.full_well_e);
        let dn = e * analog_gain / self.e_per_dn;
        let dn_max = self.dn_max();
        CaptureSample {
            dn: dn.min(dn_max),
            saturated: well_clipped || dn >= dn_max,
        }
    }
}

/// A small deterministic generator (xoshiro256**, seeded by SplitMix64).
/// The same seed gives the same stream on every platform.
#[derive(Debug, Clone)]
pub struct Rng {
    s: [u64; 4],
    spare: Option<f64>,
}

impl Rng {
    /// A generator seeded from `seed`.
    pub fn new(seed: u64) -> Self {
        let mut z = seed;
        let mut next = || {
            z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut x = z;
            x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            x ^ (x >> 31)
        };
        Self {
            s: [next(), next(), next(), next()],
            spare: None,
        }
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let result = self.s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = self.s[1] << 17;
        self.s[2] ^= self.s[0];
        self.s[3] ^= self.s[1];
        self.s[1] ^= self.s[2];
        self.s[0] ^= self.s[3];
        self.s[2] ^= t;
        self.s[3] = self.s[3].rotate_left(45);
        result
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let r = (-2.0 * self.uniform().ln()).sqrt();
        let theta = 2.0 * std::f64::consts::PI * self.uniform();
        self.spare = Some(r * theta.sin());
        r * theta.cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sensor() -> Sensor {
        Sensor {
            sensitivity_e_per_cd_m2_s: 1000.0,
            full_well_e: 10_000.0,
            read_noise_e: 3.0,
            shot_noise: true,
            adc_bits: 12,
            e_per_dn: 10_000.0 / 4095.0,
        }
    }

    #[test]
    fn normal_draws_have_unit_variance() {
        let mut rng = Rng::new(42);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        // 5 standard errors.
        assert!(mean.abs() < 5.0 / (n as f64).sqrt(), "{mean}");
        assert!((var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(), "{var}");
    }

    #[test]
    fn noisy_capture_has_the_shot_plus_read_variance() {
        let s = sensor();
        let mut rng = Rng::new(7);
        let (e, pixels, n) = (2_000.0, 100u32, 50_000);
        let dns: Vec<f64> = (0..n)
            .map(|_| s.capture(e, 1.0, Some((&mut rng, pixels))).dn)
            .collect();
        let mean = dns.iter().sum::<f64>() / n as f64;
        let var = dns.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let expect_mean = e / s.e_per_dn;
        let expect_var = (e + 9.0) / pixels as f64 / (s.e_per_dn * s.e_per_dn);
        let se_mean = (expect_var / n as f64).sqrt();
        assert!(
            (mean - expect_mean).abs() < 5.0 * se_mean,
            "{mean} vs {expect_mean}"
        );
        assert!(
            (var / expect_var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(),
            "{var} vs {expect_var}"
        );
    }

    #[test]
    fn capture_clips_at_full_well_and_flags_it() {
        let s = sensor();
        let c = s.capture(25_000.0, 1.0, None);
        assert!(c.saturated);
        assert!((c.dn - 4095.0).abs() < 1e-9);
        let c = s.capture(5_000.0, 4.0, None);
        assert!(c.saturated, "analogue gain drives the ADC into clipping");
        assert!(!s.capture(5_000.0, 1.0, None).saturated);
    }

    #[test]
    fn same_seed_same_stream() {
        let a: Vec<u64> = {
            let mut r = Rng::new(9);
            (0..5).map(|_| r.next_u64()).collect()
        };
        let b: Vec<u64> = {
            let mut r = Rng::new(9);
            (0..5).map(|_| r.next_u64()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(Rng::new(9).next_u64(), Rng::new(10).next_u64());
    }
}
