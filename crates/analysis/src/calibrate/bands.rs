//! The band estimator: the period of the horizontal bands that a rolling
//! shutter paints under a PWM light, from row profiles (docs/calibration.md,
//! "Band estimator"). It serves `linetime`, `bands`, `calibrate` and the
//! banding analysis of plans.
//!
//! 1. Each row profile (one per frame) has its least-squares quadratic in
//!    the row index removed (vignetting, uneven light).
//! 2. **Fundamental, not a harmonic.** A zero-padded periodogram gives the
//!    power at every harmonic `h f0` of each candidate fundamental `f0`.
//!    A square-wave band profile is a Fourier series, so each candidate is
//!    scored as a periodic model with its best number of harmonics `H`
//!    (1 to [`MAX_HARMONICS`]) by the Bayesian information criterion
//!    `n ln(RSS / n) + 2 H F ln n` (`F` frames). A harmonic `2 f0` cannot
//!    explain the fundamental's power; a sub-harmonic `f0 / 2` explains the
//!    same power only with twice the harmonics, and the criterion charges
//!    for them. So the fundamental wins.
//! 3. **Sub-row refinement.** The period is refined by minimising the
//!    residual of the exact least-squares fit of `quadratic + H harmonics`
//!    over all rows of all frames (golden-section search).
//! 4. **Uncertainty.** From the curvature of the residual at the optimum:
//!    `sigma_f^2 = 2 s^2 / RSS''(f)`, `s^2 = RSS / (n - k)`; and from the
//!    scatter of the estimates of column groups: the larger of the two.
//! 5. **Confidence.** The estimate is refused, with the reason, when the
//!    periodic model explains less than [`MIN_QUALITY`] of the detrended
//!    variance, when the frame holds fewer than [`MIN_BANDS`] periods, when
//!    no majority of the column groups agrees (docs/calibration.md,
//!    "Column groups"), when the only banding is a codec's block grid
//!    ("JPEG and video sources"), or when the relative uncertainty exceeds
//!    [`MAX_RELATIVE_SIGMA`].

use ledflicker_metrics::fft::{self, Complex};
use serde::Serialize;

use super::gram::{harmonic_gram, trend_sums};
use super::harmonics::harmonic_products;
use super::linalg::{lsq_rss, lsq_rss_nested, nested_from_factor, ridged_cholesky};

/// Fewest band periods in the analysed rows for a confident estimate.
pub const MIN_BANDS: f64 = 3.0;
/// Smallest share of the detrended row variance the periodic model must
/// explain (0..1).
pub const MIN_QUALITY: f64 = 0.5;
/// Largest relative uncertainty (1 sigma) of the period.
pub const MAX_RELATIVE_SIGMA: f64 = 0.02;
/// Most harmonics in the periodic model.
pub const MAX_HARMONICS: usize = 10;
/// Fewest rows analysed.
pub const MIN_ROWS: usize = 16;
/// Shortest band period searched, rows.
pub const MIN_PERIOD_ROWS: f64 = 4.0;
/// Rows whose peak-to-peak is at most this share of their level are flat
/// (rounding of a constant profile, not banding).
const FLAT_RELATIVE_PTP: f64 = 1e-9;

/// A confident band-period estimate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BandEstimate {
    /// Band period, rows per PWM period (> 0).
    pub period_rows: f64,
    /// One-sigma uncertainty of the period, rows.
    pub period_sigma_rows: f64,
    /// Share (0..1) of the detrended row-profile variance explained by the
    /// periodic model at the estimated period.
    pub quality: f64,
    /// Band periods in the analysed rows.
    pub bands: f64,
    /// Harmonics in the periodic model (1..=MAX_HARMONICS).
    pub harmonics: usize,
    /// Rows analysed per frame.
    pub rows: usize,
    /// Frames combined.
    pub frames: usize,
    /// Period estimated from each column group kept, alone, rows, left to
    /// right (empty with one column strip or when fewer than two groups
    /// show banding).
    pub group_periods_rows: Vec<f64>,
    /// Column groups left out, left to right: their banding disagrees with
    /// the majority's, or they show none.
    pub dropped: Vec<ColumnGroup>,
    /// Periods of the codec's block grid (16 / k rows) were suppressed
    /// before the search ([`Layout::block_grid`]).
    pub block_grid_suppressed: bool,
}

