//! PNG and TIFF frames (8 or 16 bit, grey or RGB, TIFF with LZW) through the
//! `image` crate, one file per frame, in file-name order.

use ledflicker_plan::trace::TimestampSource;
use std::path::{Path, PathBuf};

use image::DynamicImage;

use super::{
    Accumulator, CaptureError, CaptureTrace, FrameSink, FrameView, Pixels, ReadOptions, RoiRect,
    check_interrupt, check_rois, image_reader, times_from_fps,
};

/// Reads every `.png`, `.tif` and `.tiff` file of `dir`, sorted by name.
pub(super) fn read_dir(
    dir: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
    sink: Option<&mut dyn FrameSink>,
) -> Result<CaptureTrace, CaptureError> {
    let files = frame_files(dir).map_err(|e| CaptureError::Read {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    if files.is_empty() {
        return Err(CaptureError::Invalid {
            path: dir.to_path_buf(),
            message: "the directory holds no .png, .tif or .tiff frames".to_string(),
            hint: "frames are read in file-name order, e.g. frame_000000.png".to_string(),
        });
    }
    read_files(dir, &files, rois, opts, sink)
}

/// The frame size (width, height) of the image `file`, from its header
/// alone; `None` when it cannot be read (the read says why).
pub(super) fn frame_size(file: &Path) -> Option<(u32, u32)> {
    ledflicker_plan::image_io::dimensions(image_reader(file).ok()?).ok()
}

/// The frame files of the directory `dir`: its `.png`, `.tif` and `.tiff`
/// files, sorted by name.
pub(super) fn frame_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir)?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .is_some_and(|e| e == "png" || e == "tif" || e == "tiff")
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Decoder limits: the header's size is checked before any pixel buffer
/// is allocated, so that a forged header cannot ask for gigabytes, at the sensor bound of docs/plan-format.md.
fn frame_limits() -> image::Limits {
    let mut l = image::Limits::default();
    l.max_image_width = Some(ledflicker_plan::plan::bounds::MAX_SENSOR_SIDE);
    l.max_image_height = Some(ledflicker_plan::plan::bounds::MAX_SENSOR_SIDE);
    // 40 Mpx of 16-bit RGBA.
    l.max_alloc = Some(ledflicker_plan::plan::bounds::MAX_SENSOR_PIXELS * 8);
    l
}

/// Reads `files` as consecutive frames; `capture` names the capture in errors.
pub(super) fn read_files(
    capture: &Path,
    files: &[PathBuf],
    rois: &[RoiRect],
    opts: &ReadOptions,
    sink: Option<&mut dyn FrameSink>,
) -> Result<CaptureTrace, CaptureError> {
    let mut acc = Accumulator::new(rois, opts.luma)
        .linearising(opts.colour_transfer)
        .with_sink(sink);
    let mut first: Option<(u32, u32, image::ColorType)> = None;
    let mut full_scale = 255.0;
    for (k, file) in files.iter().enumerate() {
        check_interrupt(capture)?;
        let frame = k as u64;
        let err = |message: String| CaptureError::Frame {
            path: file.clone(),
            frame,
            message,
        };
        let mut reader = image_reader(file).map_err(|e| match e {
            CaptureError::Read { message, .. } => err(format!("cannot open: {message}")),
            other => other,
        })?;
        reader.limits(frame_limits());
        let img = ledflicker_plan::image_io::decode(reader)
            .map_err(|e| err(format!("corrupt or unsupported image: {e}")))?;
        let (w, h, colour) = (img.width(), img.height(), img.color());
        match first {
            None => {
                check_rois(file, frame, rois, w, h)?;
                first = Some((w, h, colour));
            }
            Some((w0, h0, c0)) => {
                if (w0, h0) != (w, h) {
                    return Err(err(format!(
                        "frame is {w}x{h} but frame 0 is {w0}x{h0} (mixed frame sizes)"
                    )));
                }
                if let Some(why) = mixed_pixels(c0, colour) {
                    return Err(err(why));
                }
            }
        }
        let view = |pixels| FrameView {
            pixels,
            origin: (0, 0),
            width: w,
        };
        match &img {
            DynamicImage::ImageLuma8(b) => acc.push(&view(Pixels::Grey8(b.as_raw()))),
            DynamicImage::ImageLumaA8(b) => {
                let grey: Vec<u8> = b.as_raw().chunks_exact(2).map(|p| p[0]).collect();
                acc.push(&view(Pixels::Grey8(&grey)));
            }
            DynamicImage::ImageRgb8(b) => acc.push(&view(Pixels::Rgb8(b.as_raw(), 3))),
            DynamicImage::ImageRgba8(b) => acc.push(&view(Pixels::Rgb8(b.as_raw(), 4))),
            DynamicImage::ImageLuma16(b) => {
                full_scale = 65535.0;
                acc.push(&view(Pixels::Grey16(b.as_raw())));
            }
            DynamicImage::ImageLumaA16(b) => {
                full_scale = 65535.0;
                let grey: Vec<u16> = b.as_raw().chunks_exact(2).map(|p| p[0]).collect();
                acc.push(&view(Pixels::Grey16(&grey)));
            }
            DynamicImage::ImageRgb16(b) => {
                full_scale = 65535.0;
                acc.push(&view(Pixels::Rgb16(b.as_raw(), 3)));
            }
            DynamicImage::ImageRgba16(b) => {
                full_scale = 65535.0;
                acc.push(&view(Pixels::Rgb16(b.as_raw(), 4)));
            }
            other => {
                return Err(err(format!(
                    "unsupported pixel format {:?}; use 8- or 16-bit grey or RGB",
                    other.color()
                )));
            }
        }
    }
    let n = acc.frames();
    let (luma, rgb) = acc.finish();
    Ok(CaptureTrace {
        time_s: times_from_fps(n, opts.fps.unwrap_or(f64::NAN)),
        luma,
        rgb,
        full_scale_dn: full_scale,
        frame_size: first.map_or((0, 0), |(w, h, _)| (w, h)),
        timestamps: opts
            .fps
            .map_or(TimestampSource::None, |_| TimestampSource::Fps),
        format: format!(
            "image sequence `{}` ({} files)",
            capture.display(),
            files.len()
        ),
        time_base_s: None,
        stated_fps: None,
        video: None,
    })
}

/// Why a frame of pixel type `c` cannot join frames of type `c0`, if it
/// cannot: every frame of a capture must have the same bit depth (a DN
/// means the same light only on one scale; 8-bit OFF frames read beside
/// 16-bit PWM frames would give an FDI of 513, not 1) and the same
/// channels (grey,
/// grey + alpha, RGB, RGBA: luma and the R, G, B traces need every frame).
fn mixed_pixels(c0: image::ColorType, c: image::ColorType) -> Option<String> {
    let bits = |c: image::ColorType| u32::from(c.bits_per_pixel()) / u32::from(c.channel_count());
    let (b0, b) = (bits(c0), bits(c));
    if b0 != b {
        return Some(format!(
            "frame is {b}-bit ({}) but frame 0 is {b0}-bit ({}) (mixed bit depths)\n    hint: export every frame of a capture at one bit depth",
            channel_names(c),
            channel_names(c0)
        ));
    }
    let (n0, n) = (c0.channel_count(), c.channel_count());
    if n0 != n || c0.has_alpha() != c.has_alpha() {
        return Some(format!(
            "frame has {n} channels ({}) but frame 0 has {n0} ({}) (mixed channel counts)\n    hint: export every frame of a capture as grey, or every frame as RGB",
            channel_names(c),
            channel_names(c0)
        ));
    }
    None
}

/// The channels of a pixel type, for messages.
fn channel_names(c: image::ColorType) -> &'static str {
    match (c.has_color(), c.has_alpha()) {
        (false, false) => "grey",
        (false, true) => "grey + alpha",
        (true, false) => "RGB",
        (true, true) => "RGBA",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::ColorType;

    #[test]
    fn frames_must_share_bit_depth_and_channels() {
        assert_eq!(mixed_pixels(ColorType::L8, ColorType::L8), None);
        assert_eq!(mixed_pixels(ColorType::Rgb16, ColorType::Rgb16), None);
        let depth = mixed_pixels(ColorType::L8, ColorType::L16).unwrap();
        assert!(
            depth.contains("16-bit (grey) but frame 0 is 8-bit (grey)"),
            "{depth}"
        );
        let channels = mixed_pixels(ColorType::L8, ColorType::Rgb8).unwrap();
        assert!(
            channels.contains("3 channels (RGB) but frame 0 has 1 (grey)"),
            "{channels}"
        );
        let alpha = mixed_pixels(ColorType::Rgb8, ColorType::Rgba8).unwrap();
        assert!(alpha.contains("4 channels (RGBA)"), "{alpha}");
    }
}
