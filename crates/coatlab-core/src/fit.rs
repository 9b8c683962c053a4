//! Fitting a design to a measured standard: the pigment albedo ρ(λ) that, under the
//! start design's clear coat, reproduces the standard's readings.
//!
//! The reading of the multi-angle instrument at one geometry is (spec 4, 7)
//!
//! ```text
//! R(λ) = π·R_F(μi)·S(ωi, ωo) + g(λ)·ρ/(1 − c(λ)·ρ)
//! ```
//!
//! with the specular part fixed by the coat and the gloss, g = T(μi)·T(μo)·
//! exp(−τ(1/μi′ + 1/μo′))/n² and c = C/π (the body term of spec 4.1 times π). The
//! body part is increasing in ρ, so the reading at one wavelength and geometry
//! fixes ρ; from the body part b = R − π·R_F·S,
//!
//! ```text
//! ρ = b / (g + c·b),
//! ```
//!
//! and the readings a coat allows lie between its surface reflection alone (ρ = 0)
//! and that plus g/(1 − c) (ρ = 1).
//!
//! Three cases:
//! - **one geometry with a spectrum**: ρ per wavelength by the closed form, clamped
//!   to [0, 1]; where it had to be clamped, the wavelength is reported unreachable;
//! - **several geometries**: a bounded least-squares fit of all the spectra, with a
//!   smoothness term on ρ's second derivative of weight [`SMOOTHNESS_WEIGHT`]
//!   (projected Gauss–Newton; the bounds are ρ ∈ [0, 1]);
//! - **stated colours only** (CIELAB or XYZ, no spectrum): the smoothest ρ whose
//!   readings have exactly those colours (the method of multipliers on the same
//!   smoothness term). Many spectra share a colour (a metamer set); this picks one.
//!
//! What is free is the caller's choice ([`FitRequest`], `--free`): by default ρ
//! alone, the coat (n, k, h) and the gloss coming from the start design. With any
//! coat parameter free, spectra at one or several geometries are fitted by the
//! bounded least squares of `fit/coat.rs` over ρ and those parameters together, the
//! standard's gloss readings included; colours alone cannot fix a coat and are
//! refused. Outside the measured wavelengths ρ is held flat at its end values.
//!
//! ```no_run
//! # use coatlab_core::{design::PaintDesign, fit, measurement};
//! # fn demo(start: &PaintDesign, m: &measurement::Measurement) -> Result<(), Box<dyn std::error::Error>> {
//! let standard = m.select(None)?;
//! let request = fit::FitRequest { free: fit::FreeParameters::parse("rho,gloss,h,k,n")? };
//! let fitted = fit::fit(start, &standard, &request)?;
//! println!("{} coat parameters fitted", fitted.coat.len());
//! # Ok(()) }
//! ```

use std::f64::consts::PI;

use crate::colour::cie::{Illuminant, Observer, TristimulusWeights, summation_weights};
use crate::colour::spectrum::{TabulatedSpectrum, VISIBLE, WavelengthGrid};
use crate::colour::tolerance::Tolerance;
use crate::colour::{Lab, ciede2000, lab_from_xyz};
use crate::design::{DesignError, PaintDesign};
use crate::instruments::{self, InstrumentError};
use crate::measurement::{Geometry, SampleColourError, Standard, interpolate};
use crate::paint::coat::body_brdf;
use crate::paint::fresnel::reflectance;
use crate::paint::model::PaintModel;
use crate::target::{Comparison, TargetError, compare_to_standard};

mod coat;
mod solve;

use solve::{Local, projected_newton, quadratic, smoothness_matrix};

/// The weight λ of the smoothness term: the objective
/// is mean(residual²) + λ·mean((ρ″·(10 nm)²)²). With λ = 10⁻³ a noiseless fit moves
/// ρ by less than 10⁻⁴ while 0.5 % measurement noise is damped.
pub const SMOOTHNESS_WEIGHT: f64 = 1e-3;

/// A reading beyond what ρ ∈ [0, 1] gives is reported when it lies beyond the
/// bound's reading by more than this (reflectance factor): rounding is not a finding.
const UNREACHABLE_MARGIN: f64 = 1e-6;

/// The parameters a fit may change (`--free`): any of ρ(λ) and the coat's gloss,
/// thickness h, absorption k and refractive index n; ρ alone by default.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FreeParameters {
    /// The pigment albedo ρ(λ) (`rho`).
    pub rho: bool,
    /// The gloss reading g at the start design's glossmeter geometry (`gloss`).
    pub gloss: bool,
    /// The clear coat thickness h (`h`).
    pub thickness: bool,
    /// The clear coat absorption k(λ), as a scale of the start's curve (`k`).
    pub absorption: bool,
    /// The clear coat refractive index n(λ), as a shift of the start's curve (`n`).
    pub index: bool,
}

impl Default for FreeParameters {
    fn default() -> Self {
        FreeParameters::RHO
    }
}

