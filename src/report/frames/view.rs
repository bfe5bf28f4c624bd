//! The annotated view of a sample frame: the whole frame with its display
//! stretch and the ROIs drawn and numbered, and a 4x crop around the LED
//! ROI beside it, as one RGB PNG (docs/report.md, "Sample frames"). The
//! stretch, ROI boxes, crop and caption come from the model
//! ([`crate::model::frame`]); this module only draws them.

use image::{Rgb, RgbImage};

use crate::model::frame::{CROP_ZOOM, RoiBox, Stretch, crop_rect};
use crate::model::{RenderedFrame, RoiKind};

/// Width of the whole-frame part of the view, pixels (frames narrower are
/// shown 1:1).
pub const VIEW_WIDTH: u32 = 480;
/// Gap between the frame and the crop, pixels.
const GAP: u32 = 10;

const LED_COLOUR: Rgb<u8> = Rgb([235, 40, 40]);
const BACKGROUND_COLOUR: Rgb<u8> = Rgb([40, 120, 255]);
const CROP_COLOUR: Rgb<u8> = Rgb([255, 200, 0]);

fn colour(roi: &RoiBox) -> Rgb<u8> {
    match roi.kind {
        RoiKind::Led => LED_COLOUR,
        RoiKind::Background => BACKGROUND_COLOUR,
    }
}

/// Draws a rectangle outline `[x, y, w, h]`, `thick` px wide, clipped.
fn outline(img: &mut RgbImage, [x, y, w, h]: [u32; 4], thick: u32, colour: Rgb<u8>) {
    let (iw, ih) = img.dimensions();
    let (x1, y1) = (x + w.max(1), y + h.max(1));
    for py in y.saturating_sub(thick)..(y1 + thick).min(ih) {
        for px in x.saturating_sub(thick)..(x1 + thick).min(iw) {
            let inside = px >= x && px < x1 && py >= y && py < y1;
            if !inside {
                img.put_pixel(px, py, colour);
            }
        }
    }
}

/// 3 x 5 pixel digits, one row of bits per line, most significant left.
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

/// Writes `number` in white digits 2x size on a `colour` box whose top
/// left is at (x, y), clipped to the image.
fn label(img: &mut RgbImage, number: usize, (x, y): (u32, u32), colour: Rgb<u8>) {
    let digits: Vec<usize> = number
        .to_string()
        .bytes()
        .map(|b| (b - b'0') as usize)
        .collect();
    let (bw, bh) = (2 + 8 * digits.len() as u32, 14);
    let (iw, ih) = img.dimensions();
    for py in y..(y + bh).min(ih) {
        for px in x..(x + bw).min(iw) {
            img.put_pixel(px, py, colour);
        }
    }
    for (k, &d) in digits.iter().enumerate() {
        for (r, bits) in DIGITS[d].iter().enumerate() {
            for c in 0..3 {
                if bits >> (2 - c) & 1 == 1 {
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let px = x + 2 + 8 * k as u32 + 2 * c + dx;
                        let py = y + 2 + 2 * r as u32 + dy;
                        if px < iw && py < ih {
                            img.put_pixel(px, py, Rgb([255, 255, 255]));
                        }
                    }
                }
            }
        }
    }
}

/// Stretched grey of the source box `[x0, x1) x [y0, y1)`, its mean.
fn box_grey(
    frame: &RenderedFrame,
    stretch: &Stretch,
    (x0, x1): (u32, u32),
    (y0, y1): (u32, u32),
) -> u8 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in y0..y1.max(y0 + 1) {
        frame.for_each_in_row(y, (x0, x1.max(x0 + 1)), |_, v| {
            sum += v;
            n += 1.0;
        });
    }
    stretch.apply(if n > 0.0 { sum / n } else { f64::NAN })
}

/// The view of `frame`: the whole frame (box-averaged down to
/// [`VIEW_WIDTH`] wide) with the display stretch, every ROI outlined in
/// its colour (LED red, background blue) and numbered, the crop area
/// outlined in yellow; right of it the crop at [`CROP_ZOOM`]x, nearest
/// neighbour, with the ROIs outlined. Returns the image and the stretch.
pub fn sample_view(frame: &RenderedFrame, rois: &[RoiBox]) -> (RgbImage, Stretch) {
    let stretch = Stretch::of_frame(frame);
    (stretched_view(frame, rois, &stretch), stretch)
}

