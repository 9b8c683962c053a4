//! Re-shading: a new picture after a paint edit without tracing a single ray.
//!
//! While a designer drags a paint slider, the geometry, the camera and the lighting
//! stay put; only the paint's BSDF values change. The progressive renderer records,
//! for the first K samples of every pixel, each path that touches the paint: at
//! every vertex the surface, ωo, the light sample that reached the light (its
//! directions and densities) and the continuation (direction, density, roulette),
//! plus the colour the path contributed ([`PathCache`]).
//!
//! # Glass and alpha
//!
//! What a path does at a see-through surface ([`crate::render::glass`]: skip a
//! masked or blended point, reflect off or pass through a thin pane, reflect off
//! or refract into a volume, be absorbed inside it) depends on the surface, the
//! direction and the path's random numbers, never on the paint (painted
//! materials are never see-through). So are the weights it takes there (R/P or
//! T/P of a pane, 1 for a skip or a volume's choice, the Beer–Lambert
//! absorption) and what a shadow ray lets through on its way to the light. The
//! recording keeps them as spectral factors (`SeeThroughFactor`): per vertex
//! the product of the weights met on the way to it and its light sample's
//! transmittance, and, when the path met glass after its last vertex, the whole
//! escape per unit throughput (the radiance along the direction the glass left
//! it, times its MIS weight, which the glass fixed). The replay multiplies them
//! in where the tracer did, so a recorded path through glass is re-weighed only
//! at its paint vertices, as any other; a path painted at its first vertex only
//! folds them into its two stored spectra. The estimator stays the same sum over
//! the same recorded paths with the same fixed, paint-independent factors, so
//! it stays unbiased: c_new,k is the traced path's contribution with every
//! paint factor f_old replaced by f_new and everything else as traced.
//!
//! # The estimator (a control variate)
//!
//! With I_old the accumulated image of the old design (many samples) and, per pixel,
//! the K recorded paths with contributions c_old,k, re-evaluating the same paths with
//! the new BSDF gives c_new,k, and
//!
//! Î_new = Î_old + (1/K) Σ_k (c_new,k − c_old,k)
//!
//! estimates the new image without bias: the paths were sampled with the old BSDF's
//! densities, and re-weighting them by f_new·cos/p_old (and the old roulette
//! probabilities and MIS densities, which need only be a valid partition) keeps every
//! term an unbiased estimate, as long as the old sampling covers where the new BSDF
//! is non-zero — always true here, because every paint samples the cosine hemisphere
//! with non-zero probability. Its noise is that of Î_old plus that of the difference,
//! which is small when the edit is (the same paths enter both terms). Paths that
//! never touch the paint have c_new = c_old and are not stored.
//!
//! Where it does not apply: glass and alpha are replayed (above), so a scene with
//! them re-shades like any other; what is refused is a change of the lobe from or
//! to the ideal mirror (a delta
//! cannot be re-weighted; [`ReshadeError::DeltaChanged`]); a lobe wider than the one
//! the paths were sampled from ([`ReshadeError::LobeWidened`]: a gloss edit, or an
//! index edit under a gloss reading, whose exponent falls with n), where the weights
//! are unbounded and the mean at the recorded sample counts reads the highlights far
//! too dark; and any change of the scene, lighting, camera or wavelength grid (the
//! renderer restarts and drops the cache). A sharper lobe stays unbiased with bounded
//! weights, but its noise grows with the ratio of the exponents: the application
//! traces fresh on a gloss edit.
//!
//! # A first image from fewer samples
//!
//! The mean over any fixed subset of the K recorded samples is as unbiased as
//! the mean over all K, so [`reshade_prepared`] re-shades only the first
//! m of them (each stored path knows its pixel sample's index) for a first image
//! at about m/K of the replay's cost, with a correspondingly larger variance;
//! the full re-shade or fresh passes refine it.
//!
//! # Memory
//!
//! [`PathCache::memory_bytes`]: one [`VertexRecord`] per stored vertex plus one
//! small header per stored path, and one spectrum (with a 12-byte index) per
//! see-through factor of a path that met glass or alpha. See `docs/rendering.md`
//! for measured sizes.
//!
//! # A comparison's shared difference
//!
//! The same replay, kept as the difference a second shading makes, merged over
//! a render's successive recordings and blended with each pane's own film:
//! [`ShadingDifference`] (`reshade/difference.rs`).

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use thiserror::Error;

use crate::colour::Xyz;
use crate::paint::model::SpectralBsdf;
use crate::render::environment::Environment;
use crate::render::film::Film;
use crate::render::geometry::Surface;
use crate::render::integrator::{
    NextRecord, PathRecorder, PathTracer, VertexRecord, power_heuristic,
};
use crate::render::material::{Shading, SimpleMaterial, SurfaceExtras};

mod difference;

pub use difference::{COMBINE_BLOCK, ShadingDifference};

/// How much wider, relative, a re-shaded lobe may be than the recorded one
/// (its exponent this much smaller) and still be re-weighted: what the f32
/// tables of one design can differ by, not a wider lobe
/// ([`ReshadeError::LobeWidened`]).
pub const LOBE_WIDENING_ALLOWED: f32 = 0.01;

