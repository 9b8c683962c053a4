//! Textures of glTF materials: images in buffer views, files and data URIs are
//! decoded and looked up where rays hit; bad images (a header over the pixel
//! limit, truncated PNGs and JPEGs, missing files, other formats) leave a warning
//! naming the image and the material, the factor stands in and the load goes on.
//! Every file is written by the test itself.

use std::io::Cursor;
use std::path::Path;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::geometry::RenderGeometry;
use coatlab_core::render::integrator::{IntegratorSettings, NoRecord, PathBuffers, PathTracer};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::sampler::PixelSampler;
use coatlab_core::render::texturing::{TexturePoint, surface_parameters};
use coatlab_core::scene::Scene;
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::scene::texture::MAX_TEXTURE_PIXELS;

#[path = "support/gltf_testdata.rs"]
mod gltf_testdata;
use gltf_testdata::{base64, glb};

/// A temporary folder, removed when dropped.
fn folder() -> tempfile::TempDir {
    tempfile::tempdir().expect("a temporary folder")
}

/// A 16 × 16 image, left half black, right half white, encoded as `format`.
fn two_tone(format: image::ImageFormat) -> Vec<u8> {
    let img = image::RgbImage::from_fn(16, 16, |x, _| {
        if x < 8 {
            image::Rgb([0, 0, 0])
        } else {
            image::Rgb([255, 255, 255])
        }
    });
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, format).expect("encodes");
    out.into_inner()
}

/// CRC-32 (IEEE), for a PNG chunk written by hand.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A PNG whose header (valid, with its checksum) claims `width` × `height`
/// pixels and whose data holds none of them.
fn png_header_only(width: u32, height: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut header = Vec::new();
    header.extend_from_slice(&width.to_be_bytes());
    header.extend_from_slice(&height.to_be_bytes());
    header.extend_from_slice(&[8, 2, 0, 0, 0]);
    // The decoder reads up to the first data chunk before it reports the size;
    // this one holds an empty zlib stream, far short of the pixels claimed.
    let empty_zlib = [0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01];
    for (kind, data) in [
        (b"IHDR", &header[..]),
        (b"IDAT", &empty_zlib[..]),
        (b"IEND", &[][..]),
    ] {
        let mut chunk = kind.to_vec();
        chunk.extend_from_slice(data);
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        out.extend_from_slice(&chunk);
        out.extend_from_slice(&crc32(&chunk).to_be_bytes());
    }
    out
}

/// A square (two triangles, 1 m, facing +z) with `TEXCOORD_0` spanning the
/// unit square, material 0 ("CarPaint", untextured) unused and material 1
/// ("Trim") with `texture_json` as its base-colour texture's image. `image`
/// is the image object; `bin_extra` is appended to the buffer (for images in a
/// buffer view, whose view is the third).
fn square_gltf(image: &str, bin_extra: &[u8]) -> (String, Vec<u8>) {
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let uv: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin = Vec::new();
    positions
        .iter()
        .flatten()
        .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    uv.iter()
        .flatten()
        .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    indices
        .iter()
        .for_each(|i| bin.extend_from_slice(&i.to_le_bytes()));
    let image_offset = bin.len();
    bin.extend_from_slice(bin_extra);
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"mesh":0}}],
"meshes":[{{"name":"Square","primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":1}}]}}],
"materials":[{{"name":"CarPaint"}},{{"name":"Trim","pbrMetallicRoughness":{{"baseColorFactor":[1,1,1,1],"metallicFactor":0,"roughnessFactor":1,"baseColorTexture":{{"index":0}}}}}}],
"textures":[{{"source":0,"sampler":0}}],
"samplers":[{{"wrapS":33071,"wrapT":33648}}],
"images":[{image}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},
{{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},
{{"buffer":0,"byteOffset":80,"byteLength":12}}{image_view}],
"buffers":[{{"byteLength":{bin_len}}}]}}"#,
        image_view = if bin_extra.is_empty() {
            String::new()
        } else {
            format!(
                r#",{{"buffer":0,"byteOffset":{image_offset},"byteLength":{}}}"#,
                bin_extra.len()
            )
        },
        bin_len = bin.len(),
    );
    (json, bin)
}

