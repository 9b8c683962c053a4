//! The smaller parts: door handles, mirrors, and the interior seen through the glass
//! (floor, dashboard, console, steering wheel, seats), each a closed superellipsoid
//! or torus placed from the body's layout.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use super::body::BodyShape;
use super::mesh::{add_ring_surface, add_superellipsoid};
use super::{CarParameters, DOOR_HANDLE, INTERIOR, MIRROR_GLASS, MIRROR_HOUSING, SEAT};
use crate::scene::TriangleMesh;

/// Resolution of the small closed parts: latitude rings and segments around.
const PART_RESOLUTION: (usize, usize) = (18, 40);
/// Squareness of upholstered and moulded parts (larger is boxier).
const BOXY: (f64, f64) = (5.0, 5.0);

/// Adds the handles, mirrors and interior of the car whose body is `body`.
pub(super) fn add_parts(mesh: &mut TriangleMesh, p: &CarParameters, body: &BodyShape) {
    let layout = body.layout();
    for side in [1.0, -1.0] {
        for d in [layout.b_pillar - 0.2, layout.rear_door - 0.2] {
            add_door_handle(mesh, body, d, side);
        }
        add_mirror(mesh, body, layout.cowl + 0.17, side);
    }
    add_interior(mesh, p, body);
}

/// The point and frame of the body at `d`, flank fraction `f`, on `side` (+1 right):
/// (point, outward normal, unit tangent toward the tail, unit up along the surface).
fn flank_frame(body: &BodyShape, d: f64, f: f64, side: f64) -> (DVec3, DVec3, DVec3, DVec3) {
    let psi = body.flank_angle(d, f);
    let psi = if side > 0.0 { psi } else { PI - psi };
    let (point, normal) = body.surface_frame(d, psi);
    let back = (DVec3::NEG_Z - normal * normal.z).normalize();
    (point, normal, back, normal.cross(back) * -side)
}

/// A pull handle set into the door just below the window line.
fn add_door_handle(mesh: &mut TriangleMesh, body: &BodyShape, d: f64, side: f64) {
    let (point, normal, back, up) = flank_frame(body, d, 0.8, side);
    add_superellipsoid(
        mesh,
        point + normal * 0.003,
        [back * 0.085, up * 0.016, normal * 0.013],
        (2.6, 3.0),
        PART_RESOLUTION,
        DOOR_HANDLE,
    );
}

/// A door mirror on a short arm at the front of the side window: a black housing
/// with its glass facing back.
fn add_mirror(mesh: &mut TriangleMesh, body: &BodyShape, d: f64, side: f64) {
    let (point, _, _, _) = flank_frame(body, d, 1.0, side);
    let out = DVec3::X * side;
    let arm = point + out * 0.035 + DVec3::Y * 0.025;
    let housing = point + out * 0.14 + DVec3::Y * 0.075;
    // (centre, semi-axes, exponents, material) of the arm, the housing and the glass.
    let pieces = [
        (
            arm,
            [out * 0.06, DVec3::Y * 0.018, DVec3::Z * 0.04],
            (3.0, 3.0),
            MIRROR_HOUSING,
        ),
        (
            housing,
            [out * 0.1, DVec3::Y * 0.062, DVec3::Z * 0.05],
            (3.0, 2.6),
            MIRROR_HOUSING,
        ),
        (
            housing - DVec3::Z * 0.047 + out * 0.004,
            [out * 0.088, DVec3::Y * 0.05, DVec3::Z * 0.006],
            (4.0, 4.0),
            MIRROR_GLASS,
        ),
    ];
    for (centre, axes, exponents, material) in pieces {
        add_superellipsoid(mesh, centre, axes, exponents, PART_RESOLUTION, material);
    }
}

