//! # The default car body: a parametric generator
//!
//! The preview shows this car when no scene is given. It is generated here, from a
//! small table of parameters, and written to `assets/default-car.glb` by
//! `cargo run -p coatlab-core --example make_default_car`; a test checks that the
//! committed file is byte for byte what [`generate`] and [`to_glb`] produce today.
//!
//! Frame: metres, Y up, the car's length along Z with the nose toward +Z, centred at
//! x = z = 0, the tyres touching the ground plane y = 0.
//!
//! ## Parameters ([`CarParameters`], table in [`PARAMETERS`])
//!
//! | name | unit | range | default | meaning |
//! |---|---|---|---|---|
//! | `length_m` | m | 3.5 – 5.5 | 4.50 | overall length, nose to tail |
//! | `width_m` | m | 1.5 – 2.1 | 1.80 | overall body width (no mirrors) |
//! | `height_m` | m | 1.1 – 1.8 | 1.40 | roof top above the ground |
//! | `wheelbase_m` | m | 2.0 – 3.4 | 2.70 | front to rear axle |
//! | `front_overhang_m` | m | 0.5 – 1.3 | 0.90 | nose to front axle |
//! | `wheel_radius_m` | m | 0.26 – 0.42 | 0.33 | tyre outer radius |
//! | `tyre_width_m` | m | 0.15 – 0.32 | 0.22 | tyre tread width |
//! | `rim_fraction` | 1 | 0.5 – 0.8 | 0.66 | rim radius / tyre radius |
//! | `ground_clearance_m` | m | 0.08 – 0.30 | 0.16 | sill height between the wheels |
//! | `nose_height_m` | m | 0.5 – 1.0 | 0.70 | bonnet leading edge above the ground |
//! | `bonnet_height_m` | m | 0.7 – 1.2 | 0.93 | bonnet at the windscreen base (cowl) |
//! | `bonnet_length_m` | m | 0.7 – 1.8 | 1.25 | nose to cowl, along Z |
//! | `windscreen_length_m` | m | 0.4 – 1.2 | 0.80 | cowl to roof front, along Z (rake) |
//! | `roof_length_m` | m | 0.5 – 2.0 | 1.10 | roof front to rear-window top |
//! | `rear_window_length_m` | m | 0.2 – 1.2 | 0.72 | rear-window top to boot deck |
//! | `boot_height_m` | m | 0.7 – 1.3 | 1.00 | boot deck at the rear-window base |
//! | `tail_height_m` | m | 0.6 – 1.2 | 0.93 | top of the tail, before it rounds off |
//! | `belt_rise_m` | m | 0 – 0.2 | 0.06 | rise of the window line from cowl to deck |
//! | `greenhouse_width_fraction` | 1 | 0.6 – 0.95 | 0.80 | cabin width at the roof / body width (tumblehome) |
//! | `section_squareness` | 1 | 2.5 – 6 | 4.0 | superellipse exponent of the cross-sections |
//! | `roof_crown` | 1 | 0 – 0.3 | 0.08 | transverse crown of bonnet, roof and boot |
//! | `flank_bulge` | 1 | 0 – 0.1 | 0.03 | outward bow of the flanks (curvature in the sides) |
//! | `rings` | count | 64 – 2000 | 320 | body cross-sections along the length |
//! | `section_vertices` | count | 48 – 1024 | 144 | vertices around each cross-section (rounded to a multiple of 16) |
//! | `wheel_segments` | count | 16 – 512 | 72 | segments around each wheel (rounded to even) |
//!
//! Out-of-range values are clamped, and so are inconsistent combinations (axles or the
//! cabin longer than the car, a bonnet above the roof); each adjustment is reported in
//! [`Scene::warnings`].
//!
//! ## Construction
//!
//! - **Body**: one closed surface swept along Z. Each cross-section is a superellipse
//!   (polar parametrisation, exponent `section_squareness`) split at the waist line
//!   into an upper and a lower half with their own heights. The top line (nose,
//!   bonnet, raked windscreen, roof, rear window, boot deck, tail), the bottom line,
//!   the waist and the half-width are monotone cubic (PCHIP) profiles through control
//!   points derived from the parameters; nose and tail close with superelliptic end
//!   caps onto a single pole vertex each. Above the window line the section narrows
//!   toward `greenhouse_width_fraction` (the cabin and its tumblehome); a parabolic
//!   crown and a bow of the flanks keep the curvature non-zero everywhere, so there
//!   are no flat panels.
//! - **Wheel arches**: around each wheel the body is scaled toward the centre plane
//!   (x → x·(1 − k·w(ρ)), ρ the distance from the wheel centre in the side view)
//!   into a well whose floor lies inside the tyre. The well floor is `trim` (black).
//! - **Glass**: windscreen, side windows (split by a B-pillar) and rear window are
//!   material regions of the same surface; the rows of the section grid follow the
//!   window line and the roof rail, so the glass edges are smooth curves, not steps.
//! - **Wheels**: four tyres (tori with a superelliptic section, touching y = 0) and
//!   rims (closed discs with a dished, five-spoke outer face; the openings are
//!   `trim`).
//! - **Normals**: area-weighted averages of the face normals of each part, outward
//!   (every part is a closed surface; its orientation is checked by its signed volume).
//!
//! ## Creases
//!
//! The body is smooth (adjacent vertex normals within a few degrees) except along the
//! lip and the floor edge of each wheel arch, where the well wall turns the surface
//! through nearly 90° over a few centimetres: the band [`ARCH_LIP_WIDTH_M`] wide
//! inside the arch radius [`CarParameters::arch_radius_m`]. Wheels have deliberate
//! creases at the rim edge and the spokes.
//!
//! ## Materials
//!
//! [`BODY`] (the paint, the only entry of `paint_materials`), [`GLASS`], [`TYRE`],
//! [`RIM`], [`TRIM`], in that order.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::DVec3;
use palette::LinSrgb;

