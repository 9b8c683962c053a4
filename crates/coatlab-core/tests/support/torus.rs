//! A synthetic torus mesh shared by the acceleration-structure tests and benches
//! (included with `#[path]`, so each target compiles its own copy of one source).

use std::f32::consts::PI;

use coatlab_core::scene::TriangleMesh;

/// A torus of `rings × sides × 2` triangles around the y axis, 4.5 m across, centred
/// at y = 0.6, with unit normals and one material.
pub fn torus(rings: usize, sides: usize) -> TriangleMesh {
    let (major, minor) = (1.8f32, 0.45f32);
    let mut mesh = TriangleMesh::default();
    for i in 0..rings {
        let a = 2.0 * PI * i as f32 / rings as f32;
        for j in 0..sides {
            let b = 2.0 * PI * j as f32 / sides as f32;
            let r = major + minor * b.cos();
            mesh.positions
                .push([r * a.cos(), 0.6 + minor * b.sin(), r * a.sin()]);
            mesh.normals
                .push([b.cos() * a.cos(), b.sin(), b.cos() * a.sin()]);
        }
    }
    let index = |i: usize, j: usize| ((i % rings) * sides + j % sides) as u32;
    for i in 0..rings {
        for j in 0..sides {
            let [p, q, r, s] =
                [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)].map(|(i, j)| index(i, j));
            mesh.triangles.push([p, r, q]);
            mesh.triangles.push([p, s, r]);
        }
    }
    mesh.triangle_material = vec![0; mesh.triangles.len()];
    mesh
}
