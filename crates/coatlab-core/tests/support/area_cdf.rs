//! The running sum of a mesh's triangle areas, for picking triangles in
//! proportion to their area (shared by the BVH tests and benchmarks).

use coatlab_core::scene::TriangleMesh;

/// Entry `t` is the summed area of triangles `0..=t` (in f64, in index order);
/// the last entry is the mesh's total area.
pub fn area_cdf(mesh: &TriangleMesh) -> Vec<f64> {
    let mut cdf = Vec::with_capacity(mesh.triangles.len());
    let mut acc = 0.0f64;
    for t in 0..mesh.triangles.len() {
        acc += f64::from(mesh.triangle_area(t));
        cdf.push(acc);
    }
    cdf
}