use super::{Scene, SceneMaterial, TriangleMesh};
use crate::parameter::{Bounds, Parameter};
use crate::units::Unit;

/// Material index of the painted body.
pub const BODY: u32 = 0;
/// Material index of the windows.
pub const GLASS: u32 = 1;
/// Material index of the tyres.
pub const TYRE: u32 = 2;
/// Material index of the rims.
pub const RIM: u32 = 3;
/// Material index of black plastic: wheel-well liners, rim openings.
pub const TRIM: u32 = 4;

/// Width of the arch lip (the well wall), metres: the crease band of the body.
pub const ARCH_LIP_WIDTH_M: f64 = 0.05;
/// Clearance between the tyre tread and the arch radius, metres.
const ARCH_CLEARANCE_M: f64 = 0.07;
/// Gap between the tyre's outer face and the body's half-width, metres.
const TYRE_INSET_M: f64 = 0.025;
/// Clearance between the tyre's inner face and the well floor, metres.
const WELL_CLEARANCE_M: f64 = 0.03;

/// A field that can be clamped into its documented range.
trait Clampable: Copy {
    fn clamp_into(self, min: f64, max: f64, default: f64) -> Self;
    fn as_f64(self) -> f64;
}

impl Clampable for f32 {
    fn clamp_into(self, min: f64, max: f64, default: f64) -> Self {
        if self.is_finite() {
            (self as f64).clamp(min, max) as f32
        } else {
            default as f32
        }
    }
    fn as_f64(self) -> f64 {
        self as f64
    }
}

impl Clampable for u32 {
    fn clamp_into(self, min: f64, max: f64, _default: f64) -> Self {
        (self as f64).clamp(min, max) as u32
    }
    fn as_f64(self) -> f64 {
        self as f64
    }
}

fn clamp_field<T: Clampable>(value: &mut T, spec: &Parameter, warnings: &mut Vec<String>) {
    let clamped = value.clamp_into(spec.range.min, spec.range.max, spec.default);
    if clamped.as_f64() != value.as_f64() {
        warnings.push(format!(
            "car parameter {} = {} is outside {}; using {}",
            spec.name,
            value.as_f64(),
            spec.range_text(),
            clamped.as_f64()
        ));
        *value = clamped;
    }
}

