//! A CSV of spectra — a `wavelength_nm` column and one column of reflectance
//! factors per sample, as `coatlab color` reads it — as readings. A CSV does not
//! say where it was measured, so the caller states the geometry (or leaves it
//! [`Geometry::Unspecified`], which a comparison lists as not comparable).

use crate::colour::spectrum::{SpectrumError, ValueBounds, read_spectra_csv};

use super::{
    Format, Geometry, MAX_REFLECTANCE_FACTOR, Measurement, Reflectance, Sample, SpectrumProblem,
};

/// Why a CSV of spectra is not a measurement.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectraCsvError {
    /// The CSV itself (named with its line by the reader).
    #[error(transparent)]
    Csv(#[from] SpectrumError),
    /// A column is no reading (a wavelength outside the CIE tables, say).
    #[error("{file}, column {column:?}: {problem}")]
    Column {
        file: String,
        column: String,
        problem: SpectrumProblem,
    },
}

/// Reads a CSV of spectra: each column one standard of that name, measured at
/// `geometry`; values are fractions (0 to [`MAX_REFLECTANCE_FACTOR`]), as
/// `coatlab color` takes them.
pub fn read_spectra_measurement(
    bytes: &[u8],
    file: &str,
    geometry: Geometry,
) -> Result<Measurement, SpectraCsvError> {
    let bounds = ValueBounds::new(0.0, MAX_REFLECTANCE_FACTOR)?;
    let csv = read_spectra_csv(bytes, file, bounds)?;
    let samples =
        csv.samples
            .iter()
            .map(|(name, values)| {
                let spectrum = Reflectance::new(csv.wavelengths_nm.clone(), values.clone())
                    .map_err(|problem| SpectraCsvError::Column {
                        file: file.to_owned(),
                        column: name.clone(),
                        problem,
                    })?;
                Ok(Sample {
                    name: name.clone(),
                    id: None,
                    geometry,
                    spectrum: Some(spectrum),
                    colour: None,
                    gloss: Vec::new(),
                })
            })
            .collect::<Result<Vec<_>, SpectraCsvError>>()?;
    Ok(Measurement {
        format: Format::SpectraCsv,
        samples,
        reflectance_scale: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &[u8] =
        b"wavelength_nm,red,grey\n400,0.05,0.4\n500,0.06,0.41\n600,0.6,0.42\n700,0.8,0.43\n";

    #[test]
    fn each_column_is_a_standard_at_the_stated_geometry() {
        let geometry = Geometry::directional(45.0, 45.0);
        let m = read_spectra_measurement(CSV, "s.csv", geometry).expect("readable");
        assert_eq!(m.format, Format::SpectraCsv);
        let names: Vec<&str> = m.standards().iter().map(|s| s.name).collect();
        assert_eq!(names, ["red", "grey"]);
        let red = &m.samples[0];
        assert_eq!(red.geometry, geometry);
        let spectrum = red.spectrum.as_ref().expect("spectrum");
        assert_eq!(spectrum.wavelengths_nm(), [400.0, 500.0, 600.0, 700.0]);
        assert_eq!(spectrum.factors(), [0.05, 0.06, 0.6, 0.8]);
    }

    #[test]
    fn a_wavelength_the_cie_tables_lack_names_the_column() {
        let csv = b"wavelength_nm,uv\n340,0.1\n400,0.2\n";
        let e = read_spectra_measurement(csv, "uv.csv", Geometry::Unspecified)
            .expect_err("340 nm is outside the CIE tables");
        assert!(
            e.to_string()
                .starts_with("uv.csv, column \"uv\": wavelength 340 nm"),
            "{e}"
        );
        let e = read_spectra_measurement(
            b"wavelength_nm,x\n400,abc\n500,0.2\n",
            "x.csv",
            Geometry::Unspecified,
        )
        .expect_err("not a number");
        assert!(e.to_string().contains("x.csv"), "{e}");
    }
}