/// Why a re-shade cannot be done.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReshadeError {
    /// Fewer samples per pixel are recorded than asked for.
    #[error("the path cache is not complete yet ({recorded} of {wanted} samples per pixel)")]
    NotReady {
        /// Recorded so far.
        recorded: u32,
        /// Asked for.
        wanted: u32,
    },
    /// The new shading is on another grid.
    #[error("the new shading is on another wavelength grid")]
    GridChanged,
    /// A recorded mirror (delta) bounce meets a BSDF without a mirror.
    #[error("the paint changed to or from an ideal mirror: its paths must be traced anew")]
    DeltaChanged,
    /// The images to combine are of different sizes (a view was resized since
    /// the paths were re-shaded).
    #[error("the image size changed since the paths were re-shaded")]
    SizeChanged,
    /// The paint's specular lobe is wider than the one the paths were sampled
    /// from (a gloss edit, or an index edit under a gloss reading).
    #[error(
        "the gloss lobe widened (exponent {recorded} to {wanted}): its paths must be traced anew"
    )]
    LobeWidened {
        /// The exponent the paths were sampled with.
        recorded: f32,
        /// The new shading's exponent.
        wanted: f32,
    },
    /// A material other than the paint is textured: the replay does not repeat
    /// its texture look-ups.
    #[error(
        "the scene has textured materials, which re-shading does not replay: its paths must be traced anew"
    )]
    Textured,
}

/// One stored path.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CachedPath {
    /// Pixel index within the tile.
    pixel: u32,
    /// Index of the pixel sample it was traced for (for a re-shade from the first
    /// samples only, [`reshade_prepared`]).
    sample: u32,
    first_vertex: u32,
    vertex_count: u32,
    /// Its see-through factors, in [`TileCache::factors`].
    first_factor: u32,
    factor_count: u32,
    escaped: bool,
    /// XYZ it contributed when traced.
    xyz: [f32; 3],
}

/// A spectral factor a path met at see-through surfaces (glass, alpha), which
/// does not depend on the paint: what the replay multiplies in where the tracer
/// did.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SeeThroughFactor {
    /// The vertex (index within its path) it belongs to; for
    /// [`FactorKind::Escape`], the path's vertex count.
    vertex: u32,
    kind: FactorKind,
    /// Index of its spectrum in [`TileCache::spectra`] (or in the recorder's
    /// scratch while the path is being traced).
    spectrum: u32,
}

/// Where a [`SeeThroughFactor`] applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FactorKind {
    /// To the throughput on the way to the vertex: the weights of the panes
    /// crossed or reflected off, the skips, a volume's absorption.
    Before,
    /// To the vertex's light sample: what its shadow ray let through.
    Light,
    /// The escape after the last vertex, when the path met see-through
    /// surfaces after it: the environment's radiance along the final direction
    /// times its MIS weight and the factors met on the way (the whole escape,
    /// per unit throughput).
    Escape,
}

/// The recorded paths of one tile of the image.
#[derive(Debug, Clone, Default)]
pub struct TileCache {
    origin: [u32; 2],
    width: u32,
    height: u32,
    paths: Vec<CachedPath>,
    vertices: Vec<VertexRecord>,
    compact: Vec<CompactPath>,
    /// The see-through factors of the paths in `paths`.
    factors: Vec<SeeThroughFactor>,
    /// Two spectra per compact path (its light sample and the rest of the path)
    /// and one per see-through factor.
    spectra: Vec<f32>,
    /// Heap bytes this tile may hold ([`TileCache::memory_bytes`]); `usize::MAX`:
    /// unbounded.
    pool: Option<Arc<AtomicUsize>>,
    /// A path did not fit under the limit in the pass being recorded: the pass's
    /// recordings are rolled back and recording stops (see
    /// [`PathCache::memory_bytes`]).
    overflowed: bool,
    /// Per pixel of the tile (row major), the samples recorded so far: the
    /// next recorded sample's index. A pass spread by per-pixel weights records
    /// more samples of some pixels than of others.
    counts: Vec<u32>,
    /// [`Self::lengths`] and [`Self::counts`] when the pass being recorded
    /// began ([`Self::begin_pass`]), so that rolling the pass back also rolls
    /// back the counts; `None` outside a recorded pass.
    pass_start: Option<([usize; 5], Vec<u32>)>,
}

/// A path whose only painted vertex is its first, the common case (the camera
/// sees the paint; the path goes on to the floor, the sky or unpainted parts):
/// stored as the first vertex's decisions plus the two spectra that a paint edit
/// does not change, so re-shading it is two BSDF evaluations.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CompactPath {
    pixel: u32,
    /// Index of the pixel sample it was traced for.
    sample: u32,
    /// Index of its first spectrum in [`TileCache::spectra`].
    spectra: u32,
    wo: [f32; 3],
    /// The light sample's direction (local), when it reached the light.
    light_wi: Option<[f32; 3]>,
    /// The continuation: direction (local), density, delta, roulette survival.
    next: Option<([f32; 3], f32, bool, f32)>,
    xyz: [f32; 3],
}

/// Runs `$body` on each of a [`TileCache`]'s five stores (vectors of different
/// element types, so no loop can), with its index in [`TileCache::lengths`].
macro_rules! each_store {
    ($cache:expr, |$store:ident, $i:pat_param| $body:expr) => {{
        {
            let ($store, $i) = (&mut $cache.paths, 0);
            $body;
        }
        {
            let ($store, $i) = (&mut $cache.vertices, 1);
            $body;
        }
        {
            let ($store, $i) = (&mut $cache.compact, 2);
            $body;
        }
        {
            let ($store, $i) = (&mut $cache.spectra, 3);
            $body;
        }
        {
            let ($store, $i) = (&mut $cache.factors, 4);
            $body;
        }
    }};
}

impl TileCache {
    pub(crate) fn new(origin: [u32; 2], width: u32, height: u32) -> Self {
        Self {
            origin,
            width,
            height,
            counts: vec![0; width as usize * height as usize],
            ..Self::default()
        }
    }

    /// The samples recorded of the tile's pixel `pixel` (row major in the tile).
    pub(crate) fn recorded(&self, pixel: usize) -> u32 {
        self.counts[pixel]
    }

    /// Draws this tile's growth from `pool`, the bytes left in the budget that all
    /// tiles of a pass share (tiles differ a lot in how many paths touch the
    /// paint, so a fixed share per tile would stop the recording early).
    pub(crate) fn set_pool(&mut self, pool: Arc<AtomicUsize>) {
        self.pool = Some(pool);
    }

