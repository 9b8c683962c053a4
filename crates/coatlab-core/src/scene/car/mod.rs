//! # The default car: a parametric generator
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
//! | `length_m` | m | 3.5 – 5.5 | 4.70 | overall length, nose to tail |
//! | `width_m` | m | 1.5 – 2.1 | 1.82 | overall body width (no mirrors) |
//! | `height_m` | m | 1.1 – 1.8 | 1.43 | roof top above the ground |
//! | `wheelbase_m` | m | 2.0 – 3.4 | 2.83 | front to rear axle |
//! | `front_overhang_m` | m | 0.5 – 1.3 | 0.90 | nose to front axle |
//! | `wheel_radius_m` | m | 0.26 – 0.42 | 0.33 | tyre outer radius |
//! | `tyre_width_m` | m | 0.15 – 0.32 | 0.225 | tyre tread width |
//! | `rim_fraction` | 1 | 0.5 – 0.8 | 0.69 | rim radius / tyre radius |
//! | `ground_clearance_m` | m | 0.08 – 0.30 | 0.16 | sill height between the wheels |
//! | `nose_height_m` | m | 0.5 – 1.0 | 0.70 | bonnet leading edge above the ground |
//! | `bonnet_height_m` | m | 0.7 – 1.2 | 0.93 | bonnet at the windscreen base (cowl) |
//! | `bonnet_length_m` | m | 0.7 – 1.8 | 1.25 | nose to cowl, along Z |
//! | `windscreen_length_m` | m | 0.4 – 1.2 | 0.80 | cowl to roof front, along Z (rake) |
//! | `roof_length_m` | m | 0.5 – 2.0 | 1.20 | roof front to rear-window top |
//! | `rear_window_length_m` | m | 0.2 – 1.2 | 0.72 | rear-window top to boot deck |
//! | `boot_height_m` | m | 0.7 – 1.3 | 1.00 | boot deck at the rear-window base |
//! | `tail_height_m` | m | 0.6 – 1.2 | 0.93 | top of the tail, before it rounds off |
//! | `belt_rise_m` | m | 0 – 0.2 | 0.06 | rise of the window line from cowl to deck |
//! | `greenhouse_width_fraction` | 1 | 0.6 – 0.95 | 0.80 | cabin width at the roof / body width (tumblehome) |
//! | `section_squareness` | 1 | 2.5 – 6 | 4.0 | superellipse exponent of the cross-sections |
//! | `roof_crown` | 1 | 0 – 0.3 | 0.08 | transverse crown of bonnet, roof and boot |
//! | `flank_bulge` | 1 | 0 – 0.1 | 0.03 | outward bow of the flanks (curvature in the sides) |
//! | `rings` | count | 64 – 2000 | 420 | body cross-sections along the length |
//! | `section_vertices` | count | 48 – 1024 | 160 | vertices around each cross-section (rounded to a multiple of 16) |
//! | `wheel_segments` | count | 20 – 512 | 120 | segments around each wheel (rounded to a multiple of 10, the spokes) |
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
//! - **Panels** (`body.rs`): the section grid has five narrow sections (or rows) at
//!   each shut line; the middle one is pushed 4 mm in along the normal, its two
//!   quads are [`PANEL_GAP`], and the panel edges roll over between the outer ones.
//!   Cuts: bonnet (front edge and sides), front and rear doors (front, split, rear,
//!   lower edge), boot lid (front, sides, rear).
//! - **Feature line**: a crease along the flank 62 % of the way
//!   from the waist to the window line, 5 mm proud, its two sides about 20° apart,
//!   fading out toward nose and tail; above it the shoulder where the cabin narrows.
//! - **Glass**: windscreen, side windows (split by a black B-pillar) and rear window
//!   are material regions of the same surface; the rows of the section grid follow the
//!   window line and the roof rail, so the glass edges are smooth curves, not steps.
//! - **Lamps**: headlamps wrap the front corners, tail lamps the rear corners, as
//!   lens regions of the body surface ([`HEADLAMP_LENS`], [`TAIL_LAMP`]); behind each
//!   lens a bowl of the lens's grid pushed in 2.5–3 cm ([`LAMP_REFLECTOR`], with a
//!   [`LAMP_EMITTER`] strip in the headlamps) closes the pocket.
//! - **Wheels** (`wheels.rs`): four tyres (tori with a superelliptic section: tread,
//!   shoulders and sidewalls, four circumferential grooves, touching y = 0) and
//!   aluminium rims (closed discs with a dished, ten-spoke outer face; the openings
//!   are `trim`).
//! - **Parts** (`parts.rs`): chrome door handles, door mirrors (black housing on an
//!   arm, mirror glass), and the interior seen through the glass: floor, dashboard,
//!   console and steering wheel ([`INTERIOR`]), two front seats and a rear bench with
//!   headrests ([`SEAT`]); each a closed superellipsoid or torus.
//! - **Cabin lining** (`body.rs`): inside the body over the cabin's length, the
//!   section grid drawn 3 cm in toward each section's centre, less the glass's
//!   quads (door cards, pillar trims, headliner), a strip from its edge out to each
//!   pane's (the reveals), and a bulkhead closing each end ([`CABIN_LINING`]): seen
//!   through the glass the body's inside is trim, as in a real car, not the paint.
//! - **Normals**: area-weighted averages of the face normals of each part, outward
//!   (every closed part is oriented by its signed volume, each lamp bowl toward its
//!   lens).
//!
//! ## Creases
//!
//! The body is smooth (adjacent vertex normals within a few degrees) except along the
//! lip and the floor edge of each wheel arch, where the well wall turns the surface
//! through nearly 90° over a few centimetres (the band [`ARCH_LIP_WIDTH_M`] wide
//! inside the arch radius [`CarParameters::arch_radius_m`]), at the shut lines (the
//! gap walls), and along the feature line. Wheels have deliberate creases at the rim
//! edge and the spokes.
//!
//! ## Materials
//!
//! In index order: [`BODY`] (the paint, the only entry of `paint_materials`),
//! [`GLASS`], [`TYRE`], [`RIM`], [`TRIM`], [`PANEL_GAP`], [`HEADLAMP_LENS`],
//! [`LAMP_REFLECTOR`], [`LAMP_EMITTER`], [`TAIL_LAMP`], [`MIRROR_GLASS`],
//! [`DOOR_HANDLE`], [`INTERIOR`], [`SEAT`], [`MIRROR_HOUSING`], [`CABIN_LINING`];
//! named `body`, `glass`, `tyre`, `rim`, `trim`, `panel-gap`, `headlamp-lens`,
//! `lamp-reflector`, `lamp-emitter`, `tail-lamp`, `mirror-glass`, `door-handle`,
//! `interior`, `seat`, `mirror-housing`, `cabin-lining`. Only `body` matches
//! the loader's paint-name hints, so the heuristic picks it when the GLB is loaded.
//! The materials are base colour, roughness and metallic; the glass and the lamp
//! lenses are thin-walled panes (`KHR_materials_transmission`, index 1.52), the
//! windows tinted slightly green-grey and the tail lamps red by their base colour,
//! and the lamp emitter emits.

