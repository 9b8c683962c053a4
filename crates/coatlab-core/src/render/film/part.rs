//! A film part: the sums of one range of sample indices of a render, written to a
//! `.film` file so that the ranges of one image can be rendered by separate
//! processes (on separate machines) and merged into the image one process would
//! have rendered, bit for bit.
//!
//! Why merging is exact: every pixel sample is keyed by (seed, pixel, sample
//! index) ([`crate::render::sampler`]), so a range renders the same samples
//! wherever it runs, and the film's image sums are fixed-point integers
//! ([`super::EXACT_FRACTION_BITS`]), whose addition does not depend on order.
//!
//! The format is specified in `docs/film-format.md`: a magic, a format version, a
//! TOML header ([`PartHeader`]: the program, the image, the sample range and the
//! identity of every input), the per-pixel sums, and a SHA-256 of all of it.

use std::io::{self, BufWriter, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use thiserror::Error;

use super::{BlockSums, Film, PixelSums, from_exact};
use crate::colour::spectrum::{Channels, WavelengthGrid};
use crate::io::atomic::{WriteError, write_atomically};
use crate::io::tagged::{TAGGED_HEADER_BYTES, tagged_header};

/// The first bytes of every film part.
pub const MAGIC: &[u8; 8] = b"COATFILM";
/// The version of the format this program writes and reads.
pub const FORMAT_VERSION: u32 = 1;
/// Bytes per pixel in the body: count, exact Σ X Σ Y Σ Z, Σ X² Σ Y² Σ Z², the
/// top block and its sums and the sums of the block below.
pub const PIXEL_BYTES: usize = 8 + 3 * 16 + 3 * 8 + 4 + 3 * 8 + 3 * 8;
/// Longest header accepted, bytes: a header is a few hundred; a larger length is
/// a corrupt file, not a reason to allocate.
const MAX_HEADER_BYTES: u32 = 1 << 20;

/// What one input of a render is, for the header: a name a person reads and the
/// SHA-256 of its content (hex), which is what merging compares.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identity {
    /// What a person calls it: a file path, a preset or setup name.
    pub name: String,
    /// SHA-256 of its content, 64 hex digits.
    pub sha256: String,
}

impl Identity {
    /// The identity of `bytes`, called `name`.
    pub fn of_bytes(name: impl Into<String>, bytes: &[u8]) -> Self {
        Self {
            name: name.into(),
            sha256: sha256_hex(bytes),
        }
    }
}

/// SHA-256 of `bytes` as 64 lower-case hex digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The header of a film part: everything that must match for parts to merge,
/// and the range of sample indices this part holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartHeader {
    /// The program and its version ("coatlab 0.1.0"): parts of different
    /// versions may sample differently and are not merged.
    pub program: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The film's wavelength grid; `None`: linear sRGB channels.
    pub grid: Option<WavelengthGrid>,
    /// Seed of the random numbers.
    pub seed: u64,
    /// Samples per pixel of the whole image the parts make up.
    pub total_samples: u32,
    /// First sample index of this part.
    pub sample_start: u32,
    /// One past the last sample index of this part.
    pub sample_end: u32,
    /// The scene (glTF file, or the built-in car).
    pub scene: Identity,
    /// The paint design.
    pub design: Identity,
    /// The lighting setup or environment map.
    pub lighting: Identity,
    /// Every other setting that changes the image (model, exposure, …), as the
    /// program spells them.
    pub settings: Identity,
    /// The exposure (stops) a PNG made of the parts is shown at (also part of
    /// `settings`; here as a number for the merge to use).
    pub exposure_stops: f32,
}

impl PartHeader {
    /// The sample indices of this part.
    pub fn samples(&self) -> Range<u32> {
        self.sample_start..self.sample_end
    }

    /// The film's channels.
    pub fn channels(&self) -> Channels {
        match self.grid {
            Some(grid) => Channels::Spectral(grid),
            None => Channels::LinearSrgb,
        }
    }

    /// The first field (by name) whose value differs between `self` and `other`,
    /// ignoring the sample range, with both values.
    pub fn first_difference(&self, other: &PartHeader) -> Option<(&'static str, String, String)> {
        let fields: [(&str, String, String); 10] = [
            ("program", self.program.clone(), other.program.clone()),
            (
                "size",
                format!("{}x{}", self.width, self.height),
                format!("{}x{}", other.width, other.height),
            ),
            (
                "grid",
                format!("{:?}", self.grid),
                format!("{:?}", other.grid),
            ),
            ("seed", self.seed.to_string(), other.seed.to_string()),
            (
                "total samples",
                self.total_samples.to_string(),
                other.total_samples.to_string(),
            ),
            ("scene", describe(&self.scene), describe(&other.scene)),
            ("design", describe(&self.design), describe(&other.design)),
            (
                "lighting",
                describe(&self.lighting),
                describe(&other.lighting),
            ),
            (
                "settings",
                describe(&self.settings),
                describe(&other.settings),
            ),
            (
                "exposure",
                self.exposure_stops.to_string(),
                other.exposure_stops.to_string(),
            ),
        ];
        fields.into_iter().find(|(_, a, b)| a != b)
    }
}

