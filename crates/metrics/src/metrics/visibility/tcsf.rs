//! The eye's temporal contrast sensitivity: elaTCSF (Cai, Bozorgian,
//! Ashraf, Wanat and Mantiuk, "elaTCSF: A temporal contrast sensitivity
//! function for flicker detection and modeling variable refresh rate
//! flicker", SIGGRAPH Asia 2024), written here from the paper's equations
//! and its fitted parameters (docs/visibility.md).
//!
//! The model has two parts:
//! - elTCSF, the sensitivity of a point of the visual field at
//!   eccentricity `e` (deg) and luminance `L` (cd/m^2) to flicker at `f`
//!   Hz. Its shape is the TCSF of the ICDM Information Display
//!   Measurements Standard, Watson's (1986) difference of two cascades of
//!   leaky integrators, `xi |(1 + i 2 pi f tau)^-n1 - zeta (1 + i 2 pi f
//!   kappa tau)^-n2|`, whose frequency axis is stretched with eccentricity
//!   and log luminance, scaled by a luminance and an eccentricity gain;
//! - spatial summation over the stimulus (elaTCSF): the sensitivities of
//!   the points of a disk pool by a Minkowski sum of exponent `beta`, and
//!   the disk is at threshold when the pooled energy reaches `E_thr`:
//!   `S = (integral over the disk of S_el^beta dA / E_thr)^(1/beta)`.
//!
//! Sensitivity is 1 / threshold modulation, modulation being the
//! amplitude of a sinusoidal luminance modulation over its mean.

/// Cascade orders and constants of the TCSF (Cai et al. 2024, the fitted values the
/// authors publish with the model).
const N1: f64 = 15.0;
const N2: f64 = 16.0;
const XI: f64 = 154.133;
const TAU_S: f64 = 0.002_920_69;
const KAPPA: f64 = 2.125_47;
const ZETA: f64 = 0.721_095;
/// Frequency stretch with log10 luminance: `f / (B_LUM + K_LUM log10 L)`.
const K_LUM: f64 = 0.222_269;
const B_LUM: f64 = 0.6678;
/// Frequency stretch with eccentricity about `F_ECC_PIVOT_HZ`.
const K_ECC_FREQ: f64 = 0.034_181_1;
const F_ECC_PIVOT_HZ: f64 = -2.0;
/// Sensitivity loss with eccentricity: `10^(-K_ECC e)`.
const K_ECC: f64 = 0.033_093_3;
/// Luminance gain `G (1 + L_K / L)^(-P)`.
const LUM_GAIN: f64 = 1.768_01;
const LUM_K_CD_M2: f64 = 1.624_02;
const LUM_P: f64 = 0.533_781;
/// Spatial summation exponent and threshold energy (deg^2).
const BETA: f64 = 3.800_22;
const E_THR: f64 = 6.528_01;

/// Lowest mean luminance the model is used at, cd/m^2. The fitted data
/// reach down to about 0.1 cd/m^2; the frequency stretch
/// `B_LUM + K_LUM log10 L` would reach zero near 1e-3 cd/m^2, where the
/// model no longer means anything.
pub const MIN_LUMINANCE_CD_M2: f64 = 0.01;

/// Simpson intervals over the disk's radius. The integrand is smooth
/// (its steepest factor is `10^(-0.126 r)` per degree); 64 intervals keep
/// the sensitivity within 1e-6 of a 4096-interval sum up to a 60 deg disk
/// (test `disk_integral_converges`).
const RADIAL_INTERVALS: usize = 64;

/// elTCSF: sensitivity of a point at eccentricity `ecc_deg` (>= 0) of a
/// field of mean luminance `luminance_cd_m2` (>= [`MIN_LUMINANCE_CD_M2`])
/// to flicker at `frequency_hz` (>= 0). Dimensionless, >= 0.
pub fn point_sensitivity(frequency_hz: f64, ecc_deg: f64, luminance_cd_m2: f64) -> f64 {
    let f_ecc = (frequency_hz - F_ECC_PIVOT_HZ) / (1.0 + K_ECC_FREQ * ecc_deg) + F_ECC_PIVOT_HZ;
    let f = f_ecc / (B_LUM + K_LUM * luminance_cd_m2.log10());
    let w = 2.0 * std::f64::consts::PI * f * TAU_S;
    let (a_re, a_im) = inverse_power(w, N1);
    let (b_re, b_im) = inverse_power(w * KAPPA, N2);
    let tcsf = XI * (a_re - ZETA * b_re).hypot(a_im - ZETA * b_im);
    let s_ecc = 10f64.powf(-K_ECC * ecc_deg);
    let s_lum = LUM_GAIN * (1.0 + LUM_K_CD_M2 / luminance_cd_m2).powf(-LUM_P);
    s_ecc * s_lum * tcsf
}

