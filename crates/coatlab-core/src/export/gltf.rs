//! A design as the closest glTF 2.0 real-time material, and the scene that
//! carries it (the built-in car or a loaded glTF), written as GLB.
//!
//! The material ([`RealTimeMaterial`]) is glTF's metallic-roughness model with
//! `KHR_materials_clearcoat` and `KHR_materials_ior`, evaluated as the glTF 2.0
//! specification's Appendix B and the clear-coat extension define it
//! ([`reflectance_factor`]):
//!
//! | glTF | from the design |
//! | --- | --- |
//! | `metallicFactor` | 0 (the paint is a dielectric) |
//! | `clearcoatFactor` | 1: the clear coat's surface reflection |
//! | `clearcoatRoughness` | the gloss lobe's width: [`roughness_of_exponent`] |
//! | `ior` (`KHR_materials_ior`) | the coat's n at 587.6 nm (glTF applies it to the base layer's Fresnel; the clear coat layer's is fixed at 1.5 by the extension) |
//! | `roughnessFactor` | 1: the pigment scatters diffusely under the coat |
//! | `baseColorFactor` | fitted: the linear-sRGB colour whose material reads, at the five multi-angle instrument geometries, closest to the design's readings in ΔE00 ([`fit_base_colour`]) |
//!
//! What the approximation costs is stated per geometry: the ΔE00 between the
//! design's reading and the material's, both under D65 and the CIE 1931 2°
//! observer (the observer of the sRGB primaries), the material evaluated
//! "spectrally free" in linear sRGB. These numbers go into the material's
//! `extras` (`coatlab.delta_e00`).

use std::f64::consts::PI;

use gltf::json;
use palette::LinSrgb;
use serde::Serialize as _;

use crate::colour::{
    Lab, ciede2000, lab_from_xyz, linear_srgb_of_reflectance, srgb_white, xyz_from_linear_srgb,
};
use crate::design::PaintDesign;
use crate::instruments::{self, ILLUMINATION_DEG, in_plane_direction};
use crate::measurement::Geometry;
use crate::paint::gloss::GlossExponent;
use crate::paint::lobe::LobeKind;
use crate::paint::model::PaintModel;
use crate::scene::Scene;
use crate::scene::car::{GlbOptions, GlbWriteError, to_glb_with};

/// The clear-coat layer's Fresnel reflectance at normal incidence, fixed by
/// `KHR_materials_clearcoat` (an index of 1.5).
pub const CLEARCOAT_F0: f64 = 0.04;
/// The base layer's roughness: the pigment under the coat scatters diffusely.
pub const BASE_ROUGHNESS: f64 = 1.0;

/// Why a glTF export failed.
#[derive(Debug, thiserror::Error)]
pub enum GltfExportError {
    #[error("the scene has no material for the paint: nothing would show the design")]
    NoPaintMaterial,
    #[error(transparent)]
    Glb(#[from] GlbWriteError),
    #[error("cannot write the material's extras: {0}")]
    Extras(String),
}

/// The glTF material of a design (see the module docs).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RealTimeMaterial {
    /// `baseColorFactor`, linear sRGB in [0, 1].
    #[serde(serialize_with = "serialize_rgb")]
    pub base_color: LinSrgb<f64>,
    /// `roughnessFactor` of the base layer.
    pub roughness: f64,
    /// `clearcoatRoughness`.
    pub clearcoat_roughness: f64,
    /// `KHR_materials_ior`'s `ior`.
    pub ior: f64,
    /// What the material costs at each multi-angle geometry.
    pub delta_e00: Vec<AngleCost>,
}

/// The ΔE00 of the material against the design at one geometry.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AngleCost {
    #[serde(serialize_with = "serialize_geometry")]
    pub geometry: Geometry,
    pub aspecular_deg: f64,
    /// CIEDE2000, D65/2°.
    pub delta_e00: f64,
}

fn serialize_rgb<S: serde::Serializer>(rgb: &LinSrgb<f64>, s: S) -> Result<S::Ok, S::Error> {
    [rgb.red, rgb.green, rgb.blue].serialize(s)
}

fn serialize_geometry<S: serde::Serializer>(g: &Geometry, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&g.to_string())
}

/// glTF `roughness` for a Phong lobe of exponent `m` about the mirror direction.
///
/// Near the peak such a lobe falls as cos^m ψ ≈ exp(−m ψ²/2), ψ the angle to the
/// mirror direction; at normal incidence ψ ≈ 2θh (θh the half vector's angle), so
/// it is a Blinn–Phong lobe of exponent 4m, whose microfacet width is
/// α = √(2 / (4m + 2)) (Walter et al. 2007, eq. 24 for Beckmann; used for GGX's α).
/// glTF's roughness is √α. The paper's lobe is about twice as wide as a
/// normalised one of the same m, so it counts as m/4. A mirror is roughness 0.
pub fn roughness_of_exponent(exponent: GlossExponent, lobe: LobeKind) -> f64 {
    let m = match exponent {
        GlossExponent::Mirror => return 0.0,
        GlossExponent::Finite(m) => match lobe {
            LobeKind::Normalised => m,
            LobeKind::Paper => m / 4.0,
        },
    };
    (2.0 / (4.0 * m + 2.0)).sqrt().sqrt().min(1.0)
}

