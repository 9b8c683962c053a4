//! Virtual instruments (spec 7): the multi-angle spectrophotometer and the
//! glossmeter reading of a whole design.
//!
//! Multi-angle spectrophotometer (ASTM E2194 style): collimated illumination at 45°
//! from the normal; detection in the plane of incidence at aspecular angles 15°,
//! 25°, 45°, 75°, 110°, measured from the specular direction toward the
//! illuminator. The detector's polar angle is therefore 45° − aspecular: 30°, 20°
//! and 0° on the specular side, 30° and 65° on the illuminator's side. Reflectance
//! factor R(λ) = π·f(ωi, ωo) (body plus the specular lobe; a mirror's delta never
//! reaches these angles). Colour: CIELAB under D65 for the 10° observer, the paint
//! industry's reporting convention.
//!
//! Sphere spectrophotometer d:8° (CIE 15), specular component included or
//! excluded: [`sphere`]. A measurement file's geometry picks the instrument
//! ([`reading`]): 45°:0° is the multi-angle instrument's 45°as45° (for the
//! isotropic paint an annular 45°:0° instrument reads the same).
//!
//! Glossmeter (spec 4.3): the simulated ISO 2813 instrument of
//! [`crate::paint::gloss`], reading specular and body reflection together, each
//! wavelength weighted by ȳ(λ) under D65 (the standard uses illuminant C; the 2°
//! observer's ȳ is the photopic luminosity function).

use std::f64::consts::PI;

use crate::colour::cie::{Colorimeter, Illuminant, Observer};
use crate::colour::spectrum::WavelengthGrid;
use crate::colour::{Lab, ciede2000};
use crate::measurement::{
    Geometry, GlossValue, Reflectance, Sample, SpectrumProblem, SpecularComponent,
};
use crate::paint::coat::body_brdf;
use crate::paint::fresnel::reflectance;
use crate::paint::gloss::{GlossExponent, GlossGeometry, reading_from_exponent};
use crate::paint::lobe::{LobeKind, paper_lobe, phong_lobe, phong_normalisation};
use crate::paint::model::PaintModel;

pub mod sphere;

/// Illumination angle of the multi-angle instrument, degrees from the normal.
pub const ILLUMINATION_DEG: f64 = 45.0;
/// Aspecular detection angles, degrees.
pub const ASPECULAR_DEG: [f64; 5] = [15.0, 25.0, 45.0, 75.0, 110.0];

/// Why an instrument cannot measure a model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InstrumentError {
    /// The model is on linear-sRGB channels (the renderer's RGB shortcut): the
    /// instruments weigh wavelengths by the CIE tables, and these have none.
    #[error(
        "the instruments measure spectra, but this paint model is on linear-sRGB channels, which have no wavelengths"
    )]
    NotSpectral,
    /// A reading whose file does not say how it was measured.
    #[error("the reading's geometry is not stated, so no instrument can be chosen to read it")]
    NoGeometry,
}

fn spectral_grid(model: &PaintModel) -> Result<WavelengthGrid, InstrumentError> {
    model
        .channels()
        .grid()
        .copied()
        .ok_or(InstrumentError::NotSpectral)
}

/// The glossmeter's weight of each sample of `grid`: ȳ(λ)·S_D65(λ), summing to 1.
pub fn glossmeter_weights(grid: &WavelengthGrid) -> Vec<f64> {
    let luminance = Colorimeter::new(Illuminant::D65, Observer::Cie1931TwoDegree, grid);
    let weights = luminance.luminance_weights();
    let weight_sum: f64 = weights.iter().sum();
    weights.iter().map(|x| x / weight_sum).collect()
}

/// One detection angle of the multi-angle instrument.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AngleReading {
    /// Aspecular angle, degrees.
    pub aspecular_deg: f64,
    /// Signed polar angle of the detector, degrees (positive on the specular side).
    pub detector_deg: f64,
    /// CIELAB, D65/10°.
    #[serde(serialize_with = "serialize_lab")]
    pub lab: Lab,
    /// Reflectance factor π·f per wavelength of the model's grid.
    pub reflectance_factor: Vec<f64>,
}

/// The glossmeter's readings at one geometry.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GlossReading {
    /// Geometry.
    #[serde(serialize_with = "serialize_geometry")]
    pub geometry: GlossGeometry,
    /// The specular part alone, GU (what m(g) is defined on).
    pub specular_gu: f64,
    /// Specular and body together, luminance-weighted, GU (what an instrument shows).
    pub total_gu: f64,
}