/// [`sample_view`] with the frame's stretch already known (the model's).
pub fn stretched_view(frame: &RenderedFrame, rois: &[RoiBox], stretch: &Stretch) -> RgbImage {
    let (fw, fh) = (frame.width.max(1), frame.height.max(1));
    let vw = fw.min(VIEW_WIDTH);
    let vh = ((u64::from(fh) * u64::from(vw)) / u64::from(fw)).max(1) as u32;
    let to_view =
        |v: u32, full: u32, view: u32| (u64::from(v) * u64::from(view) / u64::from(full)) as u32;
    let crop = crop_rect(rois, (fw, fh));
    let (cw, ch) = crop.map_or((0, 0), |c| (c[2] * CROP_ZOOM, c[3] * CROP_ZOOM));
    let width = vw + if crop.is_some() { GAP + cw } else { 0 };
    let mut img = RgbImage::from_pixel(width, vh.max(ch), Rgb([255, 255, 255]));
    for y in 0..vh {
        let (y0, y1) = (to_view(y, vh, fh), to_view(y + 1, vh, fh));
        // The source rows of this view row, each expanded once.
        let rows: Vec<Vec<f64>> = (y0..y1.max(y0 + 1))
            .filter(|&r| r < frame.height)
            .map(|r| frame.row(r))
            .collect();
        for x in 0..vw {
            let (x0, x1) = (to_view(x, vw, fw), to_view(x + 1, vw, fw));
            let cols = x0 as usize..(x1.max(x0 + 1).min(frame.width) as usize).max(x0 as usize);
            // Row by row, left to right: the sum box_grey takes.
            let (mut sum, mut n) = (0.0, 0.0);
            for row in &rows {
                for &v in &row[cols.clone()] {
                    sum += v;
                    n += 1.0;
                }
            }
            let g = stretch.apply(if n > 0.0 { sum / n } else { f64::NAN });
            img.put_pixel(x, y, Rgb([g, g, g]));
        }
    }
    let scale_rect = |[x, y, w, h]: [u32; 4]| {
        [
            to_view(x, fw, vw),
            to_view(y, fh, vh),
            to_view(w, fw, vw).max(1),
            to_view(h, fh, vh).max(1),
        ]
    };
    if let Some(c) = crop {
        outline(&mut img, scale_rect(c), 1, CROP_COLOUR);
        let left = vw + GAP;
        for y in 0..ch {
            for x in 0..cw {
                let (sx, sy) = (c[0] + x / CROP_ZOOM, c[1] + y / CROP_ZOOM);
                let g = box_grey(frame, stretch, (sx, sx + 1), (sy, sy + 1));
                img.put_pixel(left + x, y, Rgb([g, g, g]));
            }
        }
        for roi in rois {
            let [x, y, w, h] = roi.rect_px;
            // The part of the ROI inside the crop, in crop pixels.
            let (ax, ay) = (x.max(c[0]), y.max(c[1]));
            let (bx, by) = ((x + w).min(c[0] + c[2]), (y + h).min(c[1] + c[3]));
            if bx > ax && by > ay {
                let r = [
                    left + (ax - c[0]) * CROP_ZOOM,
                    (ay - c[1]) * CROP_ZOOM,
                    (bx - ax) * CROP_ZOOM,
                    (by - ay) * CROP_ZOOM,
                ];
                outline(&mut img, r, 2, colour(roi));
                label(&mut img, roi.number, (r[0], r[1] + r[3] + 3), colour(roi));
            }
        }
        outline(&mut img, [left, 0, cw, ch], 1, CROP_COLOUR);
    }
    for roi in rois {
        let r = scale_rect(roi.rect_px);
        outline(&mut img, r, 2, colour(roi));
        // Number above the box, or below it at the top edge.
        let ly = if r[1] >= 18 {
            r[1] - 17
        } else {
            r[1] + r[3] + 3
        };
        label(&mut img, roi.number, (r[0], ly), colour(roi));
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::frame::*;

    fn frame(width: u32, height: u32, f: impl Fn(u32, u32) -> f64) -> RenderedFrame {
        let luma: Vec<f64> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        RenderedFrame::from_pixels(7, width, height, &luma, 255.0)
    }

    fn led(rect_px: [u32; 4]) -> RoiBox {
        RoiBox {
            number: 1,
            name: "led".into(),
            kind: RoiKind::Led,
            rect_px,
        }
    }

    #[test]
    fn stretch_maps_the_percentiles_to_black_and_white() {
        // 0, 1, ..., 999 DN: nearest-rank 0.5th percentile is the 5th
        // value (4 DN), the 99.5th the 995th (994 DN).
        let luma: Vec<f64> = (0..1000).rev().map(f64::from).collect();
        let s = Stretch::of(&luma);
        assert_eq!((s.low_dn, s.high_dn), (4.0, 994.0));
        assert_eq!(s.apply(4.0), 0);
        assert_eq!(s.apply(994.0), 255);
        assert_eq!(s.apply(0.0), 0);
        assert_eq!(s.apply(999.0), 255);
        assert_eq!(s.apply(499.0), 128);
        // At most 0.5 % of the pixels are clipped at each end.
        let black = luma.iter().filter(|&&v| v < s.low_dn).count();
        let white = luma.iter().filter(|&&v| v > s.high_dn).count();
        assert!(black <= 5 && white <= 5, "{black} {white}");
        // Unordered values: the selection gives what a full sort gives.
        let mixed: Vec<f64> = (0..997u64)
            .map(|i| ((i * 7919) % 997) as f64 * 0.5)
            .collect();
        let mut sorted = mixed.clone();
        sorted.sort_by(f64::total_cmp);
        let s = Stretch::of(&mixed);
        assert_eq!((s.low_dn, s.high_dn), (sorted[4], sorted[992]));
        // A flat frame gets a 1 DN span, never a division by zero.
        let flat = Stretch::of(&[31.0; 16]);
        assert_eq!((flat.low_dn, flat.high_dn), (31.0, 32.0));
        assert!(
            flat.caption()
                .contains("0.5th percentile of luma (31.0 DN)")
        );
    }

    #[test]
    fn a_dark_frame_fills_the_grey_scale() {
        // As the issue saw: 24 to 31 DN of 255.
        let f = frame(64, 32, |x, _| 24.0 + f64::from(x % 8));
        let (img, s) = sample_view(&f, &[]);
        assert_eq!((s.low_dn, s.high_dn), (24.0, 31.0));
        let greys: Vec<u8> = img.pixels().map(|p| p.0[0]).collect();
        assert_eq!(greys.iter().min(), Some(&0));
        assert_eq!(greys.iter().max(), Some(&255));
    }

    #[test]
    fn roi_outlines_are_drawn_just_outside_the_roi() {
        let f = frame(200, 100, |_, _| 50.0);
        let roi = led([50, 40, 20, 10]);
        let (img, _) = sample_view(&f, std::slice::from_ref(&roi));
        // 200 px wide: shown 1:1. The outline is 2 px outside the ROI.
        for (x, y) in [
            (48, 45),
            (49, 45),
            (70, 45),
            (71, 45),
            (60, 38),
            (60, 39),
            (60, 50),
            (60, 51),
        ] {
            assert_eq!(*img.get_pixel(x, y), LED_COLOUR, "({x}, {y})");
        }
        // Inside the ROI and 3 px away: the frame itself (flat: black).
        for (x, y) in [
            (50, 40),
            (69, 49),
            (60, 45),
            (47, 45),
            (72, 45),
            (60, 37),
            (60, 52),
        ] {
            assert_ne!(*img.get_pixel(x, y), LED_COLOUR, "({x}, {y})");
        }
        // The crop: 20 + 2 x 8 = 36 x 26 px around the ROI, at 4x right of
        // the frame; the ROI starts 8 px into it.
        let crop = crop_rect(&[roi], (200, 100)).unwrap();
        assert_eq!(crop, [42, 32, 36, 26]);
        assert_eq!(
            img.dimensions(),
            (200 + GAP + 36 * CROP_ZOOM, 100.max(26 * CROP_ZOOM))
        );
        let left = 200 + GAP;
        assert_eq!(
            *img.get_pixel(left + 8 * CROP_ZOOM - 1, 8 * CROP_ZOOM + 4),
            LED_COLOUR
        );
        assert_ne!(
            *img.get_pixel(left + 8 * CROP_ZOOM, 8 * CROP_ZOOM + 4),
            LED_COLOUR
        );
    }

    #[test]
    fn a_wide_frame_is_scaled_to_the_view_width() {
        let f = frame(1280, 800, |_, _| 10.0);
        let roi = led([590, 399, 100, 2]);
        let (img, _) = sample_view(&f, std::slice::from_ref(&roi));
        // 590 * 480 / 1280 = 221.25 -> column 221; the outline at 219, 220.
        let y = 399 * 300 / 800;
        assert_eq!(*img.get_pixel(220, y), LED_COLOUR);
        assert_ne!(*img.get_pixel(221, y), LED_COLOUR);
        assert_eq!(img.width(), 480 + GAP + 120 * CROP_ZOOM);
    }

    #[test]
    fn banding_follows_the_frame_shown() {
        // An LED panel in rows 20..180 with bands every 25 rows, over a
        // flat background.
        let banded = frame(100, 200, |x, y| {
            let lit = (20..180).contains(&y) && (30..70).contains(&x);
            let band = 1.0 + (2.0 * std::f64::consts::PI * f64::from(y) / 25.0).sin();
            if lit { 30.0 + 20.0 * band } else { 24.0 }
        });
        let rois = [led([40, 100, 20, 2])];
        let b = frame_banding(&banded, &rois).unwrap();
        assert_eq!(b.lit_rows.0, 20);
        let p = b.band_period_rows.unwrap();
        assert!((p - 25.0).abs() < 0.5, "{p}");
        let text = banding_sentence(Some(&b));
        assert!(text.contains("shows bands 25.0 rows apart"), "{text}");
        // An even panel: no bands, and the sentence says so.
        let even = frame(100, 200, |x, y| {
            if (20..180).contains(&y) && (30..70).contains(&x) {
                60.0
            } else {
                24.0
            }
        });
        let b = frame_banding(&even, &rois).unwrap();
        assert!(b.row_contrast_percent < NO_BANDS_CONTRAST_PERCENT);
        assert_eq!(b.band_period_rows, None);
        assert!(banding_sentence(Some(&b)).contains("no bands"));
        let flat = frame(100, 200, |_, _| 24.0);
        assert_eq!(frame_banding(&flat, &rois), None);
        assert!(banding_sentence(None).contains("no bands"));
        assert!(
            !caption(
                &Stretch::of_frame(&banded),
                &rois,
                None,
                frame_banding(&banded, &rois).as_ref()
            )
            .contains("no bands")
        );
    }
}
