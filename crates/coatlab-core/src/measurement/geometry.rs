//! The measuring geometry of a reading, and the names instruments write for it.
//!
//! Directional geometries are described by the illumination angle from the normal
//! and the aspecular angle: the detector's angle from the specular direction,
//! positive toward the illuminator (ASTM E2194; the virtual instrument of
//! [`crate::instruments`] uses the same convention). 45°:0° is the directional
//! geometry 45°as45°, and is shown so. A sphere reads diffuse illumination at 8° with the specular
//! component included (SCI, CIE di:8°) or excluded (SCE, de:8°).

use std::fmt;

/// Whether a sphere instrument's reading includes the specular reflection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SpecularComponent {
    /// SCI, CIE di:8°: the gloss trap closed.
    Included,
    /// SCE, CIE de:8°: the gloss trap open.
    Excluded,
}

/// Where a reading was taken from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Geometry {
    /// Collimated illumination and detection in one plane (multi-angle
    /// instruments, single-angle 45°:0°).
    Directional {
        /// Illumination angle from the normal, degrees.
        illumination_deg: f64,
        /// Detection angle from the specular direction, positive toward the
        /// illuminator, degrees.
        aspecular_deg: f64,
    },
    /// Integrating sphere, d:8°.
    Sphere {
        /// SCI or SCE.
        specular: SpecularComponent,
    },
    /// The file does not say.
    Unspecified,
}

impl Geometry {
    /// The directional geometry `illumination_deg`as`aspecular_deg`.
    pub fn directional(illumination_deg: f64, aspecular_deg: f64) -> Self {
        Geometry::Directional {
            illumination_deg,
            aspecular_deg,
        }
    }

    /// The detector's signed polar angle (positive on the specular side), for a
    /// directional geometry.
    pub fn detector_deg(&self) -> Option<f64> {
        match *self {
            Geometry::Directional {
                illumination_deg,
                aspecular_deg,
            } => Some(illumination_deg - aspecular_deg),
            _ => None,
        }
    }
}

impl fmt::Display for Geometry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Geometry::Directional {
                illumination_deg,
                aspecular_deg,
            } => write!(f, "{illumination_deg}°as{aspecular_deg}°"),
            Geometry::Sphere {
                specular: SpecularComponent::Included,
            } => f.write_str("d:8° SCI"),
            Geometry::Sphere {
                specular: SpecularComponent::Excluded,
            } => f.write_str("d:8° SCE"),
            Geometry::Unspecified => f.write_str("unspecified"),
        }
    }
}

/// Why a geometry name is not understood.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error(
        "unknown geometry {0:?}: expected a multi-angle name such as 45as15 or 45°as-15°, \
         45:0 (or 0:45), or a sphere geometry with its specular component (d:8 SCI, d8 SCE, \
         di:8, de:8, SCI, SCE)"
    )]
    Unknown(String),
    #[error(
        "sphere geometry {0:?} does not say whether the specular component is included: \
         write SCI or SCE (di:8 or de:8)"
    )]
    SpecularUnstated(String),
    #[error("geometry {name:?}: angle {angle_deg}° is outside the hemisphere (|angle| < 90°)")]
    OutOfRange { name: String, angle_deg: f64 },
}

