//! PNG and TIFF frames (8 or 16 bit, grey or RGB, TIFF with LZW) through the
//! `image` crate, one file per frame, in file-name order.

use std::path::{Path, PathBuf};

use image::DynamicImage;

use super::{
    Accumulator, CaptureError, CaptureTrace, FrameView, Pixels, ReadOptions, RoiRect, check_rois,
    times_from_fps,
};

/// Reads every `.png`, `.tif` and `.tiff` file of `dir`, sorted by name.
pub(super) fn read_dir(
    dir: &Path,
    rois: &[RoiRect],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    let entries = std::fs::read_dir(dir).map_err(|e| CaptureError::Read {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .is_some_and(|e| e == "png" || e == "tif" || e == "tiff")
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(CaptureError::Invalid {
            path: dir.to_path_buf(),
            message: "the directory holds no .png, .tif or .tiff frames".to_string(),
            hint: "frames are read in file-name order, e.g. frame_000000.png".to_string(),
        });
    }
    read_files(dir, &files, rois, opts)
}

/// Decoder limits: the header's size is checked before any pixel buffer
/// is allocated (issue 10), at the sensor bound of docs/plan-format.md.
fn frame_limits() -> image::Limits {
    let mut l = image::Limits::default();
    l.max_image_width = Some(crate::plan::bounds::MAX_SENSOR_SIDE);
    l.max_image_height = Some(crate::plan::bounds::MAX_SENSOR_SIDE);
    // 40 Mpx of 16-bit RGBA.
    l.max_alloc = Some(crate::plan::bounds::MAX_SENSOR_PIXELS * 8);
    l
}

/// Reads `files` as consecutive frames; `capture` names the capture in errors.
pub(super) fn read_files(
    capture: &Path,
    files: &[PathBuf],
    rois: &[RoiRect],
    opts: &ReadOptions,
) -> Result<CaptureTrace, CaptureError> {
    let mut acc = Accumulator::new(rois, opts.luma);
    let mut size = None;
    let mut full_scale = 255.0;
    for (k, file) in files.iter().enumerate() {
        let frame = k as u64;
        let err = |message: String| CaptureError::Frame {
            path: file.clone(),
            frame,
            message,
        };
        let mut reader = image::ImageReader::open(file)
            .map_err(|e| err(format!("cannot open: {e}")))?
            .with_guessed_format()
            .map_err(|e| err(format!("cannot read: {e}")))?;
        reader.limits(frame_limits());
        let img = reader
            .decode()
            .map_err(|e| err(format!("corrupt or unsupported image: {e}")))?;
        let (w, h) = (img.width(), img.height());
        match size {
            None => {
                check_rois(file, frame, rois, w, h)?;
                size = Some((w, h));
            }
            Some((w0, h0)) if (w0, h0) != (w, h) => {
                return Err(err(format!(
                    "frame is {w}x{h} but frame 0 is {w0}x{h0} (mixed frame sizes)"
                )));
            }
            Some(_) => {}
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
        frame_size: size.unwrap_or((0, 0)),
        timestamps: if opts.fps.is_some() { "fps" } else { "none" },
        format: format!(
            "image sequence `{}` ({} files)",
            capture.display(),
            files.len()
        ),
    })
}
