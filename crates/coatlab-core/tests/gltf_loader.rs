//! The glTF loader on the real test models (`shared/testdata/gltf`, read in place)
//! and on small synthetic files, good and bad, written to a temporary folder.

use std::path::{Path, PathBuf};

use coatlab_core::scene::Scene;
use coatlab_core::scene::gltf_loader::{LoadOptions, SceneError, TARGET_LENGTH_M, load};
use coatlab_core::scene::orientation::Front;

#[path = "support/gltf_testdata.rs"]
mod gltf_testdata;
use gltf_testdata::{base64, glb, testdata};

/// Checks that `$result` is an error matching `$pattern` (showing it where not);
/// the error.
macro_rules! assert_refused {
    ($result:expr, $pattern:pat) => {{
        let err = $result.unwrap_err();
        assert!(matches!(err, $pattern), "{err}");
        err
    }};
}

/// The test model at `rel`, checked against [`check_scene`]'s invariants and to
/// hold `triangles` triangles; `None` where the test models are absent.
fn load_model(rel: &str, triangles: usize) -> Option<Scene> {
    let path = testdata()?.join(rel);
    match load(&path, &LoadOptions::default()) {
        Ok(scene) => {
            check_scene(&scene, rel);
            assert_eq!(scene.mesh.triangle_count(), triangles, "{rel}");
            Some(scene)
        }
        Err(e) => panic!("{rel}: {e}"),
    }
}

/// How loading the test model at `rel` fails, checked to name the file; `None`
/// where the test models are absent.
fn refusal(rel: &str) -> Option<SceneError> {
    let path = testdata()?.join(rel);
    let err = load(&path, &LoadOptions::default()).unwrap_err();
    let file = rel.rsplit('/').next().unwrap_or(rel);
    assert!(err.to_string().contains(file), "{err}");
    Some(err)
}

/// Whether one of the loader's warnings on `scene` starts with `prefix`.
fn warns_with(scene: &Scene, prefix: &str) -> bool {
    scene.warnings.iter().any(|w| w.starts_with(prefix))
}

/// Whether one of the loader's warnings on `scene` contains `text`.
fn warns_about(scene: &Scene, text: &str) -> bool {
    scene.warnings.iter().any(|w| w.contains(text))
}

fn paint_names(scene: &Scene) -> Vec<&str> {
    scene
        .paint_materials
        .iter()
        .map(|&i| scene.materials[i as usize].name.as_str())
        .collect()
}

/// Invariants every loaded scene keeps: on the ground, centred, 4.5 m long,
/// unit normals, valid indices and materials, areas that add up.
fn check_scene(scene: &Scene, what: &str) {
    let mesh = &scene.mesh;
    assert_eq!(mesh.positions.len(), mesh.normals.len(), "{what}");
    assert_eq!(mesh.triangles.len(), mesh.triangle_material.len(), "{what}");
    let (lo, hi) = mesh.bounds().expect("non-empty");
    assert!(lo[1].abs() < 1e-5, "{what}: min y = {}", lo[1]);
    let extent = (hi[0] - lo[0]).max(hi[2] - lo[2]);
    assert!(
        (f64::from(extent) - TARGET_LENGTH_M).abs() < 1e-4,
        "{what}: extent {extent}"
    );
    assert!((lo[0] + hi[0]).abs() < 1e-4, "{what}: x not centred");
    assert!((lo[2] + hi[2]).abs() < 1e-4, "{what}: z not centred");
    for n in &mesh.normals {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-4, "{what}: normal length {len}");
    }
    let vertices = mesh.positions.len() as u32;
    assert!(mesh.triangles.iter().flatten().all(|&i| i < vertices));
    let materials = scene.materials.len() as u32;
    assert!(mesh.triangle_material.iter().all(|&m| m < materials));
    let total: f64 = (0..mesh.triangle_count())
        .map(|t| f64::from(mesh.triangle_area(t)))
        .sum();
    let by_material: f64 = scene.materials.iter().map(|m| f64::from(m.area_m2)).sum();
    assert!((total - by_material).abs() <= 1e-3 * total, "{what}: areas");
    assert!(
        !scene.paint_materials.is_empty(),
        "{what}: no paint material"
    );
    assert!(
        warns_with(scene, "paint material:"),
        "{what}: no reason given for the paint choice"
    );
}

// ---------------------------------------------------------------------------
// Real models

#[test]
fn cesium_milk_truck_instances_its_wheels() {
    let Some(scene) = load_model("CesiumMilkTruck/CesiumMilkTruck.glb", 3624) else {
        return;
    };
    // Yup2Zup and the hierarchy leave the truck's length along z, upright.
    let (lo, hi) = scene.mesh.bounds().unwrap();
    assert!(hi[2] - lo[2] > hi[0] - lo[0], "length along z");
    assert!(
        hi[1] - lo[1] < hi[2] - lo[2],
        "upright, not standing on its tail"
    );
    assert_eq!(paint_names(&scene), ["truck"]);
}

