//! A textured material at a ray's hit: the texture coordinates interpolated over
//! the triangle, the level of detail from a ray cone, and the glTF
//! metallic-roughness parameters there (factors × textures).
//!
//! # Level of detail
//! A ray is taken as a cone whose width grows by [`PIXEL_SPREAD_RAD`] per metre
//! travelled (the angle one pixel subtends at preview resolutions: a 45° field of
//! view over about 540 rows), along the whole path, so a reflected or refracted
//! look-up is at least as blurred as a direct one at the same distance. At the hit
//! the cone's width in texture units is its width in metres times the triangle's
//! texture-space scale √(A_uv / A_world); the level is log2 of that in texels. A
//! distant or grazing bonnet decal then reads a coarser mip level instead of
//! aliasing. Grazing angles are not widened (the cone is taken perpendicular), a
//! small under-filtering that the pixel's own jitter averages out.
//!
//! # Normal maps
//! The tangent frame is the triangle's dP/du and −dP/dv (glTF's image rows run
//! down, its normal maps' green axis up), made orthogonal to the interpolated
//! normal; `TANGENT` attributes are not read. Tangent-space x and y are scaled by
//! the texture's `scale`, as glTF says.

use palette::LinSrgb;

use crate::render::microfacet::GltfParameters;
use crate::scene::texture::TextureRef;
use crate::scene::{SceneMaterial, TriangleMesh};

/// Growth of a ray cone's width per metre travelled, radians.
pub const PIXEL_SPREAD_RAD: f32 = 1.5e-3;

/// The material's parameters at one point, textures applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceParameters {
    /// What the BSDF is built from: base colour, metallic, roughness, occlusion,
    /// index and clear coat.
    pub bsdf: GltfParameters,
    /// Emitted radiance colour, linear sRGB.
    pub emission: LinSrgb<f32>,
    /// The normal the normal map gives, world space, unit; `None` without one.
    pub normal: Option<[f32; 3]>,
}

/// Where a ray met a triangle, for texture look-ups.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TexturePoint {
    /// Triangle index in the mesh.
    pub triangle: u32,
    /// Barycentric coordinates (u, v) of vertices 1 and 2.
    pub barycentric: [f32; 2],
    /// Unit shading normal there (the side the ray came from).
    pub shading_normal: [f32; 3],
    /// Width of the ray's cone there, metres.
    pub footprint_m: f32,
}

/// `material`'s parameters at `point` of `mesh`.
pub fn surface_parameters(
    material: &SceneMaterial,
    mesh: &TriangleMesh,
    point: &TexturePoint,
) -> SurfaceParameters {
    let corners = mesh
        .triangles
        .get(point.triangle as usize)
        .copied()
        .unwrap_or([0; 3]);
    let frame = TriangleFrame::new(mesh, corners, point);
    let sample = |texture: &TextureRef| frame.sample(texture);
    let base = material.base_color;
    let mut parameters = SurfaceParameters {
        bsdf: GltfParameters::factors(material),
        emission: material.emissive,
        normal: None,
    };
    let bsdf = &mut parameters.bsdf;
    if let Some(t) = &material.base_color_texture {
        let [r, g, b, _] = sample(t);
        bsdf.base_color = LinSrgb::new(base.red * r, base.green * g, base.blue * b);
    }
    if let Some(t) = &material.metallic_roughness_texture {
        let [_, g, b, _] = sample(t);
        bsdf.roughness = (material.roughness * g).clamp(0.0, 1.0);
        bsdf.metallic = (material.metallic * b).clamp(0.0, 1.0);
    }
    if let Some(t) = &material.occlusion_texture {
        let [r, ..] = sample(t);
        bsdf.occlusion = (1.0 + t.scale * (r - 1.0)).clamp(0.0, 1.0);
    }
    if let Some(t) = &material.emissive_texture {
        let [r, g, b, _] = sample(t);
        let e = material.emissive;
        parameters.emission = LinSrgb::new(e.red * r, e.green * g, e.blue * b);
    }
    if let Some(t) = &material.normal_texture {
        parameters.normal = frame.normal(t, sample(t));
    }
    parameters
}

