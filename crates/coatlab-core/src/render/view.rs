//! Views of the car: the named views a designer picks (front three-quarter, the
//! default; rear three-quarter; side; front; rear; top; a close-up of a panel), a
//! free camera by yaw, pitch, distance and field of view, and the scene file's own
//! cameras.
//!
//! Every named view frames the car, not the scene: [`SceneFraming`] keeps the car's
//! vertices by the rule of [`crate::scene::framing`] (a drape, a floor or a
//! backdrop left out) and each view is fitted to them.
//!
//! Directions follow the scene's frame (Y up, the nose toward +Z, the car's left
//! toward +X). Azimuth is measured from the front (+Z) toward the left (+X), so 0°
//! looks at the nose, 90° at the left side and 180° at the tail.
//!
//! | view | name | azimuth | elevation | frames |
//! |---|---|---|---|---|
//! | front three-quarter | `front-34` | 40° | 15° | the car (the default) |
//! | rear three-quarter | `rear-34` | 140° | 15° | the car |
//! | side | `side` | 90° | 5° | the car |
//! | front | `front` | 0° | 8° | the car |
//! | rear | `rear` | 180° | 8° | the car |
//! | top | `top` | 180° | 89° | the car, nose up the image |
//! | close-up | `closeup` | 65° | 10° | the left front door and wing |
//!
//! The top view stops at the orbit's limit ([`MAX_ORBIT_ELEVATION_DEG`]), seen
//! from just behind, so its camera keeps +Y as up (orbiting from it turns about
//! the vertical, as from any other view) and the nose is up the image.
//!
//! A turntable (`turntable:N`) is N cameras on one orbit: the same centre (the
//! car's box centre), distance and elevation ([`FRAMING_ELEVATION_DEG`]), at
//! equal steps of 360°/N in azimuth from the front three-quarter's
//! ([`FRAMING_AZIMUTH_DEG`]) toward the car's left, so frame 0 looks from where
//! the default view does and the car turns in place from frame to frame. The
//! distance is the least at which the car stays within [`FRAMING_FILL`] of the
//! half-image in every frame. `turntable:N:K` is frame K alone (from 0).
//!
//! A named view's distance is the least at which every vertex of the car projects
//! within [`FRAMING_FILL`] of the half-image in both axes, with the car's projected
//! box centred in the image; so the car fills 85 % of the tighter axis.

use std::fmt;
use std::str::FromStr;

use glam::Vec3;

use crate::names::{UnknownName, by_name};
use crate::scene::framing::{Bounds, car_triangles};
use crate::scene::{Scene, SceneCamera};

use super::camera::{
    Camera, CameraError, FRAMING_AZIMUTH_DEG, FRAMING_ELEVATION_DEG, FRAMING_FILL, FRAMING_FOV_DEG,
    MAX_ORBIT_ELEVATION_DEG,
};

/// Share of the image the close-up's panel fills in the tighter axis.
pub const CLOSE_UP_FILL: f32 = 1.0;

/// A view chosen by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NamedView {
    /// From the front-left, a little above: how cars are photographed.
    #[default]
    FrontThreeQuarter,
    /// From the rear-left, a little above.
    RearThreeQuarter,
    /// The left side.
    Side,
    /// Nose on.
    Front,
    /// Tail on.
    Rear,
    /// From straight above, the nose up the image.
    Top,
    /// A close-up of a body panel: the left front door and wing.
    CloseUp,
}

impl NamedView {
    /// Every named view, in the order menus list them.
    pub const ALL: [NamedView; 7] = [
        NamedView::FrontThreeQuarter,
        NamedView::RearThreeQuarter,
        NamedView::Side,
        NamedView::Front,
        NamedView::Rear,
        NamedView::Top,
        NamedView::CloseUp,
    ];