macro_rules! car_parameters {
    ($( $(#[$doc:meta])* $field:ident : $ty:ty = $default:expr, $unit:expr, [$min:expr, $max:expr]; )*) => {
        /// Parameters of the default car; see the table in the [module docs](self).
        #[derive(Debug, Clone, PartialEq)]
        pub struct CarParameters {
            $( $(#[$doc])* pub $field: $ty, )*
        }

        impl Default for CarParameters {
            fn default() -> Self {
                Self { $( $field: $default, )* }
            }
        }

        /// The parameter table: one row per field of [`CarParameters`], in order.
        pub const PARAMETERS: &[Parameter] = &[
            $( Parameter {
                name: stringify!($field),
                symbol: "",
                unit: $unit,
                range: Bounds::new($min as f64, $max as f64),
                control: None,
                default: $default as f64,
            }, )*
        ];

        impl CarParameters {
            /// Clamps each field into its range, reporting each change.
            fn clamp_ranges(&mut self, warnings: &mut Vec<String>) {
                let mut specs = PARAMETERS.iter();
                $( if let Some(spec) = specs.next() {
                    clamp_field(&mut self.$field, spec, warnings);
                } )*
            }
        }
    };
}

car_parameters! {
    /// Overall length, nose to tail, m.
    length_m: f32 = 4.5, Unit::Metre, [3.5, 5.5];
    /// Overall body width (no mirrors), m.
    width_m: f32 = 1.8, Unit::Metre, [1.5, 2.1];
    /// Roof top above the ground, m.
    height_m: f32 = 1.4, Unit::Metre, [1.1, 1.8];
    /// Front to rear axle, m.
    wheelbase_m: f32 = 2.7, Unit::Metre, [2.0, 3.4];
    /// Nose to front axle, m.
    front_overhang_m: f32 = 0.9, Unit::Metre, [0.5, 1.3];
    /// Tyre outer radius, m.
    wheel_radius_m: f32 = 0.33, Unit::Metre, [0.26, 0.42];
    /// Tyre tread width, m.
    tyre_width_m: f32 = 0.22, Unit::Metre, [0.15, 0.32];
    /// Rim radius over tyre radius.
    rim_fraction: f32 = 0.66, Unit::Dimensionless, [0.5, 0.8];
    /// Sill height between the wheels, m.
    ground_clearance_m: f32 = 0.16, Unit::Metre, [0.08, 0.3];
    /// Bonnet leading edge above the ground, m.
    nose_height_m: f32 = 0.70, Unit::Metre, [0.5, 1.0];
    /// Bonnet height at the windscreen base (cowl), m.
    bonnet_height_m: f32 = 0.93, Unit::Metre, [0.7, 1.2];
    /// Nose to cowl along Z, m.
    bonnet_length_m: f32 = 1.25, Unit::Metre, [0.7, 1.8];
    /// Cowl to roof front along Z, m (the windscreen rake).
    windscreen_length_m: f32 = 0.8, Unit::Metre, [0.4, 1.2];
    /// Roof front to rear-window top along Z, m.
    roof_length_m: f32 = 1.1, Unit::Metre, [0.5, 2.0];
    /// Rear-window top to boot deck along Z, m.
    rear_window_length_m: f32 = 0.72, Unit::Metre, [0.2, 1.2];
    /// Boot deck height at the rear-window base, m.
    boot_height_m: f32 = 1.0, Unit::Metre, [0.7, 1.3];
    /// Top of the tail before it rounds off, m.
    tail_height_m: f32 = 0.93, Unit::Metre, [0.6, 1.2];
    /// Rise of the window line from cowl to deck, m.
    belt_rise_m: f32 = 0.06, Unit::Metre, [0.0, 0.2];
    /// Cabin width at the roof over body width (tumblehome).
    greenhouse_width_fraction: f32 = 0.8, Unit::Dimensionless, [0.6, 0.95];
    /// Superellipse exponent of the cross-sections (2 = ellipse, larger = squarer).
    section_squareness: f32 = 4.0, Unit::Dimensionless, [2.5, 6.0];
    /// Transverse crown of bonnet, roof and boot (fraction of the section height).
    roof_crown: f32 = 0.08, Unit::Dimensionless, [0.0, 0.3];
    /// Outward bow of the flanks (fraction of the half-width).
    flank_bulge: f32 = 0.03, Unit::Dimensionless, [0.0, 0.1];
    /// Body cross-sections along the length.
    rings: u32 = 320, Unit::Count, [64, 2000];
    /// Vertices around each body cross-section (rounded to a multiple of 16).
    section_vertices: u32 = 144, Unit::Count, [48, 1024];
    /// Segments around each wheel (rounded to even).
    wheel_segments: u32 = 72, Unit::Count, [16, 512];
}

impl CarParameters {
    /// Z of the front axle, m.
    pub fn front_axle_z(&self) -> f64 {
        0.5 * self.length_m as f64 - self.front_overhang_m as f64
    }

    /// Z of the rear axle, m.
    pub fn rear_axle_z(&self) -> f64 {
        self.front_axle_z() - self.wheelbase_m as f64
    }

    /// |x| of the wheel centres (half the track), m.
    pub fn wheel_centre_x(&self) -> f64 {
        0.5 * self.width_m as f64 - TYRE_INSET_M - 0.5 * self.tyre_width_m as f64
    }

    /// Radius of the wheel arches in the side view, m (tyre radius plus clearance).
    pub fn arch_radius_m(&self) -> f64 {
        self.wheel_radius_m as f64 + ARCH_CLEARANCE_M
    }

    /// The parameters clamped into their ranges and made consistent, with a message
    /// for each change.
    pub fn validated(&self) -> (CarParameters, Vec<String>) {
        let mut p = self.clone();
        let mut warnings = Vec::new();
        p.clamp_ranges(&mut warnings);
        p.section_vertices = p.section_vertices.div_ceil(16) * 16;
        p.wheel_segments += p.wheel_segments % 2;

        let length = p.length_m;
        let axles = p.front_overhang_m + p.wheelbase_m;
        let max_axles = length - 0.5 * p.front_overhang_m.min(1.0);
        if axles > max_axles {
            let scale = max_axles / axles;
            p.front_overhang_m *= scale;
            p.wheelbase_m *= scale;
            warnings.push(format!(
                "front overhang + wheelbase {axles:.2} m leave no rear overhang on a \
                 {length:.2} m car; scaled by {scale:.3}"
            ));
        }
        let cabin =
            p.bonnet_length_m + p.windscreen_length_m + p.roof_length_m + p.rear_window_length_m;
        let max_cabin = length - 0.3;
        if cabin > max_cabin {
            let scale = max_cabin / cabin;
            p.bonnet_length_m *= scale;
            p.windscreen_length_m *= scale;
            p.roof_length_m *= scale;
            p.rear_window_length_m *= scale;
            warnings.push(format!(
                "bonnet + windscreen + roof + rear window {cabin:.2} m leave less than \
                 0.3 m of boot on a {length:.2} m car; scaled by {scale:.3}"
            ));
        }
        let mut limit = |value: &mut f32, max: f32, what: &str| {
            if *value > max {
                warnings.push(format!("{what} {:.2} m lowered to {max:.2} m", *value));
                *value = max;
            }
        };
        limit(&mut p.bonnet_height_m, p.height_m - 0.25, "bonnet height");
        limit(
            &mut p.nose_height_m,
            p.bonnet_height_m - 0.05,
            "nose height",
        );
        limit(&mut p.boot_height_m, p.height_m - 0.2, "boot height");
        limit(&mut p.tail_height_m, p.boot_height_m, "tail height");
        limit(
            &mut p.ground_clearance_m,
            0.6 * p.nose_height_m.min(p.tail_height_m) - 0.1,
            "ground clearance",
        );
        (p, warnings)
    }
}

/// Generates the car: body, glass, four wheels. Invalid parameters are clamped and
/// reported in [`Scene::warnings`].
pub fn generate(parameters: &CarParameters) -> Scene {
    let (p, warnings) = parameters.validated();
    let body = BodyShape::new(&p);
    let mut mesh = TriangleMesh::default();
    body.add_to(&mut mesh, &p);
    for axle_z in [p.front_axle_z(), p.rear_axle_z()] {
        for side in [1.0, -1.0] {
            let wheel = WheelShape::new(&p, side, axle_z);
            wheel.add_tyre(&mut mesh, &p);
            wheel.add_rim(&mut mesh, &p);
        }
    }
    let mut materials = vec![
        material("body", LinSrgb::new(0.55, 0.04, 0.03), 0.05, 0.0),
        material("glass", LinSrgb::new(0.01, 0.012, 0.015), 0.02, 0.0),
        material("tyre", LinSrgb::new(0.025, 0.025, 0.025), 0.85, 0.0),
        material("rim", LinSrgb::new(0.62, 0.62, 0.64), 0.25, 1.0),
        material("trim", LinSrgb::new(0.015, 0.015, 0.015), 0.6, 0.0),
    ];
    for t in 0..mesh.triangle_count() {
        materials[mesh.triangle_material[t] as usize].area_m2 += mesh.triangle_area(t);
    }
    Scene {
        mesh,
        materials,
        paint_materials: vec![BODY],
        warnings,
        ..Scene::default()
    }
}

fn material(name: &str, base_color: LinSrgb<f32>, roughness: f32, metallic: f32) -> SceneMaterial {
    SceneMaterial {
        name: name.to_owned(),
        base_color,
        roughness,
        metallic,
        ..SceneMaterial::default()
    }
}

// ---------------------------------------------------------------------------------
// Small numeric helpers

fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Smooth minimum of `a` and `b` with blend width `k`.
fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    lerp(b, a, h) - k * h * (1.0 - h)
}

/// Point of the unit superellipse |x|^n + |y|^n = 1 at polar angle `psi`.
fn superellipse(psi: f64, n: f64) -> (f64, f64) {
    let (s, c) = psi.sin_cos();
    let r = (c.abs().powf(n) + s.abs().powf(n)).powf(-1.0 / n);
    (r * c, r * s)
}

/// Quarter-superellipse end cap: 0 at the tip (`d = 0`), rising to 1 at `d = radius`
/// with zero slope there.
fn end_cap(d: f64, radius: f64, n: f64) -> f64 {
    if d >= radius {
        1.0
    } else {
        let t = 1.0 - (d / radius).max(0.0);
        (1.0 - t.powf(n)).max(0.0).powf(1.0 / n)
    }
}

/// Monotone piecewise-cubic Hermite interpolation (PCHIP, Fritsch–Butland slopes):
/// C¹, no overshoot between control points.
#[derive(Debug, Clone)]
struct Profile {
    xs: Vec<f64>,
    ys: Vec<f64>,
    slopes: Vec<f64>,
}

impl Profile {
    fn new(points: &[(f64, f64)]) -> Self {
        let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
        let n = xs.len();
        let h: Vec<f64> = (0..n - 1).map(|k| xs[k + 1] - xs[k]).collect();
        let delta: Vec<f64> = (0..n - 1).map(|k| (ys[k + 1] - ys[k]) / h[k]).collect();
        let mut slopes = vec![0.0; n];
        slopes[0] = delta[0];
        slopes[n - 1] = delta[n - 2];
        for k in 1..n - 1 {
            let (d0, d1) = (delta[k - 1], delta[k]);
            if d0 * d1 > 0.0 {
                let (h0, h1) = (h[k - 1], h[k]);
                slopes[k] = 3.0 * (h0 + h1) / ((2.0 * h1 + h0) / d0 + (h1 + 2.0 * h0) / d1);
            }
        }
        Self { xs, ys, slopes }
    }

    fn eval(&self, x: f64) -> f64 {
        let n = self.xs.len();
        let x = x.clamp(self.xs[0], self.xs[n - 1]);
        let k = self.xs[1..n - 1].partition_point(|&xk| xk <= x);
        let h = self.xs[k + 1] - self.xs[k];
        let t = (x - self.xs[k]) / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * self.ys[k]
            + (t3 - 2.0 * t2 + t) * h * self.slopes[k]
            + (-2.0 * t3 + 3.0 * t2) * self.ys[k + 1]
            + (t3 - t2) * h * self.slopes[k + 1]
    }
}

// ---------------------------------------------------------------------------------
// Mesh assembly

/// Appends a surface made of rings of equal vertex count, closed around each ring.
/// With `poles`, the first and last rings are joined to a pole vertex each (a closed
/// surface like a sphere); with `wrap`, the last ring is joined to the first (a
/// torus). `material(i, j)` is the material of the quad from ring `i`, vertex `j`
/// (ring −1 and `rings.len()` stand for the poles). The part is oriented outward by
/// its signed volume; normals are area-weighted face normals.
fn add_ring_surface(
    mesh: &mut TriangleMesh,
    rings: &[Vec<[f64; 3]>],
    poles: Option<([f64; 3], [f64; 3])>,
    wrap: bool,
    material: impl Fn(isize, usize) -> u32,
) {
    let m = rings[0].len();
    let base = mesh.positions.len() as u32;
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(rings.len() * m + 2);
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut materials: Vec<u32> = Vec::new();
    let ring_start = usize::from(poles.is_some());
    if let Some((first, _)) = poles {
        positions.push(first);
    }
    for ring in rings {
        positions.extend_from_slice(ring);
    }
    let vertex = |i: usize, j: usize| (ring_start + i * m + j % m) as u32;
    for (i, _) in rings.iter().enumerate().take(rings.len() - 1) {
        for j in 0..m {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            );
            let mat = material(i as isize, j);
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
            materials.extend([mat, mat]);
        }
    }
    if wrap {
        let i = rings.len() - 1;
        for j in 0..m {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(0, j),
                vertex(0, j + 1),
                vertex(i, j + 1),
            );
            let mat = material(i as isize, j);
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
            materials.extend([mat, mat]);
        }
    }
    if let Some((_, last)) = poles {
        let last_index = positions.len() as u32;
        positions.push(last);
        let i = rings.len() - 1;
        for j in 0..m {
            triangles.push([0, vertex(0, j), vertex(0, j + 1)]);
            materials.push(material(-1, j));
            triangles.push([vertex(i, j), last_index, vertex(i, j + 1)]);
            materials.push(material(i as isize, j));
        }
    }

    // Orient outward: a closed surface has positive signed volume.
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| DVec3::from(positions[k as usize]));
            a.dot(b.cross(c))
        })
        .sum();
    if volume < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }

    let mut normals = vec![DVec3::ZERO; positions.len()];
    for t in &triangles {
        let [a, b, c] = t.map(|k| DVec3::from(positions[k as usize]));
        let n = (b - a).cross(c - a);
        for k in t {
            normals[*k as usize] += n;
        }
    }
    for (p, n) in positions.iter().zip(&normals) {
        let length = n.length();
        // Divided by the length, not `normalize()` (times its reciprocal): the
        // mesh, and so every render, stays the same to the bit.
        let unit = if length > 0.0 { *n / length } else { DVec3::Y };
        mesh.positions.push(p.map(|v| v as f32));
        mesh.normals.push(unit.as_vec3().to_array());
    }
    mesh.triangles
        .extend(triangles.iter().map(|t| t.map(|k| k + base)));
    mesh.triangle_material.extend(materials);
}

