//! A painted unit sphere, the camera that frames it and the exact ray–sphere hit:
//! the simple object of the image-space furnace and mirror tests, whose every
//! pixel's view geometry is known analytically.
#![allow(dead_code)] // each test crate uses its own subset

use coatlab_core::render::camera::Camera;
use coatlab_core::scene::{Scene, SceneMaterial, TriangleMesh};

/// A unit sphere at (0, 1, 0) with smooth normals, `rings` × 2·`rings` quads, all
/// of its one material painted.
pub fn sphere(rings: u32) -> Scene {
    let mut mesh = TriangleMesh::default();
    let segments = 2 * rings;
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
            let n = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            mesh.positions.push([n[0], n[1] + 1.0, n[2]]);
            mesh.normals.push(n);
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let a = i * segments + j;
            let b = i * segments + (j + 1) % segments;
            let (c, d) = (a + segments, b + segments);
            mesh.triangles.push([a, c, b]);
            mesh.triangles.push([b, c, d]);
        }
    }
    mesh.triangle_material = vec![0; mesh.triangles.len()];
    Scene {
        mesh,
        materials: vec![SceneMaterial {
            name: "paint".into(),
            base_color: palette::LinSrgb::new(0.5, 0.5, 0.5),
            roughness: 0.5,
            metallic: 0.0,
            area_m2: 4.0 * std::f32::consts::PI,
            ..SceneMaterial::default()
        }],
        paint_materials: vec![0],
        ..Scene::default()
    }
}

/// A square `size` × `size` camera 6 m in front of the sphere, 22° field of view.
pub fn sphere_camera(size: u32) -> Camera {
    Camera::new(
        [0.0, 1.0, 6.0],
        [0.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        22.0,
        size,
        size,
    )
    .expect("camera")
}

/// Where the ray through continuous pixel (`px`, `py`) hits the unit sphere: the
/// unit normal there and the ray's direction, in double precision; `None` on a miss.
pub fn sphere_hit(camera: &Camera, px: f32, py: f32) -> Option<([f64; 3], [f64; 3])> {
    let (o, d) = camera.ray(px, py);
    let oc = [f64::from(o[0]), f64::from(o[1]) - 1.0, f64::from(o[2])];
    let d = d.map(f64::from);
    let b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
    let c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - 1.0;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    Some(([oc[0] + t * d[0], oc[1] + t * d[1], oc[2] + t * d[2]], d))
}
