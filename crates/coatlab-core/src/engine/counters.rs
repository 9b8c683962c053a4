//! What the engine has built and rendered since it started: the record its tests
//! read to check that a command rebuilt what it had to and nothing else.

/// Running totals of the engine's work.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EngineCounters {
    /// Scenes loaded and their BVH built.
    pub bvh_builds: u64,
    /// Lighting environments built (setups, or map files read).
    pub lighting_builds: u64,
    /// The first view's paint model built or brought up to a new design (its
    /// derived tables).
    pub table_builds: u64,
    /// The first view's shading built (the paint model in the view's model, for
    /// the scene's materials).
    pub shading_builds: u64,
    /// The second view's shading built (each on a thread of its own).
    pub second_shading_builds: u64,
    /// Renders made by the back-end (the first view's on a new grid, the second
    /// view's when it is rendered apart).
    pub render_builds: u64,
    /// Times the first view started again from nothing (coarse pass first).
    pub retraces: u64,
    /// Paint edits shown re-shaded from the recorded paths.
    pub reshades: u64,
    /// Re-shades of the recorded paths into the panes of a shared comparison.
    pub pane_reshades: u64,
    /// Passes of the first view.
    pub passes: u64,
    /// Passes of the second view when rendered apart.
    pub second_passes: u64,
}

impl EngineCounters {
    /// What was done between `earlier` and now.
    pub fn since(&self, earlier: &EngineCounters) -> EngineCounters {
        EngineCounters {
            bvh_builds: self.bvh_builds - earlier.bvh_builds,
            lighting_builds: self.lighting_builds - earlier.lighting_builds,
            table_builds: self.table_builds - earlier.table_builds,
            shading_builds: self.shading_builds - earlier.shading_builds,
            second_shading_builds: self.second_shading_builds - earlier.second_shading_builds,
            render_builds: self.render_builds - earlier.render_builds,
            retraces: self.retraces - earlier.retraces,
            reshades: self.reshades - earlier.reshades,
            pane_reshades: self.pane_reshades - earlier.pane_reshades,
            passes: self.passes - earlier.passes,
            second_passes: self.second_passes - earlier.second_passes,
        }
    }
}
