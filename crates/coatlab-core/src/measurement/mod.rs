//! Spectrophotometer files: CGATS.17 / ASTM E1708 text ([`cgats`]) and X-Rite CxF3
//! XML ([`cxf`]), read into one [`Measurement`].
//!
//! A measurement is a list of readings ([`Sample`]): each with a name, the
//! [`Geometry`] it was taken at, a reflectance spectrum on its own wavelengths
//! (always as fractions, whatever the file used) and/or a colour the file states
//! (CIELAB or XYZ, with the illuminant and observer where the file gives them), and
//! gloss readings where the file has them. A multi-angle standard is several
//! readings of the same name at different geometries; [`Measurement::standards`]
//! groups them. The variants each reader accepts, and its conventions, are in
//! `docs/measurements.md`. A CSV of spectra ([`spectra_csv`]) is read the same
//! way at a geometry the caller states.

pub mod cgats;
pub mod cgats_write;
pub mod cxf;
pub mod cxf_write;
pub mod geometry;
pub mod spectra_csv;

use std::fmt;

use crate::colour::cie::{Colorimeter, Illuminant, Observer, summation_weights};
use crate::colour::spectrum::WavelengthGrid;
use crate::colour::{Lab, Xyz, lab_from_xyz};

pub use geometry::{Geometry, GeometryError, SpecularComponent, parse_geometry};

/// The shortest and longest wavelengths a reading may have, nm: the range of the
/// CIE tables (CIE 15:2004).
pub const WAVELENGTH_RANGE_NM: (f64, f64) = (360.0, 830.0);
/// The smallest reflectance factor accepted: instrument noise on a black sample
/// reads a little below zero at the ends of the range.
pub const MIN_REFLECTANCE_FACTOR: f64 = -0.05;
/// The largest reflectance factor accepted: fluorescent samples and noise on near
/// whites exceed 1 a little; 1.5 still catches a unit mistake.
pub const MAX_REFLECTANCE_FACTOR: f64 = 1.5;

/// The file formats read here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Format {
    /// CGATS.17 / ASTM E1708 text.
    Cgats,
    /// X-Rite CxF3 XML.
    Cxf3,
    /// A CSV of spectra ([`spectra_csv`]), at a geometry the reader states.
    SpectraCsv,
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Cgats => "CGATS",
            Format::Cxf3 => "CxF3",
            Format::SpectraCsv => "spectral CSV",
        })
    }
}

/// How a file wrote its reflectance values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ReflectanceScale {
    /// 0 to 1.
    Fraction,
    /// 0 to 100.
    Percent,
}

/// What told the reader the scale.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleEvidence {
    /// A header keyword and its value, as written.
    Header(String),
    /// The largest value in the file (above [`PERCENT_THRESHOLD`]: percent).
    Data { max: f64 },
}

/// Reflectance values above this can only be percent: no real sample reflects
/// twice the light of the perfect white diffuser.
pub const PERCENT_THRESHOLD: f64 = 2.0;

/// The scale a file's reflectances were found in, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ScaleFound {
    pub scale: ReflectanceScale,
    pub evidence: ScaleEvidence,
}

impl fmt::Display for ScaleFound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scale = match self.scale {
            ReflectanceScale::Fraction => "fractions (0–1)",
            ReflectanceScale::Percent => "percent (0–100)",
        };
        match &self.evidence {
            ScaleEvidence::Header(keyword) => {
                write!(f, "reflectance in {scale}, as the header says ({keyword})")
            }
            ScaleEvidence::Data { max } => write!(
                f,
                "reflectance in {scale}, judged from the data (largest value {max}; above {PERCENT_THRESHOLD} means percent)"
            ),
        }
    }
}

/// A reflectance-factor spectrum on its own wavelengths, as fractions.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Reflectance {
    wavelengths_nm: Vec<f64>,
    factors: Vec<f64>,
}

/// Why a spectrum is not a valid reading.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumProblem {
    #[error("{wavelengths} wavelengths but {values} values")]
    LengthMismatch { wavelengths: usize, values: usize },
    #[error("no wavelengths")]
    Empty,
    #[error("wavelength {0} nm is outside 360–830 nm (the CIE tables' range)")]
    OutOfRange(f64),
    #[error("wavelengths must increase: {0} nm follows {1} nm")]
    NotIncreasing(f64, f64),
    #[error(
        "reflectance factor {value} at {wavelength_nm} nm is outside {MIN_REFLECTANCE_FACTOR}–{MAX_REFLECTANCE_FACTOR}"
    )]
    ValueOutOfRange { wavelength_nm: f64, value: f64 },
}

