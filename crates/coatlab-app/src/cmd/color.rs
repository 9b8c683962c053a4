//! `coatlab color`: CIE XYZ and CIELAB of measured spectra (spec section 6), from
//! a CSV of spectra or a spectrophotometer file (CGATS.17 text, CxF3 XML).
//!
//! Plain summation at the file's own wavelengths — the way a spectrophotometer
//! report is computed — rather than the renderer's grid colorimeter, so nothing is
//! resampled. A reading with no spectrum (a Lab- or XYZ-only file) is printed as
//! the file states it, if it states it under the illuminant and observer asked for.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use coatlab_core::colour::cie::{Illuminant, Observer, summation_weights};
use coatlab_core::colour::spectrum::{ValueBounds, read_spectra_csv};
use coatlab_core::colour::{lab_from_xyz, xyz_from_lab};
use coatlab_core::measurement::{self, LabSource, white_of};

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
    /// (0 to 1.5) per sample: prints `name,X,Y,Z,L,a,b` per sample. Or a CGATS.17 or
    /// CxF3 measurement file: prints `name,geometry,X,Y,Z,L,a,b` per reading.
    pub file: PathBuf,
}

pub fn run(args: &ColorArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let file_name = args.file.display().to_string();
    // Read whole (spectra files are small), so that a file that cannot be read
    // (missing, a folder, no permission) is told from one whose content is bad.
    let bytes = std::fs::read(&args.file)
        .with_context(|| format!("cannot read {file_name}"))
        .or_fail(Failure::NoInput)?;
    if measurement::sniff(&bytes).is_some() {
        return run_measurement(args, &bytes, &file_name, out);
    }
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

/// `color` of a CGATS or CxF3 file: one row per reading, with its geometry.
fn run_measurement(
    args: &ColorArgs,
    bytes: &[u8],
    file_name: &str,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let m = measurement::read(bytes, file_name).or_fail(Failure::Data)?;
    if let Some(scale) = &m.reflectance_scale {
        to_stderr(format_args!("coatlab: note: {file_name}: {scale}\n"));
    }
    let white = white_of(args.illuminant, args.observer);
    let mut writer = csv::Writer::from_writer(out);
    writer
        .write_record(["name", "geometry", "X", "Y", "Z", "L", "a", "b"])
        .or_fail(Failure::Io)?;
    let mut assumed = false;
    for sample in m
        .samples
        .iter()
        .filter(|s| s.spectrum.is_some() || s.colour.is_some())
    {
        let (xyz, lab) = match &sample.spectrum {
            Some(spectrum) => {
                let weights =
                    summation_weights(args.illuminant, args.observer, spectrum.wavelengths_nm())
                        .with_context(|| format!("{file_name}: cannot compute colour"))?;
                let xyz = weights.xyz(spectrum.factors());
                (xyz, lab_from_xyz(xyz, weights.white()))
            }
            None => {
                let (lab, source) = sample
                    .lab(args.illuminant, args.observer)
                    .with_context(|| file_name.to_owned())
                    .or_fail(Failure::Data)?;
                assumed |= source == LabSource::StatedAssumed;
                (xyz_from_lab(lab, white), lab)
            }
        };
        let numbers = [xyz.x, xyz.y, xyz.z, lab.l, lab.a, lab.b].map(|v| v.to_string());
        let geometry = sample.geometry.to_string();
        writer
            .write_record(
                [sample.name.as_str(), geometry.as_str()]
                    .into_iter()
                    .chain(numbers.iter().map(String::as_str)),
            )
            .or_fail(Failure::Io)?;
    }
    writer.flush().or_fail(Failure::Io)?;
    if assumed {
        to_stderr(format_args!(
            "coatlab: note: {file_name} does not name the illuminant and observer of its colours; \
             {}/{} assumed\n",
            args.illuminant, args.observer
        ));
    }
    Ok(())
}

/// Writes to standard error, ignoring failure (a closed stderr is no reason to
/// fail a colour computation).
fn to_stderr(text: std::fmt::Arguments) {
    let _ = std::io::stderr().write_fmt(text);
}
