//! `coatlab color`: CIE XYZ and CIELAB of measured spectra (spec section 6).
//!
//! Plain summation at the file's own wavelengths — the way a spectrophotometer
//! report is computed — rather than the renderer's grid colorimeter, so nothing is
//! resampled.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use coatlab_core::colour::cie::{Illuminant, Observer, summation_weights};
use coatlab_core::colour::lab_from_xyz;
use coatlab_core::colour::spectrum::{ValueBounds, read_spectra_csv};

use super::failure::{Classify, Failure};

/// Reflectance factors above 1 are allowed up to this value: fluorescent samples and
/// measurement noise on near-white samples exceed 1 a little, while 1.5 still
/// catches percentages (50 for 0.5) and other unit mistakes.
const MAX_REFLECTANCE_FACTOR: f64 = 1.5;

#[derive(clap::Args, Debug)]
pub struct ColorArgs {
    /// Illuminant: D65, D50, A, F2, F7 or F11 (case-insensitive).
    #[arg(long, default_value = "D65")]
    pub illuminant: Illuminant,
    /// Standard observer: 2 (CIE 1931) or 10 (CIE 1964); "2deg"/"10deg" also work.
    #[arg(long, default_value = "10")]
    pub observer: Observer,
    /// CSV file with a `wavelength_nm` column and one column of reflectance factors
    /// (0 to 1.5) per sample; prints `name,X,Y,Z,L,a,b` per sample.
    pub file: PathBuf,
}

pub fn run(args: &ColorArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let file_name = args.file.display().to_string();
    // Read whole (spectra files are small), so that a file that cannot be read
    // (missing, a folder, no permission) is told from one whose content is bad.
    let bytes = std::fs::read(&args.file)
        .with_context(|| format!("cannot read {file_name}"))
        .or_fail(Failure::NoInput)?;
    let bounds = ValueBounds::new(0.0, MAX_REFLECTANCE_FACTOR).or_fail(Failure::Internal)?;
    let spectra = read_spectra_csv(bytes.as_slice(), &file_name, bounds)?;
    let weights = summation_weights(args.illuminant, args.observer, &spectra.wavelengths_nm)
        .with_context(|| format!("{file_name}: cannot compute colour"))?;

    let mut writer = csv::Writer::from_writer(out);
    writer
        .write_record(["name", "X", "Y", "Z", "L", "a", "b"])
        .or_fail(Failure::Io)?;
    for (name, values) in &spectra.samples {
        let xyz = weights.xyz(values);
        let lab = lab_from_xyz(xyz, weights.white());
        let numbers = [xyz.x, xyz.y, xyz.z, lab.l, lab.a, lab.b].map(|v| v.to_string());
        writer
            .write_record(std::iter::once(name.as_str()).chain(numbers.iter().map(String::as_str)))
            .or_fail(Failure::Io)?;
    }
    writer.flush().or_fail(Failure::Io)?;
    Ok(())
}