/// A design read at one measurement geometry: what a file of that geometry holds.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GeometryReading {
    pub geometry: Geometry,
    /// CIELAB, D65/10°.
    #[serde(serialize_with = "serialize_lab")]
    pub lab: Lab,
    /// Reflectance factor per wavelength of the model's grid.
    pub reflectance_factor: Vec<f64>,
}

/// The sphere instrument's geometries, in the order of [`Measurement::sphere`].
pub const SPHERE_GEOMETRIES: [Geometry; 2] = [
    Geometry::Sphere {
        specular: SpecularComponent::Included,
    },
    Geometry::Sphere {
        specular: SpecularComponent::Excluded,
    },
];

/// Everything the virtual instruments report for a design.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Measurement {
    /// Wavelengths of the reflectance factors, nm.
    pub wavelength_nm: Vec<f64>,
    /// Multi-angle readings, in the order of [`ASPECULAR_DEG`].
    pub angles: Vec<AngleReading>,
    /// Sphere (d:8°) readings, SCI then SCE.
    pub sphere: Vec<GeometryReading>,
    /// Gloss at 20°, 60°, 85°.
    pub gloss: Vec<GlossReading>,
}

impl Measurement {
    /// The glossmeter's total readings (specular and body) as a measurement file
    /// states gloss.
    pub fn gloss_values(&self) -> Vec<GlossValue> {
        self.gloss
            .iter()
            .map(|g| GlossValue {
                angle_deg: f64::from(u32::from(g.geometry)),
                gu: g.total_gu,
            })
            .collect()
    }

    /// The multi-angle readings as one standard's samples, named `name`, as a
    /// measurement file would hold them: every `step`-th wavelength (2 gives the
    /// 10 nm most instruments write), 45° illumination, and the gloss readings on
    /// each angle's row (as a multi-angle CGATS table repeats them).
    pub fn multi_angle_samples(
        &self,
        name: &str,
        step: usize,
    ) -> Result<Vec<Sample>, SpectrumProblem> {
        let keep: Vec<usize> = (0..self.wavelength_nm.len()).step_by(step.max(1)).collect();
        let wavelength_nm: Vec<f64> = keep.iter().map(|&i| self.wavelength_nm[i]).collect();
        let gloss = self.gloss_values();
        self.angles
            .iter()
            .map(|a| {
                let factors = keep.iter().map(|&i| a.reflectance_factor[i]).collect();
                Ok(Sample {
                    name: name.to_owned(),
                    id: None,
                    geometry: Geometry::directional(ILLUMINATION_DEG, a.aspecular_deg),
                    spectrum: Some(Reflectance::new(wavelength_nm.clone(), factors)?),
                    colour: None,
                    gloss: gloss.clone(),
                })
            })
            .collect()
    }
}

/// CIELAB as `{"L", "a", "b"}`, as every JSON report writes it.
pub(crate) fn serialize_lab<S: serde::Serializer>(lab: &Lab, s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeStruct;
    let mut st = s.serialize_struct("Lab", 3)?;
    st.serialize_field("L", &lab.l)?;
    st.serialize_field("a", &lab.a)?;
    st.serialize_field("b", &lab.b)?;
    st.end()
}

fn serialize_geometry<S: serde::Serializer>(g: &GlossGeometry, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u32(u32::from(*g))
}

pub(crate) fn in_plane_direction(signed_deg: f64) -> [f64; 3] {
    let t = signed_deg.to_radians();
    [t.sin(), 0.0, t.cos()]
}

/// Measures a design with both instruments; errors for a model that is not spectral.
pub fn measure(model: &PaintModel) -> Result<Measurement, InstrumentError> {
    let grid = spectral_grid(model)?;
    let colorimeter = Colorimeter::new(Illuminant::D65, Observer::Cie1964TenDegree, &grid);
    let angles = ASPECULAR_DEG
        .iter()
        .map(|&aspecular| read_directional(model, &colorimeter, ILLUMINATION_DEG, aspecular))
        .collect();
    let sphere = SPHERE_GEOMETRIES
        .iter()
        .map(|&g| read_at(model, &colorimeter, g))
        .collect::<Result<_, _>>()?;
    let gloss = GlossGeometry::ALL
        .iter()
        .map(|&g| gloss_reading(model, g))
        .collect::<Result<_, _>>()?;
    Ok(Measurement {
        wavelength_nm: grid.wavelengths_nm().collect(),
        angles,
        sphere,
        gloss,
    })
}

