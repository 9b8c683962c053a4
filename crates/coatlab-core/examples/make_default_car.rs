//! Writes the default car body to `assets/default-car.glb`.
//!
//! `cargo run -p coatlab-core --example make_default_car [OUTPUT.glb] [--preview IMAGE.ppm]`
//!
//! The car is `coatlab_core::scene::car::generate(&CarParameters::default())`; the
//! test suite checks that the committed file is exactly what this writes. With
//! `--preview`, also rasterises four views (3/4 front, 3/4 rear, side, top) into a
//! binary PPM for a quick look: N·L shading plus a sky reflection on paint and glass.

use std::path::PathBuf;
use std::process::ExitCode;

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
    if let Err(error) = std::fs::write(&output, &bytes) {
        eprintln!("error: cannot write {}: {error}", output.display());
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
        println!("  {:<6} {:7.3} m²", m.name, m.area_m2);
    }
    if let Some(path) = preview {
        let image = preview::render(&scene, 720, 450);
        if let Err(error) = std::fs::write(&path, image) {
            eprintln!("error: cannot write {}: {error}", path.display());
            return ExitCode::FAILURE;
        }
        println!("preview: {}", path.display());
    }
    ExitCode::SUCCESS
}

/// A throwaway z-buffer rasteriser, enough to see the shape.
mod preview {
    use super::Scene;

    type V3 = [f32; 3];

    fn sub(a: V3, b: V3) -> V3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn dot(a: V3, b: V3) -> f32 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    fn cross(a: V3, b: V3) -> V3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    fn normalise(a: V3) -> V3 {
        let l = dot(a, a).sqrt();
        [a[0] / l, a[1] / l, a[2] / l]
    }

    /// Four views in a 2 × 2 mosaic, as a binary PPM.
    pub fn render(scene: &Scene, width: usize, height: usize) -> Vec<u8> {
        let views: [(V3, V3, f32); 4] = [
            ([5.2, 1.7, 5.6], [0.0, 0.55, 0.0], 30.0),
            ([-5.0, 1.9, -5.8], [0.0, 0.55, 0.0], 30.0),
            ([9.0, 0.8, 0.0], [0.0, 0.6, 0.0], 30.0),
            ([0.01, 10.0, 0.0], [0.0, 0.0, 0.0], 30.0),
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

    fn view(scene: &Scene, eye: V3, target: V3, fov_deg: f32, w: usize, h: usize) -> Vec<[f32; 3]> {
        let forward = normalise(sub(target, eye));
        let right = normalise(cross(forward, [0.0, 1.0, 0.0]));
        let up = cross(right, forward);
        let focal = 0.5 * h as f32 / (0.5 * fov_deg.to_radians()).tan();
        let mut colour = vec![[0.0f32; 3]; w * h];
        let mut depth = vec![f32::INFINITY; w * h];
        // Background: sky above the horizon, ground below.
        for y in 0..h {
            for x in 0..w {
                let dir = normalise([
                    forward[0] * focal + right[0] * (x as f32 - 0.5 * w as f32)
                        - up[0] * (y as f32 - 0.5 * h as f32),
                    forward[1] * focal + right[1] * (x as f32 - 0.5 * w as f32)
                        - up[1] * (y as f32 - 0.5 * h as f32),
                    forward[2] * focal + right[2] * (x as f32 - 0.5 * w as f32)
                        - up[2] * (y as f32 - 0.5 * h as f32),
                ]);
                colour[y * w + x] = if dir[1] < 0.0 {
                    [0.25, 0.25, 0.23]
                } else {
                    [0.55, 0.62, 0.75]
                };
            }
        }
        let project = |p: V3| {
            let q = sub(p, eye);
            let z = dot(q, forward);
            [
                0.5 * w as f32 + focal * dot(q, right) / z,
                0.5 * h as f32 - focal * dot(q, up) / z,
                z,
            ]
        };
        let light = normalise([0.4, 0.8, 0.45]);
        let mesh = &scene.mesh;
        let screen: Vec<[f32; 3]> = mesh.positions.iter().map(|&p| project(p)).collect();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|i| screen[i as usize]);
            if a[2] <= 0.0 || b[2] <= 0.0 || c[2] <= 0.0 {
                continue;
            }
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if area.abs() < 1e-12 {
                continue;
            }
            let x0 = a[0].min(b[0]).min(c[0]).floor().max(0.0) as usize;
            let x1 = (a[0].max(b[0]).max(c[0]).ceil() as usize).min(w - 1);
            let y0 = a[1].min(b[1]).min(c[1]).floor().max(0.0) as usize;
            let y1 = (a[1].max(b[1]).max(c[1]).ceil() as usize).min(h - 1);
            let material = &scene.materials[mesh.triangle_material[t] as usize];
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let w0 = ((b[0] - px) * (c[1] - py) - (b[1] - py) * (c[0] - px)) / area;
                    let w1 = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    let z = 1.0 / (w0 / a[2] + w1 / b[2] + w2 / c[2]);
                    if z >= depth[y * w + x] {
                        continue;
                    }
                    depth[y * w + x] = z;
                    let [na, nb, nc] = tri.map(|i| mesh.normals[i as usize]);
                    let (u0, u1, u2) = (w0 * z / a[2], w1 * z / b[2], w2 * z / c[2]);
                    let n = normalise([
                        u0 * na[0] + u1 * nb[0] + u2 * nc[0],
                        u0 * na[1] + u1 * nb[1] + u2 * nc[1],
                        u0 * na[2] + u1 * nb[2] + u2 * nc[2],
                    ]);
                    let pos = [
                        u0 * mesh.positions[tri[0] as usize][0]
                            + u1 * mesh.positions[tri[1] as usize][0]
                            + u2 * mesh.positions[tri[2] as usize][0],
                        u0 * mesh.positions[tri[0] as usize][1]
                            + u1 * mesh.positions[tri[1] as usize][1]
                            + u2 * mesh.positions[tri[2] as usize][1],
                        u0 * mesh.positions[tri[0] as usize][2]
                            + u1 * mesh.positions[tri[1] as usize][2]
                            + u2 * mesh.positions[tri[2] as usize][2],
                    ];
                    let v = normalise(sub(eye, pos));
                    let diffuse = 0.2 + 0.8 * dot(n, light).max(0.0);
                    let base = material.base_color;
                    let mut c = [base.red, base.green, base.blue].map(|b| b * diffuse);
                    if material.metallic < 0.5 && material.roughness < 0.3 {
                        // Mirror reflection of a sky with a bright band near the horizon.
                        let r = sub(
                            [
                                2.0 * dot(n, v) * n[0],
                                2.0 * dot(n, v) * n[1],
                                2.0 * dot(n, v) * n[2],
                            ],
                            v,
                        );
                        let fresnel = 0.04 + 0.96 * (1.0 - dot(n, v).max(0.0)).powi(5);
                        let sky = if r[1] < 0.0 {
                            0.05
                        } else {
                            0.3 + 2.0 * (-(r[1] - 0.15).powi(2) / 0.004).exp()
                        };
                        let spec = (dot(r, light).max(0.0)).powf(200.0) * 8.0;
                        c = c.map(|v| v + fresnel * sky + spec * 0.05);
                    } else if material.metallic > 0.5 {
                        c = c.map(|b| b * (0.5 + 0.5 * n[1].abs()));
                    }
                    colour[y * w + x] = c;
                }
            }
        }
        colour
    }
}
