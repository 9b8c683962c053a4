//! Paint design files: one gloss solid paint (spec section 1) as a versioned,
//! human-readable TOML document.
//!
//! Units and ranges are those of the paint model's parameter table
//! ([`crate::paint::parameters`]); validation reads them from there.
//!
//! | field | parameter | file key |
//! | --- | --- | --- |
//! | name | not blank | `name` |
//! | description | optional | `description` |
//! | pigment diffuse albedo ρ(λ) | [`ALBEDO`] | `pigment.albedo` (table) |
//! | clear coat refractive index n(λ) | [`REFRACTIVE_INDEX`] over [`VISIBLE`]; [`CAUCHY_A`], [`CAUCHY_B`] | `clear_coat.refractive_index` (`cauchy` or `table`) |
//! | clear coat absorption k(λ) | [`ABSORPTION`] | `clear_coat.absorption_per_um` (`constant` or `table`) |
//! | clear coat thickness h | [`THICKNESS`] | `clear_coat.thickness_um` |
//! | gloss g | [`GLOSS`], at least the reading of m = 0 | `gloss.gu` |
//! | glossmeter geometry | 20°, 60°, 85° ([`GlossGeometry`]) | `gloss.geometry_deg` |
//! | specular lobe | `normalised`, `paper` ([`LobeKind`]) | `gloss.lobe` |
//! | pass/fail limits (optional) | [`Tolerance`], as `coatlab measure --tolerance` writes them | `tolerance.spec`, with `tolerance.version` ([`TOLERANCE_VERSION`]) |
//!
//! Tables are `{ wavelength_nm = [...], value = [...] }` with strictly increasing
//! wavelengths covering at least 400–700 nm; between samples a table is linear, beyond
//! its ends constant. A Cauchy index is n(λ) = a + b_um2 / λ² with λ in µm.
//!
//! ```toml
//! format = "coatlab-paint-design"
//! version = 1
//! name = "Signal red"
//!
//! [pigment.albedo]
//! wavelength_nm = [380, 385, 390]   # ... up to at least 700
//! value = [0.05, 0.05, 0.05]
//!
//! [clear_coat]
//! thickness_um = 45.0
//! refractive_index = { cauchy = { a = 1.515, b_um2 = 0.0045 } }
//! absorption_per_um = { constant = 0.0004 }
//!
//! [gloss]
//! gu = 88.0
//! geometry_deg = 20
//! lobe = "normalised"
//!
//! # Optional: the limits a measured standard is judged by (`coatlab measure
//! # --target` uses them when no --tolerance is given).
//! [tolerance]
//! version = 1
//! spec = "de00:1,15=1.5,110=2"
//! ```
//!
//! Reading is strict: an unknown `format`, a newer `version`, a missing or unknown key
//! (a typo must not be silently ignored), a non-finite number (TOML has `nan` and
//! `inf` literals) or a value outside its range is refused with a message naming the
//! file, the field and the value. Saving is atomic: a crash or a full disk never
//! leaves a half-written design where the old one was.
//!
//! [`presets`] holds the illustrative designs shipped in `assets/presets/`.

use std::fmt::Write as _;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use thiserror::Error;

use crate::colour::spectrum::{SampledSpectrum, TabulatedSpectrum, VISIBLE, WavelengthGrid};
use crate::colour::tolerance::{Formula, Tolerance};
use crate::io::atomic::write_bytes_atomically;
use crate::paint::gloss::{
    GLOSS_WAVELENGTH_NM, GlossError, GlossExponent, GlossGeometry, exponent_from_reading,
    reading_from_exponent,
};
use crate::paint::lobe::LobeKind;
use crate::paint::model::{GlossSetting, PaintModel, PaintParams};
use crate::paint::parameters::{
    ABSORPTION, ALBEDO, CAUCHY_A, CAUCHY_B, GLOSS, Parameter, REFRACTIVE_INDEX, THICKNESS,
};

/// The `format` key every design file starts with.
pub const FORMAT_NAME: &str = "coatlab-paint-design";
/// The file format version this Coatlab writes (and the newest it reads).
pub const FORMAT_VERSION: i64 = 1;
/// The version of the `[tolerance]` table this Coatlab writes (and the newest it
/// reads); the table has its own so that its syntax can grow without a new design
/// file version.
pub const TOLERANCE_VERSION: i64 = 1;
/// Every tabulated spectrum must cover at least this range, where colour is decided;
/// beyond its ends a table is held constant.
pub const REQUIRED_COVERAGE_NM: (f64, f64) = (400.0, 700.0);

/// Why a design could not be read, checked or saved.
///
/// Messages name the field (as its TOML key path) and the offending value; errors
/// from a file are wrapped in [`DesignError::InFile`], which prefixes the file name.
#[derive(Debug, Error)]
pub enum DesignError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read { path: PathBuf, error: io::Error },
    /// The design could not be written (the previous file, if any, is untouched).
    #[error("cannot save {}: {error}", path.display())]
    Write { path: PathBuf, error: io::Error },
    /// Not valid TOML, or a missing, unknown or mistyped key; the message is toml's
    /// own, with line and column.
    #[error("{message}")]
    Toml { message: String },
    /// `format` is missing or is not [`FORMAT_NAME`].
    #[error("not a Coatlab paint design: {found} (expected format = \"{FORMAT_NAME}\")")]
    NotADesign { found: String },
    /// A version above [`FORMAT_VERSION`].
    #[error(
        "version = {found}: this design was written by a newer Coatlab (this one reads up to version {FORMAT_VERSION}); update Coatlab to open it"
    )]
    NewerVersion { found: i64 },
    /// A version that no Coatlab ever wrote (missing, not an integer, or below 1).
    #[error(
        "version = {found} is not a paint design file version (this Coatlab reads version {FORMAT_VERSION})"
    )]
    UnknownVersion { found: String },
    /// A value outside its range; `field` is the TOML key path
    /// (`pigment.albedo.value[12]`), `message` the whole sentence, field included.
    #[error("{message}")]
    Invalid { field: String, message: String },
    /// A model on linear-sRGB channels was to be updated from the design's
    /// spectra, which need wavelengths (an RGB model is built by
    /// the RGB shortcut of `cargo xtask bench`, xtask/src/bench/rgb.rs).
    #[error("{name}: a design's spectra need a wavelength grid, not linear-sRGB channels")]
    NotSpectral { name: String },
    /// The gloss reading cannot be turned into a lobe exponent.
    #[error("gloss.gu = {gu}: {error}")]
    Gloss { gu: f64, error: GlossError },
    /// Any of the above, found in a named file or text.
    #[error("{file}: {error}")]
    InFile {
        file: String,
        error: Box<DesignError>,
    },
}

