//! Exchange files of a design: what the virtual instruments read of it, as the
//! measurement files a colour lab exchanges (CxF3, CGATS.17), and the design as
//! a real-time material on the car (glTF 2.0, [`gltf`]). `docs/export.md` is the
//! manual: what each file holds, the custom CxF3 section's schema, the glTF
//! material mapping and what the approximation costs.
//!
//! The readings ([`virtual_readings`]): the multi-angle instrument at the five
//! aspecular angles of [`instruments::ASPECULAR_DEG`] (illumination 45°), then the
//! sphere at d:8° SCI and SCE, each with its reflectance factor on the reference
//! grid (380–780 nm, 5 nm) and its CIELAB (D65/10°); the glossmeter's total
//! readings at 20°, 60° and 85° go with the first reading, as the readers attach
//! an object's gloss.

pub mod cxf;
pub mod gltf;

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use crate::colour::cie::{Illuminant, Observer};
use crate::colour::spectrum::WavelengthGrid;
use crate::design::{DesignError, PaintDesign};
use crate::instruments::{self, InstrumentError};
use crate::io::atomic::{WriteError, write_bytes_atomically};
use crate::measurement::cgats_write::write_cgats;
use crate::measurement::{
    Geometry, GlossValue, MAX_REFLECTANCE_FACTOR, ReadingsWriteError, Reflectance, Sample,
    SpectrumProblem, StatedColour, StatedValue,
};
use crate::names::{UnknownName, by_name, or_list};
use crate::scene::Scene;
use crate::scene::car::{CarParameters, generate};

/// The `Creator`/`ORIGINATOR` written into every export.
pub const CREATOR: &str = concat!("Coatlab ", env!("CARGO_PKG_VERSION"));

/// The exchange formats a design is exported to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ExportFormat {
    /// X-Rite CxF3 XML: every reading, the gloss, and the design itself.
    Cxf,
    /// CGATS.17 text: one row per geometry.
    Cgats,
    /// glTF 2.0 binary (GLB): the car with the design as a real-time material.
    Gltf,
}

impl ExportFormat {
    /// Every format, in the order the help lists them.
    pub const ALL: [ExportFormat; 3] = [ExportFormat::Cxf, ExportFormat::Cgats, ExportFormat::Gltf];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Cxf => "cxf",
            ExportFormat::Cgats => "cgats",
            ExportFormat::Gltf => "gltf",
        }
    }

    /// The file extensions a file of this format may have (the first is proposed).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            ExportFormat::Cxf => &["cxf"],
            ExportFormat::Cgats => &["txt", "cgats", "cgt", "it8"],
            ExportFormat::Gltf => &["glb"],
        }
    }

    /// The format named `text` (case ignored), else a refusal listing them all.
    pub fn by_name(text: &str) -> Result<ExportFormat, UnknownName> {
        by_name(text, "an export format", &Self::ALL, Self::name)
    }

    /// Whether `extension` (without the dot, any case) suits the format.
    pub fn accepts_extension(self, extension: &str) -> bool {
        self.extensions()
            .iter()
            .any(|e| e.eq_ignore_ascii_case(extension))
    }
}

impl fmt::Display for ExportFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a design could not be exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(transparent)]
    Design(#[from] DesignError),
    #[error(transparent)]
    Instrument(#[from] InstrumentError),
    #[error(
        "the reading at {geometry} is {value} at {wavelength_nm} nm, above the {MAX_REFLECTANCE_FACTOR} \
         that measurement files may hold (a reader would take it for percent): the gloss lobe is too \
         narrow for this geometry"
    )]
    OutOfFileRange {
        geometry: Geometry,
        wavelength_nm: f64,
        value: f64,
    },
    #[error("reading at {geometry}: {problem}")]
    Spectrum {
        geometry: Geometry,
        problem: SpectrumProblem,
    },
    /// CGATS or CxF3.
    #[error(transparent)]
    File(#[from] ReadingsWriteError),
    #[error(transparent)]
    Gltf(#[from] gltf::GltfExportError),
    #[error(
        "{}: a {format} export is a .{} file{}",
        path.display(),
        format.extensions()[0],
        other_extensions(*format)
    )]
    Extension { path: PathBuf, format: ExportFormat },
    /// The message of [`WriteError`] names the file already.
    #[error("{error}")]
    Write { path: PathBuf, error: WriteError },
}

fn other_extensions(format: ExportFormat) -> String {
    match format.extensions() {
        [_] => String::new(),
        [_, rest @ ..] => {
            let dotted: Vec<String> = rest.iter().map(|e| format!(".{e}")).collect();
            format!(" (or {})", or_list(&dotted))
        }
        [] => String::new(),
    }
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    pub format: ExportFormat,
    /// The file's size, bytes.
    pub bytes: usize,
    /// For glTF: the material written, with what it costs at each geometry.
    pub material: Option<gltf::RealTimeMaterial>,
}

