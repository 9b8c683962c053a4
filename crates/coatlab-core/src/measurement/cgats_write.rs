//! Writing readings as a CGATS.17 file, the form [`super::cgats`] reads: one row
//! per sample and geometry, `SAMPLE_NAME`, `GEOMETRY`, the spectrum as fractions in
//! `SPECTRAL_NM_<λ>` columns and the gloss in `GLOSS_<angle>` columns. Numbers are
//! written in Rust's shortest form that reads back to the same `f64`, so a file
//! read back gives the same numbers.

use std::fmt::Write;

use super::{Geometry, ReadingsWriteError, Sample, SpecularComponent};

/// Why readings cannot be written as one CGATS table.
pub type CgatsWriteError = ReadingsWriteError;

/// The `GEOMETRY` field of a reading: `45as15`, `di:8`, `de:8`.
fn geometry_field(geometry: Geometry) -> Option<String> {
    match geometry {
        Geometry::Directional {
            illumination_deg,
            aspecular_deg,
        } => Some(format!("{illumination_deg}as{aspecular_deg}")),
        Geometry::Sphere {
            specular: SpecularComponent::Included,
        } => Some("di:8".to_owned()),
        Geometry::Sphere {
            specular: SpecularComponent::Excluded,
        } => Some("de:8".to_owned()),
        Geometry::Unspecified => None,
    }
}

/// `samples` as a CGATS.17 text. Every sample needs a spectrum on the first one's
/// wavelengths, a stated geometry, and the first one's gloss angles.
pub fn write_cgats(originator: &str, samples: &[Sample]) -> Result<String, CgatsWriteError> {
    let first = samples.first().ok_or(CgatsWriteError::Empty)?;
    let wavelengths = first
        .spectrum
        .as_ref()
        .ok_or(CgatsWriteError::Empty)?
        .wavelengths_nm();
    let gloss_angles: Vec<f64> = first.gloss.iter().map(|g| g.angle_deg).collect();
    let mut fields = vec!["SAMPLE_NAME".to_owned(), "GEOMETRY".to_owned()];
    fields.extend(wavelengths.iter().map(|nm| format!("SPECTRAL_NM_{nm}")));
    fields.extend(gloss_angles.iter().map(|a| format!("GLOSS_{a}")));

    let mut text = String::new();
    let _ = writeln!(text, "CGATS.17");
    let _ = writeln!(text, "ORIGINATOR {originator:?}");
    let _ = writeln!(text, "REFLECTANCE_SCALE FRACTION");
    let _ = writeln!(text, "NUMBER_OF_FIELDS {}", fields.len());
    let _ = writeln!(
        text,
        "BEGIN_DATA_FORMAT\n{}\nEND_DATA_FORMAT",
        fields.join(" ")
    );
    let _ = writeln!(text, "NUMBER_OF_SETS {}\nBEGIN_DATA", samples.len());
    for s in samples {
        let unwritable = |why| CgatsWriteError::Unwritable {
            name: s.name.clone(),
            geometry: s.geometry,
            why,
        };
        if s.name.contains(['"', '\n', '\r']) {
            return Err(unwritable("a quote or a line end in the name"));
        }
        let geometry = geometry_field(s.geometry).ok_or_else(|| unwritable("no geometry"))?;
        let spectrum = s
            .spectrum
            .as_ref()
            .ok_or_else(|| unwritable("no spectrum"))?;
        if spectrum.wavelengths_nm() != wavelengths {
            return Err(unwritable("other wavelengths than the first sample's"));
        }
        let gloss: Vec<f64> = gloss_angles
            .iter()
            .map(|a| s.gloss.iter().find(|g| g.angle_deg == *a).map(|g| g.gu))
            .collect::<Option<_>>()
            .filter(|_: &Vec<f64>| s.gloss.len() == gloss_angles.len())
            .ok_or_else(|| unwritable("other gloss angles than the first sample's"))?;
        let _ = write!(text, "{:?} {geometry}", s.name);
        for v in spectrum.factors().iter().chain(&gloss) {
            let _ = write!(text, " {v}");
        }
        text.push('\n');
    }
    text.push_str("END_DATA\n");
    Ok(text)
}