impl DesignError {
    /// The error without its file context.
    pub fn without_file(&self) -> &DesignError {
        match self {
            DesignError::InFile { error, .. } => error.without_file(),
            other => other,
        }
    }

    /// The TOML key path of the offending field, for errors about one field.
    pub fn field(&self) -> Option<&str> {
        match self.without_file() {
            DesignError::Invalid { field, .. } => Some(field),
            DesignError::Gloss { .. } => Some("gloss.gu"),
            DesignError::NewerVersion { .. } | DesignError::UnknownVersion { .. } => {
                Some("version")
            }
            DesignError::NotADesign { .. } => Some("format"),
            _ => None,
        }
    }

    fn in_file(self, file: &str) -> DesignError {
        DesignError::InFile {
            file: file.to_owned(),
            error: Box::new(self),
        }
    }
}

fn invalid(field: impl Into<String>, message: String) -> DesignError {
    DesignError::Invalid {
        field: field.into(),
        message,
    }
}

/// Clear coat refractive index n(λ).
#[derive(Debug, Clone, PartialEq)]
pub enum RefractiveIndex {
    /// n(λ) = a + b_um2 / λ², λ in µm (normal dispersion for b_um2 > 0).
    Cauchy { a: f64, b_um2: f64 },
    /// Tabulated n(λ).
    Table(TabulatedSpectrum),
}

impl RefractiveIndex {
    /// n at one wavelength (nm).
    pub fn at_nm(&self, wavelength_nm: f64) -> f64 {
        match self {
            RefractiveIndex::Cauchy { a, b_um2 } => {
                let wavelength_um = wavelength_nm * 1e-3;
                a + b_um2 / (wavelength_um * wavelength_um)
            }
            RefractiveIndex::Table(table) => table.value_at_nm(wavelength_nm),
        }
    }

    /// n on a grid: each sample is the mean of n over its bin (the resampling rule of
    /// [`crate::colour::spectrum`]), exact for the Cauchy form.
    pub fn on_grid(&self, grid: &WavelengthGrid) -> SampledSpectrum {
        match self {
            RefractiveIndex::Cauchy { a, b_um2 } => {
                let half_um = 0.5e-3 * grid.bin_width_nm();
                SampledSpectrum::from_fn(*grid, |wavelength_nm| {
                    let (lo_um, hi_um) = (
                        wavelength_nm * 1e-3 - half_um,
                        wavelength_nm * 1e-3 + half_um,
                    );
                    // The mean of 1/λ² over [lo, hi] is 1/(lo·hi); a bin reaching 0 nm
                    // (only on absurd grids) falls back to the centre value.
                    if lo_um > 0.0 {
                        a + b_um2 / (lo_um * hi_um)
                    } else {
                        self.at_nm(wavelength_nm)
                    }
                })
            }
            RefractiveIndex::Table(table) => table.to_grid(grid),
        }
    }
}

impl RefractiveIndex {
    /// The Cauchy index A + B/λ² (λ in µm) nearest a table in the least-squares
    /// sense: linear regression of n on 1/λ² over the table's samples in
    /// [`VISIBLE`]. With fewer than two samples there, the constant
    /// n(587.6 nm) (at least 1).
    pub fn cauchy_fit(table: &TabulatedSpectrum) -> RefractiveIndex {
        let samples: Vec<(f64, f64)> = table
            .wavelengths_nm()
            .iter()
            .zip(table.values())
            .filter(|(l, _)| VISIBLE.contains(**l))
            .map(|(&l, &n)| (1.0 / (l * 1e-3).powi(2), n))
            .collect();
        if samples.len() < 2 {
            return RefractiveIndex::Cauchy {
                a: table.value_at_nm(GLOSS_WAVELENGTH_NM).max(1.0),
                b_um2: 0.0,
            };
        }
        let count = samples.len() as f64;
        let mean_x = samples.iter().map(|s| s.0).sum::<f64>() / count;
        let mean_y = samples.iter().map(|s| s.1).sum::<f64>() / count;
        let sxx: f64 = samples.iter().map(|s| (s.0 - mean_x).powi(2)).sum();
        let sxy: f64 = samples
            .iter()
            .map(|s| (s.0 - mean_x) * (s.1 - mean_y))
            .sum();
        let b_um2 = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        RefractiveIndex::Cauchy {
            a: mean_y - b_um2 * mean_x,
            b_um2,
        }
    }
}

/// Clear coat absorption coefficient k(λ), 1/µm.
#[derive(Debug, Clone, PartialEq)]
pub enum Absorption {
    /// The same k at every wavelength.
    Constant(f64),
    /// Tabulated k(λ) (a UV absorber makes k rise steeply below ~400 nm).
    Table(TabulatedSpectrum),
}

impl Absorption {
    /// k at one wavelength (nm), 1/µm.
    pub fn at_nm(&self, wavelength_nm: f64) -> f64 {
        match self {
            Absorption::Constant(k) => *k,
            Absorption::Table(table) => table.value_at_nm(wavelength_nm),
        }
    }

    /// k on a grid, 1/µm, by the resampling rule of [`crate::colour::spectrum`].
    pub fn on_grid(&self, grid: &WavelengthGrid) -> SampledSpectrum {
        match self {
            Absorption::Constant(k) => SampledSpectrum::constant(*grid, *k),
            Absorption::Table(table) => table.to_grid(grid),
        }
    }
}

