//! Directions on the sphere in the environment's conventions (see the module
//! documentation of [`super`]): y up, azimuth φ = atan2(x, z) from +Z toward +X,
//! an equirectangular column u = 0.5 − φ/2π; and a direction being looked up.

use std::f64::consts::PI;

use glam::DVec3;

use super::fast_math::{atan2_approx, sin_cos_fast};

/// How far from an azimuth bound (and from ±π) the polynomial arctangent's
/// answer must lie to decide which side of it a direction is on: 50 times its
/// error bound, 2e-8 rad.
const GUESS_SLACK: f64 = 1e-6;

/// A unit direction being looked up, with its azimuth computed at most once (an
/// `atan2`, shared by the map's column and every emitter's azimuth test), and so
/// its polynomial guess.
#[derive(Debug, Clone, Copy)]
pub(super) struct Query {
    pub(super) d: DVec3,
    pub(super) azimuth: Option<f64>,
    /// [`atan2_approx`] of the direction, once asked for.
    guess: Option<Option<f64>>,
}

impl Query {
    pub(super) fn new(d: DVec3) -> Self {
        Self {
            d,
            azimuth: None,
            guess: None,
        }
    }

    /// The polynomial arctangent's φ (within 2e-8 rad; `None` at the poles).
    #[inline]
    pub(super) fn azimuth_guess(&mut self) -> Option<f64> {
        *self
            .guess
            .get_or_insert_with(|| atan2_approx(self.d.x, self.d.z))
    }

    /// φ = atan2(x, z), in [−π, π].
    pub(super) fn azimuth(&mut self) -> f64 {
        *self.azimuth.get_or_insert_with(|| self.d.x.atan2(self.d.z))
    }

    /// Whether φ lies in [`low`, `high`], exactly as the exact φ answers: from
    /// the polynomial arctangent (error below 2e-8 rad) where that lies more
    /// than [`GUESS_SLACK`] from both bounds and from ±π (near which it may
    /// answer the other end of the range), else from [`Self::azimuth`]. An
    /// emitter's test then costs an `atan2` only for the few directions that
    /// graze its edge.
    #[inline]
    pub(super) fn azimuth_within(&mut self, low: f64, high: f64) -> bool {
        if let Some(azimuth) = self.azimuth {
            return (low..=high).contains(&azimuth);
        }
        if let Some(guess) = self.azimuth_guess()
            && (guess - low).abs() > GUESS_SLACK
            && (guess - high).abs() > GUESS_SLACK
            && guess.abs() < PI - GUESS_SLACK
        {
            return (low..=high).contains(&guess);
        }
        let azimuth = self.azimuth();
        (low..=high).contains(&azimuth)
    }
}

/// `d` in f64 and divided by its length, or `None` for a zero, infinite or NaN
/// vector. A division, not glam's `normalize` (a multiplication by the
/// reciprocal), which rounds differently: the look-ups, and so the renders, stay
/// bit for bit those of the division.
#[inline]
pub(super) fn normalised(d: [f32; 3]) -> Option<DVec3> {
    let d = DVec3::from_array(d.map(f64::from));
    let len = d.length();
    (len > 0.0 && len.is_finite()).then(|| d / len)
}

/// The azimuth of an equirectangular map's column coordinate (`column` in
/// [0, width], fractional within a column).
#[inline]
pub(super) fn azimuth_of_column(column: f64, width: usize) -> f64 {
    (0.5 - column / width as f64) * 2.0 * PI
}

/// The unit direction of azimuth `azimuth` and height `y` = cos θ = sin(elevation).
#[inline]
pub(super) fn direction_from_azimuth_y(azimuth: f64, y: f64) -> DVec3 {
    let y = y.clamp(-1.0, 1.0);
    let r = (1.0 - y * y).max(0.0).sqrt();
    let (s, c) = azimuth.sin_cos();
    DVec3::new(r * s, y, r * c)
}

/// [`direction_from_azimuth_y`] and its rounding to f32, that rounding always
/// the exact one's: the sine and cosine by [`sin_cos_fast`] (no libm call),
/// within [`SIN_COS_MARGIN`] of libm's after the product with r, taken where
/// every number within that margin rounds to the same f32; else (about one
/// coordinate in 10⁷, and more where x or z is tiny) libm's `sin_cos`. The f64
/// direction returned is then off the exact one's by at most the margin.
#[inline]
pub(super) fn direction_from_azimuth_y_f32(azimuth: f64, y: f64) -> (DVec3, [f32; 3]) {
    let y = y.clamp(-1.0, 1.0);
    let r = (1.0 - y * y).max(0.0).sqrt();
    let (s, c) = sin_cos_fast(azimuth);
    let (x, z) = (r * s, r * c);
    let rounds_alike = |v: f64| (v - SIN_COS_MARGIN) as f32 == (v + SIN_COS_MARGIN) as f32;
    if rounds_alike(x) && rounds_alike(z) {
        (DVec3::new(x, y, z), [x as f32, y as f32, z as f32])
    } else {
        let d = direction_from_azimuth_y(azimuth, y);
        (d, d.as_vec3().to_array())
    }
}

