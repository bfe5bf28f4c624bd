//! Frame images in and out, for every crate that reads or writes one.
//!
//! `image`'s own entry points are generic over the reader or writer, and
//! those that pick the format at run time (`decode`, `save`, `write_to`)
//! bring in every codec: each crate that called them compiled the PNG,
//! TIFF and JPEG codecs again (about 100,000 lines of LLVM IR a crate).
//! These functions are not generic, so the codecs are compiled here once.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use image::codecs::jpeg::JpegEncoder;
use image::codecs::png::{PngDecoder, PngEncoder};
use image::{
    DynamicImage, ExtendedColorType, ImageDecoder, ImageEncoder, ImageReader, ImageResult, Limits,
};

/// A frame file's decoder, as [`ImageReader`] sets it up.
pub type FileReader = ImageReader<BufReader<File>>;

/// Decodes a frame file in the format `reader` was given or guessed.
pub fn decode(reader: FileReader) -> ImageResult<DynamicImage> {
    reader.decode()
}

/// A frame file's width and height, from its header alone.
pub fn dimensions(reader: FileReader) -> ImageResult<(u32, u32)> {
    reader.into_dimensions()
}

/// Writes `img` to `path`, in the format its extension names (`png`,
/// `tif`/`tiff`, `jpg`/`jpeg` at `image`'s default quality), its pixels as
/// they are: a format that cannot hold them (16-bit grey in a JPEG) is an
/// error, not a conversion.
pub fn save(img: &DynamicImage, path: &Path) -> ImageResult<()> {
    let (pixels, (w, h)) = (img.as_bytes(), (img.width(), img.height()));
    fits(pixels, w, h, img.color().into())?;
    image::save_buffer(path, pixels, w, h, img.color())
}

/// An error, where `image`'s encoders would panic, when `pixels` are not
/// exactly a `width` x `height` picture of `color`.
fn fits(pixels: &[u8], width: u32, height: u32, color: ExtendedColorType) -> ImageResult<()> {
    let want = u64::from(width) * u64::from(height) * u64::from(color.bits_per_pixel()) / 8;
    if want == pixels.len() as u64 {
        return Ok(());
    }
    Err(image::ImageError::Parameter(
        image::error::ParameterError::from_kind(
            image::error::ParameterErrorKind::DimensionMismatch,
        ),
    ))
}

/// Writes 8-bit grey `pixels` (`width` x `height`, rows top down) to
/// `path` as a JPEG of `quality` (1 to 100).
pub fn save_jpeg_grey(
    pixels: &[u8],
    (width, height): (u32, u32),
    path: &Path,
    quality: u8,
) -> ImageResult<()> {
    fits(pixels, width, height, ExtendedColorType::L8)?;
    let file = std::io::BufWriter::new(File::create(path)?);
    JpegEncoder::new_with_quality(file, quality).write_image(
        pixels,
        width,
        height,
        ExtendedColorType::L8,
    )
}

/// `img` as the bytes of a PNG file, with `image`'s default compression
/// and filter: the bytes `DynamicImage::write_to` writes as PNG.
pub fn png_bytes(img: &DynamicImage) -> ImageResult<Vec<u8>> {
    encode_png(
        img.as_bytes(),
        img.width(),
        img.height(),
        img.color().into(),
    )
}