// ---------------------------------------------------------------------------------
// Body

/// Bands of rows around a body cross-section (upper quarter, mirrored on the left).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Band {
    /// Upper flank, waist to window line.
    Flank,
    /// Side window rows, window line to roof rail.
    Window,
    /// Roof rail and pillars.
    Rail,
    /// Bonnet, windscreen, roof, rear window, boot deck.
    Top,
    /// Below the waist.
    Lower,
}

/// The body's profiles along the length, as functions of `d`, the distance back
/// from the nose (z = length/2 − d).
struct BodyShape {
    length: f64,
    half_width: f64,
    top: Profile,
    bottom: Profile,
    width: Profile,
    belt_start: f64,
    belt_rise: f64,
    bonnet_height: f64,
    greenhouse: f64,
    squareness: f64,
    crown: f64,
    bulge: f64,
    cowl: f64,
    roof_front: f64,
    roof_rear: f64,
    deck: f64,
    b_pillar: f64,
    wheels_z: [f64; 2],
    wheel_radius: f64,
    arch_radius: f64,
    well_scale: f64,
    /// Polar angles bounding the roof-rail band in the normalised section.
    rail: (f64, f64),
    /// Row counts per quarter: flank, window, rail, top; lower.
    rows: [usize; 5],
}

/// Height of the window line above the belt (the shoulder), m.
const SHOULDER_M: f64 = 0.07;