/// A bound on |r·s − r·s_libm| (and for c) in [`direction_from_azimuth_y_f32`],
/// with a factor 4 to spare: [`sin_cos_fast`] is within 1e-15 of libm's (the
/// test's largest difference over 10⁶ azimuths and the quadrant edges is one
/// ulp, 2.2e-16), and each product adds half an ulp (1.1e-16).
pub(super) const SIN_COS_MARGIN: f64 = 4e-15;

/// The unit direction of azimuth `azimuth` and elevation `elevation` (radians).
pub(super) fn direction_from_azimuth_elevation(azimuth: f64, elevation: f64) -> DVec3 {
    direction_from_azimuth_y(azimuth, elevation.sin())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::test_support::uniform;

    /// An azimuth range answers for every direction as the exact azimuth does:
    /// random directions, and directions within 1e-12 to 1e-5 rad of each
    /// bound and of ±π, for ranges inside (−π, π), reaching either end, and
    /// past it.
    #[test]
    fn azimuth_ranges_answer_as_the_exact_azimuth_does() {
        let ranges = [
            [-0.4, 0.9],
            [1.0, 2.5],
            [-PI, -2.0],
            [2.0, PI],
            [3.0, 3.5],
            [-3.5, -3.0],
            [-PI, PI],
        ];
        let mut state = 29;
        let mut azimuths: Vec<f64> = (0..200_000)
            .map(|_| (2.0 * uniform(&mut state) - 1.0) * PI)
            .collect();
        for bound in ranges.iter().flatten().chain(&[PI, -PI, 0.0]) {
            for offset in [1e-12, 1e-10, 1e-8, 3e-8, 1e-7, 1e-6, 2e-6, 1e-5] {
                azimuths.extend([bound - offset, *bound, bound + offset]);
            }
        }
        let mut checked = 0;
        for &a in &azimuths {
            let y = 2.0 * uniform(&mut state) - 1.0;
            let d = direction_from_azimuth_y(a, y);
            for [low, high] in ranges {
                let exact = (low..=high).contains(&d.x.atan2(d.z));
                assert_eq!(
                    Query::new(d).azimuth_within(low, high),
                    exact,
                    "azimuth {a} in [{low}, {high}]"
                );
                checked += 1;
            }
        }
        assert!(checked > 1_000_000);
    }

    /// Directions built with the fast sine and cosine round to the f32 numbers
    /// of the libm ones, bit for bit: random (azimuth, y), quadrant edges, the
    /// poles, and small x or z (where the guard falls back to libm).
    #[test]
    fn fast_directions_round_as_the_libm_ones_do() {
        let mut state = 23;
        let check = |a: f64, y: f64| {
            let (d, dir) = direction_from_azimuth_y_f32(a, y);
            let want = direction_from_azimuth_y(a, y).as_vec3().to_array();
            assert_eq!(
                dir.map(f32::to_bits),
                want.map(f32::to_bits),
                "azimuth {a} y {y}"
            );
            assert_eq!(
                d.as_vec3().to_array().map(f32::to_bits),
                want.map(f32::to_bits)
            );
        };
        for _ in 0..2_000_000 {
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            let y = 2.0 * uniform(&mut state) - 1.0;
            check(a, y);
        }
        for k in -4..=4 {
            for e in [0.0, 1e-300, 1e-15, 1e-10, 1e-7, 1e-4] {
                for y in [0.0, 0.5, -0.99, 1.0, -1.0, 1.0 - 1e-12] {
                    check(f64::from(k) * PI / 4.0 + e, y);
                    check(f64::from(k) * PI / 4.0 - e, y);
                }
            }
        }
    }

    #[test]
    fn normalised_refuses_zero_and_non_finite_vectors() {
        assert!(normalised([0.0; 3]).is_none());
        assert!(normalised([f32::NAN, 0.0, 1.0]).is_none());
        assert!(normalised([f32::INFINITY, 0.0, 1.0]).is_none());
        let d = normalised([3.0, 0.0, 4.0]).unwrap();
        assert_eq!(d, DVec3::new(0.6, 0.0, 0.8));
    }
}