/// Pixels laid out as `color` says (rows top down, samples in native byte
/// order) as the bytes of a PNG file, as [`png_bytes`] writes them.
pub fn encode_png(
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> ImageResult<Vec<u8>> {
    fits(pixels, width, height, color)?;
    let mut out = Vec::new();
    PngEncoder::new(&mut out).write_image(pixels, width, height, color)?;
    Ok(out)
}

/// Decodes the bytes of a PNG file, within `image`'s default limits (a
/// picture of more than 512 MiB is refused), as `ImageReader` decodes.
pub fn decode_png(bytes: &[u8]) -> ImageResult<DynamicImage> {
    let mut limits = Limits::default();
    let decoder = PngDecoder::with_limits(std::io::Cursor::new(bytes), limits.clone())?;
    limits.reserve(decoder.total_bytes())?;
    DynamicImage::from_decoder(decoder)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageBuffer, ImageFormat, Luma, Rgb};

    /// The PNG bytes are the ones `write_to` writes (the report's frames
    /// must not change), and they decode to the same pixels.
    #[test]
    fn png_bytes_are_write_tos_and_decode_back() {
        let grey16 = ImageBuffer::from_fn(5, 3, |x, y| Luma([(x * 9000 + y * 700) as u16]));
        let rgb = ImageBuffer::from_fn(4, 2, |x, y| Rgb([x as u8 * 60, y as u8 * 100, 7]));
        for img in [
            DynamicImage::ImageLuma16(grey16),
            DynamicImage::ImageRgb8(rgb),
        ] {
            let mut want = std::io::Cursor::new(Vec::new());
            img.write_to(&mut want, ImageFormat::Png).unwrap();
            let got = png_bytes(&img).unwrap();
            assert_eq!(got, want.into_inner());
            assert_eq!(decode_png(&got).unwrap(), img);
        }
    }

    #[test]
    fn a_file_saved_by_extension_decodes_back() {
        let dir = tempfile::tempdir().unwrap();
        let img = DynamicImage::ImageLuma8(ImageBuffer::from_fn(6, 4, |x, y| {
            Luma([(x * 40 + y) as u8])
        }));
        for name in ["f.png", "f.tiff"] {
            let path = dir.path().join(name);
            save(&img, &path).unwrap();
            let reader = ImageReader::open(&path).unwrap();
            assert_eq!(decode(reader).unwrap(), img, "{name}");
            let reader = ImageReader::open(&path).unwrap();
            assert_eq!(dimensions(reader).unwrap(), (6, 4), "{name}");
        }
        assert!(decode_png(b"not a png").is_err());
        // Pixels that are not the picture named are an error, not a panic,
        // and no file is made for them.
        let short = dir.path().join("short.jpg");
        assert!(save_jpeg_grey(&[0; 3], (2, 2), &short, 90).is_err());
        assert!(!short.exists());
        assert!(encode_png(&[0; 5], 2, 2, ExtendedColorType::L8).is_err());
        assert!(encode_png(&[0; 7], 2, 2, ExtendedColorType::L16).is_err());
        let grey16 = DynamicImage::ImageLuma16(ImageBuffer::new(2, 2));
        let jpeg = dir.path().join("f.jpg");
        assert!(save(&grey16, &jpeg).is_err(), "16-bit grey is no JPEG");
        save_jpeg_grey(&[0, 64, 128, 255], (2, 2), &jpeg, 90).unwrap();
        let reader = ImageReader::open(&jpeg)
            .unwrap()
            .with_guessed_format()
            .unwrap();
        assert_eq!(dimensions(reader).unwrap(), (2, 2));
    }

    /// A PNG whose header claims a picture of gigabytes is refused before
    /// anything is allocated for it, as `ImageReader` refuses it.
    #[test]
    fn a_png_beyond_the_default_limits_is_refused() {
        let small = encode_png(&[0; 4], 2, 2, ExtendedColorType::L8).unwrap();
        // The IHDR chunk: length (4), type (4), width, height, then 5 bytes
        // of depth and types, and its CRC over type and data.
        let mut png = small.clone();
        png[16..20].copy_from_slice(&40_000u32.to_be_bytes());
        png[20..24].copy_from_slice(&40_000u32.to_be_bytes());
        png[24] = 16;
        png[25] = 6;
        let crc = crc32(&png[12..29]);
        png[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = decode_png(&png).unwrap_err();
        assert!(
            matches!(e, image::ImageError::Limits(_)),
            "a 12.8 GB picture: {e}"
        );
        assert!(decode_png(&small).is_ok());
    }

    /// CRC-32 of PNG chunks (ISO 3309, polynomial 0xEDB88320).
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    (c >> 1) ^ 0xEDB8_8320
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
}