    pub(crate) fn overflowed(&self) -> bool {
        self.overflowed
    }

    /// Makes room for `extra` more items in the vector `which` picks, taking the
    /// growth from the shared pool (capacity, not only length, is paid for, so the
    /// heap memory never passes the budget). False when they do not fit.
    fn reserve(&mut self, which: Store, extra: usize) -> bool {
        let pool = self.pool.as_deref();
        let overflowed = &mut self.overflowed;
        match which {
            Store::Paths => grow(&mut self.paths, extra, pool, overflowed),
            Store::Vertices => grow(&mut self.vertices, extra, pool, overflowed),
            Store::Compact => grow(&mut self.compact, extra, pool, overflowed),
            Store::Spectra => grow(&mut self.spectra, extra, pool, overflowed),
            Store::Factors => grow(&mut self.factors, extra, pool, overflowed),
        }
    }

    pub(crate) fn clear(&mut self) {
        each_store!(self, |store, _| store.clear());
        self.overflowed = false;
        self.counts.fill(0);
        self.pass_start = None;
    }

    /// Notes where a recorded pass begins, for [`Self::truncate`]: before any
    /// tile of the pass runs, since a cancelled pass may skip a tile whole.
    pub(crate) fn begin_pass(&mut self) {
        self.pass_start = Some((self.lengths(), self.counts.clone()));
    }

    /// The recorded pass is done: nothing to roll back any more.
    pub(crate) fn end_pass(&mut self) {
        self.pass_start = None;
    }

    /// What is stored, to roll back a cancelled pass.
    pub(crate) fn lengths(&self) -> [usize; 5] {
        [
            self.paths.len(),
            self.vertices.len(),
            self.compact.len(),
            self.spectra.len(),
            self.factors.len(),
        ]
    }

    pub(crate) fn truncate(&mut self, lengths: [usize; 5]) {
        // Called with the lengths from before a pass (cancelled or over the
        // budget): that pass's samples are not recorded. A pass that was not
        // recorded has nothing to roll back.
        if let Some((start, counts)) = self.pass_start.take()
            && start == lengths
        {
            self.counts = counts;
        }
        each_store!(self, |store, i| store.truncate(lengths[i]));
    }

    /// Rolls back to `lengths` after an overflow and gives the memory back.
    pub(crate) fn roll_back(&mut self, lengths: [usize; 5]) {
        self.truncate(lengths);
        each_store!(self, |store, _| store.shrink_to_fit());
        self.overflowed = false;
    }

    fn memory_bytes(&self) -> usize {
        self.paths.capacity() * size_of::<CachedPath>()
            + self.vertices.capacity() * size_of::<VertexRecord>()
            + self.compact.capacity() * size_of::<CompactPath>()
            + self.spectra.capacity() * size_of::<f32>()
            + self.factors.capacity() * size_of::<SeeThroughFactor>()
    }
}

/// The vectors of a [`TileCache`], for [`TileCache::reserve`].
#[derive(Debug, Clone, Copy)]
enum Store {
    Paths,
    Vertices,
    Compact,
    Spectra,
    Factors,
}

/// [`TileCache::reserve`] for one vector: doubles its capacity (at least 16), or
/// grows it just enough when the pool cannot pay for doubling; sets `overflowed`
/// and returns false when the pool cannot pay for even that.
fn grow<T>(
    items: &mut Vec<T>,
    extra: usize,
    pool: Option<&AtomicUsize>,
    overflowed: &mut bool,
) -> bool {
    let (len, capacity, size) = (items.len(), items.capacity(), size_of::<T>());
    if len + extra <= capacity {
        return true;
    }
    let doubled = (len + extra).max(capacity * 2).max(16);
    let wanted = match pool {
        None => doubled,
        Some(pool) => {
            let take = |count: usize| {
                let bytes = (count - capacity) * size;
                pool.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |left| {
                    left.checked_sub(bytes)
                })
                .is_ok()
            };
            if take(doubled) {
                doubled
            } else if take(len + extra) {
                len + extra
            } else {
                *overflowed = true;
                return false;
            }
        }
    };
    items.reserve_exact(wanted - len);
    true
}

/// The decisions of one path traced in a wave, kept until the wave is done and
/// then handed to the tile's [`TileRecorder`] in the path's turn
/// ([`Self::replay_into`]): a wave traces its paths' bounces together, while a
/// tile cache stores each path's records in one run. Reused from wave to wave
/// (clearing keeps its memory).
#[derive(Debug, Default)]
pub(crate) struct PathLog {
    events: Vec<LoggedEvent>,
    /// The spectra the events carry, one after another.
    spectra: Vec<f32>,
}

/// One call a path made to its recorder; a spectrum's length is kept with it,
/// its values in [`PathLog::spectra`].
#[derive(Debug, Clone, Copy)]
enum LoggedEvent {
    Vertex(VertexRecord, Option<usize>),
    Crossed(Option<usize>),
    Escape([f32; 3], f32),
}

impl PathLog {
    pub(crate) fn clear(&mut self) {
        self.events.clear();
        self.spectra.clear();
    }

    /// Hands the logged decisions to `recorder` in the order the path made them.
    pub(crate) fn replay_into(&self, recorder: &mut impl PathRecorder) {
        let mut at = 0;
        let mut take = |len: Option<usize>| {
            len.map(|len| {
                let spectrum = &self.spectra[at..at + len];
                at += len;
                spectrum
            })
        };
        for event in &self.events {
            match *event {
                LoggedEvent::Vertex(vertex, len) => recorder.vertex(&vertex, take(len)),
                LoggedEvent::Crossed(len) => recorder.crossed(take(len)),
                LoggedEvent::Escape(dir, mis) => recorder.escape(dir, mis),
            }
        }
    }

    fn keep(&mut self, spectrum: Option<&[f32]>) -> Option<usize> {
        spectrum.map(|values| {
            self.spectra.extend_from_slice(values);
            values.len()
        })
    }
}