#[test]
fn toy_car_with_external_bin_is_scaled_up() {
    let Some(scene) = load_model("ToyCar/ToyCar.gltf", 108_936) else {
        return;
    };
    assert_eq!(paint_names(&scene), ["ToyCar"]);
    // Its clear coat is read (on the parts that do not carry the design), not warned about.
    assert!(!warns_with(&scene, "KHR_materials_clearcoat"));
    // Its clear-coat texture is not read, and says so.
    assert!(warns_about(
        &scene,
        "'ToyCar': KHR_materials_clearcoat clearcoatTexture not read"
    ));
    // Its textures are decoded (PNG files next to the .gltf), none refused.
    let toy = scene
        .materials
        .iter()
        .find(|m| m.name == "ToyCar")
        .expect("the ToyCar material");
    assert!(toy.base_color_texture.is_some() && toy.normal_texture.is_some());
    assert!(toy.metallic_roughness_texture.is_some() && toy.emissive_texture.is_some());
    assert!(
        !warns_about(&scene, "texture not used"),
        "{:?}",
        scene.warnings
    );
    assert!(!scene.mesh.texcoords[0].is_empty());
}

#[test]
fn clear_coat_car_paint_loads_despite_its_required_extensions() {
    let Some(scene) = load_model("ClearCoatCarPaint/ClearCoatCarPaint.glb", 3072) else {
        return;
    };
    assert_eq!(scene.paint_materials, [0]);
    assert!(
        !warns_with(&scene, "KHR_materials_clearcoat"),
        "{:?}",
        scene.warnings
    );
    let m = &scene.materials[0];
    assert!((m.base_color.red - 0.7).abs() < 1e-6 && m.base_color.green == 0.0);
    assert!((m.roughness - 0.4).abs() < 1e-6 && (m.metallic - 0.3).abs() < 1e-6);
    // KHR_materials_clearcoat's factors (1 and 0 in the file); no KHR_materials_ior: 1.5.
    assert_eq!((m.clearcoat, m.clearcoat_roughness), (1.0, 0.0));
    assert_eq!(m.ior, 1.5);
}

#[test]
fn lamborghini_is_normalised_to_a_car_length() {
    let Some(scene) = load_model("LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb", 145_917) else {
        return;
    };
    assert_eq!(scene.materials.len(), 45);
    // No material is named like paint: the largest non-excluded area seen from
    // outside wins (the livery; CarBase is larger but mostly hidden under it).
    assert_eq!(paint_names(&scene), ["Material.035"]);

    // The livery can be chosen by name.
    let path = testdata()
        .unwrap()
        .join("LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb");
    let options = LoadOptions {
        paint_material: Some("Material.035".into()),
        ..LoadOptions::default()
    };
    let scene = load(&path, &options).unwrap();
    assert_eq!(paint_names(&scene), ["Material.035"]);
}

#[test]
fn draco_is_refused_by_name() {
    let Some(err) = refusal("CesiumMilkTruck/glTF-Draco/CesiumMilkTruck.gltf") else {
        return;
    };
    assert!(
        matches!(&err, SceneError::UnsupportedExtension { extension, .. } if extension == "KHR_draco_mesh_compression")
    );
    assert!(
        err.to_string().contains("KHR_draco_mesh_compression"),
        "{err}"
    );
}

#[test]
fn meshopt_is_refused_by_name() {
    let Some(err) = refusal("LamborghiniHuracanGT3/LamborghiniHuracanGT3.meshopt.glb") else {
        return;
    };
    assert!(err.to_string().contains("EXT_meshopt_compression"), "{err}");
}

#[test]
fn truncated_real_glb_is_a_parse_error() {
    let Some(dir) = testdata() else { return };
    let bytes = std::fs::read(dir.join("CesiumMilkTruck/CesiumMilkTruck.glb")).unwrap();
    let tmp = TempDir::new("truncated_real");
    for cut in [0, 5, 12, 19, 20, 100, bytes.len() / 2, bytes.len() - 1] {
        let path = tmp.write("cut.glb", &bytes[..cut]);
        let err = load(&path, &LoadOptions::default()).unwrap_err();
        assert!(matches!(err, SceneError::Parse { .. }), "cut {cut}: {err}");
    }
}

// ---------------------------------------------------------------------------
// Synthetic files

/// A folder under the target directory, emptied on creation.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("coatlab-gltf-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }

    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Binary payload: `positions` (f32 vec3) then u16 `indices`, padded to 4 bytes.