    /// The name on the command line (`--view`).
    pub fn name(self) -> &'static str {
        match self {
            NamedView::FrontThreeQuarter => "front-34",
            NamedView::RearThreeQuarter => "rear-34",
            NamedView::Side => "side",
            NamedView::Front => "front",
            NamedView::Rear => "rear",
            NamedView::Top => "top",
            NamedView::CloseUp => "closeup",
        }
    }

    /// The name in menus.
    pub fn label(self) -> &'static str {
        match self {
            NamedView::FrontThreeQuarter => "Front three-quarter",
            NamedView::RearThreeQuarter => "Rear three-quarter",
            NamedView::Side => "Side",
            NamedView::Front => "Front",
            NamedView::Rear => "Rear",
            NamedView::Top => "Top",
            NamedView::CloseUp => "Close-up (door and wing)",
        }
    }

    /// Azimuth (from +Z toward +X) and elevation of the direction from the car
    /// toward the camera, degrees.
    pub fn direction_deg(self) -> (f32, f32) {
        match self {
            NamedView::FrontThreeQuarter => (FRAMING_AZIMUTH_DEG, FRAMING_ELEVATION_DEG),
            NamedView::RearThreeQuarter => (180.0 - FRAMING_AZIMUTH_DEG, FRAMING_ELEVATION_DEG),
            NamedView::Side => (90.0, 5.0),
            NamedView::Front => (0.0, 8.0),
            NamedView::Rear => (180.0, 8.0),
            NamedView::Top => (180.0, MAX_ORBIT_ELEVATION_DEG),
            NamedView::CloseUp => (65.0, 10.0),
        }
    }
}

impl fmt::Display for NamedView {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Text that names no view or camera, or a camera with values out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewParseError {
    #[error(transparent)]
    UnknownView(#[from] UnknownName),
    #[error(
        "'{0}' is not a camera: use yaw_deg,pitch_deg,distance_m,fov_deg (e.g. 40,15,9,35) or gltf:N"
    )]
    Syntax(String),
    #[error("'{text}': {problem}")]
    OutOfRange { text: String, problem: String },
}

impl FromStr for NamedView {
    type Err = ViewParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Ok(by_name(text, "a view", &NamedView::ALL, NamedView::name)?)
    }
}

/// The most frames a turntable takes: one a degree.
pub const MAX_TURNTABLE_FRAMES: u32 = 360;

/// A turn around the car in equal steps of azimuth (see the module's text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Turntable {
    frames: u32,
}

impl Turntable {
    /// A turntable of `frames` frames, 1 to [`MAX_TURNTABLE_FRAMES`].
    pub fn new(frames: u32) -> Result<Self, String> {
        if (1..=MAX_TURNTABLE_FRAMES).contains(&frames) {
            Ok(Self { frames })
        } else {
            Err(format!(
                "{frames} frames: a turntable takes 1 to {MAX_TURNTABLE_FRAMES}"
            ))
        }
    }

    /// How many frames make the turn.
    pub fn frames(self) -> u32 {
        self.frames
    }

    /// Azimuth of the camera of `frame` (from +Z toward +X), degrees.
    pub fn azimuth_deg(self, frame: u32) -> f32 {
        FRAMING_AZIMUTH_DEG + 360.0 * frame as f32 / self.frames as f32
    }
}

/// A `--view` value: a named view, a whole turntable, or one frame of one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewSpec {
    Named(NamedView),
    /// Every frame of the turntable (`turntable:N`).
    Turntable(Turntable),
    /// One frame (`turntable:N:K`, K from 0).
    TurntableFrame(Turntable, u32),
}

impl ViewSpec {
    /// The single views this one stands for: a whole turntable's frames in order,
    /// anything else itself.
    pub fn frames(self) -> Vec<ViewSpec> {
        match self {
            ViewSpec::Turntable(turntable) => (0..turntable.frames)
                .map(|k| ViewSpec::TurntableFrame(turntable, k))
                .collect(),
            single => vec![single],
        }
    }
}

impl fmt::Display for ViewSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ViewSpec::Named(view) => f.write_str(view.name()),
            ViewSpec::Turntable(t) => write!(f, "turntable:{}", t.frames),
            ViewSpec::TurntableFrame(t, k) => write!(f, "turntable:{}:{k}", t.frames),
        }
    }
}

impl FromStr for ViewSpec {
    type Err = ViewParseError;