fn describe(identity: &Identity) -> String {
    format!(
        "{} (sha256 {})",
        identity.name,
        &identity.sha256[..identity.sha256.len().min(12)]
    )
}

/// What went wrong reading, writing or merging film parts; each names the file.
#[derive(Debug, Error)]
pub enum PartError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read { path: PathBuf, error: io::Error },
    /// The file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// The file is not a film part, or is damaged.
    #[error("{}: not a valid Coatlab film part: {why}", path.display())]
    Corrupt { path: PathBuf, why: String },
    /// A film part of a format version this program does not read.
    #[error(
        "{}: film part format version {found}; this program reads version {FORMAT_VERSION}",
        path.display()
    )]
    Version { path: PathBuf, found: u32 },
    /// The film does not fit the header (a programming error of the caller).
    #[error("{}: the film ({why}) does not match the part's header", path.display())]
    Mismatch { path: PathBuf, why: String },
    /// Nothing to merge.
    #[error("no film parts to merge")]
    NoParts,
    /// Two parts of different renders.
    #[error(
        "{} and {} are parts of different renders: {field} {a} vs {b}",
        first.display(), other.display()
    )]
    Different {
        first: PathBuf,
        other: PathBuf,
        field: &'static str,
        a: String,
        b: String,
    },
    /// Two parts hold some of the same samples.
    #[error(
        "{} (samples {}..{}) and {} (samples {}..{}) overlap",
        first.display(), a.start, a.end, other.display(), b.start, b.end
    )]
    Overlap {
        first: PathBuf,
        a: Range<u32>,
        other: PathBuf,
        b: Range<u32>,
    },
    /// Samples no part holds.
    #[error(
        "samples {}..{} of {total} are in none of the parts ({})",
        missing.start, missing.end, files.join(", ")
    )]
    Missing {
        missing: Range<u32>,
        total: u32,
        files: Vec<String>,
    },
}

/// A film part read from a file: its header and its sums as a film.
#[derive(Debug, Clone)]
pub struct FilmPart {
    /// What made it.
    pub header: PartHeader,
    /// The sums of its samples.
    pub film: Film,
}

/// Writes `film` (the sums of the samples `header` names, of a whole image) to
/// `path` atomically.
pub fn write_part(path: &Path, header: &PartHeader, film: &Film) -> Result<(), PartError> {
    let mismatch = |why: String| PartError::Mismatch {
        path: path.to_owned(),
        why,
    };
    if (film.width, film.height) != (header.width, header.height) || film.origin != [0, 0] {
        return Err(mismatch(format!(
            "{}x{} at {:?}",
            film.width, film.height, film.origin
        )));
    }
    if *film.channels() != header.channels() {
        return Err(mismatch(format!("channels {:?}", film.channels())));
    }
    let text = toml::to_string(header).map_err(|e| mismatch(format!("header: {e}")))?;
    write_atomically(path, |file| {
        let mut out = HashingWriter {
            inner: BufWriter::new(file),
            hash: Sha256::new(),
        };
        out.write_all(MAGIC)?;
        out.write_all(&FORMAT_VERSION.to_le_bytes())?;
        let length = u32::try_from(text.len())
            .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "header too long"))?;
        out.write_all(&length.to_le_bytes())?;
        out.write_all(text.as_bytes())?;
        let mut bytes = [0u8; PIXEL_BYTES];
        for i in 0..film.pixels.len() {
            encode_pixel(
                &film.pixels[i],
                &film.exact[i],
                &film.squares[i],
                &film.blocks[i],
                &mut bytes,
            );
            out.write_all(&bytes)?;
        }
        out.write_all(&film.rejected.to_le_bytes())?;
        let digest = out.hash.finalize_reset();
        out.inner.write_all(&digest)?;
        out.inner.flush()
    })?;
    Ok(())
}

/// Reads and checks a film part: the magic, the version, the header, the length
/// and the checksum.
pub fn read_part(path: &Path) -> Result<FilmPart, PartError> {
    let bytes = std::fs::read(path).map_err(|error| PartError::Read {
        path: path.to_owned(),
        error,
    })?;
    parse_part(path, &bytes)
}

