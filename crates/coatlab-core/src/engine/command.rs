//! What the live engine is told: the commands, and the values they carry.

use std::path::PathBuf;

use crate::design::PaintDesign;
use crate::paint::phong::PhongVariant;
use crate::render::film::DisplayChoice;
use crate::render::lighting::Lighting;
use crate::render::material::ShadingModel;
use crate::render::view::ViewChoice;

use super::{DEFAULT_WAVELENGTHS, MAX_SPP};

/// A change the engine is asked to make. Each is taken in the order sent; what it
/// rebuilds is decided by [`super::plan`].
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// The design of the first view (and of the second, unless it has its own).
    Design(Box<PaintDesign>),
    /// The views' models and the comparison.
    Views(Views),
    /// The lighting. A [`Lighting::Map`] whose file was read last (on the current
    /// wavelength grid) is used again without reading it.
    Lighting(Lighting),
    /// An environment map file, read now even if it was read before.
    OpenMap(PathBuf),
    /// The scene to render: its BVH is built (a file that cannot be loaded leaves
    /// the current scene).
    Scene(SceneSource),
    /// The scene materials that carry the paint instead of the loader's choice
    /// (`None`: the loader's choice; several: a body split across materials).
    PaintMaterials(Option<Vec<u32>>),
    /// Toggles whether the material seen at a point of the image (fractions of
    /// its width and height from the top left) carries the paint
    /// ([`crate::render::pick`]); a point on no material changes nothing. The new
    /// list is reported ([`super::events::EngineEvent::PaintMaterials`]).
    TogglePaintAt(f32, f32),
    /// The image size, pixels.
    Size(u32, u32),
    /// Turns the view about its target by yaw and pitch, degrees.
    Orbit(f32, f32),
    /// Moves the camera towards its target by a factor (< 1: closer).
    Zoom(f32),
    /// Moves the camera and its target sideways, in pixels of the image.
    Pan(f32, f32),
    /// Puts the camera at a named view, a free camera or one of the scene file's
    /// cameras ([`crate::render::view`]); a camera the scene does not have is
    /// reported and changes nothing.
    View(ViewChoice),
    /// The quality knobs: wavelengths, sample target, resolution divisor.
    Quality(QualityKnobs),
    /// How the images are shown: the tone mapping and the exposure (automatic
    /// with an adjustment, or fixed). Re-shows the images; renders nothing again.
    Display(DisplayChoice),
}

impl Command {
    /// Whether the command leaves the picture as it is whatever the engine's state
    /// (a camera step of zero); other no-ops are found by comparing with what is set.
    pub fn is_null_step(&self) -> bool {
        match *self {
            Command::Orbit(yaw, pitch) => yaw == 0.0 && pitch == 0.0,
            Command::Zoom(factor) => factor == 1.0,
            Command::Pan(dx, dy) => dx == 0.0 && dy == 0.0,
            _ => false,
        }
    }
}

/// Where the scene comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SceneSource {
    /// The procedural car of [`crate::scene::car`] with its default parameters.
    BuiltInCar,
    /// A glTF 2.0 file (.glb or .gltf).
    File(PathBuf),
}

/// What the two views render: the first view's model, and the second view if
/// there is one.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Views {
    /// The model of the first view.
    pub first: ShadingModel,
    /// The second view of a comparison.
    pub second: Option<SecondView>,
}

/// The second view of a comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct SecondView {
    /// Its own design; `None`: the first view's.
    pub design: Option<Box<PaintDesign>>,
    /// Its model.
    pub model: ShadingModel,
}

impl Views {
    /// One view in `model`.
    pub fn single(model: ShadingModel) -> Self {
        Self {
            first: model,
            second: None,
        }
    }

    /// The paint model against Phong's `variant`, on the same design.
    pub fn models(variant: PhongVariant) -> Self {
        Self {
            first: ShadingModel::Paint,
            second: Some(SecondView {
                design: None,
                model: ShadingModel::Phong(variant),
            }),
        }
    }

    /// The design against `second` (none chosen yet: one view), both in `model`.
    pub fn designs(model: ShadingModel, second: Option<&PaintDesign>) -> Self {
        Self {
            first: model,
            second: second.map(|d| SecondView {
                design: Some(Box::new(d.clone())),
                model,
            }),
        }
    }
}

/// The knobs a quality preset sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QualityKnobs {
    /// Wavelengths per path.
    pub wavelengths: usize,
    /// Refinement stops at this many samples per pixel.
    pub max_spp: u32,
    /// The image renders at 1/divisor of its pane's size and is scaled up on screen.
    pub resolution_divisor: u32,
}

impl Default for QualityKnobs {
    /// Without a preset: [`DEFAULT_WAVELENGTHS`] wavelengths (as `coatlab render`),
    /// refinement to [`MAX_SPP`], full resolution.
    fn default() -> Self {
        Self {
            wavelengths: DEFAULT_WAVELENGTHS,
            max_spp: MAX_SPP,
            resolution_divisor: 1,
        }
    }
}

impl QualityKnobs {
    /// The render size for a pane of `size` pixels.
    pub fn divide(&self, size: (u32, u32)) -> (u32, u32) {
        let d = self.resolution_divisor.max(1);
        ((size.0 / d).max(1), (size.1 / d).max(1))
    }
}
