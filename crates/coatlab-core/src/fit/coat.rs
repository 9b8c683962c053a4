//! The fit with coat parameters free (`--free` naming `gloss`, `h`, `k` or `n`): a
//! bounded least-squares fit of every directional spectrum and every gloss reading
//! of the standard over ρ(λ) on the fit wavelengths and the free coat parameters.
//!
//! The objective, with A the number of spectra and N their wavelengths,
//!
//! ```text
//! (1/A)·[ Σ_a (1/N)·Σ_λ (R_a(λ) − R_a,target(λ))² + Σ_g ((G_g − G_g,target)/100 GU)² ]
//!   + λ_s·mean((ρ″·(10 nm)²)²)
//! ```
//!
//! counts each gloss reading as much as one whole spectrum, with 100 GU standing for
//! a reflectance factor of 1 (a glossmeter's scale), and keeps the smoothness term
//! (λ_s = [`SMOOTHNESS_WEIGHT`]) of the ρ-only fit; without coat parameters and
//! gloss readings it is that fit's objective.
//!
//! The coat parameters, each in the box the paint parameter table gives (the span
//! of its GUI control where it has one, else its accepted range):
//! - **gloss g**: the reading at the start design's glossmeter geometry, GU, from
//!   the broadest lobe's reading to the mirror's ([`reading_range`], the table's
//!   documented lower limit);
//! - **h**: the clear coat thickness, µm ([`THICKNESS`]);
//! - **k**: the start design's k(λ) *scaled*, one number: its largest value, 1/µm
//!   ([`ABSORPTION`]). The shape (a UV absorber's rise, say) is the start's: the
//!   readings cannot tell a shape apart from τ's effect on the angles, so a few
//!   basis coefficients would be undetermined. A start with k ≡ 0 gets a constant
//!   k;
//! - **n**: the start design's n(λ) *shifted*, one number: n at 587.6 nm. A Cauchy
//!   index shifts its A; n(λ) stays within [`REFRACTIVE_INDEX`]'s range (n ≥ 1) and
//!   below the top of the Cauchy A control ([`CAUCHY_A`]), n's own range having no
//!   upper end.
//!
//! **What can be identified.** The readings depend on h and k only through the
//! optical depth τ = k·h: with both free only their product is determined, and the
//! split follows the start. τ also trades off partly against ρ (both darken the
//! body; only the angles tell them apart), and the gloss against n near the
//! specular direction. The tests therefore check the readings a fit reproduces,
//! not the parameters it returns.
//!
//! **The method**: projected Gauss–Newton over the box ([`projected_newton`]), the
//! Jacobian analytic in ρ for the spectra and by forward differences in the coat
//! parameters (each difference a new paint model). The gloss readings' dependence on
//! ρ (the body's small share of a glossmeter reading) is differentiated as if the
//! body's angular factor were the same at every wavelength (it varies with n(λ) and
//! τ(λ) only); the line search uses the exact objective, so this costs at most
//! some steps.

use std::cell::RefCell;
use std::f64::consts::PI;
use std::rc::Rc;

use super::solve::{Local, projected_newton, quadratic, smoothness_matrix};
use super::{Coat, FitError, FittedParameter, FreeParameters, Reading, SMOOTHNESS_WEIGHT};
use crate::colour::spectrum::{TabulatedSpectrum, WavelengthGrid};
use crate::design::{Absorption, PaintDesign, RefractiveIndex};
use crate::instruments::{gloss_reading, glossmeter_weights};
use crate::measurement::{Geometry, interpolate};
use crate::paint::gloss::{GLOSS_WAVELENGTH_NM, GlossGeometry, reading_range};
use crate::paint::parameters::{
    ABSORPTION, Bounds, CAUCHY_A, GLOSS, Parameter, REFRACTIVE_INDEX, THICKNESS,
};

/// Gloss readings are compared on this scale: 100 GU counts as a reflectance
/// factor of 1.
const GLOSS_SCALE_GU: f64 = 100.0;

/// The forward-difference step of the coat parameters, in the solver's units
/// (each parameter divided by its `scale`, so of order 1): small against their
/// ranges, large against the model's rounding (~1e-13).
const DIFFERENCE_STEP: f64 = 1e-6;

/// Gauss–Newton steps at most; a fit converges in well under this.
const ITERATIONS: usize = 60;