use palette::LinSrgb;

use super::transparency::Transparency;
use super::{Scene, SceneMaterial, TriangleMesh};
use crate::parameter::{Bounds, Parameter};
use crate::units::Unit;

mod body;
mod glb;
mod mesh;
mod parts;
mod wheels;

pub use glb::{GlbOptions, GlbWriteError, to_glb, to_glb_with};

/// The segment the default car is drawn from, a modern compact-executive (D-segment)
/// saloon: the span of the 2019–2024 BMW 3 Series (G20), Audi A4 (B9), Mercedes
/// C-Class (W206) and Tesla Model 3 as their makers state them: overall length,
/// width without mirrors, height, wheelbase, and track (mean of front and rear), m.
/// The default parameters give a car inside every range (`tests/default_car.rs`).
pub const SEGMENT_RANGES: &[(&str, f64, f64)] = &[
    ("length", 4.69, 4.77),
    ("width", 1.82, 1.85),
    ("height", 1.42, 1.45),
    ("wheelbase", 2.82, 2.88),
    ("track", 1.55, 1.59),
];

/// Material index of the painted body.
pub const BODY: u32 = 0;
/// Material index of the windows.
pub const GLASS: u32 = 1;
/// Material index of the tyres.
pub const TYRE: u32 = 2;
/// Material index of the rims.
pub const RIM: u32 = 3;
/// Material index of black plastic: wheel-well liners, rim openings, B-pillars,
/// the front intake, mirrors.
pub const TRIM: u32 = 4;
/// Material index of the floors of the shut lines between panels.
pub const PANEL_GAP: u32 = 5;
/// Material index of the headlamps' cover glass.
pub const HEADLAMP_LENS: u32 = 6;
/// Material index of the lamps' reflector bowls behind the lenses.
pub const LAMP_REFLECTOR: u32 = 7;
/// Material index of the headlamps' light strips (daytime running lights).
pub const LAMP_EMITTER: u32 = 8;
/// Material index of the tail lamps' red cover glass.
pub const TAIL_LAMP: u32 = 9;
/// Material index of the door mirrors' glass.
pub const MIRROR_GLASS: u32 = 10;
/// Material index of the door handles (chrome).
pub const DOOR_HANDLE: u32 = 11;
/// Material index of the dark interior mouldings: floor, dashboard, console, wheel.
pub const INTERIOR: u32 = 12;
/// Material index of the seats' leather.
pub const SEAT: u32 = 13;
/// Material index of the door mirrors' housings and arms (black).
pub const MIRROR_HOUSING: u32 = 14;
/// Material index of the cabin's lining: door cards, pillar trims, headliner,
/// bulkheads and the reveals around the glass (dark grey textile).
pub const CABIN_LINING: u32 = 15;