    /// A view's name, `turntable:N` or `turntable:N:K`.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let out_of_range = |problem: String| ViewParseError::OutOfRange {
            text: text.trim().to_owned(),
            problem,
        };
        let Some(rest) = text.trim().strip_prefix("turntable:") else {
            return text.parse().map(ViewSpec::Named).map_err(|e| match e {
                ViewParseError::UnknownView(mut unknown) => {
                    unknown.accepted.push("turntable:N".into());
                    ViewParseError::UnknownView(unknown)
                }
                other => other,
            });
        };
        let whole = |part: &str, what: &str| {
            part.trim().parse::<u32>().map_err(|_| {
                out_of_range(format!(
                    "{what} '{part}' is not a whole number: use turntable:N (N frames, 1 to \
                     {MAX_TURNTABLE_FRAMES}) or turntable:N:K (frame K of N, from 0)"
                ))
            })
        };
        let (frames, frame) = match rest.split_once(':') {
            None => (whole(rest, "N")?, None),
            Some((frames, frame)) => (whole(frames, "N")?, Some(whole(frame, "K")?)),
        };
        let turntable = Turntable::new(frames).map_err(out_of_range)?;
        match frame {
            None => Ok(ViewSpec::Turntable(turntable)),
            Some(k) if k < frames => Ok(ViewSpec::TurntableFrame(turntable, k)),
            Some(k) => Err(out_of_range(format!(
                "frame {k} of {frames}: the frames are 0 to {}",
                frames - 1
            ))),
        }
    }
}

/// A camera placed by hand around the car's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeCamera {
    /// Azimuth from the front (+Z) toward the left (+X), degrees; any finite value.
    pub yaw_deg: f32,
    /// Elevation above the horizontal, degrees, within ±[`MAX_ORBIT_ELEVATION_DEG`].
    pub pitch_deg: f32,
    /// Distance from the centre of the car's box, metres, > 0.
    pub distance_m: f32,
    /// Vertical field of view, degrees, in (0, 180).
    pub fov_deg: f32,
}

impl FreeCamera {
    /// Checks the ranges; the problem in words.
    pub fn validate(&self) -> Result<(), String> {
        if !self.yaw_deg.is_finite() {
            return Err(format!("yaw {} must be finite", self.yaw_deg));
        }
        // NaN fails the range test too.
        if self.pitch_deg.is_nan() || self.pitch_deg.abs() > MAX_ORBIT_ELEVATION_DEG {
            return Err(format!(
                "pitch {}° must be within ±{MAX_ORBIT_ELEVATION_DEG}°",
                self.pitch_deg
            ));
        }
        if !(self.distance_m > 0.0 && self.distance_m.is_finite()) {
            return Err(format!(
                "distance {} m must be a positive number of metres",
                self.distance_m
            ));
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(format!(
                "field of view {}° must be in (0°, 180°)",
                self.fov_deg
            ));
        }
        Ok(())
    }
}

/// What the camera shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ViewChoice {
    /// A named view of the car.
    Named(NamedView),
    /// A camera placed by yaw, pitch, distance and field of view.
    Free(FreeCamera),
    /// The scene file's camera with this index ([`Scene::cameras`]).
    SceneCamera(usize),
}

impl Default for ViewChoice {
    fn default() -> Self {
        ViewChoice::Named(NamedView::default())
    }
}

impl FromStr for ViewChoice {
    type Err = ViewParseError;

    /// A `--camera` value: `gltf:N` (the file's camera N, from 0) or
    /// `yaw_deg,pitch_deg,distance_m,fov_deg`.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let syntax = || ViewParseError::Syntax(text.to_owned());
        if let Some(index) = text.trim().strip_prefix("gltf:") {
            return index
                .trim()
                .parse()
                .map(ViewChoice::SceneCamera)
                .map_err(|_| syntax());
        }
        let numbers: Vec<f32> = text
            .split(',')
            .map(|part| part.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| syntax())?;
        let [yaw_deg, pitch_deg, distance_m, fov_deg] = numbers[..] else {
            return Err(syntax());
        };
        let free = FreeCamera {
            yaw_deg,
            pitch_deg,
            distance_m,
            fov_deg,
        };
        free.validate()
            .map_err(|problem| ViewParseError::OutOfRange {
                text: text.to_owned(),
                problem,
            })?;
        Ok(ViewChoice::Free(free))
    }
}