impl Reflectance {
    /// A spectrum of fractions; errors name the first bad wavelength or value.
    pub fn new(wavelengths_nm: Vec<f64>, factors: Vec<f64>) -> Result<Self, SpectrumProblem> {
        if wavelengths_nm.len() != factors.len() {
            return Err(SpectrumProblem::LengthMismatch {
                wavelengths: wavelengths_nm.len(),
                values: factors.len(),
            });
        }
        if wavelengths_nm.is_empty() {
            return Err(SpectrumProblem::Empty);
        }
        let (lo, hi) = WAVELENGTH_RANGE_NM;
        for (i, (&nm, &value)) in wavelengths_nm.iter().zip(&factors).enumerate() {
            if !(lo..=hi).contains(&nm) {
                return Err(SpectrumProblem::OutOfRange(nm));
            }
            if i > 0 && nm <= wavelengths_nm[i - 1] {
                return Err(SpectrumProblem::NotIncreasing(nm, wavelengths_nm[i - 1]));
            }
            if !(MIN_REFLECTANCE_FACTOR..=MAX_REFLECTANCE_FACTOR).contains(&value) {
                return Err(SpectrumProblem::ValueOutOfRange {
                    wavelength_nm: nm,
                    value,
                });
            }
        }
        Ok(Self {
            wavelengths_nm,
            factors,
        })
    }

    /// A uniform spectrum from `start_nm` in steps of `step_nm`.
    pub fn uniform(
        start_nm: f64,
        step_nm: f64,
        factors: Vec<f64>,
    ) -> Result<Self, SpectrumProblem> {
        let wavelengths_nm = (0..factors.len())
            .map(|i| start_nm + step_nm * i as f64)
            .collect();
        Self::new(wavelengths_nm, factors)
    }

    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// Reflectance factors, fractions.
    pub fn factors(&self) -> &[f64] {
        &self.factors
    }

    /// The factor at `wavelength_nm`, linear between samples, the end value held
    /// beyond them.
    pub fn at_nm(&self, wavelength_nm: f64) -> f64 {
        interpolate(&self.wavelengths_nm, &self.factors, wavelength_nm)
    }
}

/// `values` (on increasing `wavelengths_nm`) at `wavelength_nm`: linear between
/// samples, the end value held beyond them.
pub fn interpolate(wavelengths_nm: &[f64], values: &[f64], wavelength_nm: f64) -> f64 {
    let n = wavelengths_nm.len();
    if wavelength_nm <= wavelengths_nm[0] {
        return values[0];
    }
    if wavelength_nm >= wavelengths_nm[n - 1] {
        return values[n - 1];
    }
    let upper = wavelengths_nm.partition_point(|&w| w < wavelength_nm);
    let (w0, w1) = (wavelengths_nm[upper - 1], wavelengths_nm[upper]);
    let t = (wavelength_nm - w0) / (w1 - w0);
    values[upper - 1] + t * (values[upper] - values[upper - 1])
}

/// A colour as the file states it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StatedValue {
    Lab(Lab),
    /// Tristimulus values, white at Y = 100.
    Xyz(Xyz),
}

/// A colour the file states, with the conditions it names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatedColour {
    pub value: StatedValue,
    pub illuminant: Option<Illuminant>,
    pub observer: Option<Observer>,
}

/// One gloss reading.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GlossValue {
    /// Glossmeter geometry, degrees (20, 60, 85).
    pub angle_deg: f64,
    /// Gloss units.
    pub gu: f64,
}

/// One reading of a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// The sample's name (without any geometry suffix it carried).
    pub name: String,
    /// An identifier beside the name, where the file has both.
    pub id: Option<String>,
    pub geometry: Geometry,
    pub spectrum: Option<Reflectance>,
    pub colour: Option<StatedColour>,
    pub gloss: Vec<GlossValue>,
}

/// Where a sample's CIELAB came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LabSource {
    /// Computed from the spectrum (ASTM E308-style summation at its wavelengths).
    Spectrum,
    /// As the file states it, under the conditions it names.
    Stated,
    /// As the file states it; the file names no illuminant or observer, so those
    /// asked for are assumed.
    StatedAssumed,
}

