//! The data the views are rendered from, derived from the inputs: the wavelength
//! grid, the scene with its BVH, the lighting, and the first view's paint model.
//! Each is built only here, and each build is counted.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::colour::spectrum::WavelengthGrid;
use crate::design::PaintDesign;
use crate::paint::model::PaintModel;
use crate::render::environment::Environment;
use crate::render::lighting::Lighting;
use crate::render::progressive::RenderScene;
use crate::scene::car::{CarParameters, generate};
use crate::scene::gltf_loader::{LoadOptions, load};

use super::command::SceneSource;
use super::counters::EngineCounters;
use super::events::{EngineError, SceneInfo};

/// What the views are rendered from.
#[derive(Debug)]
pub(super) struct World {
    /// Every path carries these wavelengths.
    pub grid: WavelengthGrid,
    /// The scene with its BVH and materials.
    pub scene: Arc<RenderScene>,
    /// The scene as the user sees it.
    pub info: SceneInfo,
    /// The lighting, on `grid`.
    pub environment: Arc<Environment>,
    /// The environment map read last, with its file, on `grid`: lighting with it
    /// again does not read the file.
    pub map: Option<(PathBuf, Arc<Environment>)>,
    /// The first view's paint model and the design it was built for, kept so an
    /// edit rebuilds only the derived tables it touches.
    tables: Option<(PaintDesign, PaintModel)>,
}

impl World {
    /// The built-in car in the studio on `grid`.
    pub fn new(grid: WavelengthGrid, counters: &mut EngineCounters) -> Result<Self, EngineError> {
        let (scene, info) = load_scene(&SceneSource::BuiltInCar, counters)?;
        let environment = Arc::new(build_lighting(&Lighting::Studio, &grid, counters)?);
        Ok(Self {
            grid,
            scene,
            info,
            environment,
            map: None,
            tables: None,
        })
    }

    /// The first view's paint model for `design`: kept when it was built for it,
    /// brought up to it from the previous design where one is kept (unless
    /// `rebuild`), else built. `None` when the design cannot be modelled; the
    /// next model is then built from scratch.
    pub fn model_for(
        &mut self,
        design: &PaintDesign,
        rebuild: bool,
        counters: &mut EngineCounters,
    ) -> Option<&PaintModel> {
        let kept = if rebuild { None } else { self.tables.take() };
        let model = match kept {
            Some((previous, model)) if previous == *design => model,
            Some((previous, mut model)) => {
                counters.table_builds += 1;
                design.update_model(&previous, &mut model).ok()?;
                model
            }
            None => {
                counters.table_builds += 1;
                design.model(self.grid).ok()?
            }
        };
        self.tables = Some((design.clone(), model));
        self.tables.as_ref().map(|(_, model)| model)
    }

    /// The lighting `lighting` on the current grid: a map read last from the
    /// same file is used again.
    pub fn lighting(
        &mut self,
        lighting: &Lighting,
        counters: &mut EngineCounters,
    ) -> Result<Arc<Environment>, EngineError> {
        match lighting {
            Lighting::Map(path) => match &self.map {
                Some((read, environment)) if read == path => Ok(environment.clone()),
                _ => self.read_map(path, counters),
            },
            setup => Ok(Arc::new(build_lighting(setup, &self.grid, counters)?)),
        }
    }

    /// The environment map in `path`, read now; it becomes the map read last.
    pub fn read_map(
        &mut self,
        path: &Path,
        counters: &mut EngineCounters,
    ) -> Result<Arc<Environment>, EngineError> {
        let lighting = Lighting::Map(path.to_owned());
        let environment = Arc::new(build_lighting(&lighting, &self.grid, counters)?);
        self.map = Some((path.to_owned(), environment.clone()));
        Ok(environment)
    }

    /// Moves to `grid`, rebuilding `lighting` on it. A map is not read again:
    /// the grid then stays and the error says so.
    pub fn regrid(
        &mut self,
        grid: WavelengthGrid,
        lighting: &Lighting,
        counters: &mut EngineCounters,
    ) -> Result<(), EngineError> {
        if matches!(lighting, Lighting::Map(_)) {
            return Err(EngineError::MapKeepsGrid(self.grid.len()));
        }
        self.environment = Arc::new(build_lighting(lighting, &grid, counters)?);
        self.grid = grid;
        self.map = None;
        Ok(())
    }
}

/// Loads the scene of `source` and builds its BVH.
pub(super) fn load_scene(
    source: &SceneSource,
    counters: &mut EngineCounters,
) -> Result<(Arc<RenderScene>, SceneInfo), EngineError> {
    let (scene, path) = match source {
        SceneSource::BuiltInCar => (generate(&CarParameters::default()), None),
        SceneSource::File(path) => (
            load(path, &LoadOptions::default()).map_err(|e| EngineError::Scene(e.to_string()))?,
            Some(path.as_path()),
        ),
    };
    let info = SceneInfo::of(&scene, path.map(Path::new));
    counters.bvh_builds += 1;
    let scene = RenderScene::new(scene).map_err(|e| EngineError::Scene(e.to_string()))?;
    Ok((Arc::new(scene), info))
}

fn build_lighting(
    lighting: &Lighting,
    grid: &WavelengthGrid,
    counters: &mut EngineCounters,
) -> Result<Environment, EngineError> {
    counters.lighting_builds += 1;
    Ok(lighting.build(grid)?)
}