/// A view that cannot be made for this scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewError {
    #[error("the scene has no camera {index} ({})", cameras_held(*count))]
    NoSuchCamera { index: usize, count: usize },
    #[error("free camera: {0}")]
    BadFreeCamera(String),
    #[error("the scene's camera {index}: {error}")]
    BadSceneCamera { index: usize, error: CameraError },
}

fn cameras_held(count: usize) -> String {
    match count {
        0 => "it has none of its own".into(),
        1 => "it has one, gltf:0".into(),
        n => format!("it has {n}, gltf:0 to gltf:{}", n - 1),
    }
}

/// What the views of one scene are fitted to: the car's vertices and bounds, and
/// the file's cameras.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneFraming {
    /// Vertices of the car's triangles, metres, world.
    points: Vec<Vec3>,
    /// Their bounds.
    bounds: Option<Bounds>,
    /// The scene file's cameras.
    cameras: Vec<SceneCamera>,
}

impl SceneFraming {
    /// The framing of `scene`: its car by [`crate::scene::framing`], its cameras.
    pub fn new(scene: &Scene) -> Self {
        let mesh = &scene.mesh;
        let car = car_triangles(mesh, &scene.paint_materials);
        let mut used = vec![false; mesh.positions.len()];
        for (t, triangle) in mesh.triangles.iter().enumerate() {
            if car[t] {
                for &v in triangle {
                    used[v as usize] = true;
                }
            }
        }
        let points: Vec<Vec3> = mesh
            .positions
            .iter()
            .zip(&used)
            .filter(|(_, used)| **used)
            .map(|(p, _)| Vec3::from(*p))
            .collect();
        let bounds = points.iter().fold(None, |acc: Option<Bounds>, p| {
            let (lo, hi) = acc.unwrap_or((p.to_array(), p.to_array()));
            Some((
                Vec3::from(lo).min(*p).to_array(),
                Vec3::from(hi).max(*p).to_array(),
            ))
        });
        Self {
            points,
            bounds,
            cameras: scene.cameras.clone(),
        }
    }

    /// The car's bounds (min, max), metres; `None` for an empty scene.
    pub fn car_bounds(&self) -> Option<Bounds> {
        self.bounds
    }

    /// The scene file's cameras.
    pub fn cameras(&self) -> &[SceneCamera] {
        &self.cameras
    }

    /// The camera of `choice` at `width` × `height` pixels.
    pub fn camera(
        &self,
        choice: &ViewChoice,
        width: u32,
        height: u32,
    ) -> Result<Camera, ViewError> {
        let (width, height) = (width.max(1), height.max(1));
        match *choice {
            ViewChoice::Named(view) => Ok(self.named(view, width, height)),
            ViewChoice::Free(free) => {
                free.validate().map_err(ViewError::BadFreeCamera)?;
                let centre = self.centre();
                let towards = direction(free.yaw_deg, free.pitch_deg);
                Camera::new(
                    (centre + free.distance_m * towards).into(),
                    centre.into(),
                    [0.0, 1.0, 0.0],
                    free.fov_deg,
                    width,
                    height,
                )
                .map_err(|e| ViewError::BadFreeCamera(e.to_string()))
            }
            ViewChoice::SceneCamera(index) => {
                let camera = self.cameras.get(index).ok_or(ViewError::NoSuchCamera {
                    index,
                    count: self.cameras.len(),
                })?;
                let position = Vec3::from(camera.position);
                Camera::new(
                    camera.position,
                    (position + Vec3::from(camera.forward)).into(),
                    camera.up,
                    camera.vertical_fov_deg,
                    width,
                    height,
                )
                .map_err(|error| ViewError::BadSceneCamera { index, error })
            }
        }
    }

    /// A named view: never fails (an empty scene is framed as a 1 mm cube at the
    /// origin).
    pub fn named(&self, view: NamedView, width: u32, height: u32) -> Camera {
        let (azimuth, elevation) = view.direction_deg();
        let towards = direction(azimuth, elevation);
        let up = Vec3::Y;
        if view == NamedView::CloseUp {
            let panel = self.close_up_panel();
            return fit(&corners(panel), towards, up, CLOSE_UP_FILL, width, height);
        }
        if self.points.is_empty() {
            return fit(
                &corners(self.bounds_or_point()),
                towards,
                up,
                FRAMING_FILL,
                width,
                height,
            );
        }
        fit(&self.points, towards, up, FRAMING_FILL, width, height)
    }