/// glTF's specular microfacet BRDF V·D (GGX distribution, height-correlated
/// separable Smith visibility as the glTF 2.0 spec writes it) for α = roughness².
fn specular_brdf(roughness: f64, n_l: f64, n_v: f64, n_h: f64) -> f64 {
    let a2 = roughness.powi(4);
    if a2 == 0.0 || n_h <= 0.0 {
        // A mirror reflects nothing away from the mirror direction.
        return 0.0;
    }
    let d = a2 / (PI * (n_h * n_h * (a2 - 1.0) + 1.0).powi(2));
    let v = 1.0
        / ((n_l + (a2 + (1.0 - a2) * n_l * n_l).sqrt())
            * (n_v + (a2 + (1.0 - a2) * n_v * n_v).sqrt()));
    v * d
}

/// The material's reflectance factor π·f(ωi, ωo) in linear sRGB, with
/// `base_color` in place of its own: the glTF 2.0 BRDF (Appendix B) of a
/// dielectric (metallic 0) under `KHR_materials_clearcoat` (the coat weighted by
/// its Fresnel term at N·V, as the extension specifies). `wi` toward the light,
/// `wo` toward the viewer, z the normal.
pub fn reflectance_factor(
    material: &RealTimeMaterial,
    base_color: [f64; 3],
    wi: [f64; 3],
    wo: [f64; 3],
) -> [f64; 3] {
    let (n_l, n_v) = (wi[2], wo[2]);
    if n_l <= 0.0 || n_v <= 0.0 {
        return [0.0; 3];
    }
    let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    let h = h.map(|c| c / len);
    let n_h = h[2];
    let v_h = (wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]).abs();
    let schlick = |f0: f64, cos: f64| f0 + (1.0 - f0) * (1.0 - cos).powi(5);

    let f0 = ((material.ior - 1.0) / (material.ior + 1.0)).powi(2);
    let fresnel = schlick(f0, v_h);
    let base_specular = specular_brdf(material.roughness, n_l, n_v, n_h);
    let coat_weight = schlick(CLEARCOAT_F0, n_v);
    let coat = specular_brdf(material.clearcoat_roughness, n_l, n_v, n_h);
    base_color.map(|c| {
        let dielectric = (1.0 - fresnel) * c / PI + fresnel * base_specular;
        PI * ((1.0 - coat_weight) * dielectric + coat_weight * coat)
    })
}

fn lab_of_linear_srgb(rgb: [f64; 3]) -> Lab {
    lab_from_xyz(
        xyz_from_linear_srgb(LinSrgb::new(rgb[0], rgb[1], rgb[2])),
        srgb_white(),
    )
}

/// The five multi-angle geometries with the design's colour there (D65/2°).
fn design_colours(model: &PaintModel) -> Result<Vec<(f64, Lab)>, super::ExportError> {
    let m = instruments::measure(model)?;
    Ok(m.angles
        .iter()
        .map(|a| {
            (
                a.aspecular_deg,
                lab_of_linear_srgb(linear_srgb_of_reflectance(&a.reflectance_factor)),
            )
        })
        .collect())
}

fn geometry_directions(aspecular_deg: f64) -> ([f64; 3], [f64; 3]) {
    (
        in_plane_direction(-ILLUMINATION_DEG),
        in_plane_direction(ILLUMINATION_DEG - aspecular_deg),
    )
}

/// Σ ΔE00² over the geometries of `targets` for base colour `rgb`.
fn cost(material: &RealTimeMaterial, rgb: [f64; 3], targets: &[(f64, Lab)]) -> f64 {
    targets
        .iter()
        .map(|&(aspecular, lab)| {
            let (wi, wo) = geometry_directions(aspecular);
            ciede2000(
                lab_of_linear_srgb(reflectance_factor(material, rgb, wi, wo)),
                lab,
            )
            .powi(2)
        })
        .sum()
}

/// The base colour in [0, 1]³ that minimises Σ ΔE00² over `targets`, by a
/// compass search (steps along each axis, halved when none improves) from `start`:
/// the cost is smooth but ΔE00 has no handy derivative, and three unknowns make
/// a derivative-free search cheap (a few hundred evaluations).
pub fn fit_base_colour(
    material: &RealTimeMaterial,
    start: [f64; 3],
    targets: &[(f64, Lab)],
) -> [f64; 3] {
    let mut best = start.map(|c| c.clamp(0.0, 1.0));
    let mut best_cost = cost(material, best, targets);
    let mut step = 0.1;
    while step > 1e-7 {
        let mut improved = false;
        for axis in 0..3 {
            for sign in [1.0, -1.0] {
                let mut trial = best;
                trial[axis] = (trial[axis] + sign * step).clamp(0.0, 1.0);
                let c = cost(material, trial, targets);
                if c < best_cost {
                    (best, best_cost, improved) = (trial, c, true);
                }
            }
        }
        if !improved {
            step *= 0.5;
        }
    }
    best
}

