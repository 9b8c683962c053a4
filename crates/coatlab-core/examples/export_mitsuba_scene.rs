//! Exports one scene for the Mitsuba 3 side-by-side benchmark (`benches/mitsuba/`):
//! the same geometry, camera, light and design for both renderers.
//!
//! `cargo run --release -p coatlab-core --example export_mitsuba_scene -- OUT_DIR [WIDTHxHEIGHT]`
//!
//! Writes into OUT_DIR:
//! - `body.glb`: the default car's painted body alone (Mitsuba has no BSDF for the
//!   glTF simple materials of tyres, glass and trim, so only the part both renderers
//!   shade with the same physics is kept). Coatlab renders this file with `--scene`.
//! - `body.ply`: the same triangles as Coatlab's loader normalises them (scaled,
//!   standing on y = 0), with its shading normals, for Mitsuba.
//! - `studio.exr`: the studio lighting baked to a 1024 × 512 lat-long map of linear
//!   sRGB (32-bit float), each texel the mean of 4 × 4 directions inside it. Both
//!   renderers read this file, so they see the same light (both up-sample its RGB
//!   to spectra, each by its own method).
//! - `design.toml`: the paint model's special case that Mitsuba's `plastic` BSDF
//!   covers: the signal-red preset's ρ(λ) under a coat with k = 0, n = 1.5 at every
//!   wavelength (Cauchy b = 0), and a gloss at the coat's mirror reading (the ideal
//!   mirror).
//! - `scene.json`: everything Mitsuba needs: the camera of `RenderScene::default_camera`
//!   (position, look-at, up, vertical field of view, size), the map and the factor
//!   Coatlab's normalisation applies to it, the floor's reflectance, n and ρ(λ).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::{Xyz, linear_srgb_from_xyz, srgb_white};
use coatlab_core::design::{Absorption, RefractiveIndex, presets};
use coatlab_core::paint::gloss::{GlossExponent, Glossmeter};
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::progressive::RenderScene;
use coatlab_core::scene::car::{self, CarParameters};
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::scene::{Scene, TriangleMesh};

