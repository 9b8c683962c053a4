//! Which way a loaded car points, and the turn that puts it in the scene's frame
//! (Y up, the nose toward +Z, as [`super::car`] builds its car).
//!
//! The heuristic (the user's account is in `docs/scenes.md`, "Orientation"), on
//! the car's triangles only ([`super::framing`]), after the file's node transforms:
//!
//! | step | rule | why |
//! |---|---|---|
//! | up | the file's +Y, as glTF prescribes; if the car is taller than it is long or wide, the file was exported Z-up and its +Z is taken as up | a car is never taller than long |
//! | long axis | the principal axis of the horizontal spread (second moments) of the car's surface; snapped to the file's X or Z axis within [`SNAP_DEG`]; the file's axes kept when the two spreads differ by less than [`MIN_ELONGATION`] or the footprint is narrower than [`MIN_WIDTH_RATIO`] of its length (not car-shaped: a panel, a strip) | a car is longer than wide, and mirror-symmetric, so the long axis is a principal axis |
//! | front end | the end of the long axis whose top, over its last [`END_SLICE`] of the length, is lower by at least [`MIN_HEIGHT_STEP`] of the car's height; when the ends are within that, the end nearer the file's +Z (glTF's front, the prior) | bonnets and noses are low; cabins, boots, rear wings and truck boxes sit high at the back |
//! | override | [`Front`]: the end of the long axis nearest the named file axis is the front | a car whose nose is the high end (a van, a cab-over truck) |
//!
//! Limits: a car with the same height at both ends and the nose toward the file's
//! −Z is turned the wrong way round (use the override); a model whose horizontal
//! spread is nearly round keeps its file axes; up is only ever the file's +Y or +Z.

use std::fmt;
use std::str::FromStr;

use glam::{DMat3, DVec3};

use super::TriangleMesh;
use crate::names::{UnknownName, by_name};

/// A principal axis within this of the file's X or Z axis is taken as that axis,
/// degrees: models authored along an axis stay exactly along it.
pub const SNAP_DEG: f64 = 3.0;
/// The larger horizontal spread (variance) must exceed the smaller by this factor
/// for its axis to count as the car's length.
pub const MIN_ELONGATION: f64 = 1.2;
/// A footprint narrower than this share of its length is not taken for a car (a
/// car is about 0.4 as wide as long): its axes are left as the file has them.
pub const MIN_WIDTH_RATIO: f64 = 0.15;
/// Share of the car's length at each end whose top height is compared.
pub const END_SLICE: f64 = 0.2;
/// The ends' top heights must differ by this share of the car's height for the
/// lower one to be taken as the nose.
pub const MIN_HEIGHT_STEP: f64 = 0.08;

/// The file axis the user names as the car's front (`--front`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Front {
    PlusX,
    MinusX,
    PlusZ,
    MinusZ,
}

impl Front {
    /// Every choice, in the order the help lists them.
    pub const ALL: [Front; 4] = [Front::PlusX, Front::MinusX, Front::PlusZ, Front::MinusZ];

    /// The name on the command line: `+x`, `-x`, `+z`, `-z`.
    pub fn name(self) -> &'static str {
        match self {
            Front::PlusX => "+x",
            Front::MinusX => "-x",
            Front::PlusZ => "+z",
            Front::MinusZ => "-z",
        }
    }

    /// The axis as a unit vector in the file's frame.
    pub fn direction(self) -> DVec3 {
        match self {
            Front::PlusX => DVec3::X,
            Front::MinusX => DVec3::NEG_X,
            Front::PlusZ => DVec3::Z,
            Front::MinusZ => DVec3::NEG_Z,
        }
    }
}

impl fmt::Display for Front {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A `--front` value that names no axis.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(transparent)]
pub struct FrontParseError(#[from] pub UnknownName);

impl FromStr for Front {
    type Err = FrontParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Ok(by_name(text, "an axis", &Front::ALL, Front::name)?)
    }
}

/// How the file's axes were turned: the car's front and up as directions in the
/// file's frame (after its node transforms), and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Orientation {
    /// Unit direction of the car's nose, file frame.
    pub front_in_file: [f64; 3],
    /// Unit up direction, file frame.
    pub up_in_file: [f64; 3],
    /// How the front was found, for the loader's notes.
    pub reason: String,
}

impl Default for Orientation {
    /// The scene's own convention: nothing turned.
    fn default() -> Self {
        Self {
            front_in_file: [0.0, 0.0, 1.0],
            up_in_file: [0.0, 1.0, 0.0],
            reason: "the scene's own axes".into(),
        }
    }
}