fn payload(positions: &[[f32; 3]], indices: &[u16]) -> Vec<u8> {
    let mut bin = Vec::new();
    for p in positions {
        for x in p {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in indices {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    bin
}

/// glTF JSON for one mesh ("Body", material "CarPaint" and "Glass") with the
/// given positions and indices in buffer 0; `extra` is merged into the root.
fn gltf_json(
    positions: &[[f32; 3]],
    indices: &[u16],
    buffer_uri: Option<&str>,
    nodes: &str,
    mode: u32,
    extra: &str,
) -> String {
    let bin_len = payload(positions, indices).len();
    let pos_len = positions.len() * 12;
    let (lo, hi) = positions.iter().fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        },
    );
    let minmax = if lo.iter().chain(&hi).all(|x| x.is_finite()) {
        format!(r#","min":{lo:?},"max":{hi:?}"#)
    } else {
        String::new()
    };
    let uri = buffer_uri.map_or(String::new(), |u| format!(r#","uri":"{u}""#));
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":{nodes}}}],
"nodes":[{{"mesh":0,"name":"n0"}},{{"mesh":0,"translation":[5,0,0]}},{{"mesh":0,"scale":[-1,1,1]}},{{"children":[0]}}],
"meshes":[{{"name":"Body","primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0,"mode":{mode}}}]}}],
"materials":[{{"name":"CarPaint","pbrMetallicRoughness":{{"baseColorFactor":[0.8,0.1,0.1,1],"roughnessFactor":0.3,"metallicFactor":0}}}},{{"name":"Glass"}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{np},"type":"VEC3"{minmax}}},{{"bufferView":1,"componentType":5123,"count":{ni},"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}},{{"buffer":0,"byteOffset":{pos_len},"byteLength":{il}}}],
"buffers":[{{"byteLength":{bin_len}{uri}}}]{extra}}}"#,
        np = positions.len(),
        ni = indices.len(),
        il = indices.len() * 2,
    )
}

/// A unit right triangle in the x-y plane, facing +z.
const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// [`TRIANGLE`] as one mesh under `nodes`, `extra` merged into the root: the JSON
/// and the binary payload.
fn triangle(nodes: &str, extra: &str) -> (String, Vec<u8>) {
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], None, nodes, 4, extra);
    (json, payload(&TRIANGLE, &[0, 1, 2]))
}

fn load_glb(tmp: &TempDir, json: &str, bin: &[u8]) -> Result<Scene, SceneError> {
    let path = tmp.write("scene.glb", &glb(json, bin));
    load(&path, &LoadOptions::default())
}

fn geometric_normal(scene: &Scene, t: usize) -> [f32; 3] {
    let [a, b, c] = scene.mesh.triangles[t].map(|i| scene.mesh.positions[i as usize]);
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
}

#[test]
fn glb_instancing_and_mirroring() {
    let tmp = TempDir::new("instancing");
    let bin = payload(&TRIANGLE, &[0, 1, 2]);
    // Node 3 holds node 0; nodes 1 and 2 are further instances, 2 mirrored.
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], None, "[3,1,2]", 4, "");
    let scene = load_glb(&tmp, &json, &bin).unwrap();
    check_scene(&scene, "instancing");
    assert_eq!(scene.mesh.triangle_count(), 3);
    for t in 0..3 {
        // Computed normals agree with the winding, also under the mirror.
        let g = geometric_normal(&scene, t);
        let n = scene.mesh.normals[scene.mesh.triangles[t][0] as usize];
        assert!(g[2] > 0.0 && n[2] > 0.999, "triangle {t}: {g:?} {n:?}");
    }
    assert_eq!(paint_names(&scene), ["CarPaint"]);
    assert!(
        scene.warnings.contains(
            &"paint material: 'CarPaint' (name matches 'paint', largest such area)".into()
        ),
        "{:?}",
        scene.warnings
    );
    // Uniform scale: the row of instances, x from -1 to 6, becomes 4.5 m long.
    let (lo, hi) = scene.mesh.bounds().unwrap();
    assert!((hi[1] - lo[1] - 4.5 / 7.0).abs() < 1e-5);
}

#[test]
fn gltf_with_external_and_data_uri_buffers() {
    let tmp = TempDir::new("external");
    let bin = payload(&TRIANGLE, &[0, 1, 2]);
    tmp.write("my data.bin", &bin);
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], Some("my%20data.bin"), "[0]", 4, "");
    let path = tmp.write("scene.gltf", json.as_bytes());
    let scene = load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(scene.mesh.triangle_count(), 1);

    let encoded = base64(&bin);
    let uri = format!("data:application/octet-stream;base64,{encoded}");
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], Some(&uri), "[0]", 4, "");
    let path = tmp.write("embedded.gltf", json.as_bytes());
    let scene = load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(scene.mesh.triangle_count(), 1);
}

