//! Colour tolerances as a quality lab reports them: the CIELAB differences ΔL*,
//! Δa*, Δb*, ΔC*ab, ΔH*ab, the totals ΔE*ab, ΔE00 and CMC(l:c), pass or fail
//! against per-angle limits, and the CIE special metamerism index for a change of
//! illuminant. Formulas and sources are in `docs/measurements.md`.
//!
//! Every difference is trial (the sample, batch or design) minus standard (the
//! target), the convention of CIE 15:2004 and of instrument reports: ΔL* > 0 means
//! the trial is lighter. ΔH*ab carries the sign of the hue-angle difference.

use std::fmt;
use std::str::FromStr;

use crate::colour::cie::{CieError, Illuminant, Observer, summation_weights};
use crate::colour::{Lab, Xyz, ciede2000, lab_from_xyz};

/// The differences of a trial from a standard.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LabDifference {
    #[serde(rename = "dL")]
    pub dl: f64,
    #[serde(rename = "da")]
    pub da: f64,
    #[serde(rename = "db")]
    pub db: f64,
    /// ΔC*ab, chroma difference.
    #[serde(rename = "dC")]
    pub dc: f64,
    /// ΔH*ab, signed metric hue difference.
    #[serde(rename = "dH")]
    pub dh: f64,
    /// CIE 1976 ΔE*ab.
    #[serde(rename = "dEab")]
    pub de_ab: f64,
    /// CIEDE2000 (kL = kC = kH = 1).
    #[serde(rename = "dE00")]
    pub de00: f64,
    /// CMC(2:1).
    #[serde(rename = "dECMC")]
    pub de_cmc: f64,
}

fn chroma(lab: Lab) -> f64 {
    lab.a.hypot(lab.b)
}

/// Hue angle, degrees in [0, 360); 0 for a neutral colour.
fn hue_deg(lab: Lab) -> f64 {
    if lab.a == 0.0 && lab.b == 0.0 {
        0.0
    } else {
        lab.b.atan2(lab.a).to_degrees().rem_euclid(360.0)
    }
}

/// ΔH*ab = 2 √(C*₁ C*₂) sin(Δh/2), with Δh the hue difference taken the short way
/// round: the signed form of √(ΔE*ab² − ΔL*² − ΔC*²) (CIE 15:2004, 8.2.1).
pub fn delta_hue(standard: Lab, trial: Lab) -> f64 {
    let product = chroma(standard) * chroma(trial);
    if product == 0.0 {
        return 0.0;
    }
    let mut dh = hue_deg(trial) - hue_deg(standard);
    if dh > 180.0 {
        dh -= 360.0;
    } else if dh < -180.0 {
        dh += 360.0;
    }
    2.0 * product.sqrt() * (0.5 * dh).to_radians().sin()
}

/// CMC(l:c) (Clarke, McDonald & Rigg, J. Soc. Dyers Colour. 100 (1984) 128–132;
/// ISO 105-J03), the weights taken at the standard.
pub fn cmc(standard: Lab, trial: Lab, l: f64, c: f64) -> f64 {
    let (l1, c1, h1) = (standard.l, chroma(standard), hue_deg(standard));
    let dl = trial.l - l1;
    let dc = chroma(trial) - c1;
    let dh = delta_hue(standard, trial);
    let s_l = if l1 < 16.0 {
        0.511
    } else {
        0.040975 * l1 / (1.0 + 0.01765 * l1)
    };
    let s_c = 0.0638 * c1 / (1.0 + 0.0131 * c1) + 0.638;
    let c1_4 = c1.powi(4);
    let f = (c1_4 / (c1_4 + 1900.0)).sqrt();
    let t = if (164.0..=345.0).contains(&h1) {
        0.56 + (0.2 * (h1 + 168.0).to_radians().cos()).abs()
    } else {
        0.36 + (0.4 * (h1 + 35.0).to_radians().cos()).abs()
    };
    let s_h = s_c * (f * t + 1.0 - f);
    ((dl / (l * s_l)).powi(2) + (dc / (c * s_c)).powi(2) + (dh / s_h).powi(2)).sqrt()
}

