//! What results.json says of a case's sample frame: the display stretch,
//! the ROIs as drawn, the crop around the LED ROI, the row analysis of the
//! frame shown and the caption that states them (docs/report.md, "Sample
//! frames"). Computed in the analysis stage; the report draws the view
//! from it ([`crate::report::frames::view`]).
//!
//! The stretch maps the frame's 0.5th percentile of luma to black and its
//! 99.5th percentile to white, linearly, clipping the rest: a frame whose
//! values span 24 to 66 DN of 255 fills the grey scale instead of looking
//! black. The row analysis of the frame in its LED ROI's columns
//! ([`frame_banding`], by the banding analysis [`crate::analysis::banding`])
//! gives the banding sentence printed beside it, so the text always
//! describes the frame shown.

use serde::{Deserialize, Serialize};

use super::FrameBanding;
use crate::analysis::banding::NO_BANDS_CONTRAST_PERCENT;
use crate::plan::{Roi, RoiKind};
use crate::trace::RenderedFrame;

/// Percentile of the frame's luma shown black.
pub const STRETCH_LOW_PERCENTILE: f64 = 0.5;
/// Percentile of the frame's luma shown white.
pub const STRETCH_HIGH_PERCENTILE: f64 = 99.5;
/// Magnification of the crop around the LED ROI.
pub const CROP_ZOOM: u32 = 4;
/// Largest crop, source pixels (wide ROIs are cropped around their centre).
const CROP_MAX: (u32, u32) = (120, 80);
/// Smallest crop, source pixels.
const CROP_MIN: u32 = 24;

/// The linear display stretch of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stretch {
    /// Luma shown black: the frame's [`STRETCH_LOW_PERCENTILE`], DN.
    pub low_dn: f64,
    /// Luma shown white: the frame's [`STRETCH_HIGH_PERCENTILE`], DN (at
    /// least `low_dn + 1`).
    pub high_dn: f64,
}

impl Stretch {
    /// The stretch of `luma`: its percentiles (nearest rank) of the finite
    /// values; 0 to 1 DN when there are none.
    pub fn of(luma: &[f64]) -> Stretch {
        Self::of_counts(luma.iter().map(|&v| (v, 1)).collect())
    }

    /// The stretch of a frame's luma: [`Stretch::of`] its pixels.
    pub fn of_frame(frame: &RenderedFrame) -> Stretch {
        Self::of_counts(frame.value_counts())
    }

    /// The stretch of the values `(value, pixels)`: the nearest-rank
    /// percentiles of the finite values, found by sorting the distinct
    /// values (a few thousand for a simulated frame) and counting pixels.
    fn of_counts(mut counts: Vec<(f64, u64)>) -> Stretch {
        counts.retain(|(v, _)| v.is_finite());
        counts.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let total: u64 = counts.iter().map(|c| c.1).sum();
        let nth = |p: f64| {
            let i = rank(total as usize, p)? as u64;
            let mut below = 0;
            counts.iter().find_map(|&(v, n)| {
                below += n;
                (below > i).then_some(v)
            })
        };
        let low_dn = nth(STRETCH_LOW_PERCENTILE).unwrap_or(0.0);
        let high_dn = nth(STRETCH_HIGH_PERCENTILE)
            .unwrap_or(1.0)
            .max(low_dn + 1.0);
        Stretch { low_dn, high_dn }
    }

    /// Display grey of luma `v`, 0..=255.
    pub fn apply(&self, v: f64) -> u8 {
        let u = (v - self.low_dn) / (self.high_dn - self.low_dn);
        if u.is_nan() {
            0
        } else {
            (u * 255.0).round().clamp(0.0, 255.0) as u8
        }
    }

    /// The caption sentence stating the stretch.
    pub fn caption(&self) -> String {
        format!(
            "Display stretch: the frame's {STRETCH_LOW_PERCENTILE}th percentile of luma ({} DN) is shown black and its {STRETCH_HIGH_PERCENTILE}th percentile ({} DN) white, linearly in between; darker and brighter pixels are clipped.",
            crate::util::fixed(self.low_dn, 1),
            crate::util::fixed(self.high_dn, 1)
        )
    }
}

/// Index in sorted order of the nearest-rank percentile `p` (0..=100) of
/// `n` values; `None` when there are none.
fn rank(n: usize, p: f64) -> Option<usize> {
    let rank = ((p / 100.0) * n as f64).ceil() as usize;
    (n > 0).then(|| rank.clamp(1, n) - 1)
}

/// An ROI as drawn on the view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoiBox {
    /// Number written on the view, from 1 in plan order.
    pub number: usize,
    /// ROI name.
    pub name: String,
    /// led or background.
    pub kind: RoiKind,
    /// Left column, top row, width and height, source pixels.
    pub rect_px: [u32; 4],
}

impl RoiBox {
    /// The plan's ROIs, numbered from 1.
    pub fn from_plan(rois: &[Roi]) -> Vec<RoiBox> {
        rois.iter()
            .enumerate()
            .map(|(i, r)| RoiBox {
                number: i + 1,
                name: r.name.clone(),
                kind: r.kind,
                rect_px: [r.x_px, r.y_px, r.width_px, r.height_px],
            })
            .collect()
    }
}