/// `material`'s alpha at `point` of `mesh`: the base colour factor's alpha times
/// the base colour texture's (the part `alphaMode` reads; `surface_parameters`
/// leaves it out, as the opaque parts of a path never need it).
pub fn base_alpha(material: &SceneMaterial, mesh: &TriangleMesh, point: &TexturePoint) -> f32 {
    let alpha = material.transparency.alpha;
    match &material.base_color_texture {
        Some(t) => {
            let corners = mesh
                .triangles
                .get(point.triangle as usize)
                .copied()
                .unwrap_or([0; 3]);
            alpha * TriangleFrame::new(mesh, corners, point).sample(t)[3]
        }
        None => alpha,
    }
}

/// A triangle's texture coordinates at a point and their scale per set.
struct TriangleFrame {
    /// Per set: (u, v) at the point, texture units per metre, dP/du and dP/dv.
    sets: [Option<SetFrame>; 2],
    normal: [f32; 3],
    footprint_m: f32,
}

#[derive(Clone, Copy)]
struct SetFrame {
    uv: [f32; 2],
    units_per_m: f32,
    dp_du: [f32; 3],
    dp_dv: [f32; 3],
}

impl TriangleFrame {
    fn new(mesh: &TriangleMesh, corners: [u32; 3], point: &TexturePoint) -> Self {
        let p = corners.map(|i| mesh.positions.get(i as usize).copied().unwrap_or([0.0; 3]));
        let e1 = sub(p[1], p[0]);
        let e2 = sub(p[2], p[0]);
        let world_area2 = length(cross(e1, e2));
        let [bu, bv] = point.barycentric;
        let bw = 1.0 - bu - bv;
        let sets = std::array::from_fn(|k| {
            let set = &mesh.texcoords[k];
            let t = corners.map(|i| set.get(i as usize).copied());
            let t = [t[0]?, t[1]?, t[2]?];
            let uv = [0, 1].map(|c| bw * t[0][c] + bu * t[1][c] + bv * t[2][c]);
            let d1 = [t[1][0] - t[0][0], t[1][1] - t[0][1]];
            let d2 = [t[2][0] - t[0][0], t[2][1] - t[0][1]];
            let uv_area2 = d1[0] * d2[1] - d2[0] * d1[1];
            let units_per_m = if world_area2 > 0.0 {
                (uv_area2.abs() / world_area2).sqrt()
            } else {
                0.0
            };
            // dP/du and dP/dv from the two edges (zero when the map is degenerate).
            let r = if uv_area2 != 0.0 { 1.0 / uv_area2 } else { 0.0 };
            let dp_du = std::array::from_fn(|c| (e1[c] * d2[1] - e2[c] * d1[1]) * r);
            let dp_dv = std::array::from_fn(|c| (e2[c] * d1[0] - e1[c] * d2[0]) * r);
            Some(SetFrame {
                uv,
                units_per_m: if units_per_m.is_finite() {
                    units_per_m
                } else {
                    0.0
                },
                dp_du,
                dp_dv,
            })
        });
        Self {
            sets,
            normal: point.shading_normal,
            footprint_m: point.footprint_m,
        }
    }

    /// The filtered texel of `texture` (RGBA); texel (0, 0)'s neighbourhood when the
    /// mesh lacks the texture's coordinate set.
    fn sample(&self, texture: &TextureRef) -> [f32; 4] {
        let set = self.sets.get(texture.texcoord as usize).copied().flatten();
        let (uv, units_per_m) = set.map_or(([0.0; 2], 0.0), |s| (s.uv, s.units_per_m));
        let (w, h) = texture.texture.size();
        let texels = self.footprint_m * units_per_m * w.max(h) as f32;
        let lod = if texels > 0.0 { texels.log2() } else { 0.0 };
        texture.sample(uv, lod)
    }