    /// The camera of `frame` of `turntable` (see the module's text); `frame` is
    /// taken modulo the frame count.
    pub fn turntable(&self, turntable: Turntable, frame: u32, width: u32, height: u32) -> Camera {
        let (width, height) = (width.max(1), height.max(1));
        let centre = self.centre();
        let fallback = corners(self.bounds_or_point());
        let points: &[Vec3] = if self.points.is_empty() {
            &fallback
        } else {
            &self.points
        };
        let lens = Lens::new(FRAMING_FILL, width, height);
        let distance = (0..turntable.frames)
            .map(|k| {
                let towards = direction(turntable.azimuth_deg(k), FRAMING_ELEVATION_DEG);
                lens.least_distance(points, centre, -towards, Vec3::Y)
            })
            .fold(0.0, f32::max);
        let towards = direction(
            turntable.azimuth_deg(frame % turntable.frames),
            FRAMING_ELEVATION_DEG,
        );
        Camera::new(
            (centre + distance * towards).into(),
            centre.into(),
            [0.0, 1.0, 0.0],
            FRAMING_FOV_DEG,
            width,
            height,
        )
        .expect("a turntable builds a valid camera from finite points")
    }

    /// The camera of a single view `spec`: a named view, or one turntable frame (a
    /// whole turntable gives its frame 0).
    pub fn view(&self, spec: ViewSpec, width: u32, height: u32) -> Camera {
        match spec {
            ViewSpec::Named(view) => self.named(view, width, height),
            ViewSpec::Turntable(turntable) => self.turntable(turntable, 0, width, height),
            ViewSpec::TurntableFrame(turntable, k) => self.turntable(turntable, k, width, height),
        }
    }

    fn bounds_or_point(&self) -> Bounds {
        self.bounds.unwrap_or(([-0.5e-3; 3], [0.5e-3; 3]))
    }

    fn centre(&self) -> Vec3 {
        let (lo, hi) = self.bounds_or_point();
        0.5 * (Vec3::from(lo) + Vec3::from(hi))
    }

    /// The box the close-up frames: on the car's left flank (+X), from the front
    /// axle region to the middle of the car (the front wing and door), from 30 % to
    /// 75 % of the height.
    pub fn close_up_panel(&self) -> Bounds {
        let (lo, hi) = self.bounds_or_point();
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        let size = hi - lo;
        let centre_z = 0.5 * (lo.z + hi.z);
        (
            [hi.x - 0.15 * size.x, lo.y + 0.3 * size.y, centre_z],
            [hi.x, lo.y + 0.75 * size.y, centre_z + 0.3 * size.z],
        )
    }
}