impl PathRecorder for PathLog {
    fn vertex(&mut self, vertex: &VertexRecord, light_transmittance: Option<&[f32]>) {
        let len = self.keep(light_transmittance);
        self.events.push(LoggedEvent::Vertex(*vertex, len));
    }

    fn crossed(&mut self, factor: Option<&[f32]>) {
        let len = self.keep(factor);
        self.events.push(LoggedEvent::Crossed(len));
    }

    fn escape(&mut self, dir: [f32; 3], mis: f32) {
        self.events.push(LoggedEvent::Escape(dir, mis));
    }
}

/// Records one path into a tile cache (see [`PathRecorder`]).
pub(crate) struct TileRecorder<'a> {
    cache: &'a mut TileCache,
    tracer: &'a PathTracer<'a>,
    buffers: ReplayBuffers,
    start: usize,
    painted_vertices: u32,
    first_painted: bool,
    escaped: bool,
    /// The product of the see-through factors met since the last vertex, and
    /// whether any see-through event happened since (a skip or a volume's
    /// reflection weighs 1 but may turn or continue the path).
    factor: Vec<f32>,
    crossed: bool,
    /// This path's see-through factors so far, their spectra in `factor_spectra`.
    factors: Vec<SeeThroughFactor>,
    factor_spectra: Vec<f32>,
}

impl<'a> TileRecorder<'a> {
    pub(crate) fn new(cache: &'a mut TileCache, tracer: &'a PathTracer<'a>) -> Self {
        let start = cache.vertices.len();
        Self {
            cache,
            tracer,
            buffers: ReplayBuffers::new(tracer.len()),
            start,
            painted_vertices: 0,
            first_painted: false,
            escaped: false,
            factor: vec![1.0; tracer.len()],
            crossed: false,
            factors: Vec::new(),
            factor_spectra: Vec::new(),
        }
    }

    /// Starts the next path.
    pub(crate) fn begin(&mut self) {
        self.start = self.cache.vertices.len();
        self.painted_vertices = 0;
        self.first_painted = false;
        self.escaped = false;
        self.factor.fill(1.0);
        self.crossed = false;
        self.factors.clear();
        self.factor_spectra.clear();
    }

    /// Index within the path being traced of its next vertex.
    fn next_vertex(&self) -> u32 {
        (self.cache.vertices.len() - self.start) as u32
    }

    /// Ends the path traced since [`Self::begin`], at image pixel (`x`, `y`), which
    /// contributed `xyz`: kept if it touched the paint.
    pub(crate) fn finish(&mut self, x: u32, y: u32, xyz: Xyz) {
        let start = self.start;
        let pixel = (y - self.cache.origin[1]) * self.cache.width + (x - self.cache.origin[0]);
        let count = &mut self.cache.counts[pixel as usize];
        let sample = *count;
        *count += 1;
        if self.painted_vertices == 0 || self.cache.overflowed {
            self.cache.vertices.truncate(start);
            return;
        }
        let xyz = [xyz.x as f32, xyz.y as f32, xyz.z as f32];
        if self.painted_vertices == 1 && self.first_painted {
            let len = self.tracer.len();
            if self.cache.reserve(Store::Compact, 1) && self.cache.reserve(Store::Spectra, 2 * len)
            {
                self.store_compact(pixel, sample, xyz);
            }
            self.cache.vertices.truncate(start);
            return;
        }
        if !(self.cache.reserve(Store::Paths, 1)
            && self.cache.reserve(Store::Factors, self.factors.len())
            && self
                .cache
                .reserve(Store::Spectra, self.factor_spectra.len()))
        {
            self.cache.vertices.truncate(start);
            return;
        }
        let (first_factor, offset) = (self.cache.factors.len(), self.cache.spectra.len() as u32);
        self.cache
            .factors
            .extend(self.factors.iter().map(|f| SeeThroughFactor {
                spectrum: f.spectrum + offset,
                ..*f
            }));
        self.cache.spectra.extend_from_slice(&self.factor_spectra);
        self.cache.paths.push(CachedPath {
            pixel,
            sample,
            first_vertex: start as u32,
            vertex_count: (self.cache.vertices.len() - start) as u32,
            first_factor: first_factor as u32,
            factor_count: self.factors.len() as u32,
            escaped: self.escaped,
            xyz,
        });
    }

    /// Stores the path begun at `self.start` (painted at its first vertex only) in
    /// compact form. Its first vertex's see-through factors are folded into the
    /// two spectra (what reached the vertex multiplies both, what its shadow ray
    /// let through the light sample's).
    fn store_compact(&mut self, pixel: u32, sample: u32, xyz: [f32; 3]) {
        let environment = self.tracer.environment();
        let shading = self.tracer.shading();
        let floor = self.tracer.floor_material();
        let len = self.tracer.len();
        let vertices = &self.cache.vertices[self.start..];
        let first = vertices[0];
        let offset = self.cache.spectra.len();
        let (own, rest) = self
            .factors
            .split_at(self.factors.partition_point(|f| f.vertex == 0));
        let spectrum_of = |kind: FactorKind| {
            own.iter()
                .find(|f| f.kind == kind)
                .map(|f| &self.factor_spectra[f.spectrum as usize..][..len])
        };
        let (before, transmitted) = (
            spectrum_of(FactorKind::Before),
            spectrum_of(FactorKind::Light),
        );
        // The light sample's radiance times its fixed weights.
        let light = &mut self.buffers.light;
        match first.light {
            Some(l) => {
                environment.radiance(l.direction.world, light);
                let scale =
                    l.direction.local[2] * power_heuristic(l.light_pdf, l.bsdf_pdf) / l.light_pdf;
                light.iter_mut().for_each(|v| *v *= scale);
                for factor in [before, transmitted].into_iter().flatten() {
                    light.iter_mut().zip(factor).for_each(|(v, f)| *v *= f);
                }
            }
            None => light.fill(0.0),
        }
        self.cache.spectra.extend_from_slice(&light[..len]);
        // The rest of the path: unpainted, so it does not change with the paint.
        // Written into `buffers.out`, then appended: no allocation per path.
        let replayed = replay_path(
            &Recorded {
                vertices: &vertices[1..],
                first: 1,
                previous: first.next,
                escaped: self.escaped,
                factors: rest,
                spectra: &self.factor_spectra,
            },
            environment,
            shading,
            floor,
            &mut self.buffers,
        );
        let out = &mut self.buffers.out;
        if replayed.is_err() {
            out.fill(0.0);
        }
        if let Some(before) = before {
            out.iter_mut().zip(before).for_each(|(v, f)| *v *= f);
        }
        self.cache.spectra.extend_from_slice(&out[..len]);
        self.cache.compact.push(CompactPath {
            pixel,
            sample,
            spectra: offset as u32,
            wo: first.wo,
            light_wi: first.light.map(|l| l.direction.local),
            next: first
                .next
                .map(|n| (n.direction.local, n.pdf, n.delta, n.survive)),
            xyz,
        });
    }
}