/// The design's real-time material: the mapping of the module docs, the base
/// colour fitted from the linear sRGB of ρ(λ) under D65, and its cost per geometry.
pub fn real_time_material(design: &PaintDesign) -> Result<RealTimeMaterial, super::ExportError> {
    let model = design.model(crate::colour::spectrum::WavelengthGrid::reference())?;
    let mut material = RealTimeMaterial {
        base_color: LinSrgb::new(0.0, 0.0, 0.0),
        roughness: BASE_ROUGHNESS,
        clearcoat_roughness: roughness_of_exponent(model.exponent(), model.lobe()),
        ior: model.index_at_gloss_wavelength(),
        delta_e00: Vec::new(),
    };
    let targets = design_colours(&model)?;
    let start = linear_srgb_of_reflectance(model.albedo());
    let rgb = fit_base_colour(&material, start, &targets);
    material.base_color = LinSrgb::new(rgb[0], rgb[1], rgb[2]);
    material.delta_e00 = targets
        .iter()
        .map(|&(aspecular_deg, lab)| {
            let (wi, wo) = geometry_directions(aspecular_deg);
            AngleCost {
                geometry: Geometry::directional(ILLUMINATION_DEG, aspecular_deg),
                aspecular_deg,
                delta_e00: ciede2000(
                    lab_of_linear_srgb(reflectance_factor(&material, rgb, wi, wo)),
                    lab,
                ),
            }
        })
        .collect();
    Ok(material)
}

/// The extensions the material uses.
pub const EXTENSIONS_USED: [&str; 2] = ["KHR_materials_clearcoat", "KHR_materials_ior"];

/// The glTF JSON material of `material`, named `name`, with the design's name and
/// the approximation's cost in `extras.coatlab`.
pub fn json_material(
    material: &RealTimeMaterial,
    name: &str,
    design_name: &str,
) -> Result<json::Material, GltfExportError> {
    let c = material.base_color;
    let extras = json::Value::from_iter([(
        "coatlab".to_owned(),
        json::Value::from_iter([
            ("design".to_owned(), json::Value::from(design_name)),
            (
                "delta_e00_conditions".to_owned(),
                json::Value::from(
                    "CIEDE2000 of this material (glTF BRDF with clearcoat, linear sRGB) against the \
                     design's multi-angle reading, D65, CIE 1931 2° observer, illumination 45°",
                ),
            ),
            (
                "delta_e00".to_owned(),
                json::serialize::to_value(&material.delta_e00)
                    .map_err(|e| GltfExportError::Extras(e.to_string()))?,
            ),
        ]),
    )]);
    let extras = json::extras::RawValue::from_string(extras.to_string())
        .map_err(|e| GltfExportError::Extras(e.to_string()))?;
    let clearcoat = json::Value::from_iter([
        ("clearcoatFactor".to_owned(), json::Value::from(1.0)),
        (
            "clearcoatRoughnessFactor".to_owned(),
            json::Value::from(material.clearcoat_roughness),
        ),
    ]);
    Ok(json::Material {
        name: Some(name.to_owned()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([
                c.red as f32,
                c.green as f32,
                c.blue as f32,
                1.0,
            ]),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(material.roughness as f32),
            ..Default::default()
        },
        extensions: Some(json::extensions::material::Material {
            ior: Some(json::extensions::material::Ior {
                ior: json::extensions::material::IndexOfRefraction(material.ior as f32),
                extras: None,
            }),
            others: [("KHR_materials_clearcoat".to_owned(), clearcoat)]
                .into_iter()
                .collect(),
            ..Default::default()
        }),
        extras: Some(extras),
        ..Default::default()
    })
}

/// The name the paint material gets in the file: it says "paint", so the loader's
/// heuristic picks it again.
pub fn paint_material_name(design: &PaintDesign) -> String {
    format!("Coatlab paint: {}", design.name)
}

/// `scene` as GLB with the design's material on its paint materials.
pub fn scene_glb(
    scene: &Scene,
    design: &PaintDesign,
    material: &RealTimeMaterial,
) -> Result<Vec<u8>, GltfExportError> {
    if scene.paint_materials.is_empty() {
        return Err(GltfExportError::NoPaintMaterial);
    }
    let options = GlbOptions {
        generator: super::CREATOR.to_owned(),
        mesh_name: "car".to_owned(),
        paint_material: Some(json_material(
            material,
            &paint_material_name(design),
            &design.name,
        )?),
        extensions_used: EXTENSIONS_USED.map(str::to_owned).to_vec(),
    };
    Ok(to_glb_with(scene, &options)?)
}
