//! A decoded linear-RGB picture, and what can go wrong reading one.

use thiserror::Error;

/// What went wrong reading an RGB image file (or checking one in memory).
#[derive(Debug, Error)]
pub enum ImageReadError {
    /// The file could not be read.
    // The message names the environment map: maps are what these readers load.
    #[error("{path}: cannot read the environment map: {error}")]
    Io {
        /// The file, as given.
        path: String,
        /// Why the system refused it.
        error: std::io::Error,
    },
    /// The header is not that of a Radiance RGBE (.hdr) picture we can read.
    #[error("{path}: not a readable Radiance .hdr file: {reason}")]
    BadHeader {
        /// The file, as given.
        path: String,
        /// What in the header is wrong.
        reason: String,
    },
    /// The pixel data stop early.
    #[error(
        "{path}: truncated: the pixel data end in scanline {row} of {height} (the header promises {width}×{height} pixels)"
    )]
    Truncated {
        /// The file, as given.
        path: String,
        /// The scanline (from the top of the file) where the data end.
        row: usize,
        /// Width the header promises.
        width: usize,
        /// Height the header promises.
        height: usize,
    },
    /// Run-length data that do not decode to a scanline.
    #[error("{path}: corrupt run-length data in scanline {row}: {reason}")]
    CorruptScanline {
        /// The file, as given.
        path: String,
        /// The scanline (from the top of the file).
        row: usize,
        /// What does not fit.
        reason: &'static str,
    },
    /// An OpenEXR file the decoder cannot read (or without RGB channels).
    #[error("{path}: not a readable OpenEXR file: {reason}")]
    BadExr {
        /// The file, as given.
        path: String,
        /// The decoder's complaint.
        reason: String,
    },
    /// An image whose pixel buffer does not fit its size, or holds NaN or infinity.
    #[error("{name}: {reason}")]
    InvalidImage {
        /// The file, or "RGB image" for pixels given in memory.
        name: String,
        /// What is wrong with the pixels.
        reason: String,
    },
}

/// A linear-RGB picture, row-major, top row first; at least one pixel, all finite.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// An image from its pixels; errors unless there are `width × height ≥ 1` of
    /// them, all finite.
    pub fn new(width: usize, height: usize, pixels: Vec<[f32; 3]>) -> Result<Self, ImageReadError> {
        let invalid = |reason: String| ImageReadError::InvalidImage {
            name: "RGB image".to_owned(),
            reason,
        };
        if width == 0 || height == 0 || width.checked_mul(height) != Some(pixels.len()) {
            return Err(invalid(format!(
                "{} pixels do not make a {width}×{height} image",
                pixels.len()
            )));
        }
        if let Some(i) = pixels.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(invalid(format!(
                "pixel {i} ({:?}) is not finite",
                pixels[i]
            )));
        }
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The pixels, row-major, top row first.
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.pixels
    }

    /// The image `factor` times smaller each way (rounded up), each pixel the mean
    /// of the block of up to factor × factor pixels it covers.
    pub fn box_downsample(&self, factor: usize) -> Self {
        let width = self.width.div_ceil(factor);
        let height = self.height.div_ceil(factor);
        let mut pixels = vec![[0.0f32; 3]; width * height];
        let mut counts = vec![0u32; width * height];
        for row in 0..self.height {
            for col in 0..self.width {
                let target = (row / factor) * width + col / factor;
                let p = self.pixels[row * self.width + col];
                for c in 0..3 {
                    pixels[target][c] += p[c];
                }
                counts[target] += 1;
            }
        }
        for (p, &n) in pixels.iter_mut().zip(&counts) {
            *p = p.map(|v| v / n as f32);
        }
        Self {
            width,
            height,
            pixels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_downsampling_averages_blocks_and_rounds_the_size_up() {
        let pixels: Vec<[f32; 3]> = (0..15).map(|i| [i as f32, 1.0, 2.0 * i as f32]).collect();
        let image = RgbImage::new(5, 3, pixels).unwrap();
        let small = image.box_downsample(2);
        assert_eq!((small.width(), small.height()), (3, 2));
        // Top-left block: pixels 0, 1, 5, 6; bottom-right: pixel 14 alone.
        assert_eq!(small.pixels()[0], [3.0, 1.0, 6.0]);
        assert_eq!(small.pixels()[5], [14.0, 1.0, 28.0]);
    }
}
