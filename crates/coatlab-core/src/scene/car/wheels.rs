//! Wheels: tyres with sidewalls and tread grooves, multi-spoke rims.

use std::f64::consts::{PI, TAU};

use super::mesh::{add_ring_surface, smoothstep, superellipse};
use super::{CarParameters, RIM, TRIM, TYRE};
use crate::scene::TriangleMesh;

/// Spokes of each rim.
pub(super) const SPOKES: usize = 10;
/// Depth and half-width (fraction of the tread's half-width) of the tyre's four
/// circumferential grooves.
const GROOVE_DEPTH_M: f64 = 0.004;
const GROOVE_HALF_WIDTH: f64 = 0.06;

pub(super) struct WheelShape {
    /// +1 for the right wheels (x > 0), −1 for the left.
    side: f64,
    centre: [f64; 3],
    radius: f64,
    rim_radius: f64,
    half_width: f64,
    segments: usize,
}

impl WheelShape {
    pub(super) fn new(p: &CarParameters, side: f64, axle_z: f64) -> Self {
        let radius = p.wheel_radius_m as f64;
        Self {
            side,
            centre: [side * p.wheel_centre_x(), radius, axle_z],
            radius,
            rim_radius: radius * p.rim_fraction as f64,
            half_width: 0.5 * p.tyre_width_m as f64,
            segments: p.wheel_segments as usize,
        }
    }

    /// World point at `axial` metres outward from the wheel's centre plane, `radial`
    /// metres from the axle, angle `theta` around it (0 at the ground contact).
    fn at(&self, axial: f64, radial: f64, theta: f64) -> [f64; 3] {
        let (s, c) = theta.sin_cos();
        [
            self.centre[0] + self.side * axial,
            self.centre[1] - radial * c,
            self.centre[2] + radial * s,
        ]
    }

    fn thetas(&self) -> Vec<f64> {
        (0..self.segments)
            .map(|k| TAU * k as f64 / self.segments as f64)
            .collect()
    }

    pub(super) fn add_tyre(&self, mesh: &mut TriangleMesh) {
        let section_height = 0.5 * (self.radius - self.rim_radius);
        let section_centre = self.radius - section_height;
        let around = 8 * (self.segments / 18).max(4);
        let thetas = self.thetas();
        let rings: Vec<Vec<[f64; 3]>> = thetas
            .iter()
            .map(|&theta| {
                (0..around)
                    .map(|k| {
                        let sigma = TAU * k as f64 / around as f64;
                        let (a, r) = superellipse(sigma, 3.5);
                        let groove = [-0.6, -0.25, 0.25, 0.6]
                            .iter()
                            .any(|g| (a - g).abs() < GROOVE_HALF_WIDTH && r > 0.9);
                        let depth = if groove { GROOVE_DEPTH_M } else { 0.0 };
                        self.at(
                            self.half_width * a,
                            section_centre + section_height * r - depth,
                            theta,
                        )
                    })
                    .collect()
            })
            .collect();
        add_ring_surface(mesh, &rings, None, true, |_, _| TYRE);
    }

    pub(super) fn add_rim(&self, mesh: &mut TriangleMesh) {
        let disc = self.rim_radius + 0.12 * (self.radius - self.rim_radius);
        let face = 0.55 * self.half_width;
        let back = -0.5 * self.half_width;
        let thetas = self.thetas();
        let spoke = |theta: f64| (0.5 + 0.5 * (SPOKES as f64 * theta).cos()).powf(0.7);
        let opening = |q: f64, theta: f64| {
            (1.0 - spoke(theta)) * smoothstep(0.28, 0.4, q) * (1.0 - smoothstep(0.8, 0.92, q))
        };
        let dish = |q: f64, theta: f64| {
            0.2 * self.half_width * q * q + 0.45 * self.half_width * opening(q, theta)
                - 0.15 * self.half_width * (1.0 - smoothstep(0.0, 0.22, q))
        };
        // Meridian: outer face from the hub out, the edge, the inner face back in.
        let face_rings = 24;
        let mut meridian: Vec<(f64, Option<f64>)> = Vec::new();
        for k in 1..=face_rings {
            meridian.push((k as f64 / face_rings as f64, None));
        }
        meridian.push((1.0, Some(0.5 * (face + back))));
        meridian.push((1.0, Some(back)));
        for k in (1..face_rings / 3).rev() {
            meridian.push((k as f64 / (face_rings / 3) as f64, Some(back)));
        }
        let rings: Vec<Vec<[f64; 3]>> = meridian
            .iter()
            .map(|&(q, axial)| {
                thetas
                    .iter()
                    .map(|&theta| {
                        let a = axial.unwrap_or_else(|| face - dish(q, theta));
                        self.at(a, q * disc, theta)
                    })
                    .collect()
            })
            .collect();
        let poles = (
            self.at(face - dish(0.0, 0.0), 0.0, 0.0),
            self.at(back, 0.0, 0.0),
        );
        let material = |i: isize, j: usize| {
            let i = (i + 1) as usize;
            match meridian.get(i) {
                Some(&(q, None))
                    if opening(
                        q - 0.5 / face_rings as f64,
                        thetas[j] + PI / self.segments as f64,
                    ) > 0.5 =>
                {
                    TRIM
                }
                _ => RIM,
            }
        };
        add_ring_surface(mesh, &rings, Some(poles), false, material);
    }
}