impl Orientation {
    /// The rotation taking the file's frame to the scene's: up to +Y, front to +Z.
    pub fn world_from_file(&self) -> DMat3 {
        let up = DVec3::from(self.up_in_file);
        let front = DVec3::from(self.front_in_file);
        // Rows of the rotation are the scene's axes expressed in the file's frame.
        let x = up.cross(front);
        DMat3::from_cols(x, up, front).transpose()
    }
}

/// Finds the orientation of the car made of the triangles `car` selects in `mesh`
/// (file frame), by the module's heuristic or with `front` given.
pub fn orient(mesh: &TriangleMesh, car: &[bool], front: Option<Front>) -> Orientation {
    let samples = surface_samples(mesh, car);
    let up = up_axis(&samples);
    // Horizontal coordinates (a, b) of the file frame for this up: (x, z) for +Y
    // up; for +Z up (y → −z after the turn) the same right-handed pair (x, −y).
    let horizontal = |p: DVec3| -> (f64, f64) {
        if up == DVec3::Y {
            (p.x, p.z)
        } else {
            (p.x, -p.y)
        }
    };
    let to_file = |a: f64, b: f64| -> DVec3 {
        if up == DVec3::Y {
            DVec3::new(a, 0.0, b)
        } else {
            DVec3::new(a, -b, 0.0)
        }
    };
    // Second moments of the surface, each triangle integrated exactly
    // (E[v vᵀ] over a triangle = (Σ vᵢvᵢᵀ + s sᵀ) / 12, s = Σ vᵢ), so a coarse
    // mesh's diagonal splits do not tilt the axes.
    let (mut total, mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (corners, area) in triangles_of(mesh, car) {
        let hv = corners.map(horizontal);
        let s = hv.iter().fold((0.0, 0.0), |s, v| (s.0 + v.0, s.1 + v.1));
        let m = |f: &dyn Fn((f64, f64)) -> f64, g: &dyn Fn((f64, f64)) -> f64| {
            (hv.iter().map(|v| f(*v) * g(*v)).sum::<f64>() + f(s) * g(s)) / 12.0
        };
        let (fa, fb) = (|v: (f64, f64)| v.0, |v: (f64, f64)| v.1);
        total += area;
        sa += area * s.0 / 3.0;
        sb += area * s.1 / 3.0;
        saa += area * m(&fa, &fa);
        sbb += area * m(&fb, &fb);
        sab += area * m(&fa, &fb);
    }
    let total = total.max(1e-300);
    let mean = (sa / total, sb / total);
    let caa = saa / total - mean.0 * mean.0;
    let cbb = sbb / total - mean.1 * mean.1;
    let cab = sab / total - mean.0 * mean.1;
    // Angle of the major axis from the a axis, and the two variances.
    let angle = 0.5 * (2.0 * cab).atan2(caa - cbb);
    let (mid, half_gap) = (
        0.5 * (caa + cbb),
        (0.25 * (caa - cbb).powi(2) + cab * cab).sqrt(),
    );
    let (major, minor) = (mid + half_gap, mid - half_gap);
    let car_shaped = {
        // Extents along the two principal axes.
        let (c, s) = (angle.cos(), angle.sin());
        let (mut u, mut v) = (
            (f64::INFINITY, f64::NEG_INFINITY),
            (f64::INFINITY, f64::NEG_INFINITY),
        );
        for (p, _) in &samples {
            let (a, b) = horizontal(*p);
            let (pu, pv) = (a * c + b * s, -a * s + b * c);
            u = (u.0.min(pu), u.1.max(pu));
            v = (v.0.min(pv), v.1.max(pv));
        }
        (v.1 - v.0) >= MIN_WIDTH_RATIO * (u.1 - u.0)
    };
    let elongated = major > MIN_ELONGATION * minor.max(0.0) && major > 0.0 && car_shaped;

    let (mut axis, axis_note) = if elongated {
        let snapped = snap(angle);
        let note = if snapped.1 {
            "the long axis is the file's axis".to_string()
        } else {
            format!(
                "the long axis, by the spread of the surface, is {:.1}° off the file's axes",
                angle.to_degrees()
            )
        };
        (to_file(snapped.0.cos(), snapped.0.sin()), note)
    } else {
        (
            to_file(0.0, 1.0),
            "no clear long axis (the surface spreads alike both ways); the file's axes kept"
                .to_string(),
        )
    };
    // The prior's direction: glTF's +Z, which for a Z-up file is its −Y.
    let prior = to_file(0.0, 1.0);
    if axis.dot(prior) < 0.0 || (axis.dot(prior).abs() < 1e-9 && axis.dot(to_file(1.0, 0.0)) < 0.0)
    {
        axis = -axis;
    }
    let up_note = if up == DVec3::Y {
        ""
    } else {
        "taller than long in +Y, so taken as exported Z-up; "
    };
    let (front_in_file, front_note) = match front {
        Some(named) => {
            let named_dir = if up == DVec3::Y {
                named.direction()
            } else {
                let d = named.direction();
                to_file(d.x, d.z)
            };
            let chosen = if axis.dot(named_dir) >= 0.0 {
                axis
            } else {
                -axis
            };
            (chosen, format!("front given as the file's {named}"))
        }
        None => {
            let (high_plus, high_minus) = end_heights(&samples, up, axis);
            let height = height_of(&samples, up);
            let step = (high_plus - high_minus) / height.max(1e-300);
            if step.abs() >= MIN_HEIGHT_STEP {
                let chosen = if step < 0.0 { axis } else { -axis };
                (
                    chosen,
                    format!(
                        "front is the lower end (its top {:.0} % of the height below the other's)",
                        100.0 * step.abs()
                    ),
                )
            } else {
                (
                    axis,
                    "the ends are alike in height; front toward the file's +Z (glTF's convention)"
                        .to_string(),
                )
            }
        }
    };
    Orientation {
        front_in_file: front_in_file.normalize().into(),
        up_in_file: up.into(),
        reason: format!("{up_note}{axis_note}; {front_note}"),
    }
}

/// Snaps an angle (radians) to a multiple of 90° within [`SNAP_DEG`]; whether it did.
fn snap(angle: f64) -> (f64, bool) {
    let quarter = std::f64::consts::FRAC_PI_2;
    let nearest = (angle / quarter).round() * quarter;
    if (angle - nearest).abs() <= SNAP_DEG.to_radians() {
        (nearest, true)
    } else {
        (angle, false)
    }
}

/// The car's triangles (file frame) with their areas; degenerate ones left out.
fn triangles_of<'a>(
    mesh: &'a TriangleMesh,
    car: &'a [bool],
) -> impl Iterator<Item = ([DVec3; 3], f64)> + 'a {
    mesh.triangles
        .iter()
        .enumerate()
        .filter(|(t, _)| car.get(*t).copied().unwrap_or(true))
        .filter_map(|(_, triangle)| {
            let corners = triangle.map(|v| DVec3::from(mesh.positions[v as usize].map(f64::from)));
            let [a, b, c] = corners;
            let area = 0.5 * (b - a).cross(c - a).length();
            (area.is_finite() && area > 0.0).then_some((corners, area))
        })
}