/// Floor, dashboard, console, steering wheel and four seats, inside the shell.
fn add_interior(mesh: &mut TriangleMesh, p: &CarParameters, body: &BodyShape) {
    let l = body.layout();
    let half_length = 0.5 * l.length;
    let at = |d: f64, x: f64, y: f64| DVec3::new(x, y, half_length - d);
    let half_width = 0.5 * p.width_m as f64;
    let arch = p.arch_radius_m();
    let (front_axle, rear_axle) = (
        p.front_overhang_m as f64,
        (p.front_overhang_m + p.wheelbase_m) as f64,
    );
    let belt = body.belt(l.cowl);

    // Floor between the wheel arches.
    let (floor_from, floor_to) = (front_axle + arch + 0.03, rear_axle - arch - 0.03);
    add_superellipsoid(
        mesh,
        at(0.5 * (floor_from + floor_to), 0.0, 0.36),
        [
            DVec3::X * 0.76 * half_width,
            DVec3::Y * 0.06,
            DVec3::Z * 0.5 * (floor_to - floor_from),
        ],
        BOXY,
        PART_RESOLUTION,
        INTERIOR,
    );
    // Dashboard under the windscreen, and the centre console.
    add_superellipsoid(
        mesh,
        at(l.cowl + 0.34, 0.0, belt - 0.07),
        [
            DVec3::X * 0.72 * half_width,
            DVec3::Y * 0.085,
            DVec3::Z * 0.18,
        ],
        (3.0, 4.0),
        PART_RESOLUTION,
        INTERIOR,
    );
    add_superellipsoid(
        mesh,
        at(0.5 * (l.cowl + 0.45 + l.b_pillar - 0.1), 0.0, 0.52),
        [
            DVec3::X * 0.09,
            DVec3::Y * 0.14,
            DVec3::Z * 0.5 * (l.b_pillar - 0.1 - l.cowl - 0.45),
        ],
        BOXY,
        PART_RESOLUTION,
        INTERIOR,
    );
    // Steering wheel in front of the left seat (the car's left is +x), its plane
    // tilted back 25° from vertical.
    let tilt = 25f64.to_radians();
    let axis = DVec3::new(0.0, tilt.sin(), -tilt.cos());
    add_torus(
        mesh,
        at(l.cowl + 0.62, 0.37, belt + 0.02),
        axis,
        (0.185, 0.016),
        INTERIOR,
    );

    // Seats: the front pair and the rear bench, each cushion, backrest, headrests.
    let front = Seat {
        d: l.b_pillar - 0.25,
        cushion_y: 0.5,
        half_width: 0.25,
        recline_deg: 20.0,
    };
    for x in [0.37, -0.37] {
        front.add(mesh, &at, x, &[0.0]);
    }
    let rear = Seat {
        d: l.roof_rear - 0.45,
        cushion_y: 0.52,
        half_width: 0.6,
        recline_deg: 26.0,
    };
    rear.add(mesh, &at, 0.0, &[0.36, -0.36]);
}

/// A seat: cushion at `d` (its centre), backrest behind, headrests on top.
struct Seat {
    d: f64,
    cushion_y: f64,
    half_width: f64,
    recline_deg: f64,
}

impl Seat {
    fn add(
        &self,
        mesh: &mut TriangleMesh,
        at: &dyn Fn(f64, f64, f64) -> DVec3,
        x: f64,
        headrests: &[f64],
    ) {
        let cushion = at(self.d, x, self.cushion_y);
        add_superellipsoid(
            mesh,
            cushion,
            [
                DVec3::X * self.half_width,
                DVec3::Y * 0.065,
                DVec3::Z * 0.25,
            ],
            BOXY,
            PART_RESOLUTION,
            SEAT,
        );
        let recline = self.recline_deg.to_radians();
        let up = DVec3::new(0.0, recline.cos(), -recline.sin());
        let back = DVec3::new(0.0, recline.sin(), recline.cos()) * -1.0;
        let backrest = cushion + DVec3::NEG_Z * 0.25 + up * 0.3 + back * 0.02;
        add_superellipsoid(
            mesh,
            backrest,
            [DVec3::X * (self.half_width - 0.01), up * 0.3, back * 0.07],
            BOXY,
            PART_RESOLUTION,
            SEAT,
        );
        for &dx in headrests {
            add_superellipsoid(
                mesh,
                backrest + up * 0.38 + DVec3::X * dx,
                [DVec3::X * 0.13, up * 0.085, back * 0.055],
                (3.0, 3.0),
                PART_RESOLUTION,
                SEAT,
            );
        }
    }
}

/// A torus around `axis` through `centre`: (major, minor) radii.
fn add_torus(
    mesh: &mut TriangleMesh,
    centre: DVec3,
    axis: DVec3,
    (major, minor): (f64, f64),
    material: u32,
) {
    let axis = axis.normalize();
    let u = axis.any_orthonormal_vector();
    let v = axis.cross(u);
    let (segments, around) = (64, 16);
    let rings: Vec<Vec<[f64; 3]>> = (0..segments)
        .map(|k| {
            let phi = TAU * k as f64 / segments as f64;
            let radial = u * phi.cos() + v * phi.sin();
            (0..around)
                .map(|s| {
                    let sigma = TAU * s as f64 / around as f64;
                    (centre + radial * (major + minor * sigma.cos()) + axis * (minor * sigma.sin()))
                        .to_array()
                })
                .collect()
        })
        .collect();
    add_ring_surface(mesh, &rings, None, true, |_, _| material);
}