/// Columns of the frame and the band period they give alone.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ColumnGroup {
    /// Pixel columns `[first, end)` of the frame (end exclusive); several
    /// ranges when a region is not contiguous.
    pub columns: Vec<[u32; 2]>,
    /// Their band period, rows; `None` when they show no confident banding.
    pub period_rows: Option<f64>,
    /// Its one-sigma uncertainty, rows.
    pub period_rows_sigma: Option<f64>,
}

impl std::fmt::Display for ColumnGroup {
    /// `columns 0..320, 480..640: period 40.00 +- 0.01 rows`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let cols: Vec<String> = self
            .columns
            .iter()
            .map(|[a, b]| format!("{a}..{b}"))
            .collect();
        write!(f, "columns {}: ", cols.join(", "))?;
        match (self.period_rows, self.period_rows_sigma) {
            (Some(p), Some(s)) => write!(f, "period {p:.3} +- {s:.3} rows"),
            _ => write!(f, "no banding"),
        }
    }
}

/// Where the strip profiles come from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    /// Pixel columns `[first, end)` of each strip, left to right; empty
    /// when not known (each strip then stands for one column).
    pub columns: Vec<[u32; 2]>,
    /// The source went through a block-transform codec (JPEG, a video):
    /// its 8- and 16-row block grid is not banding.
    pub block_grid: bool,
}

/// Rows between the bands of a light of `frequency_hz` on a rolling
/// shutter of `line_time_s` per row: `P = 1 / (f t_line)`.
pub fn band_period_rows(frequency_hz: f64, line_time_s: f64) -> f64 {
    1.0 / (frequency_hz * line_time_s)
}

impl BandEstimate {
    /// Line time and its sigma, seconds, for a light of `frequency_hz`:
    /// `t_line = 1 / (f P)`.
    pub fn line_time_s(&self, frequency_hz: f64) -> (f64, f64) {
        let t = 1.0 / (frequency_hz * self.period_rows);
        (t, t * self.period_sigma_rows / self.period_rows)
    }

    /// PWM frequency and its sigma, Hz, for a known line time:
    /// `f = 1 / (t_line P)`.
    pub fn frequency_hz(&self, line_time_s: f64) -> (f64, f64) {
        let f = 1.0 / (line_time_s * self.period_rows);
        (f, f * self.period_sigma_rows / self.period_rows)
    }
}

