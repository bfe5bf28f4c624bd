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

use image::codecs::png::{PngDecoder, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder, ImageReader, ImageResult};

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
/// `tif`/`tiff`, `jpg`/`jpeg` at `image`'s default quality).
pub fn save(img: &DynamicImage, path: &Path) -> ImageResult<()> {
    img.save(path)
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
    let mut out = Vec::new();
    PngEncoder::new(&mut out).write_image(pixels, width, height, color)?;
    Ok(out)
}

/// Decodes the bytes of a PNG file.
pub fn decode_png(bytes: &[u8]) -> ImageResult<DynamicImage> {
    DynamicImage::from_decoder(PngDecoder::new(std::io::Cursor::new(bytes))?)
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
    }
}