/// A gloss reading and the glossmeter geometry it was read at (spec 4.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gloss {
    /// Specular gloss, gloss units.
    pub gu: f64,
    /// ISO 2813 geometry.
    pub geometry: GlossGeometry,
}

impl Gloss {
    /// The reading at geometry `to` of the lobe this reading gives on a coat of
    /// index `n` (at 587.6 nm): the same paint, read by another glossmeter. A
    /// reading no lobe gives (or an invalid n) is kept as it is, at `to`.
    pub fn at_geometry(self, to: GlossGeometry, n: f64) -> Gloss {
        let gu = exponent_from_reading(self.geometry, n, self.gu)
            .and_then(|m| reading_from_exponent(to, n, m))
            .unwrap_or(self.gu);
        Gloss { gu, geometry: to }
    }
}

/// One gloss solid paint: the parameters of spec section 1 plus gloss and lobe.
///
/// Fields are public for editing; [`PaintDesign::validate`] checks them, and
/// [`PaintDesign::load`] and [`PaintDesign::save`] never accept or write an invalid one.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintDesign {
    /// Shown to the user; not blank.
    pub name: String,
    /// Free text: pigments, provenance, intent.
    pub description: Option<String>,
    /// Pigment layer diffuse albedo ρ(λ), in [0, 1].
    pub albedo: TabulatedSpectrum,
    /// Clear coat refractive index n(λ) ≥ 1.
    pub refractive_index: RefractiveIndex,
    /// Clear coat absorption coefficient k(λ) ≥ 0, 1/µm.
    pub absorption_per_um: Absorption,
    /// Clear coat thickness h ≥ 0, µm.
    pub thickness_um: f64,
    /// Gloss reading, which sets the lobe exponent m.
    pub gloss: Gloss,
    /// Which specular lobe the model uses.
    pub lobe: LobeKind,
    /// Pass/fail limits against a target, stored with the design (`[tolerance]`);
    /// `None`: the default, ΔE00 ≤ 1 at every angle.
    pub tolerance: Option<Tolerance>,
}

impl PaintDesign {
    /// Reads and validates a design file; errors name the file.
    pub fn load(path: impl AsRef<Path>) -> Result<PaintDesign, DesignError> {
        let path = path.as_ref();
        let text = fs::read_to_string(path).map_err(|error| DesignError::Read {
            path: path.to_owned(),
            error,
        })?;
        PaintDesign::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates a design from TOML text; `source_name` (usually the file
    /// name) prefixes every error message.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<PaintDesign, DesignError> {
        parse_design(text).map_err(|error| error.in_file(source_name))
    }

    /// The design as a TOML document (with explanatory comments) that
    /// [`PaintDesign::from_toml_str`] reads back to an equal design. Numbers are written
    /// in Rust's shortest round-trip form, so nothing is lost.
    pub fn to_toml_string(&self) -> String {
        write_design(self)
    }

    /// Validates, then writes the design atomically: the text goes to a temporary file
    /// in the same directory, which is flushed to disk and renamed over `path`. If
    /// anything fails the previous file at `path` is left as it was.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), DesignError> {
        self.validate()?;
        let path = path.as_ref();
        write_bytes_atomically(path, self.to_toml_string().as_bytes()).map_err(|e| {
            DesignError::Write {
                path: e.path,
                error: e.error,
            }
        })
    }

    /// Checks every field against its range (see the module table), including that the
    /// gloss reading is one the coat can produce.
    pub fn validate(&self) -> Result<(), DesignError> {
        if self.name.trim().is_empty() {
            return Err(invalid(
                "name",
                format!("name = {} is empty", toml_string(&self.name)),
            ));
        }
        check_table(
            "pigment.albedo",
            self.albedo.wavelengths_nm(),
            self.albedo.values(),
            &ALBEDO,
        )?;
        match &self.refractive_index {
            RefractiveIndex::Cauchy { a, b_um2 } => check_cauchy(*a, *b_um2)?,
            RefractiveIndex::Table(table) => check_table(
                "clear_coat.refractive_index.table",
                table.wavelengths_nm(),
                table.values(),
                &REFRACTIVE_INDEX,
            )?,
        }
        match &self.absorption_per_um {
            Absorption::Constant(k) => {
                check_value("clear_coat.absorption_per_um.constant", *k, &ABSORPTION)?;
            }
            Absorption::Table(table) => check_table(
                "clear_coat.absorption_per_um.table",
                table.wavelengths_nm(),
                table.values(),
                &ABSORPTION,
            )?,
        }
        check_value("clear_coat.thickness_um", self.thickness_um, &THICKNESS)?;
        check_value("gloss.gu", self.gloss.gu, &GLOSS)?;
        if let Some(tolerance) = &self.tolerance {
            let limits = std::iter::once(tolerance.default_limit)
                .chain(tolerance.per_angle.iter().map(|(_, limit)| *limit));
            let angles_finite = tolerance
                .per_angle
                .iter()
                .all(|(angle, _)| angle.is_finite());
            if !limits.into_iter().all(|l| l.is_finite() && l > 0.0) || !angles_finite {
                return Err(invalid(
                    "tolerance.spec",
                    format!(
                        "tolerance.spec = {}: every limit must be a positive number and every angle finite",
                        toml_string(&tolerance_spec(tolerance))
                    ),
                ));
            }
        }
        self.exponent().map(|_| ())
    }

    /// ρ(λ) on a grid.
    pub fn albedo_on(&self, grid: &WavelengthGrid) -> SampledSpectrum {
        self.albedo.to_grid(grid)
    }

    /// n(λ) on a grid (bin means).
    pub fn refractive_index_on(&self, grid: &WavelengthGrid) -> SampledSpectrum {
        self.refractive_index.on_grid(grid)
    }

    /// k(λ) on a grid, 1/µm.
    pub fn absorption_on(&self, grid: &WavelengthGrid) -> SampledSpectrum {
        self.absorption_per_um.on_grid(grid)
    }