/// Why there is no confident estimate. Each says what was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NoConfidence {
    /// Too few rows.
    #[error("{rows} rows are too few; at least {min} are needed", min = MIN_ROWS)]
    TooFewRows {
        /// Rows given.
        rows: usize,
    },
    /// The rows are constant (to rounding): there is nothing to fit.
    #[error("the rows are flat (peak-to-peak {relative_ptp:.1e} of the level): no banding")]
    Flat {
        /// Peak-to-peak of the rows over their largest magnitude.
        relative_ptp: f64,
    },
    /// The rows are not periodic.
    #[error(
        "no periodic banding: the best periodic fit (period {period_rows:.1} rows) explains {quality:.2} of the row variance, below {min}",
        min = MIN_QUALITY
    )]
    NoBanding {
        /// Share explained by the best periodic model.
        quality: f64,
        /// Its period, rows (0 for flat rows).
        period_rows: f64,
    },
    /// Fewer than MIN_BANDS periods.
    #[error(
        "fewer than {min} bands: the best period, {period_rows:.1} rows, fits {bands:.1} times in {rows} rows",
        min = MIN_BANDS
    )]
    TooFewBands {
        /// Best period, rows.
        period_rows: f64,
        /// Periods in the rows.
        bands: f64,
        /// Rows analysed.
        rows: usize,
    },
    /// Column groups band at different periods: regions of the frame band
    /// differently (two lights, or a light and a periodic overlay).
    #[error(
        "regions of the frame band at different periods (two lights at different frequencies, or a periodic overlay); the frequency given cannot be paired with one period: {}",
        regions.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
    )]
    StripsDisagree {
        /// Regions of consistent banding, largest first, then the columns
        /// without banding.
        regions: Vec<ColumnGroup>,
    },
    /// The banding found lies at the codec's block grid: the only banding
    /// there was, or a period too near it to be told from it.
    #[error(
        "the banding found, a period of {period_rows:.3} rows, lies at the block grid of the JPEG or video coding (16 / k rows: 16, 8, 5.33, 4, within {near} cycles per frame): it cannot be told from the grid",
        near = grid::NEAR_CYCLES
    )]
    BlockGrid {
        /// The period found, rows.
        period_rows: f64,
    },
    /// The banding found changes mostly on the codec's block boundaries:
    /// contours of a quantised gradient, not a light's bands.
    #[error(
        "the banding found, a period of {period_rows:.3} rows, changes mostly on the 8-row block boundaries of the JPEG or video coding ({share:.2} of its row-to-row change, above {max}): contours of a quantised gradient, not bands",
        share = boundary_share,
        max = grid::MAX_BOUNDARY_SHARE
    )]
    BlockContours {
        /// The period found, rows.
        period_rows: f64,
        /// Share of the squared row-to-row differences on block boundaries.
        boundary_share: f64,
    },
    /// The fit leaves the period too uncertain.
    #[error(
        "the period, {period_rows:.2} rows, is uncertain by {relative_sigma:.3} (1 sigma), more than {max}",
        max = MAX_RELATIVE_SIGMA
    )]
    Uncertain {
        /// Period, rows.
        period_rows: f64,
        /// Relative one-sigma uncertainty.
        relative_sigma: f64,
    },
}

impl NoConfidence {
    /// A hint on what to change.
    pub fn hint(&self) -> &'static str {
        match self {
            NoConfidence::TooFewRows { .. } => "use a taller frame or --roi",
            NoConfidence::NoBanding { .. } | NoConfidence::Flat { .. } => {
                "use a frame of a diffusely lit PWM scene (or --roi on the light), exposure shorter than the PWM period"
            }
            NoConfidence::TooFewBands { .. } => {
                "raise the PWM frequency or use more rows, so that at least 3 bands show"
            }
            NoConfidence::StripsDisagree { .. } => {
                "analyse one light at a time: --roi X,Y,W,H over the columns of the region it lights, with that light's --frequency-hz"
            }
            NoConfidence::BlockGrid { .. } | NoConfidence::BlockContours { .. } => {
                "use a lossless frame (PNG, TIFF) of a diffusely lit PWM scene, or --roi around a directly imaged LED; a true band period within 2 cycles per frame of 16 / k rows cannot be told from the block grid"
            }
            NoConfidence::Uncertain { .. } => "use more frames, more rows or a cleaner frame",
        }
    }
}

/// Row profiles: `frames[frame][strip][row]`, the mean of each row over
/// each of a frame's column strips, left to right. All frames have the same
/// number of strips and rows.
pub type StripProfiles = Vec<Vec<Vec<f64>>>;

/// Per-row median over strips (the mean for one or two strips): a text
/// overlay or a bright object in a minority of the strips does not move it.
pub fn combine_strips(strips: &[Vec<f64>]) -> Vec<f64> {
    let n = strips.first().map_or(0, Vec::len);
    let mut buf = Vec::with_capacity(strips.len());
    (0..n)
        .map(|r| {
            buf.clear();
            buf.extend(strips.iter().map(|s| s[r]));
            median(&mut buf)
        })
        .collect()
}

/// Median of a slice (mean of the middle two for even lengths); 0 if empty.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// Estimates the band period of a single row profile (one frame, one strip).
pub fn estimate_profile(profile: &[f64]) -> Result<BandEstimate, NoConfidence> {
    estimate_profiles(&[profile.to_vec()])
}

/// Estimates the band period common to all frames of `input`: the codec's
/// block grid suppressed (module `grid`) when `layout` says there is one,
/// the column groups compared and combined (module `strips`).
pub fn estimate(input: &StripProfiles, layout: &Layout) -> Result<BandEstimate, NoConfidence> {
    if layout.block_grid {
        grid::estimate(input, &layout.columns)
    } else {
        strips::estimate(input, &layout.columns)
    }
}