struct Section {
    waist: f64,
    upper: f64,
    lower: f64,
    half_width: f64,
    belt: f64,
}

impl BodyShape {
    fn new(p: &CarParameters) -> Self {
        let f = |v: f32| v as f64;
        let length = f(p.length_m);
        let half_width = 0.5 * f(p.width_m);
        let height = f(p.height_m);
        let fo = f(p.front_overhang_m);
        let wb = f(p.wheelbase_m);
        let ro = length - fo - wb;
        let clearance = f(p.ground_clearance_m);
        let nose = f(p.nose_height_m);
        let bonnet = f(p.bonnet_height_m);
        let boot = f(p.boot_height_m);
        let tail = f(p.tail_height_m);
        let cowl = f(p.bonnet_length_m);
        let roof_front = cowl + f(p.windscreen_length_m);
        let roof_rear = roof_front + f(p.roof_length_m);
        let deck = roof_rear + f(p.rear_window_length_m);
        let rl = roof_rear - roof_front;
        let rwl = deck - roof_rear;
        let boot_length = length - deck;

        let top = Profile::new(&[
            (0.0, nose),
            (0.45 * cowl, lerp(nose, bonnet, 0.72)),
            (cowl, bonnet),
            (cowl + 0.5 * (roof_front - cowl), lerp(bonnet, height, 0.58)),
            (roof_front, height - 0.025),
            (roof_front + 0.42 * rl, height),
            (roof_rear, height - 0.035),
            (roof_rear + 0.5 * rwl, lerp(height - 0.035, boot, 0.6)),
            (deck, boot),
            (deck + 0.6 * boot_length, boot - 0.012),
            (length, tail),
        ]);
        let bottom = Profile::new(&[
            (0.0, clearance + 0.22),
            (0.5 * fo, clearance + 0.07),
            (fo, clearance + 0.025),
            (fo + 0.5 * wb, clearance),
            (fo + wb, clearance + 0.025),
            (length - 0.5 * ro, clearance + 0.09),
            (length, clearance + 0.26),
        ]);
        let width = Profile::new(&[
            (0.0, 0.86),
            (0.5 * fo, 0.965),
            (fo, 0.99),
            (fo + 0.5 * wb, 1.0),
            (fo + wb, 0.993),
            (length - 0.5 * ro, 0.97),
            (length, 0.9),
        ]);

        let m = p.section_vertices as usize;
        let quarter_up = 5 * m / 16;
        let flank = ((quarter_up as f64) * 0.32).round() as usize;
        let window = ((quarter_up as f64) * 0.22).round() as usize;
        let rail = (((quarter_up as f64) * 0.11).round() as usize).max(2);
        let top_rows = quarter_up - flank - window - rail;
        let lower = m / 2 - quarter_up;
        let wheel_x = p.wheel_centre_x();
        let floor_x = wheel_x - 0.5 * f(p.tyre_width_m) - WELL_CLEARANCE_M;
        Self {
            length,
            half_width,
            top,
            bottom,
            width,
            belt_start: cowl,
            belt_rise: f(p.belt_rise_m) / (deck - cowl),
            bonnet_height: bonnet,
            greenhouse: f(p.greenhouse_width_fraction),
            squareness: f(p.section_squareness),
            crown: f(p.roof_crown),
            bulge: f(p.flank_bulge),
            cowl,
            roof_front,
            roof_rear,
            deck,
            b_pillar: cowl + 0.5 * (roof_rear - 0.1 - cowl),
            wheels_z: [p.front_axle_z(), p.rear_axle_z()],
            wheel_radius: f(p.wheel_radius_m),
            arch_radius: p.arch_radius_m(),
            well_scale: 1.0 - floor_x / half_width,
            rail: (0.52 * FRAC_PI_2, 0.60 * FRAC_PI_2),
            rows: [flank, window, rail, top_rows, lower],
        }
    }