/// Adds a see-through factor of `kind` for the path's vertex `vertex`, its
/// spectrum appended to `spectra`.
fn push_factor(
    factors: &mut Vec<SeeThroughFactor>,
    spectra: &mut Vec<f32>,
    vertex: u32,
    kind: FactorKind,
    spectrum: &[f32],
) {
    factors.push(SeeThroughFactor {
        vertex,
        kind,
        spectrum: spectra.len() as u32,
    });
    spectra.extend_from_slice(spectrum);
}

impl PathRecorder for TileRecorder<'_> {
    fn vertex(&mut self, vertex: &VertexRecord, light_transmittance: Option<&[f32]>) {
        // Past the limit nothing more is kept in this pass (it is rolled back).
        if self.cache.overflowed || !self.cache.reserve(Store::Vertices, 1) {
            return;
        }
        let index = self.next_vertex();
        if std::mem::take(&mut self.crossed) {
            if self.factor.iter().any(|&v| v != 1.0) {
                let (factors, spectra) = (&mut self.factors, &mut self.factor_spectra);
                push_factor(factors, spectra, index, FactorKind::Before, &self.factor);
            }
            self.factor.fill(1.0);
        }
        if let Some(transmitted) = light_transmittance
            && vertex.light.is_some()
        {
            let (factors, spectra) = (&mut self.factors, &mut self.factor_spectra);
            push_factor(factors, spectra, index, FactorKind::Light, transmitted);
        }
        if let Surface::Mesh { material } = vertex.surface
            && self.tracer.shading().is_painted(material)
        {
            self.painted_vertices += 1;
            if index == 0 {
                self.first_painted = true;
            }
        }
        self.cache.vertices.push(*vertex);
    }

    fn crossed(&mut self, factor: Option<&[f32]>) {
        self.crossed = true;
        if let Some(factor) = factor {
            self.factor
                .iter_mut()
                .zip(factor)
                .for_each(|(v, f)| *v *= f);
        }
    }

    fn escape(&mut self, dir: [f32; 3], mis: f32) {
        self.escaped = true;
        if self.crossed {
            // Turned or weighed by glass since its last vertex: the whole escape
            // per unit throughput, as the tracer added it.
            let index = self.next_vertex();
            let seen = &mut self.buffers.light;
            self.tracer.environment().radiance(dir, seen);
            for (v, f) in seen.iter_mut().zip(&self.factor) {
                *v *= f * mis;
            }
            let (factors, spectra) = (&mut self.factors, &mut self.factor_spectra);
            push_factor(factors, spectra, index, FactorKind::Escape, seen);
        }
    }
}

/// The paths recorded for re-shading: of every pixel's recorded samples, those
/// that touched the paint. Every pixel has [`PathCache::samples_per_pixel`]
/// recorded samples, unless the recorded passes were spread by per-pixel
/// weights ([`PathCache::recorded_per_pixel`]).
#[derive(Debug, Clone, Default)]
pub struct PathCache {
    pub(crate) tiles: Vec<TileCache>,
    pub(crate) samples_per_pixel: u32,
    /// Whether the paint it was recorded with is an ideal mirror.
    pub(crate) paint_is_mirror: bool,
    /// The exponent of the paint's lobe it was recorded with (`None`: a mirror).
    pub(crate) lobe_exponent: Option<f32>,
}

impl PathCache {
    /// Samples per pixel recorded: every pixel's, or with passes spread by
    /// per-pixel weights, the passes' samples per pixel (the pixels' mean).
    pub fn samples_per_pixel(&self) -> u32 {
        self.samples_per_pixel
    }

    /// Per pixel of the `width` × `height` image the cache was recorded for (row
    /// major), its recorded samples.
    pub fn recorded_per_pixel(&self, width: u32, height: u32) -> Vec<u32> {
        let mut counts = vec![0; width as usize * height as usize];
        for tile in &self.tiles {
            for (row, tile_row) in tile
                .counts
                .chunks_exact(tile.width.max(1) as usize)
                .enumerate()
            {
                let start =
                    (tile.origin[1] as usize + row) * width as usize + tile.origin[0] as usize;
                counts[start..start + tile_row.len()].copy_from_slice(tile_row);
            }
        }
        counts
    }

    /// Stored paths (those that touched the paint).
    pub fn path_count(&self) -> usize {
        self.tiles
            .iter()
            .map(|t| t.paths.len() + t.compact.len())
            .sum()
    }

    /// Of [`Self::path_count`], those stored compactly (painted at the first
    /// vertex only).
    pub fn compact_path_count(&self) -> usize {
        self.tiles.iter().map(|t| t.compact.len()).sum()
    }