/// All differences of `trial` from `standard`.
pub fn difference(standard: Lab, trial: Lab) -> LabDifference {
    let dl = trial.l - standard.l;
    let da = trial.a - standard.a;
    let db = trial.b - standard.b;
    LabDifference {
        dl,
        da,
        db,
        dc: chroma(trial) - chroma(standard),
        dh: delta_hue(standard, trial),
        de_ab: (dl * dl + da * da + db * db).sqrt(),
        de00: ciede2000(standard, trial),
        de_cmc: cmc(standard, trial, 2.0, 1.0),
    }
}

/// The total difference a tolerance is set in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Formula {
    /// CIEDE2000.
    #[serde(rename = "dE00")]
    De00,
    /// CIE 1976 ΔE*ab.
    #[serde(rename = "dEab")]
    DeAb,
    /// CMC(2:1).
    #[serde(rename = "dECMC")]
    Cmc,
}

impl Formula {
    /// This formula's value in `d`.
    pub fn of(self, d: &LabDifference) -> f64 {
        match self {
            Formula::De00 => d.de00,
            Formula::DeAb => d.de_ab,
            Formula::Cmc => d.de_cmc,
        }
    }
}

impl fmt::Display for Formula {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Formula::De00 => "ΔE00",
            Formula::DeAb => "ΔE*ab",
            Formula::Cmc => "ΔE CMC(2:1)",
        })
    }
}

/// Why a tolerance text is not understood.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ToleranceError {
    #[error("unknown colour-difference formula {0:?}: expected de00, deab (or de76) or cmc")]
    UnknownFormula(String),
    #[error("tolerance {0:?} is not a positive number")]
    NotALimit(String),
    #[error("angle {0:?} is not a number of degrees")]
    NotAnAngle(String),
    #[error("no tolerance given")]
    Empty,
}

/// Pass/fail limits: one formula, a limit for every angle, and limits for
/// particular aspecular angles.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Tolerance {
    pub formula: Formula,
    /// The limit where no angle-specific one is set.
    pub default_limit: f64,
    /// (aspecular angle in degrees, limit).
    pub per_angle: Vec<(f64, f64)>,
}

impl Default for Tolerance {
    /// ΔE00 ≤ 1 at every angle.
    fn default() -> Self {
        Self {
            formula: Formula::De00,
            default_limit: 1.0,
            per_angle: Vec::new(),
        }
    }
}

impl Tolerance {
    /// The limit at a directional reading of aspecular angle `aspecular_deg`, or
    /// (with `None`) at a sphere or unspecified geometry.
    pub fn limit_at(&self, aspecular_deg: Option<f64>) -> f64 {
        aspecular_deg
            .and_then(|a| {
                self.per_angle
                    .iter()
                    .find(|(angle, _)| (angle - a).abs() < 1e-9)
                    .map(|(_, limit)| *limit)
            })
            .unwrap_or(self.default_limit)
    }
}

impl FromStr for Tolerance {
    type Err = ToleranceError;

    /// `[FORMULA:]ITEM[,ITEM…]`, each ITEM a limit for every angle or
    /// `ANGLE=LIMIT` for one aspecular angle: `1`, `cmc:1.5`,
    /// `de00:1,15=1.5,110=2`. Without a limit for every angle, it is 1.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        if s.is_empty() {
            return Err(ToleranceError::Empty);
        }
        let (formula, items) = match s.split_once(':') {
            Some((name, rest)) => {
                let formula = match name.trim().to_ascii_lowercase().as_str() {
                    "de00" | "ciede2000" | "2000" => Formula::De00,
                    "deab" | "de76" | "cie76" | "1976" => Formula::DeAb,
                    "cmc" | "cmc21" | "cmc2:1" => Formula::Cmc,
                    _ => return Err(ToleranceError::UnknownFormula(name.to_owned())),
                };
                (formula, rest)
            }
            None => (Formula::De00, s),
        };
        let limit = |t: &str| {
            t.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| ToleranceError::NotALimit(t.trim().to_owned()))
        };
        let mut tolerance = Tolerance {
            formula,
            ..Tolerance::default()
        };
        for item in items.split(',').filter(|i| !i.trim().is_empty()) {
            match item.split_once('=') {
                Some((angle, value)) => {
                    let angle_deg = angle
                        .trim()
                        .trim_end_matches('°')
                        .trim_start_matches("as")
                        .parse::<f64>()
                        .ok()
                        .filter(|a| a.is_finite())
                        .ok_or_else(|| ToleranceError::NotAnAngle(angle.trim().to_owned()))?;
                    let value = limit(value)?;
                    tolerance.per_angle.retain(|(a, _)| *a != angle_deg);
                    tolerance.per_angle.push((angle_deg, value));
                }
                None => tolerance.default_limit = limit(item)?,
            }
        }
        Ok(tolerance)
    }
}

