//! The stored render reference: the default car in the studio, the signal-red
//! preset, small, from enough independent replicas that its own noise is far below
//! a test render's. Stores per pixel the mean X, Y, Z over the replicas and the
//! variance of those means (the replicas' spread over their count: the sampler's
//! stratified samples make a single render's s²/n an over-statement).
//! Written by `examples/make_render_reference.rs`, read by `tests/render.rs`; both
//! also include `support/progressive.rs`.
#![allow(dead_code)] // the example and the test each use their own half

use std::path::Path;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::progressive::RenderSettings;
use coatlab_core::scene::car::{CarParameters, generate};

use crate::image_stats::{Replicas, film_image};
use crate::progressive::{film_in_passes, shading_for};

pub const REFERENCE_FILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/render_reference.csv"
);
/// The first seed of the reference's replicas (replica i has seed + i).
pub const REFERENCE_SEED: u64 = 1000;
/// The reference's replicas and samples per pixel of each.
pub const REFERENCE_REPLICAS: (usize, u32) = (32, 256);
const WIDTH: u32 = 48;
const HEIGHT: u32 = 27;
const WAVELENGTHS: usize = 16;

/// Renders the reference scene with `seed` and `spp` samples per pixel.
pub fn reference_render(seed: u64, spp: u32) -> Film {
    let grid = WavelengthGrid::visible(WAVELENGTHS).expect("grid");
    let design = presets::all().into_iter().next().expect("preset").design;
    let model = design.model(grid).expect("model");
    let scene = generate(&CarParameters::default());
    let shading = shading_for(&scene, &model, ShadingModel::Paint);
    let camera = Camera::framing(scene.mesh.bounds().expect("bounds"), WIDTH, HEIGHT);
    let settings = RenderSettings::seeded(seed);
    let environment = Environment::studio(&grid);
    film_in_passes(scene, environment, shading, camera, settings, spp, 16)
}

/// `k` renders of the reference scene, seeds `first_seed` + i, `spp` samples each.
pub fn reference_replicas(first_seed: u64, k: usize, spp: u32) -> Replicas {
    Replicas::collect(WIDTH, HEIGHT, k, |i| {
        film_image(&reference_render(first_seed + i as u64, spp))
    })
}

/// Per pixel the mean XYZ and the variance of each mean, and how many replicas.
pub struct Reference {
    pub width: u32,
    pub height: u32,
    replicas: usize,
    values: Vec<[f64; 6]>,
}

impl Reference {
    pub fn from_replicas(replicas: &Replicas) -> Self {
        Self {
            width: replicas.width,
            height: replicas.height,
            replicas: replicas.count as usize,
            values: replicas
                .mean
                .iter()
                .zip(&replicas.variance)
                .map(|(m, v)| [m[0], m[1], m[2], v[0], v[1], v[2]])
                .collect(),
        }
    }

    /// The reference as replicas, for `image_stats::compare`.
    pub fn replicas(&self) -> Replicas {
        Replicas {
            width: self.width,
            height: self.height,
            count: self.replicas as f64,
            mean: self.values.iter().map(|v| [v[0], v[1], v[2]]).collect(),
            variance: self.values.iter().map(|v| [v[3], v[4], v[5]]).collect(),
        }
    }

    /// A seed that none of the reference's replicas used.
    pub fn seed_for_test(&self) -> u64 {
        REFERENCE_SEED + self.replicas as u64
    }

    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let (k, spp) = REFERENCE_REPLICAS;
        // Six significant digits of a mean: its own noise is about 10⁻³ of it.
        let mut text = format!(
            "# Coatlab render reference: default car, studio, signal-red, {WAVELENGTHS} \
             wavelengths, {k} replicas of {spp} spp, seeds {REFERENCE_SEED}..{}\n\
             # replicas={}\nx,y,X,Y,Z,var_X,var_Y,var_Z\n",
            REFERENCE_SEED + k as u64 - 1,
            self.replicas
        );
        for y in 0..self.height {
            for x in 0..self.width {
                let v = self.values[(y * self.width + x) as usize];
                text.push_str(&format!(
                    "{x},{y},{:.5e},{:.5e},{:.5e},{:.3e},{:.3e},{:.3e}\n",
                    v[0], v[1], v[2], v[3], v[4], v[5]
                ));
            }
        }
        std::fs::write(path, text)
    }

    pub fn read(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut values = Vec::new();
        let (mut width, mut height, mut replicas) = (0, 0, 0);
        for (number, line) in text.lines().enumerate() {
            if let Some(k) = line.strip_prefix("# replicas=") {
                replicas = k
                    .parse()
                    .map_err(|_| format!("{}: bad replica count {k}", path.display()))?;
                continue;
            }
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
            values.push([
                parse(2)?,
                parse(3)?,
                parse(4)?,
                parse(5)?,
                parse(6)?,
                parse(7)?,
            ]);
        }
        if (width, height) != (WIDTH, HEIGHT) || values.len() != (WIDTH * HEIGHT) as usize {
            return Err(format!(
                "{}: expected {WIDTH}x{HEIGHT} pixels",
                path.display()
            ));
        }
        if replicas < 2 {
            return Err(format!("{}: no replica count", path.display()));
        }
        Ok(Self {
            width,
            height,
            replicas,
            values,
        })
    }
}