#[test]
fn strips_fans_and_points() {
    let tmp = TempDir::new("modes");
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    // Strip (5) and fan (6, over 0, 1, 3, 2): 2 triangles each, both facing +z.
    for (mode, indices, name) in [(5, [0, 1, 2, 3], "strip"), (6, [0, 1, 3, 2], "fan")] {
        let bin = payload(&quad, &indices);
        let json = gltf_json(&quad, &indices, None, "[0]", mode, "");
        let scene = load_glb(&tmp, &json, &bin).unwrap();
        assert_eq!(scene.mesh.triangle_count(), 2, "{name}");
        for t in 0..2 {
            assert!(geometric_normal(&scene, t)[2] > 0.0, "{name} triangle {t}");
        }
    }
    // Points (0) only: skipped with a warning, leaving an empty scene.
    let bin = payload(&quad, &[0, 1, 2, 3]);
    let json = gltf_json(&quad, &[0, 1, 2, 3], None, "[0]", 0, "");
    let err = assert_refused!(load_glb(&tmp, &json, &bin), SceneError::Empty { .. });
    assert!(err.to_string().contains("1 primitives skipped"), "{err}");
}

#[test]
fn malformed_node_graphs_are_errors() {
    let cases = [
        // Node 0 under node 3 twice.
        (r#""children":[0]"#, r#""children":[0,0]"#),
        // A cycle: 3 -> 0 -> 3.
        (r#""name":"n0""#, r#""name":"n0","children":[3]"#),
        // Node 3 its own child.
        (r#""children":[0]"#, r#""children":[3]"#),
    ];
    for (k, err) in edits_refused("graphs", "[3]", &cases) {
        assert!(matches!(err, SceneError::Parse { .. }), "case {k}: {err}");
    }
}

/// The [`triangle`] under `nodes` with each of `edits` (text replaced once) in
/// turn: each case's index and its error; fails where an edit does not apply or a
/// case loads.
fn edits_refused(name: &str, nodes: &str, edits: &[(&str, &str)]) -> Vec<(usize, SceneError)> {
    let tmp = TempDir::new(name);
    let (json, bin) = triangle(nodes, "");
    let mut errors = Vec::new();
    for (k, (from, to)) in edits.iter().enumerate() {
        let broken = json.replacen(from, to, 1);
        assert_ne!(broken, json, "case {k} did not apply");
        let Err(err) = load_glb(&tmp, &broken, &bin) else {
            panic!("case {k} loaded");
        };
        errors.push((k, err));
    }
    errors
}

#[test]
fn truncated_glb_is_a_parse_error() {
    let tmp = TempDir::new("truncated");
    let (json, bin) = triangle("[0]", "");
    let bytes = glb(&json, &bin);
    for cut in [3, 12, 30, bytes.len() - 10] {
        let path = tmp.write("cut.glb", &bytes[..cut]);
        let err = load(&path, &LoadOptions::default()).unwrap_err();
        assert!(matches!(err, SceneError::Parse { .. }), "cut {cut}: {err}");
        assert!(err.to_string().contains("cut.glb"), "{err}");
    }
    // A header that declares a length below its own size.
    let mut bad = bytes.clone();
    bad[8..12].copy_from_slice(&4u32.to_le_bytes());
    let path = tmp.write("bad.glb", &bad);
    assert_refused!(
        load(&path, &LoadOptions::default()),
        SceneError::Parse { .. }
    );
    // Truncated JSON.
    let path = tmp.write("cut.gltf", b"{\"asset\":{\"version\":\"2.0\"},\"sce");
    assert_refused!(
        load(&path, &LoadOptions::default()),
        SceneError::Parse { .. }
    );
}

#[test]
fn missing_bin_is_reported_by_path() {
    let tmp = TempDir::new("missing");
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], Some("gone.bin"), "[0]", 4, "");
    let path = tmp.write("scene.gltf", json.as_bytes());
    let err = load(&path, &LoadOptions::default()).unwrap_err();
    assert!(
        matches!(&err, SceneError::MissingBuffer { path, .. } if path.ends_with("gone.bin")),
        "{err}"
    );
    let message = err.to_string();
    assert!(message.contains("scene.gltf") && message.contains("gone.bin"));
    // A .bin that is shorter than its byteLength.
    tmp.write("gone.bin", &[0; 8]);
    assert_refused!(
        load(&path, &LoadOptions::default()),
        SceneError::Parse { .. }
    );
    // Missing file itself.
    assert_refused!(
        load(&tmp.0.join("nothing.glb"), &LoadOptions::default()),
        SceneError::Io { .. }
    );
}

#[test]
fn nan_vertex_names_the_mesh() {
    let tmp = TempDir::new("nan");
    let mut positions = TRIANGLE;
    positions[1][2] = f32::NAN;
    let bin = payload(&positions, &[0, 1, 2]);
    let json = gltf_json(&positions, &[0, 1, 2], None, "[0]", 4, "");
    let err = load_glb(&tmp, &json, &bin).unwrap_err();
    assert!(
        matches!(&err, SceneError::NonFinite { mesh, primitive: 0, .. } if mesh == "Body"),
        "{err}"
    );
    // Infinite scale in a node transform.
    let (json, bin) = triangle("[0]", "");
    let json = json.replace(r#""name":"n0""#, r#""name":"n0","scale":[1e39,1,1]"#);
    assert_refused!(load_glb(&tmp, &json, &bin), SceneError::NonFinite { .. });
}

#[test]
fn empty_scenes_are_errors() {
    let tmp = TempDir::new("empty");
    let (json, bin) = triangle("[]", "");
    assert_refused!(load_glb(&tmp, &json, &bin), SceneError::Empty { .. });
    let path = tmp.write("bare.gltf", br#"{"asset":{"version":"2.0"}}"#);
    assert_refused!(
        load(&path, &LoadOptions::default()),
        SceneError::Empty { .. }
    );
    // Degenerate: all vertices on one vertical line.
    let line = [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0]];
    let bin = payload(&line, &[0, 1, 2]);
    let json = gltf_json(&line, &[0, 1, 2], None, "[0]", 4, "");
    assert_refused!(load_glb(&tmp, &json, &bin), SceneError::Empty { .. });
}

#[test]
fn unknown_required_extension_is_refused_and_optional_warned() {
    let tmp = TempDir::new("extensions");
    let extra = r#","extensionsUsed":["EXT_fancy"],"extensionsRequired":["EXT_fancy"]"#;
    let (json, bin) = triangle("[0]", extra);
    let err = load_glb(&tmp, &json, &bin).unwrap_err();
    assert!(
        matches!(&err, SceneError::UnsupportedExtension { extension, .. } if extension == "EXT_fancy"),
        "{err}"
    );
    assert!(err.to_string().contains("scene.glb"));

    let extra = r#","extensionsUsed":["EXT_fancy","KHR_materials_sheen"]"#;
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], None, "[0]", 4, extra);
    let scene = load_glb(&tmp, &json, &bin).unwrap();
    assert!(warns_with(&scene, "EXT_fancy:"));
    assert!(warns_with(&scene, "KHR_materials_sheen:"));
}