/// The unit direction toward the camera for an azimuth (from +Z toward +X) and an
/// elevation, degrees.
fn direction(azimuth_deg: f32, elevation_deg: f32) -> Vec3 {
    let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

fn corners((lo, hi): Bounds) -> [Vec3; 8] {
    std::array::from_fn(|c| {
        Vec3::new(
            if c & 1 == 0 { lo[0] } else { hi[0] },
            if c & 2 == 0 { lo[1] } else { hi[1] },
            if c & 4 == 0 { lo[2] } else { hi[2] },
        )
    })
}

/// The framing lens ([`FRAMING_FOV_DEG`]) at an image's aspect, with the share of
/// the half-image the points may fill.
struct Lens {
    fill: f32,
    tan_v: f32,
    tan_h: f32,
}

impl Lens {
    fn new(fill: f32, width: u32, height: u32) -> Self {
        let tan_v = (0.5 * FRAMING_FOV_DEG.to_radians()).tan();
        Self {
            fill,
            tan_v,
            tan_h: tan_v * width as f32 / height as f32,
        }
    }

    /// The least distance from `target` back along `forward` at which every point
    /// projects within the fill (see [`fit`]), and outside the points' box.
    fn least_distance(&self, points: &[Vec3], target: Vec3, forward: Vec3, up: Vec3) -> f32 {
        let forward = forward.normalize();
        let right = forward.cross(up).normalize();
        let image_up = right.cross(forward);
        let (mut d, mut lo, mut hi): (f32, Vec3, Vec3) = (
            0.0,
            Vec3::splat(f32::INFINITY),
            Vec3::splat(f32::NEG_INFINITY),
        );
        for p in points {
            let o = *p - target;
            let depth = o.dot(forward);
            d = d
                .max(o.dot(right).abs() / (self.fill * self.tan_h) - depth)
                .max(o.dot(image_up).abs() / (self.fill * self.tan_v) - depth);
            (lo, hi) = (lo.min(*p), hi.max(*p));
        }
        let half = (0.5 * (hi - lo)).max(Vec3::splat(0.5e-3));
        // Stay outside the box whatever the aspect ratio.
        d.max(1.01 * half.length())
    }
}

/// Passes of [`fit`]'s re-centring: each moves the target by the projected box's
/// offset, and the distance changes with it; after eight the test cars' views
/// fill their tighter axis to within 1.5 % of [`FRAMING_FILL`] (tests/views.rs).
const CENTRING_PASSES: usize = 8;

/// The camera looking along −`towards` with `up` upward (field of view
/// [`FRAMING_FOV_DEG`]) that holds every point within `fill` of the half-image in
/// both axes at the least distance, with the points' projected box centred.
///
/// For a target T and distance d, a point at offset o from T, with lateral offset a
/// and depth b along the view, stays inside when |a| / (d + b) ≤ fill · tan(half
/// fov): so d = max(|a| / (fill · tan) − b) over the points, exactly. The target
/// starts at the points' box centre and moves, pass by pass, by the projected box's
/// offset from the image centre (at the target's depth).
fn fit(points: &[Vec3], towards: Vec3, up: Vec3, fill: f32, width: u32, height: u32) -> Camera {
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let mut target = 0.5 * (lo + hi);
    let forward = -towards.normalize();
    let right = forward.cross(up).normalize();
    let image_up = right.cross(forward);
    let lens = Lens::new(fill, width, height);
    let distance_for = |target: Vec3| lens.least_distance(points, target, forward, up);
    let mut distance = distance_for(target);
    for _ in 0..CENTRING_PASSES {
        let (mut min, mut max) = (
            glam::Vec2::splat(f32::INFINITY),
            glam::Vec2::splat(f32::NEG_INFINITY),
        );
        for p in points {
            let o = *p - target;
            let depth = distance + o.dot(forward);
            let s = glam::Vec2::new(o.dot(right), o.dot(image_up)) / depth;
            min = min.min(s);
            max = max.max(s);
        }
        let offset = 0.5 * (min + max);
        target += distance * (offset.x * right + offset.y * image_up);
        distance = distance_for(target);
    }
    let position = target - distance * forward;
    Camera::new(
        position.into(),
        target.into(),
        up.into(),
        FRAMING_FOV_DEG,
        width,
        height,
    )
    .expect("a fit builds a valid camera from finite points")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_cameras_parse() {
        for view in NamedView::ALL {
            assert_eq!(view.name().parse::<NamedView>(), Ok(view));
        }
        assert!("diagonal".parse::<NamedView>().is_err());
        assert_eq!(
            "gltf:3".parse::<ViewChoice>(),
            Ok(ViewChoice::SceneCamera(3))
        );
        assert_eq!(
            "30, -5, 8.5, 40".parse::<ViewChoice>(),
            Ok(ViewChoice::Free(FreeCamera {
                yaw_deg: 30.0,
                pitch_deg: -5.0,
                distance_m: 8.5,
                fov_deg: 40.0
            }))
        );
        for bad in ["gltf:", "gltf:-1", "1,2,3", "1,2,3,4,5", "a,b,c,d", ""] {
            assert!(
                matches!(bad.parse::<ViewChoice>(), Err(ViewParseError::Syntax(_))),
                "{bad}"
            );
        }
        for bad in [
            "0,95,5,35",
            "0,0,0,35",
            "0,0,-1,35",
            "0,0,5,180",
            "0,0,5,0",
            "inf,0,5,35",
        ] {
            assert!(
                matches!(
                    bad.parse::<ViewChoice>(),
                    Err(ViewParseError::OutOfRange { .. })
                ),
                "{bad}"
            );
        }
    }
}