    /// n at one wavelength (nm); at [`GLOSS_WAVELENGTH_NM`] it sets the gloss.
    pub fn refractive_index_at_nm(&self, wavelength_nm: f64) -> f64 {
        self.refractive_index.at_nm(wavelength_nm)
    }

    /// The paint model of this design on a wavelength grid, with all derived tables.
    pub fn model(&self, grid: WavelengthGrid) -> Result<PaintModel, DesignError> {
        self.validate()?;
        let params = PaintParams {
            channels: grid.into(),
            albedo: self.albedo_on(&grid).into_values(),
            refractive_index: self.refractive_index_on(&grid).into_values(),
            index_at_gloss_wavelength: self.refractive_index_at_nm(GLOSS_WAVELENGTH_NM),
            absorption_per_um: self.absorption_on(&grid).into_values(),
            thickness_um: self.thickness_um,
            gloss: GlossSetting::Reading {
                gu: self.gloss.gu,
                geometry: self.gloss.geometry,
            },
            lobe: self.lobe,
        };
        PaintModel::new(params).map_err(|error| DesignError::Invalid {
            field: "design".to_string(),
            message: format!("{}: {error}", self.name),
        })
    }

    /// Brings `model`, built from `previous` on its grid, up to this design through
    /// the model's setters, so an edit rebuilds only the derived tables the changed
    /// fields touch (ρ: the body factor alone; see [`PaintModel`]'s setters). Where
    /// a setter refuses an intermediate state (n and gloss changed together, say),
    /// the model is built anew.
    pub fn update_model(
        &self,
        previous: &PaintDesign,
        model: &mut PaintModel,
    ) -> Result<(), DesignError> {
        self.validate()?;
        let Some(&grid) = model.channels().grid() else {
            return Err(DesignError::NotSpectral {
                name: self.name.clone(),
            });
        };
        let mut apply = || -> Result<(), crate::paint::model::ParamError> {
            if self.albedo != previous.albedo {
                model.set_albedo(self.albedo_on(&grid).into_values())?;
            }
            if self.refractive_index != previous.refractive_index {
                model.set_refractive_index(
                    self.refractive_index_on(&grid).into_values(),
                    self.refractive_index_at_nm(GLOSS_WAVELENGTH_NM),
                )?;
            }
            if self.absorption_per_um != previous.absorption_per_um {
                model.set_absorption(self.absorption_on(&grid).into_values())?;
            }
            if self.thickness_um != previous.thickness_um {
                model.set_thickness(self.thickness_um)?;
            }
            if self.gloss != previous.gloss {
                model.set_gloss(GlossSetting::Reading {
                    gu: self.gloss.gu,
                    geometry: self.gloss.geometry,
                })?;
            }
            model.set_lobe(self.lobe);
            Ok(())
        };
        if apply().is_err() {
            *model = self.model(grid)?;
        }
        Ok(())
    }

    /// The lobe exponent m(g) from the gloss reading, its geometry and n at 587.6 nm
    /// (spec 4.3): finite, or the ideal mirror for readings at or above the coat's
    /// mirror reading. Errors for readings below what the broadest lobe gives.
    pub fn exponent(&self) -> Result<GlossExponent, DesignError> {
        let n = self.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
        exponent_from_reading(self.gloss.geometry, n, self.gloss.gu).map_err(|error| {
            DesignError::Gloss {
                gu: self.gloss.gu,
                error,
            }
        })
    }
}

// ---------------------------------------------------------------------------------
// Checks

/// `field = value` against its parameter's range; the message names the field, the
/// value, the parameter and its range.
fn check_value(field: &str, value: f64, parameter: &'static Parameter) -> Result<(), DesignError> {
    match parameter.range.violation(value) {
        None => Ok(()),
        Some(violation) => Err(invalid(
            field,
            format!(
                "{field} = {value} {violation}: {} must lie in {}",
                parameter.label(),
                parameter.range_text()
            ),
        )),
    }
}

fn check_finite(field: &str, value: f64) -> Result<(), DesignError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("{field} = {value} is not a finite number"),
        ))
    }
}

/// A table's shape (lengths, increasing positive wavelengths, coverage) and values.
fn check_table(
    field: &str,
    wavelengths_nm: &[f64],
    values: &[f64],
    parameter: &'static Parameter,
) -> Result<(), DesignError> {
    if values.len() != wavelengths_nm.len() {
        return Err(invalid(
            field,
            format!(
                "{field} has {} values for {} wavelengths; they must pair up",
                values.len(),
                wavelengths_nm.len()
            ),
        ));
    }
    if wavelengths_nm.len() < 2 {
        return Err(invalid(
            field,
            format!(
                "{field} has {} sample(s); a table needs at least 2",
                wavelengths_nm.len()
            ),
        ));
    }
    for (index, &wavelength_nm) in wavelengths_nm.iter().enumerate() {
        let element = format!("{field}.wavelength_nm[{index}]");
        check_finite(&element, wavelength_nm)?;
        if wavelength_nm <= 0.0 {
            return Err(invalid(
                element.clone(),
                format!("{element} = {wavelength_nm} nm is not a positive wavelength"),
            ));
        }
        if index > 0 && wavelength_nm <= wavelengths_nm[index - 1] {
            return Err(invalid(
                element.clone(),
                format!(
                    "{element} = {wavelength_nm} nm is not greater than the one before it ({} nm); wavelengths must strictly increase",
                    wavelengths_nm[index - 1]
                ),
            ));
        }
    }
    let (first_nm, last_nm) = (wavelengths_nm[0], wavelengths_nm[wavelengths_nm.len() - 1]);
    let (need_lo_nm, need_hi_nm) = REQUIRED_COVERAGE_NM;
    if first_nm > need_lo_nm || last_nm < need_hi_nm {
        let element = format!("{field}.wavelength_nm");
        return Err(invalid(
            element.clone(),
            format!(
                "{element} covers {first_nm}–{last_nm} nm; a design's spectra must cover at least {need_lo_nm}–{need_hi_nm} nm"
            ),
        ));
    }
    for (index, (&value, &wavelength_nm)) in values.iter().zip(wavelengths_nm).enumerate() {
        let Some(violation) = parameter.range.violation(value) else {
            continue;
        };
        let element = format!("{field}.value[{index}]");
        return Err(invalid(
            element.clone(),
            format!(
                "{element} = {value} at {wavelength_nm} nm {violation}: {} must lie in {}",
                parameter.label(),
                parameter.range_text()
            ),
        ));
    }
    Ok(())
}