/// A step that lowers the objective by less than this ends the fit: 10⁻¹² is a
/// spectral RMS of 10⁻⁶, a thousandth of what 0.05 ΔE00 allows, and each further
/// step costs some five paint models with their gloss readings.
const MIN_DECREASE: f64 = 1e-12;

/// The box a fit keeps a parameter in: the span of its GUI control (the paints the
/// model is meant for) where the table gives one, else its accepted range.
fn span(parameter: &Parameter) -> Bounds {
    parameter.control.unwrap_or(parameter.range)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Knob {
    Gloss,
    Thickness,
    Absorption,
    Index,
}

/// One free coat parameter: its value is `x·scale` for the solver's variable x.
#[derive(Debug, Clone, Copy)]
struct Variable {
    knob: Knob,
    scale: f64,
    start: f64,
    lower: f64,
    upper: f64,
}

/// What the coat fit found.
pub(super) struct CoatOutcome {
    /// The start design with the fitted coat, and ρ(λ) fitted where ρ is free.
    pub design: PaintDesign,
    /// ρ on the fit wavelengths.
    pub albedo: Vec<f64>,
    pub parameters: Vec<FittedParameter>,
    /// The fitted coat's share of each reading, for the unreachable check.
    pub coat: Coat,
    pub readings: Vec<Reading>,
}

/// The standard's readings the coat fit reproduces.
pub(super) struct Targets<'a> {
    pub wavelength_nm: &'a [f64],
    /// Directional geometries, with their spectra on `wavelength_nm`.
    pub geometries: Vec<Geometry>,
    pub spectra: &'a [Vec<f64>],
    /// Glossmeter readings, GU.
    pub gloss: Vec<(GlossGeometry, f64)>,
}

/// The residuals at one point and what the Jacobian needs of them.
struct Evaluation {
    /// √weight·(model − target): spectra (A·N, by geometry then wavelength), then
    /// gloss readings.
    residual: Vec<f64>,
    /// ∂residual/∂ρ_j of the spectra, by geometry then wavelength (diagonal blocks).
    spectral_slope: Vec<f64>,
    /// ∂residual/∂ρ_j of each gloss reading (dense rows).
    gloss_slope: Vec<Vec<f64>>,
    coat: Coat,
    readings: Vec<Reading>,
}

struct Problem<'a> {
    start: &'a PaintDesign,
    targets: &'a Targets<'a>,
    grid: WavelengthGrid,
    grid_nm: Vec<f64>,
    variables: Vec<Variable>,
    rho_free: bool,
    /// The start's largest k, 1/µm (0 for a start with k ≡ 0).
    start_k_max: f64,
    /// The glossmeter's weight of each grid wavelength.
    gloss_weights: Vec<f64>,
    /// hat[i][j]: the weight of the fitted ρ_j in ρ at grid wavelength i.
    hat: Vec<Vec<f64>>,
    spectral_weight: f64,
    gloss_weight: f64,
    smoothness: Vec<f64>,
    /// The line search's last accepted point is where the next step starts: its
    /// evaluation is kept rather than made again (a paint model and its gloss
    /// readings each time).
    last: RefCell<Option<(Vec<f64>, Rc<Evaluation>)>>,
}

fn largest(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

fn smallest(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::INFINITY, f64::min)
}

