//! Radiance RGBE (.hdr) input: our own reader of the `#?RADIANCE` header and the
//! flat, old-style and new-style run-length encoded scanlines.

use std::path::Path;

use crate::io::rgb_image::{ImageReadError, RgbImage};

/// Reads a Radiance RGBE picture (`#?RADIANCE` header, `FORMAT=32-bit_rle_rgbe`,
/// resolution `-Y h +X w` or `+Y h +X w`, flat, old-style or new-style run-length
/// encoded scanlines). Pixel value = (mantissa + ½)·2^(exponent − 136), as Radiance
/// decodes it; EXPOSURE lines are ignored (environments are normalised anyway).
pub fn read_hdr(path: &Path) -> Result<RgbImage, ImageReadError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|error| ImageReadError::Io {
        path: name.clone(),
        error,
    })?;
    decode_hdr(&bytes, &name)
}

/// [`read_hdr`] on bytes in memory; `name` is used in errors.
pub fn decode_hdr(bytes: &[u8], name: &str) -> Result<RgbImage, ImageReadError> {
    let header = Header::parse(bytes, name)?;
    let (width, height) = (header.width, header.height);
    let mut data = ScanlineReader {
        bytes,
        pos: header.data_start,
        name,
        width,
        height,
    };
    let mut pixels = vec![[0.0f32; 3]; width * height];
    let mut scanline = vec![[0u8; 4]; width];
    for row in 0..height {
        data.read_scanline(row, &mut scanline)?;
        let target = if header.bottom_up {
            height - 1 - row
        } else {
            row
        };
        for (p, rgbe) in pixels[target * width..(target + 1) * width]
            .iter_mut()
            .zip(&scanline)
        {
            *p = rgbe_to_float(*rgbe);
        }
    }
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

/// What the header says about the pixels that follow it.
struct Header {
    /// Where the scanlines start.
    data_start: usize,
    /// `+Y`: the file's first scanline is the picture's bottom row.
    bottom_up: bool,
    width: usize,
    height: usize,
}

impl Header {
    /// The header lines up to the blank line, then the resolution line.
    fn parse(bytes: &[u8], name: &str) -> Result<Self, ImageReadError> {
        let bad = |reason: &str| ImageReadError::BadHeader {
            path: name.to_owned(),
            reason: reason.to_owned(),
        };
        let mut pos = 0;
        let next_line = |pos: &mut usize| -> Option<&[u8]> {
            let rest = bytes.get(*pos..)?;
            let end = rest.iter().position(|&b| b == b'\n')?;
            *pos += end + 1;
            Some(&rest[..end])
        };
        let first = next_line(&mut pos).ok_or_else(|| bad("no header line"))?;
        if !first.starts_with(b"#?") {
            return Err(bad(
                "the first line does not start with \"#?\" (e.g. #?RADIANCE)",
            ));
        }
        loop {
            let line = next_line(&mut pos).ok_or_else(|| bad("the header never ends"))?;
            if line.is_empty() {
                break;
            }
            if let Some(format) = line.strip_prefix(b"FORMAT=") {
                let format = String::from_utf8_lossy(format);
                if format.trim() != "32-bit_rle_rgbe" {
                    return Err(bad(&format!(
                        "pixel format {} (only 32-bit_rle_rgbe is supported)",
                        format.trim()
                    )));
                }
            }
        }
        let resolution = next_line(&mut pos).ok_or_else(|| bad("no resolution line"))?;
        let resolution = String::from_utf8_lossy(resolution);
        let fields: Vec<&str> = resolution.split_whitespace().collect();
        let (bottom_up, height, width) = match fields.as_slice() {
            [y, h, "+X", w] if *y == "-Y" || *y == "+Y" => {
                let parse = |s: &str| s.parse::<usize>().ok().filter(|&n| n > 0);
                match (parse(h), parse(w)) {
                    (Some(h), Some(w)) => (*y == "+Y", h, w),
                    _ => return Err(bad(&format!("bad resolution line {resolution:?}"))),
                }
            }
            _ => {
                return Err(bad(&format!(
                    "resolution line {resolution:?} (only \"-Y h +X w\" and \"+Y h +X w\" are supported)"
                )));
            }
        };
        if width.checked_mul(height).is_none_or(|n| n > 1 << 28) {
            return Err(bad(&format!(
                "image of {width}×{height} pixels is too large"
            )));
        }
        Ok(Self {
            data_start: pos,
            bottom_up,
            width,
            height,
        })
    }
}

fn rgbe_to_float([r, g, b, e]: [u8; 4]) -> [f32; 3] {
    if e == 0 {
        return [0.0; 3];
    }
    let f = 2f32.powi(i32::from(e) - 136);
    [r, g, b].map(|m| (f32::from(m) + 0.5) * f)
}

/// Reads scanlines from the pixel data, naming the file and scanline in errors.
struct ScanlineReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    name: &'a str,
    width: usize,
    height: usize,
}