/// A design read by the instrument of `geometry`: the multi-angle instrument at a
/// directional geometry (any illumination and aspecular angle with the detector
/// above the surface; 45°:0° is 45°as45°), the sphere at d:8°. Errors for a model
/// that is not spectral and for an unstated geometry.
pub fn reading(model: &PaintModel, geometry: Geometry) -> Result<GeometryReading, InstrumentError> {
    let grid = spectral_grid(model)?;
    let colorimeter = Colorimeter::new(Illuminant::D65, Observer::Cie1964TenDegree, &grid);
    read_at(model, &colorimeter, geometry)
}

fn read_at(
    model: &PaintModel,
    colorimeter: &Colorimeter,
    geometry: Geometry,
) -> Result<GeometryReading, InstrumentError> {
    let reflectance_factor = match geometry {
        Geometry::Directional {
            illumination_deg,
            aspecular_deg,
        } => {
            read_directional(model, colorimeter, illumination_deg, aspecular_deg).reflectance_factor
        }
        Geometry::Sphere { specular } => sphere::sphere_reflectance(model, specular),
        Geometry::Unspecified => return Err(InstrumentError::NoGeometry),
    };
    Ok(GeometryReading {
        geometry,
        lab: colorimeter.lab(&reflectance_factor),
        reflectance_factor,
    })
}

/// The multi-angle instrument's reading at any in-plane geometry: illumination at
/// `illumination_deg` from the normal, detection at `aspecular_deg` from the
/// specular direction toward the illuminator (45°as45° is the 45°:0° geometry).
/// Errors for a model that is not spectral; the detector must be above the surface
/// (|illumination − aspecular| < 90°), as a measurement file's geometry is.
pub fn directional_reading(
    model: &PaintModel,
    illumination_deg: f64,
    aspecular_deg: f64,
) -> Result<AngleReading, InstrumentError> {
    let grid = spectral_grid(model)?;
    let colorimeter = Colorimeter::new(Illuminant::D65, Observer::Cie1964TenDegree, &grid);
    Ok(read_directional(
        model,
        &colorimeter,
        illumination_deg,
        aspecular_deg,
    ))
}

fn read_directional(
    model: &PaintModel,
    colorimeter: &Colorimeter,
    illumination_deg: f64,
    aspecular: f64,
) -> AngleReading {
    // Illuminator on the −x side, so the specular direction is +illumination.
    let wi = in_plane_direction(-illumination_deg);
    let detector = illumination_deg - aspecular;
    let wo = in_plane_direction(detector);
    let mut f = vec![0.0; colorimeter.grid().len()];
    model.eval_reference(wi, wo, &mut f);
    let reflectance_factor: Vec<f64> = f.iter().map(|v| PI * v).collect();
    let lab = colorimeter.lab(&reflectance_factor);
    AngleReading {
        aspecular_deg: aspecular,
        detector_deg: detector,
        lab,
        reflectance_factor,
    }
}

/// The glossmeter's specular-only and total readings of a design at one geometry;
/// errors for a model that is not spectral.
pub fn gloss_reading(
    model: &PaintModel,
    geometry: GlossGeometry,
) -> Result<GlossReading, InstrumentError> {
    let grid = spectral_grid(model)?;
    let meter = crate::paint::gloss::Glossmeter::new(geometry);
    let w = glossmeter_weights(&grid);

    let exponent = model.exponent();
    let index = model.refractive_index();
    let specular = meter.reading_of(|wi| {
        let fraction = match (exponent, model.lobe()) {
            (GlossExponent::Mirror, _) => 1.0,
            (GlossExponent::Finite(m), LobeKind::Normalised) => {
                let peak = [-wi[0], -wi[1], wi[2]];
                let captured = meter
                    .receptor_integral(peak, 1.0 / (m + 1.0).sqrt(), |wo| phong_lobe(wi, wo, m));
                captured / phong_normalisation(wi[2], m)
            }
            (GlossExponent::Finite(m), LobeKind::Paper) => {
                let peak = [-wi[0], -wi[1], wi[2]];
                // The paper's lobe is about twice as wide as a Phong lobe of the same m.
                meter.receptor_integral(peak, 2.0 / (m + 1.0).sqrt(), |wo| paper_lobe(wi, wo, m))
            }
        };
        let r: f64 = w
            .iter()
            .zip(index)
            .map(|(w, &n)| w * reflectance(wi[2], n))
            .sum();
        r * fraction
    });
    let body = meter.reading_of(|wi| {
        meter.receptor_integral(wi, 10.0, |wo| {
            (0..grid.len())
                .map(|i| {
                    w[i] * body_brdf(
                        model.albedo()[i],
                        index[i],
                        model.optical_depth()[i],
                        model.coat_integral()[i],
                        wi[2],
                        wo[2],
                    )
                })
                .sum()
        })
    });
    Ok(GlossReading {
        geometry,
        specular_gu: specular,
        total_gu: specular + body,
    })
}

