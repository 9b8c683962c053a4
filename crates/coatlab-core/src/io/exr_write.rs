//! The OpenEXR writer, through the `exr` crate: linear sRGB images as R, G, B
//! channels of 32-bit or 16-bit floats, with a lossless compression and text
//! attributes in the header saying what made the image.
//!
//! The files are single-part scanline images with the sRGB `chromaticities`
//! (primaries and D65 white), which is what EXR viewers assume for RGB without
//! them. They are reproducible: the same pixels and attributes give the same bytes
//! (see `canonical_attribute_order`).

use std::io::Cursor;
use std::path::{Path, PathBuf};

use exr::meta::attribute::Chromaticities;
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Compression, Encoding, FlatSamples, Image,
    ImageAttributes, IntegerBounds, Layer, LayerAttributes, SmallVec, Text, Vec2, WritableImage,
    f16,
};
use palette::LinSrgb;
use thiserror::Error;

use super::atomic::{WriteError, write_bytes_atomically};

/// The sample type of the channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ExrPrecision {
    /// 32-bit floats: the values exactly.
    #[default]
    Float,
    /// 16-bit floats (half): half the size, about three significant digits
    /// (relative error ≤ 2⁻¹¹), values above 65504 become infinite.
    Half,
}

/// How the pixel data is compressed; all of these are lossless.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ExrCompression {
    /// None: the largest files, the fastest to write and read.
    None,
    /// Run-length: cheap, small gains except on flat areas.
    Rle,
    /// Deflate per scanline.
    Zips,
    /// Deflate per block of 16 scanlines: OpenEXR's own default, and ours.
    #[default]
    Zip,
    /// Wavelet and Huffman per block of 32 scanlines: often the smallest for
    /// noisy renders.
    Piz,
}

impl ExrCompression {
    /// Every choice, in the order of [`Self::name`]s a user is offered.
    pub const ALL: [ExrCompression; 5] = [
        ExrCompression::None,
        ExrCompression::Rle,
        ExrCompression::Zips,
        ExrCompression::Zip,
        ExrCompression::Piz,
    ];

    /// The name on the command line (OpenEXR's, in lower case).
    pub fn name(self) -> &'static str {
        match self {
            ExrCompression::None => "none",
            ExrCompression::Rle => "rle",
            ExrCompression::Zips => "zips",
            ExrCompression::Zip => "zip",
            ExrCompression::Piz => "piz",
        }
    }

    /// The choice of that name.
    pub fn from_name(name: &str) -> Option<ExrCompression> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }

    fn to_exr(self) -> Compression {
        match self {
            ExrCompression::None => Compression::Uncompressed,
            ExrCompression::Rle => Compression::RLE,
            ExrCompression::Zips => Compression::ZIP1,
            ExrCompression::Zip => Compression::ZIP16,
            ExrCompression::Piz => Compression::PIZ,
        }
    }
}

/// How an EXR is written.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExrOptions {
    /// 32-bit or 16-bit floats.
    pub precision: ExrPrecision,
    /// The lossless compression.
    pub compression: ExrCompression,
    /// Text attributes for the header, (name, value). Names are ASCII, 1–31
    /// bytes, and must not be one of OpenEXR's own; values are stored as UTF-8.
    pub attributes: Vec<(String, String)>,
}

/// What went wrong writing an EXR; each names the file.
#[derive(Debug, Error)]
pub enum ExrWriteError {
    /// The `exr` crate refused the image.
    #[error("encoding OpenEXR {}: {error}", path.display())]
    Encode {
        path: PathBuf,
        error: exr::error::Error,
    },
    /// The pixels do not fill the image (a caller's mistake).
    #[error("{}: {pixels} pixels given for a {width}×{height} image", path.display())]
    PixelCount {
        path: PathBuf,
        width: usize,
        height: usize,
        pixels: usize,
    },
    /// A header attribute's name OpenEXR cannot store.
    #[error(
        "{}: the header attribute name '{name}' is not 1–31 ASCII characters without NUL",
        path.display()
    )]
    AttributeName { path: PathBuf, name: String },
    /// The file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Writes `pixels` (linear sRGB, row-major from the top-left) as an OpenEXR file