#[test]
fn bad_accessors_are_errors() {
    let cases = [
        // An accessor index that does not exist.
        (r#""indices":1"#, r#""indices":99"#),
        // More elements than the buffer view holds.
        (r#""count":3,"type":"VEC3""#, r#""count":300,"type":"VEC3""#),
        // Positions as scalars.
        (r#""type":"VEC3""#, r#""type":"SCALAR""#),
        // A view past the end of the buffer.
        (
            r#""byteOffset":0,"byteLength":36"#,
            r#""byteOffset":0,"byteLength":3600"#,
        ),
        // Count zero.
        (
            r#""count":3,"type":"SCALAR""#,
            r#""count":0,"type":"SCALAR""#,
        ),
    ];
    for (k, err) in edits_refused("accessors", "[0]", &cases) {
        assert!(
            matches!(err, SceneError::BadAccessor { .. }),
            "case {k}: {err}"
        );
    }
    // Index out of range.
    let tmp = TempDir::new("accessors");
    let (json, _) = triangle("[0]", "");
    let bin = payload(&TRIANGLE, &[0, 1, 7]);
    assert_refused!(load_glb(&tmp, &json, &bin), SceneError::BadAccessor { .. });
}

#[test]
fn paint_material_override() {
    let tmp = TempDir::new("override");
    let (json, bin) = triangle("[0]", "");
    let path = tmp.write("scene.glb", &glb(&json, &bin));
    let options = LoadOptions {
        paint_material: Some("Chassis".into()),
        ..LoadOptions::default()
    };
    let err = load(&path, &options).unwrap_err();
    assert!(
        matches!(&err, SceneError::UnknownMaterial { available, .. } if available == &["CarPaint", "Glass"]),
        "{err}"
    );
    assert!(err.to_string().contains("'CarPaint', 'Glass'"), "{err}");
    let options = LoadOptions {
        paint_material: Some("Glass".into()),
        ..LoadOptions::default()
    };
    let scene = load(&path, &options).unwrap();
    assert_eq!(scene.paint_materials, [1]);
}

/// What a file declares, read through the `gltf` crate without our loader:
/// triangles and vertices over every instance of every mesh of the default scene
/// (accessor counts), materials, and the bounds of the instances' vertices (read
/// by the crate's own reader) carried through the node transforms and normalised
/// as the loader documents: turned by `turn` (the loader's orientation, here taken
/// as given; its choice is tested apart), then 4.5 m long, on the ground, centred.
struct Declared {
    triangles: usize,
    vertices: usize,
    materials: usize,
    lo: [f64; 3],
    hi: [f64; 3],
}

fn declared(path: &Path, turn: glam::DMat3) -> Declared {
    type Matrix = [[f64; 4]; 4];
    fn mul(a: &Matrix, b: &Matrix) -> Matrix {
        std::array::from_fn(|c| std::array::from_fn(|r| (0..4).map(|k| a[k][r] * b[c][k]).sum()))
    }
    let bytes = std::fs::read(path).expect("read the model");
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).expect("parse the model");
    let folder = path.parent().expect("a folder");
    let buffers: Vec<Vec<u8>> = gltf
        .buffers()
        .map(|buffer| match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().expect("the GLB binary chunk"),
            gltf::buffer::Source::Uri(uri) => std::fs::read(folder.join(uri)).expect("a buffer"),
        })
        .collect();
    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .expect("a scene");
    let identity: Matrix = std::array::from_fn(|c| std::array::from_fn(|r| f64::from(c == r)));
    let (mut triangles, mut vertices) = (0, 0);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut stack: Vec<(gltf::Node, Matrix)> = scene.nodes().map(|n| (n, identity)).collect();
    while let Some((node, parent)) = stack.pop() {
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let world = mul(&parent, &local);
        stack.extend(node.children().map(|c| (c, world)));
        let Some(mesh) = node.mesh() else { continue };
        for primitive in mesh.primitives() {
            assert_eq!(primitive.mode(), gltf::mesh::Mode::Triangles, "{path:?}");
            let positions = primitive.get(&gltf::Semantic::Positions).expect("POSITION");
            vertices += positions.count();
            triangles += primitive.indices().map_or(positions.count(), |i| i.count()) / 3;
            let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            for p in reader.read_positions().expect("POSITION") {
                let p = p.map(f64::from);
                let w = glam::DVec3::from_array(std::array::from_fn(|r| {
                    (0..3).map(|k| world[k][r] * p[k]).sum::<f64>() + world[3][r]
                }));
                let w = (turn * w).to_array();
                for r in 0..3 {
                    lo[r] = lo[r].min(w[r]);
                    hi[r] = hi[r].max(w[r]);
                }
            }
        }
    }
    let scale = TARGET_LENGTH_M / (hi[0] - lo[0]).max(hi[2] - lo[2]);
    let centre = [(lo[0] + hi[0]) / 2.0, lo[1], (lo[2] + hi[2]) / 2.0];
    Declared {
        triangles,
        vertices,
        materials: gltf.materials().count(),
        lo: std::array::from_fn(|k| (lo[k] - centre[k]) * scale),
        hi: std::array::from_fn(|k| (hi[k] - centre[k]) * scale),
    }
}

/// Each real model loads as its file declares (the counts over every instance,
/// the materials, the bounds of the transformed vertices), with the scene
/// invariants, and the paint material the heuristic is known to pick, with the
/// note saying why. The counts are also pinned here, so a changed test file is
/// noticed. A loader that dropped a primitive or an instance, misapplied a node
/// transform or lost a material fails. (The Draco and meshopt copies are refused:
/// `draco_is_refused_by_name`, `meshopt_is_refused_by_name`.)
#[test]
fn real_models_load_as_their_files_declare() {
    struct Model {
        rel: &'static str,
        triangles: usize,
        vertices: usize,
        materials: usize,
        paint: &'static str,
    }
    let models = [
        Model {
            rel: "CesiumMilkTruck/CesiumMilkTruck.glb",
            triangles: 3624,
            vertices: 4823,
            materials: 4,
            paint: "truck",
        },
        Model {
            rel: "ClearCoatCarPaint/ClearCoatCarPaint.glb",
            triangles: 3072,
            vertices: 1728,
            materials: 1,
            paint: "Clear Coat Car Paint",
        },
        Model {
            rel: "LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb",
            triangles: 145_917,
            vertices: 115_576,
            materials: 45,
            paint: "Material.035",
        },
        Model {
            rel: "ToyCar/ToyCar.gltf",
            triangles: 108_936,
            vertices: 77_429,
            materials: 3,
            paint: "ToyCar",
        },
    ];
    for m in models {
        let Some(scene) = load_model(m.rel, m.triangles) else {
            return;
        };
        // The loader turns the Lamborghini (yawed 43.6° in its file) to put its
        // nose on +Z; the declared boxes are turned the same way.
        let d = declared(
            &testdata().expect("test data").join(m.rel),
            scene.orientation.world_from_file(),
        );
        assert_eq!(
            (d.triangles, d.vertices, d.materials),
            (m.triangles, m.vertices, m.materials),
            "{}: the test file changed",
            m.rel
        );
        let mesh = &scene.mesh;
        assert_eq!(
            (
                mesh.triangle_count(),
                mesh.positions.len(),
                scene.materials.len()
            ),
            (d.triangles, d.vertices, d.materials),
            "{}: triangles, vertices, materials",
            m.rel
        );
        let (lo, hi) = mesh.bounds().expect("non-empty");
        // f32 positions of a 4.5 m model: a few ulps of rounding.
        let tolerance = 1e-4;
        for k in 0..3 {
            let (lo, hi) = (f64::from(lo[k]), f64::from(hi[k]));
            let equal = (lo - d.lo[k]).abs() < tolerance && (hi - d.hi[k]).abs() < tolerance;
            assert!(
                equal,
                "{}: axis {k}: loaded {lo}..{hi}, declared {}..{}",
                m.rel, d.lo[k], d.hi[k]
            );
        }
        assert_eq!(paint_names(&scene), [m.paint], "{}: paint", m.rel);
        let note = format!("paint material: '{}' (", m.paint);
        assert!(
            warns_with(&scene, &note),
            "{}: no note on the paint's choice in {:?}",
            m.rel,
            scene.warnings
        );
    }
}

#[test]
fn file_normals_follow_the_inverse_transpose_and_the_mirror() {
    let tmp = TempDir::new("normals");
    let bin = payload(&TRIANGLE, &[0, 1, 2]);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let normals = payload(&[[s, 0.0, s]; 3], &[]);
    let uri = format!("data:application/octet-stream;base64,{}", base64(&normals));
    let json = gltf_json(&TRIANGLE, &[0, 1, 2], None, "[0]", 4, "")
        .replacen(r#""POSITION":0"#, r#""POSITION":0,"NORMAL":2"#, 1)
        .replacen(
            r#""type":"SCALAR"}]"#,
            r#""type":"SCALAR"},{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"}]"#,
            1,
        )
        .replacen(
            "}],\n\"buffers\":[",
            r#"},{"buffer":1,"byteLength":36}],
"buffers":["#,
            1,
        )
        // Mirror and stretch x: the normal (1, 0, 1)/√2 maps to (-0.5, 0, 1), normalised.
        .replacen(r#""name":"n0""#, r#""name":"n0","scale":[-2,1,1]"#, 1);
    // Buffer 1, the normals, goes last.
    let json = format!(
        r#"{},{{"byteLength":36,"uri":"{uri}"}}]}}"#,
        json.strip_suffix("]}").unwrap()
    );
    let scene = load_glb(&tmp, &json, &bin).unwrap();
    check_scene(&scene, "normals");
    let expected = [-0.5 / 1.25f32.sqrt(), 0.0, 1.0 / 1.25f32.sqrt()];
    for n in &scene.mesh.normals {
        for k in 0..3 {
            assert!((n[k] - expected[k]).abs() < 1e-5, "{n:?} vs {expected:?}");
        }
    }
    // The flipped winding still faces the same side as the normals.
    assert!(geometric_normal(&scene, 0)[2] > 0.0);
}

// ---------------------------------------------------------------------------
// Orientation

/// The 8 corners and 12 outward triangles of the box `lo`–`hi`, vertices from `base`.
fn cuboid(lo: [f32; 3], hi: [f32; 3], base: u16) -> (Vec<[f32; 3]>, Vec<u16>) {
    let corners = (0..8)
        .map(|c| std::array::from_fn(|k| if c >> k & 1 == 0 { lo[k] } else { hi[k] }))
        .collect();
    // Corner bits: x = 1, y = 2, z = 4; each face as two counter-clockwise triangles.
    let faces: [[u16; 4]; 6] = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    let indices = faces
        .iter()
        .flat_map(|[a, b, c, d]| [*a, *b, *c, *a, *c, *d])
        .map(|i| base + i)
        .collect();
    (corners, indices)
}

/// A car-like block along the file's X axis: a long low body and a cabin over its
/// +X half, so the low end (the nose, by the heuristic) is −X. As one mesh under
/// node 0, turned by `yaw_deg` about +Y.
fn stepped_block(yaw_deg: f64) -> (String, Vec<u8>) {
    let (mut positions, mut indices) = cuboid([-2.0, 0.0, -0.9], [2.0, 0.6, 0.9], 0);
    let (cabin, cabin_indices) = cuboid([0.0, 0.6, -0.7], [2.0, 1.3, 0.7], 8);
    positions.extend(cabin);
    indices.extend(cabin_indices);
    let half = 0.5 * yaw_deg.to_radians();
    let json = gltf_json(&positions, &indices, None, "[0]", 4, "").replacen(
        r#"{"mesh":0,"name":"n0"}"#,
        &format!(
            r#"{{"mesh":0,"name":"n0","rotation":[0,{},0,{}]}}"#,
            half.sin(),
            half.cos()
        ),
        1,
    );
    (json, payload(&positions, &indices))
}

/// The file direction the loader took for the nose, turned by `yaw_deg` back into
/// the block's own frame.
fn nose_in_block_frame(scene: &Scene, yaw_deg: f64) -> glam::DVec3 {
    glam::DQuat::from_rotation_y(-yaw_deg.to_radians())
        * glam::DVec3::from(scene.orientation.front_in_file)
}

#[test]
fn the_lower_end_becomes_the_nose_and_the_long_axis_follows_the_geometry() {
    let tmp = TempDir::new("orientation");
    for yaw_deg in [0.0, 30.0, -70.0, 180.0] {
        let (json, bin) = stepped_block(yaw_deg);
        let scene = load_glb(&tmp, &json, &bin).unwrap();
        check_scene(&scene, "stepped block");
        let nose = nose_in_block_frame(&scene, yaw_deg);
        assert!(
            nose.dot(glam::DVec3::NEG_X) > 0.9999,
            "yaw {yaw_deg}°: nose {nose:?}, {:?}",
            scene.warnings
        );
        assert_eq!(scene.orientation.up_in_file, [0.0, 1.0, 0.0]);
        // In the scene the car is 4.5 m along z, with its cabin (the high part)
        // behind: every vertex above the body is at z ≤ 0.
        let (lo, hi) = scene.mesh.bounds().unwrap();
        assert!(
            (hi[2] - lo[2] - 4.5).abs() < 1e-3,
            "yaw {yaw_deg}°: {lo:?} {hi:?}"
        );
        assert!(
            (hi[0] - lo[0] - 1.8 * 4.5 / 4.0).abs() < 1e-3,
            "yaw {yaw_deg}°"
        );
        let body_top = 0.6 * 4.5 / 4.0 + 1e-3;
        assert!(
            scene
                .mesh
                .positions
                .iter()
                .filter(|p| p[1] > body_top)
                .all(|p| p[2] <= 1e-3),
            "yaw {yaw_deg}°: the cabin is not at the back"
        );
        assert!(warns_with(&scene, "orientation: "), "{:?}", scene.warnings);
    }
}

#[test]
fn the_front_override_picks_the_end_of_the_long_axis() {
    let tmp = TempDir::new("front_override");
    let (json, bin) = stepped_block(30.0);
    let path = tmp.write("scene.glb", &glb(&json, &bin));
    // The block's +X end is the file's (cos 30°, 0, −sin 30°): nearest +x.
    for (front, expected) in [
        (Front::PlusX, glam::DVec3::X),
        (Front::MinusZ, glam::DVec3::X),
        (Front::MinusX, glam::DVec3::NEG_X),
        (Front::PlusZ, glam::DVec3::NEG_X),
    ] {
        let options = LoadOptions {
            front: Some(front),
            ..LoadOptions::default()
        };
        let scene = load(&path, &options).unwrap();
        let nose = nose_in_block_frame(&scene, 30.0);
        assert!(nose.dot(expected) > 0.9999, "{front}: nose {nose:?}");
        assert!(warns_about(
            &scene,
            &format!("front given as the file's {front}")
        ));
    }
    assert_eq!("-Z".parse::<Front>(), Ok(Front::MinusZ));
    assert!("+y".parse::<Front>().is_err());
}

#[test]
fn a_car_exported_z_up_is_stood_upright() {
    let tmp = TempDir::new("z_up");
    // The stepped block with its height along the file's +Z and length along +Y:
    // x stays, y ← −z, z ← y (length 4 along y, so it stands 4 m tall in glTF's Y).
    let (positions, indices) = {
        let (mut p, mut i) = cuboid([-2.0, 0.0, -0.9], [2.0, 0.6, 0.9], 0);
        let (c, ci) = cuboid([0.0, 0.6, -0.7], [2.0, 1.3, 0.7], 8);
        p.extend(c);
        i.extend(ci);
        // Length along y, width along x, height along z.
        let p: Vec<[f32; 3]> = p.iter().map(|q| [q[2], q[0], q[1]]).collect();
        (p, i)
    };
    let json = gltf_json(&positions, &indices, None, "[0]", 4, "");
    let scene = load_glb(&tmp, &json, &payload(&positions, &indices)).unwrap();
    assert_eq!(scene.orientation.up_in_file, [0.0, 0.0, 1.0]);
    // The low end was at the file's −Y.
    let nose = glam::DVec3::from(scene.orientation.front_in_file);
    assert!(nose.dot(glam::DVec3::NEG_Y) > 0.9999, "{nose:?}");
    let (lo, hi) = scene.mesh.bounds().unwrap();
    assert!(
        (hi[1] - lo[1] - 1.3 * 4.5 / 4.0).abs() < 1e-3,
        "{lo:?} {hi:?}"
    );
    assert!((hi[2] - lo[2] - 4.5).abs() < 1e-3, "{lo:?} {hi:?}");
}