impl ScanlineReader<'_> {
    fn byte(&mut self, row: usize) -> Result<u8, ImageReadError> {
        let b = self
            .bytes
            .get(self.pos)
            .copied()
            .ok_or_else(|| ImageReadError::Truncated {
                path: self.name.to_owned(),
                row,
                width: self.width,
                height: self.height,
            })?;
        self.pos += 1;
        Ok(b)
    }

    fn pixel(&mut self, row: usize) -> Result<[u8; 4], ImageReadError> {
        Ok([
            self.byte(row)?,
            self.byte(row)?,
            self.byte(row)?,
            self.byte(row)?,
        ])
    }

    fn corrupt(&self, row: usize, reason: &'static str) -> ImageReadError {
        ImageReadError::CorruptScanline {
            path: self.name.to_owned(),
            row,
            reason,
        }
    }

    /// One scanline into `out`, in whichever encoding its first pixel announces.
    fn read_scanline(&mut self, row: usize, out: &mut [[u8; 4]]) -> Result<(), ImageReadError> {
        let width = out.len();
        let first = self.pixel(row)?;
        let new_rle =
            (8..=0x7fff).contains(&width) && first[0] == 2 && first[1] == 2 && first[2] & 0x80 == 0;
        if new_rle {
            if (usize::from(first[2]) << 8 | usize::from(first[3])) != width {
                return Err(self.corrupt(row, "the scanline length differs from the image width"));
            }
            self.read_channel_runs(row, out)
        } else {
            self.read_flat(row, first, out)
        }
    }

    /// New-style run-length data: four channel planes, each of runs (count > 128
    /// repeats one byte) and literal spans (count ≤ 128 bytes).
    fn read_channel_runs(&mut self, row: usize, out: &mut [[u8; 4]]) -> Result<(), ImageReadError> {
        let width = out.len();
        for channel in 0..4 {
            let mut x = 0;
            while x < width {
                let count = usize::from(self.byte(row)?);
                if count > 128 {
                    let run = count - 128;
                    if x + run > width {
                        return Err(self.corrupt(row, "a run overflows the scanline"));
                    }
                    let value = self.byte(row)?;
                    for p in &mut out[x..x + run] {
                        p[channel] = value;
                    }
                    x += run;
                } else {
                    if count == 0 || x + count > width {
                        return Err(self.corrupt(row, "a literal span is empty or too long"));
                    }
                    for p in &mut out[x..x + count] {
                        p[channel] = self.byte(row)?;
                    }
                    x += count;
                }
            }
        }
        Ok(())
    }

    /// Flat pixels, with old-style runs: (1, 1, 1, n) repeats the previous pixel
    /// n << shift times, shift growing by 8 for consecutive run markers. `first` is
    /// the scanline's first pixel, already read.
    fn read_flat(
        &mut self,
        row: usize,
        first: [u8; 4],
        out: &mut [[u8; 4]],
    ) -> Result<(), ImageReadError> {
        let width = out.len();
        let mut x = 0;
        let mut shift = 0u32;
        let mut pixel = first;
        loop {
            if pixel[0] == 1 && pixel[1] == 1 && pixel[2] == 1 {
                if x == 0 {
                    return Err(self.corrupt(row, "a run marker with no pixel before it"));
                }
                let run = usize::from(pixel[3])
                    .checked_shl(shift)
                    .filter(|&r| shift < 24 && x + r <= width)
                    .ok_or_else(|| self.corrupt(row, "an old-style run overflows the scanline"))?;
                let previous = out[x - 1];
                out[x..x + run].fill(previous);
                x += run;
                shift += 8;
            } else {
                out[x] = pixel;
                x += 1;
                shift = 0;
            }
            if x == width {
                return Ok(());
            }
            pixel = self.pixel(row)?;
        }
    }
}
