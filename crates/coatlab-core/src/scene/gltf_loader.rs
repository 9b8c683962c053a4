//! glTF 2.0 scene loader: `.glb` and `.gltf` (external, embedded `data:` or GLB
//! buffers) flattened into one world-space [`TriangleMesh`], normalised to a car on
//! the ground, with the car-body material picked for the designed paint.
//!
//! The user manual is `docs/scenes.md`. In short:
//!
//! | step | what happens |
//! |---|---|
//! | parse | `Gltf::from_slice_without_validation`, then our own check of `extensionsRequired` against [`IGNORED_EXTENSIONS`], then the crate's JSON validation (minus its extension check) |
//! | buffers | GLB `BIN` chunk, files by URI relative to the `.gltf` (percent-decoded), base64 `data:` URIs |
//! | flatten | the default scene (or scene 0), world matrices (TRS or matrix), every instance of a mesh, winding flipped under negative determinants |
//! | normals | `NORMAL` by the inverse transpose, else area-weighted smooth normals |
//! | normalise | uniform scale so the larger horizontal (x, z) extent is [`TARGET_LENGTH_M`], then min y = 0 and x, z centred |
//! | paint | [`LoadOptions::paint_material`] by name, else the heuristic of [`choose_paint_material`] |
//! | orient | the car's triangles ([`super::framing`]) turned so it stands on +Y with its nose toward +Z ([`super::orientation`], or [`LoadOptions::front`]), then normalised again |
//! | cameras | each perspective camera of the default scene's nodes, carried through its node transforms and the same turn, scale and centring |
//!
//! Every accessor is read by our own bounds-checked reader (the crate's reader
//! panics on some malformed input), so bad files give a [`SceneError`], never a panic.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DAffine3, DMat3, DVec3};
use gltf::json;
use gltf::mesh::Mode;
use palette::LinSrgb;

use super::orientation::{Front, orient};
use super::texture::{TexelEncoding, Texture, TextureRef, UvTransform, WrapMode};
use super::transparency::{AlphaMode, Transparency};
use super::{Scene, SceneCamera, SceneMaterial, TriangleMesh, framing};

/// Length the model is scaled to: its larger horizontal extent, metres (a car's length).
pub const TARGET_LENGTH_M: f64 = 4.5;

/// Deepest node hierarchy accepted; deeper ones are taken for a cycle.
const MAX_NODE_DEPTH: usize = 256;

/// Most elements of a sparse accessor with no bufferView (all zeros but the sparse
/// ones): a guard against a tiny file asking for gigabytes.
const MAX_SPARSE_ONLY_COUNT: u64 = 1 << 24;

/// Extensions we understand well enough to ignore, even when a file requires them,
/// with what each means for us. Anything else in `extensionsRequired` is refused.
pub const IGNORED_EXTENSIONS: &[(&str, &str)] = &[
    (
        "KHR_materials_sheen",
        "sheen ignored: materials render as base colour and roughness",
    ),
    (
        "KHR_materials_specular",
        "specular ignored: materials use the glTF default F₀",
    ),
];

/// Extensions the loader and the tracer model (`docs/materials.md`): allowed in
/// `extensionsRequired`, used without a warning.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_texture_transform",
    "KHR_materials_emissive_strength",
    // On the parts that do not carry the design (the design has its own coat);
    // factors only, its textures are not read.
    "KHR_materials_clearcoat",
    // Its `ior` sets the dielectric's F₀ (render/microfacet) and the glass's.
    "KHR_materials_ior",
    // Glass (render/glass): thin panes and refracting volumes.
    "KHR_materials_transmission",
    "KHR_materials_volume",
];

/// Substrings (case-insensitive) of a material name that mark the car body.
pub const PAINT_NAME_HINTS: &[&str] = &[
    "paint",
    "body",
    "carpaint",
    "car_paint",
    "exterior",
    "livery",
    "shell",
];

/// Substrings (case-insensitive) of a material name that rule it out as the car body.
pub const NOT_PAINT_NAME_HINTS: &[&str] = &[
    "glass", "window", "tyre", "tire", "wheel", "rim", "chrome", "interior", "light", "lamp",
    "carbon", "fabric", "cloth", "ground", "floor",
];

/// How to load a scene.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Paint every material with exactly this name instead of the heuristic's choice.
    pub paint_material: Option<String>,
    /// The file axis the car's nose points along, instead of the orientation
    /// heuristic's choice ([`super::orientation`]).
    pub front: Option<Front>,
}

/// Why a scene could not be loaded. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file (or one it references) could not be read. The cause is part of
    /// the message, not a `source()`, as in every core error that names it: an
    /// error chain printed with `{:#}` would otherwise name it twice.
    #[error("cannot read {}: {error}", file.display())]
    Io {
        file: PathBuf,
        error: std::io::Error,
    },
    /// Not valid glTF 2.0: truncated GLB, invalid JSON, failed validation, cyclic nodes.
    #[error("{}: not a valid glTF 2.0 file: {details}", file.display())]
    Parse { file: PathBuf, details: String },
    /// `extensionsRequired` names an extension we cannot honour.
    #[error(
        "{}: requires the glTF extension {extension}, which Coatlab does not support{}",
        file.display(),
        compression_hint(extension)
    )]
    UnsupportedExtension { file: PathBuf, extension: String },
    /// A buffer's data is not there: a missing `.bin`, or no GLB `BIN` chunk.
    #[error("{}: buffer '{uri}' not found at {}", file.display(), path.display())]
    MissingBuffer {
        file: PathBuf,
        uri: String,
        path: PathBuf,
    },
    /// An accessor that does not fit its buffer, or has the wrong type or indices.
    #[error("{}: bad accessor: {details}", file.display())]
    BadAccessor { file: PathBuf, details: String },
    /// NaN or infinite vertex positions (in the file or after the node transforms).
    #[error(
        "{}: mesh '{mesh}' primitive {primitive} has non-finite (NaN or infinite) vertex positions",
        file.display()
    )]
    NonFinite {
        file: PathBuf,
        mesh: String,
        primitive: usize,
    },
    /// The scene has no triangles (or no extent).
    #[error("{}: the scene has no triangles to render{details}", file.display())]
    Empty { file: PathBuf, details: String },
    /// [`LoadOptions::paint_material`] names no material in the file.
    #[error(
        "{}: no material named '{name}'; available: {}",
        file.display(),
        quoted_list(available)
    )]
    UnknownMaterial {
        file: PathBuf,
        name: String,
        available: Vec<String>,
    },
}