/// Coefficients in their ranges and n(λ) in [`REFRACTIVE_INDEX`]'s range over the
/// visible range. n(λ) is monotonic in λ, so its minimum over the range is at one
/// end: 780 nm for normal dispersion (b > 0), 380 nm otherwise.
fn check_cauchy(a: f64, b_um2: f64) -> Result<(), DesignError> {
    check_value("clear_coat.refractive_index.cauchy.a", a, &CAUCHY_A)?;
    check_value("clear_coat.refractive_index.cauchy.b_um2", b_um2, &CAUCHY_B)?;
    let index = RefractiveIndex::Cauchy { a, b_um2 };
    let at_nm = if b_um2 >= 0.0 {
        VISIBLE.end_nm
    } else {
        VISIBLE.start_nm
    };
    let n = index.at_nm(at_nm);
    if let Some(violation) = REFRACTIVE_INDEX.range.violation(n) {
        return Err(invalid(
            "clear_coat.refractive_index",
            format!(
                "clear_coat.refractive_index: Cauchy n({at_nm} nm) = {n:.4} {violation} (a = {a}, b_um2 = {b_um2}); {} must lie in {} over {VISIBLE}",
                REFRACTIVE_INDEX.label(),
                REFRACTIVE_INDEX.range_text()
            ),
        ));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------
// Reading

/// The file as written: sections as a paint engineer thinks of the film. Unknown keys
/// are refused everywhere so a typo cannot silently fall back to something else.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DesignFile {
    #[allow(
        dead_code,
        reason = "checked before the full parse, present so it is not unknown"
    )]
    format: String,
    #[allow(
        dead_code,
        reason = "checked before the full parse, present so it is not unknown"
    )]
    version: i64,
    name: String,
    #[serde(default)]
    description: Option<String>,
    pigment: PigmentSection,
    clear_coat: ClearCoatSection,
    gloss: GlossSection,
    #[serde(default)]
    tolerance: Option<ToleranceSection>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ToleranceSection {
    version: i64,
    spec: String,
}

impl ToleranceSection {
    fn into_tolerance(self) -> Result<Tolerance, DesignError> {
        if self.version > TOLERANCE_VERSION {
            return Err(invalid(
                "tolerance.version",
                format!(
                    "tolerance.version = {}: this tolerance was written by a newer Coatlab (this one reads up to version {TOLERANCE_VERSION}); update Coatlab, or remove the [tolerance] table",
                    self.version
                ),
            ));
        }
        if self.version < 1 {
            return Err(invalid(
                "tolerance.version",
                format!(
                    "tolerance.version = {} is not a tolerance version (this Coatlab reads version {TOLERANCE_VERSION})",
                    self.version
                ),
            ));
        }
        self.spec.parse().map_err(|error| {
            invalid(
                "tolerance.spec",
                format!("tolerance.spec = {}: {error}", toml_string(&self.spec)),
            )
        })
    }
}

