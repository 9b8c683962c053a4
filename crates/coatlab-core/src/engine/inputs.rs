//! What the engine has been told to render: the values the commands set, and
//! which [`Change`] each command makes to them.

use crate::design::PaintDesign;
use crate::render::camera::Camera;
use crate::render::film::DisplayChoice;
use crate::render::lighting::Lighting;
use crate::render::view::ViewChoice;

use super::command::{Command, QualityKnobs, Views};
use super::plan::Change;

/// The values set by commands (the derived data built from them lives in
/// [`super::world::World`]).
#[derive(Debug, Clone)]
pub(super) struct Inputs {
    /// The first view's design.
    pub design: PaintDesign,
    /// The views' models and the comparison.
    pub views: Views,
    /// The lighting in use.
    pub lighting: Lighting,
    /// The scene materials painted instead of the loader's choice.
    pub paint_override: Option<Vec<u32>>,
    /// The quality knobs.
    pub quality: QualityKnobs,
    /// How the images are shown.
    pub display: DisplayChoice,
    /// The full image size, pixels.
    pub size: (u32, u32),
    /// The view; its resolution follows the pass being rendered (coarse or full).
    pub camera: Camera,
    /// The view the camera is at, while it is not moved by hand (an orbit, a zoom
    /// or a pan clears it): a new image size fits that view again to its aspect.
    pub view: Option<ViewChoice>,
}

impl Inputs {
    /// Takes a command that needs nothing loaded or built (design, views, paint
    /// material, size, camera, display) and says what it changed. Other commands are
    /// [`Change::Nothing`] here: the engine takes them itself.
    pub fn take(&mut self, command: Command) -> Change {
        match command {
            Command::Design(design) => self.take_design(*design),
            Command::Views(views) => {
                if views == self.views {
                    return Change::Nothing;
                }
                let second = views.second.is_some();
                self.views = views;
                Change::Views { second }
            }
            Command::PaintMaterials(chosen) => {
                if chosen == self.paint_override {
                    return Change::Nothing;
                }
                self.paint_override = chosen;
                Change::PaintMaterials
            }
            Command::Size(width, height) => {
                // A zero-sized image has no pixels to render.
                if (width, height) == self.size || width == 0 || height == 0 {
                    return Change::Nothing;
                }
                self.size = (width, height);
                Change::Size
            }
            Command::Display(choice) => {
                if choice == self.display {
                    return Change::Nothing;
                }
                self.display = choice;
                Change::Display
            }
            Command::Orbit(yaw, pitch) => self.move_camera(|c| c.orbit(yaw, pitch)),
            Command::Zoom(factor) => self.move_camera(|c| c.zoom(factor)),
            Command::Pan(dx, dy) => self.move_camera(|c| c.pan(dx, dy)),
            Command::Lighting(_)
            | Command::OpenMap(_)
            | Command::Scene(_)
            | Command::View(_)
            | Command::TogglePaintAt(..)
            | Command::Quality(_) => Change::Nothing,
        }
    }

    fn take_design(&mut self, design: PaintDesign) -> Change {
        if design == self.design {
            return Change::Nothing;
        }
        let gloss_changed = design.gloss != self.design.gloss;
        self.design = design;
        if gloss_changed {
            Change::Gloss
        } else {
            Change::Paint
        }
    }

    fn move_camera(&mut self, step: impl FnOnce(&mut Camera)) -> Change {
        step(&mut self.camera);
        self.view = None;
        Change::Camera
    }

    /// The scene materials that carry the paint: the override, else the loader's.
    pub fn paint_materials(&self, automatic: &[u32]) -> Vec<u32> {
        self.paint_override
            .clone()
            .unwrap_or_else(|| automatic.to_vec())
    }
}