fn compression_hint(extension: &str) -> &'static str {
    match extension {
        "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
            " (mesh compression: export the model uncompressed)"
        }
        _ => "",
    }
}

fn quoted_list(names: &[String]) -> String {
    let mut out = String::new();
    for (i, name) in names.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let _ = write!(out, "'{name}'");
    }
    out
}

/// Loads a `.glb` or `.gltf` file as a normalised [`Scene`].
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|error| SceneError::Io {
        file: path.to_path_buf(),
        error,
    })?;
    load_from_bytes(path, &bytes, options)
}

fn load_from_bytes(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene, SceneError> {
    let file = path.to_path_buf();
    let parse_err = |details: String| SceneError::Parse {
        file: file.clone(),
        details,
    };
    check_glb_header(bytes).map_err(parse_err)?;
    let gltf =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| parse_err(e.to_string()))?;
    let document = &gltf.document;
    let root = document.as_json();

    // Extensions: refuse what is required and unknown, before anything else reads data.
    let mut warnings = Vec::new();
    for ext in &root.extensions_required {
        if !IGNORED_EXTENSIONS.iter().any(|(name, _)| name == ext)
            && !SUPPORTED_EXTENSIONS.contains(&ext.as_str())
        {
            return Err(SceneError::UnsupportedExtension {
                file,
                extension: ext.clone(),
            });
        }
    }
    for ext in &root.extensions_used {
        if SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            continue;
        }
        match IGNORED_EXTENSIONS.iter().find(|(name, _)| name == ext) {
            Some((_, meaning)) => warnings.push(format!("{ext}: {meaning}")),
            None => warnings.push(format!("{ext}: optional extension not supported, ignored")),
        }
    }
    validate_json(root).map_err(|(details, accessor)| {
        if accessor {
            SceneError::BadAccessor {
                file: file.clone(),
                details,
            }
        } else {
            parse_err(details)
        }
    })?;

    let buffers = resolve_buffers(path, document, gltf.blob.as_deref())?;
    let reader = AccessorReader {
        file: &file,
        root,
        buffers: &buffers,
    };

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| SceneError::Empty {
            file: file.clone(),
            details: " (it has no scenes)".into(),
        })?;
    check_single_parents(&file, root)?;
    let mut instances = Vec::new();
    let mut camera_nodes = Vec::new();
    for node in scene.nodes() {
        collect_instances(&file, node, &IDENTITY, 0, &mut instances, &mut camera_nodes)?;
    }
    if document.animations().next().is_some() {
        warnings.push("animations ignored: the scene is shown at rest".into());
    }
    if document.skins().next().is_some() {
        warnings.push("skins ignored: skinned meshes are shown in their bind pose".into());
    }

    let mut materials = {
        let mut images = ImageSource {
            file: path,
            buffers: &buffers,
            cache: HashMap::new(),
        };
        document_materials(document, &mut images, &mut warnings)
    };
    let mut default_material = None;
    let mut mesh = TriangleMesh::default();
    let mut cache: HashMap<(usize, usize), Option<LocalPrimitive>> = HashMap::new();
    for (mesh_index, world_from_mesh) in &instances {
        let Some(gmesh) = document.meshes().nth(*mesh_index) else {
            continue;
        };
        let mesh_name = gmesh
            .name()
            .map_or_else(|| format!("mesh {mesh_index}"), str::to_owned);
        for prim in gmesh.primitives() {
            let key = (*mesh_index, prim.index());
            if let std::collections::hash_map::Entry::Vacant(slot) = cache.entry(key) {
                slot.insert(read_primitive(&reader, &prim, &mesh_name, &mut warnings)?);
            }
            let Some(local) = cache.get(&key).and_then(Option::as_ref) else {
                continue;
            };
            let material = match prim.material().index() {
                Some(m) => m as u32,
                None => *default_material.get_or_insert_with(|| {
                    materials.push(SceneMaterial {
                        name: "(glTF default material)".into(),
                        ..SceneMaterial::default()
                    });
                    (materials.len() - 1) as u32
                }),
            };
            append_instance(
                &mut mesh,
                local,
                world_from_mesh,
                material,
                &file,
                &mesh_name,
                prim.index(),
            )?;
        }
    }
    if mesh.triangles.is_empty() {
        let skipped = warnings.iter().filter(|w| w.contains("skipped")).count();
        let details = if skipped > 0 {
            format!(" ({skipped} primitives skipped: not triangles or no positions)")
        } else {
            String::new()
        };
        return Err(SceneError::Empty { file, details });
    }
    compact_vertices(&mut mesh);
    let empty = |details| SceneError::Empty {
        file: file.clone(),
        details,
    };
    let mut world_from_file = normalise(&mut mesh).map_err(empty)?;
    add_areas(&mesh, &mut materials);

    let paint_materials = match &options.paint_material {
        Some(name) => {
            let chosen: Vec<u32> = (0..materials.len() as u32)
                .filter(|&i| materials[i as usize].name == *name)
                .collect();
            if chosen.is_empty() {
                return Err(SceneError::UnknownMaterial {
                    file,
                    name: name.clone(),
                    available: materials.iter().map(|m| m.name.clone()).collect(),
                });
            }
            warnings.push(format!("paint material: '{name}' (chosen by name)"));
            chosen
        }
        None => match choose_paint_material_by(
            &materials,
            &visible_area_by_material(&mesh, materials.len()),
        ) {
            Some((index, reason)) => {
                warnings.push(format!(
                    "paint material: '{}' ({reason})",
                    materials[index].name
                ));
                vec![index as u32]
            }
            None => {
                warnings.push("paint material: none (no material has area)".into());
                Vec::new()
            }
        },
    };

    // Orient on the car alone: a drape or a floor would otherwise set the axes.
    let car = framing::car_triangles(&mesh, &paint_materials);
    let orientation = orient(&mesh, &car, options.front);
    let turn = orientation.world_from_file();
    if turn != DMat3::IDENTITY {
        for (p, n) in mesh.positions.iter_mut().zip(&mut mesh.normals) {
            *p = (turn * DVec3::from(p.map(f64::from))).as_vec3().into();
            *n = (turn * DVec3::from(n.map(f64::from))).as_vec3().into();
        }
        world_from_file =
            normalise(&mut mesh).map_err(empty)? * DAffine3::from_mat3(turn) * world_from_file;
        add_areas(&mesh, &mut materials);
    }
    warnings.push(format!("orientation: {}", orientation.reason));
    let cameras = scene_cameras(&camera_nodes, &world_from_file, &mut warnings);

    Ok(Scene {
        mesh,
        materials,
        paint_materials,
        warnings,
        cameras,
        orientation,
    })
}

