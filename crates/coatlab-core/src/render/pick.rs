//! What is under a pixel: the ray through it from the camera ([`Camera::ray`])
//! against the scene's BVH, the same closest-hit query the tracer's camera rays
//! make, so a click in the preview names the material the image shows there.
//! The floor is not picked: it is no material of the scene. The same rays on a
//! coarse grid over the image measure how much of each material the view shows
//! ([`visible_areas`]).

use super::camera::Camera;
use super::geometry::Surface;
use super::progressive::RenderScene;

/// The surface under a pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pick {
    /// The material's index in the scene's materials.
    pub material: u32,
    /// The hit point, world space, metres.
    pub position: [f32; 3],
    /// Distance from the camera, metres.
    pub distance_m: f32,
}

/// The scene material seen through the continuous pixel coordinates
/// (`pixel_x`, `pixel_y`) of `camera`'s image, if a triangle of the scene is
/// there (nothing for the background or the floor, or a point off the image).
pub fn pick(scene: &RenderScene, camera: &Camera, pixel_x: f32, pixel_y: f32) -> Option<Pick> {
    let inside = |v: f32, size: u32| v.is_finite() && (0.0..=size as f32).contains(&v);
    if !inside(pixel_x, camera.width()) || !inside(pixel_y, camera.height()) {
        return None;
    }
    let (origin, direction) = camera.ray(pixel_x, pixel_y);
    let hit = scene
        .geometry()
        .intersect_with_floor(origin, direction, f32::INFINITY, false)?;
    match hit.surface {
        Surface::Mesh { material } => Some(Pick {
            material,
            position: hit.position,
            distance_m: hit.t,
        }),
        Surface::Floor => None,
    }
}

/// Per material of `scene`, the area the view of `camera` sees of it, m²:
/// the sum over the rays through the centres of a `columns` × `rows` grid over
/// the image of the ray's solid angle times the squared distance to what it
/// hits (the cell's footprint across the line of sight there). It is the
/// projected area seen, nothing behind other surfaces counted, and converges to
/// it as the grid gets finer; a surface seen edge-on shows little of its area.
pub fn visible_areas(scene: &RenderScene, camera: &Camera, columns: u32, rows: u32) -> Vec<f32> {
    let mut areas = vec![0.0f32; scene.materials().len()];
    let (columns, rows) = (columns.max(1), rows.max(1));
    let tan_v = (0.5 * camera.vertical_fov_deg().to_radians()).tan();
    let tan_h = tan_v * camera.width() as f32 / camera.height() as f32;
    // A cell's area on the image plane at unit distance along the view.
    let cell = (2.0 * tan_h / columns as f32) * (2.0 * tan_v / rows as f32);
    let forward = glam::Vec3::from(camera.forward()).normalize();
    let (sx, sy) = (
        camera.width() as f32 / columns as f32,
        camera.height() as f32 / rows as f32,
    );
    for row in 0..rows {
        for column in 0..columns {
            let (px, py) = ((column as f32 + 0.5) * sx, (row as f32 + 0.5) * sy);
            let Some(hit) = pick(scene, camera, px, py) else {
                continue;
            };
            let (_, direction) = camera.ray(px, py);
            let cos = glam::Vec3::from(direction).normalize().dot(forward);
            // Solid angle of the cell: its plane area × cos³ of its angle off the axis.
            let solid_angle = cell * cos * cos * cos;
            if let Some(area) = areas.get_mut(hit.material as usize) {
                *area += solid_angle * hit.distance_m * hit.distance_m;
            }
        }
    }
    areas
}

/// `painted` (material indices) with `material` added, or taken out if it was
/// there; sorted: what a click on the car or a box in the paint list makes of
/// the materials that carry the design.
pub fn toggled(painted: &[u32], material: u32) -> Vec<u32> {
    let mut chosen: Vec<u32> = painted.iter().copied().filter(|&i| i != material).collect();
    if chosen.len() == painted.len() {
        chosen.push(material);
    }
    chosen.sort_unstable();
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::car::{BODY, CarParameters, generate};

    /// From the default view the image centre looks at the middle of the car's
    /// box, on the body; a corner of the image sees the background.
    #[test]
    fn the_image_centre_of_the_default_view_is_the_body() {
        let scene = RenderScene::new(generate(&CarParameters::default())).unwrap();
        let camera = scene.default_camera(320, 180);
        let hit = pick(&scene, &camera, 160.0, 90.0).expect("the centre hits the car");
        assert_eq!(hit.material, BODY);
        assert!(scene.paint_materials().contains(&hit.material));
        let seen = (glam::Vec3::from(hit.position) - glam::Vec3::from(camera.position())).length();
        assert!((seen - hit.distance_m).abs() < 1e-3 * seen);
        assert_eq!(
            pick(&scene, &camera, 0.5, 0.5),
            None,
            "the sky above the car"
        );
        assert_eq!(pick(&scene, &camera, -1.0, 90.0), None, "off the image");
        assert_eq!(pick(&scene, &camera, f32::NAN, 90.0), None);
    }

    /// A 1 m square facing the camera squarely is seen as 1 m² (to the
    /// grid's resolution of its edges); a smaller square behind it is not seen.
    #[test]
    fn a_square_facing_the_camera_shows_its_area_and_hides_what_is_behind_it() {
        use crate::scene::{Scene, SceneMaterial, TriangleMesh};
        let mut mesh = TriangleMesh::default();
        for (z, half, material) in [(0.0f32, 0.5f32, 0u32), (-1.0, 0.3, 1)] {
            let base = mesh.positions.len() as u32;
            for (x, y) in [(-half, -half), (half, -half), (half, half), (-half, half)] {
                mesh.positions.push([x, 1.0 + y, z]);
                mesh.normals.push([0.0, 0.0, 1.0]);
            }
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.triangles.push([base, base + 2, base + 3]);
            mesh.triangle_material.extend([material; 2]);
        }
        let material = |name: &str| SceneMaterial {
            name: name.into(),
            ..SceneMaterial::default()
        };
        let scene = Scene {
            mesh,
            materials: vec![material("front"), material("behind")],
            paint_materials: vec![0],
            ..Scene::default()
        };
        let scene = RenderScene::new(scene).unwrap();
        // From 3 m and from twice as far the same area (not the image share,
        // which is a quarter).
        for (distance, tolerance) in [(3.0, 0.03), (6.0, 0.05)] {
            let camera = Camera::new(
                [0.0, 1.0, distance],
                [0.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                40.0,
                160,
                100,
            )
            .unwrap();
            let areas = visible_areas(&scene, &camera, 256, 160);
            assert!(
                (areas[0] - 1.0).abs() < tolerance,
                "front square from {distance} m: {} m²",
                areas[0]
            );
            assert_eq!(areas[1], 0.0, "the square behind it");
        }
    }

    #[test]
    fn toggling_adds_or_removes_one_material() {
        assert_eq!(toggled(&[0, 3], 2), vec![0, 2, 3]);
        assert_eq!(toggled(&[0, 2, 3], 2), vec![0, 3]);
        assert_eq!(toggled(&[], 5), vec![5]);
    }
}
