//! Binary glTF (GLB) writer for generated scenes.

use crate::scene::Scene;

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

/// What a GLB holds besides the scene's geometry and simple materials.
#[derive(Debug, Clone)]
pub struct GlbOptions {
    /// `asset.generator`.
    pub generator: String,
    /// The name of the one mesh and its node.
    pub mesh_name: String,
    /// The material written for every material of [`Scene::paint_materials`]
    /// instead of its base colour (`None`: the scene's own).
    pub paint_material: Option<gltf::json::Material>,
    /// `extensionsUsed`: the extensions the paint material carries.
    pub extensions_used: Vec<String>,
}

/// Writes `scene` as binary glTF 2.0 (GLB): one mesh on one node, one primitive per
/// material with triangles, all sharing one POSITION and one NORMAL accessor (f32),
/// u32 indices; materials as metallic-roughness base colours with their names.
/// Deterministic: the same scene gives the same bytes.
pub fn to_glb(scene: &Scene) -> Result<Vec<u8>, GlbWriteError> {
    to_glb_with(
        scene,
        &GlbOptions {
            generator: "coatlab-core scene::car".to_owned(),
            mesh_name: "default car".to_owned(),
            paint_material: None,
            extensions_used: Vec::new(),
        },
    )
}

/// [`to_glb`] with the paint materials, the generator and the extensions of
/// `options` (textures and texture coordinates are not written).
pub fn to_glb_with(scene: &Scene, options: &GlbOptions) -> Result<Vec<u8>, GlbWriteError> {
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
            generator: Some(options.generator.clone()),
            ..Default::default()
        },
        extensions_used: options.extensions_used.clone(),
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
    let mut used = std::collections::BTreeSet::new();
    for (index, m) in scene.materials.iter().enumerate() {
        let paint = options
            .paint_material
            .as_ref()
            .filter(|_| scene.paint_materials.contains(&(index as u32)));
        // glTF keeps emissiveFactor in [0, 1]; the rest goes into the strength.
        let e = m.emissive;
        let emissive_strength = e.red.max(e.green).max(e.blue).max(1.0);
        let emissive_factor = [e.red, e.green, e.blue].map(|c| c / emissive_strength);
        let material = root.push(paint.cloned().unwrap_or_else(|| json::Material {
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
            emissive_factor: json::material::EmissiveFactor(emissive_factor),
            extensions: material_extensions(m, emissive_strength, &mut used),
            ..Default::default()
        }));
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
        name: Some(options.mesh_name.clone()),
        primitives,
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        name: Some(options.mesh_name.clone()),
        ..Default::default()
    });
    let scene_index = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene_index);
    // The paint material's extensions (options) and the other parts' (used).
    let mut extensions_used = std::mem::take(&mut root.extensions_used);
    extensions_used.extend(used.into_iter().map(str::to_owned));
    extensions_used.sort();
    extensions_used.dedup();
    root.extensions_used = extensions_used;

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

/// The glTF extensions that carry `m`'s glass and emission strength (`None`
/// without either), their names added to `used`.
fn material_extensions(
    m: &super::SceneMaterial,
    emissive_strength: f32,
    used: &mut std::collections::BTreeSet<&'static str>,
) -> Option<gltf::json::extensions::material::Material> {
    use gltf::json::extensions::material as ext;
    let p = &m.transparency;
    let mut extensions = ext::Material::default();
    if p.transmission > 0.0 {
        used.insert("KHR_materials_transmission");
        used.insert("KHR_materials_ior");
        extensions.transmission = Some(ext::Transmission {
            transmission_factor: ext::TransmissionFactor(p.transmission),
            ..Default::default()
        });
        extensions.ior = Some(ext::Ior {
            ior: ext::IndexOfRefraction(p.ior),
            ..Default::default()
        });
    }
    if emissive_strength > 1.0 {
        used.insert("KHR_materials_emissive_strength");
        extensions.emissive_strength = Some(ext::EmissiveStrength {
            emissive_strength: ext::EmissiveStrengthFactor(emissive_strength),
        });
    }
    (extensions.transmission.is_some() || extensions.emissive_strength.is_some())
        .then_some(extensions)
}
