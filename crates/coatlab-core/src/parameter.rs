//! One row of a model's parameter table: a quantity a person sets, with its name,
//! symbol, unit, the values the model accepts, the span of the GUI's control and a
//! default; and the refusal of a value outside that range, which names all of it.
//!
//! Each model states its table once, as constants of [`Parameter`]: the paint model in
//! [`crate::paint::parameters`], the default car in [`crate::scene::car::PARAMETERS`].
//! Validation, the CLI and the GUI read those tables, never numbers of their own.

use std::fmt;

use crate::units::Unit;

/// A closed interval of accepted values, `[min, max]`; `min` may be −∞ and `max` +∞
/// (then only finite values are accepted on that side).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// The smallest accepted value.
    pub min: f64,
    /// The largest accepted value.
    pub max: f64,
}

impl Bounds {
    /// `[min, max]`.
    pub const fn new(min: f64, max: f64) -> Self {
        Self { min, max }
    }

    /// Whether `value` is finite and in `[min, max]`.
    pub fn accepts(&self, value: f64) -> bool {
        value.is_finite() && value >= self.min && value <= self.max
    }

    /// What is wrong with `value`, in the words messages use after "x = value":
    /// "is not a finite number", "is negative" (below a minimum of 0 with no
    /// maximum), "is below 1" (below another minimum with no maximum), or
    /// "is outside [0, 1]"; `None` when it is accepted.
    pub fn violation(&self, value: f64) -> Option<Violation> {
        if !value.is_finite() {
            Some(Violation::NotFinite)
        } else if value >= self.min && value <= self.max {
            None
        } else if self.max == f64::INFINITY && self.min == 0.0 {
            Some(Violation::Negative)
        } else if self.max == f64::INFINITY {
            Some(Violation::Below(self.min))
        } else {
            Some(Violation::Outside(*self))
        }
    }

    /// `(min, max)`, for widgets that take a pair.
    pub const fn pair(&self) -> (f64, f64) {
        (self.min, self.max)
    }
}

impl fmt::Display for Bounds {
    /// "[0, 1]", "[1, ∞)", "(−∞, ∞)".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.min == f64::NEG_INFINITY {
            f.write_str("(−∞, ")?;
        } else {
            write!(f, "[{}, ", self.min)?;
        }
        if self.max == f64::INFINITY {
            f.write_str("∞)")
        } else {
            write!(f, "{}]", self.max)
        }
    }
}

/// Why a value is refused (see [`Bounds::violation`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Violation {
    /// NaN or infinite.
    NotFinite,
    /// Below a minimum of 0.
    Negative,
    /// Below this minimum.
    Below(f64),
    /// Outside these finite bounds.
    Outside(Bounds),
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Violation::NotFinite => f.write_str("is not a finite number"),
            Violation::Negative => f.write_str("is negative"),
            Violation::Below(min) => write!(f, "is below {min}"),
            Violation::Outside(bounds) => write!(f, "is outside {bounds}"),
        }
    }
}

/// One parameter of a model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parameter {
    /// What it is, in words: "clear coat thickness".
    pub name: &'static str,
    /// Its symbol in the model's formulas: "h".
    pub symbol: &'static str,
    /// Its unit.
    pub unit: Unit,
    /// The values the model accepts (finite ones only).
    pub range: Bounds,
    /// The span of the GUI's control: the paints the model is meant for, within
    /// `range`; `None` where the GUI has no control for it.
    pub control: Option<Bounds>,
    /// A typical value: what the presets and examples use.
    pub default: f64,
}

/// A value outside its parameter's range. The message names the parameter and
/// the range: "-5 is negative: clear coat thickness h must lie in [0, ∞) µm".
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{value} {violation}: {} must lie in {}", .parameter.label(), .parameter.range_text())]
pub struct RangeError {
    /// The parameter.
    pub parameter: &'static Parameter,
    /// The value given.
    pub value: f64,
    /// What is wrong with it.
    pub violation: Violation,
}

impl Parameter {
    /// Name and symbol: "clear coat thickness h"; the name alone where there is
    /// no symbol.
    pub fn label(&self) -> String {
        if self.symbol.is_empty() {
            self.name.to_owned()
        } else {
            format!("{} {}", self.name, self.symbol)
        }
    }

    /// The accepted range with the unit: "[0, ∞) µm", "[0, 1]".
    pub fn range_text(&self) -> String {
        format!("{}{}", self.range, self.unit.suffix())
    }

    /// Whether `value` is finite and in range.
    pub fn accepts(&self, value: f64) -> bool {
        self.range.accepts(value)
    }

    /// `Ok` for a finite value in range; otherwise an error naming the parameter
    /// and its range.
    pub fn check(&'static self, value: f64) -> Result<(), RangeError> {
        match self.range.violation(value) {
            None => Ok(()),
            Some(violation) => Err(RangeError {
                parameter: self,
                value,
                violation,
            }),
        }
    }
}