/// Sets each material's area from the triangles using it.
fn add_areas(mesh: &TriangleMesh, materials: &mut [SceneMaterial]) {
    for m in materials.iter_mut() {
        m.area_m2 = 0.0;
    }
    for t in 0..mesh.triangle_count() {
        let m = mesh.triangle_material[t] as usize;
        materials[m].area_m2 += mesh.triangle_area(t);
    }
}

/// A camera node of the default scene: the camera, its node's world matrix (file
/// frame) and the node's name.
struct CameraNode<'a> {
    camera: gltf::Camera<'a>,
    world_from_node: Mat4,
    node_name: Option<String>,
}

/// The perspective cameras carried into the scene's world frame by
/// `world_from_file` (the loader's turn, scales and moves). A camera looks along
/// its node's −Z with +Y up (glTF 2.0, 3.10.1); orthographic cameras and those
/// whose node collapses the view are left out with a warning.
fn scene_cameras(
    nodes: &[CameraNode<'_>],
    world_from_file: &DAffine3,
    warnings: &mut Vec<String>,
) -> Vec<SceneCamera> {
    let mut cameras = Vec::new();
    for (i, node) in nodes.iter().enumerate() {
        let name = node
            .camera
            .name()
            .map(str::to_owned)
            .or_else(|| node.node_name.clone())
            .unwrap_or_else(|| format!("camera {i}"));
        let gltf::camera::Projection::Perspective(perspective) = node.camera.projection() else {
            warnings.push(format!(
                "camera '{name}': orthographic, left out (only perspective cameras are used)"
            ));
            continue;
        };
        let m = &node.world_from_node;
        let column = |c: usize| DVec3::new(m[c][0], m[c][1], m[c][2]);
        let node_to_world = |d: DVec3| world_from_file.transform_vector3(d);
        let position = world_from_file.transform_point3(column(3));
        let forward = node_to_world(-column(2)).normalize_or_zero();
        let up = node_to_world(column(1));
        // Only the part of up across the view shows in the image.
        let up = (up - up.dot(forward) * forward).normalize_or_zero();
        let fov_deg = f64::from(perspective.yfov()).to_degrees();
        let usable = position.is_finite()
            && forward != DVec3::ZERO
            && up != DVec3::ZERO
            && fov_deg > 0.0
            && fov_deg < 180.0;
        if !usable {
            warnings.push(format!(
                "camera '{name}': its node's transform or field of view gives no usable view, left out"
            ));
            continue;
        }
        cameras.push(SceneCamera {
            name,
            position: position.as_vec3().into(),
            forward: forward.as_vec3().into(),
            up: up.as_vec3().into(),
            vertical_fov_deg: fov_deg as f32,
        });
    }
    cameras
}

/// The heuristic for the car-body material by total area (see
/// [`choose_paint_material_by`]).
pub fn choose_paint_material(materials: &[SceneMaterial]) -> Option<(usize, String)> {
    let area: Vec<f32> = materials.iter().map(|m| m.area_m2).collect();
    choose_paint_material_by(materials, &area)
}

/// The heuristic for the car-body material, returning its index and the reason;
/// `score` is an area per material: the loader passes the area seen from outside
/// ([`visible_area_by_material`]), because real models hide large surfaces inside
/// (the Lamborghini's `CarBase`, 17.7 m², is mostly under the livery `Material.035`).
///
/// 1. Among materials whose name contains one of [`PAINT_NAME_HINTS`] and none of
///    [`NOT_PAINT_NAME_HINTS`] (case-insensitive), the one with the largest score.
/// 2. Otherwise the largest-score material whose name contains none of
///    [`NOT_PAINT_NAME_HINTS`].
/// 3. Otherwise the largest-score material.
///
/// Materials without area (unused) are never chosen.
pub fn choose_paint_material_by(
    materials: &[SceneMaterial],
    score: &[f32],
) -> Option<(usize, String)> {
    let score_of = |i: usize| score.get(i).copied().unwrap_or(0.0);
    let largest = |filter: &dyn Fn(&str) -> bool| {
        materials
            .iter()
            .enumerate()
            .filter(|(i, m)| {
                m.area_m2 > 0.0 && score_of(*i) > 0.0 && filter(&m.name.to_lowercase())
            })
            .max_by(|(a, _), (b, _)| score_of(*a).total_cmp(&score_of(*b)))
            .map(|(i, _)| i)
    };
    let excluded = |name: &str| NOT_PAINT_NAME_HINTS.iter().any(|h| name.contains(h));
    let paint_hint = |name: &str| PAINT_NAME_HINTS.iter().find(|h| name.contains(*h));
    if let Some(i) = largest(&|name| paint_hint(name).is_some() && !excluded(name)) {
        let lower = materials[i].name.to_lowercase();
        let hint = paint_hint(&lower).copied().unwrap_or_default();
        return Some((i, format!("name matches '{hint}', largest such area")));
    }
    if let Some(i) = largest(&|name| !excluded(name)) {
        return Some((
            i,
            format!(
                "no name matches a paint hint; largest area seen from outside, {:.2} m², among names not like glass, wheel, lights, …",
                score_of(i)
            ),
        ));
    }
    largest(&|_| true).map(|i| {
        (
            i,
            "every material looks like a non-body part; largest area seen from outside".into(),
        )
    })
}

/// Directions the model is looked at from in [`visible_area_by_material`].
const VISIBILITY_VIEWS: usize = 64;
/// Rays per view and side of the square grid.
const VISIBILITY_GRID: usize = 40;

/// Per material, the area a viewer outside the model sees of it: the projected
/// area hit first by parallel rays from `VISIBILITY_VIEWS` directions spread over
/// the sphere (those from below the ground left out), averaged over the views
/// (m²; a sphere of radius r scores πr²). Falls back to the total area when the
/// mesh cannot be traced.
pub fn visible_area_by_material(mesh: &TriangleMesh, material_count: usize) -> Vec<f32> {
    let total_area = || {
        let mut area = vec![0.0f32; material_count];
        for t in 0..mesh.triangle_count() {
            if let Some(a) = area.get_mut(mesh.triangle_material[t] as usize) {
                *a += mesh.triangle_area(t);
            }
        }
        area
    };
    let (Some((lo, hi)), Ok(accel)) = (mesh.bounds(), crate::accel::Accel::build(mesh)) else {
        return total_area();
    };
    let centre: [f32; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let radius =
        0.5 * ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    if !(radius > 0.0 && radius.is_finite()) {
        return total_area();
    }
    let cell = 2.0 * radius / VISIBILITY_GRID as f32;
    let mut seen = vec![0.0f64; material_count];
    let mut views = 0;
    for k in 0..VISIBILITY_VIEWS {
        // Fibonacci sphere: even coverage without a preferred axis.
        let y = 1.0 - 2.0 * (k as f32 + 0.5) / VISIBILITY_VIEWS as f32;
        if y < -0.2 {
            continue;
        }
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = k as f32 * 2.399_963_2;
        // The ray direction points from the viewer toward the model.
        let dir = [-r * phi.cos(), -y, -r * phi.sin()];
        let (u, v) = crate::paint::lobe::orthonormal_basis(dir);
        views += 1;
        for i in 0..VISIBILITY_GRID {
            for j in 0..VISIBILITY_GRID {
                let a = -radius + (i as f32 + 0.5) * cell;
                let b = -radius + (j as f32 + 0.5) * cell;
                let origin: [f32; 3] = std::array::from_fn(|c| {
                    centre[c] - 2.0 * radius * dir[c] + a * u[c] + b * v[c]
                });
                if let Some(hit) = accel.closest_hit(origin, dir, 4.0 * radius)
                    && let Some(s) =
                        seen.get_mut(mesh.triangle_material[hit.triangle as usize] as usize)
                {
                    *s += f64::from(cell * cell);
                }
            }
        }
    }
    seen.iter()
        .map(|&s| (s / f64::from(views.max(1))) as f32)
        .collect()
}

// ---------------------------------------------------------------------------
// Parsing and validation

/// The GLB header checks the `gltf` crate makes with arithmetic that can overflow.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    if bytes.len() < 20 {
        return Err(format!(
            "truncated GLB: {} bytes, shorter than its 20-byte header",
            bytes.len()
        ));
    }
    let declared = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    if declared < 20 {
        return Err(format!(
            "GLB header declares an impossible length of {declared} bytes"
        ));
    }
    if declared > bytes.len() {
        return Err(format!(
            "truncated GLB: the header declares {declared} bytes, the file has {}",
            bytes.len()
        ));
    }
    Ok(())
}