/// [`read_part`] of bytes already read (`path` names them in errors).
pub fn parse_part(path: &Path, bytes: &[u8]) -> Result<FilmPart, PartError> {
    let corrupt = |why: String| PartError::Corrupt {
        path: path.to_owned(),
        why,
    };
    let Some([version, header_len]) = tagged_header(bytes, MAGIC) else {
        return Err(corrupt("it does not start with COATFILM".into()));
    };
    if version != FORMAT_VERSION {
        return Err(PartError::Version {
            path: path.to_owned(),
            found: version,
        });
    }
    if header_len > MAX_HEADER_BYTES || TAGGED_HEADER_BYTES + header_len as usize > bytes.len() {
        return Err(corrupt(format!(
            "a header of {header_len} bytes in a file of {} (truncated?)",
            bytes.len()
        )));
    }
    let body_start = TAGGED_HEADER_BYTES + header_len as usize;
    let text = std::str::from_utf8(&bytes[TAGGED_HEADER_BYTES..body_start])
        .map_err(|_| corrupt("the header is not UTF-8".into()))?;
    let header: PartHeader =
        toml::from_str(text).map_err(|e| corrupt(format!("the header: {e}")))?;
    let pixels = header.width as usize * header.height as usize;
    let expected = pixels
        .checked_mul(PIXEL_BYTES)
        .and_then(|b| b.checked_add(body_start + 8 + 32));
    if expected != Some(bytes.len()) {
        return Err(corrupt(format!(
            "{} bytes, but a {}x{} part has {} (truncated or padded)",
            bytes.len(),
            header.width,
            header.height,
            expected.map_or("more than memory holds".into(), |e| e.to_string())
        )));
    }
    let (content, digest) = bytes.split_at(bytes.len() - 32);
    if Sha256::digest(content).as_slice() != digest {
        return Err(corrupt(
            "its checksum does not match its content (damaged)".into(),
        ));
    }
    if header.width == 0 || header.height == 0 {
        return Err(corrupt("the image has no pixels".into()));
    }
    if let Some(grid) = header.grid {
        WavelengthGrid::new(grid.start_nm(), grid.step_nm(), grid.len())
            .map_err(|e| corrupt(format!("the grid: {e}")))?;
    }
    if header.sample_start >= header.sample_end || header.sample_end > header.total_samples {
        return Err(corrupt(format!(
            "sample range {}..{} is not inside 0..{}",
            header.sample_start, header.sample_end, header.total_samples
        )));
    }
    let mut film = Film::new(header.width, header.height, header.channels());
    for (i, chunk) in content[body_start..body_start + pixels * PIXEL_BYTES]
        .chunks_exact(PIXEL_BYTES)
        .enumerate()
    {
        decode_pixel(
            chunk,
            &mut film.pixels[i],
            &mut film.exact[i],
            &mut film.squares[i],
            &mut film.blocks[i],
        );
    }
    let at = body_start + pixels * PIXEL_BYTES;
    film.rejected = u64::from_le_bytes(content[at..at + 8].try_into().unwrap_or_default());
    Ok(FilmPart { header, film })
}

/// Merges the parts in `paths` (read one at a time) into the film of the whole
/// render: they must come from the same render (every header field but the
/// range equal) and their ranges must cover 0 .. total samples once each.
/// Returns the film and the common header (with the whole range).
pub fn merge_parts(paths: &[PathBuf]) -> Result<(PartHeader, Film), PartError> {
    let (first_path, rest) = paths.split_first().ok_or(PartError::NoParts)?;
    let first = read_part(first_path)?;
    let mut header = first.header;
    let mut film = first.film;
    let mut ranges = vec![(header.samples(), first_path.clone())];
    for path in rest {
        let part = read_part(path)?;
        if let Some((field, a, b)) = header.first_difference(&part.header) {
            return Err(PartError::Different {
                first: first_path.clone(),
                other: path.clone(),
                field,
                a,
                b,
            });
        }
        film.merge(&part.film);
        ranges.push((part.header.samples(), path.clone()));
    }
    ranges.sort_by_key(|(range, _)| (range.start, range.end));
    let mut next = 0;
    for (i, (range, path)) in ranges.iter().enumerate() {
        if range.start < next {
            let (previous, previous_path) = &ranges[i - 1];
            return Err(PartError::Overlap {
                first: previous_path.clone(),
                a: previous.clone(),
                other: path.clone(),
                b: range.clone(),
            });
        }
        if range.start > next {
            return Err(missing(next..range.start, &header, &ranges));
        }
        next = range.end;
    }
    if next < header.total_samples {
        return Err(missing(next..header.total_samples, &header, &ranges));
    }
    header.sample_start = 0;
    header.sample_end = header.total_samples;
    Ok((header, film))
}

