//! The Instruments tab's target: another design, or one standard of a measurement
//! file (CGATS.17, CxF3), and the design against it as `coatlab measure --target`
//! reports it. What a comparison is, and how a standard is read, is the core's
//! ([`coatlab_core::target`], [`coatlab_core::measurement`]); this module only
//! keeps what the person chose and asks the core.

use std::path::{Path, PathBuf};

use anyhow::Context;
use coatlab_core::analysis::{
    Analysis, Swatch, design_swatch_reflectance, standard_swatch_reflectance, swatches,
};
use coatlab_core::colour::tolerance::Tolerance;
use coatlab_core::design::PaintDesign;
use coatlab_core::instruments::{ASPECULAR_DEG, ILLUMINATION_DEG, SPHERE_GEOMETRIES};
use coatlab_core::measurement::spectra_csv::read_spectra_measurement;
use coatlab_core::measurement::{self, Format, Geometry, Measurement, Standard};
use coatlab_core::target::{Comparison, compare_designs, compare_to_standard};

/// A measurement file and the standard in it that is the target.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredTarget {
    pub path: PathBuf,
    pub measurement: Measurement,
    /// Which of [`Measurement::standards`] is the target.
    pub selected: usize,
}

impl MeasuredTarget {
    /// The names of the file's standards, in file order.
    pub fn standard_names(&self) -> Vec<String> {
        self.measurement
            .standards()
            .iter()
            .map(|s| s.name.to_owned())
            .collect()
    }

    /// Whether the file leaves the geometry to the person (a CSV of spectra).
    pub fn geometry_is_chosen(&self) -> bool {
        self.measurement.format == Format::SpectraCsv
    }

    /// The geometry of a CSV's readings.
    pub fn chosen_geometry(&self) -> Geometry {
        self.measurement
            .samples
            .first()
            .map_or(Geometry::Unspecified, |s| s.geometry)
    }

    /// States the geometry of every reading (a CSV says none).
    pub fn set_geometry(&mut self, geometry: Geometry) {
        for s in &mut self.measurement.samples {
            s.geometry = geometry;
        }
    }

    /// The chosen standard (the first if the choice is out of range).
    pub fn standard(&self) -> Option<Standard<'_>> {
        let mut standards = self.measurement.standards();
        let index = self.selected.min(standards.len().checked_sub(1)?);
        Some(standards.swap_remove(index))
    }
}

/// What the design is compared with.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    Design(PaintDesign),
    Measured(MeasuredTarget),
}

impl Target {
    /// The name shown in the Target box: the design's, or the standard's with its file.
    pub fn label(&self) -> String {
        match self {
            Target::Design(d) => d.name.clone(),
            Target::Measured(m) => {
                let file = m
                    .path
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                match m.standard() {
                    Some(s) => format!("{} ({file})", s.name),
                    None => file,
                }
            }
        }
    }

    /// The target design, if the target is one (the analysis reads it too).
    pub fn design(&self) -> Option<&PaintDesign> {
        match self {
            Target::Design(d) => Some(d),
            Target::Measured(_) => None,
        }
    }
}

/// Whether `bytes` are a measurement file rather than a design or a spectral CSV.
pub fn is_measurement(bytes: &[u8]) -> bool {
    measurement::sniff(bytes).is_some()
}

/// The geometries a CSV's readings may be stated at: the virtual instruments'.
pub fn geometry_choices() -> Vec<Geometry> {
    std::iter::once(Geometry::Unspecified)
        .chain(
            ASPECULAR_DEG
                .iter()
                .map(|&a| Geometry::directional(ILLUMINATION_DEG, a)),
        )
        .chain(SPHERE_GEOMETRIES)
        .collect()
}

/// Reads `path` as a target: a CGATS or CxF3 measurement file by its content, a
/// CSV of spectra (`.csv`, as `coatlab color` reads it; its geometry unstated
/// until the person states it), otherwise a design file. A file with several
/// standards starts on the first; the Instruments tab offers the others. Errors
/// name the file and, from the core's readers, the line, column or element.
pub fn load_target(path: &Path) -> anyhow::Result<Target> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {file}"))?;
    let is_csv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    let measurement = if is_measurement(&bytes) {
        measurement::read(&bytes, &file)?
    } else if is_csv {
        read_spectra_measurement(&bytes, &file, Geometry::Unspecified)?
    } else {
        return Ok(Target::Design(PaintDesign::load(path)?));
    };
    Ok(Target::Measured(MeasuredTarget {
        path: path.to_owned(),
        measurement,
        selected: 0,
    }))
}

/// The tolerance the design is judged by: its own `[tolerance]`, else ΔE00 ≤ 1.
pub fn tolerance_of(design: &PaintDesign) -> Tolerance {
    design.tolerance.clone().unwrap_or_default()
}

/// The design against its target, as the Instruments tab shows it.
#[derive(Debug, Clone)]
pub struct TargetView {
    /// The comparison, or why there is none.
    pub comparison: Result<Comparison, String>,
    /// Design and target side by side under D65, A and F11.
    pub swatches: Vec<Swatch>,
}

/// Compares the analysed design with `target` under `tolerance` (the core's
/// [`compare_designs`] and [`compare_to_standard`], as `coatlab measure` does).
pub fn compare(analysis: &Analysis, target: &Target, tolerance: &Tolerance) -> TargetView {
    let design = &analysis.measurement;
    match target {
        Target::Design(_) => match &analysis.target {
            Some((_, readings)) => TargetView {
                comparison: compare_designs(design, readings, tolerance).map_err(|e| e.to_string()),
                swatches: swatches(design, design_swatch_reflectance(readings)),
            },
            None => TargetView {
                comparison: Err("the target design has no readings".to_owned()),
                swatches: analysis.swatches.clone(),
            },
        },
        Target::Measured(m) => {
            let Some(standard) = m.standard() else {
                return TargetView {
                    comparison: Err(format!("{}: no sample in the file", m.path.display())),
                    swatches: analysis.swatches.clone(),
                };
            };
            let factor = standard_swatch_reflectance(&standard, &design.wavelength_nm);
            TargetView {
                comparison: compare_to_standard(&analysis.model, design, &standard, tolerance)
                    .map_err(|e| {
                        format!(
                            "{}: cannot compare with sample {:?}: {e}",
                            m.path.display(),
                            standard.name
                        )
                    }),
                swatches: swatches(design, factor.as_deref()),
            }
        }
    }
}
