//! The block grid of JPEG and video coding: it is not banding.
//!
//! JPEG codes a frame in 8 x 8 blocks, in 16-row units with vertically
//! subsampled chroma (4:2:0); video codecs in 4 x 4 to 16 x 16 blocks and
//! 16-row macroblocks. Quantisation leaves a pattern that repeats every 8
//! or 16 rows (a smooth gradient becomes a staircase of block levels), so
//! the row profile carries power at `k / 16` cycles per row, periods of
//! `16 / k` rows, that says nothing of the light. Before the search every
//! profile loses its part that repeats every 16 rows: the mean, over the
//! rows of each phase `r mod 16`, of the profile less its quadratic trend.
//! That is the least-squares projection on every sequence of period 16, so
//! it takes all of `k / 16` and little else.
//!
//! What is left is estimated as usual. An estimate within [`NEAR_CYCLES`]
//! cycles per frame of `k / 16` is refused (the projection took much of
//! it); so is a frame whose only banding was the grid (docs/calibration.md,
//! "JPEG and video sources").
//!
//! Quantisation also turns a smooth gradient into contours: a staircase
//! of block levels that steps where the gradient crosses a quantiser step,
//! every `step / gradient` rows, which can pass for bands of any period.
//! Its steps lie on the 8-row block boundaries, where a light's band edges
//! fall on one row in 8. An estimate whose rows change mostly there (more
//! than [`MAX_BOUNDARY_SHARE`] of the squared row-to-row differences of
//! the whole frame's profile on the boundary rows) is refused too.

use super::{BandEstimate, NoConfidence, StripProfiles, strips};

/// Rows of the grid's longest period (JPEG 4:2:0 units, macroblocks).
const GRID_ROWS: usize = 16;
/// A frequency within this many cycles per frame of a grid frequency
/// `k / 16` is not told from it: a sinusoid loses a share
/// `sinc^2(pi d)` of its power to the projection at `d` cycles per frame,
/// and the side lobes beyond 2 cycles hold under 2 % of it.
pub(super) const NEAR_CYCLES: f64 = 2.0;

/// Rows of a JPEG block.
const BLOCK_ROWS: usize = 8;
/// Largest share of the squared row-to-row differences that may fall on
/// the block boundaries (1 row in 8: 1/8 for bands of a light, all of it
/// for block contours).
pub(super) const MAX_BOUNDARY_SHARE: f64 = 0.5;

/// The estimate of [`super::estimate`] for a block-coded source.
pub(super) fn estimate(
    input: &StripProfiles,
    columns: &[[u32; 2]],
) -> Result<BandEstimate, NoConfidence> {
    let suppressed: StripProfiles = input
        .iter()
        .map(|frame| frame.iter().map(|p| suppress(p)).collect())
        .collect();
    match strips::estimate(&suppressed, columns) {
        Ok(e) if near_grid(e.period_rows, e.rows) => Err(NoConfidence::BlockGrid {
            period_rows: e.period_rows,
        }),
        Ok(e) if boundary_share(input) > MAX_BOUNDARY_SHARE => Err(NoConfidence::BlockContours {
            period_rows: e.period_rows,
            boundary_share: boundary_share(input),
        }),
        Ok(mut e) => {
            e.block_grid_suppressed = true;
            Ok(e)
        }
        // Nothing left: say so when what was there is the grid.
        Err(reason) => match strips::estimate(input, columns) {
            Ok(e) if near_grid(e.period_rows, e.rows) => Err(NoConfidence::BlockGrid {
                period_rows: e.period_rows,
            }),
            _ => Err(reason),
        },
    }
}

/// Whether a period of `period_rows` over `rows` rows lies within
/// [`NEAR_CYCLES`] cycles per frame of a grid frequency `k / 16`, `k >= 1`.
pub(super) fn near_grid(period_rows: f64, rows: usize) -> bool {
    let f = 1.0 / period_rows;
    let k = (f * GRID_ROWS as f64).round();
    k >= 1.0 && (f - k / GRID_ROWS as f64).abs() * rows as f64 <= NEAR_CYCLES
}

/// `profile` less its part of period [`GRID_ROWS`]: for each phase
/// `r mod 16`, the mean over those rows of the profile less its quadratic
/// trend.
pub(super) fn suppress(profile: &[f64]) -> Vec<f64> {
    let detrended = super::detrend(profile);
    let mut sums = [0.0; GRID_ROWS];
    let mut counts = [0usize; GRID_ROWS];
    for (r, v) in detrended.iter().enumerate() {
        sums[r % GRID_ROWS] += v;
        counts[r % GRID_ROWS] += 1;
    }
    profile
        .iter()
        .enumerate()
        .map(|(r, v)| v - sums[r % GRID_ROWS] / counts[r % GRID_ROWS] as f64)
        .collect()
}

/// Share of the squared row-to-row differences of each frame's profile
/// (the median over all strips) that falls between a block's last row and
/// the next block's first.
pub(super) fn boundary_share(input: &StripProfiles) -> f64 {
    let (mut boundary, mut all) = (0.0, 0.0);
    for frame in input {
        let profile = super::combine_strips(frame);
        for (r, w) in profile.windows(2).enumerate() {
            let d2 = (w[1] - w[0]).powi(2);
            all += d2;
            if r % BLOCK_ROWS == BLOCK_ROWS - 1 {
                boundary += d2;
            }
        }
    }
    if all > 0.0 { boundary / all } else { 0.0 }
}
