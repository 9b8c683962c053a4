//! A design against its target — another design, or a standard read from a
//! measurement file — as a quality lab reports it: per geometry the CIELAB
//! differences, the total in the chosen formula, pass or fail, and the CIE
//! metamerism index under A and F11 for a pair matched under D65.
//!
//! Geometry: the design is read by the virtual instrument of the measurement's own
//! geometry ([`instruments::reading`]): the multi-angle instrument at directional
//! geometries (45°:0° is 45°as45°), the sphere at d:8° SCI and SCE. A reading of
//! unstated geometry is listed as not comparable rather than compared with
//! numbers of another geometry.
//!
//! Colour: a spectral target is compared on its own wavelengths (the design's
//! reflectance factor interpolated there) under D65 and the 10° observer, the paint
//! industry's reporting conditions; a target that states only a colour is compared
//! under the illuminant and observer it names.

use crate::colour::Lab;
use crate::colour::cie::{CieError, Illuminant, Observer, summation_weights};
use crate::colour::tolerance::{
    LabDifference, METAMERIC_DE00, MetamerismIndex, Tolerance, difference, metamerism_index,
};
use crate::instruments::{self, InstrumentError};
use crate::measurement::{Geometry, LabSource, SampleColourError, Standard, interpolate};
use crate::paint::model::PaintModel;

/// The illuminants of the metamerism index: incandescent light and the narrow-band
/// fluorescent of paint light booths.
pub const METAMERISM_TEST_ILLUMINANTS: [Illuminant; 2] = [Illuminant::A, Illuminant::F11];

/// The comparison at one geometry.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AngleComparison {
    pub geometry: Geometry,
    /// The design's CIELAB at this geometry.
    #[serde(serialize_with = "instruments::serialize_lab")]
    pub design_lab: Lab,
    /// The target's CIELAB.
    #[serde(serialize_with = "instruments::serialize_lab")]
    pub target_lab: Lab,
    /// The conditions of both, e.g. "D65/CIE 1964 10°".
    pub conditions: String,
    /// Where the target's colour came from.
    pub target_source: LabSource,
    /// Design minus target.
    pub difference: LabDifference,
    /// The limit here, in the tolerance's formula.
    pub limit: f64,
    /// The difference in the tolerance's formula.
    pub value: f64,
    pub pass: bool,
    /// Under A and F11; empty without a target spectrum.
    pub metamerism: Vec<MetamerismIndex>,
}

impl AngleComparison {
    /// The metamerism indices as reports print them: `A: 0.12 (0.20)   F11: …`,
    /// ΔE00 with ΔE*ab in brackets.
    pub fn metamerism_summary(&self) -> String {
        let cells: Vec<String> = self
            .metamerism
            .iter()
            .map(|m| format!("{}: {:.2} ({:.2})", m.illuminant, m.de00, m.de_ab))
            .collect();
        cells.join("   ")
    }
}

/// A reading of the target that cannot be compared, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NotComparable {
    pub geometry: Geometry,
    pub reason: String,
}

/// A gloss reading of the target beside the design's.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GlossComparison {
    pub angle_deg: f64,
    /// The design's glossmeter reading (specular and body), GU.
    pub design_gu: f64,
    pub target_gu: f64,
}

/// A design against its target.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Comparison {
    pub tolerance: Tolerance,
    pub angles: Vec<AngleComparison>,
    pub not_comparable: Vec<NotComparable>,
    pub gloss: Vec<GlossComparison>,
    /// Pass at every compared geometry; `None` when none could be compared.
    pub pass: Option<bool>,
    /// A metamerism index above [`METAMERIC_DE00`] at some geometry where the pair
    /// passes under D65.
    pub metameric: bool,
    /// What the reader should know (assumed conditions, extrapolated wavelengths).
    pub notes: Vec<String>,
}

