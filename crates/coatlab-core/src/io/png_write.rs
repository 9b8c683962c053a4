//! The PNG writer: 8-bit sRGB images, the one format every viewer shows as it is.

use std::path::{Path, PathBuf};

use palette::Srgb;
use thiserror::Error;

use super::atomic::{WriteError, write_bytes_atomically};

/// What went wrong writing a PNG; each names the file.
#[derive(Debug, Error)]
pub enum PngWriteError {
    /// The encoder refused the image.
    #[error("encoding PNG {}: {error}", path.display())]
    Encode {
        path: PathBuf,
        error: png::EncodingError,
    },
    /// The pixels do not fill the image (a caller's mistake).
    #[error("{}: {pixels} pixels given for a {width}×{height} image", path.display())]
    PixelCount {
        path: PathBuf,
        width: u32,
        height: u32,
        pixels: usize,
    },
    /// The file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Writes `pixels` (row-major from the top-left) as an 8-bit RGB PNG with an
/// sRGB chunk (perceptual intent), atomically ([`super::atomic`]). The image is
/// encoded in memory first, so an encoding failure touches no file.
pub fn write_srgb8_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[Srgb<u8>],
) -> Result<(), PngWriteError> {
    if pixels.len() as u64 != u64::from(width) * u64::from(height) {
        return Err(PngWriteError::PixelCount {
            path: path.to_owned(),
            width,
            height,
            pixels: pixels.len(),
        });
    }
    let encode = |error| PngWriteError::Encode {
        path: path.to_owned(),
        error,
    };
    let mut encoded = Vec::new();
    let mut encoder = png::Encoder::new(&mut encoded, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(encode)?;
    writer
        .write_image_data(palette::cast::into_component_slice(pixels))
        .map_err(encode)?;
    writer.finish().map_err(encode)?;
    Ok(write_bytes_atomically(path, &encoded)?)
}