    fn belt(&self, d: f64) -> f64 {
        self.bonnet_height
            + self.belt_rise * (d - self.belt_start).clamp(0.0, self.deck - self.belt_start)
    }

    fn section(&self, d: f64) -> Section {
        let top = self.top.eval(d);
        let bottom = self.bottom.eval(d);
        let belt = self.belt(d);
        let waist = bottom + 0.55 * (smooth_min(top, belt, 0.05) - bottom);
        let from_tail = self.length - d;
        let cap_w = end_cap(d, 0.5, 2.6) * end_cap(from_tail, 0.42, 2.6);
        let cap_h = end_cap(d, 0.26, 2.0) * end_cap(from_tail, 0.3, 2.0);
        Section {
            waist,
            upper: (top - waist) * cap_h,
            lower: (waist - bottom) * cap_h,
            half_width: self.half_width * self.width.eval(d) * cap_w,
            belt,
        }
    }

    /// Point of section `s` at polar angle `psi` ∈ [0, 2π) of the normalised
    /// superellipse (0 at the right waist, π/2 at the top), before the arches.
    fn point(&self, s: &Section, psi: f64) -> (f64, f64) {
        let (xn, yn) = superellipse(psi, self.squareness);
        let bow = (1.0 + self.bulge * (1.0 - yn * yn)) / (1.0 + self.bulge);
        let crown = (1.0 + self.crown * (1.0 - xn * xn)) / (1.0 + self.crown);
        if yn >= 0.0 {
            let y = s.waist + s.upper * yn * crown;
            let narrowing = smoothstep(s.belt - 0.07, s.belt + 0.27, y);
            let x = s.half_width * xn * bow * (1.0 - (1.0 - self.greenhouse) * narrowing);
            (x, y)
        } else {
            (s.half_width * xn * bow, s.waist + s.lower * yn * crown)
        }
    }

    /// Weight of the wheel well at (y, z): 1 inside, 0 outside the arch.
    fn well(&self, y: f64, z: f64) -> f64 {
        self.wheels_z
            .iter()
            .map(|&wz| {
                let rho = (y - self.wheel_radius).hypot(z - wz);
                1.0 - smoothstep(self.arch_radius - ARCH_LIP_WIDTH_M, self.arch_radius, rho)
            })
            .fold(0.0, f64::max)
    }