/// Why a sample has no colour under the conditions asked for.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SampleColourError {
    #[error(
        "sample {name:?} has no spectrum, and its stated colour is under {stated}, not {wanted}; \
         a colour cannot be moved to another illuminant without a spectrum"
    )]
    OtherConditions {
        name: String,
        stated: String,
        wanted: String,
    },
    #[error("sample {name:?} has neither a spectrum nor a colour")]
    NoColour { name: String },
    #[error("sample {name:?}: {error}")]
    Cie {
        name: String,
        error: crate::colour::cie::CieError,
    },
}

fn conditions(illuminant: Option<Illuminant>, observer: Option<Observer>) -> String {
    let i = illuminant.map_or("an unstated illuminant".to_owned(), |i| i.to_string());
    let o = observer.map_or("an unstated observer".to_owned(), |o| o.to_string());
    format!("{i}/{o}")
}

impl Sample {
    /// CIELAB under `illuminant` and `observer`: from the spectrum where there is
    /// one, else the stated colour if its conditions are these (or unstated).
    pub fn lab(
        &self,
        illuminant: Illuminant,
        observer: Observer,
    ) -> Result<(Lab, LabSource), SampleColourError> {
        if let Some(spectrum) = &self.spectrum {
            let weights = summation_weights(illuminant, observer, spectrum.wavelengths_nm())
                .map_err(|error| SampleColourError::Cie {
                    name: self.name.clone(),
                    error,
                })?;
            return Ok((weights.lab(spectrum.factors()), LabSource::Spectrum));
        }
        let Some(stated) = self.colour else {
            return Err(SampleColourError::NoColour {
                name: self.name.clone(),
            });
        };
        let matches = stated.illuminant.is_none_or(|i| i == illuminant)
            && stated.observer.is_none_or(|o| o == observer);
        if !matches {
            return Err(SampleColourError::OtherConditions {
                name: self.name.clone(),
                stated: conditions(stated.illuminant, stated.observer),
                wanted: conditions(Some(illuminant), Some(observer)),
            });
        }
        let source = if stated.illuminant.is_some() && stated.observer.is_some() {
            LabSource::Stated
        } else {
            LabSource::StatedAssumed
        };
        let lab = match stated.value {
            StatedValue::Lab(lab) => lab,
            StatedValue::Xyz(xyz) => lab_from_xyz(xyz, white_of(illuminant, observer)),
        };
        Ok((lab, source))
    }
}

/// The white (Y = 100) of `illuminant` and `observer` on the 5 nm tables.
pub fn white_of(illuminant: Illuminant, observer: Observer) -> Xyz {
    Colorimeter::new(illuminant, observer, &WavelengthGrid::reference()).white()
}

/// The readings of one file.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    pub format: Format,
    pub samples: Vec<Sample>,
    /// The scale the reflectances were written in; `None` without spectra.
    pub reflectance_scale: Option<ScaleFound>,
}

/// The readings of one standard (one name, any number of geometries).
#[derive(Debug, Clone, PartialEq)]
pub struct Standard<'a> {
    pub name: &'a str,
    pub readings: Vec<&'a Sample>,
}

/// Why readings cannot be written as a measurement file ([`cgats_write`],
/// [`cxf_write`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReadingsWriteError {
    #[error("nothing to write: no reading has a spectrum")]
    Empty,
    #[error("sample {name:?} at {geometry}: {why}")]
    Unwritable {
        name: String,
        geometry: Geometry,
        why: &'static str,
    },
}

/// Why `--sample` finds nothing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SelectError {
    #[error("the file has no sample")]
    Empty,
    #[error("the file has {} samples ({}); choose one by name or number (from 1)", .0.len(), .0.join(", "))]
    Ambiguous(Vec<String>),
    #[error("no sample {key:?}: the file has {}", names.join(", "))]
    NotFound { key: String, names: Vec<String> },
}