/// A tolerance in the `--tolerance` syntax, which [`Tolerance`]'s `FromStr` reads
/// back to an equal value (numbers in Rust's shortest round-trip form).
pub fn tolerance_spec(tolerance: &Tolerance) -> String {
    let formula = match tolerance.formula {
        Formula::De00 => "de00",
        Formula::DeAb => "deab",
        Formula::Cmc => "cmc",
    };
    let mut spec = format!("{formula}:{}", tolerance.default_limit);
    for (angle, limit) in &tolerance.per_angle {
        spec.push_str(&format!(",{angle}={limit}"));
    }
    spec
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PigmentSection {
    albedo: TableFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ClearCoatSection {
    thickness_um: f64,
    refractive_index: IndexFile,
    absorption_per_um: AbsorptionFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
enum IndexFile {
    Cauchy(CauchyFile),
    Table(TableFile),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CauchyFile {
    a: f64,
    b_um2: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
enum AbsorptionFile {
    Constant(f64),
    Table(TableFile),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GlossSection {
    gu: f64,
    geometry_deg: GlossGeometry,
    lobe: LobeKind,
}

/// `TabulatedSpectrum`'s own serde form ignores unknown keys; this one refuses them.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TableFile {
    wavelength_nm: Vec<f64>,
    value: Vec<f64>,
}

impl TableFile {
    /// Checks with field names, then builds the spectrum (whose own checks then pass).
    fn into_spectrum(
        self,
        field: &str,
        parameter: &'static Parameter,
    ) -> Result<TabulatedSpectrum, DesignError> {
        check_table(field, &self.wavelength_nm, &self.value, parameter)?;
        TabulatedSpectrum::new(self.wavelength_nm, self.value)
            .map_err(|error| invalid(field, format!("{field}: {error}")))
    }
}

fn parse_design(text: &str) -> Result<PaintDesign, DesignError> {
    // Format and version first, from a schema-free parse: a newer file with new keys
    // must say "newer Coatlab", not "unknown field".
    let table: toml::Table = toml::from_str(text).map_err(toml_error)?;
    match table.get("format") {
        Some(toml::Value::String(format)) if format == FORMAT_NAME => {}
        Some(other) => {
            return Err(DesignError::NotADesign {
                found: format!("format = {other}"),
            });
        }
        None => {
            return Err(DesignError::NotADesign {
                found: "no `format` key".to_owned(),
            });
        }
    }
    match table.get("version") {
        Some(toml::Value::Integer(version)) if *version == FORMAT_VERSION => {}
        Some(toml::Value::Integer(version)) if *version > FORMAT_VERSION => {
            return Err(DesignError::NewerVersion { found: *version });
        }
        Some(other) => {
            return Err(DesignError::UnknownVersion {
                found: other.to_string(),
            });
        }
        None => {
            return Err(invalid(
                "version",
                format!("no `version` key (this Coatlab writes version = {FORMAT_VERSION})"),
            ));
        }
    }

    let file: DesignFile = toml::from_str(text).map_err(toml_error)?;
    let refractive_index = match file.clear_coat.refractive_index {
        IndexFile::Cauchy(CauchyFile { a, b_um2 }) => RefractiveIndex::Cauchy { a, b_um2 },
        IndexFile::Table(table) => RefractiveIndex::Table(
            table.into_spectrum("clear_coat.refractive_index.table", &REFRACTIVE_INDEX)?,
        ),
    };
    let absorption_per_um = match file.clear_coat.absorption_per_um {
        AbsorptionFile::Constant(k) => Absorption::Constant(k),
        AbsorptionFile::Table(table) => Absorption::Table(
            table.into_spectrum("clear_coat.absorption_per_um.table", &ABSORPTION)?,
        ),
    };
    let design = PaintDesign {
        name: file.name,
        description: file.description,
        albedo: file
            .pigment
            .albedo
            .into_spectrum("pigment.albedo", &ALBEDO)?,
        refractive_index,
        absorption_per_um,
        thickness_um: file.clear_coat.thickness_um,
        gloss: Gloss {
            gu: file.gloss.gu,
            geometry: file.gloss.geometry_deg,
        },
        lobe: file.gloss.lobe,
        tolerance: file
            .tolerance
            .map(ToleranceSection::into_tolerance)
            .transpose()?,
    };
    design.validate()?;
    Ok(design)
}

fn toml_error(error: toml::de::Error) -> DesignError {
    DesignError::Toml {
        message: error.to_string().trim_end().to_owned(),
    }
}

// ---------------------------------------------------------------------------------
// Writing

/// Values per line in written arrays: nine 5 nm samples span 40 nm, so lines start at
/// 380, 425, 470, ... and stay short enough to read.
const VALUES_PER_LINE: usize = 9;

fn write_design(design: &PaintDesign) -> String {
    // `write!` into a String cannot fail; the results are ignored for that reason.
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Coatlab paint design: a gloss solid paint, clear coat over an opaque pigment layer."
    );
    let _ = writeln!(out, "format = {}", toml_string(FORMAT_NAME));
    let _ = writeln!(out, "version = {FORMAT_VERSION}");
    let _ = writeln!(out, "name = {}", toml_string(&design.name));
    if let Some(description) = &design.description {
        let _ = writeln!(out, "description = {}", toml_string(description));
    }

    out.push_str(
        "\n# Pigment layer: Lambertian diffuse albedo ρ(λ) in [0, 1], linear between samples.\n",
    );
    out.push_str("[pigment.albedo]\n");
    write_table(&mut out, &design.albedo);

    out.push_str("\n# Clear coat: smooth dielectric slab that absorbs but does not scatter.\n");
    out.push_str("[clear_coat]\n");
    let _ = writeln!(out, "thickness_um = {}", toml_float(design.thickness_um));
    if let RefractiveIndex::Cauchy { a, b_um2 } = &design.refractive_index {
        out.push_str("# n(λ) = a + b_um2 / λ², λ in µm\n");
        let _ = writeln!(
            out,
            "refractive_index = {{ cauchy = {{ a = {}, b_um2 = {} }} }}",
            toml_float(*a),
            toml_float(*b_um2)
        );
    }
    if let Absorption::Constant(k) = &design.absorption_per_um {
        out.push_str("# absorption coefficient k, 1/µm (optical depth τ = k·h)\n");
        let _ = writeln!(
            out,
            "absorption_per_um = {{ constant = {} }}",
            toml_float(*k)
        );
    }
    if let RefractiveIndex::Table(table) = &design.refractive_index {
        out.push_str("\n# Refractive index n(λ), linear between samples.\n");
        out.push_str("[clear_coat.refractive_index.table]\n");
        write_table(&mut out, table);
    }
    if let Absorption::Table(table) = &design.absorption_per_um {
        out.push_str("\n# Absorption coefficient k(λ), 1/µm (optical depth τ = k·h), linear between samples.\n");
        out.push_str("[clear_coat.absorption_per_um.table]\n");
        write_table(&mut out, table);
    }

    out.push_str(
        "\n# Specular gloss as an ISO 2813 glossmeter reads it (geometry 20, 60 or 85 degrees);\n",
    );
    out.push_str(
        "# it sets the lobe exponent m. lobe = \"normalised\" (energy-conserving) or \"paper\".\n",
    );
    out.push_str("[gloss]\n");
    let _ = writeln!(out, "gu = {}", toml_float(design.gloss.gu));
    let _ = writeln!(out, "geometry_deg = {}", u32::from(design.gloss.geometry));
    let _ = writeln!(out, "lobe = {}", toml_string(design.lobe.name()));
    if let Some(tolerance) = &design.tolerance {
        out.push_str(
            "\n# Pass/fail limits against a target, as `coatlab measure --tolerance` takes them:\n",
        );
        out.push_str("# [FORMULA:]LIMIT[,ANGLE=LIMIT...], FORMULA de00, deab or cmc (2:1).\n");
        out.push_str("[tolerance]\n");
        let _ = writeln!(out, "version = {TOLERANCE_VERSION}");
        let _ = writeln!(out, "spec = {}", toml_string(&tolerance_spec(tolerance)));
    }
    out
}

fn write_table(out: &mut String, table: &TabulatedSpectrum) {
    write_array(
        out,
        "wavelength_nm",
        table.wavelengths_nm(),
        toml_wavelength,
    );
    write_array(out, "value", table.values(), toml_float);
}

fn write_array(out: &mut String, key: &str, values: &[f64], format: fn(f64) -> String) {
    let _ = writeln!(out, "{key} = [");
    for line in values.chunks(VALUES_PER_LINE) {
        let items: Vec<String> = line.iter().map(|&v| format(v)).collect();
        let _ = writeln!(out, "    {},", items.join(", "));
    }
    out.push_str("]\n");
}

/// Shortest text that reads back as the same f64. Non-finite values (which a valid
/// design never has) use TOML's own literals so the output always parses and the
/// reader can name the field.
fn toml_float(value: f64) -> String {
    if value.is_nan() {
        "nan".to_owned()
    } else if value.is_infinite() {
        if value > 0.0 { "inf" } else { "-inf" }.to_owned()
    } else {
        // `{:?}` always has a '.' or an exponent, which TOML needs to read a float.
        format!("{value:?}")
    }
}

/// Whole wavelengths as integers (`380`, not `380.0`): that is how people write them,
/// and an integer reads back as exactly the same f64.
fn toml_wavelength(value: f64) -> String {
    if value.is_finite() && value.fract() == 0.0 && value.abs() < 1e15 {
        format!("{}", value as i64)
    } else {
        toml_float(value)
    }
}

/// A TOML basic string.
fn toml_string(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

// ---------------------------------------------------------------------------------
// Presets

/// The illustrative preset designs shipped in `assets/presets/`, written there by
/// `cargo run -p coatlab-core --example make_presets`.
///
/// The pigment albedos are smooth models shaped after typical published reflectance
/// curves of each pigment family, not measured data. The clear coat is one
/// 2K-polyurethane-like coat: Cauchy n = 1.515 + 0.0045/λ² (n = 1.528 at 587.6 nm)
/// and a UV absorber.
pub mod presets {
    use super::{Absorption, Gloss, PaintDesign, RefractiveIndex};
    use crate::colour::spectrum::{TabulatedSpectrum, WavelengthGrid};
    use crate::paint::gloss::GlossGeometry;
    use crate::paint::lobe::LobeKind;
    use crate::paint::parameters;

    /// A preset: its file stem and its design.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Preset {
        /// File stem in `assets/presets/` (`signal-red` → `signal-red.toml`).
        pub slug: &'static str,
        /// The design.
        pub design: PaintDesign,
    }

    /// The preset whose file stem is `slug` (`"signal-red"`).
    pub fn by_slug(slug: &str) -> Option<Preset> {
        all().into_iter().find(|p| p.slug == slug)
    }

    /// Every preset, in a stable order.
    pub fn all() -> Vec<Preset> {
        let white = white_albedo;
        let black = black_albedo;
        vec![
            preset(
                "signal-red",
                "Signal red",
                "Solid red from an organic red pigment (diketopyrrolopyrrole-like): low reflectance \
                 through the blue and green, a steep rise near 600 nm to a high red plateau.",
                red_albedo,
                coat(45.0, 88.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "pure-white",
                "Pure white",
                "Solid white from rutile TiO2: its absorption edge makes the reflectance rise steeply \
                 from ~380 to ~420 nm, then an almost flat plateau near 0.9.",
                white,
                coat(40.0, 87.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "jet-black",
                "Jet black",
                "Solid black from carbon black: flat, 0.04 falling to 0.035 across the visible.",
                black,
                coat(50.0, 89.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "deep-blue",
                "Deep blue",
                "Deep solid blue from a phthalocyanine-blue-like pigment: a reflectance peak near \
                 450 nm, low through green and red, and the rise beyond 700 nm typical of \
                 phthalocyanines.",
                blue_albedo,
                coat(45.0, 88.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "sunflower-yellow",
                "Sunflower yellow",
                "Solid yellow from a bismuth-vanadate-like yellow: low in the violet and blue, an \
                 edge near 500 nm, a high plateau from 550 nm.",
                yellow_albedo,
                coat(45.0, 87.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "mid-grey",
                "Mid grey",
                "Mid grey (ρ = 0.20 at 550 nm) mixed from the white and black presets' pigments by \
                 single-constant Kubelka-Munk mixing (K/S adds by concentration).",
                || grey_albedo(0.20, &white(), &black()),
                coat(45.0, 88.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "silver-grey",
                "Silver grey",
                "Light solid grey (ρ = 0.45 at 550 nm) mixed from the white and black presets' \
                 pigments by single-constant Kubelka-Munk mixing.",
                || grey_albedo(0.45, &white(), &black()),
                coat(45.0, 88.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "racing-green",
                "Racing green",
                "Deep solid green from a phthalocyanine-green-like pigment: a reflectance peak near \
                 520 nm, low in the blue and red, rising beyond 700 nm.",
                green_albedo,
                coat(45.0, 88.0, GlossGeometry::Deg20, LobeKind::Normalised),
            ),
            preset(
                "satin-grey",
                "Satin grey",
                "The mid grey pigment under a satin clear coat, specified at 60° (the geometry for \
                 mid gloss) with the paper's unnormalised lobe.",
                || grey_albedo(0.20, &white(), &black()),
                coat(40.0, 45.0, GlossGeometry::Deg60, LobeKind::Paper),
            ),
        ]
    }

    /// The clear coat shared by the presets, with its thickness and gloss.
    struct Coat {
        thickness_um: f64,
        gloss: Gloss,
        lobe: LobeKind,
    }

    fn coat(thickness_um: f64, gu: f64, geometry: GlossGeometry, lobe: LobeKind) -> Coat {
        Coat {
            thickness_um,
            gloss: Gloss { gu, geometry },
            lobe,
        }
    }

    /// Cauchy coefficients of the presets' clear coat: the parameter table's
    /// defaults (n(587.6 nm) = 1.528; see there why).
    const CAUCHY_A: f64 = parameters::CAUCHY_A.default;
    const CAUCHY_B_UM2: f64 = parameters::CAUCHY_B.default;

    fn preset(
        slug: &'static str,
        name: &str,
        pigment: &str,
        albedo: impl Fn() -> Vec<f64>,
        coat: Coat,
    ) -> Preset {
        let grid = WavelengthGrid::reference();
        let values = albedo()
            .into_iter()
            .map(|v| round_decimals(v.clamp(0.0, 1.0), 4))
            .collect();
        let albedo = TabulatedSpectrum::new(grid.wavelengths_nm().collect(), values)
            .expect("the reference grid is increasing and the models are finite");
        Preset {
            slug,
            design: PaintDesign {
                name: name.to_owned(),
                description: Some(format!(
                    "{pigment} Illustrative preset: the albedo is a smooth model shaped after typical \
                     published reflectance curves of the pigment family, not measured data. Clear coat: \
                     Cauchy n = {CAUCHY_A} + {CAUCHY_B_UM2}/λ², UV absorber below 400 nm."
                )),
                albedo,
                refractive_index: RefractiveIndex::Cauchy {
                    a: CAUCHY_A,
                    b_um2: CAUCHY_B_UM2,
                },
                absorption_per_um: Absorption::Table(uv_absorber_clear_coat()),
                thickness_um: coat.thickness_um,
                gloss: coat.gloss,
                lobe: coat.lobe,
                tolerance: None,
            },
        }
    }

    /// k(λ) of a clear coat with a hydroxyphenyl-triazine-like UV absorber, 300–780 nm
    /// every 10 nm: ~0.15/µm in the UV (a 45 µm coat passes ~0.1 % at 350 nm), a steep
    /// logistic edge centred at 372 nm (45 µm pass ~25 % at 380 nm, ~94 % at 400 nm),
    /// and 1.5–4e-4/µm in the visible, slightly higher toward the blue (the faint
    /// yellowness of cured binder), so τ = k·h stays below 0.02.
    pub fn uv_absorber_clear_coat() -> TabulatedSpectrum {
        let wavelengths_nm: Vec<f64> = (0..=48).map(|i| 300.0 + 10.0 * f64::from(i)).collect();
        let values = wavelengths_nm
            .iter()
            .map(|&l| {
                let uv = 0.15 * logistic(-(l - 372.0) / 6.0);
                let binder = 1.5e-4 + 2.5e-4 * (-(l - 400.0) / 80.0).exp();
                round_significant(uv + binder, 3)
            })
            .collect();
        TabulatedSpectrum::new(wavelengths_nm, values)
            .expect("increasing wavelengths, finite values")
    }

    fn logistic(x: f64) -> f64 {
        1.0 / (1.0 + (-x).exp())
    }

    fn gaussian(l: f64, centre_nm: f64, width_nm: f64) -> f64 {
        let x = (l - centre_nm) / width_nm;
        (-0.5 * x * x).exp()
    }

    fn on_reference_grid(f: impl Fn(f64) -> f64) -> Vec<f64> {
        WavelengthGrid::reference()
            .wavelengths_nm()
            .map(f)
            .collect()
    }

    /// Rutile TiO2 white: absorption edge at ~405 nm, plateau 0.90 easing to 0.88.
    fn white_albedo() -> Vec<f64> {
        on_reference_grid(|l| {
            0.05 + (0.85 - 0.02 * (l - 450.0).max(0.0) / 330.0) * logistic((l - 405.0) / 7.0)
        })
    }

    /// Carbon black: flat and very dark.
    fn black_albedo() -> Vec<f64> {
        on_reference_grid(|l| 0.040 - 0.005 * (l - 380.0) / 400.0)
    }

    /// Organic red: ~0.05 below 570 nm with a faint violet lift, edge at 600 nm,
    /// plateau ~0.78.
    fn red_albedo() -> Vec<f64> {
        on_reference_grid(|l| {
            0.045 + 0.02 * gaussian(l, 400.0, 20.0) + 0.735 * logistic((l - 600.0) / 10.0)
        })
    }

    /// Phthalocyanine-like blue masstone: peak ~0.24 at 450 nm, ~0.03 in the red,
    /// rising past 700 nm toward 0.45.
    fn blue_albedo() -> Vec<f64> {
        on_reference_grid(|l| {
            0.03 + 0.21 * gaussian(l, 450.0, 32.0) + 0.45 * logistic((l - 735.0) / 18.0)
        })
    }

    /// Bismuth-vanadate-like yellow: ~0.06 in the blue, edge at 495 nm, plateau ~0.86.
    fn yellow_albedo() -> Vec<f64> {
        on_reference_grid(|l| 0.06 + 0.80 * logistic((l - 495.0) / 12.0))
    }

    /// Phthalocyanine-like green masstone: peak ~0.13 at 520 nm, rise past 700 nm.
    fn green_albedo() -> Vec<f64> {
        on_reference_grid(|l| {
            0.035 + 0.10 * gaussian(l, 520.0, 35.0) + 0.35 * logistic((l - 740.0) / 20.0)
        })
    }

    /// A grey from two pigments by single-constant Kubelka–Munk mixing:
    /// K/S(λ) = (1 − c)·K/S_white(λ) + c·K/S_black(λ), with the black fraction c chosen
    /// so that ρ(550 nm) is `target_at_550`.
    fn grey_albedo(target_at_550: f64, white: &[f64], black: &[f64]) -> Vec<f64> {
        let k_over_s = |r: f64| (1.0 - r) * (1.0 - r) / (2.0 * r);
        let reflectance = |ks: f64| 1.0 + ks - (ks * ks + 2.0 * ks).sqrt();
        // 550 nm is sample 34 of the reference grid.
        let i550 = 34;
        let (w, b) = (k_over_s(white[i550]), k_over_s(black[i550]));
        let c = (k_over_s(target_at_550) - w) / (b - w);
        white
            .iter()
            .zip(black)
            .map(|(&w, &b)| reflectance((1.0 - c) * k_over_s(w) + c * k_over_s(b)))
            .collect()
    }

    /// Four decimals: as many as a spectrophotometer reports.
    fn round_decimals(value: f64, decimals: i32) -> f64 {
        let scale = 10f64.powi(decimals);
        (value * scale).round() / scale
    }

    fn round_significant(value: f64, digits: i32) -> f64 {
        if value == 0.0 {
            return 0.0;
        }
        let decimals = digits - 1 - value.abs().log10().floor() as i32;
        round_decimals(value, decimals)
    }
}