/// Writes the square with `image` as a GLB in `dir` and loads it.
fn load_square(dir: &Path, image: &str, bin_extra: &[u8]) -> Scene {
    let (json, bin) = square_gltf(image, bin_extra);
    let path = dir.join("square.glb");
    std::fs::write(&path, glb(&json, &bin)).expect("written");
    // The paint goes on the unused material, so "Trim" keeps its own.
    let options = LoadOptions {
        paint_material: Some("CarPaint".into()),
        ..LoadOptions::default()
    };
    load(&path, &options).expect("the square loads")
}

fn trim(scene: &Scene) -> &coatlab_core::scene::SceneMaterial {
    scene
        .materials
        .iter()
        .find(|m| m.name == "Trim")
        .expect("the Trim material")
}

/// The base colour where the square's triangle 0 is hit at barycentric `b`.
fn base_colour_at(scene: &Scene, b: [f32; 2]) -> f32 {
    let point = TexturePoint {
        triangle: 0,
        barycentric: b,
        shading_normal: [0.0, 0.0, 1.0],
        footprint_m: 0.0,
    };
    surface_parameters(trim(scene), &scene.mesh, &point)
        .bsdf
        .base_color
        .green
}

fn check_textured(scene: &Scene, what: &str) {
    let material = trim(scene);
    assert!(
        material.base_color_texture.is_some(),
        "{what}: {:?}",
        scene.warnings
    );
    // Triangle 0 is (0,0,0), (1,0,0), (1,1,0) with u = x: its barycentric u
    // weighs vertex 1 (u = 1), so u = b[0] + b[1].
    let dark = base_colour_at(scene, [0.1, 0.05]);
    let light = base_colour_at(scene, [0.5, 0.3]);
    assert!(dark < 0.02 && light > 0.98, "{what}: {dark} {light}");
    assert!(
        !scene
            .warnings
            .iter()
            .any(|w| w.contains("texture not used")),
        "{what}: {:?}",
        scene.warnings
    );
}

