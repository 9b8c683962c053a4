//! The stored render reference: the default car in the studio, the signal-red
//! preset, small, with enough samples that its own noise is far below a test
//! render's. Stores per pixel the mean luminance Y and the variance of that mean.
//! Written by `examples/make_render_reference.rs`, read by `tests/render.rs`.
#![allow(dead_code)] // the example and the test each use their own half

use std::path::Path;
use std::sync::Arc;

use coatlab_core::design::presets;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::spectrum::WavelengthGrid;

pub const REFERENCE_FILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/render_reference.csv"
);
pub const REFERENCE_SEED: u64 = 1000;
const WIDTH: u32 = 48;
const HEIGHT: u32 = 27;
const WAVELENGTHS: usize = 16;

/// Renders the reference scene with `seed` and `spp` samples per pixel.
pub fn reference_render(seed: u64, spp: u32) -> Film {
    let grid = WavelengthGrid::visible(WAVELENGTHS).expect("grid");
    let design = presets::all().into_iter().next().expect("preset").design;
    let model = design.model(grid).expect("model");
    let scene = generate(&CarParameters::default());
    let shading = Shading::new(
        &model,
        ShadingModel::Paint,
        &scene.materials,
        &scene.paint_materials,
    );
    let camera = Camera::framing(scene.mesh.bounds().expect("bounds"), WIDTH, HEIGHT);
    let mut render = ProgressiveRender::new(
        Arc::new(RenderScene::new(scene).expect("scene")),
        Arc::new(Environment::studio(&grid)),
        Arc::new(shading),
        camera,
        RenderSettings {
            seed,
            ..RenderSettings::default()
        },
    )
    .expect("render");
    while render.samples_per_pixel() < spp {
        render.render_pass(16.min(spp - render.samples_per_pixel()));
    }
    render.film().clone()
}

/// Mean and variance-of-mean luminance images.
pub struct Reference {
    pub width: u32,
    pub height: u32,
    values: Vec<(f64, f64)>,
}

impl Reference {
    pub fn from_film(film: &Film) -> Self {
        let mut values = Vec::new();
        for y in 0..film.height() {
            for x in 0..film.width() {
                values.push((film.mean_xyz(x, y).y, film.variance_of_mean_xyz(x, y)[1]));
            }
        }
        Self {
            width: film.width(),
            height: film.height(),
            values,
        }
    }

    /// A seed that differs from the reference's.
    pub fn seed_for_test(&self) -> u64 {
        REFERENCE_SEED + 1
    }

    pub fn luminance(&self, x: u32, y: u32) -> (f64, f64) {
        self.values[(y * self.width + x) as usize]
    }

    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let mut text = String::from(
            "# Coatlab render reference: default car, studio, signal-red, 16 wavelengths, \
             seed 1000, 2048 spp\nx,y,mean_Y,variance_of_mean_Y\n",
        );
        for y in 0..self.height {
            for x in 0..self.width {
                let (m, v) = self.luminance(x, y);
                text.push_str(&format!("{x},{y},{m:.9e},{v:.9e}\n"));
            }
        }
        std::fs::write(path, text)
    }

    pub fn read(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut values = Vec::new();
        let (mut width, mut height) = (0, 0);
        for (number, line) in text.lines().enumerate() {
            if line.starts_with('#') || line.starts_with("x,") {
                continue;
            }
            let fields: Vec<&str> = line.split(',').collect();
            let parse = |i: usize| -> Result<f64, String> {
                fields.get(i).and_then(|f| f.parse().ok()).ok_or_else(|| {
                    format!(
                        "{} line {}: bad field {}",
                        path.display(),
                        number + 1,
                        i + 1
                    )
                })
            };
            let (x, y) = (parse(0)? as u32, parse(1)? as u32);
            width = width.max(x + 1);
            height = height.max(y + 1);
            values.push((parse(2)?, parse(3)?));
        }
        if (width, height) != (WIDTH, HEIGHT) || values.len() != (WIDTH * HEIGHT) as usize {
            return Err(format!(
                "{}: expected {WIDTH}x{HEIGHT} pixels",
                path.display()
            ));
        }
        Ok(Self {
            width,
            height,
            values,
        })
    }
}