/// Estimates the band period common to a set of row profiles (one per
/// frame): every check but the column groups', whose scatter is not added
/// to the sigma.
fn estimate_profiles(profiles: &[Vec<f64>]) -> Result<BandEstimate, NoConfidence> {
    let n = profiles.first().map_or(0, Vec::len);
    if n < MIN_ROWS || profiles.iter().any(|p| p.len() != n) {
        return Err(NoConfidence::TooFewRows { rows: n });
    }
    let (lo, hi) = profiles
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let relative_ptp = (hi - lo) / lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE);
    if relative_ptp.is_nan() || relative_ptp <= FLAT_RELATIVE_PTP {
        return Err(NoConfidence::Flat { relative_ptp });
    }
    let fit = PeriodicFit::new(profiles);
    let (f0, ratios) = fit.coarse();
    let bin = 1.0 / fit.padded as f64;
    let (f, h, rss) = fit.verify(f0, &ratios, 1.5 * bin);
    let quality = (1.0 - rss / fit.trend_rss).clamp(0.0, 1.0);
    let period = 1.0 / f;
    if quality < MIN_QUALITY {
        return Err(NoConfidence::NoBanding {
            quality,
            period_rows: period,
        });
    }
    let bands = n as f64 * f;
    if bands < MIN_BANDS {
        return Err(NoConfidence::TooFewBands {
            period_rows: period,
            bands,
            rows: n,
        });
    }
    let relative_sigma = fit.sigma(f, h, rss) / f;
    if relative_sigma.is_nan() || relative_sigma > MAX_RELATIVE_SIGMA {
        return Err(NoConfidence::Uncertain {
            period_rows: period,
            relative_sigma,
        });
    }
    Ok(BandEstimate {
        period_rows: period,
        period_sigma_rows: relative_sigma * period,
        quality,
        bands,
        harmonics: h,
        rows: n,
        frames: profiles.len(),
        group_periods_rows: Vec::new(),
        dropped: Vec::new(),
        block_grid_suppressed: false,
    })
}

/// Least-squares periodic models of a set of equally long row profiles.
struct PeriodicFit<'a> {
    profiles: &'a [Vec<f64>],
    /// Rows per profile.
    n: usize,
    /// Residual of the quadratic trend alone, summed over profiles.
    trend_rss: f64,
    /// Length of the zero-padded periodogram.
    padded: usize,
    /// Sum of the squares of every profile value.
    sum_squares: f64,
    /// `sum_i t^p`, `p` in `0..=4`: the trend block of every Gram matrix.
    trend_sums: [f64; 5],
    /// Each profile's `sum_i t^p y_i` (`p` in `0..3`) and `sum_i y_i^2`,
    /// in row order: the trend part of every `A^T y`.
    trend_products: Vec<([f64; 3], f64)>,
    /// Scratch space for the harmonic columns of a trial frequency.
    columns: std::cell::RefCell<Vec<f64>>,
}

impl<'a> PeriodicFit<'a> {
    fn new(profiles: &'a [Vec<f64>]) -> Self {
        let n = profiles.first().map_or(0, Vec::len);
        let trend_rss = profiles
            .iter()
            .map(|p| lsq_rss(p, 3, |i, r| trend_basis(i, n, r)).unwrap_or(0.0))
            .sum();
        Self {
            profiles,
            n,
            trend_rss,
            padded: (8 * n).next_power_of_two(),
            sum_squares: profiles.iter().flatten().map(|v| v * v).sum(),
            trend_sums: trend_sums(n),
            trend_products: profiles.iter().map(|p| trend_products(p)).collect(),
            columns: std::cell::RefCell::new(Vec::new()),
        }
    }

    /// Residual of `quadratic + h harmonics of f` (cycles per row), summed
    /// over profiles.
    fn rss(&self, f: f64, h: usize) -> f64 {
        self.rss_upto(f, h)[h - 1]
    }

