//! The pinhole camera: rays from continuous pixel coordinates, an automatic 3/4
//! front framing of the car, and orbit/zoom/pan for the viewport.
//!
//! Pixel coordinates are continuous: x to the right, y down, (0, 0) the top-left
//! corner of the image and (width, height) the bottom-right one, so pixel (i, j)
//! covers [i, i + 1) × [j, j + 1) and its centre is (i + 0.5, j + 0.5). Antialiasing
//! passes the pixel index plus a jitter in [0, 1)².
//!
//! Parameters (set) and the orthonormal frame derived from them are kept apart: every
//! setter re-derives the frame, and [`Camera::ray`] only reads it.
//!
//! | parameter | unit | range |
//! | --- | --- | --- |
//! | position, look_at | m, world space | distinct points |
//! | up | world direction | not parallel to look_at − position |
//! | vertical field of view | degrees | (0, 180) |
//! | width × height | pixels | ≥ 1 each |

use glam::Vec3;
use thiserror::Error;

/// Vertical field of view of [`Camera::framing`] (degrees): a moderate telephoto
/// look, close to how cars are photographed, with little perspective distortion.
pub const FRAMING_FOV_DEG: f32 = 35.0;
/// Fraction of the half-image (in the tighter axis) that the framed box reaches.
pub const FRAMING_FILL: f32 = 0.85;
/// Azimuth of the framing view from the car's front (+Z) toward its left (+X),
/// degrees.
pub const FRAMING_AZIMUTH_DEG: f32 = 40.0;
/// Elevation of the framing view above the horizontal, degrees.
pub const FRAMING_ELEVATION_DEG: f32 = 15.0;
/// [`Camera::orbit`] keeps the elevation within ± this (degrees), away from the
/// poles where the view direction would become parallel to `up`.
pub const MAX_ORBIT_ELEVATION_DEG: f32 = 89.0;

/// Camera parameters that describe no usable camera.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CameraError {
    #[error("camera position {position:?} and look-at point {look_at:?} must differ")]
    PositionAtLookAt {
        position: [f32; 3],
        look_at: [f32; 3],
    },
    #[error("camera up vector {up:?} must be non-zero and not parallel to the view direction")]
    BadUp { up: [f32; 3] },
    #[error("vertical field of view {fov_deg}° must be in (0°, 180°)")]
    BadFov { fov_deg: f32 },
    #[error("image size {width}×{height} must be at least 1×1 pixel")]
    EmptyImage { width: u32, height: u32 },
    #[error("camera parameters must be finite")]
    NonFinite,
}

