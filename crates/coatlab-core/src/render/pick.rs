//! What is under a pixel: the ray through it from the camera ([`Camera::ray`])
//! against the scene's BVH, the same closest-hit query the tracer's camera rays
//! make, so a click in the preview names the material the image shows there.
//! The floor is not picked: it is no material of the scene.

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

    #[test]
    fn toggling_adds_or_removes_one_material() {
        assert_eq!(toggled(&[0, 3], 2), vec![0, 2, 3]);
        assert_eq!(toggled(&[0, 2, 3], 2), vec![0, 3]);
        assert_eq!(toggled(&[], 5), vec![5]);
    }
}
