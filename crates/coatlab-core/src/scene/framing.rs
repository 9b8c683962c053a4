//! Which part of a scene is the car: the bounds the camera frames and the
//! orientation heuristic reads, so that a cloth drape, a ground plane or a
//! backdrop does not shrink the car in the frame or turn it.
//!
//! The rule (documented for users in `docs/scenes.md`, "Framing"):
//!
//! 1. Start from the box around the triangles of the painted materials (the car
//!    body, by the loader's heuristic or the user's choice).
//! 2. Grow it by [`CAR_MARGIN`] of its size on every horizontal side and above, and
//!    down to the lowest point of the scene (wheels and tyres hang below the body).
//! 3. A material belongs to the car when at least [`CAR_MATERIAL_SHARE`] of its
//!    area lies in triangles wholly inside that box; the painted ones always do.
//! 4. The car is every triangle of the car's materials lying wholly inside the
//!    grown box; its bounds are the bounds of those triangles.
//!
//! A material that spreads beyond the car (a drape, a floor, a wall) drops out
//! whole, also where it passes under the car; the car's own parts (wheels, glass,
//! mirrors) stay, and a stray triangle cannot make the box larger than the grown
//! one. Limits: a ground plane sharing a material with the car's parts stays in
//! where it is inside the box; without painted triangles the whole scene is the car.

use super::TriangleMesh;

/// Axis-aligned bounds (min, max), metres.
pub type Bounds = ([f32; 3], [f32; 3]);

/// How far the body's box is grown to take in the rest of the car, as a fraction
/// of its size in each axis: wheels, mirrors and spoilers stick out of the painted
/// shell by a few per cent of its length.
pub const CAR_MARGIN: f32 = 0.15;

/// Share of a material's area that must lie inside the grown box for the material
/// to be part of the car: a little below 1, so a part whose tip pokes out (an
/// antenna, a spoiler beyond the margin) still counts.
pub const CAR_MATERIAL_SHARE: f32 = 0.9;

/// Which triangles of `mesh` belong to the car by the rule of this module, given
/// the materials that carry the paint.
pub fn car_triangles(mesh: &TriangleMesh, paint_materials: &[u32]) -> Vec<bool> {
    let Some(grown) = grown_body_box(mesh, paint_materials) else {
        return vec![true; mesh.triangle_count()];
    };
    let inside = |p: [f32; 3]| (0..3).all(|k| p[k] >= grown.0[k] && p[k] <= grown.1[k]);
    let materials = mesh
        .triangle_material
        .iter()
        .max()
        .map_or(0, |&m| m as usize + 1);
    let (mut area_inside, mut area_total) = (vec![0.0f32; materials], vec![0.0f32; materials]);
    let wholly_inside: Vec<bool> = mesh
        .triangles
        .iter()
        .map(|t| t.iter().all(|&v| inside(mesh.positions[v as usize])))
        .collect();
    for (t, &whole) in wholly_inside.iter().enumerate() {
        let m = mesh.triangle_material[t] as usize;
        let area = mesh.triangle_area(t);
        area_total[m] += area;
        if whole {
            area_inside[m] += area;
        }
    }
    let car_material = |m: u32| {
        paint_materials.contains(&m)
            || area_inside[m as usize] >= CAR_MATERIAL_SHARE * area_total[m as usize]
    };
    wholly_inside
        .iter()
        .zip(&mesh.triangle_material)
        .map(|(&whole, &m)| whole && car_material(m))
        .collect()
}

/// The car's bounds in `mesh` (see the module's rule); `None` for an empty mesh.
pub fn car_bounds(mesh: &TriangleMesh, paint_materials: &[u32]) -> Option<Bounds> {
    let car = car_triangles(mesh, paint_materials);
    bounds_of(mesh, |t| car[t]).or_else(|| mesh.bounds())
}

/// The painted triangles' box grown by the margin and down to the scene's floor.
fn grown_body_box(mesh: &TriangleMesh, paint_materials: &[u32]) -> Option<Bounds> {
    let (lo, hi) = bounds_of(mesh, |t| {
        paint_materials.contains(&mesh.triangle_material[t])
    })?;
    let (scene_lo, _) = mesh.bounds()?;
    let grown_lo = std::array::from_fn(|k| {
        if k == 1 {
            scene_lo[1]
        } else {
            lo[k] - CAR_MARGIN * (hi[k] - lo[k])
        }
    });
    let grown_hi = std::array::from_fn(|k| hi[k] + CAR_MARGIN * (hi[k] - lo[k]));
    Some((grown_lo, grown_hi))
}

/// Bounds of the vertices of the triangles `keep` selects; `None` when none is kept.
fn bounds_of(mesh: &TriangleMesh, keep: impl Fn(usize) -> bool) -> Option<Bounds> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut any = false;
    for (t, triangle) in mesh.triangles.iter().enumerate() {
        if !keep(t) {
            continue;
        }
        any = true;
        for &v in triangle {
            let p = mesh.positions[v as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    any.then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quad from `lo` to `hi` in the plane y = `y`, material `material`.
    fn add_quad(mesh: &mut TriangleMesh, lo: [f32; 2], hi: [f32; 2], y: f32, material: u32) {
        let base = mesh.positions.len() as u32;
        for (x, z) in [
            (lo[0], lo[1]),
            (hi[0], lo[1]),
            (hi[0], hi[1]),
            (lo[0], hi[1]),
        ] {
            mesh.positions.push([x, y, z]);
            mesh.normals.push([0.0, 1.0, 0.0]);
        }
        mesh.triangles.push([base, base + 2, base + 1]);
        mesh.triangles.push([base, base + 3, base + 2]);
        mesh.triangle_material.extend([material; 2]);
    }

    #[test]
    fn a_floor_larger_than_the_car_is_left_out_and_wheels_stay_in() {
        let mut mesh = TriangleMesh::default();
        // Body (material 0) 2 × 4 m at 0.3–1.3 m high: two quads, bottom and top.
        add_quad(&mut mesh, [-1.0, -2.0], [1.0, 2.0], 0.3, 0);
        add_quad(&mut mesh, [-1.0, -2.0], [1.0, 2.0], 1.3, 0);
        // A "wheel" (material 1) below the body, slightly outside it sideways.
        add_quad(&mut mesh, [0.9, 1.0], [1.1, 1.6], 0.0, 1);
        // A 20 m floor (material 2).
        add_quad(&mut mesh, [-10.0, -10.0], [10.0, 10.0], 0.0, 2);
        // A drape (material 3) under the car, most of it outside the car's box, one
        // of its pieces wholly inside.
        add_quad(&mut mesh, [-3.0, -3.0], [3.0, 3.0], 0.1, 3);
        add_quad(&mut mesh, [-0.5, -0.5], [0.5, 0.5], 0.05, 3);
        let (lo, hi) = car_bounds(&mesh, &[0]).unwrap();
        assert_eq!(lo, [-1.0, 0.0, -2.0]);
        assert_eq!(hi, [1.1, 1.3, 2.0]);
        let mut expected = vec![true; 6];
        expected.extend([false; 6]);
        assert_eq!(car_triangles(&mesh, &[0]), expected);
        // Nothing painted: the whole scene.
        assert_eq!(car_bounds(&mesh, &[]), mesh.bounds());
        assert_eq!(car_bounds(&TriangleMesh::default(), &[0]), None);
    }
}