/// `(1 + i x)^-n` as (real, imaginary): modulus `(1 + x^2)^(-n/2)`,
/// argument `-n atan(x)`.
fn inverse_power(x: f64, n: f64) -> (f64, f64) {
    let modulus = (1.0 + x * x).powf(-n / 2.0);
    let arg = -n * x.atan();
    (modulus * arg.cos(), modulus * arg.sin())
}

/// elaTCSF: sensitivity to flicker at `frequency_hz` of a uniform disk of
/// `radius_deg` (> 0) centred where the observer looks, at mean
/// luminance `luminance_cd_m2` (>= [`MIN_LUMINANCE_CD_M2`]).
pub fn disk_sensitivity(frequency_hz: f64, radius_deg: f64, luminance_cd_m2: f64) -> f64 {
    disk_sensitivity_with(frequency_hz, radius_deg, luminance_cd_m2, RADIAL_INTERVALS)
}

/// [`disk_sensitivity`] with `intervals` (even) Simpson intervals.
fn disk_sensitivity_with(
    frequency_hz: f64,
    radius_deg: f64,
    luminance_cd_m2: f64,
    intervals: usize,
) -> f64 {
    // A disk centred on fixation: eccentricity is the radius r, and the
    // area element is 2 pi r dr.
    let h = radius_deg / intervals as f64;
    let integrand = |i: usize| {
        let r = i as f64 * h;
        point_sensitivity(frequency_hz, r, luminance_cd_m2).powf(BETA) * r
    };
    let mut sum = integrand(0) + integrand(intervals);
    for i in 1..intervals {
        sum += integrand(i) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    let energy = 2.0 * std::f64::consts::PI * sum * h / 3.0;
    (energy / E_THR).powf(1.0 / BETA)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_integral_converges() {
        for &(f, r, l) in &[
            (1.0, 0.05, 0.1),
            (15.0, 1.0, 50.0),
            (40.0, 30.0, 450.0),
            (60.0, 60.0, 5000.0),
        ] {
            let coarse = disk_sensitivity(f, r, l);
            let fine = disk_sensitivity_with(f, r, l, 4096);
            assert!(
                (coarse / fine - 1.0).abs() < 1e-6,
                "f {f} r {r} L {l}: {coarse} vs {fine}"
            );
        }
    }

    #[test]
    fn a_small_disk_sums_its_area_at_the_fovea() {
        // For r -> 0 the integrand is S(0)^beta r, so S_disk -> S(0) (pi
        // r^2 / E_thr)^(1/beta): the sensitivity grows as the area^(1/beta).
        let (f, l) = (10.0, 100.0);
        let r = 1e-4;
        let expected =
            point_sensitivity(f, 0.0, l) * (std::f64::consts::PI * r * r / E_THR).powf(1.0 / BETA);
        let got = disk_sensitivity(f, r, l);
        assert!((got / expected - 1.0).abs() < 1e-5, "{got} vs {expected}");
    }

    #[test]
    fn inverse_power_matches_repeated_complex_division() {
        // (1 + i x)^-n by n divisions, for an integer n.
        let x: f64 = 0.7;
        let (mut re, mut im) = (1.0f64, 0.0f64);
        for _ in 0..15 {
            // (re + i im) / (1 + i x)
            let d = 1.0 + x * x;
            (re, im) = ((re + im * x) / d, (im - re * x) / d);
        }
        let (a, b) = inverse_power(x, 15.0);
        assert!((a - re).abs() < 1e-12 && (b - im).abs() < 1e-12);
    }

    #[test]
    fn the_peak_moves_up_and_rises_with_luminance() {
        // Kelly 1961 and de Lange 1958: the peak moves up in frequency
        // and rises with luminance (the Ferry-Porter trend).
        let peak = |l: f64| {
            (1..=600)
                .map(|i| i as f64 * 0.1)
                .map(|f| (f, disk_sensitivity(f, 30.0, l)))
                .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
        };
        let (f_lo, s_lo) = peak(0.3);
        let (f_hi, s_hi) = peak(500.0);
        assert!(f_lo < 6.0 && f_hi > f_lo + 4.0, "{f_lo} {f_hi}");
        assert!(s_hi > 2.0 * s_lo, "{s_lo} {s_hi}");
    }
}