/// with R, G, B channels (no alpha), atomically ([`super::atomic`]). Values are
/// stored as they are: negative (out-of-gamut) and above-one components too.
pub fn write_linear_srgb_exr(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[LinSrgb<f32>],
    options: &ExrOptions,
) -> Result<(), ExrWriteError> {
    if pixels.len() != width * height {
        return Err(ExrWriteError::PixelCount {
            path: path.to_owned(),
            width,
            height,
            pixels: pixels.len(),
        });
    }
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in &options.attributes {
        let valid =
            !name.is_empty() && name.len() <= 31 && name.bytes().all(|b| b.is_ascii() && b != 0);
        if !valid {
            return Err(ExrWriteError::AttributeName {
                path: path.to_owned(),
                name: name.clone(),
            });
        }
        layer_attributes.other.insert(
            Text::from_slice_unchecked(name.as_bytes()),
            AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())),
        );
    }
    let channel = |name: &str, component: fn(&LinSrgb<f32>) -> f32| {
        let values = pixels.iter().map(component);
        let samples = match options.precision {
            ExrPrecision::Float => FlatSamples::F32(values.collect()),
            ExrPrecision::Half => FlatSamples::F16(values.map(f16::from_f32).collect()),
        };
        AnyChannel::new(name, samples)
    };
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        channel("R", |p| p.red),
        channel("G", |p| p.green),
        channel("B", |p| p.blue),
    ]));
    let encoding = Encoding {
        compression: options.compression.to_exr(),
        ..Encoding::UNCOMPRESSED
    };
    let size = Vec2(width, height);
    let layer = Layer::new(size, layer_attributes, encoding, channels);
    let mut image_attributes = ImageAttributes::new(IntegerBounds::from_dimensions(size));
    image_attributes.chromaticities = Some(Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    let image = Image::new(image_attributes, layer);
    let encode = |error| ExrWriteError::Encode {
        path: path.to_owned(),
        error,
    };
    let mut encoded = Cursor::new(Vec::new());
    image.write().to_buffered(&mut encoded).map_err(encode)?;
    let mut encoded = encoded.into_inner();
    canonical_attribute_order(&mut encoded)
        .map_err(|reason| encode(exr::error::Error::Invalid(reason.into())))?;
    Ok(write_bytes_atomically(path, &encoded)?)
}

/// Sorts the header attributes of a single-part file by name, in place.
///
/// The `exr` crate keeps custom attributes in a `HashMap` with a random hasher
/// and writes them in its iteration order, so two writes of the same image would
/// differ in the header's order. Sorting (as OpenEXR's own library writes them)
/// makes the bytes reproducible; the header keeps its length, so the offset table
/// after it stays right.
fn canonical_attribute_order(file: &mut [u8]) -> Result<(), &'static str> {
    // Magic number and version field (flags), then the header: attributes of
    // name\0 type\0 size(i32, little-endian) value, ended by an empty name.
    const HEADER_START: usize = 8;
    const MULTI_PART_FLAG: u32 = 0x1000;
    let version = file
        .get(4..8)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or("file shorter than its version field")?;
    if version & MULTI_PART_FLAG != 0 {
        return Err("a multi-part file where a single part was written");
    }
    let mut attributes: Vec<(&[u8], &[u8])> = Vec::new();
    let mut at = HEADER_START;
    let cstring_end = |from: usize| -> Result<usize, &'static str> {
        file[from..]
            .iter()
            .position(|&b| b == 0)
            .map(|p| from + p)
            .ok_or("unterminated attribute name")
    };
    loop {
        if *file.get(at).ok_or("header without its end")? == 0 {
            break;
        }
        let name_end = cstring_end(at)?;
        let type_end = cstring_end(name_end + 1)?;
        let size_bytes = file
            .get(type_end + 1..type_end + 5)
            .ok_or("attribute size cut off")?;
        let size = i32::from_le_bytes([size_bytes[0], size_bytes[1], size_bytes[2], size_bytes[3]]);
        let size = usize::try_from(size).map_err(|_| "negative attribute size")?;
        let end = type_end + 5 + size;
        if end > file.len() {
            return Err("attribute value cut off");
        }
        attributes.push((&file[at..name_end], &file[at..end]));
        at = end;
    }
    attributes.sort_by_key(|(name, _)| *name);
    let mut sorted = Vec::with_capacity(at - HEADER_START);
    for (_, bytes) in attributes {
        sorted.extend_from_slice(bytes);
    }
    file[HEADER_START..at].copy_from_slice(&sorted);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Caller mistakes are refused, naming the file, before anything is written.
    #[test]
    fn bad_attribute_names_and_pixel_counts_are_refused_by_name() {
        let path =
            std::env::temp_dir().join(format!("coatlab-exr-refused-{}.exr", std::process::id()));
        let pixels = vec![LinSrgb::new(0.5, 0.25, 0.125); 6];
        let error =
            write_linear_srgb_exr(&path, 4, 2, &pixels, &ExrOptions::default()).unwrap_err();
        assert!(
            matches!(error, ExrWriteError::PixelCount { pixels: 6, .. }),
            "{error}"
        );
        for name in [
            "",
            "a name far longer than thirty-one bytes",
            "nul\0inside",
            "é",
        ] {
            let options = ExrOptions {
                attributes: vec![(name.to_owned(), "value".to_owned())],
                ..ExrOptions::default()
            };
            let error = write_linear_srgb_exr(&path, 3, 2, &pixels, &options).unwrap_err();
            assert!(
                matches!(error, ExrWriteError::AttributeName { .. }),
                "{name:?}"
            );
            assert!(error.to_string().contains("coatlab-exr-refused"), "{error}");
        }
        assert!(!path.exists());
    }

    #[test]
    fn compressions_are_named_as_on_the_command_line() {
        for compression in ExrCompression::ALL {
            assert_eq!(
                ExrCompression::from_name(compression.name()),
                Some(compression)
            );
        }
        assert_eq!(ExrCompression::from_name("dwaa"), None);
        assert_eq!(ExrCompression::default(), ExrCompression::Zip);
        assert_eq!(ExrPrecision::default(), ExrPrecision::Float);
    }
}