/// Width of the arch lip (the well wall), metres: the crease band of the body.
pub const ARCH_LIP_WIDTH_M: f64 = 0.05;
/// Clearance between the tyre tread and the arch radius, metres.
const ARCH_CLEARANCE_M: f64 = 0.07;
/// Gap between the tyre's outer face and the body's half-width, metres.
const TYRE_INSET_M: f64 = 0.012;
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
    length_m: f32 = 4.7, Unit::Metre, [3.5, 5.5];
    /// Overall body width (no mirrors), m.
    width_m: f32 = 1.82, Unit::Metre, [1.5, 2.1];
    /// Roof top above the ground, m.
    height_m: f32 = 1.43, Unit::Metre, [1.1, 1.8];
    /// Front to rear axle, m.
    wheelbase_m: f32 = 2.83, Unit::Metre, [2.0, 3.4];
    /// Nose to front axle, m.
    front_overhang_m: f32 = 0.9, Unit::Metre, [0.5, 1.3];
    /// Tyre outer radius, m.
    wheel_radius_m: f32 = 0.33, Unit::Metre, [0.26, 0.42];
    /// Tyre tread width, m.
    tyre_width_m: f32 = 0.225, Unit::Metre, [0.15, 0.32];
    /// Rim radius over tyre radius.
    rim_fraction: f32 = 0.69, Unit::Dimensionless, [0.5, 0.8];
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
    roof_length_m: f32 = 1.2, Unit::Metre, [0.5, 2.0];
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
    rings: u32 = 420, Unit::Count, [64, 2000];
    /// Vertices around each body cross-section (rounded to a multiple of 16).
    section_vertices: u32 = 160, Unit::Count, [48, 1024];
    /// Segments around each wheel (rounded to a multiple of the spoke count).
    wheel_segments: u32 = 120, Unit::Count, [20, 512];
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
        p.wheel_segments = p.wheel_segments.div_ceil(wheels::SPOKES as u32) * wheels::SPOKES as u32;

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

/// Generates the car: body with its glass and lamps, four wheels, handles, mirrors
/// and interior. Invalid parameters are clamped and reported in [`Scene::warnings`].
pub fn generate(parameters: &CarParameters) -> Scene {
    let (p, warnings) = parameters.validated();
    let body = body::BodyShape::new(&p);
    let mut mesh = TriangleMesh::default();
    body.add_to(&mut mesh, &p);
    for axle_z in [p.front_axle_z(), p.rear_axle_z()] {
        for side in [1.0, -1.0] {
            let wheel = wheels::WheelShape::new(&p, side, axle_z);
            wheel.add_tyre(&mut mesh);
            wheel.add_rim(&mut mesh);
        }
    }
    parts::add_parts(&mut mesh, &p, &body);
    // In the order of the material indices above.
    let grey = |v: f32| LinSrgb::new(v, v, v);
    let mut materials = vec![
        material("body", LinSrgb::new(0.55, 0.04, 0.03), 0.05, 0.0),
        glass("glass", LinSrgb::new(0.72, 0.78, 0.76)),
        material("tyre", grey(0.025), 0.85, 0.0),
        material("rim", LinSrgb::new(0.91, 0.92, 0.92), 0.22, 1.0),
        material("trim", grey(0.015), 0.45, 0.0),
        material("panel-gap", grey(0.004), 0.9, 0.0),
        glass("headlamp-lens", LinSrgb::new(0.97, 0.97, 0.97)),
        material("lamp-reflector", LinSrgb::new(0.9, 0.9, 0.91), 0.08, 1.0),
        SceneMaterial {
            emissive: LinSrgb::new(LAMP_RADIANCE, LAMP_RADIANCE, 0.95 * LAMP_RADIANCE),
            ..material("lamp-emitter", grey(0.95), 0.3, 0.0)
        },
        glass("tail-lamp", LinSrgb::new(0.75, 0.015, 0.01)),
        material("mirror-glass", grey(0.9), 0.02, 1.0),
        material("door-handle", LinSrgb::new(0.85, 0.85, 0.86), 0.1, 1.0),
        material("interior", grey(0.03), 0.7, 0.0),
        material("seat", LinSrgb::new(0.18, 0.09, 0.045), 0.55, 0.0),
        material("mirror-housing", grey(0.015), 0.45, 0.0),
        material("cabin-lining", grey(0.04), 0.9, 0.0),
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

/// Index of refraction of the car's glass and lamp lenses (soda-lime glass and
/// polycarbonate lie between 1.50 and 1.59).
const GLASS_IOR: f32 = 1.52;

/// Radiance of the headlamps' light strips, in units of a white sky of radiance 1
/// (bright enough to read as lit against the studio's reflections).
const LAMP_RADIANCE: f32 = 6.0;

/// A thin-walled pane whose transmission `tint` colours (glTF's base colour of a
/// transmitting material): the windows, the lamp lenses.
fn glass(name: &str, tint: LinSrgb<f32>) -> SceneMaterial {
    SceneMaterial {
        transparency: Transparency::thin_glass(GLASS_IOR),
        ..material(name, tint, 0.0, 0.0)
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
