//! The annotated view of a sample frame: the whole frame with its display
//! stretch and the ROIs drawn and numbered, and a 4x crop around the LED
//! ROI beside it, as one RGB PNG (docs/report.md, "Sample frames"). The
//! stretch, ROI boxes, crop and caption come from the model
//! ([`crate::model::frame`]); this module only draws them.

use image::{Rgb, RgbImage};

use crate::model::frame::{CROP_ZOOM, RoiBox, Stretch, crop_rect};
use crate::model::{RenderedFrame, RoiKind, Run};

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
    let (left, right) = (x.saturating_sub(thick), (x1 + thick).min(iw));
    for py in y.saturating_sub(thick)..(y1 + thick).min(ih) {
        // Rows beside the box are drawn across; rows through it only left
        // and right of it: the interior is never visited.
        let through = py >= y && py < y1;
        let spans = if through {
            [(left, x.min(right)), (x1.max(left), right)]
        } else {
            [(left, right), (right, right)]
        };
        for (from, to) in spans {
            for px in from..to {
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

/// Reads one source row left to right, run by run: the value of any
/// column at or right of the last one asked, in amortised constant time.
struct RowCursor<'a> {
    runs: std::slice::Iter<'a, Run>,
    /// End (exclusive) of the current run; 0 before the first.
    end: u32,
    /// Value of the current run (NaN past the row's runs).
    value: f64,
}

impl<'a> RowCursor<'a> {
    fn new(frame: &'a RenderedFrame, y: u32) -> Self {
        Self {
            runs: frame.runs(y).iter(),
            end: 0,
            value: f64::NAN,
        }
    }

    /// The value of column `x` (never left of an earlier `x`) and the end
    /// of its run; past the row's runs, NaN to the end of the row.
    #[inline]
    fn at(&mut self, x: u32) -> (f64, u32) {
        while x >= self.end {
            match self.runs.next() {
                Some(r) => {
                    self.end = self.end.saturating_add(r.len);
                    self.value = r.value;
                }
                None => {
                    self.end = u32::MAX;
                    self.value = f64::NAN;
                }
            }
        }
        (self.value, self.end)
    }
}

/// Fills pixels `x0..x0 + greys.len()` of image row `y` with the greys.
fn put_greys(img: &mut RgbImage, y: u32, x0: u32, greys: &[u8]) {
    let width = img.width() as usize;
    let start = (y as usize * width + x0 as usize) * 3;
    let buf: &mut [u8] = img;
    let row = &mut buf[start..start + greys.len() * 3];
    for (px, &g) in row.chunks_exact_mut(3).zip(greys) {
        px.copy_from_slice(&[g, g, g]);
    }
}

/// Copies pixels `x0..x0 + len` of image row `from` to row `to`.
fn copy_row_part(img: &mut RgbImage, from: u32, to: u32, x0: u32, len: u32) {
    let width = img.width() as usize;
    let at = |y: u32| (y as usize * width + x0 as usize) * 3;
    let src = at(from);
    img.copy_within(src..src + len as usize * 3, at(to));
}

/// The greys of one view row: the box means of the source rows `rows` over
/// the column boxes `cols` (one per view pixel), each summed row by row,
/// left to right, from 0.0, then stretched.
///
/// Where every source row is one run across a box, the box's sum is the
/// same sequence of additions as that of the last such box of the same
/// width inside the same runs, so its grey is reused instead of summed and
/// rounded again: bit for bit what the per-pixel sum gives.
fn view_row_greys(
    frame: &RenderedFrame,
    stretch: &Stretch,
    rows: &[u32],
    cols: &[(u32, u32)],
    out: &mut Vec<u8>,
) {
    let mut cursors: Vec<RowCursor> = rows.iter().map(|&r| RowCursor::new(frame, r)).collect();
    out.clear();
    // Every cursor's run covers the columns from where they were last
    // placed up to `segment_end`; the memo holds the greys of boxes of each
    // width inside that segment.
    let mut segment_end = 0;
    let mut memo: Vec<(u32, u8)> = Vec::new();
    for &(x0, x1) in cols {
        if x0 >= segment_end {
            segment_end = cursors
                .iter_mut()
                .map(|c| c.at(x0).1)
                .min()
                .unwrap_or(u32::MAX);
            memo.clear();
        }
        let uniform = x1 <= segment_end;
        if uniform && let Some(&(_, g)) = memo.iter().find(|m| m.0 == x1 - x0) {
            out.push(g);
            continue;
        }
        let (mut sum, mut n) = (0.0, 0.0);
        for c in &mut cursors {
            for x in x0..x1 {
                sum += c.at(x).0;
                n += 1.0;
            }
        }
        let g = stretch.apply(if n > 0.0 { sum / n } else { f64::NAN });
        if uniform {
            memo.push((x1 - x0, g));
        } else {
            // The cursors moved on: place them again at the next box.
            segment_end = 0;
        }
        out.push(g);
    }
}

/// Draws the whole frame, box-averaged to `vw` x `vh`, at the top left.
/// A view row whose source rows hold the same runs as the previous view
/// row's is a copy of it.
fn draw_frame(img: &mut RgbImage, frame: &RenderedFrame, stretch: &Stretch, (vw, vh): (u32, u32)) {
    let (fw, fh) = (frame.width.max(1), frame.height.max(1));
    let to_view =
        |v: u32, full: u32, view: u32| (u64::from(v) * u64::from(view) / u64::from(full)) as u32;
    let cols: Vec<(u32, u32)> = (0..vw)
        .map(|x| {
            let (x0, x1) = (to_view(x, vw, fw), to_view(x + 1, vw, fw));
            (x0, x1.max(x0 + 1).min(frame.width).max(x0))
        })
        .collect();
    let mut greys = Vec::with_capacity(vw as usize);
    let mut last: Vec<u32> = Vec::new();
    for y in 0..vh {
        let (y0, y1) = (to_view(y, vh, fh), to_view(y + 1, vh, fh));
        let rows: Vec<u32> = (y0..y1.max(y0 + 1)).filter(|&r| r < frame.height).collect();
        let same = y > 0
            && rows.len() == last.len()
            && rows.iter().zip(&last).all(|(&a, &b)| frame.same_runs(a, b));
        if same {
            copy_row_part(img, y - 1, y, 0, vw);
        } else {
            view_row_greys(frame, stretch, &rows, &cols, &mut greys);
            put_greys(img, y, 0, &greys);
        }
        last = rows;
    }
}

/// Draws the crop `c` (source pixels) at [`CROP_ZOOM`]x, nearest
/// neighbour, with its left edge at image column `left`. Each source pixel
/// is shown as its own one-pixel box mean, `(0.0 + v) / 1.0`, stretched;
/// pixels outside the frame are black.
fn draw_crop(img: &mut RgbImage, frame: &RenderedFrame, stretch: &Stretch, c: [u32; 4], left: u32) {
    let mut greys = Vec::with_capacity((c[2] * CROP_ZOOM) as usize);
    for sy in c[1]..c[1] + c[3] {
        let mut cursor = RowCursor::new(frame, sy);
        let in_frame = sy < frame.height;
        // The grey of the current run and the run's end: computed once
        // per run.
        let mut memo: Option<(u32, u8)> = None;
        greys.clear();
        for sx in c[0]..c[0] + c[2] {
            let g = if in_frame && sx < frame.width {
                match memo {
                    Some((end, g)) if sx < end => g,
                    _ => {
                        let (v, end) = cursor.at(sx);
                        let g = stretch.apply((0.0 + v) / 1.0);
                        memo = Some((end, g));
                        g
                    }
                }
            } else {
                stretch.apply(f64::NAN)
            };
            greys.extend([g; CROP_ZOOM as usize]);
        }
        let top = (sy - c[1]) * CROP_ZOOM;
        put_greys(img, top, left, &greys);
        for dy in 1..CROP_ZOOM {
            copy_row_part(img, top, top + dy, left, greys.len() as u32);
        }
    }
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

/// The whole frame with `stretch`, box-averaged to at most `max_width`
/// pixels wide, without annotations (the ROI map draws its own).
pub fn stretched_frame(frame: &RenderedFrame, stretch: &Stretch, max_width: u32) -> RgbImage {
    let (fw, fh) = (frame.width.max(1), frame.height.max(1));
    let vw = fw.min(max_width.max(1));
    let vh = ((u64::from(fh) * u64::from(vw)) / u64::from(fw)).max(1) as u32;
    let mut img = RgbImage::from_pixel(vw, vh, Rgb([255, 255, 255]));
    draw_frame(&mut img, frame, stretch, (vw, vh));
    img
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
    draw_frame(&mut img, frame, stretch, (vw, vh));
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
        draw_crop(&mut img, frame, stretch, c, left);
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
    use ledflicker_core::model::frame::frame_banding;
    use ledflicker_results::analysis::banding::NO_BANDS_CONTRAST_PERCENT;

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
    fn outline_draws_exactly_the_band_around_the_box() {
        // Every pixel within `thick` of the box and outside it, clipped to
        // the image, as first written: the whole area visited.
        let by_area = |img: &mut RgbImage, [x, y, w, h]: [u32; 4], thick: u32, c: Rgb<u8>| {
            let (iw, ih) = img.dimensions();
            let (x1, y1) = (x + w.max(1), y + h.max(1));
            for py in y.saturating_sub(thick)..(y1 + thick).min(ih) {
                for px in x.saturating_sub(thick)..(x1 + thick).min(iw) {
                    if !(px >= x && px < x1 && py >= y && py < y1) {
                        img.put_pixel(px, py, c);
                    }
                }
            }
        };
        let red = Rgb([200, 0, 0]);
        for rect in [
            [5, 6, 10, 4],
            [0, 0, 3, 3],
            [1, 1, 0, 0],
            [30, 15, 10, 10],
            [38, 18, 9, 9],
            [0, 10, 40, 2],
            [45, 25, 5, 5],
        ] {
            for thick in [1, 2, 3] {
                let mut fast = RgbImage::from_pixel(40, 20, Rgb([255, 255, 255]));
                let mut slow = fast.clone();
                outline(&mut fast, rect, thick, red);
                by_area(&mut slow, rect, thick, red);
                assert_eq!(fast, slow, "rect {rect:?}, thick {thick}");
            }
        }
    }

    /// The view's frame and crop pixels as first written: every source row
    /// expanded, every box summed pixel by pixel, every crop pixel looked
    /// up on its own. The run-wise drawing must give the same image.
    fn reference_pixels(frame: &RenderedFrame, rois: &[RoiBox], stretch: &Stretch) -> RgbImage {
        let (fw, fh) = (frame.width.max(1), frame.height.max(1));
        let vw = fw.min(VIEW_WIDTH);
        let vh = ((u64::from(fh) * u64::from(vw)) / u64::from(fw)).max(1) as u32;
        let to_view = |v: u32, full: u32, view: u32| {
            (u64::from(v) * u64::from(view) / u64::from(full)) as u32
        };
        let crop = crop_rect(rois, (fw, fh));
        let (cw, ch) = crop.map_or((0, 0), |c| (c[2] * CROP_ZOOM, c[3] * CROP_ZOOM));
        let width = vw + if crop.is_some() { GAP + cw } else { 0 };
        let mut img = RgbImage::from_pixel(width, vh.max(ch), Rgb([255, 255, 255]));
        for y in 0..vh {
            let (y0, y1) = (to_view(y, vh, fh), to_view(y + 1, vh, fh));
            let rows: Vec<Vec<f64>> = (y0..y1.max(y0 + 1))
                .filter(|&r| r < frame.height)
                .map(|r| frame.row(r))
                .collect();
            for x in 0..vw {
                let (x0, x1) = (to_view(x, vw, fw), to_view(x + 1, vw, fw));
                let cols = x0 as usize..(x1.max(x0 + 1).min(frame.width) as usize).max(x0 as usize);
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
        if let Some(c) = crop {
            for y in 0..ch {
                for x in 0..cw {
                    let (sx, sy) = (c[0] + x / CROP_ZOOM, c[1] + y / CROP_ZOOM);
                    let (mut sum, mut n) = (0.0, 0.0);
                    frame.for_each_in_row(sy, (sx, sx + 1), |_, v| {
                        sum += v;
                        n += 1.0;
                    });
                    let g = stretch.apply(if n > 0.0 { sum / n } else { f64::NAN });
                    img.put_pixel(vw + GAP + x, y, Rgb([g, g, g]));
                }
            }
        }
        img
    }

    /// The view with its annotations left out: [`stretched_view`] drawn
    /// with no ROIs and the crop `c` (if any) pasted from a view with ROIs.
    fn view_pixels(frame: &RenderedFrame, rois: &[RoiBox], stretch: &Stretch) -> RgbImage {
        let (fw, fh) = (frame.width.max(1), frame.height.max(1));
        let vw = fw.min(VIEW_WIDTH);
        let vh = ((u64::from(fh) * u64::from(vw)) / u64::from(fw)).max(1) as u32;
        let crop = crop_rect(rois, (fw, fh));
        let (cw, ch) = crop.map_or((0, 0), |c| (c[2] * CROP_ZOOM, c[3] * CROP_ZOOM));
        let width = vw + if crop.is_some() { GAP + cw } else { 0 };
        let mut img = RgbImage::from_pixel(width, vh.max(ch), Rgb([255, 255, 255]));
        draw_frame(&mut img, frame, stretch, (vw, vh));
        if let Some(c) = crop {
            draw_crop(&mut img, frame, stretch, c, vw + GAP);
        }
        img
    }

    #[test]
    fn run_wise_drawing_equals_the_pixel_by_pixel_view() {
        let mut seed = 12345u64;
        let mut noise = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as f64 / 2f64.powi(31)
        };
        let mut frames = Vec::new();
        // Smooth, noisy (a run per pixel), banded rows, and rows of runs
        // like the simulator's, with short rows (NaN tails) and a NaN run.
        for &(w, h) in &[(1280, 800), (200, 100), (481, 37), (1000, 3), (7, 900)] {
            let noisy: Vec<f64> = (0..w * h).map(|_| (noise() * 60.0).round()).collect();
            frames.push(RenderedFrame::from_pixels(1, w, h, &noisy, 255.0));
            frames.push(frame(w, h, |x, y| {
                let lamp = (w / 3..w / 2).contains(&x) && (h / 4..h / 2).contains(&y);
                let band = (f64::from(y) * 0.37).sin();
                if lamp {
                    100.0 + 50.0 * band
                } else {
                    24.0 + 0.1 * f64::from(x % 5)
                }
            }));
            let rows: Vec<Vec<Run>> = (0..h)
                .map(|y| {
                    let lamp = 100.0 + (f64::from(y / 3) * 0.91).cos() * 40.0;
                    let mut runs = vec![
                        Run {
                            len: w / 3,
                            value: 24.0,
                        },
                        Run {
                            len: w / 4 + y % 3,
                            value: lamp,
                        },
                        Run { len: 0, value: 5.0 },
                    ];
                    if y % 17 == 5 {
                        runs.push(Run {
                            len: 2,
                            value: f64::NAN,
                        });
                    }
                    if y % 29 != 3 {
                        runs.push(Run {
                            len: w,
                            value: 24.0,
                        });
                    }
                    runs
                })
                .collect();
            frames.push(RenderedFrame::from_runs(2, w, 255.0, rows));
        }
        frames.push(RenderedFrame::from_runs(3, 0, 255.0, Vec::new()));
        for f in &frames {
            let (w, h) = (f.width, f.height);
            let roi_sets = [
                vec![],
                vec![led([w / 2, h / 2, (w / 10).max(1), 2.min(h.max(1))])],
                // An ROI reaching past the frame's right and bottom edges.
                vec![led([w.saturating_sub(3), h.saturating_sub(1), 40, 30])],
            ];
            for rois in &roi_sets {
                let stretch = Stretch::of_frame(f);
                let want = reference_pixels(f, rois, &stretch);
                let got = view_pixels(f, rois, &stretch);
                assert_eq!(got.dimensions(), want.dimensions(), "{w} x {h} {rois:?}");
                assert!(got == want, "{w} x {h} {rois:?}: pixels differ");
            }
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
