//! Writes the default car to `assets/default-car.glb`.
//!
//! `cargo run -p coatlab-core --example make_default_car [OUTPUT.glb] [--preview IMAGE.ppm]`
//!
//! The car is `coatlab_core::scene::car::generate(&CarParameters::default())`; the
//! test suite checks that the committed file is exactly what this writes. With
//! `--preview`, also rasterises four views (3/4 front, 3/4 rear, side, top) into a
//! binary PPM for a quick look: N·L shading plus a sky reflection on paint and glass.

use std::path::PathBuf;
use std::process::ExitCode;

use coatlab_core::io::atomic::write_bytes_atomically;
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{self, CarParameters};

fn main() -> ExitCode {
    let mut output = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/default-car.glb");
    let mut preview = None;
    let mut args = std::env::args_os().skip(1);
    while let Some(arg) = args.next() {
        if arg == "--preview" {
            preview = args.next().map(PathBuf::from);
        } else {
            output = PathBuf::from(arg);
        }
    }

    let scene = car::generate(&CarParameters::default());
    for warning in &scene.warnings {
        eprintln!("warning: {warning}");
    }
    let bytes = match car::to_glb(&scene) {
        Ok(bytes) => bytes,
        Err(error) => {
            eprintln!("error: {error}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(error) = write_bytes_atomically(&output, &bytes) {
        eprintln!("error: {error}");
        return ExitCode::FAILURE;
    }
    let (lo, hi) = scene.mesh.bounds().unwrap_or_default();
    println!(
        "{}: {} triangles, {} vertices, {} bytes; bounds x [{:.3}, {:.3}] y [{:.3}, {:.3}] z [{:.3}, {:.3}] m",
        output.display(),
        scene.mesh.triangle_count(),
        scene.mesh.positions.len(),
        bytes.len(),
        lo[0],
        hi[0],
        lo[1],
        hi[1],
        lo[2],
        hi[2]
    );
    for m in &scene.materials {
        println!("  {:<14} {:7.3} m²", m.name, m.area_m2);
    }
    if let Some(path) = preview {
        let image = preview::render(&scene, 720, 450);
        if let Err(error) = write_bytes_atomically(&path, &image) {
            eprintln!("error: {error}");
            return ExitCode::FAILURE;
        }
        println!("preview: {}", path.display());
    }
    ExitCode::SUCCESS
}

/// A throwaway z-buffer rasteriser, enough to see the shape.
mod preview {
    use glam::Vec3;

    use super::Scene;

    /// Four views in a 2 × 2 mosaic, as a binary PPM.
    pub fn render(scene: &Scene, width: usize, height: usize) -> Vec<u8> {
        let views: [(Vec3, Vec3, f32); 4] = [
            (Vec3::new(5.2, 1.7, 5.6), Vec3::new(0.0, 0.55, 0.0), 30.0),
            (Vec3::new(-5.0, 1.9, -5.8), Vec3::new(0.0, 0.55, 0.0), 30.0),
            (Vec3::new(9.0, 0.8, 0.0), Vec3::new(0.0, 0.6, 0.0), 30.0),
            (Vec3::new(0.01, 10.0, 0.0), Vec3::ZERO, 30.0),
        ];
        let mut image = vec![[0.0f32; 3]; 4 * width * height];
        for (k, &(eye, target, fov)) in views.iter().enumerate() {
            let tile = view(scene, eye, target, fov, width, height);
            let (ox, oy) = ((k % 2) * width, (k / 2) * height);
            for y in 0..height {
                for x in 0..width {
                    image[(oy + y) * 2 * width + ox + x] = tile[y * width + x];
                }
            }
        }
        let mut ppm = format!("P6\n{} {}\n255\n", 2 * width, 2 * height).into_bytes();
        for p in image {
            for c in p {
                ppm.push((c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0 + 0.5) as u8);
            }
        }
        ppm
    }

    fn view(
        scene: &Scene,
        eye: Vec3,
        target: Vec3,
        fov_deg: f32,
        w: usize,
        h: usize,
    ) -> Vec<[f32; 3]> {
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let focal = 0.5 * h as f32 / (0.5 * fov_deg.to_radians()).tan();
        let mut colour = vec![[0.0f32; 3]; w * h];
        let mut depth = vec![f32::INFINITY; w * h];
        // Background: sky above the horizon, ground below.
        for y in 0..h {
            for x in 0..w {
                let dir = forward * focal + right * (x as f32 - 0.5 * w as f32)
                    - up * (y as f32 - 0.5 * h as f32);
                colour[y * w + x] = if dir.y < 0.0 {
                    [0.25, 0.25, 0.23]
                } else {
                    [0.55, 0.62, 0.75]
                };
            }
        }
        let project = |p: Vec3| {
            let q = p - eye;
            let z = q.dot(forward);
            Vec3::new(
                0.5 * w as f32 + focal * q.dot(right) / z,
                0.5 * h as f32 - focal * q.dot(up) / z,
                z,
            )
        };
        let light = Vec3::new(0.4, 0.8, 0.45).normalize();
        let mesh = &scene.mesh;
        let screen: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|&p| project(Vec3::from(p)))
            .collect();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|i| screen[i as usize]);
            if a.z <= 0.0 || b.z <= 0.0 || c.z <= 0.0 {
                continue;
            }
            let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
            if area.abs() < 1e-12 {
                continue;
            }
            let x0 = a.x.min(b.x).min(c.x).floor().max(0.0) as usize;
            let x1 = (a.x.max(b.x).max(c.x).ceil() as usize).min(w - 1);
            let y0 = a.y.min(b.y).min(c.y).floor().max(0.0) as usize;
            let y1 = (a.y.max(b.y).max(c.y).ceil() as usize).min(h - 1);
            let material = &scene.materials[mesh.triangle_material[t] as usize];
            let [na, nb, nc] = tri.map(|i| Vec3::from(mesh.normals[i as usize]));
            let [pa, pb, pc] = tri.map(|i| Vec3::from(mesh.positions[i as usize]));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
                    let w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    let z = 1.0 / (w0 / a.z + w1 / b.z + w2 / c.z);
                    if z >= depth[y * w + x] {
                        continue;
                    }
                    depth[y * w + x] = z;
                    let (u0, u1, u2) = (w0 * z / a.z, w1 * z / b.z, w2 * z / c.z);
                    let n = (u0 * na + u1 * nb + u2 * nc).normalize();
                    let pos = u0 * pa + u1 * pb + u2 * pc;
                    let v = (eye - pos).normalize();
                    let diffuse = 0.2 + 0.8 * n.dot(light).max(0.0);
                    let base = material.base_color;
                    let mut c = [base.red, base.green, base.blue].map(|b| b * diffuse);
                    if material.metallic < 0.5 && material.roughness < 0.3 {
                        // Mirror reflection of a sky with a bright band near the horizon.
                        let r = 2.0 * n.dot(v) * n - v;
                        let fresnel = 0.04 + 0.96 * (1.0 - n.dot(v).max(0.0)).powi(5);
                        let sky = if r.y < 0.0 {
                            0.05
                        } else {
                            0.3 + 2.0 * (-(r.y - 0.15).powi(2) / 0.004).exp()
                        };
                        let spec = (r.dot(light).max(0.0)).powf(200.0) * 8.0;
                        c = c.map(|v| v + fresnel * sky + spec * 0.05);
                    } else if material.metallic > 0.5 {
                        c = c.map(|b| b * (0.5 + 0.5 * n.y.abs()));
                    }
                    colour[y * w + x] = c;
                }
            }
        }
        colour
    }
}
