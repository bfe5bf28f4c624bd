//! Draws ROIs on a frame at full resolution: each outlined just outside
//! its pixels (so the pixels measured stay visible) and named in a small
//! bitmap font on a box of its colour.

use image::{Rgb, RgbImage};

use super::{Overlay, Picture};
use ledflicker_acquisition::capture::RoiRect;
use ledflicker_plan::plan::RoiKind;

const LED_COLOUR: Rgb<u8> = Rgb([235, 40, 40]);
const BACKGROUND_COLOUR: Rgb<u8> = Rgb([40, 120, 255]);
const REGION_COLOUR: Rgb<u8> = Rgb([255, 200, 0]);
/// Outline width, px.
const LINE: u32 = 2;
/// Font pixels per glyph pixel.
const SCALE: u32 = 2;
/// Glyph cell: 3 x 5 glyph pixels plus one of spacing.
const CELL: u32 = 4 * SCALE;
/// Label box height, px.
const LABEL_H: u32 = 5 * SCALE + 4;

/// `picture` in grey, stretched so that its 99.5th percentile is white,
/// with each of `regions` outlined thinly in yellow and each overlay
/// outlined (red: LED, blue: background) and named.
pub fn annotate(picture: &Picture, overlays: &[Overlay], regions: &[RoiRect]) -> RgbImage {
    let (w, h) = (picture.width, picture.height);
    let white = white_level(picture);
    let mut img = RgbImage::from_fn(w, h, |x, y| {
        let v = picture.luma[y as usize * w as usize + x as usize];
        let g = (f64::from(v) * 255.0 / white).round().clamp(0.0, 255.0) as u8;
        Rgb([g, g, g])
    });
    for r in regions {
        outline(&mut img, *r, 1, REGION_COLOUR);
    }
    for o in overlays {
        let colour = match o.kind {
            RoiKind::Led => LED_COLOUR,
            RoiKind::Background => BACKGROUND_COLOUR,
        };
        outline(&mut img, o.rect, LINE, colour);
    }
    // Names after every outline, so that no outline crosses a name.
    for o in overlays {
        let colour = match o.kind {
            RoiKind::Led => LED_COLOUR,
            RoiKind::Background => BACKGROUND_COLOUR,
        };
        let r = o.rect;
        let above = r.y > LINE + LABEL_H;
        let y = if above {
            r.y - LINE - LABEL_H - 1
        } else {
            r.y + r.height + LINE + 1
        };
        label(&mut img, &o.name, (r.x.saturating_sub(LINE), y), colour);
    }
    img
}

/// The luma drawn white: the 99.5th percentile of the picture (of every
/// 7th pixel), or full scale when that is 0.
fn white_level(p: &Picture) -> f64 {
    let mut s: Vec<f32> = p.luma.iter().step_by(7).copied().collect();
    if s.is_empty() {
        return p.full_scale_dn.max(1.0);
    }
    let k = ((s.len() - 1) as f64 * 0.995).round() as usize;
    let (_, v, _) = s.select_nth_unstable_by(k, f32::total_cmp);
    let v = f64::from(*v);
    if v > 0.0 { v } else { p.full_scale_dn.max(1.0) }
}

/// Outlines `r` with a band `thick` px wide just outside it, clipped.
fn outline(img: &mut RgbImage, r: RoiRect, thick: u32, colour: Rgb<u8>) {
    let (iw, ih) = img.dimensions();
    let (x0, y0) = (r.x.saturating_sub(thick), r.y.saturating_sub(thick));
    let (x1, y1) = (
        (r.x + r.width + thick).min(iw),
        (r.y + r.height + thick).min(ih),
    );
    for y in y0..y1 {
        for x in x0..x1 {
            let inside = x >= r.x && x < r.x + r.width && y >= r.y && y < r.y + r.height;
            if !inside {
                img.put_pixel(x, y, colour);
            }
        }
    }
}

