//! Glass and alpha in scenes: the loader reads `KHR_materials_transmission`,
//! `KHR_materials_ior`, `KHR_materials_volume` and `alphaMode` (bad values a
//! warning naming the material, never a panic), and the tracer shows what lies
//! behind a pane: a lit backdrop seen through clear glass of index 1 or through a
//! masked-out veil is the backdrop seen through nothing (Z-tests of the mean
//! radiance), through real glass a little darker, and through an opaque pane dark.

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::geometry::RenderGeometry;
use coatlab_core::render::integrator::{IntegratorSettings, NoRecord, PathBuffers, PathTracer};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::sampler::PixelSampler;
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::scene::transparency::{AlphaMode, Transparency};
use coatlab_core::scene::{SceneMaterial, TriangleMesh};
use palette::LinSrgb;

#[path = "support/gltf_testdata.rs"]
mod gltf_testdata;
use gltf_testdata::glb;

/// A one-triangle GLB whose document carries `materials` (JSON objects; the
/// triangle uses the first).
fn triangle_with_materials(materials: &str) -> Vec<u8> {
    let mut bin = Vec::new();
    [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        .iter()
        .flatten()
        .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"extensionsUsed":["KHR_materials_transmission","KHR_materials_ior","KHR_materials_volume"],
"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
"materials":[{materials}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}],
"buffers":[{{"byteLength":36}}]}}"#
    );
    glb(&json, &bin)
}

#[test]
fn the_loader_reads_glass_and_alpha_and_warns_of_bad_values_by_material() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("glass.glb");
    let bytes = triangle_with_materials(
        r#"{"name":"CarPaint"},
{"name":"Window","pbrMetallicRoughness":{"baseColorFactor":[0.7,0.8,0.75,1]},
 "extensions":{"KHR_materials_transmission":{"transmissionFactor":1},"KHR_materials_ior":{"ior":1.45}}},
{"name":"Lens","extensions":{"KHR_materials_transmission":{"transmissionFactor":0.8},
 "KHR_materials_volume":{"thicknessFactor":0.01,"attenuationColor":[1,0.2,0.1],"attenuationDistance":0.05}}},
{"name":"BadIor","extensions":{"KHR_materials_transmission":{"transmissionFactor":1},"KHR_materials_ior":{"ior":0.5}}},
{"name":"BadVolume","extensions":{"KHR_materials_transmission":{"transmissionFactor":1.5},
 "KHR_materials_volume":{"thicknessFactor":-1,"attenuationColor":[2,0,0],"attenuationDistance":-3}}},
{"name":"Veil","alphaMode":"BLEND","pbrMetallicRoughness":{"baseColorFactor":[0.1,0.1,0.1,0.3]}},
{"name":"Cutout","alphaMode":"MASK","alphaCutoff":0.7},
{"name":"BadCutout","alphaMode":"MASK","alphaCutoff":-0.2}"#,
    );
    std::fs::write(&path, bytes).expect("written");
    let options = LoadOptions {
        paint_material: Some("CarPaint".into()),
        ..LoadOptions::default()
    };
    let scene = load(&path, &options).expect("bad values are warnings, not errors");
    let find = |name: &str| -> Transparency {
        scene
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap_or_else(|| panic!("material {name}"))
            .transparency
    };
    let window = find("Window");
    assert_eq!(
        (window.transmission, window.ior, window.thickness_m),
        (1.0, 1.45, 0.0)
    );
    assert!(!window.is_volume() && window.is_see_through());
    let lens = find("Lens");
    assert_eq!(
        (lens.transmission, lens.ior, lens.thickness_m),
        (0.8, 1.5, 0.01)
    );
    assert_eq!(lens.attenuation_color, LinSrgb::new(1.0, 0.2, 0.1));
    assert_eq!(lens.attenuation_distance_m, 0.05);
    assert!(lens.is_volume());
    // Bad values: the default stands in and a warning names the material and
    // the value.
    let defaults = Transparency::default();
    assert_eq!(find("BadIor").ior, defaults.ior);
    let bad = find("BadVolume");
    assert_eq!(bad.transmission, 0.0);
    assert_eq!(bad.thickness_m, 0.0);
    assert_eq!(bad.attenuation_color, defaults.attenuation_color);
    assert_eq!(bad.attenuation_distance_m, f32::INFINITY);
    for (material, what) in [
        ("BadIor", "ior 0.5"),
        ("BadVolume", "transmissionFactor 1.5"),
        ("BadVolume", "thicknessFactor -1"),
        ("BadVolume", "attenuationColor"),
        ("BadVolume", "attenuationDistance -3"),
        ("BadCutout", "alphaCutoff -0.2"),
    ] {
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains(&format!("'{material}'")) && w.contains(what)),
            "no warning about {material}'s {what}: {:?}",
            scene.warnings
        );
    }
    let veil = find("Veil");
    assert_eq!(veil.alpha_mode, AlphaMode::Blend);
    assert!((veil.alpha - 0.3).abs() < 1e-6);
    assert_eq!(find("Cutout").alpha_mode, AlphaMode::Mask { cutoff: 0.7 });
    assert_eq!(
        find("BadCutout").alpha_mode,
        AlphaMode::Mask { cutoff: 0.5 }
    );
    // The glass extensions are understood: no "ignored" warning for them.
    assert!(
        !scene.warnings.iter().any(|w| w.contains("ignored")),
        "{:?}",
        scene.warnings
    );
}

