//! The units of the quantities a person sets or reads: what a slider shows after its
//! value, what a message prints after a number, what a parameter table states.
//!
//! Inside the core a quantity is a bare `f64` whose name ends in its unit
//! (`wavelength_nm`, `thickness_um`, `absorption_per_um`, `gu`, `theta_deg`), which is
//! what every formula reads and costs nothing in the inner loops. Where a quantity
//! meets a person — the parameter tables ([`crate::paint::parameters`]), the CLI's
//! and the design file's messages, the GUI's controls — it carries a [`Unit`], so the
//! symbol is written in one place and a table row cannot state a number without
//! saying in what.

use std::fmt;

/// The unit of a quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// A pure number: a reflectance, a refractive index, an optical depth.
    Dimensionless,
    /// Nanometres (wavelengths).
    Nanometre,
    /// Micrometres (coat thickness).
    Micrometre,
    /// Per micrometre (absorption coefficients).
    PerMicrometre,
    /// Square micrometres (the Cauchy coefficient B of n = A + B/λ², λ in µm).
    SquareMicrometre,
    /// Gloss units (ISO 2813: 100 GU is polished black glass of n = 1.567).
    GlossUnit,
    /// Degrees of angle.
    Degree,
    /// Metres (the default car's dimensions).
    Metre,
    /// A number of things (mesh rings, segments).
    Count,
}

impl Unit {
    /// The symbol written after a value: "" for a pure number.
    pub const fn symbol(self) -> &'static str {
        match self {
            Unit::Dimensionless => "",
            Unit::Nanometre => "nm",
            Unit::Micrometre => "µm",
            Unit::PerMicrometre => "1/µm",
            Unit::SquareMicrometre => "µm²",
            Unit::GlossUnit => "GU",
            Unit::Degree => "°",
            Unit::Metre => "m",
            Unit::Count => "",
        }
    }

    /// What goes between a value and its symbol: nothing for degrees ("20°") and
    /// pure numbers, a space otherwise ("45 µm").
    pub const fn separator(self) -> &'static str {
        match self {
            Unit::Dimensionless | Unit::Degree | Unit::Count => "",
            _ => " ",
        }
    }

    /// The suffix a control shows after its value: separator and symbol (" µm").
    pub fn suffix(self) -> String {
        format!("{}{}", self.separator(), self.symbol())
    }

    /// `value` with its unit: "45 µm", "20°", "0.5".
    pub fn format(self, value: f64) -> String {
        format!("{value}{}", self.suffix())
    }
}

impl fmt::Display for Unit {
    /// The symbol ([`Unit::symbol`]).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_print_with_their_symbols() {
        assert_eq!(Unit::Micrometre.format(45.0), "45 µm");
        assert_eq!(Unit::Degree.format(20.0), "20°");
        assert_eq!(Unit::Dimensionless.format(0.5), "0.5");
        assert_eq!(Unit::PerMicrometre.suffix(), " 1/µm");
        assert_eq!(Unit::GlossUnit.to_string(), "GU");
    }
}