/// Writes `text` in white on a `colour` box whose top left is `(x, y)`,
/// clipped to the image.
fn label(img: &mut RgbImage, text: &str, (x, y): (u32, u32), colour: Rgb<u8>) {
    let (iw, ih) = img.dimensions();
    let n = text.chars().count() as u32;
    let bw = 2 + CELL * n;
    for py in y..(y + LABEL_H).min(ih) {
        for px in x..(x + bw).min(iw) {
            img.put_pixel(px, py, colour);
        }
    }
    for (k, c) in text.chars().enumerate() {
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..3u32 {
                if bits >> (2 - col) & 1 == 0 {
                    continue;
                }
                for d in 0..SCALE * SCALE {
                    let px = x + 2 + CELL * k as u32 + SCALE * col + d % SCALE;
                    let py = y + 2 + SCALE * row as u32 + d / SCALE;
                    if px < iw && py < ih {
                        img.put_pixel(px, py, Rgb([255, 255, 255]));
                    }
                }
            }
        }
    }
}

/// A 3 x 5 glyph, one row per entry, most significant of 3 bits left.
/// Letters of either case share the capital's shape (ROI names are
/// letters, digits, `-` and `_`); anything else draws a filled box.
fn glyph(c: char) -> [u8; 5] {
    match c.to_ascii_uppercase() {
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [3, 4, 4, 4, 3],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [3, 4, 5, 5, 3],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 2],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'Q' => [2, 5, 5, 6, 3],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [6, 1, 2, 4, 7],
        '3' => [6, 1, 2, 1, 6],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 6, 1, 6],
        '6' => [3, 4, 7, 5, 7],
        '7' => [7, 1, 2, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 6],
        '-' => [0, 0, 7, 0, 0],
        '_' => [0, 0, 0, 0, 7],
        '.' => [0, 0, 0, 0, 2],
        ' ' => [0, 0, 0, 0, 0],
        _ => [7, 7, 7, 7, 7],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: u32, h: u32, v: f32) -> Picture {
        Picture {
            frame: 0,
            width: w,
            height: h,
            full_scale_dn: 255.0,
            luma: vec![v; (w * h) as usize],
        }
    }

    #[test]
    fn outline_leaves_the_roi_pixels_and_draws_the_band_around_them() {
        let pic = flat(40, 40, 100.0);
        let roi = Overlay {
            name: "a".into(),
            kind: RoiKind::Led,
            rect: RoiRect {
                x: 10,
                y: 20,
                width: 12,
                height: 2,
            },
        };
        let img = annotate(&pic, &[roi], &[]);
        // The ROI's own pixels keep the picture's grey (white: 100 is the
        // 99.5th percentile).
        for x in 10..22 {
            for y in 20..22 {
                assert_eq!(img.get_pixel(x, y), &Rgb([255, 255, 255]));
            }
        }
        // The band just outside is red on every side; beyond it, grey.
        for (x, y) in [(9, 20), (22, 21), (10, 19), (21, 22), (8, 18), (23, 23)] {
            assert_eq!(img.get_pixel(x, y), &LED_COLOUR, "({x}, {y})");
        }
        for (x, y) in [(7, 20), (24, 21), (15, 24)] {
            assert_eq!(img.get_pixel(x, y), &Rgb([255, 255, 255]), "({x}, {y})");
        }
        // The name sits on a red box above the outline.
        assert_eq!(img.get_pixel(8, 18 - LABEL_H), &LED_COLOUR);
    }

    #[test]
    fn every_name_character_has_a_glyph_of_its_own() {
        let chars: Vec<char> = ('a'..='z').chain('0'..='9').chain(['-', '_']).collect();
        for (i, a) in chars.iter().enumerate() {
            assert_ne!(glyph(*a), glyph('#'), "{a} draws the unknown box");
            for b in &chars[i + 1..] {
                assert_ne!(glyph(*a), glyph(*b), "{a} and {b} look the same");
            }
        }
    }
}