impl Measurement {
    /// The readings grouped by sample name, in the order names first appear.
    pub fn standards(&self) -> Vec<Standard<'_>> {
        let mut out: Vec<Standard<'_>> = Vec::new();
        for sample in &self.samples {
            match out.iter_mut().find(|s| s.name == sample.name) {
                Some(standard) => standard.readings.push(sample),
                None => out.push(Standard {
                    name: &sample.name,
                    readings: vec![sample],
                }),
            }
        }
        out
    }

    /// The standard named `key` (by name, then by id), else the `key`-th counting
    /// from 1; with no key, the only standard.
    pub fn select(&self, key: Option<&str>) -> Result<Standard<'_>, SelectError> {
        let standards = self.standards();
        let names = || standards.iter().map(|s| s.name.to_owned()).collect();
        let Some(key) = key else {
            return match standards.len() {
                0 => Err(SelectError::Empty),
                1 => Ok(standards[0].clone()),
                _ => Err(SelectError::Ambiguous(names())),
            };
        };
        let by_name = standards.iter().find(|s| s.name == key).or_else(|| {
            standards
                .iter()
                .find(|s| s.readings.iter().any(|r| r.id.as_deref() == Some(key)))
        });
        let by_index = || {
            key.parse::<usize>()
                .ok()
                .and_then(|i| i.checked_sub(1))
                .and_then(|i| standards.get(i))
        };
        by_name
            .or_else(by_index)
            .cloned()
            .ok_or_else(|| SelectError::NotFound {
                key: key.to_owned(),
                names: names(),
            })
    }
}

/// What is wrong with a reading in a file of any format; the readers place it
/// (line, element).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReadingProblem {
    #[error("{what} is {text:?}, not a number")]
    NotANumber { what: String, text: String },
    #[error("{0}")]
    Geometry(#[from] GeometryError),
    #[error("{0}")]
    Spectrum(#[from] SpectrumProblem),
    #[error("{0}")]
    Scale(#[from] ScaleConflict),
    #[error(
        "the colours are stated under illuminant {0:?}, which Coatlab does not have \
         (D65, D50, A, F2, F7, F11), and there are no spectra to compute them from"
    )]
    UnknownIlluminant(String),
}

/// `text` (spaces around it allowed) as a finite number; `what` names the value in
/// the refusal.
pub(crate) fn parse_number(what: &str, text: &str) -> Result<f64, ReadingProblem> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| ReadingProblem::NotANumber {
            what: what.to_owned(),
            text: text.to_owned(),
        })
}

/// Why a measurement file is refused; each names the file and where in it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasurementError {
    #[error("{file}, line {line}: {problem}")]
    Cgats {
        file: String,
        line: usize,
        problem: cgats::CgatsProblem,
    },
    #[error("{file}, line {line}, element <{element}>: {problem}")]
    Cxf {
        file: String,
        line: u32,
        element: String,
        problem: cxf::CxfProblem,
    },
    #[error("{file}: not well-formed XML: {message}")]
    Xml { file: String, message: String },
    #[error("{file}: {problem}")]
    File { file: String, problem: FileProblem },
}

/// A problem of the file as a whole.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FileProblem {
    #[error("not UTF-8 text (byte {0})")]
    NotText(usize),
    #[error("the file is empty")]
    Empty,
    #[error("no samples in the file")]
    NoSamples,
    #[error("neither CGATS (no BEGIN_DATA_FORMAT) nor CxF3 XML (does not start with '<')")]
    UnknownFormat,
}

/// Whether `bytes` look like a measurement file this module reads (CxF3 or CGATS),
/// as opposed to a CSV of spectra.
pub fn sniff(bytes: &[u8]) -> Option<Format> {
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(64 * 1024)]);
    let text = text.trim_start_matches('\u{feff}').trim_start();
    if text.starts_with('<') {
        Some(Format::Cxf3)
    } else if text
        .lines()
        .any(|l| l.trim().eq_ignore_ascii_case("BEGIN_DATA_FORMAT"))
    {
        Some(Format::Cgats)
    } else {
        None
    }
}

/// Reads a CGATS or CxF3 file (told apart by [`sniff`]); `file` names it in errors.
pub fn read(bytes: &[u8], file: &str) -> Result<Measurement, MeasurementError> {
    let file_error = |problem| MeasurementError::File {
        file: file.to_owned(),
        problem,
    };
    let text = std::str::from_utf8(bytes)
        .map_err(|e| file_error(FileProblem::NotText(e.valid_up_to())))?;
    let text = text.trim_start_matches('\u{feff}');
    if text.trim().is_empty() {
        return Err(file_error(FileProblem::Empty));
    }
    let measurement = match sniff(text.as_bytes()) {
        Some(Format::Cxf3) => cxf::read_cxf(text, file)?,
        Some(Format::Cgats) => cgats::read_cgats(text, file)?,
        // `sniff` never answers SpectraCsv: a CSV needs its geometry stated
        // (`spectra_csv::read_spectra_measurement`).
        Some(Format::SpectraCsv) | None => return Err(file_error(FileProblem::UnknownFormat)),
    };
    if measurement.samples.is_empty() {
        return Err(file_error(FileProblem::NoSamples));
    }
    Ok(measurement)
}

