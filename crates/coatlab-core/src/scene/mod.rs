//! Scenes for the car-body preview: triangle geometry in world space (metres, Y up,
//! the car on the ground plane y = 0) and the materials it carries.
//!
//! Everything is flattened on load: node hierarchies and instances become one
//! triangle list in world space, which is what the BVH and the tracer consume.

use palette::LinSrgb;

pub mod car;
pub mod framing;
pub mod gltf_loader;
pub mod orientation;
pub mod texture;
pub mod transparency;

use crate::accel::Triangles;
use texture::TextureRef;

/// Triangle geometry in world space, with smooth (per-vertex) normals.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions, metres.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals (shading normals).
    pub normals: Vec<[f32; 3]>,
    /// Vertex indices of each triangle, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Material of each triangle: an index into [`Scene::materials`].
    pub triangle_material: Vec<u32>,
    /// Texture coordinates `TEXCOORD_0` and `TEXCOORD_1` per vertex; each either
    /// empty (no textured material uses the set) or as long as `positions`.
    pub texcoords: [Vec<[f32; 2]>; 2],
}

impl TriangleMesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Axis-aligned bounds (min, max); `None` for an empty mesh.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = *self.positions.first()?;
        let mut lo = first;
        let mut hi = first;
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Some((lo, hi))
    }

    /// Area of triangle `t`, square metres.
    pub fn triangle_area(&self, t: usize) -> f32 {
        let [a, b, c] = self.triangles[t].map(|i| self.positions[i as usize]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let cross = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        0.5 * (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt()
    }
}

/// The mesh's triangles as the acceleration structure takes them (positions and
/// vertex indices, borrowed): `Accel::build(&mesh)`.
impl<'a> From<&'a TriangleMesh> for Triangles<'a> {
    fn from(mesh: &'a TriangleMesh) -> Triangles<'a> {
        Triangles::new(&mesh.positions, &mesh.triangles)
    }
}

/// A non-paint material as the scene file gives it: glTF's metallic-roughness
/// description with its textures, reduced to what the tracer models
/// (`render::material` and `docs/materials.md` say how each part is rendered).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMaterial {
    /// Name in the file (or a generated one for unnamed materials).
    pub name: String,
    /// Base colour (glTF `baseColorFactor`, linear sRGB), each component in [0, 1].
    pub base_color: LinSrgb<f32>,
    /// glTF roughness in [0, 1].
    pub roughness: f32,
    /// glTF metallic in [0, 1].
    pub metallic: f32,
    /// Total area of the triangles using it in the normalised scene, m².
    pub area_m2: f32,
    /// Base-colour texture (sRGB-decoded; multiplies `base_color`).
    pub base_color_texture: Option<TextureRef>,
    /// Metallic (blue) and roughness (green) texture, multiplying the factors.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Tangent-space normal map; its `scale` scales the x and y of the normal.
    pub normal_texture: Option<TextureRef>,
    /// Ambient occlusion (red); its `scale` is glTF's `strength`.
    pub occlusion_texture: Option<TextureRef>,
    /// Emitted radiance colour, linear sRGB (`emissiveFactor` × KHR_materials_emissive_strength;
    /// 1 is the luminance of a white sky of radiance 1).
    pub emissive: LinSrgb<f32>,
    /// Emissive texture (sRGB-decoded; multiplies `emissive`).
    pub emissive_texture: Option<TextureRef>,
    /// Index of refraction of the dielectric part (`KHR_materials_ior`, default
    /// 1.5); sets its F₀ only.
    pub ior: f32,
    /// `KHR_materials_clearcoat`'s `clearcoatFactor` in [0, 1] (0: no coat).
    pub clearcoat: f32,
    /// `KHR_materials_clearcoat`'s `clearcoatRoughnessFactor` in [0, 1].
    pub clearcoat_roughness: f32,
    /// Alpha and glass.
    pub transparency: transparency::Transparency,
}

/// A glTF material with no properties set: white, metallic 1, roughness 1, no
/// textures, no emission, η = 1.5, no clear coat (the glTF 2.0 defaults), with no area yet.
impl Default for SceneMaterial {
    fn default() -> Self {
        Self {
            name: String::new(),
            base_color: LinSrgb::new(1.0, 1.0, 1.0),
            roughness: 1.0,
            metallic: 1.0,
            area_m2: 0.0,
            base_color_texture: None,
            metallic_roughness_texture: None,
            normal_texture: None,
            occlusion_texture: None,
            emissive: LinSrgb::new(0.0, 0.0, 0.0),
            emissive_texture: None,
            ior: 1.5,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            transparency: transparency::Transparency::default(),
        }
    }
}

impl SceneMaterial {
    /// Whether any texture modulates it.
    pub fn has_textures(&self) -> bool {
        self.textures().next().is_some()
    }

    /// The textures it uses.
    pub fn textures(&self) -> impl Iterator<Item = &TextureRef> {
        [
            &self.base_color_texture,
            &self.metallic_roughness_texture,
            &self.normal_texture,
            &self.occlusion_texture,
            &self.emissive_texture,
        ]
        .into_iter()
        .flatten()
    }

    /// Whether it emits light.
    pub fn is_emissive(&self) -> bool {
        let e = self.emissive;
        e.red > 0.0 || e.green > 0.0 || e.blue > 0.0
    }
}

/// A loaded (or generated) scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    /// All geometry, world space.
    pub mesh: TriangleMesh,
    /// Materials referenced by `mesh.triangle_material`.
    pub materials: Vec<SceneMaterial>,
    /// Which materials get the designed paint.
    pub paint_materials: Vec<u32>,
    /// Problems that did not stop the load (ignored optional extensions, …).
    pub warnings: Vec<String>,
    /// The file's own cameras, in the scene's world frame (empty for the built-in car).
    pub cameras: Vec<SceneCamera>,
    /// How the file's axes were turned to the scene's convention (Y up, nose +Z).
    pub orientation: orientation::Orientation,
}

/// A perspective camera the scene file carries, moved with the geometry into the
/// scene's world frame (the loader's rotation, scale and centring).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneCamera {
    /// Name of the camera (or of its node; a generated one when both are unnamed).
    pub name: String,
    /// Position, m, world.
    pub position: [f32; 3],
    /// Unit view direction, world (the camera node's −Z).
    pub forward: [f32; 3],
    /// Unit direction that appears upward in the image, world (the node's +Y).
    pub up: [f32; 3],
    /// Vertical field of view, degrees (glTF `yfov`).
    pub vertical_fov_deg: f32,
}