/// Two axis-aligned quads facing +z: the backdrop (material 0) at z = −1, 4 m
/// wide, and, when `pane` is set, a 2 m pane (material 1) at z = 0.
fn backdrop_scene(pane: bool) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    let mut quad = |z: f32, half: f32, material: u32| {
        let base = mesh.positions.len() as u32;
        for [x, y] in [[-half, -half], [half, -half], [half, half], [-half, half]] {
            mesh.positions.push([x, y + 1.5, z]);
            mesh.normals.push([0.0, 0.0, 1.0]);
        }
        for t in [[0, 1, 2], [0, 2, 3]] {
            mesh.triangles.push(t.map(|i| base + i));
            mesh.triangle_material.push(material);
        }
    };
    quad(-1.0, 2.0, 0);
    if pane {
        quad(0.0, 1.0, 1);
    }
    mesh
}

/// Mean and variance of the mean of the radiance (channel average) seen from
/// (0, 1.5, 3) toward −z through the middle of the scene, over `n` paths.
fn mean_radiance(mesh: TriangleMesh, pane: SceneMaterial, seed: u64, n: u32) -> (f64, f64) {
    let grid = WavelengthGrid::visible(8).expect("grid");
    let design = presets::all().into_iter().next().expect("a preset").design;
    let paint = design.model(grid).expect("the preset's model");
    let backdrop = SceneMaterial {
        name: "backdrop".into(),
        base_color: LinSrgb::new(0.8, 0.8, 0.8),
        metallic: 0.0,
        roughness: 1.0,
        ..SceneMaterial::default()
    };
    let materials = [backdrop, pane];
    let shading = Shading::new(&paint, ShadingModel::Paint, &materials, &[]);
    let geometry = RenderGeometry::new(mesh, false).expect("the scene builds");
    let environment = Environment::studio(&grid);
    let settings = IntegratorSettings::default();
    let tracer = PathTracer::new(&geometry, &environment, &shading, settings);
    let mut buffers = PathBuffers::new(tracer.len());
    let mut out = vec![0.0; tracer.len()];
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let mut sampler = PixelSampler::new(seed, i, 0);
        // Slightly spread rays, all through the pane's middle.
        let [jx, jy] = sampler.next_2d();
        let dir = [0.1 * (jx - 0.5), 0.1 * (jy - 0.5), -1.0];
        let length = (dir[0] * dir[0] + dir[1] * dir[1] + 1.0f32).sqrt();
        let dir = dir.map(|d| d / length);
        let origin = [0.0, 1.5, 3.0];
        tracer.radiance(
            origin,
            dir,
            &mut sampler,
            &mut buffers,
            &mut out,
            &mut NoRecord,
        );
        let value = f64::from(out.iter().sum::<f32>()) / out.len() as f64;
        sum += value;
        sum2 += value * value;
    }
    let mean = sum / f64::from(n);
    let variance = (sum2 / f64::from(n) - mean * mean).max(0.0);
    (mean, variance / f64::from(n))
}

fn pane(transparency: Transparency, base: f32) -> SceneMaterial {
    SceneMaterial {
        name: "pane".into(),
        base_color: LinSrgb::new(base, base, base),
        metallic: 0.0,
        roughness: 0.5,
        transparency,
        ..SceneMaterial::default()
    }
}

#[test]
fn the_backdrop_is_seen_and_lit_through_glass() {
    let n = 6_000;
    let (open, open_var) = mean_radiance(
        backdrop_scene(false),
        pane(Transparency::default(), 0.0),
        1,
        n,
    );
    assert!(open > 0.05, "the backdrop is lit: {open}");
    let z = |(a, va): (f64, f64)| (a - open) / (va + open_var).sqrt();
    // Glass of index 1 reflects nothing and transmits everything: the same
    // picture as no pane (camera rays and the backdrop's shadow rays through it).
    let invisible = mean_radiance(
        backdrop_scene(true),
        pane(Transparency::thin_glass(1.0), 1.0),
        2,
        n,
    );
    assert!(
        z(invisible).abs() < 4.0,
        "index-1 pane {invisible:?} against open {open}"
    );
    // A masked-out veil (alpha 0 below the cutoff) is not there either.
    let cut_out = Transparency {
        alpha: 0.0,
        alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
        ..Transparency::default()
    };
    let masked = mean_radiance(backdrop_scene(true), pane(cut_out, 0.0), 3, n);
    assert!(
        z(masked).abs() < 4.0,
        "masked pane {masked:?} against open {open}"
    );
    // Real glass: the backdrop through it, dimmed by the pane's 8 % reflection on
    // the way in and the light's on the way to the backdrop, plus what the pane
    // reflects of the studio behind the camera.
    let (glass, _) = mean_radiance(
        backdrop_scene(true),
        pane(Transparency::thin_glass(1.5), 1.0),
        4,
        n,
    );
    assert!(
        glass > 0.6 * open && glass < 1.1 * open,
        "glass {glass} against open {open}"
    );
    // The same pane opaque and black hides the backdrop.
    let (opaque, _) = mean_radiance(
        backdrop_scene(true),
        pane(Transparency::default(), 0.0),
        5,
        n,
    );
    assert!(
        opaque < 0.3 * glass,
        "opaque {opaque} against glass {glass}"
    );
}