/// Size of the baked environment map, texels: fine enough that the softboxes'
/// edges are sharp at this benchmark's resolutions, small enough to load at once.
const MAP_WIDTH: usize = 1024;
const MAP_HEIGHT: usize = 512;
/// Directions per texel side averaged into each texel of the baked map.
const MAP_SUPERSAMPLING: usize = 4;
/// The clear coat's refractive index, at every wavelength.
const COAT_INDEX: f64 = 1.5;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("export_mitsuba_scene: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let out_dir = PathBuf::from(
        args.next()
            .ok_or("usage: export_mitsuba_scene OUT_DIR [WIDTHxHEIGHT]")?,
    );
    let size = args.next().unwrap_or_else(|| "320x180".to_owned());
    let (width, height) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0)
        .ok_or_else(|| format!("size '{size}': use WIDTHxHEIGHT, e.g. 320x180"))?;
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;

    // The painted body alone, through the same glTF loader `coatlab render --scene`
    // uses, so the PLY holds exactly the triangles Coatlab renders.
    let glb_path = out_dir.join("body.glb");
    let body = body_only(&car::generate(&CarParameters::default()))?;
    let bytes = car::to_glb(&body).map_err(|e| format!("cannot encode the body: {e}"))?;
    write(&glb_path, &bytes)?;
    let loaded = load(&glb_path, &LoadOptions::default()).map_err(|e| e.to_string())?;
    if loaded.paint_materials != [0] {
        return Err(format!(
            "{}: the loader paints materials {:?}, expected the body (0)",
            glb_path.display(),
            loaded.paint_materials
        ));
    }
    write(&out_dir.join("body.ply"), &ply(&loaded.mesh))?;
    let render_scene = RenderScene::new(loaded.clone()).map_err(|e| e.to_string())?;
    let camera = render_scene.default_camera(width, height);

    // The lighting, baked on the 5 nm grid.
    let grid = WavelengthGrid::reference();
    let studio = Environment::studio(&grid);
    let film = Film::new(1, 1, grid);
    let pixels = bake(&studio, &film);
    let map_path = out_dir.join("studio.exr");
    exr::prelude::write_rgb_file(&map_path, MAP_WIDTH, MAP_HEIGHT, |x, y| {
        let p = pixels[y * MAP_WIDTH + x];
        (p[0], p[1], p[2])
    })
    .map_err(|e| format!("cannot write {}: {e}", map_path.display()))?;
    // Coatlab normalises a map to horizontal illuminance π; Mitsuba takes the file
    // as it is. The factor Coatlab applies, measured on the loaded map (radiance of
    // a texel against the texel's RGB), goes to Mitsuba as the emitter's scale.
    let loaded_map = Environment::from_image(&map_path, &grid).map_err(|e| e.to_string())?;
    let map_scale = normalisation_factor(&loaded_map, &film, &pixels);
    let floor = loaded_map
        .floor()
        .ok_or("the loaded map has no floor")?
        .reflectance
        .clone();
    let floor_reflectance = floor.first().copied().unwrap_or(0.0);
    if floor.iter().any(|&r| r != floor_reflectance) {
        return Err("the image map's floor is not flat grey".to_owned());
    }

    // The design: the special case of the paint model that `plastic` is.
    let mut design = presets::by_slug("signal-red")
        .ok_or("no signal-red preset")?
        .design;
    design.name = "Signal red, k = 0, n = 1.5, mirror (Mitsuba plastic case)".to_owned();
    design.description = Some(
        "The signal-red preset's pigment under a non-absorbing coat of constant index 1.5 \
         with mirror gloss: the case Mitsuba 3's plastic BSDF models."
            .to_owned(),
    );
    design.refractive_index = RefractiveIndex::Cauchy {
        a: COAT_INDEX,
        b_um2: 0.0,
    };
    design.absorption_per_um = Absorption::Constant(0.0);
    design.gloss.gu = Glossmeter::new(design.gloss.geometry).mirror_reading(COAT_INDEX);
    if design.exponent().map_err(|e| e.to_string())? != GlossExponent::Mirror {
        return Err("the gloss reading does not give the ideal mirror".to_owned());
    }
    design
        .save(out_dir.join("design.toml"))
        .map_err(|e| e.to_string())?;
    let albedo = design.albedo_on(&grid);

    let mut json = String::new();
    let list = |values: &mut dyn Iterator<Item = f64>| {
        values
            .map(|v| format!("{v}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let [px, py, pz] = camera.position();
    let [tx, ty, tz] = camera.look_at();
    let [ux, uy, uz] = camera.up();
    let _ = writeln!(json, "{{");
    let _ = writeln!(json, "  \"width\": {width},\n  \"height\": {height},");
    let _ = writeln!(
        json,
        "  \"camera\": {{\"position\": [{px}, {py}, {pz}], \"look_at\": [{tx}, {ty}, {tz}], \
         \"up\": [{ux}, {uy}, {uz}], \"vertical_fov_deg\": {}}},",
        camera.vertical_fov_deg()
    );
    let _ = writeln!(
        json,
        "  \"mesh\": \"body.ply\",\n  \"coatlab_scene\": \"body.glb\",\n  \"design\": \"design.toml\","
    );
    let _ = writeln!(
        json,
        "  \"environment\": \"studio.exr\",\n  \"environment_scale\": {map_scale},"
    );
    let _ = writeln!(json, "  \"floor_reflectance\": {floor_reflectance},");
    let _ = writeln!(json, "  \"coat_index\": {COAT_INDEX},");
    let _ = writeln!(
        json,
        "  \"albedo\": {{\"wavelength_nm\": [{}], \"value\": [{}]}}",
        list(&mut grid.wavelengths_nm()),
        list(&mut albedo.values().iter().copied())
    );
    let _ = writeln!(json, "}}");
    write(&out_dir.join("scene.json"), json.as_bytes())?;
    println!(
        "{}: body {} triangles, camera {:?} → {:?}, fov {:.2}°, {width}x{height}; map scale {map_scale:.6}, floor ρ {floor_reflectance}",
        out_dir.display(),
        loaded.mesh.triangle_count(),
        camera.position(),
        camera.look_at(),
        camera.vertical_fov_deg()
    );
    Ok(())
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// The scene's painted triangles as a scene of their own, with one material.
fn body_only(scene: &Scene) -> Result<Scene, String> {
    let &[paint] = scene.paint_materials.as_slice() else {
        return Err("the default car should paint exactly one material".to_owned());
    };
    let mut mesh = TriangleMesh::default();
    let mut remap = vec![u32::MAX; scene.mesh.positions.len()];
    for (t, triangle) in scene.mesh.triangles.iter().enumerate() {
        if scene.mesh.triangle_material[t] != paint {
            continue;
        }
        let corners = triangle.map(|v| {
            let v = v as usize;
            if remap[v] == u32::MAX {
                remap[v] = mesh.positions.len() as u32;
                mesh.positions.push(scene.mesh.positions[v]);
                mesh.normals.push(scene.mesh.normals[v]);
            }
            remap[v]
        });
        mesh.triangles.push(corners);
        mesh.triangle_material.push(0);
    }
    let mut material = scene.materials[paint as usize].clone();
    material.area_m2 = (0..mesh.triangle_count())
        .map(|t| mesh.triangle_area(t))
        .sum();
    Ok(Scene {
        mesh,
        materials: vec![material],
        paint_materials: vec![0],
        ..Scene::default()
    })
}

/// Binary little-endian PLY: float positions and normals, int triangle lists.
fn ply(mesh: &TriangleMesh) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment Coatlab default car body, normalised as \
         coatlab render --scene loads it\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangle_count()
    );
    let mut bytes = header.into_bytes();
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        for v in p.iter().chain(n) {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    for triangle in &mesh.triangles {
        bytes.push(3);
        for &v in triangle {
            bytes.extend_from_slice(&(v as i32).to_le_bytes());
        }
    }
    bytes
}

/// The direction of lat-long coordinates (u, v) in [0, 1]²: v = 0 the zenith, u = 0.5
/// toward +Z, azimuth φ = atan2(x, z) = 2π (0.5 − u) (the convention of
/// `docs/lighting.md`).
fn direction(u: f64, v: f64) -> [f32; 3] {
    let theta = v * std::f64::consts::PI;
    let phi = (0.5 - u) * 2.0 * std::f64::consts::PI;
    [
        (theta.sin() * phi.sin()) as f32,
        theta.cos() as f32,
        (theta.sin() * phi.cos()) as f32,
    ]
}

/// Linear sRGB (D65 white, Y = 1 → (1, 1, 1), as Coatlab's EXR output) of the
/// environment's mean radiance over each texel.
fn bake(env: &Environment, film: &Film) -> Vec<[f32; 3]> {
    let mut radiance = vec![0.0f32; env.channels().len()];
    let white = srgb_white();
    let mut pixels = Vec::with_capacity(MAP_WIDTH * MAP_HEIGHT);
    for row in 0..MAP_HEIGHT {
        for col in 0..MAP_WIDTH {
            let mut sum = [0.0f64; 3];
            for sy in 0..MAP_SUPERSAMPLING {
                for sx in 0..MAP_SUPERSAMPLING {
                    let u = (col as f64 + (sx as f64 + 0.5) / MAP_SUPERSAMPLING as f64)
                        / MAP_WIDTH as f64;
                    let v = (row as f64 + (sy as f64 + 0.5) / MAP_SUPERSAMPLING as f64)
                        / MAP_HEIGHT as f64;
                    env.radiance(direction(u, v), &mut radiance);
                    let xyz = film.xyz_of(&radiance);
                    sum[0] += xyz.x;
                    sum[1] += xyz.y;
                    sum[2] += xyz.z;
                }
            }
            // `linear_srgb_from_xyz` takes XYZ on the Y = 100 scale of its white.
            let n = (MAP_SUPERSAMPLING * MAP_SUPERSAMPLING) as f64 / 100.0;
            let rgb = linear_srgb_from_xyz(Xyz::new(sum[0] / n, sum[1] / n, sum[2] / n), white);
            pixels.push([rgb.red as f32, rgb.green as f32, rgb.blue as f32]);
        }
    }
    pixels
}

/// The factor between the luminance Coatlab gives a loaded map's texel and the
/// luminance of the texel's RGB: the median over the upper hemisphere's texels
/// brighter than a tenth of the mean (up-sampling keeps luminance, so all agree).
fn normalisation_factor(env: &Environment, film: &Film, pixels: &[[f32; 3]]) -> f64 {
    let mut radiance = vec![0.0f32; env.channels().len()];
    let luminance = |p: &[f32; 3]| {
        0.212_639 * f64::from(p[0]) + 0.715_169 * f64::from(p[1]) + 0.072_192 * f64::from(p[2])
    };
    let mean = pixels.iter().map(luminance).sum::<f64>() / pixels.len() as f64;
    let mut ratios = Vec::new();
    for row in (0..MAP_HEIGHT / 2).step_by(7) {
        for col in (0..MAP_WIDTH).step_by(7) {
            let rgb = &pixels[row * MAP_WIDTH + col];
            let y_rgb = luminance(rgb);
            if y_rgb < 0.1 * mean {
                continue;
            }
            let u = (col as f64 + 0.5) / MAP_WIDTH as f64;
            let v = (row as f64 + 0.5) / MAP_HEIGHT as f64;
            env.radiance(direction(u, v), &mut radiance);
            ratios.push(film.xyz_of(&radiance).y / y_rgb);
        }
    }
    ratios.sort_by(f64::total_cmp);
    ratios.get(ratios.len() / 2).copied().unwrap_or(1.0)
}