/// The colour difference a metamerism index counts as a visible change of match:
/// half the default acceptance limit of ΔE00 = 1.
pub const METAMERIC_DE00: f64 = 0.5;

/// The CIE special metamerism index for a change of illuminant of one test
/// illuminant.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MetamerismIndex {
    #[serde(serialize_with = "serialize_illuminant")]
    pub illuminant: Illuminant,
    /// In CIEDE2000.
    #[serde(rename = "dE00")]
    pub de00: f64,
    /// In ΔE*ab (what CIE 15:2004 states the index in).
    #[serde(rename = "dEab")]
    pub de_ab: f64,
}

fn serialize_illuminant<S: serde::Serializer>(i: &Illuminant, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&i.to_string())
}

/// The CIE special metamerism index for a change of illuminant (CIE 15:2004,
/// 8.2.2; CIE 80): the standard and the trial, spectra on the same
/// `wavelengths_nm`, are matched under `reference` by the multiplicative correction
/// (each of the trial's X, Y, Z under `test` multiplied by the ratio of the
/// standard's to the trial's under `reference`), then compared under `test`.
pub fn metamerism_index(
    wavelengths_nm: &[f64],
    standard: &[f64],
    trial: &[f64],
    reference: Illuminant,
    test: Illuminant,
    observer: Observer,
) -> Result<MetamerismIndex, CieError> {
    let under_reference = summation_weights(reference, observer, wavelengths_nm)?;
    let under_test = summation_weights(test, observer, wavelengths_nm)?;
    let (s_r, t_r) = (under_reference.xyz(standard), under_reference.xyz(trial));
    let (s_t, t_t) = (under_test.xyz(standard), under_test.xyz(trial));
    // A zero tristimulus value of the trial leaves that component uncorrected.
    let ratio = |s: f64, t: f64| if t > 0.0 { s / t } else { 1.0 };
    let corrected = Xyz::new(
        t_t.x * ratio(s_r.x, t_r.x),
        t_t.y * ratio(s_r.y, t_r.y),
        t_t.z * ratio(s_r.z, t_r.z),
    );
    let white = under_test.white();
    let standard_lab = lab_from_xyz(s_t, white);
    let trial_lab = lab_from_xyz(corrected, white);
    let d = difference(standard_lab, trial_lab);
    Ok(MetamerismIndex {
        illuminant: test,
        de00: d.de00,
        de_ab: d.de_ab,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tolerance_texts_parse() {
        assert_eq!("1".parse::<Tolerance>(), Ok(Tolerance::default()));
        let t: Tolerance = "cmc:1.5,15=2,as110°=2.5".parse().expect("tolerance");
        assert_eq!(t.formula, Formula::Cmc);
        assert_eq!(t.default_limit, 1.5);
        assert_eq!(t.limit_at(Some(15.0)), 2.0);
        assert_eq!(t.limit_at(Some(45.0)), 1.5);
        assert_eq!(t.limit_at(None), 1.5);
        let t: Tolerance = "deab:15=2".parse().expect("tolerance");
        assert_eq!((t.formula, t.default_limit), (Formula::DeAb, 1.0));
        for bad in ["", "x:1", "-1", "0", "de00:abc", "de00:q=1"] {
            assert!(bad.parse::<Tolerance>().is_err(), "{bad}");
        }
    }
}