fn missing(range: Range<u32>, header: &PartHeader, parts: &[(Range<u32>, PathBuf)]) -> PartError {
    PartError::Missing {
        missing: range,
        total: header.total_samples,
        files: parts
            .iter()
            .map(|(r, p)| format!("{}: {}..{}", p.display(), r.start, r.end))
            .collect(),
    }
}

fn encode_pixel(
    pixel: &PixelSums,
    exact: &[i128; 3],
    squares: &[f64; 3],
    blocks: &BlockSums,
    out: &mut [u8; PIXEL_BYTES],
) {
    let mut at = 0;
    let mut put = |bytes: &[u8]| {
        out[at..at + bytes.len()].copy_from_slice(bytes);
        at += bytes.len();
    };
    put(&pixel.count.to_le_bytes());
    exact.iter().for_each(|v| put(&v.to_le_bytes()));
    squares.iter().for_each(|v| put(&v.to_le_bytes()));
    put(&blocks.top.to_le_bytes());
    blocks.top_sum.iter().for_each(|v| put(&v.to_le_bytes()));
    blocks.below_sum.iter().for_each(|v| put(&v.to_le_bytes()));
}

fn decode_pixel(
    bytes: &[u8],
    pixel: &mut PixelSums,
    exact: &mut [i128; 3],
    squares: &mut [f64; 3],
    blocks: &mut BlockSums,
) {
    let mut at = 0;
    let mut take = |n: usize| {
        let slice = &bytes[at..at + n];
        at += n;
        slice
    };
    let u64_of = |b: &[u8]| u64::from_le_bytes(b.try_into().unwrap_or_default());
    pixel.count = u64_of(take(8));
    for v in exact.iter_mut() {
        *v = i128::from_le_bytes(take(16).try_into().unwrap_or_default());
    }
    for v in squares.iter_mut() {
        *v = f64::from_bits(u64_of(take(8)));
    }
    blocks.top = u32::from_le_bytes(take(4).try_into().unwrap_or_default());
    for v in blocks.top_sum.iter_mut() {
        *v = f64::from_bits(u64_of(take(8)));
    }
    for v in blocks.below_sum.iter_mut() {
        *v = f64::from_bits(u64_of(take(8)));
    }
    pixel.sum = exact.map(from_exact);
}

/// A writer that hashes what passes through it.
struct HashingWriter<W: Write> {
    inner: W,
    hash: Sha256,
}