impl<'a> Problem<'a> {
    fn new(
        start: &'a PaintDesign,
        targets: &'a Targets<'a>,
        free: FreeParameters,
    ) -> Result<Self, FitError> {
        let grid = WavelengthGrid::reference();
        let grid_nm: Vec<f64> = grid.wavelengths_nm().collect();
        let index = start.refractive_index_on(&grid);
        let n_at_gloss = start.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
        let start_k_max = match &start.absorption_per_um {
            Absorption::Constant(k) => *k,
            Absorption::Table(table) => largest(table.values()),
        };
        let mut variables = Vec::new();
        // n first: the gloss's range depends on it.
        let (mut n_low, mut n_high) = (n_at_gloss, n_at_gloss);
        if free.index {
            n_low = n_at_gloss + REFRACTIVE_INDEX.range.min - smallest(index.values());
            n_high = n_at_gloss + span(&CAUCHY_A).max - largest(index.values());
            variables.push(Variable {
                knob: Knob::Index,
                scale: 1.0,
                start: n_at_gloss,
                lower: n_low,
                upper: n_high,
            });
        }
        if free.gloss {
            let geometry = start.gloss.geometry;
            // The broadest lobe's reading rises with n: the lowest n gives the
            // lowest admissible reading, the highest n the mirror's top.
            let lower = reading_range(geometry, n_low)
                .map_err(|e| FitError::Bounds(format!("gloss: {e}")))?
                .min
                .max(GLOSS.range.min);
            let upper = reading_range(geometry, n_high)
                .map_err(|e| FitError::Bounds(format!("gloss: {e}")))?
                .max;
            variables.push(Variable {
                knob: Knob::Gloss,
                scale: GLOSS_SCALE_GU,
                start: start.gloss.gu,
                lower,
                upper,
            });
        }
        if free.thickness {
            let b = span(&THICKNESS);
            variables.push(Variable {
                knob: Knob::Thickness,
                scale: 100.0,
                start: start.thickness_um,
                lower: b.min,
                upper: b.max,
            });
        }
        if free.absorption {
            let b = span(&ABSORPTION);
            variables.push(Variable {
                knob: Knob::Absorption,
                scale: 1e-3,
                start: start_k_max,
                lower: b.min,
                upper: b.max,
            });
        }
        let n = targets.wavelength_nm.len();
        let hat = grid_nm
            .iter()
            .map(|&nm| {
                (0..n)
                    .map(|j| {
                        let mut unit = vec![0.0; n];
                        unit[j] = 1.0;
                        interpolate(targets.wavelength_nm, &unit, nm)
                    })
                    .collect()
            })
            .collect();
        let spectra = targets.geometries.len().max(1) as f64;
        Ok(Problem {
            start,
            targets,
            grid,
            gloss_weights: glossmeter_weights(&grid),
            grid_nm,
            variables,
            rho_free: free.rho,
            start_k_max,
            hat,
            spectral_weight: 1.0 / (spectra * n as f64),
            gloss_weight: 1.0 / (spectra * GLOSS_SCALE_GU * GLOSS_SCALE_GU),
            smoothness: smoothness_matrix(targets.wavelength_nm),
            last: RefCell::new(None),
        })
    }

    fn rho_len(&self) -> usize {
        self.targets.wavelength_nm.len()
    }

    /// The start design with the coat and ρ of the solver's point `x`; `None` where
    /// the design is not valid (the solver's line search then steps back).
    fn design_at(&self, x: &[f64]) -> Option<PaintDesign> {
        let n = self.rho_len();
        let mut design = self.start.clone();
        if self.rho_free {
            design.albedo = super::albedo_table(self.targets.wavelength_nm, &x[..n]).ok()?;
        }
        let mut gloss = None;
        for (v, &xv) in self.variables.iter().zip(&x[n..]) {
            let value = xv * v.scale;
            match v.knob {
                Knob::Index => {
                    let shift = value - v.start;
                    design.refractive_index = match &self.start.refractive_index {
                        RefractiveIndex::Cauchy { a, b_um2 } => RefractiveIndex::Cauchy {
                            a: a + shift,
                            b_um2: *b_um2,
                        },
                        RefractiveIndex::Table(t) => RefractiveIndex::Table(
                            TabulatedSpectrum::new(
                                t.wavelengths_nm().to_vec(),
                                t.values().iter().map(|n| n + shift).collect(),
                            )
                            .ok()?,
                        ),
                    };
                }
                Knob::Thickness => design.thickness_um = value,
                Knob::Absorption => {
                    design.absorption_per_um = match &self.start.absorption_per_um {
                        Absorption::Table(t) if self.start_k_max > 0.0 => Absorption::Table(
                            TabulatedSpectrum::new(
                                t.wavelengths_nm().to_vec(),
                                t.values()
                                    .iter()
                                    .map(|k| k * value / self.start_k_max)
                                    .collect(),
                            )
                            .ok()?,
                        ),
                        _ => Absorption::Constant(value),
                    };
                }
                Knob::Gloss => gloss = Some(value),
            }
        }
        if let Some(gu) = gloss {
            // Below the broadest lobe's reading for this n there is no lobe: the
            // broadest is the nearest paint.
            let n = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
            let floor = reading_range(design.gloss.geometry, n).ok()?.min;
            design.gloss.gu = gu.max(floor);
        }
        design.validate().ok()?;
        Some(design)
    }