/// Writes `design` as `format` to `path` atomically (the file there, if any, is
/// untouched on failure); glTF puts it on `scene`, else on the built-in car.
/// `path` must have one of the format's extensions.
pub fn export_to_file(
    design: &PaintDesign,
    format: ExportFormat,
    scene: Option<&Scene>,
    path: &Path,
) -> Result<Exported, ExportError> {
    let extension_fits = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| format.accepts_extension(e));
    if !extension_fits {
        return Err(ExportError::Extension {
            path: path.to_owned(),
            format,
        });
    }
    let (bytes, material) = match format {
        ExportFormat::Cxf => (
            cxf::to_cxf(design, &utc_timestamp(SystemTime::now()))?.into_bytes(),
            None,
        ),
        ExportFormat::Cgats => (to_cgats(design)?.into_bytes(), None),
        ExportFormat::Gltf => {
            let material = gltf::real_time_material(design)?;
            let built_in;
            let scene = match scene {
                Some(scene) => scene,
                None => {
                    built_in = generate(&CarParameters::default());
                    &built_in
                }
            };
            (gltf::scene_glb(scene, design, &material)?, Some(material))
        }
    };
    write_bytes_atomically(path, &bytes).map_err(|error| ExportError::Write {
        path: path.to_owned(),
        error,
    })?;
    Ok(Exported {
        format,
        bytes: bytes.len(),
        material,
    })
}

/// `time` as an `xs:dateTime` in UTC, to the second (`2026-12-02T18:00:00Z`).
pub fn utc_timestamp(time: SystemTime) -> String {
    let seconds = time.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, second_of_day) = (seconds / 86_400, seconds % 86_400);
    // Days since 1970-01-01 to the proleptic Gregorian date (H. Hinnant's
    // `civil_from_days`), in 400-year eras of 146 097 days.
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let mp = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        second_of_day / 3600,
        second_of_day / 60 % 60,
        second_of_day % 60
    )
}

/// The design's readings by the virtual instruments, as a measurement file holds
/// them (see the module docs); each sample is named after the design.
pub fn virtual_readings(design: &PaintDesign) -> Result<Vec<Sample>, ExportError> {
    let grid = WavelengthGrid::reference();
    let model = design.model(grid)?;
    let m = instruments::measure(&model)?;
    let gloss: Vec<GlossValue> = m
        .gloss
        .iter()
        .map(|g| GlossValue {
            angle_deg: g.geometry.angle_deg(),
            gu: g.total_gu,
        })
        .collect();
    let directional = m.angles.iter().map(|a| {
        (
            Geometry::directional(instruments::ILLUMINATION_DEG, a.aspecular_deg),
            a.lab,
            &a.reflectance_factor,
        )
    });
    let sphere = m
        .sphere
        .iter()
        .map(|r| (r.geometry, r.lab, &r.reflectance_factor));
    let mut samples = Vec::new();
    for (k, (geometry, lab, factors)) in directional.chain(sphere).enumerate() {
        if let Some((j, &value)) = factors
            .iter()
            .enumerate()
            .find(|&(_, v)| *v > MAX_REFLECTANCE_FACTOR)
        {
            return Err(ExportError::OutOfFileRange {
                geometry,
                wavelength_nm: m.wavelength_nm[j],
                value,
            });
        }
        let spectrum = Reflectance::new(m.wavelength_nm.clone(), factors.clone())
            .map_err(|problem| ExportError::Spectrum { geometry, problem })?;
        samples.push(Sample {
            name: design.name.clone(),
            id: None,
            geometry,
            spectrum: Some(spectrum),
            colour: Some(StatedColour {
                value: StatedValue::Lab(lab),
                illuminant: Some(Illuminant::D65),
                observer: Some(Observer::Cie1964TenDegree),
            }),
            gloss: if k == 0 { gloss.clone() } else { Vec::new() },
        });
    }
    Ok(samples)
}

/// The design's readings as CGATS.17 text: one row per geometry (the five
/// multi-angle geometries, then d:8° SCI and SCE), the gloss on every row.
pub fn to_cgats(design: &PaintDesign) -> Result<String, ExportError> {
    let mut samples = virtual_readings(design)?;
    // A CGATS table has one set of columns: every row repeats the gloss.
    let gloss = samples.first().map(|s| s.gloss.clone()).unwrap_or_default();
    for s in &mut samples {
        s.gloss.clone_from(&gloss);
    }
    Ok(write_cgats(CREATOR, &samples)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn timestamps_are_utc_calendar_dates() {
        let at = |s| utc_timestamp(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        // 2000-02-29 12:34:56: a leap day in a century leap year.
        assert_eq!(at(951_827_696), "2000-02-29T12:34:56Z");
        assert_eq!(at(1_796_169_600), "2026-12-02T00:00:00Z");
    }

    #[test]
    fn a_wrong_extension_names_the_file_and_the_ones_that_fit() {
        let design = crate::design::presets::all()[0].design.clone();
        let e = export_to_file(
            &design,
            ExportFormat::Cgats,
            None,
            Path::new("/nonexistent/out.cxf"),
        )
        .expect_err("wrong extension");
        assert_eq!(
            e.to_string(),
            "/nonexistent/out.cxf: a cgats export is a .txt file (or .cgats, .cgt or .it8)"
        );
    }
}
