//! The emitters of a lighting set-up (softboxes, the booth's diffuser, the sun):
//! regions of the sphere at infinity with constant radiance, sampled uniformly in
//! solid angle, exactly.

use std::f64::consts::PI;

use glam::DVec3;

use super::direction::{Query, direction_from_azimuth_y};

/// A region of the sphere with constant radiance.
#[derive(Debug, Clone)]
pub(super) enum Shape {
    /// Azimuth in [a₀, a₁] (radians, from +Z toward +X, within [−π, π]) and
    /// y = sin(elevation) in [y₀, y₁]: uniform in (azimuth, y) is uniform in solid
    /// angle, so sampling is exact. A full azimuth range makes a cap about +Y.
    LatLong { azimuth: [f64; 2], y: [f64; 2] },
    /// A cone of directions about `axis`; `one_minus_cos` = 1 − cos(half-angle)
    /// (kept apart for precision with the sun's tiny disc).
    Cap {
        axis: DVec3,
        tangent: DVec3,
        bitangent: DVec3,
        one_minus_cos: f64,
    },
}

impl Shape {
    /// The cone of half-angle `half_angle` (radians) about the unit `axis`.
    pub(super) fn cap(axis: DVec3, half_angle: f64) -> Self {
        let helper = if axis.y.abs() < 0.9 {
            DVec3::Y
        } else {
            DVec3::X
        };
        let across = helper.cross(axis);
        // Divided by the length rather than glam's `normalize` (a product with
        // the reciprocal): the sun's frame, and its samples, stay bit for bit.
        let tangent = across / across.length();
        let bitangent = axis.cross(tangent);
        Shape::Cap {
            axis,
            tangent,
            bitangent,
            one_minus_cos: 2.0 * (0.5 * half_angle).sin().powi(2),
        }
    }

    pub(super) fn solid_angle(&self) -> f64 {
        match self {
            Shape::LatLong { azimuth, y } => (azimuth[1] - azimuth[0]) * (y[1] - y[0]),
            Shape::Cap { one_minus_cos, .. } => 2.0 * PI * one_minus_cos,
        }
    }

    /// ∫ max(y, 0) dω over the region: horizontal irradiance per unit radiance
    /// (exact for a lat-long rectangle, which is cut at the horizon, and for a cap
    /// [`Self::above_horizon`]).
    pub(super) fn cosine_integral(&self) -> f64 {
        match self {
            Shape::LatLong { azimuth, y } => lat_long_cosine_integral(azimuth[1] - azimuth[0], *y),
            Shape::Cap {
                axis,
                one_minus_cos,
                ..
            } => {
                // π sin²α times the axis's cosine.
                let sin2 = one_minus_cos * (2.0 - one_minus_cos);
                PI * sin2 * axis.y.max(0.0)
            }
        }
    }

    /// Whether the region lies wholly on or above the horizon, where
    /// [`Self::cosine_integral`] is exact.
    pub(super) fn above_horizon(&self) -> bool {
        match self {
            Shape::LatLong { .. } => true,
            Shape::Cap {
                axis,
                one_minus_cos,
                ..
            } => axis.y >= (one_minus_cos * (2.0 - one_minus_cos)).sqrt(),
        }
    }

    #[inline]
    pub(super) fn contains(&self, q: &mut Query) -> bool {
        match self {
            Shape::LatLong { azimuth, y } => {
                (y[0]..=y[1]).contains(&q.d.y) && q.azimuth_within(azimuth[0], azimuth[1])
            }
            Shape::Cap {
                axis,
                one_minus_cos,
                ..
            } => 1.0 - q.d.dot(*axis) <= *one_minus_cos,
        }
    }

    /// The direction of the two uniform numbers `u`, uniform in solid angle over
    /// the region.
    #[inline]
    pub(super) fn sample(&self, u: [f64; 2]) -> DVec3 {
        match self {
            Shape::LatLong { azimuth, y } => {
                let a = azimuth[0] + u[0] * (azimuth[1] - azimuth[0]);
                let y = y[0] + u[1] * (y[1] - y[0]);
                direction_from_azimuth_y(a, y)
            }
            Shape::Cap {
                axis,
                tangent,
                bitangent,
                one_minus_cos,
            } => {
                let one_minus = u[0] * one_minus_cos;
                let cos_t = 1.0 - one_minus;
                let sin_t = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
                let phi = 2.0 * PI * u[1];
                let (s, c) = phi.sin_cos();
                sin_t * (c * *tangent + s * *bitangent) + cos_t * *axis
            }
        }
    }
}

/// ∫ max(y, 0) dω over `azimuth_width` radians of azimuth and y = sin(elevation)
/// in `y`: dω = dφ dy, so Δφ (y₁² − y₀²)/2 with both cut at the horizon. A
/// lat-long emitter's, and a map texel's (its row's y bounds, 2π/width wide).
pub(super) fn lat_long_cosine_integral(azimuth_width: f64, y: [f64; 2]) -> f64 {
    let (y0, y1) = (y[0].max(0.0), y[1].max(0.0));
    azimuth_width * 0.5 * (y1 * y1 - y0 * y0)
}

/// An emitter: a region with its radiance.
#[derive(Debug, Clone)]
pub(super) struct Patch {
    pub(super) shape: Shape,
    pub(super) solid_angle: f64,
    pub(super) radiance: Vec<f32>,
}