    /// [`Self::evaluate`], reusing the last point's.
    fn evaluate_cached(&self, x: &[f64]) -> Option<Rc<Evaluation>> {
        if let Some((at, e)) = self.last.borrow().as_ref()
            && at == x
        {
            return Some(Rc::clone(e));
        }
        let e = Rc::new(self.evaluate(x)?);
        *self.last.borrow_mut() = Some((x.to_vec(), Rc::clone(&e)));
        Some(e)
    }

    fn evaluate(&self, x: &[f64]) -> Option<Evaluation> {
        let n = self.rho_len();
        let rho = &x[..n];
        let design = self.design_at(x)?;
        let model = design.model(self.grid).ok()?;
        let coat = Coat::new(&model, &self.grid_nm, self.targets.wavelength_nm);
        let readings: Vec<Reading> = self
            .targets
            .geometries
            .iter()
            .map(|&g| coat.reading(&model, g))
            .collect::<Option<_>>()?;
        let root = self.spectral_weight.sqrt();
        let mut residual = Vec::with_capacity(readings.len() * n + self.targets.gloss.len());
        let mut spectral_slope = Vec::with_capacity(readings.len() * n);
        for (reading, target) in readings.iter().zip(self.targets.spectra) {
            for j in 0..n {
                residual.push(root * (reading.value(&coat, j, rho[j]) - target[j]));
                spectral_slope.push(root * reading.slope(&coat, j, rho[j]));
            }
        }
        // The body's share of a glossmeter reading as Σ wᵢ·φ(ρᵢ)·(an angular factor
        // taken as the same at every wavelength), φ = ρ/(n²(π − ρC)).
        let albedo = model.albedo();
        let index = model.refractive_index();
        let c = model.coat_integral();
        let phi: f64 = (0..albedo.len())
            .map(|i| {
                self.gloss_weights[i] * albedo[i] / (index[i] * index[i] * (PI - albedo[i] * c[i]))
            })
            .sum();
        let root = self.gloss_weight.sqrt();
        let mut gloss_slope = Vec::with_capacity(self.targets.gloss.len());
        for &(geometry, target) in &self.targets.gloss {
            let g = gloss_reading(&model, geometry).ok()?;
            residual.push(root * (g.total_gu - target));
            let body = g.total_gu - g.specular_gu;
            let mut row = vec![0.0; n];
            if self.rho_free && phi > 0.0 {
                for (i, hat) in self.hat.iter().enumerate() {
                    let d = PI - albedo[i] * c[i];
                    let slope =
                        body * self.gloss_weights[i] * PI / (index[i] * index[i] * d * d) / phi;
                    for (r, h) in row.iter_mut().zip(hat) {
                        *r += root * slope * h;
                    }
                }
            }
            gloss_slope.push(row);
        }
        Some(Evaluation {
            residual,
            spectral_slope,
            gloss_slope,
            coat,
            readings,
        })
    }

    fn value(&self, x: &[f64]) -> f64 {
        match self.evaluate_cached(x) {
            Some(e) => self.objective(&e, x),
            None => f64::INFINITY,
        }
    }

    fn objective(&self, e: &Evaluation, x: &[f64]) -> f64 {
        let data: f64 = e.residual.iter().map(|r| r * r).sum();
        data + SMOOTHNESS_WEIGHT * quadratic(&self.smoothness, &x[..self.rho_len()])
    }