impl<W: Write> Write for HashingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let written = self.inner.write(buf)?;
        self.hash.update(&buf[..written]);
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::WavelengthGrid;

    fn header(range: Range<u32>) -> PartHeader {
        PartHeader {
            program: "coatlab test".into(),
            width: 3,
            height: 2,
            grid: Some(WavelengthGrid::visible(4).unwrap()),
            seed: 7,
            total_samples: 6,
            sample_start: range.start,
            sample_end: range.end,
            scene: Identity::of_bytes("scene", b"s"),
            design: Identity::of_bytes("design", b"d"),
            lighting: Identity::of_bytes("studio", b"studio"),
            settings: Identity::of_bytes("paint", b"paint"),
            exposure_stops: 0.0,
        }
    }

    /// The radiance of sample `s` of pixel (`x`, `y`): values near 1 and near
    /// 2⁻³⁰ with assorted mantissas, so that f64 sums of them round, and round
    /// differently in different orders.
    fn radiance(x: u32, y: u32, s: u32) -> [f32; 4] {
        let mantissa = 1.0 + ((x * 7 + y * 3 + s * 13) % 23) as f32 / 23.0;
        let v = mantissa * 2f32.powi(-30 * ((s + x + y) % 2) as i32);
        [v; 4]
    }

    /// A film of samples `range` of [`radiance`].
    fn film(range: Range<u32>) -> Film {
        let mut film = Film::new(3, 2, WavelengthGrid::visible(4).unwrap());
        for s in range {
            for y in 0..2 {
                for x in 0..3 {
                    film.add_sample_indexed(x, y, u64::from(s), &radiance(x, y, s));
                }
            }
        }
        film
    }

    #[test]
    fn parts_round_trip_and_merge_to_the_whole_film_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let paths: Vec<PathBuf> = [0..1, 1..4, 4..6]
            .into_iter()
            .enumerate()
            .map(|(i, range)| {
                let path = dir.path().join(format!("p{i}.film"));
                write_part(&path, &header(range.clone()), &film(range)).unwrap();
                path
            })
            .collect();
        let (merged_header, merged) =
            merge_parts(&[paths[2].clone(), paths[0].clone(), paths[1].clone()]).unwrap();
        assert_eq!(merged_header.samples(), 0..6);
        let whole = film(0..6);
        // The data can tell: plain f64 sums of the parts, added part by part, are
        // not the f64 sum of all samples in order for some pixel.
        let xyz = |x, y, s| whole.xyz_of(&radiance(x, y, s)).y;
        let in_order = |x, y, r: Range<u32>| r.fold(0.0, |sum, s| sum + xyz(x, y, s));
        let differs = (0..2).any(|y| {
            (0..3).any(|x| {
                let by_parts = [0..1, 1..4, 4..6]
                    .into_iter()
                    .fold(0.0, |sum, r| sum + in_order(x, y, r));
                by_parts != in_order(x, y, 0..6)
            })
        });
        assert!(differs, "the test data must make f64 sums depend on order");
        assert_eq!(merged.exact, whole.exact);
        assert_eq!(merged.pixels, whole.pixels);
        assert_eq!(merged.linear_srgb_image(), whole.linear_srgb_image());
    }

    #[test]
    fn damaged_truncated_and_foreign_files_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.film");
        write_part(&path, &header(0..6), &film(0..6)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let cases: [(&str, Vec<u8>, &str); 4] = [
            (
                "truncated",
                bytes[..bytes.len() - 100].to_vec(),
                "truncated",
            ),
            (
                "magic",
                b"NOTAFILM".iter().chain(&bytes[8..]).copied().collect(),
                "COATFILM",
            ),
            (
                "flipped",
                {
                    let mut b = bytes.clone();
                    let i = b.len() - 200;
                    b[i] ^= 1;
                    b
                },
                "checksum",
            ),
            (
                "version",
                {
                    let mut b = bytes.clone();
                    b[8] = 9;
                    b
                },
                "version 9",
            ),
        ];
        for (what, bytes, expected) in cases {
            let message = parse_part(&path, &bytes).unwrap_err().to_string();
            assert!(
                message.contains(expected) && message.contains("p.film"),
                "{what}: {message}"
            );
        }
    }

    #[test]
    fn parts_of_other_renders_gaps_and_overlaps_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, header: PartHeader| {
            let path = dir.path().join(name);
            let range = header.samples();
            write_part(&path, &header, &film(range)).unwrap();
            path
        };
        let a = write("a.film", header(0..3));
        let b = write("b.film", header(3..6));
        let overlapping = write("c.film", header(2..6));
        let short = write("d.film", header(4..6));
        let other_seed = write(
            "e.film",
            PartHeader {
                seed: 8,
                ..header(3..6)
            },
        );
        let other_design = write(
            "f.film",
            PartHeader {
                design: Identity::of_bytes("design", b"other"),
                ..header(3..6)
            },
        );
        let other_program = write(
            "g.film",
            PartHeader {
                program: "coatlab 9.9.9".into(),
                ..header(3..6)
            },
        );
        let other_grid = dir.path().join("h.film");
        let five = WavelengthGrid::visible(5).unwrap();
        let grid_header = PartHeader {
            grid: Some(five),
            ..header(3..6)
        };
        write_part(&other_grid, &grid_header, &Film::new(3, 2, five)).unwrap();
        let message = |paths: &[&PathBuf]| {
            let paths: Vec<PathBuf> = paths.iter().map(|p| (*p).clone()).collect();
            merge_parts(&paths).unwrap_err().to_string()
        };
        assert!(merge_parts(&[a.clone(), b.clone()]).is_ok());
        let m = message(&[&a, &overlapping]);
        assert!(
            m.contains("overlap") && m.contains("a.film") && m.contains("c.film"),
            "{m}"
        );
        let m = message(&[&a, &short]);
        assert!(m.contains("samples 3..4 of 6"), "{m}");
        let m = message(&[&a]);
        assert!(m.contains("samples 3..6"), "{m}");
        let m = message(&[&a, &other_seed]);
        assert!(m.contains("seed 7 vs 8") && m.contains("e.film"), "{m}");
        let m = message(&[&a, &other_program]);
        assert!(
            m.contains("program coatlab test vs coatlab 9.9.9") && m.contains("g.film"),
            "{m}"
        );
        let m = message(&[&a, &other_grid]);
        assert!(m.contains("grid") && m.contains("h.film"), "{m}");
        let m = message(&[&a, &other_design]);
        assert!(m.contains("design") && m.contains("f.film"), "{m}");
    }
}