/// Decides the scale of a file's reflectances from a header statement (if any) and
/// the largest value; errors if the two disagree.
pub(crate) fn decide_scale(
    header: Option<(ReflectanceScale, String)>,
    max: f64,
) -> Result<ScaleFound, ScaleConflict> {
    let from_data = if max > PERCENT_THRESHOLD {
        ReflectanceScale::Percent
    } else {
        ReflectanceScale::Fraction
    };
    match header {
        Some((ReflectanceScale::Fraction, keyword)) if from_data == ReflectanceScale::Percent => {
            Err(ScaleConflict { keyword, max })
        }
        Some((scale, keyword)) => Ok(ScaleFound {
            scale,
            evidence: ScaleEvidence::Header(keyword),
        }),
        None => Ok(ScaleFound {
            scale: from_data,
            evidence: ScaleEvidence::Data { max },
        }),
    }
}

/// The header says fractions, the data hold percentages.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the header says fractions ({keyword}) but a value is {max}, which only percent allows")]
pub struct ScaleConflict {
    pub keyword: String,
    pub max: f64,
}

/// Reads an illuminant name as files write it ("D65", "ILLUMINANT, D50", "CIE A").
pub(crate) fn parse_illuminant(text: &str) -> Option<Illuminant> {
    let cleaned = text
        .to_ascii_uppercase()
        .replace("ILLUMINANT", "")
        .replace("CIE", "")
        .replace([',', '_', '"'], " ");
    cleaned
        .split_whitespace()
        .find_map(|word| word.parse::<Illuminant>().ok())
}

/// Reads an observer as files write it ("10", "2 degree", "OBSERVER, 10_Degree",
/// "CIE 1964").
pub(crate) fn parse_observer(text: &str) -> Option<Observer> {
    let cleaned = text.to_ascii_lowercase().replace(['_', ',', '"', '°'], " ");
    cleaned
        .split_whitespace()
        .find_map(|word| word.trim_end_matches("deg").parse::<Observer>().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_read_as_files_write_them() {
        assert_eq!(parse_illuminant("ILLUMINANT, D50"), Some(Illuminant::D50));
        assert_eq!(parse_illuminant("CIE A"), Some(Illuminant::A));
        assert_eq!(parse_illuminant("F11"), Some(Illuminant::F11));
        assert_eq!(parse_illuminant("C"), None);
        assert_eq!(
            parse_observer("OBSERVER, 10_Degree"),
            Some(Observer::Cie1964TenDegree)
        );
        assert_eq!(parse_observer("2 degree"), Some(Observer::Cie1931TwoDegree));
        assert_eq!(parse_observer("10deg"), Some(Observer::Cie1964TenDegree));
        assert_eq!(parse_observer("45"), None);
    }

    #[test]
    fn the_scale_comes_from_the_header_or_the_data_and_a_conflict_is_refused() {
        let found = decide_scale(None, 87.0).expect("percent");
        assert_eq!(found.scale, ReflectanceScale::Percent);
        let found = decide_scale(None, 0.87).expect("fraction");
        assert_eq!(found.scale, ReflectanceScale::Fraction);
        // A dark sample in percent: only the header can say so.
        let found =
            decide_scale(Some((ReflectanceScale::Percent, "X".into())), 1.2).expect("percent");
        assert_eq!(found.scale, ReflectanceScale::Percent);
        assert!(decide_scale(Some((ReflectanceScale::Fraction, "X".into())), 50.0).is_err());
    }

    #[test]
    fn interpolation_is_linear_and_holds_the_ends() {
        let w = [400.0, 410.0, 420.0];
        let v = [0.1, 0.3, 0.2];
        assert_eq!(interpolate(&w, &v, 390.0), 0.1);
        assert!((interpolate(&w, &v, 405.0) - 0.2).abs() < 1e-15);
        assert_eq!(interpolate(&w, &v, 420.0), 0.2);
        assert_eq!(interpolate(&w, &v, 700.0), 0.2);
    }
}
