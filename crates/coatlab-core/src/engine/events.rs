//! What the live engine reports besides images: loads, failures, and why.

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::render::environment::EnvironmentError;
use crate::render::progressive::RenderError;
use crate::render::view::ViewError;
use crate::scene::Scene;

/// Something the user should be told.
#[derive(Debug)]
pub enum EngineEvent {
    /// A scene was loaded and is now rendered (not sent for the scene the engine
    /// starts with).
    SceneLoaded(SceneInfo),
    /// An environment map was read and now lights the scene.
    MapLoaded(PathBuf),
    /// The materials that carry the paint now, after a pick toggled one
    /// ([`super::command::Command::TogglePaintAt`]).
    PaintMaterials(Vec<u32>),
    /// Per scene material, the area the current view sees of it, m²
    /// ([`super::LiveEngine::visible_areas`]), measured by a job the app sent.
    VisibleAreas(Vec<f32>),
    /// Something failed; the picture keeps what it had.
    Failed(EngineError),
    /// What a job run on the render thread reported ([`super::EngineThread::run_job`]).
    Report {
        /// The text for the user.
        text: String,
        /// Whether it tells of a failure.
        is_error: bool,
    },
}

/// Why a command or a render step failed.
#[derive(Debug, Error)]
pub enum EngineError {
    /// The wavelength grid of the live preview could not be made.
    #[error("preview: no wavelength grid")]
    NoGrid,
    /// The design cannot be modelled.
    #[error("preview: the design is invalid")]
    DesignInvalid,
    /// The second design of a comparison cannot be modelled.
    #[error("preview: the second design is invalid")]
    SecondDesignInvalid,
    /// A scene file could not be loaded, or has nothing to render.
    #[error("Could not open the scene: {0}")]
    Scene(String),
    /// An environment map could not be read.
    #[error("Could not open the environment map: {0}")]
    Map(#[from] EnvironmentError),
    /// A new wavelength count with an environment map as the lighting: the map's
    /// file would have to be read again, so the grid stays.
    #[error(
        "quality: an environment map stays at {0} wavelengths (choose a built-in lighting to change them)"
    )]
    MapKeepsGrid(usize),
    /// The back-end could not set up or change a render.
    #[error("preview: {0}")]
    Render(#[from] RenderError),
    /// A view the scene cannot give (a file camera it does not have).
    #[error("view: {0}")]
    View(#[from] ViewError),
}

/// The scene being rendered, as a user sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneInfo {
    /// "Built-in car" or the file name.
    pub name: String,
    /// Its file; `None` for the built-in car.
    pub path: Option<PathBuf>,
    /// The materials, by index.
    pub materials: Vec<MaterialInfo>,
    /// Materials that carry the paint as the loader chose them.
    pub automatic_paint: Vec<u32>,
    /// Problems that did not stop the load.
    pub warnings: Vec<String>,
    /// Names of the file's own cameras, by index (`ViewChoice::SceneCamera`).
    pub cameras: Vec<String>,
}

/// A scene material as the paint list shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialInfo {
    pub name: String,
    /// Its surface area, m²: what lets the body's large panels stand out from trim.
    pub area_m2: f32,
}

impl SceneInfo {
    /// What a user sees of `scene`, loaded from `path` (`None`: the built-in car).
    pub fn of(scene: &Scene, path: Option<&Path>) -> Self {
        Self {
            name: path.map(file_name).unwrap_or_else(|| "Built-in car".into()),
            path: path.map(Path::to_owned),
            materials: scene
                .materials
                .iter()
                .map(|m| MaterialInfo {
                    name: m.name.clone(),
                    area_m2: m.area_m2,
                })
                .collect(),
            automatic_paint: scene.paint_materials.clone(),
            warnings: scene.warnings.clone(),
            cameras: scene.cameras.iter().map(|c| c.name.clone()).collect(),
        }
    }
}

/// The last component of `path`, or all of it.
pub fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