impl FreeParameters {
    /// ρ alone: the coat and gloss are the start design's.
    pub const RHO: FreeParameters = FreeParameters {
        rho: true,
        gloss: false,
        thickness: false,
        absorption: false,
        index: false,
    };

    /// The names `--free` takes, in its order.
    pub const NAMES: [&'static str; 5] = ["rho", "gloss", "h", "k", "n"];

    /// What each of [`Self::NAMES`] fits, in the same order (for the app's choice).
    pub const DESCRIPTIONS: [&'static str; 5] = [
        "the pigment albedo ρ(λ)",
        "the gloss reading g at the design's glossmeter geometry",
        "the clear coat thickness h",
        "the clear coat absorption k(λ), as a scale of its curve",
        "the clear coat refractive index n(λ), as a shift of its curve",
    ];

    /// Reads a comma-separated list of [`Self::NAMES`] (`ρ` for `rho` too), in any
    /// order, repeats allowed; an empty list or an unknown name is refused by name.
    pub fn parse(list: &str) -> Result<FreeParameters, FitError> {
        let mut free = FreeParameters {
            rho: false,
            ..FreeParameters::RHO
        };
        for item in list.split(',').map(str::trim) {
            let flag = free
                .flag_mut(item)
                .ok_or_else(|| FitError::UnknownParameter {
                    parameter: item.to_owned(),
                })?;
            *flag = true;
        }
        Ok(free)
    }

    /// The flag of the parameter named `name` (one of [`Self::NAMES`], or `ρ`).
    pub fn flag_mut(&mut self, name: &str) -> Option<&mut bool> {
        match name {
            "rho" | "ρ" => Some(&mut self.rho),
            "gloss" => Some(&mut self.gloss),
            "h" => Some(&mut self.thickness),
            "k" => Some(&mut self.absorption),
            "n" => Some(&mut self.index),
            _ => None,
        }
    }

    /// Whether anything at all is free (a fit needs one).
    pub fn any(&self) -> bool {
        self.rho || self.coat()
    }

    /// Whether any coat parameter (gloss, h, k, n) is free.
    pub fn coat(&self) -> bool {
        self.gloss || self.thickness || self.absorption || self.index
    }

    /// The free parameters' names, in the order of [`Self::NAMES`].
    pub fn names(&self) -> Vec<&'static str> {
        let flags = [
            self.rho,
            self.gloss,
            self.thickness,
            self.absorption,
            self.index,
        ];
        Self::NAMES
            .iter()
            .zip(flags)
            .filter(|(_, on)| *on)
            .map(|(name, _)| *name)
            .collect()
    }
}

/// As the list of names: `["rho", "gloss"]`.
impl serde::Serialize for FreeParameters {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.names().serialize(s)
    }
}

/// What to fit: the one entry point of the app's *Fit to target* and of
/// `coatlab fit` ([`fit`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FitRequest {
    /// What may change; the rest is the start design's.
    pub free: FreeParameters,
}

/// A coat parameter of a fit with it free: where it started, where it ended and
/// the box it was kept in (from the paint parameter table).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FittedParameter {
    /// Its `--free` name: `gloss`, `h`, `k` or `n`.
    pub name: &'static str,
    /// What the number is: "clear coat thickness h".
    pub label: String,
    /// The unit as a suffix (" µm"; empty for n).
    pub unit: String,
    pub start: f64,
    pub fitted: f64,
    pub lower: f64,
    pub upper: f64,
}

impl std::fmt::Display for FittedParameter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let at_bound = if self.fitted <= self.lower {
            " (at its lower bound)"
        } else if self.fitted >= self.upper {
            " (at its upper bound)"
        } else {
            ""
        };
        write!(
            f,
            "{}: {:.6}{unit} fitted to {:.6}{unit}{at_bound}, kept in [{:.6}, {:.6}]{unit}",
            self.label,
            self.start,
            self.fitted,
            self.lower,
            self.upper,
            unit = self.unit
        )
    }
}

/// The parameters of `--free` (see [`FreeParameters::parse`]).
pub fn parse_free(list: &str) -> Result<FreeParameters, FitError> {
    FreeParameters::parse(list)
}

/// How ρ was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// One geometry: the closed form per wavelength.
    ClosedForm,
    /// Several geometries: bounded least squares with the smoothness term.
    LeastSquares,
    /// Stated colours only: the smoothest ρ with those colours.
    SmoothestMetamer,
}

/// Which way a reading lies beyond what the coat allows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Beyond {
    /// Brighter than ρ = 1 gives under this coat.
    Brighter,
    /// Darker than the coat's surface reflection alone (ρ = 0).
    Darker,
}

/// A wavelength and geometry where the target cannot be reached.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Unreachable {
    pub geometry: Geometry,
    pub wavelength_nm: f64,
    pub beyond: Beyond,
    /// The target's reflectance factor.
    pub target: f64,
    /// The reading of ρ = 1 (brighter) or ρ = 0 (darker) under this coat.
    pub limit: f64,
}

