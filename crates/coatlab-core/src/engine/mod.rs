//! The live-rendering engine: what the designer's preview renders, and when.
//!
//! One type, [`LiveEngine`], owns the one or two views of the preview (the
//! second for a comparison), takes [`Command`]s — the design, the views' models
//! and the comparison, the scene, the lighting, the camera, the size, the
//! quality knobs — and decides by itself what to re-shade, re-trace or rebuild.
//! The decisions are an explicit state machine ([`plan`]): a command becomes a
//! [`plan::Change`], [`plan::transition`] gives the next [`plan::State`] and the
//! [`plan::Actions`] (which derived tables, BVH, lighting, renders and caches to
//! rebuild; whether to re-shade or restart), and what the back-end reports
//! moves the state on through [`plan::advance`]. [`EngineCounters`] records
//! every build, so the tests check each transition without a window.
//!
//! | module | what |
//! | --- | --- |
//! | [`command`] | the commands and the values they carry |
//! | [`plan`] | the state machine: states, changes, outcomes, actions |
//! | [`live`] | [`LiveEngine`]: the commands taken |
//! | `step` | [`LiveEngine::step`]: actions done, passes rendered, images published |
//! | `inputs`, `world` | what is set, and what is derived from it (grid, BVH, lighting, tables) |
//! | `views` | the first view, and the second: shared or rendered apart |
//! | [`frame`] | the published images |
//! | [`delta_e`] | the ΔE00 map between the views |
//! | [`guide`] | both views' samples (and shared, the first view's recordings) spent where the map is undecided |
//! | [`backend`], [`cpu`] | the seam for a back-end, and the CPU path tracer behind it |
//! | [`events`] | loads, failures, the scene as shown |
//! | [`thread`] | the engine on a render thread, commands in, images out |
//!
//! The engine knows no window: the app's preview sends commands to an
//! [`EngineThread`] and shows the images it posts.

pub mod backend;
pub mod command;
mod counters;
pub mod cpu;
pub mod delta_e;
pub mod events;
pub mod frame;
pub mod guide;
mod inputs;
pub mod live;
pub mod plan;
mod step;
pub mod thread;
mod views;
mod world;

#[cfg(test)]
mod tests;

use std::sync::Arc;

pub use backend::{BackendView, RenderBackend, ViewSetup};
pub use command::{Command, QualityKnobs, SceneSource, SecondView, Views};
pub use counters::EngineCounters;
pub use cpu::CpuBackend;
pub use delta_e::DeltaEMap;
pub use events::{EngineError, EngineEvent, MaterialInfo, SceneInfo, file_name};
pub use frame::{Frame, SecondSource, SecondUpdate, ViewsUpdate};
pub use live::{LiveEngine, Output, Progress, VISIBLE_AREA_COLUMNS};
pub use plan::{Pairing, Phase, State};
pub use thread::{EngineThread, Job, Mailbox, ThreadHooks};
pub use views::SecondImage;

/// Wavelengths per path without a quality preset: as `coatlab render` by default.
pub const DEFAULT_WAVELENGTHS: usize = 32;
/// Refinement stops here without a quality preset; the image is then as good as
/// the preview gets.
pub const MAX_SPP: u32 = 1024;
/// The coarse first pass after a change renders at 1/COARSE_FACTOR of the
/// resolution, so a change shows within a frame or two.
pub const COARSE_FACTOR: u32 = 4;
/// Samples per pixel whose paths the first view records for re-shading paint
/// edits (memory bounded by the core's default path-cache budget).
pub const RESHADE_SAMPLES: u32 = 4;
/// Samples per pixel of one recording of the first view's paths in a
/// comparison, for the second view to be re-shaded from. Each complete
/// recording is merged into the shared difference and the next one takes its
/// place, so the difference refines with the first view's samples while the
/// memory stays that of one recording. The memory budget
/// ([`crate::render::progressive::DEFAULT_PATH_CACHE_BUDGET_BYTES`]) makes a
/// recording shorter if it must.
pub const COMPARE_CACHE_SAMPLES: u32 = 16;
/// How much sharper the second view's gloss lobe may be than the first's,
/// relative excess of its exponent, for the second to be shared from the first
/// view's paths (a wider second lobe is never shared beyond
/// [`crate::render::reshade::LOBE_WIDENING_ALLOWED`]). A Phong best fit keeps the
/// paint's exponent to 10⁻⁵; a design against a variant of itself at another
/// gloss reading differs by a factor. Measured on the signal red against
/// itself at lower readings, shared against rendered apart with map guidance
/// (docs/benchmarks.md, "Comparison"): at ×1.12 (87.5 against 88 GU) both leave
/// every highlight pixel decided, and sharing leaves the map's floor and both
/// panes cleaner; from ×1.23 (87 against 88 GU) two renders with map guidance
/// leave the highlights, where such designs differ, as decided or more (×1.23:
/// every pixel against one missed in half the shared runs; ×1.42: 95.5 against
/// 92.4 %). The limit lies between: ×1.2.
pub const SHARED_LOBE_NARROWING: f32 = 0.2;
/// The image size an engine starts at, before it is told its pane's.
pub const INITIAL_SIZE: (u32, u32) = (320, 200);

/// A function run first on every thread the engine starts.
pub type ThreadHook = Arc<dyn Fn() + Send + Sync>;