    /// Residuals of `quadratic + k harmonics of f` for every `k` in
    /// `1..=h` (entry `k - 1`), summed over profiles: the models are nested
    /// (harmonic `k` adds two columns), so one accumulation and one
    /// factorisation give them all ([`lsq_rss_nested`]). The Gram matrix
    /// is the same for every profile and is in closed form
    /// ([`harmonic_gram`]) where that is accurate; only `A^T y` is summed
    /// over the rows.
    fn rss_upto(&self, f: f64, h: usize) -> Vec<f64> {
        let n = self.n;
        let m = 3 + 2 * h;
        let mut total = vec![0.0; h];
        let mut add = |rss: &[f64]| {
            for (t, k) in total.iter_mut().zip(1..=h) {
                *t += rss[3 + 2 * k];
            }
        };
        let w = 2.0 * std::f64::consts::PI * f;
        let Some(gram) = harmonic_gram(n, w, h, &self.trend_sums) else {
            for p in self.profiles {
                add(&lsq_rss_nested(p, m, 3, |design, stride| {
                    harmonic_design(design, stride, n, f, h)
                }));
            }
            return total;
        };
        let (l, good) = ridged_cholesky(gram, m, 3);
        let products = harmonic_products(&mut self.columns.borrow_mut(), self.profiles, n, f, h);
        let mut aty = Vec::with_capacity(m);
        for ((trend, yy), harmonics) in self.trend_products.iter().zip(products) {
            aty.clear();
            aty.extend_from_slice(trend);
            aty.extend(harmonics);
            add(&nested_from_factor(&l, good, &aty, *yy, m));
        }
        total
    }

    /// The best fundamental on the periodogram grid, by the information
    /// criterion of the module docs, and the ratios to it that
    /// [`Self::verify`] checks exactly: `1, 1/2, 1/3`, and each multiple
    /// `m` (up to the chosen harmonic count) whose peak holds at least a
    /// tenth of the strongest harmonic's power. The grid's sums of peak
    /// powers overlap (zero-padded bins are not independent), so a
    /// sub-harmonic `f0 / m` can win here; the exact check of `m` undoes it.
    fn coarse(&self) -> (f64, Vec<f64>) {
        let (n, big_n) = (self.n, self.padded);
        let frames = self.profiles.len();
        let mut power = vec![0.0; big_n / 2 + 1];
        let mut buf = vec![Complex::new(0.0, 0.0); big_n];
        for p in self.profiles {
            let d = detrend(p);
            buf.iter_mut().for_each(|c| *c = Complex::new(0.0, 0.0));
            for (b, &v) in buf.iter_mut().zip(&d) {
                b.re = v;
            }
            fft::forward(&mut buf);
            for (k, pw) in power.iter_mut().enumerate() {
                // Sum of squares a sinusoid at bin k explains: 2 |Y|^2 / n.
                *pw += 2.0 * buf[k].norm_sqr() / n as f64;
            }
        }
        let (k0, h) = grid_choice(&power, n, frames, self.trend_rss);
        let peak = |m: usize| {
            let (c, w) = (m * k0, m / 2);
            let hi = (c + w).min(big_n / 2);
            power[c.saturating_sub(w).min(hi)..=hi]
                .iter()
                .fold(0.0f64, |a, &b| a.max(b))
        };
        let strongest = (1..=h).map(peak).fold(0.0f64, f64::max);
        let mut ratios = vec![1.0, 0.5, 1.0 / 3.0];
        ratios.extend(
            (2..=h)
                .filter(|&m| peak(m) >= 0.1 * strongest)
                .map(|m| m as f64),
        );
        (k0 as f64 / big_n as f64, ratios)
    }