impl std::fmt::Display for Unreachable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.beyond {
            Beyond::Brighter => write!(
                f,
                "{} at {} nm: the target reads {:.4}, brighter than ρ = 1 allows under this coat ({:.4})",
                self.geometry, self.wavelength_nm, self.target, self.limit
            ),
            Beyond::Darker => write!(
                f,
                "{} at {} nm: the target reads {:.4}, darker than the coat's surface reflection alone (ρ = 0 gives {:.4})",
                self.geometry, self.wavelength_nm, self.target, self.limit
            ),
        }
    }
}

/// Why a fit cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(
        "--free {parameter:?}: unknown parameter (expected a comma-separated list of rho, gloss, h, k, n)"
    )]
    UnknownParameter { parameter: String },
    #[error("nothing is free to fit: free at least one of rho, gloss, h, k, n")]
    NothingFree,
    #[error(
        "standard {name:?} states only colours: a coat (gloss, h, k, n) cannot be fitted to colours; free only rho, or fit a measurement with spectra"
    )]
    CoatNeedsSpectra { name: String },
    #[error("the coat fit's bounds: {0}")]
    Bounds(String),
    #[error(
        "standard {name:?} has no directional reading with a spectrum or a colour to fit (sphere readings are compared but not fitted; unstated geometries have no instrument)"
    )]
    NothingToFit { name: String },
    #[error("the start design: {0}")]
    Design(#[from] DesignError),
    #[error(transparent)]
    Instrument(#[from] InstrumentError),
    #[error(transparent)]
    Colour(#[from] SampleColourError),
    #[error(transparent)]
    Cie(#[from] crate::colour::cie::CieError),
    #[error(transparent)]
    Target(#[from] TargetError),
}

/// A fitted design and how it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The start design with the fitted ρ(λ).
    pub design: PaintDesign,
    pub method: Method,
    /// The wavelengths ρ was fitted at, nm.
    pub wavelength_nm: Vec<f64>,
    /// ρ there.
    pub albedo: Vec<f64>,
    /// The smoothness weight used (none for the closed form).
    pub smoothness_weight: Option<f64>,
    /// What was free.
    pub free: FreeParameters,
    /// The free coat parameters, start and fitted (empty when only ρ was free).
    pub coat: Vec<FittedParameter>,
    /// Readings the coat cannot produce with any ρ in [0, 1].
    pub unreachable: Vec<Unreachable>,
    /// What the reader should know (flat extension, metamers, the gloss not fitted).
    pub notes: Vec<String>,
}

/// The coat's share of one directional reading on the fit wavelengths.
#[derive(Clone)]
struct Reading {
    geometry: Geometry,
    /// π·R_F·S: the surface reflection.
    specular: Vec<f64>,
    /// g of the module docs.
    gain: Vec<f64>,
}

/// The coat's quantities on the fit wavelengths, from the start model on its grid.
#[derive(Clone)]
struct Coat {
    /// C/π.
    c: Vec<f64>,
    index: Vec<f64>,
    tau: Vec<f64>,
}

impl Coat {
    fn new(model: &PaintModel, grid: &[f64], wavelengths_nm: &[f64]) -> Self {
        let at = |values: &[f64]| -> Vec<f64> {
            wavelengths_nm
                .iter()
                .map(|&nm| interpolate(grid, values, nm))
                .collect()
        };
        Coat {
            c: at(model.coat_integral()).iter().map(|c| c / PI).collect(),
            index: at(model.refractive_index()),
            tau: at(model.optical_depth()),
        }
    }

    fn reading(&self, model: &PaintModel, geometry: Geometry) -> Option<Reading> {
        let Geometry::Directional {
            illumination_deg,
            aspecular_deg,
        } = geometry
        else {
            return None;
        };
        let direction = |deg: f64| {
            let t = f64::to_radians(deg);
            [t.sin(), 0.0, t.cos()]
        };
        // As the instrument: the illuminator on the −x side.
        let wi = direction(-illumination_deg);
        let wo = direction(illumination_deg - aspecular_deg);
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return None;
        }
        let lobe = model.lobe_value_reference(wi, wo);
        let specular = self
            .index
            .iter()
            .map(|&n| PI * reflectance(wi[2], n) * lobe)
            .collect();
        let gain = self
            .index
            .iter()
            .zip(&self.tau)
            .map(|(&n, &tau)| PI * body_brdf(1.0, n, tau, 0.0, wi[2], wo[2]))
            .collect();
        Some(Reading {
            geometry,
            specular,
            gain,
        })
    }
}

impl Reading {
    fn value(&self, coat: &Coat, j: usize, rho: f64) -> f64 {
        self.specular[j] + self.gain[j] * rho / (1.0 - coat.c[j] * rho)
    }

    fn slope(&self, coat: &Coat, j: usize, rho: f64) -> f64 {
        let d = 1.0 - coat.c[j] * rho;
        self.gain[j] / (d * d)
    }

    /// The closed-form inverse at one wavelength, unclamped.
    fn invert(&self, coat: &Coat, j: usize, target: f64) -> f64 {
        let b = target - self.specular[j];
        b / (self.gain[j] + coat.c[j] * b)
    }

    /// Whether `target` lies beyond the reading of the bound `rho` is at.
    fn beyond(&self, coat: &Coat, j: usize, rho: f64, target: f64) -> Option<(Beyond, f64)> {
        if rho >= 1.0 {
            let limit = self.value(coat, j, 1.0);
            (target > limit + UNREACHABLE_MARGIN).then_some((Beyond::Brighter, limit))
        } else if rho <= 0.0 {
            let limit = self.specular[j];
            (target < limit - UNREACHABLE_MARGIN).then_some((Beyond::Darker, limit))
        } else {
            None
        }
    }
}

/// Fits ρ(λ) alone of `start` to `standard`: [`fit`] with the default request.
pub fn fit_albedo(start: &PaintDesign, standard: &Standard<'_>) -> Result<Fit, FitError> {
    fit(start, standard, &FitRequest::default())
}

/// Where the readings at ρ's bounds cannot reach their targets.
fn unreachable_at(
    coat: &Coat,
    readings: &[Reading],
    targets: &[Vec<f64>],
    wavelength_nm: &[f64],
    albedo: &[f64],
) -> Vec<Unreachable> {
    let mut unreachable = Vec::new();
    for (reading, target) in readings.iter().zip(targets) {
        for (j, (&rho, &t)) in albedo.iter().zip(target).enumerate() {
            if let Some((beyond, limit)) = reading.beyond(coat, j, rho, t) {
                unreachable.push(Unreachable {
                    geometry: reading.geometry,
                    wavelength_nm: wavelength_nm[j],
                    beyond,
                    target: t,
                    limit,
                });
            }
        }
    }
    unreachable
}

/// ρ on the fit wavelengths as a design's table: flat end points make the flat
/// extension to the visible range explicit (a design file needs 400–700 nm).
fn albedo_table(wavelength_nm: &[f64], albedo: &[f64]) -> Result<TabulatedSpectrum, FitError> {
    let (lo, hi) = (wavelength_nm[0], wavelength_nm[wavelength_nm.len() - 1]);
    let mut table_nm = wavelength_nm.to_vec();
    let mut table_rho = albedo.to_vec();
    if lo > VISIBLE.start_nm {
        table_nm.insert(0, VISIBLE.start_nm);
        table_rho.insert(0, albedo[0]);
    }
    if hi < VISIBLE.end_nm {
        table_nm.push(VISIBLE.end_nm);
        table_rho.push(albedo[albedo.len() - 1]);
    }
    TabulatedSpectrum::new(table_nm, table_rho).map_err(|error| {
        FitError::Design(DesignError::Invalid {
            field: "pigment.albedo".to_owned(),
            message: format!("the fitted albedo: {error}"),
        })
    })
}

/// The standard's gloss readings at the glossmeter geometries the instruments
/// have (20°, 60°, 85°); others are left out with a note.
fn gloss_targets(
    standard: &Standard<'_>,
    notes: &mut Vec<String>,
) -> Vec<(crate::paint::gloss::GlossGeometry, f64)> {
    let mut targets: Vec<(crate::paint::gloss::GlossGeometry, f64)> = Vec::new();
    // A multi-angle file repeats the gloss on each angle's row: one reading per
    // geometry, the mean of its repeats.
    let mut counts: Vec<f64> = Vec::new();
    for g in standard.readings.iter().flat_map(|s| &s.gloss) {
        let geometry = (g.angle_deg.fract() == 0.0 && g.angle_deg >= 0.0)
            .then(|| crate::paint::gloss::GlossGeometry::try_from(g.angle_deg as u32).ok())
            .flatten();
        match geometry {
            Some(geometry) => match targets.iter().position(|(t, _)| *t == geometry) {
                Some(k) => {
                    counts[k] += 1.0;
                    targets[k].1 += (g.gu - targets[k].1) / counts[k];
                }
                None => {
                    targets.push((geometry, g.gu));
                    counts.push(1.0);
                }
            },
            None => notes.push(format!(
                "the gloss reading at {}° is not fitted: the glossmeter reads at 20°, 60° and 85°",
                g.angle_deg
            )),
        }
    }
    targets
}

/// Fits `start` to `standard`, changing what `request` frees (see the module
/// docs for the methods). The fitted design is `start` with those parameters
/// replaced; errors name the standard or the start design's fault.
pub fn fit(
    start: &PaintDesign,
    standard: &Standard<'_>,
    request: &FitRequest,
) -> Result<Fit, FitError> {
    let free = request.free;
    if !free.any() {
        return Err(FitError::NothingFree);
    }
    let grid = WavelengthGrid::reference();
    let model = start.model(grid)?;
    let grid_nm: Vec<f64> = grid.wavelengths_nm().collect();

    let spectral: Vec<_> = standard
        .readings
        .iter()
        .filter(|s| matches!(s.geometry, Geometry::Directional { .. }))
        .filter_map(|s| s.spectrum.as_ref().map(|r| (s.geometry, r)))
        .collect();
    let mut notes = Vec::new();
    let mut design = start.clone();
    let mut coat_parameters = Vec::new();
    let (method, wavelength_nm, albedo, unreachable) = if let Some(&(_, first)) = spectral.first() {
        let wavelength_nm = first.wavelengths_nm().to_vec();
        let coat = Coat::new(&model, &grid_nm, &wavelength_nm);
        let mut readings = Vec::new();
        let mut targets = Vec::new();
        for &(geometry, spectrum) in &spectral {
            let Some(reading) = coat.reading(&model, geometry) else {
                continue;
            };
            if spectrum.wavelengths_nm() != wavelength_nm.as_slice() {
                let note = "the readings are on different wavelengths; each is interpolated to \
                            those of the first"
                    .to_owned();
                if !notes.contains(&note) {
                    notes.push(note);
                }
            }
            targets.push(
                wavelength_nm
                    .iter()
                    .map(|&nm| spectrum.at_nm(nm))
                    .collect::<Vec<f64>>(),
            );
            readings.push(reading);
        }
        if readings.is_empty() {
            return Err(FitError::NothingToFit {
                name: standard.name.to_owned(),
            });
        }
        if free.coat() {
            let start_albedo: Vec<f64> = if free.rho {
                mean_inverse(&coat, &readings, &targets)
            } else {
                wavelength_nm
                    .iter()
                    .map(|&nm| start.albedo.value_at_nm(nm))
                    .collect()
            };
            let coat_targets = coat::Targets {
                wavelength_nm: &wavelength_nm,
                geometries: readings.iter().map(|r| r.geometry).collect(),
                spectra: &targets,
                gloss: gloss_targets(standard, &mut notes),
            };
            let outcome = coat::fit_coat(start, &coat_targets, free, &start_albedo)?;
            if free.thickness && free.absorption {
                let tau = outcome
                    .design
                    .absorption_per_um
                    .at_nm(crate::paint::gloss::GLOSS_WAVELENGTH_NM)
                    * outcome.design.thickness_um;
                notes.push(format!(
                    "h and k trade off: the readings depend on their product τ = k·h alone \
                     (fitted τ = {tau:.6} at 587.6 nm), so their split is not determined"
                ));
            }
            let unreachable = unreachable_at(
                &outcome.coat,
                &outcome.readings,
                &targets,
                &wavelength_nm,
                &outcome.albedo,
            );
            design = outcome.design;
            coat_parameters = outcome.parameters;
            (
                Method::LeastSquares,
                wavelength_nm,
                outcome.albedo,
                unreachable,
            )
        } else {
            let (method, albedo) = if readings.len() == 1 {
                let albedo = (0..wavelength_nm.len())
                    .map(|j| readings[0].invert(&coat, j, targets[0][j]).clamp(0.0, 1.0))
                    .collect();
                (Method::ClosedForm, albedo)
            } else {
                let albedo = least_squares(&coat, &readings, &targets, &wavelength_nm);
                (Method::LeastSquares, albedo)
            };
            let unreachable = unreachable_at(&coat, &readings, &targets, &wavelength_nm, &albedo);
            (method, wavelength_nm, albedo, unreachable)
        }
    } else {
        if free.coat() {
            return Err(FitError::CoatNeedsSpectra {
                name: standard.name.to_owned(),
            });
        }
        let albedo = smoothest_metamer(&model, &grid_nm, standard, &mut notes)?;
        notes.push(
            "the target states only colours: many spectra have them (a metamer set); this is \
             the smoothest ρ(λ) that does, and it may differ from the standard's own spectrum \
             under another light"
                .to_owned(),
        );
        (Method::SmoothestMetamer, grid_nm, albedo, Vec::new())
    };

    let (lo, hi) = (wavelength_nm[0], wavelength_nm[wavelength_nm.len() - 1]);
    if free.rho {
        if lo > VISIBLE.start_nm || hi < VISIBLE.end_nm {
            notes.push(format!(
                "outside the measured {lo}–{hi} nm, ρ is extended flat at its end values"
            ));
        }
        design.albedo = albedo_table(&wavelength_nm, &albedo)?;
    }
    if !free.coat() && standard.readings.iter().any(|s| !s.gloss.is_empty()) {
        notes.push(
            "the standard's gloss readings are not fitted: the gloss is the start design's"
                .to_owned(),
        );
    }
    design.validate()?;
    let smoothness_weight = (method != Method::ClosedForm && free.rho).then_some(SMOOTHNESS_WEIGHT);
    Ok(Fit {
        design,
        method,
        wavelength_nm,
        albedo,
        smoothness_weight,
        free,
        coat: coat_parameters,
        unreachable,
        notes,
    })
}

/// The fitted design against the standard: per geometry the residual ΔE00 (and the
/// rest of the comparison, with the metamerism index) and the spectral RMS.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FitReport {
    pub comparison: Comparison,
    /// Per compared spectral reading: (geometry, RMS of the reflectance-factor
    /// residual on the standard's wavelengths).
    pub spectral_rms: Vec<(Geometry, f64)>,
}

/// Compares the fitted design with the standard it was fitted to.
pub fn report(
    fit: &Fit,
    standard: &Standard<'_>,
    tolerance: &Tolerance,
) -> Result<FitReport, FitError> {
    let model = fit.design.model(WavelengthGrid::reference())?;
    let readings = instruments::measure(&model)?;
    let comparison = compare_to_standard(&model, &readings, standard, tolerance)?;
    let mut spectral_rms = Vec::new();
    for s in &standard.readings {
        let (
            Geometry::Directional {
                illumination_deg,
                aspecular_deg,
            },
            Some(spectrum),
        ) = (s.geometry, &s.spectrum)
        else {
            continue;
        };
        let reading = instruments::directional_reading(&model, illumination_deg, aspecular_deg)?;
        let sum: f64 = spectrum
            .wavelengths_nm()
            .iter()
            .zip(spectrum.factors())
            .map(|(&nm, &t)| {
                let d = interpolate(&readings.wavelength_nm, &reading.reflectance_factor, nm) - t;
                d * d
            })
            .sum();
        spectral_rms.push((s.geometry, (sum / spectrum.factors().len() as f64).sqrt()));
    }
    Ok(FitReport {
        comparison,
        spectral_rms,
    })
}

/// The mean over the readings of the closed-form ρ, each kept in [0, 1]: where the
/// least-squares fits start.
fn mean_inverse(coat: &Coat, readings: &[Reading], targets: &[Vec<f64>]) -> Vec<f64> {
    (0..coat.c.len())
        .map(|j| {
            let sum: f64 = readings
                .iter()
                .zip(targets)
                .map(|(r, t)| r.invert(coat, j, t[j]).clamp(0.0, 1.0))
                .sum();
            sum / readings.len() as f64
        })
        .collect()
}

/// ρ minimising mean((R_a(ρ) − target_a)²) + λ·ρᵀQρ over the box.
fn least_squares(
    coat: &Coat,
    readings: &[Reading],
    targets: &[Vec<f64>],
    wavelengths_nm: &[f64],
) -> Vec<f64> {
    let n = wavelengths_nm.len();
    let q = smoothness_matrix(wavelengths_nm);
    let weight = 1.0 / (readings.len() * n) as f64;
    let value = |rho: &[f64]| -> f64 {
        let data: f64 = readings
            .iter()
            .zip(targets)
            .map(|(r, t)| {
                (0..n)
                    .map(|j| (r.value(coat, j, rho[j]) - t[j]).powi(2))
                    .sum::<f64>()
            })
            .sum();
        weight * data + SMOOTHNESS_WEIGHT * quadratic(&q, rho)
    };
    let local = |rho: &[f64]| -> Local {
        let mut hessian: Vec<f64> = q.iter().map(|v| 2.0 * SMOOTHNESS_WEIGHT * v).collect();
        let mut gradient: Vec<f64> = (0..n)
            .map(|a| 2.0 * SMOOTHNESS_WEIGHT * (0..n).map(|b| q[a * n + b] * rho[b]).sum::<f64>())
            .collect();
        for (r, t) in readings.iter().zip(targets) {
            for j in 0..n {
                let residual = r.value(coat, j, rho[j]) - t[j];
                let slope = r.slope(coat, j, rho[j]);
                gradient[j] += 2.0 * weight * residual * slope;
                hessian[j * n + j] += 2.0 * weight * slope * slope;
            }
        }
        Local {
            value: value(rho),
            gradient,
            hessian,
        }
    };
    let start = mean_inverse(coat, readings, targets);
    let (lower, upper) = (vec![0.0; n], vec![1.0; n]);
    projected_newton(start, (&lower, &upper), (200, 0.0), local, &value)
}

/// One stated colour to reproduce: the tristimulus weights of its conditions on
/// the fit wavelengths and the target CIELAB.
struct ColourTarget {
    reading: Reading,
    weights: TristimulusWeights,
    lab: Lab,
}

/// CIELAB of `xyz` and its Jacobian ∂(L, a, b)/∂(X, Y, Z).
fn lab_and_jacobian(xyz: [f64; 3], white: [f64; 3]) -> (Lab, [[f64; 3]; 3]) {
    const EPSILON: f64 = 216.0 / 24389.0;
    const KAPPA: f64 = 24389.0 / 27.0;
    let mut f = [0.0; 3];
    let mut df = [0.0; 3];
    for i in 0..3 {
        let t = xyz[i] / white[i];
        if t > EPSILON {
            f[i] = t.cbrt();
            df[i] = 1.0 / (3.0 * f[i] * f[i] * white[i]);
        } else {
            f[i] = (KAPPA * t + 16.0) / 116.0;
            df[i] = KAPPA / (116.0 * white[i]);
        }
    }
    let lab = Lab::new(
        116.0 * f[1] - 16.0,
        500.0 * (f[0] - f[1]),
        200.0 * (f[1] - f[2]),
    );
    let jacobian = [
        [0.0, 116.0 * df[1], 0.0],
        [500.0 * df[0], -500.0 * df[1], 0.0],
        [0.0, 200.0 * df[1], -200.0 * df[2]],
    ];
    (lab, jacobian)
}

/// The smoothest ρ on the design's grid whose readings have the standard's stated
/// colours: min ρᵀQρ subject to Lab(ρ) = target at each geometry, 0 ≤ ρ ≤ 1, by the
/// method of multipliers (scaled form: min λρᵀQρ + K·Σ|Lab(ρ) − Lab_t + u|², then
/// u += Lab(ρ) − Lab_t, until the colours agree to 10⁻⁴ ΔE00).
fn smoothest_metamer(
    model: &PaintModel,
    grid_nm: &[f64],
    standard: &Standard<'_>,
    notes: &mut Vec<String>,
) -> Result<Vec<f64>, FitError> {
    let coat = Coat::new(model, grid_nm, grid_nm);
    let mut targets = Vec::new();
    for s in &standard.readings {
        let Some(colour) = s.colour.as_ref() else {
            continue;
        };
        let Some(reading) = coat.reading(model, s.geometry) else {
            continue;
        };
        let illuminant = colour.illuminant.unwrap_or(Illuminant::D65);
        let observer = colour.observer.unwrap_or(Observer::Cie1964TenDegree);
        if colour.illuminant.is_none() || colour.observer.is_none() {
            let note = format!(
                "the file does not name the illuminant and observer of its colours; \
                 {illuminant}/{observer} assumed"
            );
            if !notes.contains(&note) {
                notes.push(note);
            }
        }
        let (lab, _) = s.lab(illuminant, observer)?;
        let weights = summation_weights(illuminant, observer, grid_nm)?;
        targets.push(ColourTarget {
            reading,
            weights,
            lab,
        });
    }
    if targets.is_empty() {
        return Err(FitError::NothingToFit {
            name: standard.name.to_owned(),
        });
    }
    let n = grid_nm.len();
    let q = smoothness_matrix(grid_nm);
    let penalty = 10.0;
    let reflectance_of = |t: &ColourTarget, rho: &[f64]| -> Vec<f64> {
        (0..n).map(|j| t.reading.value(&coat, j, rho[j])).collect()
    };
    let white = |t: &ColourTarget| {
        let w = t.weights.white();
        [w.x, w.y, w.z]
    };
    let lab_of = |t: &ColourTarget, rho: &[f64]| -> Lab {
        lab_from_xyz(t.weights.xyz(&reflectance_of(t, rho)), t.weights.white())
    };
    // The rows of the tristimulus weights, for the Jacobian.
    let rows: Vec<[Vec<f64>; 3]> = targets
        .iter()
        .map(|t| {
            let unit = |i: usize| {
                let mut e = vec![0.0; n];
                e[i] = 1.0;
                t.weights.xyz(&e)
            };
            let columns: Vec<_> = (0..n).map(unit).collect();
            [
                columns.iter().map(|c| c.x).collect(),
                columns.iter().map(|c| c.y).collect(),
                columns.iter().map(|c| c.z).collect(),
            ]
        })
        .collect();
    let mut shift = vec![[0.0f64; 3]; targets.len()];
    let mut rho = vec![0.5; n];
    let (lower, upper) = (vec![0.0; n], vec![1.0; n]);
    for _ in 0..60 {
        let value = |rho: &[f64]| -> f64 {
            let data: f64 = targets
                .iter()
                .zip(&shift)
                .map(|(t, u)| {
                    let lab = lab_of(t, rho);
                    (lab.l - t.lab.l + u[0]).powi(2)
                        + (lab.a - t.lab.a + u[1]).powi(2)
                        + (lab.b - t.lab.b + u[2]).powi(2)
                })
                .sum();
            penalty * data + SMOOTHNESS_WEIGHT * quadratic(&q, rho)
        };
        let local = |rho: &[f64]| -> Local {
            let mut hessian: Vec<f64> = q.iter().map(|v| 2.0 * SMOOTHNESS_WEIGHT * v).collect();
            let mut gradient: Vec<f64> = (0..n)
                .map(|a| {
                    2.0 * SMOOTHNESS_WEIGHT * (0..n).map(|b| q[a * n + b] * rho[b]).sum::<f64>()
                })
                .collect();
            for ((t, u), row) in targets.iter().zip(&shift).zip(&rows) {
                let xyz = t.weights.xyz(&reflectance_of(t, rho));
                let (lab, dlab) = lab_and_jacobian([xyz.x, xyz.y, xyz.z], white(t));
                let residual = [
                    lab.l - t.lab.l + u[0],
                    lab.a - t.lab.a + u[1],
                    lab.b - t.lab.b + u[2],
                ];
                // ∂Lab/∂ρ_j = dlab · (row_k[j] · dR/dρ_j).
                let jac: Vec<[f64; 3]> = (0..n)
                    .map(|j| {
                        let slope = t.reading.slope(&coat, j, rho[j]);
                        let dxyz = [row[0][j] * slope, row[1][j] * slope, row[2][j] * slope];
                        let mut out = [0.0; 3];
                        for (k, o) in out.iter_mut().enumerate() {
                            *o = (0..3).map(|i| dlab[k][i] * dxyz[i]).sum();
                        }
                        out
                    })
                    .collect();
                for a in 0..n {
                    gradient[a] +=
                        2.0 * penalty * (0..3).map(|k| residual[k] * jac[a][k]).sum::<f64>();
                    for b in 0..n {
                        hessian[a * n + b] +=
                            2.0 * penalty * (0..3).map(|k| jac[a][k] * jac[b][k]).sum::<f64>();
                    }
                }
            }
            Local {
                value: value(rho),
                gradient,
                hessian,
            }
        };
        rho = projected_newton(rho, (&lower, &upper), (200, 0.0), local, &value);
        let mut worst = 0.0f64;
        for (t, u) in targets.iter().zip(shift.iter_mut()) {
            let lab = lab_of(t, &rho);
            worst = worst.max(ciede2000(lab, t.lab));
            u[0] += lab.l - t.lab.l;
            u[1] += lab.a - t.lab.a;
            u[2] += lab.b - t.lab.b;
        }
        if worst < 1e-4 {
            break;
        }
    }
    Ok(rho)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smoothness_term_is_zero_on_lines_and_scales_with_the_step() {
        let w5: Vec<f64> = (0..81).map(|i| 380.0 + 5.0 * f64::from(i)).collect();
        let w10: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * f64::from(i)).collect();
        let line = |w: &[f64]| w.iter().map(|nm| 0.1 + 0.001 * nm).collect::<Vec<_>>();
        // Zero up to rounding (the parabola below gives 4e-6).
        assert!(quadratic(&smoothness_matrix(&w5), &line(&w5)).abs() < 1e-12);
        // A parabola has the same second derivative on either step.
        let parabola = |w: &[f64]| {
            w.iter()
                .map(|nm| 1e-5 * (nm - 580.0).powi(2))
                .collect::<Vec<_>>()
        };
        let a = quadratic(&smoothness_matrix(&w5), &parabola(&w5));
        let b = quadratic(&smoothness_matrix(&w10), &parabola(&w10));
        // ρ″ = 2e-5 /nm², times (10 nm)², squared.
        assert!(
            (a - 4e-6).abs() < 1e-12 && (b - 4e-6).abs() < 1e-12,
            "{a} {b}"
        );
    }

    #[test]
    fn the_lab_jacobian_matches_finite_differences() {
        let white = [94.8, 100.0, 107.3];
        for xyz in [[20.0, 25.0, 30.0], [0.3, 0.5, 0.4]] {
            let (_, jac) = lab_and_jacobian(xyz, white);
            for i in 0..3 {
                let h = 1e-6 * xyz[i];
                let mut up = xyz;
                up[i] += h;
                let mut down = xyz;
                down[i] -= h;
                let (lu, _) = lab_and_jacobian(up, white);
                let (ld, _) = lab_and_jacobian(down, white);
                let numeric = [
                    (lu.l - ld.l) / (2.0 * h),
                    (lu.a - ld.a) / (2.0 * h),
                    (lu.b - ld.b) / (2.0 * h),
                ];
                for k in 0..3 {
                    assert!(
                        (numeric[k] - jac[k][i]).abs() < 1e-5 * (1.0 + jac[k][i].abs()),
                        "{xyz:?} {k} {i}: {} vs {}",
                        numeric[k],
                        jac[k][i]
                    );
                }
            }
        }
    }

    #[test]
    fn free_parameters_parse_any_subset_and_refuse_unknown_names() {
        assert_eq!(parse_free("rho").expect("rho"), FreeParameters::RHO);
        let all = parse_free("rho, gloss,h,k,n,h").expect("all");
        assert_eq!(all.names(), FreeParameters::NAMES);
        assert!(all.coat());
        let coat = parse_free("n,gloss").expect("coat only");
        assert_eq!(coat.names(), ["gloss", "n"]);
        assert!(!coat.rho);
        let e = parse_free("rho,colour").expect_err("unknown");
        assert!(e.to_string().contains("--free \"colour\": unknown"), "{e}");
        let e = parse_free("").expect_err("empty");
        assert!(e.to_string().contains("--free \"\""), "{e}");
    }
}