#[test]
fn images_in_buffer_views_files_and_data_uris_are_decoded() {
    let dir = folder();
    let png = two_tone(image::ImageFormat::Png);
    let scene = load_square(
        dir.path(),
        r#"{"bufferView":3,"mimeType":"image/png"}"#,
        &png,
    );
    check_textured(&scene, "buffer view");
    assert_eq!(scene.mesh.texcoords[0].len(), scene.mesh.positions.len());

    let jpeg = two_tone(image::ImageFormat::Jpeg);
    std::fs::write(dir.path().join("two tone.jpg"), &jpeg).expect("written");
    let scene = load_square(dir.path(), r#"{"uri":"two%20tone.jpg"}"#, &[]);
    check_textured(&scene, "JPEG file");

    let encoded = base64(&png);
    let scene = load_square(
        dir.path(),
        &format!(r#"{{"uri":"data:image/png;base64,{encoded}"}}"#),
        &[],
    );
    check_textured(&scene, "data URI");
}

/// Loads the square with a bad image file `name` holding `bytes` (not written
/// when `None`): the load succeeds, the warning names the image and the
/// material, and the factor stands in.
fn bad_image(name: &str, bytes: Option<&[u8]>, expect: &str) {
    let dir = folder();
    if let Some(bytes) = bytes {
        std::fs::write(dir.path().join(name), bytes).expect("written");
    }
    let scene = load_square(dir.path(), &format!(r#"{{"uri":"{name}"}}"#), &[]);
    assert!(trim(&scene).base_color_texture.is_none(), "{name}");
    let warning = scene
        .warnings
        .iter()
        .find(|w| w.contains("'Trim'"))
        .unwrap_or_else(|| panic!("{name}: no warning in {:?}", scene.warnings));
    assert!(warning.contains(name), "{warning}");
    assert!(warning.contains("factor stands in"), "{warning}");
    assert!(warning.contains(expect), "{name}: {warning}");
    // The factor (white) stands in everywhere.
    assert!((base_colour_at(&scene, [0.1, 0.05]) - 1.0).abs() < 1e-6);
}

#[test]
fn a_header_over_the_pixel_limit_is_refused_before_decoding() {
    let side = (MAX_TEXTURE_PIXELS as f64).sqrt() as u32 + 1;
    bad_image(
        "huge.png",
        Some(&png_header_only(side, side)),
        "more than the limit",
    );
}

#[test]
fn truncated_pngs_and_jpegs_are_warnings() {
    let png = two_tone(image::ImageFormat::Png);
    bad_image("cut.png", Some(&png[..png.len() / 2]), "cannot be decoded");
    let jpeg = two_tone(image::ImageFormat::Jpeg);
    bad_image(
        "cut.jpg",
        Some(&jpeg[..jpeg.len() / 2]),
        "cannot be decoded",
    );
    // A header that promises pixels the file does not have.
    bad_image(
        "empty.png",
        Some(&png_header_only(64, 64)),
        "cannot be decoded",
    );
}

#[test]
fn missing_files_and_other_formats_are_warnings() {
    bad_image("absent.png", None, "cannot read");
    bad_image(
        "anim.gif",
        Some(b"GIF89a\x01\x00\x01\x00\x00\x00\x00;"),
        "unsupported format",
    );
}

#[test]
fn a_textured_part_renders_with_its_texture() {
    // The square seen head-on from 2 m under the studio lights: the dark half of
    // its texture must render far darker than the light half. Independent
    // samples per pixel, so the halves' means are compared against their noise.
    let dir = folder();
    let scene = load_square(
        dir.path(),
        r#"{"bufferView":3,"mimeType":"image/png"}"#,
        &two_tone(image::ImageFormat::Png),
    );
    let grid = WavelengthGrid::visible(8).expect("grid");
    let model = presets::all()
        .into_iter()
        .next()
        .expect("a preset")
        .design
        .model(grid)
        .expect("model");
    let shading = Shading::for_scene(&model, ShadingModel::Paint, &scene);
    // Rays straight at points of triangle 0 (whichever way the loader turned the
    // square), from 2 m along its normal.
    let [p0, p1, p2] = scene.mesh.triangles[0].map(|i| scene.mesh.positions[i as usize]);
    let e1: [f32; 3] = std::array::from_fn(|k| p1[k] - p0[k]);
    let e2: [f32; 3] = std::array::from_fn(|k| p2[k] - p0[k]);
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let n = n.map(|x| x / len);
    let settings = IntegratorSettings::default();
    let (geometry, environment) = (
        RenderGeometry::new(scene.mesh.clone(), false).expect("geometry"),
        Environment::studio(&grid),
    );
    let tracer = PathTracer::new(&geometry, &environment, &shading, settings);
    let mut buffers = PathBuffers::new(tracer.len());
    let mut out = vec![0.0; tracer.len()];
    // Barycentric points with u = b0 + b1 in [u_from, u_from + 0.3].
    let mut mean = |u_from: f32| {
        let (mut sum, mut sum2, n_paths) = (0.0f64, 0.0f64, 400);
        for i in 0..n_paths {
            let mut sampler = PixelSampler::new(3, i, 0);
            let [jx, jy] = sampler.next_2d();
            let b1 = 0.1 * jy;
            let b0 = u_from + 0.2 * jx;
            let p: [f32; 3] = std::array::from_fn(|k| p0[k] + b0 * e1[k] + b1 * e2[k] + 2.0 * n[k]);
            let dir = n.map(|x| -x);
            tracer.radiance(p, dir, &mut sampler, &mut buffers, &mut out, &mut NoRecord);
            let v = f64::from(out.iter().sum::<f32>()) / out.len() as f64;
            sum += v;
            sum2 += v * v;
        }
        let m = sum / f64::from(n_paths);
        (
            m,
            ((sum2 / f64::from(n_paths) - m * m).max(0.0) / f64::from(n_paths)).sqrt(),
        )
    };
    let (dark, dark_se) = mean(0.05);
    let (light, light_se) = mean(0.65);
    assert!(light > 0.05, "the light half is lit: {light}");
    assert!(
        light - dark > 6.0 * (dark_se * dark_se + light_se * light_se).sqrt() && dark < 0.3 * light,
        "dark {dark} ± {dark_se}, light {light} ± {light_se}"
    );
}
