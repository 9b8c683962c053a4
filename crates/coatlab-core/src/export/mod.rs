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

use crate::colour::cie::{Illuminant, Observer};
use crate::colour::spectrum::WavelengthGrid;
use crate::design::{DesignError, PaintDesign};
use crate::instruments::{self, InstrumentError};
use crate::measurement::cgats_write::{CgatsWriteError, write_cgats};
use crate::measurement::cxf_write::CxfWriteError;
use crate::measurement::{
    Geometry, GlossValue, MAX_REFLECTANCE_FACTOR, Reflectance, Sample, SpectrumProblem,
    StatedColour, StatedValue,
};
use crate::names::{UnknownName, by_name};

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
    #[error(transparent)]
    Cgats(#[from] CgatsWriteError),
    #[error(transparent)]
    Cxf(#[from] CxfWriteError),
    #[error(transparent)]
    Gltf(#[from] gltf::GltfExportError),
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
