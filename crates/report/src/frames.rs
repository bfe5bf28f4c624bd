//! Sample frames as PNG: full-size files next to the report, and the
//! annotated views (display stretch, ROIs, 4x crop; [`view`]) that the HTML
//! and PDF show.

use image::{DynamicImage, ExtendedColorType, ImageBuffer, Luma};
use ledflicker_plan::image_io::{encode_png, png_bytes as encode_png_image};

use super::ReportError;
use crate::model::RenderedFrame;
use crate::model::frame::{RoiBox, Stretch};

pub mod view;

pub use crate::model::view_path;

/// The annotated view of a frame ([`view::sample_view`]) with the
/// model's display stretch, as an RGB PNG.
pub fn view_png(
    frame: &RenderedFrame,
    rois: &[RoiBox],
    stretch: &Stretch,
) -> Result<Vec<u8>, ReportError> {
    let img = view::stretched_view(frame, rois, stretch);
    let (w, h) = img.dimensions();
    encode_png(img.as_raw(), w, h, ExtendedColorType::Rgb8).map_err(image_err)
}

/// Each worst-phase frame of the model (full size) and its annotated view
/// from `views` (which the document names by the frame's path), as file
/// names in frames/.
pub fn worst_phase_files(
    model: &crate::model::Results,
    views: &std::collections::BTreeMap<String, Vec<u8>>,
) -> Result<Vec<(String, Vec<u8>)>, ReportError> {
    let mut files = Vec::new();
    for c in model
        .cases
        .resident()
        .filter(|c| model.cases.is_detailed(&c.id))
    {
        let Some(frame) = c.worst_phase.as_ref().and_then(|w| w.rendered.as_ref()) else {
            continue;
        };
        files.push((format!("{}-worst-phase.png", c.id), png_bytes(frame)?));
        if let Some(view) = views.get(&crate::model::evidence::worst_phase_frame_path(&c.id)) {
            files.push((format!("{}-worst-phase-view.png", c.id), view.clone()));
        }
    }
    Ok(files)
}

/// Width of the inline copy in the HTML report, pixels.
pub const THUMBNAIL_WIDTH: u32 = 480;

fn image_err(e: image::ImageError) -> ReportError {
    ReportError::Template {
        template: "sample frame PNG".to_string(),
        message: e.to_string(),
    }
}

/// Encodes a frame as PNG: 8-bit grey for outputs up to 255, else 16-bit.
pub fn png_bytes(frame: &RenderedFrame) -> Result<Vec<u8>, ReportError> {
    let scale = |v: f64, max: f64| (v / frame.full_scale_dn * max).round().clamp(0.0, max);
    let (w, h) = (frame.width, frame.height);
    let pixels = w as usize * h as usize;
    // Each run is scaled once: a simulated row has a few runs.
    let image = if frame.full_scale_dn <= 255.0 {
        let mut buf = Vec::with_capacity(pixels);
        for y in 0..h {
            frame.for_each_run(y, |v, n| {
                buf.extend(std::iter::repeat_n(scale(v, 255.0) as u8, n as usize));
            });
        }
        ImageBuffer::<Luma<u8>, _>::from_raw(w, h, buf).map(DynamicImage::ImageLuma8)
    } else {
        let mut buf = Vec::with_capacity(pixels);
        for y in 0..h {
            frame.for_each_run(y, |v, n| {
                buf.extend(std::iter::repeat_n(scale(v, 65535.0) as u16, n as usize));
            });
        }
        ImageBuffer::<Luma<u16>, _>::from_raw(w, h, buf).map(DynamicImage::ImageLuma16)
    };
    let image = image.ok_or_else(|| ReportError::Template {
        template: "sample frame PNG".to_string(),
        message: format!("the luma values do not fill {w} x {h} pixels"),
    })?;
    encode_png_image(&image).map_err(image_err)
}

/// A nearest-neighbour copy at most `max_width` wide.
pub fn thumbnail(frame: &RenderedFrame, max_width: u32) -> RenderedFrame {
    if frame.width <= max_width || frame.width == 0 {
        return frame.clone();
    }
    let w = max_width;
    let h = ((frame.height as u64 * w as u64) / frame.width as u64).max(1) as u32;
    let mut luma = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        let sy = (y as u64 * frame.height as u64 / h as u64) as u32;
        for x in 0..w {
            let sx = (x as u64 * frame.width as u64 / w as u64) as u32;
            luma.push(frame.pixel(sx, sy).unwrap_or(f64::NAN));
        }
    }
    RenderedFrame::from_pixels(frame.index, w, h, &luma, frame.full_scale_dn)
}

/// Standard base64 (RFC 4648) with padding.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (input, want) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(input.as_bytes()), want);
        }
    }

    #[test]
    fn png_round_trips_8_and_16_bit() {
        for full in [255.0, 65535.0] {
            let frame = RenderedFrame::from_pixels(
                3,
                4,
                2,
                &[0.0, full / 2.0, full, full / 4.0, 1.0, 2.0, 3.0, 4.0],
                full,
            );
            let png = png_bytes(&frame).unwrap();
            let img = image::load_from_memory(&png).unwrap();
            assert_eq!((img.width(), img.height()), (4, 2));
            let back = img.to_luma16();
            let max = back.pixels().map(|p| p.0[0]).max().unwrap();
            assert_eq!(max, 65535);
        }
    }
}