/// A pinhole camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    position: Vec3,
    look_at: Vec3,
    up: Vec3,
    vertical_fov_deg: f32,
    width: u32,
    height: u32,
    // Derived by `derive`.
    forward: Vec3,
    right_in_world: Vec3,
    up_in_image: Vec3,
    tan_half_fov: f32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, with `up` the world direction that
    /// appears upward in the image (it need not be perpendicular to the view).
    pub fn new(
        position: [f32; 3],
        look_at: [f32; 3],
        up: [f32; 3],
        vertical_fov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, CameraError> {
        let finite = position
            .iter()
            .chain(&look_at)
            .chain(&up)
            .chain(std::iter::once(&vertical_fov_deg))
            .all(|v| v.is_finite());
        if !finite {
            return Err(CameraError::NonFinite);
        }
        if !(vertical_fov_deg > 0.0 && vertical_fov_deg < 180.0) {
            return Err(CameraError::BadFov {
                fov_deg: vertical_fov_deg,
            });
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage { width, height });
        }
        let (p, l, u) = (Vec3::from(position), Vec3::from(look_at), Vec3::from(up));
        if (l - p).length_squared() == 0.0 {
            return Err(CameraError::PositionAtLookAt { position, look_at });
        }
        let forward = (l - p).normalize();
        if u.cross(forward).length_squared() <= 1e-12 * u.length_squared() || u == Vec3::ZERO {
            return Err(CameraError::BadUp { up });
        }
        let mut camera = Self {
            position: p,
            look_at: l,
            up: u.normalize(),
            vertical_fov_deg,
            width,
            height,
            forward,
            right_in_world: Vec3::X,
            up_in_image: Vec3::Y,
            tan_half_fov: 1.0,
        };
        camera.derive();
        Ok(camera)
    }

    /// The 3/4 front view of a car with axis-aligned `bounds` (min, max) in the
    /// world frame of [`crate::scene`] (Y up, front +Z): from the front-left
    /// (azimuth [`FRAMING_AZIMUTH_DEG`] from +Z toward +X, the driver's left; elevation
    /// [`FRAMING_ELEVATION_DEG`]), looking at the box centre, field of view
    /// [`FRAMING_FOV_DEG`].
    ///
    /// The distance is the smallest at which all 8 box corners project within
    /// [`FRAMING_FILL`] of the half-image in both axes, so the box (not its bounding
    /// sphere, which for a long car leaves it small) reaches 85 % in the tighter
    /// axis. Solved exactly: a corner at lateral offset a and depth offset b from the
    /// centre stays inside when a / (d + b) ≤ fill · tan(half fov) in that axis.
    ///
    /// Because the view looks at the box centre, perspective makes the image of the
    /// box lopsided (the near corners project further out): a 4.5 × 1.4 × 1.9 m car
    /// at 1280×720 spans x 15–75 %, y 27–93 % of the image (its near bottom corner
    /// at the 85 % limit). Centring the projected box instead would pan off the
    /// box centre.
    ///
    /// A degenerate box (a point) is treated as a 1 mm cube; zero sizes give 1×1.
    pub fn framing(bounds: ([f32; 3], [f32; 3]), width: u32, height: u32) -> Camera {
        let (lo, hi) = (Vec3::from(bounds.0), Vec3::from(bounds.1));
        let centre = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).abs().max(Vec3::splat(0.5e-3));
        let (width, height) = (width.max(1), height.max(1));
        let (azimuth, elevation) = (
            FRAMING_AZIMUTH_DEG.to_radians(),
            FRAMING_ELEVATION_DEG.to_radians(),
        );
        let towards_camera = Vec3::new(
            elevation.cos() * azimuth.sin(),
            elevation.sin(),
            elevation.cos() * azimuth.cos(),
        );
        // Frame of a camera looking along -towards_camera with Y up.
        let forward = -towards_camera;
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let tan_v = (0.5 * FRAMING_FOV_DEG.to_radians()).tan();
        let tan_h = tan_v * width as f32 / height as f32;
        let mut distance: f32 = 0.0;
        for corner in 0..8 {
            let offset = Vec3::new(
                if corner & 1 == 0 { -half.x } else { half.x },
                if corner & 2 == 0 { -half.y } else { half.y },
                if corner & 4 == 0 { -half.z } else { half.z },
            );
            let depth = offset.dot(forward);
            let need_h = offset.dot(right).abs() / (FRAMING_FILL * tan_h) - depth;
            let need_v = offset.dot(up).abs() / (FRAMING_FILL * tan_v) - depth;
            distance = distance.max(need_h).max(need_v);
        }
        // Stay outside the box whatever the aspect ratio.
        distance = distance.max(1.01 * half.length());
        let position = centre + distance * towards_camera;
        Camera::new(
            position.into(),
            centre.into(),
            [0.0, 1.0, 0.0],
            FRAMING_FOV_DEG,
            width,
            height,
        )
        .expect("framing builds a valid camera from finite bounds")
    }

    /// The ray through continuous pixel coordinates (`pixel_x`, `pixel_y`): origin at
    /// the camera position and a unit direction. The image centre
    /// (width / 2, height / 2) looks exactly at `look_at`.
    #[inline]
    pub fn ray(&self, pixel_x: f32, pixel_y: f32) -> ([f32; 3], [f32; 3]) {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * pixel_x / self.width as f32 - 1.0) * self.tan_half_fov * aspect;
        let sy = (1.0 - 2.0 * pixel_y / self.height as f32) * self.tan_half_fov;
        let direction =
            (self.forward + sx * self.right_in_world + sy * self.up_in_image).normalize();
        (self.position.into(), direction.into())
    }

    /// Orbits the camera around `look_at`: `yaw_deg` about the up axis
    /// (counter-clockwise seen from above, right-hand rule), then `pitch_deg` up
    /// (positive raises the camera, so it looks down more). The elevation is kept
    /// within ±[`MAX_ORBIT_ELEVATION_DEG`]; the distance is unchanged.
    pub fn orbit(&mut self, yaw_deg: f32, pitch_deg: f32) {
        let offset = self.position - self.look_at;
        let distance = offset.length();
        let yawed = glam::Quat::from_axis_angle(self.up, yaw_deg.to_radians()) * offset;
        let direction = yawed / distance;
        let elevation = direction.dot(self.up).clamp(-1.0, 1.0).asin();
        let limit = MAX_ORBIT_ELEVATION_DEG.to_radians();
        let target = (elevation + pitch_deg.to_radians()).clamp(-limit, limit);
        // Rotate within the plane of `up` and the current direction.
        let horizontal = direction - direction.dot(self.up) * self.up;
        let horizontal = if horizontal.length_squared() > 1e-12 {
            horizontal.normalize()
        } else {
            // Straight above or below: keep the image's current right-left axis.
            self.up.cross(self.right_in_world).normalize()
        };
        let new_direction = target.cos() * horizontal + target.sin() * self.up;
        self.position = self.look_at + distance * new_direction;
        self.derive();
    }

    /// Moves toward `look_at` by `factor` (2 halves the distance, 0.5 doubles it).
    /// Non-positive or non-finite factors are ignored.
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.position = self.look_at + (self.position - self.look_at) / factor;
            self.derive();
        }
    }

    /// Moves camera and `look_at` together, parallel to the image plane, so the
    /// scene at the `look_at` distance follows a mouse drag of (`dx`, `dy`) pixels
    /// (x right, y down).
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let distance = (self.look_at - self.position).length();
        let metres_per_pixel = 2.0 * distance * self.tan_half_fov / self.height as f32;
        let shift = metres_per_pixel * (-dx * self.right_in_world + dy * self.up_in_image);
        if shift.is_finite() {
            self.position += shift;
            self.look_at += shift;
            self.derive();
        }
    }

    /// Changes the image size, keeping the vertical field of view. Zero sizes
    /// become 1.
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        self.width = width.max(1);
        self.height = height.max(1);
    }

    /// Camera position (m, world).
    pub fn position(&self) -> [f32; 3] {
        self.position.into()
    }

    /// The point the image centre looks at (m, world).
    pub fn look_at(&self) -> [f32; 3] {
        self.look_at.into()
    }

    /// The world direction that appears upward (unit).
    pub fn up(&self) -> [f32; 3] {
        self.up.into()
    }

    /// Unit view direction (from the position toward `look_at`).
    pub fn forward(&self) -> [f32; 3] {
        self.forward.into()
    }

    /// Vertical field of view, degrees.
    pub fn vertical_fov_deg(&self) -> f32 {
        self.vertical_fov_deg
    }

    /// Horizontal field of view, degrees (from the vertical one and the aspect).
    pub fn horizontal_fov_deg(&self) -> f32 {
        let aspect = self.width as f32 / self.height as f32;
        2.0 * (self.tan_half_fov * aspect).atan().to_degrees()
    }

    /// Image width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Recomputes the orthonormal frame from the parameters.
    fn derive(&mut self) {
        self.forward = (self.look_at - self.position).normalize();
        self.right_in_world = self.forward.cross(self.up).normalize();
        self.up_in_image = self.right_in_world.cross(self.forward);
        self.tan_half_fov = (0.5 * self.vertical_fov_deg.to_radians()).tan();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAR_BOUNDS: ([f32; 3], [f32; 3]) = ([-0.95, 0.0, -2.25], [0.95, 1.4, 2.25]);

    fn angle_deg(a: Vec3, b: Vec3) -> f32 {
        a.normalize()
            .dot(b.normalize())
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }

    /// Projects a world point to continuous pixel coordinates (the inverse of `ray`).
    fn project(camera: &Camera, point: Vec3) -> (f32, f32) {
        let v = point - camera.position;
        let depth = v.dot(camera.forward);
        let sx = v.dot(camera.right_in_world) / depth;
        let sy = v.dot(camera.up_in_image) / depth;
        let aspect = camera.width as f32 / camera.height as f32;
        let x = (sx / (camera.tan_half_fov * aspect) + 1.0) * 0.5 * camera.width as f32;
        let y = (1.0 - sy / camera.tan_half_fov) * 0.5 * camera.height as f32;
        (x, y)
    }

    /// A camera with +y up.
    fn upright(position: [f32; 3], look_at: [f32; 3], fov_deg: f32, (w, h): (u32, u32)) -> Camera {
        Camera::new(position, look_at, [0.0, 1.0, 0.0], fov_deg, w, h).unwrap()
    }

    #[test]
    fn centre_ray_points_at_look_at() {
        let camera = upright([3.0, 2.0, 5.0], [0.0, 0.5, 0.0], 40.0, (640, 360));
        let (origin, dir) = camera.ray(320.0, 180.0);
        assert_eq!(origin, [3.0, 2.0, 5.0]);
        let to_target = Vec3::new(0.0, 0.5, 0.0) - Vec3::from(origin);
        assert!(angle_deg(Vec3::from(dir), to_target) < 1e-3);
        assert!((Vec3::from(dir).length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn corner_rays_span_the_field_of_view() {
        let camera = upright([0.0, 1.0, 10.0], [0.0, 1.0, 0.0], 35.0, (800, 400));
        let dir = |x, y| Vec3::from(camera.ray(x, y).1);
        let (w, h) = (800.0, 400.0);
        // Top and bottom edge centres are the vertical fov apart; left and right the
        // horizontal one.
        assert!((angle_deg(dir(w / 2.0, 0.0), dir(w / 2.0, h)) - 35.0).abs() < 1e-3);
        let horizontal = camera.horizontal_fov_deg();
        let expected = 2.0 * ((17.5f32).to_radians().tan() * 2.0).atan().to_degrees();
        assert!((horizontal - expected).abs() < 1e-3);
        assert!((angle_deg(dir(0.0, h / 2.0), dir(w, h / 2.0)) - horizontal).abs() < 1e-3);
        // Top-left goes up and left; y down in pixels.
        let top_left = dir(0.0, 0.0);
        assert!(top_left.x < 0.0 && top_left.y > 0.0 && top_left.z < 0.0);
        let bottom_right = dir(w, h);
        assert!(bottom_right.x > 0.0 && bottom_right.y < 0.0);
        // Symmetric corners.
        assert!((angle_deg(top_left, -Vec3::Z) - angle_deg(bottom_right, -Vec3::Z)).abs() < 1e-3);
    }

    #[test]
    fn framing_keeps_the_box_inside_and_fills_the_image() {
        for (w, h) in [(1280, 720), (720, 1280), (500, 500)] {
            for bounds in [
                CAR_BOUNDS,
                ([0.0; 3], [1.0; 3]),
                ([5.0, 0.0, 5.0], [5.0, 0.0, 5.0]),
            ] {
                let camera = Camera::framing(bounds, w, h);
                assert_eq!(camera.vertical_fov_deg(), FRAMING_FOV_DEG);
                let (lo, hi) = (Vec3::from(bounds.0), Vec3::from(bounds.1));
                assert!(angle_deg(camera.forward, 0.5 * (lo + hi) - camera.position) < 1e-3);
                // From the front-left and above.
                let p = camera.position - 0.5 * (lo + hi);
                assert!(p.x > 0.0 && p.y > 0.0 && p.z > 0.0);
                let (mut min_x, mut max_x, mut min_y, mut max_y) =
                    (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
                for corner in 0..8 {
                    let c = Vec3::new(
                        if corner & 1 == 0 { lo.x } else { hi.x },
                        if corner & 2 == 0 { lo.y } else { hi.y },
                        if corner & 4 == 0 { lo.z } else { hi.z },
                    );
                    let (x, y) = project(&camera, c);
                    (min_x, max_x, min_y, max_y) =
                        (min_x.min(x), max_x.max(x), min_y.min(y), max_y.max(y));
                }
                let (wf, hf) = (w as f32, h as f32);
                // Margin: at least 7 % of the image on every side.
                let margin = 0.07;
                assert!(
                    min_x >= margin * wf && max_x <= (1.0 - margin) * wf,
                    "{bounds:?} {w}x{h}: x {min_x}..{max_x}"
                );
                assert!(
                    min_y >= margin * hf && max_y <= (1.0 - margin) * hf,
                    "{bounds:?} {w}x{h}: y {min_y}..{max_y}"
                );
                let fill = ((max_x - min_x) / wf).max((max_y - min_y) / hf);
                // A point box (treated as a 1 mm cube) only has to stay in view.
                if hi != lo {
                    assert!(fill >= 0.6, "{bounds:?} {w}x{h}: fills {fill}");
                }
            }
        }
    }

    #[test]
    fn orbit_zoom_and_pan_keep_look_at_semantics() {
        let mut camera = Camera::framing(CAR_BOUNDS, 640, 480);
        let target = Vec3::from(camera.look_at());
        let distance = (camera.position - target).length();
        camera.orbit(90.0, 10.0);
        assert_eq!(Vec3::from(camera.look_at()), target);
        assert!(((camera.position - target).length() - distance).abs() < 1e-4 * distance);
        let elevation = ((camera.position - target).normalize().y)
            .asin()
            .to_degrees();
        assert!(
            (elevation - (FRAMING_ELEVATION_DEG + 10.0)).abs() < 1e-2,
            "{elevation}"
        );
        // A 90° yaw counter-clockwise seen from above takes the front-left view
        // (x > 0, z > 0) to the rear-left (x > 0, z < 0).
        assert!(camera.position.x > 0.0 && camera.position.z < 0.0);
        // Pitch clamps before the pole.
        camera.orbit(0.0, 500.0);
        let elevation = ((camera.position - target).normalize().y)
            .asin()
            .to_degrees();
        assert!((elevation - MAX_ORBIT_ELEVATION_DEG).abs() < 1e-2);
        let (_, dir) = camera.ray(320.0, 240.0);
        assert!(dir.iter().all(|v| v.is_finite()));

        camera.zoom(2.0);
        assert!(((camera.position - target).length() - 0.5 * distance).abs() < 1e-4 * distance);

        let mut camera = Camera::framing(CAR_BOUNDS, 640, 480);
        let before = project(&camera, target);
        camera.pan(30.0, -20.0);
        let after = project(&camera, target);
        assert!(
            (after.0 - before.0 - 30.0).abs() < 1e-2 && (after.1 - before.1 + 20.0).abs() < 1e-2
        );
        assert!(
            angle_deg(
                Vec3::from(camera.look_at()) - camera.position,
                camera.forward
            ) < 1e-3
        );
    }

    #[test]
    fn invalid_parameters_are_rejected() {
        let ok = |p, l, u, f, w, h| Camera::new(p, l, u, f, w, h);
        assert!(ok([0.0; 3], [0.0; 3], [0.0, 1.0, 0.0], 40.0, 1, 1).is_err());
        assert!(ok([0.0; 3], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], 40.0, 1, 1).is_err());
        assert!(ok([0.0; 3], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 180.0, 1, 1).is_err());
        assert!(ok([0.0; 3], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 40.0, 0, 1).is_err());
        assert!(
            ok(
                [f32::NAN, 0.0, 0.0],
                [0.0, 0.0, -1.0],
                [0.0, 1.0, 0.0],
                40.0,
                1,
                1
            )
            .is_err()
        );
        assert!(ok([0.0; 3], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 40.0, 1, 1).is_ok());
    }
}