    /// Stored vertices.
    pub fn vertex_count(&self) -> usize {
        self.tiles.iter().map(|t| t.vertices.len()).sum()
    }

    /// Heap memory held, bytes.
    pub fn memory_bytes(&self) -> usize {
        self.tiles.iter().map(TileCache::memory_bytes).sum()
    }
}

/// A re-shaded image: per pixel the estimate of the new design's mean XYZ and the
/// variances of that estimate's X, Y and Z.
#[derive(Debug, Clone)]
pub struct Reshaded {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Mean XYZ per pixel (white at Y = 1), row-major.
    pub xyz: Vec<[f32; 3]>,
    /// Estimated variances of each pixel's X, Y and Z.
    pub variance_xyz: Vec<[f32; 3]>,
}

/// The image a re-shade starts from: per pixel the mean XYZ of the recorded
/// render and the variances of its X, Y and Z, in f32. Prepared once per
/// editing session ([`BaseImage::of`]), so an edit does not walk the film's f64
/// sums again.
#[derive(Debug, Clone)]
pub struct BaseImage {
    width: u32,
    height: u32,
    xyz: Vec<[f32; 3]>,
    variance_xyz: Vec<[f32; 3]>,
}

impl BaseImage {
    /// The means and variances of `film` (in parallel over rows).
    pub fn of(film: &Film) -> Self {
        let (width, height) = (film.width(), film.height());
        // Rows in parallel, collected in order: unzipped into the two images.
        let (xyz, variance_xyz) = (0..height)
            .into_par_iter()
            .flat_map_iter(|y| {
                (0..width).map(move |x| {
                    let m = film.mean_xyz(x, y);
                    (
                        [m.x as f32, m.y as f32, m.z as f32],
                        film.variance_of_mean_xyz(x, y).map(|v| v as f32),
                    )
                })
            })
            .unzip();
        Self {
            width,
            height,
            xyz,
            variance_xyz,
        }
    }

    /// Heap memory held, bytes.
    pub fn memory_bytes(&self) -> usize {
        (self.xyz.capacity() + self.variance_xyz.capacity()) * size_of::<[f32; 3]>()
    }
}

/// Re-shades `cache` (recorded on `base`, rendered with the old shading, lit by
/// `environment`) with `shading`. See the module documentation.
pub fn reshade(
    base: &Film,
    cache: &PathCache,
    environment: &Environment,
    shading: &Shading,
    floor: bool,
) -> Result<Reshaded, ReshadeError> {
    if shading.channels() != base.channels() || environment.channels() != base.channels() {
        return Err(ReshadeError::GridChanged);
    }
    reshade_prepared(
        &BaseImage::of(base),
        base,
        cache,
        environment,
        shading,
        floor,
        u32::MAX,
    )
}

/// [`reshade`] from a prepared [`BaseImage`] of `film` (the film supplies only
/// its colour-matching weights) and only the first `samples` recorded samples of
/// every pixel (at least 1; all of a pixel's where it has fewer): about
/// `samples`/K of the work, for a first image the moment an edit arrives.
/// Each pixel's mean is over its own recorded samples, so a recording that
/// holds more samples of some pixels than of others (passes spread by
/// per-pixel weights) gives every pixel its own estimate from all it has.
///
/// Each recorded sample alone gives an unbiased estimate of the difference the
/// edit makes, so the mean over the first `samples` of them does too, only
/// noisier; the image from all K (or fresh passes, which the editing flow blends
/// in) follows. The variances it reports cover that noise: with two or more
/// samples their sample variance over `samples`; from a single sample, where no
/// variance can be estimated, the squared difference itself (its expectation is
/// the variance plus the squared mean: an overestimate, never an underestimate).
pub fn reshade_prepared(
    base: &BaseImage,
    film: &Film,
    cache: &PathCache,
    environment: &Environment,
    shading: &Shading,
    floor: bool,
    samples: u32,
) -> Result<Reshaded, ReshadeError> {
    if shading.channels() != film.channels() || environment.channels() != film.channels() {
        return Err(ReshadeError::GridChanged);
    }
    // A recorded mirror bounce meets a finite lobe in the replay, but a new mirror
    // has no recorded bounce to weigh: refused here, not missed silently.
    if paint_is_mirror(shading) != cache.paint_is_mirror {
        return Err(ReshadeError::DeltaChanged);
    }
    if shading.has_textures() {
        return Err(ReshadeError::Textured);
    }
    // A replayed bounce is weighed by the new BSDF over the density it was sampled
    // from. Where the new lobe is wider, that weight grows without bound away from
    // the old lobe's axis (its second moment diverges once the exponent halves):
    // unbiased in theory, but at the recorded sample counts the highlights read up
    // to a third too dark (tests/reshade.rs). A narrower lobe keeps the weight
    // bounded by the ratio of the exponents.
    if let (Some(recorded), Some(wanted)) = (cache.lobe_exponent, shading.design().lobe_exponent())
        && wanted < (1.0 - LOBE_WIDENING_ALLOWED) * recorded
    {
        return Err(ReshadeError::LobeWidened { recorded, wanted });
    }
    let floor_material = environment
        .floor()
        .filter(|_| floor)
        .map(|f| SimpleMaterial::lambertian(&f.reflectance));
    let used = samples.max(1);
    let width = base.width as usize;
    let mut xyz = vec![[0.0f32; 3]; base.xyz.len()];
    let mut variance_xyz = vec![[0.0f32; 3]; base.variance_xyz.len()];
    // Work by strips of tiles (runs of tiles on the same rows, in the order of
    // `Film::tiles`): each strip owns its rows of the output, copies the base into
    // them and adds its tiles' differences, with one tile-sized scratch of sums
    // per strip. (Image-sized f64 sums and a serial merge were a third of the
    // re-shade's time.)
    let mut strips: Vec<Strip<'_>> = Vec::new();
    let (mut xyz_rest, mut var_rest) = (&mut xyz[..], &mut variance_xyz[..]);
    let mut tiles = &cache.tiles[..];
    let mut row = 0usize;
    while let Some(first) = tiles.first() {
        let run = tiles
            .iter()
            .take_while(|t| t.origin[1] == first.origin[1] && t.height == first.height)
            .count();
        assert_eq!(
            first.origin[1] as usize, row,
            "path cache tiles are not in row-major strips"
        );
        let rows = first.height as usize;
        let (x, x_rest) = std::mem::take(&mut xyz_rest).split_at_mut(rows * width);
        let (v, v_rest) = std::mem::take(&mut var_rest).split_at_mut(rows * width);
        strips.push((&tiles[..run], x, v, row));
        (xyz_rest, var_rest, tiles) = (x_rest, v_rest, &tiles[run..]);
        row += rows;
    }
    // Rows no tile covers (an empty cache): the base as it is.
    let covered = row * width;
    xyz_rest.copy_from_slice(&base.xyz[covered..]);
    var_rest.copy_from_slice(&base.variance_xyz[covered..]);
    strips
        .into_par_iter()
        .try_for_each(|(tiles, xyz_rows, var_rows, row)| {
            let start = row * width;
            xyz_rows.copy_from_slice(&base.xyz[start..start + xyz_rows.len()]);
            var_rows.copy_from_slice(&base.variance_xyz[start..start + var_rows.len()]);
            let mut buffers = ReplayBuffers::new(shading.len());
            let mut sums: Vec<DifferenceSums> = Vec::new();
            for tile in tiles {
                sums.clear();
                sums.resize((tile.width * tile.height) as usize, [0.0; 6]);
                replay_tile(
                    tile,
                    film,
                    environment,
                    shading,
                    floor_material.as_ref(),
                    used,
                    &mut buffers,
                    &mut sums,
                )?;
                for (p, s) in sums.iter().enumerate() {
                    if s.iter().all(|&v| v == 0.0) {
                        continue;
                    }
                    let (tx, ty) = (p % tile.width as usize, p / tile.width as usize);
                    let i = ty * width + tile.origin[0] as usize + tx;
                    let (v, var) = (&mut xyz_rows[i], &mut var_rows[i]);
                    // Mean and variance of the difference over the pixel's samples
                    // used (the paths not stored have a difference of exactly 0;
                    // a stored path makes the count at least 1).
                    let recorded = tile.recorded(p);
                    let used = used.min(recorded);
                    let k = f64::from(used);
                    for c in 0..3 {
                        let mean = s[c] / k;
                        v[c] += mean as f32;
                        if used > 1 {
                            var[c] +=
                                (((s[3 + c] - k * mean * mean) / (k - 1.0)).max(0.0) / k) as f32;
                        } else if recorded > 1 {
                            var[c] += s[3 + c] as f32;
                        }
                    }
                }
            }
            Ok::<(), ReshadeError>(())
        })?;
    Ok(Reshaded {
        width: base.width,
        height: base.height,
        xyz,
        variance_xyz,
    })
}

