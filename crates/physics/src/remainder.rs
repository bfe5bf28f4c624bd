//! `x % y`, bit for bit, in a few floating-point operations.
//!
//! The phase of frame `n` is `(n f) mod fps`, formed with an exact
//! remainder so that a late frame is as accurate as an early one
//! ([`crate::PwmDrive::phase_at`]). Rust's `%` on `f64` is IEEE `fmod`,
//! exact, but the `fmod` this target links divides bit by bit, one step per
//! bit of the quotient: about 170 ns for a quotient of 2^15, which made it
//! the costliest single function of a case's analysis. [`rem`] gives the
//! same bits from one division and an exact product.

/// 2^52: below it every whole number is a double, and so is the quotient.
const QUOTIENT_MAX: f64 = 4_503_599_627_370_496.0;
/// Divisors outside `[2^-500, 2^500]` go to `%`, so that no product below
/// overflows or loses bits to underflow.
const DIVISOR_MIN: f64 = f64::from_bits((1023 - 500) << 52);
const DIVISOR_MAX: f64 = f64::from_bits((1023 + 500) << 52);
/// Veltkamp's splitter for doubles: 2^27 + 1.
const SPLITTER: f64 = 134_217_729.0;

/// `x % y` (IEEE `fmod`: the sign of `x`, magnitude below `|y|`), with the
/// same bits, NaN, infinities and zeros included.
///
/// With the quotient `q = trunc(|x| / |y|)` (a whole number, exact below
/// 2^52, and never short of the true one), `|x| - q |y|` is formed exactly:
/// `q |y| = p + e` exactly (Dekker's product), `|x| - p` is exact because
/// `p` lies within a factor of two of `|x|` (Sterbenz), and the true
/// remainder is a double, so `(|x| - p) - e` rounds to itself. A quotient
/// rounded up by the division leaves a negative remainder and is taken
/// back by one.
#[inline]
pub fn rem(x: f64, y: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let in_range = (DIVISOR_MIN..=DIVISOR_MAX).contains(&ay) && ax < ay * QUOTIENT_MAX;
    if !in_range {
        return x % y;
    }
    if ax < ay {
        return x;
    }
    let mut q = (ax / ay).trunc();
    let mut r = residual(ax, ay, q);
    if r < 0.0 {
        q -= 1.0;
        r = residual(ax, ay, q);
    } else if r >= ay {
        q += 1.0;
        r = residual(ax, ay, q);
    }
    r.copysign(x)
}

/// `x - q y`, exact when it is a double and `q y` is within a factor of
/// two of `x`.
#[inline(always)]
fn residual(x: f64, y: f64, q: f64) -> f64 {
    let p = q * y;
    let (qh, ql) = split(q);
    let (yh, yl) = split(y);
    let e = ((qh * yh - p) + qh * yl + ql * yh) + ql * yl;
    (x - p) - e
}

/// `a = hi + lo` exactly, each half of 26 bits or fewer.
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    let c = SPLITTER * a;
    let hi = c - (c - a);
    (hi, a - hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::Rng;

    fn same(x: f64, y: f64) {
        let (a, b) = (rem(x, y), x % y);
        assert!(
            a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
            "rem({x:e}, {y:e}) = {a:e}, % gives {b:e}"
        );
    }

    #[test]
    fn frame_phases_match_fmod_bit_for_bit() {
        let mut rng = Rng::new(0x5eed);
        for _ in 0..300_000 {
            // Frame n of a capture at fps, a PWM of f Hz: the phases the
            // analyses form, at the frequencies and rates plans use.
            let n = rng.next_u64() % 200_000;
            let f = 10.0 + rng.uniform() * 20_000.0;
            let fps = [
                24.0,
                29.97,
                30.0,
                60.0,
                1000.0 / 33.0,
                5.0 + rng.uniform() * 995.0,
            ][(rng.next_u64() % 6) as usize];
            same(n as f64 * f, fps);
            same(n as f64 * f.round(), fps);
        }
    }

    #[test]
    fn near_multiples_signs_and_specials_match_fmod() {
        let mut rng = Rng::new(42);
        for _ in 0..300_000 {
            // x a few ulps either side of a multiple of y: where the
            // division rounds across a whole number.
            let y = (rng.uniform() - 0.5) * 2f64.powi((rng.next_u64() % 80) as i32 - 40);
            let k = (rng.next_u64() % (1 << 40)) as f64;
            let ulps = (rng.next_u64() % 9) as i64 - 4;
            let x = f64::from_bits(((k * y).abs().to_bits() as i64 + ulps) as u64);
            same(x, y);
            same(-x, y);
            same(x, -y);
        }
        let specials = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::MIN_POSITIVE,
            5e-324,
            1e-200,
            1e200,
            2f64.powi(52),
            2f64.powi(53) + 2.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for x in specials {
            for y in specials {
                same(x, y);
            }
        }
    }
}