/// The crate's validation, minus its `extensionsRequired` check (done by us).
/// On failure: the joined messages, and whether they concern accessors.
fn validate_json(root: &json::Root) -> Result<(), (String, bool)> {
    use json::validation::{Error, Validate};
    let mut errors = Vec::new();
    root.validate(root, json::Path::new, &mut |path, error| {
        let path = path().to_string();
        if !(error == Error::Unsupported && path.starts_with("extensionsRequired")) {
            errors.push((path, error));
        }
    });
    if errors.is_empty() {
        return Ok(());
    }
    let accessor = errors
        .iter()
        .any(|(p, _)| p.contains("accessor") || p.contains("attributes") || p.contains("indices"));
    let details = errors
        .iter()
        .take(8)
        .map(|(p, e)| format!("{p}: {e}"))
        .collect::<Vec<_>>()
        .join("; ");
    Err((details, accessor))
}

// ---------------------------------------------------------------------------
// Buffers

fn resolve_buffers(
    path: &Path,
    document: &gltf::Document,
    blob: Option<&[u8]>,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let file = path.to_path_buf();
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| SceneError::MissingBuffer {
                    file: file.clone(),
                    uri: "(GLB binary chunk)".into(),
                    path: file.clone(),
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => decode_data_uri(uri)
                .map_err(|details| SceneError::Parse {
                    file: file.clone(),
                    details: format!("buffer {}: {details}", buffer.index()),
                })?,
            gltf::buffer::Source::Uri(uri) => {
                let buffer_path = dir.join(percent_decode(uri));
                match std::fs::read(&buffer_path) {
                    Ok(data) => data,
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                        return Err(SceneError::MissingBuffer {
                            file,
                            uri: uri.to_owned(),
                            path: buffer_path,
                        });
                    }
                    Err(error) => {
                        return Err(SceneError::Io {
                            file: buffer_path,
                            error,
                        });
                    }
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(SceneError::Parse {
                file,
                details: format!(
                    "buffer {} is {} bytes, its byteLength says {} (truncated?)",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                ),
            });
        }
        out.push(data);
    }
    Ok(out)
}