    /// The exact check of the coarse choice: `f0 * r` for each of `ratios`
    /// (`f0` itself, sub-multiples and the multiples that carry power) is
    /// refined and given its best harmonic count by the exact residual's
    /// BIC (with a floor of 1e-6 of the trend residual, so that noise-free
    /// profiles tie and the simpler model wins). Returns frequency,
    /// harmonics, residual.
    fn verify(&self, f0: f64, ratios: &[f64], half: f64) -> (f64, usize, f64) {
        let frames = self.profiles.len();
        let n_tot = (self.n * frames) as f64;
        let penalty = 2.0 * frames as f64 * n_tot.ln();
        let floor = 1e-6 * self.trend_rss;
        let (lo, hi) = (1.5 / self.n as f64, 1.0 / MIN_PERIOD_ROWS);
        let mut best = (f64::INFINITY, f0, 1, f64::INFINITY);
        for &ratio in ratios {
            let c = f0 * ratio;
            if c < lo || c > hi {
                continue;
            }
            let h_max = MAX_HARMONICS.min((0.5 / c) as usize).max(1);
            // Located with few harmonics and coarsely: the scores below
            // need the right basin, not the last digit, and the choice is
            // refined again below with its own harmonic count.
            let f = self.refine_to(
                c,
                h_max.min(CANDIDATE_HARMONICS),
                half * ratio.max(1.0),
                CANDIDATE_TOLERANCE,
            );
            for (h, rss) in (1..=h_max).zip(self.rss_upto(f, h_max)) {
                let bic = n_tot * (rss.max(floor) / n_tot).ln() + penalty * h as f64;
                if bic < best.0 {
                    best = (bic, f, h, rss);
                }
            }
        }
        let (_, f, h, _) = best;
        // Refine again with the chosen harmonic count.
        let f = self.refine(f, h, 0.5 * half);
        (f, h, self.rss(f, h))
    }

    /// The least residual within `f0 +- half`, by Brent's method
    /// (golden-section steps, and parabolic steps where the residual is
    /// smooth): located to [`REFINE_TOLERANCE`] of `half`, in fewer
    /// residual evaluations than golden section's 32.
    fn refine(&self, f0: f64, h: usize, half: f64) -> f64 {
        self.refine_to(f0, h, half, REFINE_TOLERANCE)
    }

    /// [`Self::refine`] to `tolerance` of `half`.
    fn refine_to(&self, f0: f64, h: usize, half: f64, tolerance: f64) -> f64 {
        let lo_limit = 1.0 / self.n as f64;
        brent_minimum(
            |f| self.rss(f, h),
            ((f0 - half).max(lo_limit), f0 + half),
            tolerance * half,
        )
    }

    /// One-sigma uncertainty of the frequency from the residual curvature.
    ///
    /// The residual is a difference of sums of `N` squares, rounded to about
    /// `N eps sum(y^2)`: frequencies whose residuals differ by less are not
    /// told apart, so that resolution is added to the residual variance.
    /// It matters only for noise-free profiles whose fit is exact to
    /// rounding (a whole number of rows per period, say), where the
    /// curvature alone would claim a sigma below what the search resolves.
    fn sigma(&self, f: f64, h: usize, rss: f64) -> f64 {
        let frames = self.profiles.len();
        let samples = (self.n * frames) as f64;
        let dof = samples - ((3 + 2 * h) * frames) as f64 - 1.0;
        let resolution = samples * f64::EPSILON * self.sum_squares;
        let s2 = rss / dof.max(1.0) + resolution;
        let step = 0.02 / (self.n as f64 * h as f64);
        let curv = (self.rss(f + step, h) - 2.0 * rss + self.rss(f - step, h)) / (step * step);
        if curv > 0.0 {
            (2.0 * s2 / curv).sqrt()
        } else {
            f64::INFINITY
        }
    }
}