/// The car's vertices (each triangle's corners) with their triangle's area.
fn surface_samples(mesh: &TriangleMesh, car: &[bool]) -> Vec<(DVec3, f64)> {
    triangles_of(mesh, car)
        .flat_map(|(corners, area)| corners.map(|p| (p, area)))
        .collect()
}

/// +Y, unless the car is taller (in Y) than its extent along X and along Z: then +Z.
fn up_axis(samples: &[(DVec3, f64)]) -> DVec3 {
    let (lo, hi) = extent(samples);
    let size = hi - lo;
    if size.y > size.x && size.y > size.z {
        DVec3::Z
    } else {
        DVec3::Y
    }
}

fn extent(samples: &[(DVec3, f64)]) -> (DVec3, DVec3) {
    samples.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), (p, _)| (lo.min(*p), hi.max(*p)),
    )
}

fn height_of(samples: &[(DVec3, f64)], up: DVec3) -> f64 {
    let (lo, hi) = samples
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (p, _)| {
            let h = p.dot(up);
            (lo.min(h), hi.max(h))
        });
    hi - lo
}

/// The highest surface point over the last [`END_SLICE`] of the length at the
/// `axis` end and at the opposite end.
fn end_heights(samples: &[(DVec3, f64)], up: DVec3, axis: DVec3) -> (f64, f64) {
    let (lo, hi) = samples
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (p, _)| {
            let u = p.dot(axis);
            (lo.min(u), hi.max(u))
        });
    let slice = END_SLICE * (hi - lo);
    let (mut plus, mut minus) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for (p, _) in samples {
        let (u, h) = (p.dot(axis), p.dot(up));
        if u >= hi - slice {
            plus = plus.max(h);
        }
        if u <= lo + slice {
            minus = minus.max(h);
        }
    }
    (plus, minus)
}