/// Decodes `%XX` escapes of a relative URI (invalid escapes stay as they are).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Decodes a `data:[<mediatype>];base64,<data>` URI.
fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let (header, payload) = uri
        .split_once(',')
        .ok_or_else(|| "data URI without a comma".to_string())?;
    if !header.ends_with(";base64") {
        return Err("data URI is not base64".into());
    }
    decode_base64(payload)
}

/// Standard base64 (RFC 4648), padding optional, whitespace ignored.
fn decode_base64(text: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let mut acc = 0u32;
    let mut bits = 0;
    for c in text.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return Err(format!("invalid base64 character {:?}", c as char)),
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

// ---------------------------------------------------------------------------
// Accessors

/// Reads accessors from the JSON with every range checked.
struct AccessorReader<'a> {
    file: &'a Path,
    root: &'a json::Root,
    buffers: &'a [Vec<u8>],
}

/// A byte range in a buffer with its element layout.
struct Strided<'a> {
    data: &'a [u8],
    stride: usize,
    count: usize,
}

impl AccessorReader<'_> {
    fn bad(&self, details: String) -> SceneError {
        SceneError::BadAccessor {
            file: self.file.to_path_buf(),
            details,
        }
    }

    /// The bytes of `count` elements of `element_size` bytes in view `view_index`.
    fn view_slice(
        &self,
        what: &str,
        view_index: usize,
        offset: u64,
        count: u64,
        element_size: usize,
    ) -> Result<Strided<'_>, SceneError> {
        let view = self
            .root
            .buffer_views
            .get(view_index)
            .ok_or_else(|| self.bad(format!("{what}: no bufferView {view_index}")))?;
        let buffer = self
            .buffers
            .get(view.buffer.value())
            .ok_or_else(|| self.bad(format!("{what}: no buffer {}", view.buffer.value())))?;
        let view_start = view.byte_offset.map_or(0, |o| o.0);
        let view_end = view_start
            .checked_add(view.byte_length.0)
            .filter(|&e| e <= buffer.len() as u64)
            .ok_or_else(|| {
                self.bad(format!(
                    "{what}: bufferView {view_index} runs past the end of buffer {}",
                    view.buffer.value()
                ))
            })?;
        let stride = view.byte_stride.map_or(element_size, |s| s.0);
        if stride < element_size {
            return Err(self.bad(format!(
                "{what}: byteStride {stride} is smaller than the element size {element_size}"
            )));
        }
        if count == 0 {
            return Err(self.bad(format!("{what}: count is 0")));
        }
        let end = (count - 1)
            .checked_mul(stride as u64)
            .and_then(|x| x.checked_add(offset))
            .and_then(|x| x.checked_add(element_size as u64))
            .filter(|&e| e <= view_end - view_start)
            .ok_or_else(|| {
                self.bad(format!(
                    "{what}: {count} elements from offset {offset} do not fit bufferView {view_index} ({} bytes)",
                    view_end - view_start
                ))
            })?;
        let start = (view_start + offset) as usize;
        Ok(Strided {
            data: &buffer[start..(view_start + end) as usize],
            stride,
            count: count as usize,
        })
    }

    /// Reads accessor `index` as `components`-vectors of f64 (flattened), converting
    /// integer components (normalised where flagged). Sparse accessors are applied.
    fn read(&self, index: usize, components: usize, what: &str) -> Result<Vec<f64>, SceneError> {
        use json::accessor::{ComponentType, Type};
        use json::validation::Checked;
        let what = format!("{what} (accessor {index})");
        let acc = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| self.bad(format!("{what}: no such accessor")))?;
        let Checked::Valid(ty) = acc.type_ else {
            return Err(self.bad(format!("{what}: invalid type")));
        };
        let Checked::Valid(json::accessor::GenericComponentType(ct)) = acc.component_type else {
            return Err(self.bad(format!("{what}: invalid componentType")));
        };
        let want = match components {
            1 => Type::Scalar,
            2 => Type::Vec2,
            3 => Type::Vec3,
            _ => Type::Vec4,
        };
        if ty != want {
            return Err(self.bad(format!("{what}: type {ty:?}, expected {want:?}")));
        }
        let count = acc.count.0;
        if count > (1 << 31) {
            return Err(self.bad(format!("{what}: count {count} is too large")));
        }
        let element_size = component_size(ct) * components;
        let mut values = match acc.buffer_view {
            Some(view) => {
                let offset = acc.byte_offset.map_or(0, |o| o.0);
                let s = self.view_slice(&what, view.value(), offset, count, element_size)?;
                decode_elements(&s, ct, components, acc.normalized)
            }
            None if acc.sparse.is_some() => {
                if count > MAX_SPARSE_ONLY_COUNT {
                    return Err(self.bad(format!(
                        "{what}: sparse accessor without a bufferView has {count} elements"
                    )));
                }
                vec![0.0; count as usize * components]
            }
            None => return Err(self.bad(format!("{what}: no bufferView and not sparse"))),
        };
        if let Some(sparse) = &acc.sparse {
            let n = sparse.count.0;
            let Checked::Valid(json::accessor::IndexComponentType(it)) =
                sparse.indices.component_type
            else {
                return Err(self.bad(format!("{what}: invalid sparse index type")));
            };
            if !matches!(
                it,
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32
            ) {
                return Err(self.bad(format!("{what}: sparse indices are {it:?}")));
            }
            let idx = self.view_slice(
                &what,
                sparse.indices.buffer_view.value(),
                sparse.indices.byte_offset.0,
                n,
                component_size(it),
            )?;
            let idx = decode_elements(&idx, it, 1, false);
            let vals = self.view_slice(
                &what,
                sparse.values.buffer_view.value(),
                sparse.values.byte_offset.0,
                n,
                element_size,
            )?;
            let vals = decode_elements(&vals, ct, components, acc.normalized);
            for (k, &i) in idx.iter().enumerate() {
                let i = i as usize;
                if i >= count as usize {
                    return Err(self.bad(format!(
                        "{what}: sparse index {i} out of range (count {count})"
                    )));
                }
                values[i * components..(i + 1) * components]
                    .copy_from_slice(&vals[k * components..(k + 1) * components]);
            }
        }
        Ok(values)
    }

    /// Reads an index accessor (unsigned integer scalars).
    fn read_indices(&self, index: usize) -> Result<Vec<u32>, SceneError> {
        use json::accessor::ComponentType;
        use json::validation::Checked;
        if let Some(acc) = self.root.accessors.get(index)
            && let Checked::Valid(json::accessor::GenericComponentType(ct)) = acc.component_type
            && !matches!(
                ct,
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32
            )
        {
            return Err(self.bad(format!(
                "indices (accessor {index}): component type {ct:?}, expected an unsigned integer"
            )));
        }
        Ok(self
            .read(index, 1, "indices")?
            .into_iter()
            .map(|i| i as u32)
            .collect())
    }
}

