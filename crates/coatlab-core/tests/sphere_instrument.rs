//! The sphere instrument (d:8°) against the picture: a flat panel of a design under
//! the uniform white sky, seen at 8° from its normal, is lit exactly as a sample
//! in an integrating sphere is (unit radiance from every direction of the
//! hemisphere), so the tracer and the film must show it with the colour of the
//! instrument's specular-included reading.
//!
//! Both sides go through the film's own colour matching: the rendered pixels are
//! the film's XYZ, and the reading's reflectance factor is turned into XYZ by the
//! same film (`Film::xyz_of`); CIELAB is taken relative to the film's white (the
//! sky, Y = 1).

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::{Lab, Xyz, ciede2000, lab_from_xyz};
use coatlab_core::design::presets;
use coatlab_core::instruments::{self, SPHERE_GEOMETRIES};
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::progressive::RenderSettings;
use coatlab_core::scene::{Scene, SceneMaterial, TriangleMesh};

#[path = "support/image_stats.rs"]
mod image_stats;
use image_stats::seed;

#[path = "support/progressive.rs"]
mod progressive;
use progressive::render_film;

/// A 2 m square panel in the xy-plane facing +z, all paint.
fn panel() -> Scene {
    let mut mesh = TriangleMesh::default();
    for [x, y] in [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]] {
        mesh.positions.push([x, y, 0.0]);
        mesh.normals.push([0.0, 0.0, 1.0]);
    }
    mesh.triangles = vec![[0, 1, 2], [0, 2, 3]];
    mesh.triangle_material = vec![0; 2];
    Scene {
        mesh,
        materials: vec![SceneMaterial {
            name: "paint".into(),
            base_color: palette::LinSrgb::new(0.5, 0.5, 0.5),
            roughness: 0.1,
            metallic: 0.0,
            area_m2: 4.0,
            ..SceneMaterial::default()
        }],
        paint_materials: vec![0],
        ..Scene::default()
    }
}

/// CIELAB of `xyz` relative to `white`.
fn lab(xyz: [f64; 3], white: Xyz) -> Lab {
    lab_from_xyz(Xyz::new(xyz[0], xyz[1], xyz[2]), white)
}

#[test]
fn a_panel_under_the_white_sky_seen_at_8_degrees_shows_the_sci_reading() {
    let design = presets::by_slug("signal-red").expect("preset").design;
    let grid = WavelengthGrid::reference();
    let model = design.model(grid).expect("model");

    // The camera 5 m from the panel's centre, 8° from its normal, with a 4° field:
    // every ray meets the panel within 2° of 8°, where the reading changes by
    // less than 10⁻⁴.
    let size = 32;
    let at = 8f32.to_radians();
    let camera = Camera::new(
        [5.0 * at.sin(), 0.0, 5.0 * at.cos()],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        4.0,
        size,
        size,
    )
    .expect("camera");
    let film: Film = render_film(
        panel(),
        Environment::uniform(&grid),
        &model,
        ShadingModel::Paint,
        camera,
        RenderSettings::seeded(seed(80)),
        32,
    );

    // Every pixel is an independent estimate of the same value: their mean and its
    // standard error, per channel.
    let pixels: Vec<[f64; 3]> = (0..size)
        .flat_map(|y| (0..size).map(move |x| (x, y)))
        .map(|(x, y)| {
            let m = film.mean_xyz(x, y);
            [m.x, m.y, m.z]
        })
        .collect();
    let n = pixels.len() as f64;
    let mean: [f64; 3] = std::array::from_fn(|c| pixels.iter().map(|p| p[c]).sum::<f64>() / n);
    let standard_error: [f64; 3] = std::array::from_fn(|c| {
        let var = pixels.iter().map(|p| (p[c] - mean[c]).powi(2)).sum::<f64>() / (n - 1.0);
        (var / n).sqrt()
    });

    let white = film.xyz_of(&vec![1.0; grid.len()]);
    let predicted = |geometry| -> [f64; 3] {
        let r = instruments::reading(&model, geometry).expect("spectral");
        let radiance: Vec<f32> = r.reflectance_factor.iter().map(|&v| v as f32).collect();
        let xyz = film.xyz_of(&radiance);
        [xyz.x, xyz.y, xyz.z]
    };
    let sci = predicted(SPHERE_GEOMETRIES[0]);
    let sce = predicted(SPHERE_GEOMETRIES[1]);

    // Z-test per channel: within 4 standard errors, plus the renderer's f32 tables
    // (10⁻³ of the value, `paint::model::SpectralPaint`).
    for c in 0..3 {
        let allowed = 4.0 * standard_error[c] + 1e-3 * sci[c];
        assert!(
            (mean[c] - sci[c]).abs() <= allowed,
            "channel {c}: rendered {} ± {}, SCI reading {}",
            mean[c],
            standard_error[c],
            sci[c]
        );
    }
    // The colour: within 0.1 ΔE00, with noise small enough for that to mean
    // something (3 standard errors move the colour by well under 0.1).
    let rendered = lab(mean, white);
    let reading = lab(sci, white);
    let de = ciede2000(rendered, reading);
    let noise = ciede2000(
        reading,
        lab(
            std::array::from_fn(|c| sci[c] + 3.0 * standard_error[c]),
            white,
        ),
    );
    println!("rendered {rendered:?}, SCI reading {reading:?}: ΔE00 {de:.4} (3σ noise {noise:.4})");
    assert!(noise < 0.05, "too noisy to judge: {noise}");
    assert!(de <= 0.1, "ΔE00 {de}");
    // The test can tell: the SCE reading, without the coat's reflection, is far off.
    let without = ciede2000(rendered, lab(sce, white));
    println!("SCE reading: {without:.2} ΔE00 away");
    assert!(without > 1.0, "SCE is {without} ΔE00 away");
}