/// Whether the designed paint of `shading` is an ideal mirror (has a delta lobe).
pub(crate) fn paint_is_mirror(shading: &Shading) -> bool {
    let mut f = vec![0.0f32; shading.len()];
    shading.design().delta_reflectance([0.0, 0.0, 1.0], &mut f)
}

/// A run of tiles on the same rows, the output rows they cover (XYZ, variances
/// of X, Y and Z) and the first of those rows.
type Strip<'a> = (
    &'a [TileCache],
    &'a mut [[f32; 3]],
    &'a mut [[f32; 3]],
    usize,
);

/// Per pixel: Σ ΔX, Σ ΔY, Σ ΔZ, Σ ΔX², Σ ΔY², Σ ΔZ² over its stored paths.
type DifferenceSums = [f64; 6];

/// Adds the [`DifferenceSums`] of every pixel of a tile, from the paths of its
/// first `samples` samples, into `sums` (one per pixel of the tile).
#[allow(clippy::too_many_arguments)]
fn replay_tile(
    tile: &TileCache,
    film: &Film,
    environment: &Environment,
    shading: &Shading,
    floor: Option<&SimpleMaterial>,
    samples: u32,
    buffers: &mut ReplayBuffers,
    sums: &mut [DifferenceSums],
) -> Result<(), ReshadeError> {
    let len = shading.len();
    let mut add = |pixel: u32, new: Xyz, old: [f32; 3]| {
        let d = [
            new.x - f64::from(old[0]),
            new.y - f64::from(old[1]),
            new.z - f64::from(old[2]),
        ];
        let s = &mut sums[pixel as usize];
        for c in 0..3 {
            s[c] += d[c];
            s[3 + c] += d[c] * d[c];
        }
    };
    for path in tile.compact.iter().filter(|p| p.sample < samples) {
        let spectra = &tile.spectra[path.spectra as usize..][..2 * len];
        let (light, rest) = spectra.split_at(len);
        let material = shading.design();
        let ReplayBuffers { out, f, .. } = &mut *buffers;
        match path.light_wi {
            Some(wi) => {
                material.eval(wi, path.wo, f);
                for ((o, fv), l) in out.iter_mut().zip(&*f).zip(light) {
                    *o = fv * l;
                }
            }
            None => out.fill(0.0),
        }
        if let Some((wi, pdf, delta, survive)) = path.next {
            let scale = if delta {
                if !material.delta_reflectance(path.wo, f) {
                    return Err(ReshadeError::DeltaChanged);
                }
                1.0 / (pdf * survive)
            } else {
                material.eval(wi, path.wo, f);
                wi[2] / (pdf * survive)
            };
            for ((o, fv), r) in out.iter_mut().zip(&*f).zip(rest) {
                *o += fv * scale * r;
            }
        }
        add(path.pixel, film.xyz_of(out), path.xyz);
    }
    for path in tile.paths.iter().filter(|p| p.sample < samples) {
        let vertices = &tile.vertices
            [path.first_vertex as usize..(path.first_vertex + path.vertex_count) as usize];
        let factors = &tile.factors[path.first_factor as usize..][..path.factor_count as usize];
        let recorded = Recorded {
            vertices,
            first: 0,
            previous: None,
            escaped: path.escaped,
            factors,
            spectra: &tile.spectra,
        };
        replay_path(&recorded, environment, shading, floor, buffers)?;
        add(path.pixel, film.xyz_of(&buffers.out), path.xyz);
    }
    Ok(())
}