fn component_size(ct: json::accessor::ComponentType) -> usize {
    use json::accessor::ComponentType::*;
    match ct {
        I8 | U8 => 1,
        I16 | U16 => 2,
        U32 | F32 => 4,
    }
}

fn decode_elements(
    s: &Strided<'_>,
    ct: json::accessor::ComponentType,
    components: usize,
    normalized: bool,
) -> Vec<f64> {
    use json::accessor::ComponentType::*;
    let size = component_size(ct);
    let mut out = Vec::with_capacity(s.count * components);
    for e in 0..s.count {
        for c in 0..components {
            let at = e * s.stride + c * size;
            let b = &s.data[at..at + size];
            let v = match ct {
                I8 => {
                    let v = f64::from(b[0] as i8);
                    if normalized { (v / 127.0).max(-1.0) } else { v }
                }
                U8 => {
                    let v = f64::from(b[0]);
                    if normalized { v / 255.0 } else { v }
                }
                I16 => {
                    let v = f64::from(i16::from_le_bytes([b[0], b[1]]));
                    if normalized {
                        (v / 32767.0).max(-1.0)
                    } else {
                        v
                    }
                }
                U16 => {
                    let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
                    if normalized { v / 65535.0 } else { v }
                }
                U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            };
            out.push(v);
        }
    }
    out
}

mod materials;
use materials::{ImageSource, document_materials};

// ---------------------------------------------------------------------------
// Scene graph