    /// Value, gradient and Gauss–Newton Hessian at `x`.
    fn local(&self, x: &[f64]) -> Local {
        let n = self.rho_len();
        let p = x.len();
        let Some(e) = self.evaluate_cached(x) else {
            return Local {
                value: f64::INFINITY,
                gradient: vec![0.0; p],
                hessian: vec![0.0; p * p],
            };
        };
        let rows = e.residual.len();
        // The Jacobian, column-major: ρ columns analytic, coat columns by forward
        // differences (backward at an upper bound).
        let mut jacobian = vec![0.0; rows * p];
        let spectral_rows = e.spectral_slope.len();
        for (row, slope) in e.spectral_slope.iter().enumerate() {
            if self.rho_free {
                jacobian[(row % n) * rows + row] = *slope;
            }
        }
        for (g, slope) in e.gloss_slope.iter().enumerate() {
            for (j, s) in slope.iter().enumerate() {
                jacobian[j * rows + spectral_rows + g] = *s;
            }
        }
        for (v, variable) in self.variables.iter().enumerate() {
            let column = n + v;
            let upper = variable.upper / variable.scale;
            let step = if x[column] + DIFFERENCE_STEP <= upper {
                DIFFERENCE_STEP
            } else {
                -DIFFERENCE_STEP
            };
            let mut moved = x.to_vec();
            moved[column] += step;
            if let Some(m) = self.evaluate(&moved) {
                for (row, (a, b)) in m.residual.iter().zip(&e.residual).enumerate() {
                    jacobian[column * rows + row] = (a - b) / step;
                }
            }
        }
        let mut gradient = vec![0.0; p];
        let mut hessian = vec![0.0; p * p];
        for a in 0..p {
            let ca = &jacobian[a * rows..(a + 1) * rows];
            gradient[a] = 2.0 * ca.iter().zip(&e.residual).map(|(j, r)| j * r).sum::<f64>();
            for b in a..p {
                let cb = &jacobian[b * rows..(b + 1) * rows];
                let h = 2.0 * ca.iter().zip(cb).map(|(x, y)| x * y).sum::<f64>();
                hessian[a * p + b] = h;
                hessian[b * p + a] = h;
            }
        }
        if self.rho_free {
            for a in 0..n {
                for b in 0..n {
                    let q = 2.0 * SMOOTHNESS_WEIGHT * self.smoothness[a * n + b];
                    hessian[a * p + b] += q;
                    gradient[a] += q * x[b];
                }
            }
        }
        Local {
            value: self.objective(&e, x),
            gradient,
            hessian,
        }
    }
}

/// Fits ρ (where free) and the free coat parameters of `start` to `targets`,
/// starting from `start_albedo` on the fit wavelengths.
pub(super) fn fit_coat(
    start: &PaintDesign,
    targets: &Targets<'_>,
    free: FreeParameters,
    start_albedo: &[f64],
) -> Result<CoatOutcome, FitError> {
    let problem = Problem::new(start, targets, free)?;
    let n = problem.rho_len();
    let mut x: Vec<f64> = start_albedo.to_vec();
    let mut lower = vec![0.0; n];
    let mut upper = vec![1.0; n];
    if !free.rho {
        lower.clone_from(&x);
        upper.clone_from(&x);
    }
    for v in &problem.variables {
        x.push(v.start / v.scale);
        lower.push(v.lower / v.scale);
        upper.push(v.upper / v.scale);
    }
    let x = projected_newton(
        x,
        (&lower, &upper),
        (ITERATIONS, MIN_DECREASE),
        |x| problem.local(x),
        &|x| problem.value(x),
    );
    let (Some(design), Some(e)) = (problem.design_at(&x), problem.evaluate_cached(&x)) else {
        return Err(FitError::Bounds(
            "the fitted coat does not make a valid design".to_owned(),
        ));
    };
    let n_at_gloss = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
    let parameters = problem
        .variables
        .iter()
        .zip(&x[n..])
        .map(|(v, &xv)| {
            let (name, label, unit, fitted) = match v.knob {
                Knob::Gloss => (
                    "gloss",
                    format!("{} at {}°", GLOSS.label(), u32::from(design.gloss.geometry)),
                    GLOSS.unit,
                    design.gloss.gu,
                ),
                Knob::Thickness => ("h", THICKNESS.label(), THICKNESS.unit, xv * v.scale),
                Knob::Absorption => (
                    "k",
                    format!(
                        "{}, its largest value (the start's k(λ) scaled)",
                        ABSORPTION.label()
                    ),
                    ABSORPTION.unit,
                    xv * v.scale,
                ),
                Knob::Index => (
                    "n",
                    format!(
                        "{} at {GLOSS_WAVELENGTH_NM} nm (the start's n(λ) shifted)",
                        REFRACTIVE_INDEX.label()
                    ),
                    REFRACTIVE_INDEX.unit,
                    n_at_gloss,
                ),
            };
            FittedParameter {
                name,
                label,
                unit: unit.suffix(),
                start: v.start,
                fitted,
                lower: v.lower,
                upper: v.upper,
            }
        })
        .collect();
    Ok(CoatOutcome {
        design,
        albedo: x[..n].to_vec(),
        parameters,
        coat: e.coat.clone(),
        readings: e.readings.clone(),
    })
}