/// The fundamental bin `k0` and harmonic count `h` of least BIC on the
/// periodogram grid (`power`, `big_n / 2 + 1` bins of a `big_n`-point FFT
/// of `frames` profiles of `n` rows; `trend_rss` their trend residual):
/// the step of [`PeriodicFit::coarse`] that scores every bin.
fn grid_choice(power: &[f64], n: usize, frames: usize, trend_rss: f64) -> (usize, usize) {
    let big_n = 2 * (power.len() - 1);
    let total = trend_rss.max(1e-300);
    let n_tot = (n * frames) as f64;
    let penalty = 2.0 * frames as f64 * n_tot.ln();
    let k_lo = ((1.5 * big_n as f64 / n as f64).ceil() as usize).max(1);
    let k_hi = (big_n as f64 / MIN_PERIOD_ROWS) as usize;
    let mut best = (f64::INFINITY, k_lo, 1);
    // `limits[h]`: a residual at or above it cannot beat the best with
    // `h` harmonics (the criterion's inverse, with a margin of 1e-9
    // that dwarfs the rounding of `ln` and `exp`), so most candidates
    // skip the logarithm; the choice is the same.
    let mut limits = [f64::INFINITY; MAX_HARMONICS + 1];
    for k0 in k_lo..=k_hi {
        let h_max = MAX_HARMONICS.min(big_n / 2 / k0).max(1);
        let mut explained = 0.0;
        for h in 1..=h_max {
            let (c, w) = (h * k0, h / 2);
            let lo = c.saturating_sub(w);
            let hi = (c + w).min(big_n / 2);
            explained += power[lo..=hi].iter().fold(0.0f64, |a, &b| a.max(b));
            let rss = (total - explained).max(1e-12 * total);
            if rss >= limits[h] {
                continue;
            }
            let bic = n_tot * (rss / n_tot).ln() + penalty * h as f64;
            if bic < best.0 {
                best = (bic, k0, h);
                for (j, limit) in limits.iter_mut().enumerate() {
                    let ln_rss = (bic - penalty * j as f64) / n_tot;
                    *limit = n_tot * ln_rss.exp() * (1.0 + 1e-9);
                }
            }
        }
    }
    (best.1, best.2)
}

/// Brent's method's tolerance on the refined frequency, as a share of the
/// search half-width: a hundredth of the final bracket of the 30
/// golden-section steps used before (`0.618^30 = 5.4e-7` of the width).
const REFINE_TOLERANCE: f64 = 5e-9;

/// Harmonics of the fits that locate each candidate of the exact check
/// ([`PeriodicFit::verify`]): the residual's basin lies at the fundamental
/// whatever the harmonic count, and a fit of 3 harmonics (9 columns) costs
/// a sixth of one of 10 (23 columns).
const CANDIDATE_HARMONICS: usize = 3;

/// Brent's tolerance when locating a candidate, as a share of the search
/// half-width. The candidate is scored where the search stops; near a
/// minimum the residual grows with the square of the distance to it, so the
/// score moves far less than what tells two candidates apart.
const CANDIDATE_TOLERANCE: f64 = 1e-4;

/// Most residual evaluations of one refinement.
const REFINE_MAX_STEPS: usize = 60;

/// The minimum of `g` on `[a, b]` to within about `tol`, by Brent's method
/// (R. P. Brent, *Algorithms for Minimization without Derivatives*, 1973,
/// chapter 5): a parabola through the three best points gives the next
/// step where it falls inside the bracket and shrinks the steps, a
/// golden-section step otherwise.
fn brent_minimum(mut g: impl FnMut(f64) -> f64, (mut a, mut b): (f64, f64), tol: f64) -> f64 {
    let golden = (3.0 - 5f64.sqrt()) / 2.0;
    let mut x = a + golden * (b - a);
    let (mut w, mut v) = (x, x);
    let mut gx = g(x);
    let (mut gw, mut gv) = (gx, gx);
    // `step` is the last step taken, `prev` the one before it.
    let (mut step, mut prev) = (0.0f64, 0.0f64);
    for _ in 0..REFINE_MAX_STEPS {
        let mid = 0.5 * (a + b);
        let tol1 = tol.max(f64::EPSILON * x.abs());
        if (x - mid).abs() <= 2.0 * tol1 - 0.5 * (b - a) {
            break;
        }
        let mut parabolic = false;
        if prev.abs() > tol1 {
            let r = (x - w) * (gx - gv);
            let q = (x - v) * (gx - gw);
            let mut p = (x - v) * q - (x - w) * r;
            let mut q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            } else {
                q = -q;
            }
            if p.abs() < (0.5 * q * prev).abs() && p > q * (a - x) && p < q * (b - x) {
                prev = step;
                step = p / q;
                let u = x + step;
                if u - a < 2.0 * tol1 || b - u < 2.0 * tol1 {
                    step = tol1.copysign(mid - x);
                }
                parabolic = true;
            }
        }
        if !parabolic {
            prev = if x >= mid { a - x } else { b - x };
            step = golden * prev;
        }
        let u = if step.abs() >= tol1 {
            x + step
        } else {
            x + tol1.copysign(step)
        };
        let gu = g(u);
        if gu <= gx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, gv, w, gw, x, gx) = (w, gw, x, gx, u, gu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if gu <= gw || w == x {
                (v, gv, w, gw) = (w, gw, u, gu);
            } else if gu <= gv || v == x || v == w {
                (v, gv) = (u, gu);
            }
        }
    }
    x
}