    /// Polar angle where the section meets the window line, and whether the section
    /// reaches it (the cabin).
    fn window_line_angle(&self, s: &Section) -> (f64, bool) {
        let limit = 0.85 * self.rail.0;
        let target = s.belt + SHOULDER_M;
        if self.point(s, limit).1 <= target {
            return (limit, false);
        }
        let (mut lo, mut hi) = (0.0, limit);
        for _ in 0..48 {
            let mid = 0.5 * (lo + hi);
            if self.point(s, mid).1 < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (0.5 * (lo + hi), true)
    }

    /// Polar angles of the section's rows and their bands (row j to j+1).
    fn row_angles(&self, window_line: f64) -> (Vec<f64>, Vec<Band>) {
        let [flank, window, rail, top, lower] = self.rows;
        let mut angles = Vec::new();
        let mut bands = Vec::new();
        let mut push_segment = |from: f64, to: f64, count: usize, band: Band| {
            for k in 0..count {
                angles.push(lerp(from, to, k as f64 / count as f64));
                bands.push(band);
            }
        };
        let quarter = [
            (0.0, window_line, flank, Band::Flank),
            (window_line, self.rail.0, window, Band::Window),
            (self.rail.0, self.rail.1, rail, Band::Rail),
            (self.rail.1, FRAC_PI_2, top, Band::Top),
        ];
        for &(from, to, count, band) in &quarter {
            push_segment(from, to, count, band);
        }
        for &(from, to, count, band) in quarter.iter().rev() {
            push_segment(PI - to, PI - from, count, band);
        }
        push_segment(PI, TAU, 2 * lower, Band::Lower);
        (angles, bands)
    }

    fn add_to(&self, mesh: &mut TriangleMesh, p: &CarParameters) {
        let n = p.rings as usize;
        // Denser toward the caps: blend of a cosine and a linear spacing.
        let ring_d = |i: usize| {
            let u = i as f64 / n as f64;
            self.length * (0.8 * 0.5 * (1.0 - (PI * u).cos()) + 0.2 * u)
        };
        let half_length = 0.5 * self.length;
        let mut rings = Vec::with_capacity(n - 1);
        let mut in_cabin = Vec::with_capacity(n - 1);
        let mut bands = Vec::new();
        for i in 1..n {
            let d = ring_d(i);
            let z = half_length - d;
            let s = self.section(d);
            let (window_line, cabin) = self.window_line_angle(&s);
            let (angles, ring_bands) = self.row_angles(window_line);
            bands = ring_bands;
            in_cabin.push(cabin);
            rings.push(
                angles
                    .iter()
                    .map(|&psi| {
                        let (x, y) = self.point(&s, psi);
                        let x = x * (1.0 - self.well_scale * self.well(y, z));
                        [x, y, z]
                    })
                    .collect::<Vec<_>>(),
            );
        }
        let nose = self.section(0.0);
        let tail = self.section(self.length);
        let poles = (
            [0.0, nose.waist, half_length],
            [0.0, tail.waist, -half_length],
        );

        let material = |i: isize, j: usize| {
            // Ring index i joins interior ring i (ring_d(i + 1)) to the next one.
            let (i0, i1) = ((i + 1) as usize, (i + 2) as usize);
            let d = 0.5 * (ring_d(i0) + ring_d(i1));
            let ring = |k: usize| rings.get(k.wrapping_sub(1));
            let centre_well = match (ring(i0), ring(i1)) {
                (Some(a), Some(b)) => {
                    let (pa, pb) = (a[j], b[(j + 1) % a.len()]);
                    self.well(0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2]))
                }
                _ => 0.0,
            };
            if centre_well > 0.9 {
                return TRIM;
            }
            let cabin = |k: usize| in_cabin.get(k.wrapping_sub(1)).copied().unwrap_or(false);
            match bands[j] {
                Band::Window
                    if cabin(i0)
                        && cabin(i1)
                        && d > self.cowl + 0.02
                        && d < self.roof_rear - 0.1
                        && (d - self.b_pillar).abs() > 0.045 =>
                {
                    GLASS
                }
                Band::Top
                    if (d > self.cowl && d < self.roof_front)
                        || (d > self.roof_rear && d < self.deck) =>
                {
                    GLASS
                }
                _ => BODY,
            }
        };
        add_ring_surface(mesh, &rings, Some(poles), false, material);
    }
}

// ---------------------------------------------------------------------------------
// Wheels

struct WheelShape {
    /// +1 for the right wheels (x > 0), −1 for the left.
    side: f64,
    centre: [f64; 3],
    radius: f64,
    rim_radius: f64,
    half_width: f64,
    segments: usize,
}