/// The source rectangle `[x, y, w, h]` shown at [`CROP_ZOOM`]x: the first
/// LED ROI (else the first ROI) with a margin of a quarter of its size (at
/// least 8 px), between [`CROP_MIN`] and [`CROP_MAX`] pixels a side,
/// centred on the ROI and inside the frame.
pub fn crop_rect(rois: &[RoiBox], (width, height): (u32, u32)) -> Option<[u32; 4]> {
    let roi = rois
        .iter()
        .find(|r| r.kind == RoiKind::Led)
        .or(rois.first())?;
    let [x, y, w, h] = roi.rect_px;
    let side = |size: u32, max: u32, limit: u32| {
        (size + 2 * (size / 4).max(8))
            .clamp(CROP_MIN, max)
            .min(limit)
    };
    let (cw, ch) = (side(w, CROP_MAX.0, width), side(h, CROP_MAX.1, height));
    if cw == 0 || ch == 0 {
        return None;
    }
    let centre = |start: u32, size: u32, crop: u32, limit: u32| {
        (start + size / 2)
            .saturating_sub(crop / 2)
            .min(limit - crop)
    };
    Some([centre(x, w, cw, width), centre(y, h, ch, height), cw, ch])
}

/// The sentence on the banding of the frame shown.
pub fn banding_sentence(banding: Option<&FrameBanding>) -> String {
    let Some(b) = banding else {
        return "The LED ROI's columns are even in this frame: it shows no bands.".to_string();
    };
    let rows = b.lit_rows.1 - b.lit_rows.0 + 1;
    let contrast = crate::util::fixed(b.row_contrast_percent, 1);
    if b.row_contrast_percent < NO_BANDS_CONTRAST_PERCENT {
        return format!(
            "The {rows} lit rows of the LED in this frame are even (row contrast {contrast} %): it shows no bands."
        );
    }
    match b.band_period_rows {
        Some(p) => format!(
            "The LED in this frame shows bands {} rows apart (row contrast {contrast} % over {rows} lit rows).",
            crate::util::fixed(p, 1)
        ),
        None => format!(
            "The LED rows of this frame vary (row contrast {contrast} % over {rows} lit rows), with fewer than two band periods."
        ),
    }
}

/// Each ROI's number, name and outline colour on a frame, e.g. `1 = led
/// (red)`.
pub fn roi_key(rois: &[RoiBox]) -> Vec<String> {
    rois.iter()
        .map(|r| {
            let colour = match r.kind {
                RoiKind::Led => "red",
                RoiKind::Background => "blue",
            };
            format!("{} = {} ({colour})", r.number, r.name)
        })
        .collect()
}

/// The caption of a view: the stretch, the ROI key, the crop and the
/// banding of the frame shown.
pub fn caption(
    stretch: &Stretch,
    rois: &[RoiBox],
    crop: Option<[u32; 4]>,
    banding: Option<&FrameBanding>,
) -> String {
    let key = roi_key(rois);
    let mut out = stretch.caption();
    if !key.is_empty() {
        out.push_str(&format!(" ROIs: {}.", key.join(", ")));
    }
    if let Some([x, y, w, h]) = crop {
        out.push_str(&format!(
            " Right: the {w} x {h} px around the LED ROI (from column {x}, row {y}; yellow box) at {CROP_ZOOM}x."
        ));
    }
    out.push(' ');
    out.push_str(&banding_sentence(banding));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counted_percentiles_are_the_sorted_pixels_percentiles() {
        let mut rng = ledflicker_physics::sensor::Rng::new(11);
        let mut values: Vec<f64> = (0..3000).map(|_| rng.normal() * 40.0).collect();
        // Duplicates, both zeros, tiny and huge magnitudes, NaN, whole numbers.
        values.extend([
            0.0,
            -0.0,
            0.0,
            1e-300,
            -1e-300,
            1e300,
            -1e300,
            5e-324,
            f64::NAN,
        ]);
        values.extend(std::iter::repeat_n(17.0, 500));
        values.extend((0..200).map(|i| f64::from(i % 7)));
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let at = |p: f64| sorted[rank(sorted.len(), p).unwrap()];
        let s = Stretch::of(&values);
        assert_eq!(s.low_dn.to_bits(), at(STRETCH_LOW_PERCENTILE).to_bits());
        assert_eq!(s.high_dn.to_bits(), at(STRETCH_HIGH_PERCENTILE).to_bits());
        // The same pixels as a frame (runs of repeated values) agree.
        let frame = RenderedFrame::from_pixels(0, 70, 52, &values[..70 * 52], 255.0);
        let mut part: Vec<f64> = values[..70 * 52]
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        part.sort_by(f64::total_cmp);
        let f = Stretch::of_frame(&frame);
        assert_eq!(
            f.low_dn,
            part[rank(part.len(), STRETCH_LOW_PERCENTILE).unwrap()]
        );
        assert_eq!(
            f.high_dn,
            part[rank(part.len(), STRETCH_HIGH_PERCENTILE).unwrap()]
        );
    }
}