struct ReplayBuffers {
    out: Vec<f32>,
    throughput: Vec<f32>,
    f: Vec<f32>,
    light: Vec<f32>,
}

impl ReplayBuffers {
    fn new(len: usize) -> Self {
        Self {
            out: vec![0.0; len],
            throughput: vec![0.0; len],
            f: vec![0.0; len],
            light: vec![0.0; len],
        }
    }
}

/// A recorded path, or the part of one after its first vertex, as
/// [`replay_path`] reads it.
struct Recorded<'a> {
    vertices: &'a [VertexRecord],
    /// Index within the path of `vertices[0]` (what the factors count from).
    first: u32,
    /// The continuation from the vertex before `vertices`, if the part starts
    /// after one: an escape right after it goes along it.
    previous: Option<NextRecord>,
    escaped: bool,
    /// The path's see-through factors from `first` on, in the order recorded.
    factors: &'a [SeeThroughFactor],
    /// Where their spectra are.
    spectra: &'a [f32],
}

/// The contribution of a recorded path under `shading`, into `buffers.out`: the
/// integrator's sums with its recorded decisions (see [`crate::render::integrator`]),
/// the see-through factors multiplied in where the tracer met them.
fn replay_path(
    path: &Recorded<'_>,
    environment: &Environment,
    shading: &Shading,
    floor: Option<&SimpleMaterial>,
    buffers: &mut ReplayBuffers,
) -> Result<(), ReshadeError> {
    let ReplayBuffers {
        out,
        throughput,
        f,
        light,
    } = buffers;
    let len = out.len();
    out.fill(0.0);
    throughput.fill(1.0);
    let mut factors = path.factors.iter().peekable();
    let spectrum_of = |factor: &SeeThroughFactor| &path.spectra[factor.spectrum as usize..][..len];
    for (index, vertex) in (path.first..).zip(path.vertices) {
        let mut transmitted = None;
        while let Some(factor) = factors.next_if(|f| f.vertex == index) {
            match factor.kind {
                FactorKind::Before => {
                    for (t, v) in throughput.iter_mut().zip(spectrum_of(factor)) {
                        *t *= v;
                    }
                }
                FactorKind::Light => transmitted = Some(spectrum_of(factor)),
                FactorKind::Escape => {}
            }
        }
        let material: &dyn SpectralBsdf = match (vertex.surface, floor) {
            (Surface::Mesh { material }, _) => {
                // A lamp adds its light where the path shaded it, as the tracer did.
                if let Some(SurfaceExtras::Emissive(emission)) = shading.extras(material) {
                    for ((o, t), e) in out.iter_mut().zip(&*throughput).zip(emission) {
                        *o += t * e;
                    }
                }
                shading.material(material)
            }
            (Surface::Floor, Some(floor)) => floor,
            // The recording saw a floor the lighting no longer has: not re-shadeable,
            // but the renderer drops the cache on a lighting change first.
            (Surface::Floor, None) => return Ok(()),
        };
        if let Some(l) = vertex.light {
            material.eval(l.direction.local, vertex.wo, f);
            environment.radiance(l.direction.world, light);
            if let Some(transmitted) = transmitted {
                light.iter_mut().zip(transmitted).for_each(|(v, t)| *v *= t);
            }
            let scale =
                l.direction.local[2] * power_heuristic(l.light_pdf, l.bsdf_pdf) / l.light_pdf;
            for (((o, t), fv), lv) in out.iter_mut().zip(&*throughput).zip(&*f).zip(&*light) {
                *o += t * fv * lv * scale;
            }
        }
        let Some(next) = vertex.next else {
            return Ok(());
        };
        if next.delta {
            if !material.delta_reflectance(vertex.wo, f) {
                return Err(ReshadeError::DeltaChanged);
            }
            let scale = 1.0 / (next.pdf * next.survive);
            for (t, fv) in throughput.iter_mut().zip(&*f) {
                *t *= fv * scale;
            }
        } else {
            material.eval(next.direction.local, vertex.wo, f);
            let scale = next.direction.local[2] / (next.pdf * next.survive);
            for (t, fv) in throughput.iter_mut().zip(&*f) {
                *t *= fv * scale;
            }
        }
    }
    if !path.escaped {
        return Ok(());
    }
    if let Some(seen) = factors.find(|f| f.kind == FactorKind::Escape) {
        for ((o, t), s) in out.iter_mut().zip(&*throughput).zip(spectrum_of(seen)) {
            *o += t * s;
        }
    } else if let Some(next) = path.vertices.last().map_or(path.previous, |v| v.next) {
        environment.radiance(next.direction.world, light);
        let mis = escape_weight(environment, &next);
        for ((o, t), lv) in out.iter_mut().zip(&*throughput).zip(&*light) {
            *o += t * lv * mis;
        }
    }
    Ok(())
}

/// The MIS weight of the environment seen by an escaping continuation, as the
/// integrator gave it: full after a delta, none where the vertex's light samples
/// alone took the direct light, else the power heuristic against the
/// environment's own sampling density.
fn escape_weight(environment: &Environment, next: &NextRecord) -> f32 {
    if next.delta {
        1.0
    } else if next.light_only {
        0.0
    } else {
        power_heuristic(next.pdf, environment.pdf(next.direction.world))
    }
}