/// glTF nodes form disjoint trees: no node may have two parents. Checked so that a
/// malformed file cannot make the traversal exponential.
fn check_single_parents(file: &Path, root: &json::Root) -> Result<(), SceneError> {
    let mut has_parent = vec![false; root.nodes.len()];
    for (parent, node) in root.nodes.iter().enumerate() {
        for child in node.children.iter().flatten() {
            let Some(slot) = has_parent.get_mut(child.value()) else {
                continue; // out-of-range indices are reported by validation
            };
            if std::mem::replace(slot, true) || child.value() == parent {
                return Err(SceneError::Parse {
                    file: file.to_path_buf(),
                    details: format!(
                        "node {} has more than one parent (or is its own child)",
                        child.value()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Column-major 4x4 matrix, `m[column][row]`, as glTF stores it.
type Mat4 = [[f64; 4]; 4];

const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

fn mat_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut out = [[0.0; 4]; 4];
    for (c, col) in out.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    out
}

fn collect_instances<'a>(
    file: &Path,
    node: gltf::Node<'a>,
    world_from_parent: &Mat4,
    depth: usize,
    out: &mut Vec<(usize, Mat4)>,
    cameras: &mut Vec<CameraNode<'a>>,
) -> Result<(), SceneError> {
    if depth > MAX_NODE_DEPTH {
        return Err(SceneError::Parse {
            file: file.to_path_buf(),
            details: format!(
                "node hierarchy deeper than {MAX_NODE_DEPTH} levels at node {} (a cycle?)",
                node.index()
            ),
        });
    }
    let local = node.transform().matrix().map(|c| c.map(f64::from));
    let world_from_node = mat_mul(world_from_parent, &local);
    if let Some(mesh) = node.mesh() {
        out.push((mesh.index(), world_from_node));
    }
    if let Some(camera) = node.camera() {
        cameras.push(CameraNode {
            camera,
            world_from_node,
            node_name: node.name().map(str::to_owned),
        });
    }
    for child in node.children() {
        collect_instances(file, child, &world_from_node, depth + 1, out, cameras)?;
    }
    Ok(())
}

/// A primitive's triangles in its mesh's frame.
struct LocalPrimitive {
    positions: Vec<[f64; 3]>,
    normals: Option<Vec<[f64; 3]>>,
    /// `TEXCOORD_0` and `TEXCOORD_1`, where present with one pair per vertex.
    texcoords: [Option<Vec<[f32; 2]>>; 2],
    triangles: Vec<[u32; 3]>,
}

fn read_primitive(
    reader: &AccessorReader<'_>,
    prim: &gltf::Primitive<'_>,
    mesh_name: &str,
    warnings: &mut Vec<String>,
) -> Result<Option<LocalPrimitive>, SceneError> {
    let label = format!("mesh '{mesh_name}' primitive {}", prim.index());
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        warnings.push(format!(
            "{label}: {mode:?} skipped (only triangles are rendered)"
        ));
        return Ok(None);
    }
    let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
        warnings.push(format!("{label}: no POSITION attribute, skipped"));
        return Ok(None);
    };
    let flat = reader.read(pos_acc.index(), 3, &format!("{label} POSITION"))?;
    let positions: Vec<[f64; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if positions.iter().flatten().any(|x| !x.is_finite()) {
        return Err(SceneError::NonFinite {
            file: reader.file.to_path_buf(),
            mesh: mesh_name.to_owned(),
            primitive: prim.index(),
        });
    }
    let normals = match prim.get(&gltf::Semantic::Normals) {
        Some(acc) => {
            let flat = reader.read(acc.index(), 3, &format!("{label} NORMAL"))?;
            let n: Vec<[f64; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let usable = n.len() == positions.len()
                && n.iter().all(|v| {
                    let len2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                    len2.is_finite() && len2 > 1e-12
                });
            if usable {
                Some(n)
            } else {
                warnings.push(format!(
                    "{label}: NORMAL has a wrong count, zero or non-finite vectors; normals computed instead"
                ));
                None
            }
        }
        None => None,
    };
    let mut texcoords = [None, None];
    for (set, slot) in texcoords.iter_mut().enumerate() {
        let Some(acc) = prim.get(&gltf::Semantic::TexCoords(set as u32)) else {
            continue;
        };
        let flat = reader.read(acc.index(), 2, &format!("{label} TEXCOORD_{set}"))?;
        let uv: Vec<[f32; 2]> = flat
            .chunks_exact(2)
            .map(|c| [c[0] as f32, c[1] as f32])
            .collect();
        if uv.len() == positions.len() && uv.iter().flatten().all(|x| x.is_finite()) {
            *slot = Some(uv);
        } else {
            warnings.push(format!(
                "{label}: TEXCOORD_{set} has a wrong count or non-finite values; textures read its texel (0, 0)"
            ));
        }
    }
    let indices = match prim.indices() {
        Some(acc) => reader.read_indices(acc.index())?,
        None => (0..positions.len() as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(reader.bad(format!(
            "{label}: index {bad} out of range ({} vertices)",
            positions.len()
        )));
    }
    let triangles = match mode {
        Mode::TriangleStrip => (2..indices.len())
            .map(|i| {
                if i % 2 == 0 {
                    [indices[i - 2], indices[i - 1], indices[i]]
                } else {
                    [indices[i - 2], indices[i], indices[i - 1]]
                }
            })
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect(),
        Mode::TriangleFan => (2..indices.len())
            .map(|i| [indices[i - 1], indices[i], indices[0]])
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect(),
        _ => {
            if indices.len() % 3 != 0 {
                warnings.push(format!(
                    "{label}: {} indices is not a multiple of 3; the last {} dropped",
                    indices.len(),
                    indices.len() % 3
                ));
            }
            indices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        }
    };
    Ok(Some(
        LocalPrimitive {
            positions,
            normals,
            texcoords,
            triangles,
        }
        .used_vertices_only(),
    ))
}

impl LocalPrimitive {
    /// The primitive with only the vertices its triangles use, in the order they
    /// are first used (the order the whole mesh's compaction gives them, so the
    /// loaded mesh is the same). Primitives that share one vertex accessor (a GLB
    /// with one vertex array for all its materials) would otherwise each hold, and
    /// add to the mesh, every vertex of it.
    fn used_vertices_only(mut self) -> Self {
        let Some(used) = renumber_by_first_use(&mut self.triangles, self.positions.len()) else {
            return self;
        };
        Self {
            positions: pick(&self.positions, &used),
            normals: self.normals.as_deref().map(|n| pick(n, &used)),
            texcoords: self
                .texcoords
                .each_ref()
                .map(|set| set.as_deref().map(|uv| pick(uv, &used))),
            triangles: self.triangles,
        }
    }
}

fn append_instance(
    mesh: &mut TriangleMesh,
    local: &LocalPrimitive,
    world_from_mesh: &Mat4,
    material: u32,
    file: &Path,
    mesh_name: &str,
    primitive: usize,
) -> Result<(), SceneError> {
    let m = world_from_mesh;
    let base = mesh.positions.len();
    if base + local.positions.len() > u32::MAX as usize {
        return Err(SceneError::Parse {
            file: file.to_path_buf(),
            details: "more than 2^32 vertices".into(),
        });
    }
    for (set, uv) in local.texcoords.iter().enumerate() {
        if let Some(uv) = uv {
            // Vertices of earlier primitives without this set read (0, 0).
            mesh.texcoords[set].resize(base, [0.0; 2]);
            mesh.texcoords[set].extend_from_slice(uv);
        }
    }
    for p in &local.positions {
        let w = [0, 1, 2].map(|r| m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r]);
        if w.iter()
            .any(|x| !x.is_finite() || x.abs() > f64::from(f32::MAX))
        {
            return Err(SceneError::NonFinite {
                file: file.to_path_buf(),
                mesh: mesh_name.to_owned(),
                primitive,
            });
        }
        mesh.positions.push(w.map(|x| x as f32));
    }
    // Linear part, its determinant and cofactor matrix (= det * inverse transpose).
    let a = |r: usize, c: usize| m[c][r];
    let cof = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1)
    };
    let det = (0..3).map(|c| a(0, c) * cof(0, c)).sum::<f64>();
    let flip = det < 0.0;
    let tri_base = mesh.triangles.len();
    for t in &local.triangles {
        let [i, j, k] = t.map(|v| v + base as u32);
        mesh.triangles
            .push(if flip { [i, k, j] } else { [i, j, k] });
        mesh.triangle_material.push(material);
    }
    let transformed = local.normals.as_ref().and_then(|normals| {
        let sign = if flip { -1.0 } else { 1.0 };
        normals
            .iter()
            .map(|n| {
                let w = [0, 1, 2].map(|r| sign * (0..3).map(|c| cof(r, c) * n[c]).sum::<f64>());
                normalised(w)
            })
            .collect::<Option<Vec<_>>>()
    });
    match transformed {
        Some(normals) => mesh.normals.extend(normals),
        None => {
            mesh.normals.resize(mesh.positions.len(), [0.0; 3]);
            smooth_normals(mesh, base, tri_base);
        }
    }
    Ok(())
}

fn normalised(v: [f64; 3]) -> Option<[f32; 3]> {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (len.is_finite() && len > 1e-30).then(|| v.map(|x| (x / len) as f32))
}

/// Area-weighted smooth normals for vertices from `vertex_base` on, from the
/// triangles from `triangle_base` on (one primitive instance).
fn smooth_normals(mesh: &mut TriangleMesh, vertex_base: usize, triangle_base: usize) {
    let mut acc = vec![DVec3::ZERO; mesh.positions.len() - vertex_base];
    for t in &mesh.triangles[triangle_base..] {
        let [a, b, c] = t.map(|i| DVec3::from(mesh.positions[i as usize].map(f64::from)));
        // Twice the area times the unit normal: area weighting for free.
        let n = (b - a).cross(c - a);
        for &i in t {
            acc[i as usize - vertex_base] += n;
        }
    }
    for (i, s) in acc.into_iter().enumerate() {
        mesh.normals[vertex_base + i] = normalised(s.to_array()).unwrap_or([0.0, 1.0, 0.0]);
    }
}

/// Renumbers the vertices of `triangles` (indices below `vertex_count`) in the
/// order the triangles first use them; for each new index, the old one. `None`
/// when every vertex is used and keeps its index.
fn renumber_by_first_use(triangles: &mut [[u32; 3]], vertex_count: usize) -> Option<Vec<usize>> {
    let mut remap = vec![u32::MAX; vertex_count];
    let mut used = Vec::new();
    for t in triangles {
        for v in t.iter_mut() {
            let slot = &mut remap[*v as usize];
            if *slot == u32::MAX {
                *slot = used.len() as u32;
                used.push(*v as usize);
            }
            *v = *slot;
        }
    }
    let unchanged = used.len() == vertex_count && used.iter().enumerate().all(|(i, &v)| i == v);
    (!unchanged).then_some(used)
}

/// The values of the vertices `used` (old indices, in their new order).
fn pick<T: Copy>(values: &[T], used: &[usize]) -> Vec<T> {
    used.iter().map(|&v| values[v]).collect()
}

/// Drops vertices no triangle uses (so the bounds are those of the geometry).
fn compact_vertices(mesh: &mut TriangleMesh) {
    for set in &mut mesh.texcoords {
        if !set.is_empty() {
            set.resize(mesh.positions.len(), [0.0; 2]);
        }
    }
    let Some(used) = renumber_by_first_use(&mut mesh.triangles, mesh.positions.len()) else {
        return;
    };
    mesh.positions = pick(&mesh.positions, &used);
    mesh.normals = pick(&mesh.normals, &used);
    for set in &mut mesh.texcoords {
        if !set.is_empty() {
            *set = pick(set, &used);
        }
    }
}

/// Scales uniformly so the larger horizontal extent is [`TARGET_LENGTH_M`], puts
/// min y on 0 and centres x and z; the transform it applied. Fails when the scene
/// has no horizontal extent.
fn normalise(mesh: &mut TriangleMesh) -> Result<DAffine3, String> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(p[k]));
            hi[k] = hi[k].max(f64::from(p[k]));
        }
    }
    let extent = (hi[0] - lo[0]).max(hi[2] - lo[2]);
    if !(extent.is_finite() && extent > 0.0) {
        return Err(" (its horizontal extent is zero)".into());
    }
    let scale = TARGET_LENGTH_M / extent;
    let centre = [0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])];
    for p in &mut mesh.positions {
        for k in 0..3 {
            p[k] = ((f64::from(p[k]) - centre[k]) * scale) as f32;
        }
    }
    Ok(
        DAffine3::from_scale(DVec3::splat(scale))
            * DAffine3::from_translation(-DVec3::from(centre)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_primitive_keeps_only_the_vertices_its_triangles_use_in_first_use_order() {
        // Five vertices of a shared array; the triangles use 4, 1, 3 (and 1 again).
        let at = |k: usize| [k as f64, 10.0 * k as f64, 0.0];
        let local = LocalPrimitive {
            positions: (0..5).map(at).collect(),
            normals: Some((0..5).map(|k| [0.0, 0.0, k as f64]).collect()),
            texcoords: [Some((0..5).map(|k| [k as f32, 0.5]).collect()), None],
            triangles: vec![[4, 1, 3], [1, 4, 3]],
        }
        .used_vertices_only();
        assert_eq!(local.positions, vec![at(4), at(1), at(3)]);
        assert_eq!(
            local.normals,
            Some(vec![[0.0, 0.0, 4.0], [0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])
        );
        assert_eq!(
            local.texcoords[0],
            Some(vec![[4.0, 0.5], [1.0, 0.5], [3.0, 0.5]])
        );
        assert_eq!(local.texcoords[1], None);
        assert_eq!(local.triangles, vec![[0, 1, 2], [1, 0, 2]]);
    }

    #[test]
    fn base64_round_trips_known_vectors() {
        assert_eq!(decode_base64("").unwrap(), b"");
        assert_eq!(decode_base64("Zg==").unwrap(), b"f");
        assert_eq!(decode_base64("Zm8=").unwrap(), b"fo");
        assert_eq!(decode_base64("Zm9v").unwrap(), b"foo");
        assert_eq!(decode_base64("Zm9vYmFy").unwrap(), b"foobar");
        assert!(decode_base64("Zm9*").is_err());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("x%2"), "x%2");
        assert_eq!(percent_decode("%e2%82%ac"), "€");
    }

    #[test]
    fn heuristic_prefers_paint_names_then_area() {
        let m = |name: &str, area: f32| SceneMaterial {
            name: name.into(),
            base_color: LinSrgb::new(0.5, 0.5, 0.5),
            roughness: 0.5,
            metallic: 0.0,
            area_m2: area,
            ..SceneMaterial::default()
        };
        let mats = [m("Glass", 10.0), m("CarPaint", 3.0), m("Body_2", 4.0)];
        assert_eq!(choose_paint_material(&mats).unwrap().0, 2);
        let mats = [m("Glass", 10.0), m("Fabric", 20.0), m("ToyCar", 3.0)];
        assert_eq!(choose_paint_material(&mats).unwrap().0, 2);
        let mats = [m("Glass", 10.0), m("Window", 3.0)];
        assert_eq!(choose_paint_material(&mats).unwrap().0, 0);
        assert!(choose_paint_material(&[m("unused", 0.0)]).is_none());
    }
}