/// CIEDE2000 between a design and a target design at each aspecular angle.
pub fn delta_e_per_angle(design: &Measurement, target: &Measurement) -> Vec<f64> {
    design
        .angles
        .iter()
        .zip(&target.angles)
        .map(|(a, b)| ciede2000(a.lab, b.lab))
        .collect()
}

/// The reading a design's gloss setting should reproduce: the specular reading
/// at the design's own geometry, through the tabulated glossmeter.
pub fn specular_reading_tabulated(model: &PaintModel, geometry: GlossGeometry) -> Option<f64> {
    reading_from_exponent(
        geometry,
        model.index_at_gloss_wavelength(),
        model.exponent(),
    )
    .ok()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::colour::spectrum::Channels;
    use crate::paint::model::{GlossSetting, PaintParams};

    /// A grey paint on the reference grid: n = 1.5, k = 0.0005, 40 µm, `gloss`.
    pub(crate) fn grey(rho: f64, gloss: GlossSetting) -> PaintModel {
        PaintModel::new(PaintParams::grey(
            WavelengthGrid::reference(),
            rho,
            1.5,
            0.0005,
            40.0,
            gloss,
        ))
        .expect("valid model")
    }

    #[test]
    fn a_grey_design_measures_neutral_and_flops_darker() {
        let model = grey(
            0.5,
            GlossSetting::Reading {
                gu: 88.0,
                geometry: GlossGeometry::Deg20,
            },
        );
        let m = measure(&model).expect("spectral");
        assert_eq!(m.angles.len(), 5);
        for a in &m.angles {
            assert!(a.lab.a.abs() < 0.5 && a.lab.b.abs() < 0.5, "{a:?}");
        }
        // Body reflection falls as the detector moves away from the normal (Fresnel
        // and the longer path out of the coat), so 110° is darker than 45°.
        assert!(m.angles[4].lab.l < m.angles[2].lab.l);
    }

    #[test]
    fn gloss_reading_of_the_specular_part_reproduces_the_designed_gloss() {
        // Below the coat's mirror reading (82.0 GU at 20° for n = 1.5).
        for (gu, geometry) in [(75.0, GlossGeometry::Deg20), (60.0, GlossGeometry::Deg60)] {
            let model = grey(0.0, GlossSetting::Reading { gu, geometry });
            let reading = gloss_reading(&model, geometry).expect("spectral");
            assert!(
                (reading.specular_gu - gu).abs() < 0.05,
                "{geometry}: {reading:?} vs {gu}"
            );
            // A black pigment adds nothing.
            assert!((reading.total_gu - reading.specular_gu).abs() < 1e-12);
            let tabulated = specular_reading_tabulated(&model, geometry).unwrap_or(f64::NAN);
            assert!((tabulated - gu).abs() < 1e-6);
        }
    }

    #[test]
    fn a_white_pigment_raises_the_total_reading() {
        let model = grey(
            0.9,
            GlossSetting::Reading {
                gu: 85.0,
                geometry: GlossGeometry::Deg20,
            },
        );
        let reading = gloss_reading(&model, GlossGeometry::Deg60).expect("spectral");
        assert!(reading.total_gu > reading.specular_gu + 0.01, "{reading:?}");
    }

    #[test]
    fn delta_e_to_itself_is_zero() {
        let model = grey(0.4, GlossSetting::Exponent(GlossExponent::Finite(200.0)));
        let m = measure(&model).expect("spectral");
        assert!(delta_e_per_angle(&m, &m).iter().all(|d| *d == 0.0));
    }

    #[test]
    fn the_instruments_refuse_a_model_without_wavelengths() {
        let model = PaintModel::new(PaintParams::grey(
            Channels::LinearSrgb,
            0.5,
            1.5,
            0.0,
            40.0,
            GlossSetting::Exponent(GlossExponent::Finite(200.0)),
        ))
        .expect("valid model");
        assert_eq!(measure(&model), Err(InstrumentError::NotSpectral));
        assert_eq!(
            gloss_reading(&model, GlossGeometry::Deg60),
            Err(InstrumentError::NotSpectral)
        );
    }
}