/// Rows between phases computed exactly in [`harmonic_design`]; the rows
/// between are turned from the row before (angle addition), so a phase is
/// at most 31 rotations, a few units of rounding, from the exact one.
const EXACT_PHASE_ROWS: usize = 32;

/// Fills the design of `quadratic + h harmonics of f` over `n` rows (row
/// `i` at `design[i * stride..]`): `1, t, t^2`, then `cos, sin` of `k` times
/// the row's phase for `k` in `1..=h`. The row's phase is computed exactly
/// every [`EXACT_PHASE_ROWS`] rows and turned by `2 pi f` from the row
/// before in between (a sine and cosine per row was a tenth of the
/// estimator). Harmonic `k + 1` is harmonic `k` turned by the row's phase
/// (angle addition); the rows are independent, so harmonic by harmonic,
/// all rows in turn, the CPU overlaps them.
fn harmonic_design(design: &mut [f64], stride: usize, n: usize, f: f64, h: usize) {
    let w = 2.0 * std::f64::consts::PI * f;
    let (sw, cw) = w.sin_cos();
    let (mut s, mut c) = (0.0f64, 1.0f64);
    for (i, r) in design.chunks_exact_mut(stride).enumerate() {
        trend_basis(i, n, r);
        (s, c) = if i % EXACT_PHASE_ROWS == 0 {
            (w * i as f64).sin_cos()
        } else {
            (s * cw + c * sw, c * cw - s * sw)
        };
        r[3] = c;
        r[4] = s;
    }
    for k in 1..h {
        for r in design.chunks_exact_mut(stride) {
            let (c1, s1) = (r[3], r[4]);
            let (c, s) = (r[1 + 2 * k], r[2 + 2 * k]);
            r[3 + 2 * k] = c * c1 - s * s1;
            r[4 + 2 * k] = s * c1 + c * s1;
        }
    }
}

/// `sum_i t^p y_i` for `p` in `0..3` and `sum_i y_i^2`, in row order.
fn trend_products(y: &[f64]) -> ([f64; 3], f64) {
    let (mut sums, mut yy, mut r) = ([0.0; 3], 0.0, [0.0; 3]);
    for (i, &v) in y.iter().enumerate() {
        trend_basis(i, y.len(), &mut r);
        for (s, x) in sums.iter_mut().zip(r) {
            *s += x * v;
        }
        yy += v * v;
    }
    (sums, yy)
}

/// `1, t, t^2` with `t` in [-1, 1] over `n` rows.
fn trend_basis(i: usize, n: usize, r: &mut [f64]) {
    let t = 2.0 * i as f64 / (n.max(2) - 1) as f64 - 1.0;
    r[0] = 1.0;
    r[1] = t;
    r[2] = t * t;
}

/// The profile minus its least-squares quadratic.
fn detrend(y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let (mut ata, mut aty) = ([0.0; 9], [0.0; 3]);
    let mut r = [0.0; 3];
    for (i, &v) in y.iter().enumerate() {
        trend_basis(i, n, &mut r);
        for p in 0..3 {
            aty[p] += r[p] * v;
            for q in 0..3 {
                ata[p * 3 + q] += r[p] * r[q];
            }
        }
    }
    let x = super::linalg::solve_spd(&ata, &aty, 3).unwrap_or_else(|| vec![0.0; 3]);
    y.iter()
        .enumerate()
        .map(|(i, &v)| {
            trend_basis(i, n, &mut r);
            v - x[0] * r[0] - x[1] * r[1] - x[2] * r[2]
        })
        .collect()
}

mod grid;
mod strips;
#[cfg(test)]
mod tests;