/// Reads a geometry name as instruments write it (case, spaces, degree signs and
/// underscores are ignored): `45as15`, `45as-15`, `as25` (illumination 45°), `45:0`,
/// `0:45`, `45/0`, `45a:0`, `45c:0`, `d:8 SCI`, `d/8 SCE`, `d8i`, `di:8`, `de:8`,
/// `SCI`, `SCE`, `SPIN`, `SPEX`.
pub fn parse_geometry(name: &str) -> Result<Geometry, GeometryError> {
    let key: String = name
        .chars()
        .filter(|c| !c.is_whitespace() && !matches!(c, '°' | '_'))
        .flat_map(char::to_lowercase)
        .collect();
    let unknown = || GeometryError::Unknown(name.to_owned());
    let number = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
    let hemisphere = |angle_deg: f64| {
        if angle_deg.abs() < 90.0 {
            Ok(angle_deg)
        } else {
            Err(GeometryError::OutOfRange {
                name: name.to_owned(),
                angle_deg,
            })
        }
    };

    // Multi-angle: [illumination]as<aspecular>.
    if let Some((illumination, aspecular)) = key.split_once("as") {
        let illumination_deg = if illumination.is_empty() {
            45.0
        } else {
            number(illumination).ok_or_else(unknown)?
        };
        let aspecular_deg = number(aspecular).ok_or_else(unknown)?;
        let illumination_deg = hemisphere(illumination_deg)?;
        hemisphere(illumination_deg - aspecular_deg)?;
        return Ok(Geometry::directional(illumination_deg, aspecular_deg));
    }

    // Sphere: the specular component from SCI/SCE, SPIN/SPEX, di/de or a trailing i/e.
    let specular = if key.contains("sci") || key.contains("spin") {
        Some(SpecularComponent::Included)
    } else if key.contains("sce") || key.contains("spex") {
        Some(SpecularComponent::Excluded)
    } else {
        None
    };
    let sphere_core: String = key
        .replace("sci", "")
        .replace("sce", "")
        .replace("spin", "")
        .replace("spex", "")
        .replace([':', '/', ',', '-', '(', ')'], "");
    let sphere_specular = match sphere_core.as_str() {
        "" if specular.is_some() => Some(specular),
        "d8" | "8d" => Some(specular),
        "di8" | "d8i" | "8di" => Some(Some(SpecularComponent::Included)),
        "de8" | "d8e" | "8de" => Some(Some(SpecularComponent::Excluded)),
        _ => None,
    };
    if let Some(found) = sphere_specular {
        return match found {
            Some(specular) => Ok(Geometry::Sphere { specular }),
            None => Err(GeometryError::SpecularUnstated(name.to_owned())),
        };
    }

    // Single angle: 45:0 (annular "a" or circumferential "c" illumination too), and
    // 0:45, the same reading by reciprocity.
    let single = key.replace(['a', 'c', 'x'], "");
    if let Some((from, to)) = single.split_once([':', '/']) {
        let (from, to) = (
            number(from).ok_or_else(unknown)?,
            number(to).ok_or_else(unknown)?,
        );
        let (illumination_deg, detector_deg) = if from >= to { (from, to) } else { (to, from) };
        let illumination_deg = hemisphere(illumination_deg)?;
        let detector_deg = hemisphere(detector_deg)?;
        // The detector on the far side of the normal from the illuminator.
        return Ok(Geometry::directional(
            illumination_deg,
            illumination_deg - detector_deg,
        ));
    }
    Err(unknown())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instrument_names_read_as_their_geometry() {
        let cases = [
            ("45as15", Geometry::directional(45.0, 15.0)),
            ("45°as-15°", Geometry::directional(45.0, -15.0)),
            ("45 as 110", Geometry::directional(45.0, 110.0)),
            ("AS25", Geometry::directional(45.0, 25.0)),
            ("15as-45", Geometry::directional(15.0, -45.0)),
            ("45:0", Geometry::directional(45.0, 45.0)),
            ("0/45", Geometry::directional(45.0, 45.0)),
            ("45a:0", Geometry::directional(45.0, 45.0)),
            (
                "d:8 SCI",
                Geometry::Sphere {
                    specular: SpecularComponent::Included,
                },
            ),
            (
                "d/8_SCE",
                Geometry::Sphere {
                    specular: SpecularComponent::Excluded,
                },
            ),
            (
                "di:8°",
                Geometry::Sphere {
                    specular: SpecularComponent::Included,
                },
            ),
            (
                "de:8",
                Geometry::Sphere {
                    specular: SpecularComponent::Excluded,
                },
            ),
            (
                "SCE",
                Geometry::Sphere {
                    specular: SpecularComponent::Excluded,
                },
            ),
        ];
        for (name, want) in cases {
            assert_eq!(parse_geometry(name), Ok(want), "{name}");
        }
        // One name for one geometry: 45°:0° is shown as the multi-angle 45°as45°.
        assert_eq!(Geometry::directional(45.0, 45.0).to_string(), "45°as45°");
        assert_eq!(Geometry::directional(45.0, -15.0).to_string(), "45°as-15°");
    }

    #[test]
    fn unknown_or_incomplete_names_are_refused_with_the_name() {
        for name in ["45 degrees", "sphere", "as", "hello", "45:x"] {
            let e = parse_geometry(name).expect_err(name);
            assert!(e.to_string().contains(name), "{e}");
        }
        assert!(matches!(
            parse_geometry("d:8"),
            Err(GeometryError::SpecularUnstated(_))
        ));
        // The detector would be below the surface.
        assert!(matches!(
            parse_geometry("45as150"),
            Err(GeometryError::OutOfRange { .. })
        ));
    }
}
