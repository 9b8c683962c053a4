//! The paint model's parameter table: for each quantity a designer (or a CLI user)
//! sets, its name, symbol, unit, the values the model accepts, the span of the GUI's
//! control, and a default.
//!
//! This is the one place these numbers are stated. The model's own checks
//! ([`super::model::PaintModel::new`] and its setters), the design file's validation
//! ([`crate::design::PaintDesign::validate`]), the glossmeter conversions
//! ([`super::gloss`]), the CLI's argument checks and the GUI's sliders all read it.
//!
//! Spectral parameters (ρ, n, k) are checked at every wavelength against the same
//! range. Two constraints are not a fixed interval and are checked where they arise:
//! a gloss reading must be at least what the broadest lobe (m = 0) reads for the
//! coat's n and the geometry ([`super::gloss::reading_range`]), and a Cauchy pair
//! (A, B) must give an n(λ) in [`REFRACTIVE_INDEX`]'s range over the whole visible
//! range ([`crate::colour::spectrum::VISIBLE`]).
//!
//! The Phong comparison model has no table: its kd, ks and m are derived from a
//! design ([`super::phong::PhongParams`]), never set by a person.

pub use crate::parameter::{Bounds, Parameter, RangeError, Violation};
use crate::units::Unit;

/// ρ(λ): the diffuse albedo of the pigment layer.
pub const ALBEDO: Parameter = Parameter {
    name: "pigment albedo",
    symbol: "ρ",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, 1.0),
    control: Some(Bounds::new(0.0, 1.0)),
    default: 0.5,
};

/// n(λ): the refractive index of the clear coat (tested up to 4).
pub const REFRACTIVE_INDEX: Parameter = Parameter {
    name: "clear coat refractive index",
    symbol: "n",
    unit: Unit::Dimensionless,
    range: Bounds::new(1.0, f64::INFINITY),
    control: None,
    default: 1.5,
};

/// A of a Cauchy index n(λ) = A + B/λ² (λ in µm), as design files and the GUI set
/// n. Any finite value, as long as n(λ) stays in [`REFRACTIVE_INDEX`]'s range.
pub const CAUCHY_A: Parameter = Parameter {
    name: "Cauchy coefficient",
    symbol: "A",
    unit: Unit::Dimensionless,
    range: Bounds::new(f64::NEG_INFINITY, f64::INFINITY),
    control: Some(Bounds::new(1.0, 2.5)),
    // With B below: n(587.6 nm) = 1.528, inside the 1.50–1.53 of automotive 2K
    // polyurethane and acrylic-melamine clears; a coat of n = 1.50 reads only
    // 82 GU at 20° even as a perfect mirror, this one ~88.6, which leaves room for
    // the 85–89 GU of a good automotive finish with a finite m.
    default: 1.515,
};

/// B of a Cauchy index n(λ) = A + B/λ² (λ in µm): positive for normal dispersion.
pub const CAUCHY_B: Parameter = Parameter {
    name: "Cauchy coefficient",
    symbol: "B",
    unit: Unit::SquareMicrometre,
    range: Bounds::new(f64::NEG_INFINITY, f64::INFINITY),
    control: Some(Bounds::new(-0.02, 0.1)),
    default: 0.0045,
};

/// k(λ): the absorption coefficient of the clear coat.
pub const ABSORPTION: Parameter = Parameter {
    name: "clear coat absorption",
    symbol: "k",
    unit: Unit::PerMicrometre,
    range: Bounds::new(0.0, f64::INFINITY),
    control: Some(Bounds::new(0.0, 1.0)),
    default: 0.0004,
};

/// h: the thickness of the clear coat.
pub const THICKNESS: Parameter = Parameter {
    name: "clear coat thickness",
    symbol: "h",
    unit: Unit::Micrometre,
    range: Bounds::new(0.0, f64::INFINITY),
    control: Some(Bounds::new(0.0, 200.0)),
    // Automotive clear coats are 35–55 µm.
    default: 45.0,
};

/// τ = k·h: the optical depth of the coat at normal incidence, which the body term
/// depends on instead of k and h apart (`coatlab brdf` takes it directly).
pub const OPTICAL_DEPTH: Parameter = Parameter {
    name: "coat optical depth",
    symbol: "τ",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, f64::INFINITY),
    control: None,
    default: ABSORPTION.default * THICKNESS.default,
};

/// g: the specular gloss as a glossmeter reads it, at a geometry of
/// [`super::gloss::GlossGeometry`]. Besides this range, a reading must be at least
/// the broadest lobe's ([`super::gloss::reading_range`]), which is also the
/// GUI control's span; readings at or above the coat's mirror reading are the
/// ideal mirror.
pub const GLOSS: Parameter = Parameter {
    name: "gloss",
    symbol: "g",
    unit: Unit::GlossUnit,
    range: Bounds::new(0.0, f64::INFINITY),
    control: None,
    default: 88.0,
};

/// Every parameter, in the order of the model's documentation.
pub const ALL: [&Parameter; 8] = [
    &ALBEDO,
    &REFRACTIVE_INDEX,
    &CAUCHY_A,
    &CAUCHY_B,
    &ABSORPTION,
    &THICKNESS,
    &OPTICAL_DEPTH,
    &GLOSS,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_and_control_lies_in_the_range() {
        for p in ALL {
            assert!(p.accepts(p.default), "{}: default {}", p.label(), p.default);
            if let Some(control) = p.control {
                assert!(control.min <= control.max, "{}", p.label());
                for end in [control.min, control.max] {
                    assert!(p.accepts(end), "{}: control end {end}", p.label());
                }
            }
        }
    }

    #[test]
    fn refusals_name_the_parameter_and_its_range() {
        let error = THICKNESS.check(-5.0).unwrap_err();
        assert_eq!(
            error.to_string(),
            "-5 is negative: clear coat thickness h must lie in [0, ∞) µm"
        );
        assert_eq!(
            ALBEDO.check(1.2).unwrap_err().to_string(),
            "1.2 is outside [0, 1]: pigment albedo ρ must lie in [0, 1]"
        );
        assert_eq!(
            REFRACTIVE_INDEX.check(0.9).unwrap_err().to_string(),
            "0.9 is below 1: clear coat refractive index n must lie in [1, ∞)"
        );
        assert_eq!(
            GLOSS.check(f64::NAN).unwrap_err().violation,
            Violation::NotFinite
        );
        assert!(CAUCHY_B.check(-1e300).is_ok());
        assert!(CAUCHY_B.check(f64::INFINITY).is_err());
    }

    #[test]
    fn bounds_accept_exactly_their_closed_interval() {
        let unit = Bounds::new(0.0, 1.0);
        for (value, accepted) in [
            (0.0, true),
            (1.0, true),
            (-f64::MIN_POSITIVE, false),
            (1.0 + f64::EPSILON, false),
            (f64::NAN, false),
        ] {
            assert_eq!(unit.accepts(value), accepted, "{value}");
            assert_eq!(unit.violation(value).is_none(), accepted, "{value}");
        }
        assert_eq!(Bounds::new(1.0, f64::INFINITY).to_string(), "[1, ∞)");
        assert_eq!(
            Bounds::new(f64::NEG_INFINITY, f64::INFINITY).to_string(),
            "(−∞, ∞)"
        );
    }
}