impl WheelShape {
    fn new(p: &CarParameters, side: f64, axle_z: f64) -> Self {
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

    fn add_tyre(&self, mesh: &mut TriangleMesh, p: &CarParameters) {
        let _ = p;
        let section_height = 0.5 * (self.radius - self.rim_radius);
        let section_centre = self.radius - section_height;
        let around = 4 * (self.segments / 12).max(4);
        let thetas = self.thetas();
        let rings: Vec<Vec<[f64; 3]>> = thetas
            .iter()
            .map(|&theta| {
                (0..around)
                    .map(|k| {
                        let sigma = TAU * k as f64 / around as f64;
                        let (a, r) = superellipse(sigma, 3.5);
                        self.at(
                            self.half_width * a,
                            section_centre + section_height * r,
                            theta,
                        )
                    })
                    .collect()
            })
            .collect();
        add_ring_surface(mesh, &rings, None, true, |_, _| TYRE);
    }

    fn add_rim(&self, mesh: &mut TriangleMesh, p: &CarParameters) {
        let _ = p;
        let disc = self.rim_radius + 0.12 * (self.radius - self.rim_radius);
        let face = 0.55 * self.half_width;
        let back = -0.5 * self.half_width;
        let thetas = self.thetas();
        let spoke = |theta: f64| (0.5 + 0.5 * (5.0 * theta).cos()).powi(2);
        let opening = |q: f64, theta: f64| {
            (1.0 - spoke(theta)) * smoothstep(0.28, 0.4, q) * (1.0 - smoothstep(0.8, 0.92, q))
        };
        let dish = |q: f64, theta: f64| {
            0.2 * self.half_width * q * q + 0.45 * self.half_width * opening(q, theta)
                - 0.15 * self.half_width * (1.0 - smoothstep(0.0, 0.22, q))
        };
        // Meridian: outer face from the hub out, the edge, the inner face back in.
        let face_rings = 18;
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

// ---------------------------------------------------------------------------------
// Binary glTF

/// Why a scene could not be written as binary glTF.
#[derive(Debug, thiserror::Error)]
pub enum GlbWriteError {
    /// The JSON chunk could not be serialised.
    #[error("glTF JSON serialisation failed: {error}")]
    Json { error: gltf::json::Error },
    /// The file would exceed the 4 GiB that a GLB header can describe.
    #[error("scene too large for binary glTF: {0} bytes (the format's limit is 4 GiB)")]
    TooLarge(usize),
    /// The mesh is inconsistent.
    #[error(
        "mesh has {positions} positions but {normals} normals and {materials} triangle materials for {triangles} triangles"
    )]
    Inconsistent {
        /// Number of positions.
        positions: usize,
        /// Number of normals.
        normals: usize,
        /// Number of triangle materials.
        materials: usize,
        /// Number of triangles.
        triangles: usize,
    },
}

/// Writes `scene` as binary glTF 2.0 (GLB): one mesh on one node, one primitive per
/// material with triangles, all sharing one POSITION and one NORMAL accessor (f32),
/// u32 indices; materials as metallic-roughness base colours with their names.
/// Deterministic: the same scene gives the same bytes.
pub fn to_glb(scene: &Scene) -> Result<Vec<u8>, GlbWriteError> {
    use gltf::json::{self, validation::Checked::Valid, validation::USize64};

    let mesh = &scene.mesh;
    if mesh.normals.len() != mesh.positions.len()
        || mesh.triangle_material.len() != mesh.triangles.len()
    {
        return Err(GlbWriteError::Inconsistent {
            positions: mesh.positions.len(),
            normals: mesh.normals.len(),
            materials: mesh.triangle_material.len(),
            triangles: mesh.triangles.len(),
        });
    }

    let mut bin: Vec<u8> = Vec::new();
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some("coatlab-core scene::car".to_owned()),
            ..Default::default()
        },
        ..Default::default()
    };
    let buffer = json::Index::new(0);
    let push_view =
        |root: &mut json::Root, bin: &mut Vec<u8>, bytes: Vec<u8>, target: json::buffer::Target| {
            let offset = bin.len();
            bin.extend_from_slice(&bytes);
            root.push(json::buffer::View {
                buffer,
                byte_length: USize64::from(bytes.len()),
                byte_offset: Some(USize64::from(offset)),
                byte_stride: None,
                extensions: None,
                extras: Default::default(),
                name: None,
                target: Some(Valid(target)),
            })
        };
    let vec3_bytes = |values: &[[f32; 3]]| {
        values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<u8>>()
    };
    let accessor = |view,
                    count: usize,
                    component,
                    type_,
                    min: Option<json::Value>,
                    max: Option<json::Value>| json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Valid(type_),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    };

    // A float VEC3 attribute in a view of its own, with its bounds where given.
    let vec3_attribute = |root: &mut json::Root,
                          bin: &mut Vec<u8>,
                          values: &[[f32; 3]],
                          bounds: Option<([f32; 3], [f32; 3])>| {
        let target = json::buffer::Target::ArrayBuffer;
        let view = push_view(root, bin, vec3_bytes(values), target);
        let (min, max) = bounds
            .map(|(lo, hi)| {
                (
                    json::Value::from(lo.to_vec()),
                    json::Value::from(hi.to_vec()),
                )
            })
            .unzip();
        root.push(accessor(
            view,
            values.len(),
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            min,
            max,
        ))
    };
    let bounds = mesh.bounds().unwrap_or(([0.0; 3], [0.0; 3]));
    let positions = vec3_attribute(&mut root, &mut bin, &mesh.positions, Some(bounds));
    let normals = vec3_attribute(&mut root, &mut bin, &mesh.normals, None);

    let mut primitives = Vec::new();
    for (index, m) in scene.materials.iter().enumerate() {
        let material = root.push(json::Material {
            name: Some(m.name.clone()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([
                    m.base_color.red,
                    m.base_color.green,
                    m.base_color.blue,
                    1.0,
                ]),
                metallic_factor: json::material::StrengthFactor(m.metallic),
                roughness_factor: json::material::StrengthFactor(m.roughness),
                ..Default::default()
            },
            ..Default::default()
        });
        let indices: Vec<u8> = mesh
            .triangles
            .iter()
            .zip(&mesh.triangle_material)
            .filter(|&(_, &mat)| mat as usize == index)
            .flat_map(|(t, _)| t.iter().flat_map(|v| v.to_le_bytes()))
            .collect();
        if indices.is_empty() {
            continue;
        }
        let count = indices.len() / 4;
        let view = push_view(
            &mut root,
            &mut bin,
            indices,
            json::buffer::Target::ElementArrayBuffer,
        );
        let indices = root.push(accessor(
            view,
            count,
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
            None,
        ));
        primitives.push(json::mesh::Primitive {
            attributes: [
                (Valid(json::mesh::Semantic::Positions), positions),
                (Valid(json::mesh::Semantic::Normals), normals),
            ]
            .into_iter()
            .collect(),
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        });
    }
    root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        extensions: None,
        extras: Default::default(),
        name: None,
        uri: None,
    });
    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("default car".to_owned()),
        primitives,
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        name: Some("default car".to_owned()),
        ..Default::default()
    });
    let scene_index = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene_index);

    // GLB: 12-byte header, JSON chunk padded with spaces, BIN chunk padded with zeros.
    let mut json_chunk = root
        .to_vec()
        .map_err(|error| GlbWriteError::Json { error })?;
    json_chunk.resize(json_chunk.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json_chunk.len() + 8 + bin.len();
    let total_u32 = u32::try_from(total).map_err(|_| GlbWriteError::TooLarge(total))?;
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&total_u32.to_le_bytes());
    for (chunk, kind) in [(&json_chunk, b"JSON"), (&bin, b"BIN\0")] {
        glb.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        glb.extend_from_slice(kind);
        glb.extend_from_slice(chunk);
    }
    Ok(glb)
}