/// Why a comparison cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetError {
    #[error(transparent)]
    Instrument(#[from] InstrumentError),
    #[error(transparent)]
    Colour(#[from] SampleColourError),
    #[error(transparent)]
    Cie(#[from] CieError),
}

const PAINT_ILLUMINANT: Illuminant = Illuminant::D65;
const PAINT_OBSERVER: Observer = Observer::Cie1964TenDegree;

fn conditions(illuminant: Illuminant, observer: Observer) -> String {
    format!("{illuminant}/{observer}")
}

fn metamerism(
    wavelengths_nm: &[f64],
    target: &[f64],
    design: &[f64],
) -> Result<Vec<MetamerismIndex>, CieError> {
    METAMERISM_TEST_ILLUMINANTS
        .iter()
        .map(|&test| {
            metamerism_index(
                wavelengths_nm,
                target,
                design,
                PAINT_ILLUMINANT,
                test,
                PAINT_OBSERVER,
            )
        })
        .collect()
}

fn finish(
    tolerance: &Tolerance,
    angles: Vec<AngleComparison>,
    not_comparable: Vec<NotComparable>,
    gloss: Vec<GlossComparison>,
    notes: Vec<String>,
) -> Comparison {
    let pass = (!angles.is_empty()).then(|| angles.iter().all(|a| a.pass));
    // Metamerism is a property of a match: a pair that already fails under D65
    // differs anyway, whatever its indices.
    let metameric = angles
        .iter()
        .filter(|a| a.pass)
        .flat_map(|a| &a.metamerism)
        .any(|m| m.de00 > METAMERIC_DE00);
    Comparison {
        tolerance: tolerance.clone(),
        angles,
        not_comparable,
        gloss,
        pass,
        metameric,
        notes,
    }
}

#[allow(clippy::too_many_arguments)]
fn angle(
    tolerance: &Tolerance,
    geometry: Geometry,
    design_lab: Lab,
    target_lab: Lab,
    conditions: String,
    target_source: LabSource,
    metamerism: Vec<MetamerismIndex>,
) -> AngleComparison {
    let d = difference(target_lab, design_lab);
    let aspecular = match geometry {
        Geometry::Directional { aspecular_deg, .. } => Some(aspecular_deg),
        _ => None,
    };
    let limit = tolerance.limit_at(aspecular);
    let value = tolerance.formula.of(&d);
    AngleComparison {
        geometry,
        design_lab,
        target_lab,
        conditions,
        target_source,
        difference: d,
        limit,
        value,
        pass: value <= limit,
        metamerism,
    }
}

/// A design's instrument readings against a target design's, at the five angles.
pub fn compare_designs(
    design: &instruments::Measurement,
    target: &instruments::Measurement,
    tolerance: &Tolerance,
) -> Result<Comparison, TargetError> {
    let mut angles = Vec::new();
    for (d, t) in design.angles.iter().zip(&target.angles) {
        let m = metamerism(
            &target.wavelength_nm,
            &t.reflectance_factor,
            &d.reflectance_factor,
        )?;
        angles.push(angle(
            tolerance,
            Geometry::directional(instruments::ILLUMINATION_DEG, d.aspecular_deg),
            d.lab,
            t.lab,
            conditions(PAINT_ILLUMINANT, PAINT_OBSERVER),
            LabSource::Spectrum,
            m,
        ));
    }
    let gloss = design
        .gloss
        .iter()
        .zip(&target.gloss)
        .map(|(d, t)| GlossComparison {
            angle_deg: f64::from(u32::from(d.geometry)),
            design_gu: d.total_gu,
            target_gu: t.total_gu,
        })
        .collect();
    Ok(finish(tolerance, angles, Vec::new(), gloss, Vec::new()))
}

/// A design against a measured standard, at each of the standard's geometries.
/// `design_readings` are the design's own instrument readings (for the gloss).
pub fn compare_to_standard(
    model: &PaintModel,
    design_readings: &instruments::Measurement,
    standard: &Standard<'_>,
    tolerance: &Tolerance,
) -> Result<Comparison, TargetError> {
    let mut angles = Vec::new();
    let mut not_comparable = Vec::new();
    let mut notes = Vec::new();
    let design_wavelengths = &design_readings.wavelength_nm;
    let (design_lo, design_hi) = (
        design_wavelengths.first().copied().unwrap_or(f64::NAN),
        design_wavelengths.last().copied().unwrap_or(f64::NAN),
    );
    for sample in &standard.readings {
        if sample.geometry == Geometry::Unspecified {
            not_comparable.push(NotComparable {
                geometry: sample.geometry,
                reason: "the file does not state this reading's geometry: not comparable"
                    .to_owned(),
            });
            continue;
        }
        if sample.spectrum.is_none() && sample.colour.is_none() {
            // Gloss only.
            continue;
        }
        let reading = instruments::reading(model, sample.geometry)?;
        match &sample.spectrum {
            Some(spectrum) => {
                let wavelengths = spectrum.wavelengths_nm();
                let design: Vec<f64> = wavelengths
                    .iter()
                    .map(|&nm| interpolate(design_wavelengths, &reading.reflectance_factor, nm))
                    .collect();
                if wavelengths.first().is_some_and(|&w| w < design_lo)
                    || wavelengths.last().is_some_and(|&w| w > design_hi)
                {
                    let note = format!(
                        "the target's spectrum reaches beyond the design's {design_lo}–{design_hi} nm; \
                         there the design's reflectance is held at its end values"
                    );
                    if !notes.contains(&note) {
                        notes.push(note);
                    }
                }
                let weights = summation_weights(PAINT_ILLUMINANT, PAINT_OBSERVER, wavelengths)?;
                let design_lab = weights.lab(&design);
                let target_lab = weights.lab(spectrum.factors());
                let m = metamerism(wavelengths, spectrum.factors(), &design)?;
                angles.push(angle(
                    tolerance,
                    sample.geometry,
                    design_lab,
                    target_lab,
                    conditions(PAINT_ILLUMINANT, PAINT_OBSERVER),
                    LabSource::Spectrum,
                    m,
                ));
            }
            None => {
                let stated = sample.colour.as_ref();
                let illuminant = stated
                    .and_then(|c| c.illuminant)
                    .unwrap_or(PAINT_ILLUMINANT);
                let observer = stated.and_then(|c| c.observer).unwrap_or(PAINT_OBSERVER);
                let (target_lab, source) = sample.lab(illuminant, observer)?;
                if source == LabSource::StatedAssumed {
                    let note = format!(
                        "the file does not name the illuminant and observer of its colours; \
                         {} assumed",
                        conditions(illuminant, observer)
                    );
                    if !notes.contains(&note) {
                        notes.push(note);
                    }
                }
                let weights = summation_weights(illuminant, observer, design_wavelengths)?;
                let design_lab = weights.lab(&reading.reflectance_factor);
                let note = "the target has no spectrum: no metamerism index".to_owned();
                if !notes.contains(&note) {
                    notes.push(note);
                }
                angles.push(angle(
                    tolerance,
                    sample.geometry,
                    design_lab,
                    target_lab,
                    conditions(illuminant, observer),
                    source,
                    Vec::new(),
                ));
            }
        }
    }
    let gloss = standard
        .readings
        .iter()
        .flat_map(|s| &s.gloss)
        .filter_map(|g| {
            design_readings
                .gloss
                .iter()
                .find(|d| f64::from(u32::from(d.geometry)) == g.angle_deg)
                .map(|d| GlossComparison {
                    angle_deg: g.angle_deg,
                    design_gu: d.total_gu,
                    target_gu: g.gu,
                })
        })
        .collect();
    Ok(finish(tolerance, angles, not_comparable, gloss, notes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::instruments::tests::grey;
    use crate::measurement::{Reflectance, Sample};
    use crate::paint::gloss::GlossExponent;
    use crate::paint::model::GlossSetting;

    fn grey_model(rho: f64) -> PaintModel {
        grey(rho, GlossSetting::Exponent(GlossExponent::Finite(300.0)))
    }

    fn reading(geometry: Geometry, spectrum: Option<Reflectance>) -> Sample {
        Sample {
            name: "S".to_owned(),
            id: None,
            geometry,
            spectrum,
            colour: None,
            gloss: Vec::new(),
        }
    }

    #[test]
    fn the_directional_reading_at_the_instrument_angles_is_the_instrument_reading() {
        let model = grey_model(0.4);
        let m = instruments::measure(&model).expect("spectral");
        for a in &m.angles {
            let r =
                instruments::directional_reading(&model, 45.0, a.aspecular_deg).expect("spectral");
            assert_eq!(&r, a);
        }
    }

    #[test]
    fn a_design_against_its_own_readings_passes_at_every_stated_geometry() {
        let model = grey_model(0.4);
        let readings = instruments::measure(&model).expect("spectral");
        let w = readings.wavelength_nm.clone();
        let mut samples: Vec<Sample> = readings
            .angles
            .iter()
            .map(|a| {
                reading(
                    Geometry::directional(45.0, a.aspecular_deg),
                    Some(Reflectance::new(w.clone(), a.reflectance_factor.clone()).expect("valid")),
                )
            })
            .collect();
        samples.extend(readings.sphere.iter().map(|s| {
            reading(
                s.geometry,
                Some(Reflectance::new(w.clone(), s.reflectance_factor.clone()).expect("valid")),
            )
        }));
        samples.push(reading(
            Geometry::Unspecified,
            Some(Reflectance::new(w.clone(), vec![0.4; w.len()]).expect("valid")),
        ));
        let standard = Standard {
            name: "S",
            readings: samples.iter().collect(),
        };
        let c = compare_to_standard(&model, &readings, &standard, &Tolerance::default())
            .expect("comparable");
        assert_eq!(c.angles.len(), 7);
        assert!(c.angles.iter().all(|a| a.difference.de00 < 1e-12 && a.pass));
        assert_eq!(c.angles[5].geometry, instruments::SPHERE_GEOMETRIES[0]);
        assert_eq!(c.pass, Some(true));
        assert!(!c.metameric);
        assert_eq!(c.not_comparable.len(), 1);
        assert!(c.notes.is_empty(), "{:?}", c.notes);

        // A lighter grey fails, and the per-angle limit decides at 15°.
        let lighter = grey_model(0.45);
        let lighter_readings = instruments::measure(&lighter).expect("spectral");
        let tolerance: Tolerance = "de00:0.1,15=100".parse().expect("tolerance");
        let c = compare_to_standard(&lighter, &lighter_readings, &standard, &tolerance)
            .expect("comparable");
        assert!(
            c.angles.iter().all(|a| a.difference.dl > 0.0),
            "lighter: ΔL* > 0"
        );
        let passes: Vec<bool> = c.angles.iter().map(|a| a.pass).collect();
        assert_eq!(passes, [true, false, false, false, false, false, false]);
        assert_eq!(c.pass, Some(false));
    }
}