    /// The normal a normal-map texel gives.
    fn normal(&self, texture: &TextureRef, texel: [f32; 4]) -> Option<[f32; 3]> {
        let set = self
            .sets
            .get(texture.texcoord as usize)
            .copied()
            .flatten()?;
        let n = self.normal;
        // Gram–Schmidt: the tangent across the normal, the bitangent across both.
        let t = normalise(sub(set.dp_du, scale(n, dot(set.dp_du, n))))?;
        let up = scale(set.dp_dv, -1.0);
        let b = sub(sub(up, scale(n, dot(up, n))), scale(t, dot(up, t)));
        let b = normalise(b).unwrap_or_else(|| cross(n, t));
        let x = (2.0 * texel[0] - 1.0) * texture.scale;
        let y = (2.0 * texel[1] - 1.0) * texture.scale;
        let z = (2.0 * texel[2] - 1.0).max(0.0);
        normalise(std::array::from_fn(|c| x * t[c] + y * b[c] + z * n[c]))
    }
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f32; 3], s: f32) -> [f32; 3] {
    a.map(|x| x * s)
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn length(a: [f32; 3]) -> f32 {
    dot(a, a).sqrt()
}

fn normalise(a: [f32; 3]) -> Option<[f32; 3]> {
    let l = length(a);
    (l.is_finite() && l > 1e-12).then(|| scale(a, 1.0 / l))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::scene::texture::{TexelEncoding, Texture};

    /// One triangle in the xz plane (normal +y) mapped to the unit square's lower
    /// half, 1 m on a side.
    fn quad_half() -> TriangleMesh {
        TriangleMesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
            normals: vec![[0.0, 1.0, 0.0]; 3],
            triangles: vec![[0, 1, 2]],
            triangle_material: vec![0],
            texcoords: [vec![[0.0, 1.0], [1.0, 1.0], [0.0, 0.0]], Vec::new()],
        }
    }

    fn point(barycentric: [f32; 2], footprint_m: f32) -> TexturePoint {
        TexturePoint {
            triangle: 0,
            barycentric,
            shading_normal: [0.0, 1.0, 0.0],
            footprint_m,
        }
    }

    fn two_tone() -> Arc<Texture> {
        // Left half black, right half white (sRGB), 64 × 64.
        let texels = (0..64 * 64)
            .map(|i| {
                if i % 64 < 32 {
                    [0, 0, 0, 255]
                } else {
                    [255; 4]
                }
            })
            .collect();
        Arc::new(Texture::from_rgba8(
            "two-tone",
            64,
            64,
            texels,
            TexelEncoding::Srgb,
        ))
    }

    #[test]
    fn base_colour_texture_multiplies_the_factor_where_the_ray_hits() {
        let material = SceneMaterial {
            base_color: LinSrgb::new(0.5, 1.0, 1.0),
            base_color_texture: Some(TextureRef::new(two_tone())),
            ..SceneMaterial::default()
        };
        let mesh = quad_half();
        // u = barycentric[0]: 0.8 lies in the white half, 0.1 in the black.
        let white = surface_parameters(&material, &mesh, &point([0.8, 0.1], 0.0));
        assert!((white.bsdf.base_color.red - 0.5).abs() < 1e-4, "{white:?}");
        assert!((white.bsdf.base_color.green - 1.0).abs() < 1e-4);
        let black = surface_parameters(&material, &mesh, &point([0.1, 0.1], 0.0));
        assert!(black.bsdf.base_color.green < 1e-4, "{black:?}");
        // A footprint as wide as the texture reads the average: linear 0.5.
        let far = surface_parameters(&material, &mesh, &point([0.1, 0.1], 5.0));
        assert!((far.bsdf.base_color.green - 0.5).abs() < 0.02, "{far:?}");
    }

    #[test]
    fn a_flat_normal_map_keeps_the_normal_and_a_tilted_one_tilts_it() {
        let flat = Arc::new(Texture::from_rgba8(
            "flat",
            1,
            1,
            vec![[128, 128, 255, 255]],
            TexelEncoding::Linear,
        ));
        let tilted = Arc::new(Texture::from_rgba8(
            "tilted",
            1,
            1,
            vec![[255, 128, 128, 255]],
            TexelEncoding::Linear,
        ));
        let mesh = quad_half();
        let normal_of = |texture| {
            let material = SceneMaterial {
                normal_texture: Some(TextureRef::new(texture)),
                ..SceneMaterial::default()
            };
            surface_parameters(&material, &mesh, &point([0.3, 0.3], 0.0))
                .normal
                .expect("a normal")
        };
        let n = normal_of(flat);
        assert!(n[1] > 0.999, "{n:?}");
        // +x in tangent space is dP/du: world +x here.
        let n = normal_of(tilted);
        assert!(n[0] > 0.9 && n[1].abs() < 0.2, "{n:?}");
    }
}
