//! The path tracer: distributed ray tracing in its modern form.
//!
//! One path per pixel sample, carrying every wavelength of the grid: the paint's
//! path geometry (where a ray goes) does not depend on wavelength, only its weight
//! does, so all wavelengths share the same directions and the picture has no colour
//! noise. At each surface the path gathers light twice, and multiple importance
//! sampling (Veach's power heuristic, β = 2) weighs the two:
//!
//! - next-event estimation: a direction drawn from the environment's emitters
//!   ([`Environment::sample`]), tested for visibility by a shadow ray;
//! - the BSDF's own sample, which also continues the path; when it escapes to the
//!   environment, the radiance there counts with the complementary weight. Mirror
//!   (delta) samples cannot be reached by the light sample and count fully.
//!
//! Two exceptions make the estimator cheaper for the same error (measured on the
//! Mitsuba side-by-side scene; docs/tradeoff.md, "Estimator efficiency"):
//!
//! - On the floor (Lambertian, normal +Y everywhere) light samples are drawn for a
//!   surface facing up ([`Environment::sample_for`]: power × mean cosine to the
//!   vertical), which makes f·L·cos θ/pdf nearly constant over the sky, and the
//!   floor's direct light comes from them alone ([`IntegratorSettings::floor_light_only`]):
//!   the light sample counts with weight 1 and an escape from the floor with 0.
//!   MIS with the cosine-sampled continuation could only add back the noise the
//!   light distribution removed; both strategies cover every direction that
//!   lights the floor, so either alone is unbiased.
//! - The floor's direct light with a control variate
//!   ([`IntegratorSettings::floor_control_variate`]): the floor is flat and the
//!   environment distant, so its unshadowed direct light is the same everywhere,
//!   ρ/π times the environment's horizontal irradiance E
//!   ([`Environment::horizontal_irradiance`], exactly the mean of a facing-up
//!   light sample's L·cos θ/pdf). A floor vertex takes α·ρ/π·E and adds each
//!   light sample's contribution times (T − α), T what its shadow ray lets
//!   through and α the share of the sky the car leaves the point
//!   (`floor_control_share`): 0 where the sky is clear and α = 1, so the open
//!   floor's direct light carries no noise; the expectation is unchanged for
//!   any α. A recorded path's radiance leaves that term out
//!   (the re-shade replays the plain estimator, so the old and new contributions
//!   of a path stay alike), and the caller adds it to the film
//!   ([`PathBuffers::floor_control`]).
//! - At the first vertex, [`IntegratorSettings::first_light_samples`] light samples
//!   (each weighted 1/k, their numbers the points k·s … k·s + k − 1 of one
//!   stratified dimension pair) share the camera ray and the hit.
//!
//! After [`IntegratorSettings::roulette_start`] bounces, Russian roulette ends paths
//! with probability 1 − q, q = max_λ throughput held within
//! [[`ROULETTE_LEAST_SURVIVAL`], [`ROULETTE_MOST_SURVIVAL`]], and divides the
//! survivors by q, which keeps the estimate unbiased. Paths also end at
//! [`IntegratorSettings::max_bounces`] (a bias toward darker images, taken to be far
//! below the noise for the car; no measurement of it is recorded).
//!
//! Glass and alpha ([`crate::render::glass`]) are resolved per hit before its light
//! sample: a point that is skipped (alpha) or is glass draws none; the path goes
//! straight on, or takes a delta reflection or refraction. Shadow rays cross what
//! lets light straight through, weighted by its transmittance, so the interior
//! behind the windows is lit. Every surface is two-sided.
//! A recording path ([`PathRecorder`]) is told each crossing's weight and each
//! recorded shadow ray's transmittance: none depends on the paint, so re-shading
//! replays them ([`crate::render::reshade`], "Glass and alpha").
//!
//! Textured materials are evaluated at each hit ([`crate::render::texturing`]: the
//! parameters there, a normal map's normal) into a BSDF of their own. Emissive
//! surfaces (lamps) add their radiance where a path shades them, with weight 1: no
//! light sample aims at them. Paths end at the last bounce's hit without shading
//! it, so a lamp seen only there is missed, like the rest of that truncation.

use crate::accel::{BATCH_LANES, RayQuery};
use crate::paint::model::SpectralBsdf;
use crate::render::environment::{
    DirectionLookUp, EnvSample, Environment, LocatedSample, SampleLookUp,
};
use crate::render::geometry::{BatchScratch, Frame, RenderGeometry, Surface, SurfaceHit, dot};
use crate::render::glass::{
    Crossing, MAX_CROSSINGS, SeeThrough, fresnel_dielectric, reflect_probability, refracted_cos,
};
use crate::render::material::{Shading, SimpleMaterial, SurfaceExtras};
use crate::render::microfacet::GltfBsdf;
use crate::render::sampler::PixelSampler;
use crate::render::texturing::{PIXEL_SPREAD_RAD, TexturePoint, surface_parameters};

/// How far and how long paths run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IntegratorSettings {
    /// Most surface interactions on a path (0: only what the camera sees directly
    /// of the environment).
    pub max_bounces: u32,
    /// Number of bounces after which Russian roulette may end a path.
    pub roulette_start: u32,
    /// Light samples at the first vertex (1, 2 or 4; others round up to a power
    /// of two, at most 4). Recorded paths ([`PathRecorder::RECORDS`]) take one.
    pub first_light_samples: u32,
    /// The floor's direct light from light samples for a surface facing up alone
    /// (weight 1; escapes from the floor count 0); `false`: the sphere's light
    /// samples and MIS with the BSDF sample, as on every other surface.
    pub floor_light_only: bool,
    /// The floor's direct light as its unshadowed value less what the shadow rays
    /// find blocked (a control variate; needs [`Self::floor_light_only`] and an
    /// environment with [`Environment::horizontal_irradiance`]); `false`: the
    /// light samples' contributions alone.
    pub floor_control_variate: bool,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            max_bounces: 8,
            roulette_start: 4,
            first_light_samples: 2,
            floor_light_only: true,
            floor_control_variate: true,
        }
    }
}

/// The least survival probability Russian roulette gives a path, so that a
/// surviving path of low throughput is weighted up by at most 1/0.3. With the
/// throughput alone as the survival probability, the dark pixels lit over several
/// bounces (the cabin seen through the glass, the floor beside and under the car)
/// take most of their light from the few paths that survive at a throughput of a
/// few percent, each weighing tens of times the pixel's mean; a comparison's map
/// then misses its signal there more than twice as often in a 30 s run
/// (docs/benchmarks.md, "Comparison").
pub const ROULETTE_LEAST_SURVIVAL: f32 = 0.3;

/// The most survival probability Russian roulette gives a path: even a bright
/// path may end, so that no path runs to [`IntegratorSettings::max_bounces`] for
/// certain.
pub const ROULETTE_MOST_SURVIVAL: f32 = 0.95;

/// The probability that Russian roulette lets a path go on whose largest
/// throughput over the wavelengths is `largest`.
#[inline]
fn roulette_survival(largest: f32) -> f32 {
    largest.clamp(ROULETTE_LEAST_SURVIVAL, ROULETTE_MOST_SURVIVAL)
}

/// Most light samples at the first vertex ([`IntegratorSettings::first_light_samples`]).
pub const MAX_FIRST_LIGHT_SAMPLES: usize = 4;

/// Paths a [`PathTracer::radiance_wave`] traces together: each bounce's rays of
/// all of them go to the BVH as one batch ([`crate::accel::Accel::closest_hits`],
/// which keeps [`BATCH_LANES`] rays in flight at a time), and so do their shadow
/// rays; their environment look-ups are begun (texel records prefetched) all
/// before any is finished. Four batches' worth rather than one lets up to 32
/// texel-record misses overlap: on the Mitsuba scene (a 1024 × 512 map) process
/// CPU fell by about 6 % against waves of 8 (interleaved A/B, 12 pairs, noisy;
/// docs/benchmarks.md). The image does not depend on it (bit for bit, tested).
pub const WAVE_PATHS: usize = 4 * BATCH_LANES;

/// Per-thread scratch, so tracing paths allocates nothing once it has grown.
#[derive(Debug, Clone)]
pub struct PathBuffers {
    len: usize,
    /// Per path: the throughput.
    throughput: Vec<f32>,
    /// Per shadow ray: its light sample's contribution, added once the ray is
    /// known to be clear.
    pending: Vec<f32>,
    /// Per path: the floor's control-variate term ([`Self::floor_control`]).
    control: Vec<f32>,
    /// Per further light sample of a batch (at first vertices): its radiance, its
    /// look-up begun, what the look-up found.
    light_extra: Vec<f32>,
    begun_extra: Vec<Begun>,
    looked_up_extra: Vec<Option<EnvSample>>,
    bsdf: Vec<f32>,
    /// Per path: the environment's radiance along its light sample or its escape.
    light: Vec<f32>,
    /// Per ray of the batch: the light sample drawn at its hit, or the escape's
    /// density (its radiance is in `light`).
    looked_up: Vec<LookUp>,
    /// Per ray of the batch: its look-up begun (texel record being fetched).
    begun: Vec<Begun>,
    weight: Vec<f32>,
    lanes: Vec<Lane>,
    rays: Vec<RayQuery>,
    ray_lanes: Vec<usize>,
    hits: Vec<Option<SurfaceHit>>,
    shadow_rays: Vec<RayQuery>,
    shadow_lanes: Vec<usize>,
    blocked: Vec<bool>,
    /// Per ray of the batch: what it does at a see-through surface it hit.
    crossings: Vec<Crossing>,
    /// Shadow rays still crossing see-through surfaces, and the next round's.
    shadow_active: Vec<usize>,
    shadow_next: Vec<usize>,
    /// Per shadow ray of a recorded path: what passed the see-through surfaces
    /// it crossed.
    shadow_transmittance: Vec<f32>,
    scratch: BatchScratch,
}

impl PathBuffers {
    /// Buffers for `len` wavelengths.
    pub fn new(len: usize) -> Self {
        Self {
            len,
            throughput: Vec::new(),
            pending: Vec::new(),
            control: Vec::new(),
            light_extra: Vec::new(),
            begun_extra: Vec::new(),
            looked_up_extra: Vec::new(),
            bsdf: vec![0.0; len],
            light: Vec::new(),
            looked_up: Vec::new(),
            begun: Vec::new(),
            weight: vec![0.0; len],
            lanes: Vec::new(),
            rays: Vec::new(),
            ray_lanes: Vec::new(),
            hits: Vec::new(),
            shadow_rays: Vec::new(),
            shadow_lanes: Vec::new(),
            blocked: Vec::new(),
            crossings: Vec::new(),
            shadow_active: Vec::new(),
            shadow_next: Vec::new(),
            shadow_transmittance: Vec::new(),
            scratch: BatchScratch::default(),
        }
    }

    /// After [`PathTracer::radiance_wave`] with a recorder that records: path
    /// `path`'s floor control-variate term (see the module documentation), which
    /// its radiance leaves out and its film sample takes. Zero for a path that
    /// met no floor, and for every path not recorded (whose radiance holds it).
    pub fn floor_control(&self, path: usize) -> &[f32] {
        &self.control[path * self.len..(path + 1) * self.len]
    }
}

/// An environment look-up of one ray of a batch, begun: what needs no texel
/// record is done and the record is on its way into the cache.
#[derive(Debug, Clone, Copy)]
enum Begun {
    Nothing,
    Escape(DirectionLookUp),
    /// A light sample drawn up to its texel record, which is being fetched.
    Light(SampleLookUp),
    /// A light sample with its direction, whose texel record is being fetched
    /// (another one when the draw took the column's alias).
    Located(LocatedSample),
    /// A light sample that carries no density.
    Lost,
}

/// What the environment look-ups of a batch found for one ray.
#[derive(Debug, Clone, Copy)]
enum LookUp {
    /// The path ends here without looking at the light.
    Nothing,
    /// The ray escaped; the environment's density in its direction.
    Escape { pdf: f32 },
    /// The ray hit a surface, where this light sample was drawn (`None`: the
    /// sample carried no density).
    Light(Option<EnvSample>),
}

/// The state of one path of a wave between bounces.
#[derive(Debug, Clone, Copy)]
struct Lane {
    origin: [f32; 3],
    dir: [f32; 3],
    /// The density with which the previous bounce chose `dir`; a delta (or the
    /// camera) gives the environment its full weight.
    previous_pdf: f32,
    previous_delta: bool,
    /// Whether the previous vertex was on the floor (whose escapes count 0 under
    /// [`IntegratorSettings::floor_light_only`]).
    previous_floor: bool,
    /// Length of the path so far, m (the ray cone's width for texture look-ups).
    travelled_m: f32,
    bounce: u32,
    /// Skips and thin-pane transmissions so far ([`MAX_CROSSINGS`]).
    crossed: u32,
    /// The glass volume (scene material) the path is inside, if any.
    inside: Option<u32>,
    alive: bool,
    /// The vertex being shaded, told to the recorder once its shadow ray is known.
    record: Option<VertexRecord>,
    /// The shadow ray of the recorded light sample, by its index in the batch.
    record_shadow: Option<usize>,
}

/// The tracer for one scene, lighting and shading.
#[derive(Debug, Clone)]
pub struct PathTracer<'a> {
    geometry: &'a RenderGeometry,
    environment: &'a Environment,
    shading: &'a Shading,
    floor: Option<SimpleMaterial>,
    /// The floor's unshadowed direct light per channel, ρ/π · E, when the floor
    /// takes it as a control variate.
    floor_direct: Option<Vec<f32>>,
    settings: IntegratorSettings,
    /// Whether any material is glass or alpha (else no hit is looked at for it).
    see_through: bool,
}

/// What one path did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PathStats {
    /// Rays traced: closest-hit and shadow rays.
    pub rays: u32,
}

/// A direction leaving a vertex, as the BSDF sees it (its local frame) and as
/// the environment is looked up (world space).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexDirection {
    /// Unit direction, the vertex's local frame (z along the shading normal).
    pub local: [f32; 3],
    /// The same direction in world space.
    pub world: [f32; 3],
}

/// The light sample at a vertex that reached the light (unoccluded, non-zero
/// weight): enough to re-evaluate its contribution with another BSDF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightRecord {
    /// Direction toward the light.
    pub direction: VertexDirection,
    /// Density of the light sample.
    pub light_pdf: f32,
    /// Density with which the BSDF in use would have sampled it (for MIS).
    pub bsdf_pdf: f32,
}

/// The BSDF sample that continued the path from a vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NextRecord {
    /// The sampled direction.
    pub direction: VertexDirection,
    /// Its density (for a delta: the probability of choosing the delta).
    pub pdf: f32,
    /// Whether it came from a delta (mirror) component.
    pub delta: bool,
    /// Russian roulette's survival probability after it (1 when no roulette).
    pub survive: f32,
    /// The environment seen along it counts 0: the vertex's direct light came
    /// from its light samples alone ([`IntegratorSettings::floor_light_only`]).
    pub light_only: bool,
}

/// What the tracer did at one surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexRecord {
    /// The surface.
    pub surface: Surface,
    /// Direction toward the viewer (the previous vertex), local frame.
    pub wo: [f32; 3],
    /// The light sample, when it reached the light.
    pub light: Option<LightRecord>,
    /// The continuation, when the path went on.
    pub next: Option<NextRecord>,
}

/// Receives the decisions a path made, in order, for re-shading
/// ([`crate::render::reshade`]): every surface vertex and every see-through
/// event between them, then, when the path ended in the environment, its escape
/// (along the last vertex's continuation, the direction glass turned it to, or
/// the camera ray).
pub trait PathRecorder {
    /// Whether it records anything. A recorded vertex keeps one light sample
    /// ([`VertexRecord::light`]), so recorded paths take one at their first
    /// vertex too (the estimate stays unbiased, only its variance differs).
    const RECORDS: bool = true;
    /// A surface vertex was shaded. `light_transmittance`: what reached it of its
    /// light sample through see-through surfaces, per wavelength, when its shadow
    /// ray crossed any (`None`: it crossed none).
    fn vertex(&mut self, vertex: &VertexRecord, light_transmittance: Option<&[f32]>);
    /// The path met a see-through surface (skipped it, or was reflected,
    /// refracted or transmitted by glass) or was absorbed inside a volume: its
    /// throughput was multiplied by `factor` per wavelength (`None`: by 1).
    fn crossed(&mut self, factor: Option<&[f32]>);
    /// The path escaped to the environment along `dir`, whose radiance counted
    /// with the multiple importance sampling weight `mis`.
    fn escape(&mut self, dir: [f32; 3], mis: f32);
}

/// Records nothing (ordinary rendering; compiles to nothing).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoRecord;

impl PathRecorder for NoRecord {
    const RECORDS: bool = false;
    #[inline]
    fn vertex(&mut self, _: &VertexRecord, _: Option<&[f32]>) {}
    #[inline]
    fn crossed(&mut self, _: Option<&[f32]>) {}
    #[inline]
    fn escape(&mut self, _: [f32; 3], _: f32) {}
}

impl<'a> PathTracer<'a> {
    /// A tracer. The floor plane takes part when both the geometry and the lighting
    /// setup have one.
    ///
    /// # Panics
    /// If the environment and the shading have different numbers of channels (a
    /// programming error: the renderer builds both on the same channels).
    pub fn new(
        geometry: &'a RenderGeometry,
        environment: &'a Environment,
        shading: &'a Shading,
        settings: IntegratorSettings,
    ) -> Self {
        assert_eq!(
            environment.channels().len(),
            shading.len(),
            "environment and shading on different channels"
        );
        let floor = environment
            .floor()
            .filter(|_| geometry.has_floor())
            .map(|f| SimpleMaterial::lambertian(&f.reflectance));
        let floor_direct = match (environment.floor(), environment.horizontal_irradiance()) {
            (Some(floor), Some(irradiance))
                if settings.floor_light_only && settings.floor_control_variate =>
            {
                Some(
                    floor
                        .reflectance
                        .iter()
                        .zip(irradiance)
                        .map(|(r, e)| r * std::f32::consts::FRAC_1_PI * e)
                        .collect(),
                )
            }
            _ => None,
        };
        Self {
            geometry,
            environment,
            shading,
            floor,
            floor_direct,
            settings,
            see_through: shading.see_through().any(),
        }
    }

    /// The lighting.
    pub fn environment(&self) -> &Environment {
        self.environment
    }

    /// The shading.
    pub fn shading(&self) -> &Shading {
        self.shading
    }

    /// The floor's material, when the floor takes part.
    pub fn floor_material(&self) -> Option<&SimpleMaterial> {
        self.floor.as_ref()
    }

    /// Number of wavelengths a path carries.
    pub fn len(&self) -> usize {
        self.shading.len()
    }

    /// Whether paths carry no wavelengths.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The BSDF at a hit; `None` for the floor when the lighting has none (the
    /// geometry reports it only when asked to).
    fn material(&self, hit: &SurfaceHit) -> Option<&dyn SpectralBsdf> {
        match (hit.surface, &self.floor) {
            (Surface::Floor, Some(floor)) => Some(floor),
            (Surface::Mesh { material }, _) => Some(self.shading.material(material)),
            (Surface::Floor, None) => None,
        }
    }

    /// Whether the path shades its hit (draws a light sample and a bounce) rather
    /// than ending there: not after its last bounce, not on a missing floor.
    fn shades(&self, hit: &SurfaceHit, lane: &Lane) -> bool {
        lane.bounce < self.settings.max_bounces && self.material(hit).is_some()
    }

    /// Spectral radiance arriving at `origin` from direction `-dir` (the camera ray
    /// `origin + t·dir`, `dir` a unit vector), one estimate, written to `out`.
    /// Random numbers come from `sampler` in a fixed order, so the estimate is a
    /// function of the sampler's key alone. `recorder` is told every decision
    /// the path made ([`NoRecord`] for ordinary rendering); with one that
    /// records, `out` leaves out the floor's control term, which is then in
    /// [`PathBuffers::floor_control`].
    pub fn radiance(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        sampler: &mut PixelSampler,
        buffers: &mut PathBuffers,
        out: &mut [f32],
        recorder: &mut impl PathRecorder,
    ) -> PathStats {
        let len = self.len();
        self.radiance_wave(
            &[(origin, dir)],
            std::slice::from_mut(sampler),
            buffers,
            &mut out[..len],
            std::slice::from_mut(recorder),
        )
    }

    /// [`Self::radiance`] for several paths at once (at most
    /// [`WAVE_PATHS`] for the batches to pay): camera ray `rays[i]` with
    /// `samplers[i]`, its radiance to `out[i·len..(i+1)·len]`, its decisions to
    /// `recorders[i]` (when they record, `out` leaves the floor's control term to
    /// [`PathBuffers::floor_control`]). Each path draws the same random numbers, meets the same
    /// surfaces and adds up its radiance in the same order as it would alone, so
    /// the result is bit for bit that of tracing the paths one by one; only the
    /// rays go to the BVH together (each bounce's closest-hit rays as one batch,
    /// then the shadow rays of the light samples as another).
    ///
    /// # Panics
    /// If the slices' lengths disagree.
    pub fn radiance_wave<R: PathRecorder>(
        &self,
        rays: &[([f32; 3], [f32; 3])],
        samplers: &mut [PixelSampler],
        buffers: &mut PathBuffers,
        out: &mut [f32],
        recorders: &mut [R],
    ) -> PathStats {
        let len = self.len();
        let paths = rays.len();
        assert_eq!(
            buffers.len, len,
            "path buffers for another wavelength count"
        );
        assert_eq!(samplers.len(), paths, "one sampler per path");
        assert_eq!(recorders.len(), paths, "one recorder per path");
        assert_eq!(out.len(), paths * len, "one spectrum per path");
        let PathBuffers {
            throughput,
            pending,
            control,
            light_extra,
            begun_extra,
            looked_up_extra,
            bsdf: f,
            light: lights,
            looked_up,
            begun,
            weight,
            lanes,
            rays: queries,
            ray_lanes,
            hits,
            shadow_rays,
            shadow_lanes,
            blocked,
            crossings,
            shadow_active,
            shadow_next,
            shadow_transmittance,
            scratch,
            ..
        } = buffers;
        out.fill(0.0);
        control.clear();
        control.resize(paths * len, 0.0);
        throughput.clear();
        throughput.resize(paths * len, 1.0);
        lights.clear();
        lights.resize(paths * len, 0.0);
        lanes.clear();
        lanes.extend(rays.iter().map(|&(origin, dir)| Lane {
            origin,
            dir,
            previous_pdf: 0.0,
            previous_delta: true,
            previous_floor: false,
            travelled_m: 0.0,
            bounce: 0,
            crossed: 0,
            inside: None,
            alive: true,
            record: None,
            record_shadow: None,
        }));
        let use_floor = self.floor.is_some();
        let floor_light_only = self.settings.floor_light_only;
        let first_lights = if R::RECORDS {
            1
        } else {
            (self.settings.first_light_samples.max(1) as usize)
                .next_power_of_two()
                .min(MAX_FIRST_LIGHT_SAMPLES)
        };
        let mut stats = PathStats::default();
        loop {
            // One batch of closest-hit rays: the next segment of every live path.
            queries.clear();
            ray_lanes.clear();
            for (i, lane) in lanes.iter().enumerate().filter(|(_, l)| l.alive) {
                queries.push(RayQuery {
                    origin: lane.origin,
                    dir: lane.dir,
                    t_max: f32::INFINITY,
                });
                ray_lanes.push(i);
            }
            if queries.is_empty() {
                break;
            }
            stats.rays += queries.len() as u32;
            hits.clear();
            hits.resize(queries.len(), None);
            self.geometry
                .intersect_batch(queries, use_floor, hits, scratch);
            // The environment look-ups of the whole batch first, in two loops of
            // their own: each reads a texel record of a map that may be far larger
            // than the caches. The first loop finds every ray's texel (an escape's
            // direction, a light sample's row and column) and prefetches its
            // record, the second reads them, so the batch's cache misses overlap
            // instead of following one another. A path's random numbers are drawn
            // in the same order as alone, and the results are bit for bit those
            // of `Environment::radiance_and_pdf` and `Environment::sample`.
            // A first vertex's further light samples go into `begun_extra`, in
            // the order of the rays.
            begun.clear();
            begun_extra.clear();
            crossings.clear();
            for (&i, hit) in ray_lanes.iter().zip(hits.iter()) {
                let lane = &lanes[i];
                // What a see-through surface does with the ray, decided before its
                // light sample: one it skips or that is glass draws none.
                let crossing = hit.map_or(Crossing::Opaque, |hit| {
                    self.crossing(&hit, lane.travelled_m, &mut samplers[i])
                });
                crossings.push(crossing);
                begun.push(match hit {
                    Some(_) if crossing != Crossing::Opaque => Begun::Nothing,
                    // An escape's density is that of the light samples at the
                    // vertex it left (a floor's are for a surface facing up).
                    None => Begun::Escape(self.environment.begin_radiance_and_pdf_for(
                        lane.dir,
                        lane.previous_floor && floor_light_only,
                    )),
                    Some(hit) if self.shades(hit, lane) => {
                        let up = floor_light_only && hit.surface == Surface::Floor;
                        if lane.bounce == 0 && first_lights > 1 {
                            let mut us = [[0.0; 2]; MAX_FIRST_LIGHT_SAMPLES];
                            let us = &mut us[..first_lights];
                            samplers[i].next_2d_split(us);
                            begun_extra.extend(
                                us[1..].iter().map(|&u| {
                                    Begun::Light(self.environment.begin_sample_for(u, up))
                                }),
                            );
                            Begun::Light(self.environment.begin_sample_for(us[0], up))
                        } else {
                            Begun::Light(
                                self.environment.begin_sample_for(samplers[i].next_2d(), up),
                            )
                        }
                    }
                    Some(_) => Begun::Nothing,
                });
            }
            // Light samples in a third step: the direction from the record just
            // read, and the record of its own texel fetched (a draw that takes
            // the column's alias lands in another texel), before any is read.
            for started in begun.iter_mut().chain(begun_extra.iter_mut()) {
                if let Begun::Light(sample) = started {
                    *started = match self.environment.locate_sample(sample) {
                        Some(located) => Begun::Located(located),
                        None => Begun::Lost,
                    };
                }
            }
            looked_up.clear();
            for (&i, started) in ray_lanes.iter().zip(begun.iter()) {
                let light = &mut lights[i * len..(i + 1) * len];
                looked_up.push(match started {
                    Begun::Escape(begun) => LookUp::Escape {
                        pdf: self.environment.finish_radiance_and_pdf(begun, light),
                    },
                    Begun::Located(located) => {
                        LookUp::Light(self.environment.finish_located_sample(located, light))
                    }
                    Begun::Light(_) => unreachable!("every light sample was located"),
                    Begun::Lost => LookUp::Light(None),
                    Begun::Nothing => LookUp::Nothing,
                });
            }
            looked_up_extra.clear();
            light_extra.resize(begun_extra.len() * len, 0.0);
            for (e, started) in begun_extra.iter().enumerate() {
                let light = &mut light_extra[e * len..(e + 1) * len];
                looked_up_extra.push(match started {
                    Begun::Located(located) => {
                        self.environment.finish_located_sample(located, light)
                    }
                    _ => None,
                });
            }
            let mut next_extra = 0;
            shadow_rays.clear();
            shadow_lanes.clear();
            pending.clear();
            for (((&i, hit), &found), &crossing) in ray_lanes
                .iter()
                .zip(hits.iter())
                .zip(looked_up.iter())
                .zip(crossings.iter())
            {
                let lane = &mut lanes[i];
                let sampler = &mut samplers[i];
                let recorder = &mut recorders[i];
                let out = &mut out[i * len..(i + 1) * len];
                let throughput = &mut throughput[i * len..(i + 1) * len];
                let light = &lights[i * len..(i + 1) * len];
                let ray_dir = lane.dir;
                let Some(hit) = hit else {
                    let LookUp::Escape { pdf: light_pdf } = found else {
                        unreachable!("an escape's look-up")
                    };
                    let mis = if lane.previous_delta {
                        1.0
                    } else if lane.previous_floor && floor_light_only {
                        0.0
                    } else {
                        power_heuristic(lane.previous_pdf, light_pdf)
                    };
                    for ((o, t), l) in out.iter_mut().zip(throughput.iter()).zip(light.iter()) {
                        *o += t * l * mis;
                    }
                    recorder.escape(ray_dir, mis);
                    lane.alive = false;
                    continue;
                };
                if let Some(volume) = lane.inside.and_then(|m| self.shading.see_through().get(m)) {
                    if R::RECORDS {
                        // The absorption on its own, for the recorder.
                        weight.fill(1.0);
                        volume.absorb(hit.t, weight);
                        scale_and_largest(throughput, weight);
                        recorder.crossed(Some(weight));
                    } else {
                        volume.absorb(hit.t, throughput);
                    }
                }
                if crossing != Crossing::Opaque {
                    self.cross(
                        hit, crossing, lane, sampler, throughput, weight, f, recorder,
                    );
                    continue;
                }
                let (LookUp::Light(light_sample), Some(plain)) = (found, self.material(hit)) else {
                    // The last bounce's hit, or a floor this lighting has not.
                    lane.alive = false;
                    continue;
                };
                let to_viewer = [-ray_dir[0], -ray_dir[1], -ray_dir[2]];
                let travelled_m = lane.travelled_m + hit.t;
                // Textures and emission: the material's parameters at this hit (a
                // BSDF of its own) and its emitted light, which no light sample
                // reaches and so counts fully.
                let textured: GltfBsdf;
                let mut mapped_normal = None;
                let material: &dyn SpectralBsdf = match hit.surface {
                    Surface::Mesh { material: index } => match self.shading.extras(index) {
                        None => plain,
                        Some(SurfaceExtras::Emissive(emission)) => {
                            add_emission(out, throughput, emission);
                            plain
                        }
                        Some(SurfaceExtras::Textured(scene_material)) => {
                            let parameters = surface_parameters(
                                scene_material,
                                self.geometry.mesh(),
                                &TexturePoint {
                                    triangle: hit.triangle,
                                    barycentric: hit.barycentric,
                                    shading_normal: hit.shading_normal,
                                    footprint_m: travelled_m * PIXEL_SPREAD_RAD,
                                },
                            );
                            let upsampler = self.shading.upsampler();
                            let e = parameters.emission;
                            if e.red > 0.0 || e.green > 0.0 || e.blue > 0.0 {
                                upsampler.emission(e, f);
                                add_emission(out, throughput, f);
                            }
                            mapped_normal = parameters.normal;
                            textured =
                                GltfBsdf::new(&parameters.bsdf, upsampler, self.shading.channels());
                            &textured
                        }
                    },
                    Surface::Floor => plain,
                };
                // Interpolated normals can face away from the viewer near silhouettes;
                // shading with them would put ωo below the surface. So can a normal
                // map's, which then gives way to the interpolated normal.
                let normal = match mapped_normal {
                    Some(n) if dot(n, to_viewer) > 0.0 => n,
                    _ if dot(hit.shading_normal, to_viewer) > 0.0 => hit.shading_normal,
                    _ => hit.geometric_normal,
                };
                let frame = Frame::from_normal(normal);
                let wo = frame.to_local(to_viewer);
                let mut record = VertexRecord {
                    surface: hit.surface,
                    wo,
                    light: None,
                    next: None,
                };

                // Next-event estimation: each contribution waits in `pending` for
                // its shadow ray, which goes out with the other paths' ones.
                let on_floor = hit.surface == Surface::Floor;
                let light_only = on_floor && floor_light_only;
                let count = if lane.bounce == 0 { first_lights } else { 1 };
                let share = 1.0 / count as f32;
                // The vertex's own light sample (the one a record keeps), then a
                // first vertex's further ones, in the order they were begun.
                let extras = next_extra..next_extra + (count - 1);
                next_extra = extras.end;
                let samples = std::iter::once((light_sample, light)).chain(
                    extras.map(|e| (looked_up_extra[e], &light_extra[e * len..(e + 1) * len])),
                );
                // The floor's control variate: its unshadowed direct light now,
                // each light sample's contribution taken off here and given back
                // by its shadow ray as far as the ray gets through.
                let mut floor_control = match &self.floor_direct {
                    Some(direct) if light_only => {
                        let share = floor_control_share(self.geometry.bounds(), hit.position);
                        let control = &mut control[i * len..(i + 1) * len];
                        for ((c, t), d) in control.iter_mut().zip(throughput.iter()).zip(direct) {
                            *c += share * t * d;
                        }
                        (share > 0.0).then_some((control, share))
                    }
                    _ => None,
                };
                for (k, (light_sample, radiance)) in samples.enumerate() {
                    let Some(light_sample) = light_sample else {
                        continue;
                    };
                    let Some(light_record) = self.light_sample(
                        material,
                        hit,
                        &frame,
                        wo,
                        light_sample,
                        LightWeights {
                            throughput,
                            radiance,
                            share,
                            light_only,
                        },
                        f,
                        pending,
                        shadow_rays,
                    ) else {
                        continue;
                    };
                    if let Some((control, share)) = &mut floor_control {
                        let contribution = &pending[pending.len() - len..];
                        for (c, p) in control.iter_mut().zip(contribution) {
                            *c -= *share * p;
                        }
                    }
                    shadow_lanes.push(i);
                    if k == 0 {
                        record.light = Some(light_record);
                        lane.record_shadow = Some(shadow_lanes.len() - 1);
                    }
                }
                lane.record = Some(record);

                // The BSDF sample continues the path.
                // The direction as one 2D pair (stratified by the sampler), the
                // lobe choice and the roulette as 1D numbers of their own.
                let [u_dir_0, u_dir_1] = sampler.next_2d();
                let u_lobe = sampler.next_1d();
                let u_bsdf = [u_lobe, u_dir_0, u_dir_1];
                let u_roulette = sampler.next_1d();
                lane.alive = false;
                let Some(sample) = material.sample(wo, u_bsdf, weight) else {
                    continue;
                };
                let next_dir = frame.to_world(sample.wi);
                // A direction above the shading normal but below the geometric surface
                // would pass through it.
                if dot(next_dir, hit.geometric_normal) <= 0.0 {
                    continue;
                }
                let largest = scale_and_largest(throughput, weight);
                if !(largest > 0.0 && largest.is_finite()) {
                    continue;
                }
                let mut survive = 1.0;
                if lane.bounce + 1 >= self.settings.roulette_start {
                    survive = roulette_survival(largest);
                    if u_roulette >= survive {
                        continue;
                    }
                    throughput.iter_mut().for_each(|t| *t /= survive);
                }
                if let Some(record) = &mut lane.record {
                    record.next = Some(NextRecord {
                        direction: VertexDirection {
                            local: sample.wi,
                            world: next_dir,
                        },
                        pdf: sample.pdf,
                        delta: sample.delta,
                        survive,
                        light_only,
                    });
                }
                lane.alive = true;
                lane.previous_pdf = sample.pdf;
                lane.previous_delta = sample.delta;
                lane.previous_floor = on_floor;
                lane.travelled_m = travelled_m;
                lane.origin = RenderGeometry::spawn_origin(hit, next_dir);
                lane.dir = next_dir;
                lane.bounce += 1;
            }

            // One batch of shadow rays; a clear one adds its light sample.
            stats.rays += shadow_rays.len() as u32;
            blocked.clear();
            blocked.resize(shadow_rays.len(), false);
            // What each recorded shadow ray lets through, for the recorder.
            let transmittance = if R::RECORDS && self.see_through {
                shadow_transmittance.clear();
                shadow_transmittance.resize(shadow_rays.len() * len, 1.0);
                Some(&mut shadow_transmittance[..])
            } else {
                None
            };
            if self.see_through {
                stats.rays += self.see_through_shadows(
                    SeeThroughShadows {
                        rays: shadow_rays,
                        pending,
                        blocked,
                        active: shadow_active,
                        next: shadow_next,
                        queries,
                        hits,
                        scratch,
                        weight,
                        f,
                        transmittance,
                    },
                    use_floor,
                );
            } else {
                self.geometry
                    .occluded_batch(shadow_rays, use_floor, blocked, scratch);
            }
            for (j, (&i, &is_blocked)) in shadow_lanes.iter().zip(blocked.iter()).enumerate() {
                let lane = &mut lanes[i];
                if is_blocked {
                    if let Some(record) = &mut lane.record {
                        record.light = None;
                    }
                } else {
                    let out = &mut out[i * len..(i + 1) * len];
                    for (o, p) in out.iter_mut().zip(&pending[j * len..(j + 1) * len]) {
                        *o += p;
                    }
                }
            }
            for (lane, recorder) in lanes.iter_mut().zip(recorders.iter_mut()) {
                let shadow = lane.record_shadow.take();
                if let Some(record) = lane.record.take() {
                    let transmittance = shadow
                        .filter(|_| R::RECORDS && self.see_through && record.light.is_some())
                        .map(|j| &shadow_transmittance[j * len..(j + 1) * len])
                        .filter(|t| t.iter().any(|&v| v != 1.0));
                    recorder.vertex(&record, transmittance);
                }
            }
        }
        if !R::RECORDS && self.floor_direct.is_some() {
            for (o, c) in out.iter_mut().zip(control.iter()) {
                *o += c;
            }
        }
        stats
    }

    /// What a ray does at `hit` ([`Crossing`]): `Opaque` except on a see-through
    /// material, where the alpha there and `sampler` decide.
    fn crossing(&self, hit: &SurfaceHit, travelled_m: f32, sampler: &mut PixelSampler) -> Crossing {
        let Surface::Mesh { material } = hit.surface else {
            return Crossing::Opaque;
        };
        if !self.see_through {
            return Crossing::Opaque;
        }
        let Some(glass) = self.shading.see_through().get(material) else {
            return Crossing::Opaque;
        };
        let alpha = self.alpha_at(glass, hit, travelled_m);
        glass.choose(alpha, || sampler.next_1d())
    }

    /// The alpha of `glass` at `hit`, reached after `travelled_m` (the ray cone).
    fn alpha_at(&self, glass: &SeeThrough, hit: &SurfaceHit, travelled_m: f32) -> f32 {
        let point = TexturePoint {
            triangle: hit.triangle,
            barycentric: hit.barycentric,
            shading_normal: hit.shading_normal,
            footprint_m: (travelled_m + hit.t) * PIXEL_SPREAD_RAD,
        };
        glass.alpha(self.geometry.mesh(), &point)
    }

    /// Carries a path across a see-through surface (`crossing` is `Skip` or
    /// `Glass`): on in the same direction, or reflected or refracted by the glass,
    /// its throughput weighed (and the weight told to `recorder`); the lane dies
    /// where the path ends.
    #[allow(clippy::too_many_arguments)]
    fn cross<R: PathRecorder>(
        &self,
        hit: &SurfaceHit,
        crossing: Crossing,
        lane: &mut Lane,
        sampler: &mut PixelSampler,
        throughput: &mut [f32],
        reflect: &mut [f32],
        transmit: &mut [f32],
        recorder: &mut R,
    ) {
        lane.alive = false;
        lane.travelled_m += hit.t;
        let Surface::Mesh { material } = hit.surface else {
            return;
        };
        let Some(glass) = self.shading.see_through().get(material) else {
            return;
        };
        let dir = lane.dir;
        // The normal on the viewer's side, as for opaque shading.
        let n = if -dot(hit.shading_normal, dir) > 0.0 {
            hit.shading_normal
        } else {
            hit.geometric_normal
        };
        let cos_o = -dot(n, dir);
        let mirror = std::array::from_fn(|k| dir[k] + 2.0 * cos_o * n[k]);
        // The event's direction, and whether it reflects.
        let next: [f32; 3];
        let mut reflected = false;
        match crossing {
            Crossing::Opaque => return,
            Crossing::Skip => {
                next = dir;
                recorder.crossed(None);
            }
            Crossing::Glass if !glass.is_volume() => {
                glass.pane(cos_o, reflect, transmit);
                let p = reflect_probability(reflect, transmit);
                let (weight, chosen) = if sampler.next_1d() < p {
                    next = mirror;
                    reflected = true;
                    (reflect, p)
                } else {
                    next = dir;
                    (transmit, 1.0 - p)
                };
                let largest = scale_and_largest(throughput, weight);
                throughput.iter_mut().for_each(|t| *t /= chosen);
                if R::RECORDS {
                    weight.iter_mut().for_each(|w| *w /= chosen);
                    recorder.crossed(Some(weight));
                }
                if largest <= 0.0 {
                    return;
                }
            }
            Crossing::Glass => {
                let entering = lane.inside != Some(material);
                let eta = if entering {
                    glass.ior()
                } else {
                    1.0 / glass.ior()
                };
                let fresnel = fresnel_dielectric(cos_o, eta);
                recorder.crossed(None);
                if sampler.next_1d() < fresnel {
                    next = mirror;
                    reflected = true;
                } else {
                    let Some(cos_t) = refracted_cos(cos_o, eta) else {
                        return;
                    };
                    // Snell's law: the tangential part scaled by 1/η, the normal
                    // part continuing through.
                    next = std::array::from_fn(|k| (dir[k] + cos_o * n[k]) / eta - cos_t * n[k]);
                    lane.inside = if entering { Some(material) } else { None };
                }
            }
        }
        // A reflection must leave on the viewer's side of the true surface, a
        // transmission on the far side.
        let side = dot(next, hit.geometric_normal);
        if (reflected && side <= 0.0) || (!reflected && side >= 0.0) {
            return;
        }
        // Reflection and refraction turn the path: a (delta) bounce. Straight
        // through keeps the previous vertex's MIS state (module documentation of
        // `render::glass`).
        if reflected || next != dir {
            if lane.bounce >= self.settings.max_bounces {
                return;
            }
            lane.bounce += 1;
            lane.previous_pdf = 1.0;
            lane.previous_delta = true;
            lane.previous_floor = false;
        } else {
            lane.crossed += 1;
            if lane.crossed > MAX_CROSSINGS {
                return;
            }
        }
        lane.origin = RenderGeometry::spawn_origin(hit, next);
        lane.dir = next;
        lane.alive = true;
    }

    /// Traces shadow rays through see-through surfaces: each crossing multiplies
    /// the ray's pending contribution by what passes straight through there
    /// ([`SeeThrough::straight_through`]); an opaque hit, the floor, a volume or
    /// more than [`MAX_CROSSINGS`] crossings block it. Returns the rays traced
    /// after the first round.
    fn see_through_shadows(&self, b: SeeThroughShadows<'_>, floor: bool) -> u32 {
        let len = self.len();
        let SeeThroughShadows {
            rays,
            pending,
            blocked,
            active,
            next,
            queries,
            hits,
            scratch,
            weight,
            f,
            mut transmittance,
        } = b;
        active.clear();
        active.extend(0..rays.len());
        let mut traced = 0;
        for round in 0..=MAX_CROSSINGS {
            if active.is_empty() {
                break;
            }
            if round > 0 {
                traced += active.len() as u32;
            }
            queries.clear();
            queries.extend(active.iter().map(|&j| rays[j]));
            hits.clear();
            hits.resize(queries.len(), None);
            self.geometry.intersect_batch(queries, floor, hits, scratch);
            next.clear();
            for (&j, hit) in active.iter().zip(hits.iter()) {
                let Some(hit) = hit else {
                    continue;
                };
                let glass = match hit.surface {
                    Surface::Mesh { material } => self.shading.see_through().get(material),
                    Surface::Floor => None,
                };
                let Some(glass) = glass else {
                    blocked[j] = true;
                    continue;
                };
                let dir = rays[j].dir;
                let alpha = self.alpha_at(glass, hit, 0.0);
                let cos = dot(hit.shading_normal, dir).abs();
                let passes = glass.straight_through(cos, alpha, &mut weight[..len], &mut f[..len]);
                let contribution = &mut pending[j * len..(j + 1) * len];
                // (`scale_and_largest` passes NaNs over: its result is never NaN.)
                if !passes || scale_and_largest(contribution, &weight[..len]) <= 0.0 {
                    blocked[j] = true;
                    continue;
                }
                if let Some(t) = transmittance.as_deref_mut() {
                    scale_and_largest(&mut t[j * len..(j + 1) * len], &weight[..len]);
                }
                rays[j].origin = RenderGeometry::spawn_origin(hit, dir);
                next.push(j);
            }
            std::mem::swap(active, next);
        }
        // Still crossing after the last round: taken as blocked.
        for &j in active.iter() {
            blocked[j] = true;
        }
        traced
    }

    /// Next-event estimation for one light sample at a vertex: its contribution
    /// (throughput · f · L · cos θ · MIS weight / pdf · share) appended to
    /// `pending` and its shadow ray to `shadow_rays`; what to record, or `None`
    /// when it carries nothing (below the surface, zero weight).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn light_sample(
        &self,
        material: &dyn SpectralBsdf,
        hit: &SurfaceHit,
        frame: &Frame,
        wo: [f32; 3],
        light_sample: EnvSample,
        weights: LightWeights<'_>,
        f: &mut [f32],
        pending: &mut Vec<f32>,
        shadow_rays: &mut Vec<RayQuery>,
    ) -> Option<LightRecord> {
        if dot(light_sample.dir, hit.geometric_normal) <= 0.0 {
            return None;
        }
        let wi = frame.to_local(light_sample.dir);
        if wi[2] <= 0.0 {
            return None;
        }
        material.eval(wi, wo, f);
        // Light alone: recorded with a BSDF density of 0, whose power heuristic
        // weight is 1, so a re-shading replay weighs it as the tracer did.
        let bsdf_pdf = if weights.light_only {
            0.0
        } else {
            material.pdf(wo, wi)
        };
        let mis = power_heuristic(light_sample.pdf, bsdf_pdf);
        let scale = wi[2] * mis / light_sample.pdf * weights.share;
        if scale.is_nan() || scale <= 0.0 {
            return None;
        }
        pending.extend(
            weights
                .throughput
                .iter()
                .zip(f.iter())
                .zip(weights.radiance.iter())
                .map(|((t, fv), l)| t * fv * l * scale),
        );
        shadow_rays.push(RayQuery {
            origin: RenderGeometry::spawn_origin(hit, light_sample.dir),
            dir: light_sample.dir,
            t_max: f32::INFINITY,
        });
        Some(LightRecord {
            direction: VertexDirection {
                local: wi,
                world: light_sample.dir,
            },
            light_pdf: light_sample.pdf,
            bsdf_pdf,
        })
    }
}

/// The buffers [`PathTracer::see_through_shadows`] works in.
struct SeeThroughShadows<'a> {
    rays: &'a mut [RayQuery],
    pending: &'a mut [f32],
    blocked: &'a mut [bool],
    active: &'a mut Vec<usize>,
    next: &'a mut Vec<usize>,
    queries: &'a mut Vec<RayQuery>,
    hits: &'a mut Vec<Option<SurfaceHit>>,
    scratch: &'a mut BatchScratch,
    weight: &'a mut [f32],
    f: &'a mut [f32],
    /// Per ray, when recording: the product of what it crossed lets through.
    transmittance: Option<&'a mut [f32]>,
}

/// What weighs a light sample's contribution at a vertex.
#[derive(Debug, Clone, Copy)]
struct LightWeights<'a> {
    /// The path's throughput to the vertex.
    throughput: &'a [f32],
    /// The environment's radiance along the sample.
    radiance: &'a [f32],
    /// 1 / the number of light samples at the vertex.
    share: f32,
    /// Light sampling alone (MIS weight 1).
    light_only: bool,
}

/// How much of the floor's control variate a floor point at `position` takes,
/// α in [0, 1]: its direct light is estimated as α·ρ/π·E plus each light
/// sample's contribution times (T − α), unbiased for any α that does not depend
/// on the sample. Its variance is least for α near the share of the sky the
/// point sees: 1 in the open (no noise left where nothing is blocked), 0 under
/// the car (where α = 1 would add the light samples' own noise to a blocked
/// sky's). That share is taken from the geometry: 0 over the mesh's footprint,
/// rising linearly to 1 at one mesh height (its top above the floor) from it.
#[inline]
fn floor_control_share(bounds: Option<([f32; 3], [f32; 3])>, position: [f32; 3]) -> f32 {
    let Some((lo, hi)) = bounds else {
        return 1.0;
    };
    let dx = (lo[0] - position[0]).max(position[0] - hi[0]).max(0.0);
    let dz = (lo[2] - position[2]).max(position[2] - hi[2]).max(0.0);
    let height = hi[1].max(1e-3);
    ((dx * dx + dz * dz).sqrt() / height).min(1.0)
}

/// Multiplies `throughput` by `weight` element by element and returns the largest
/// product (NaNs passed over, 0 when there is none above 0). Eight running maxima
/// instead of one: `f32::max` in a single chain is a scalar loop of dependent
/// max-and-NaN-select steps, which profiling found to be about a third of the
/// tracer's own time on the Mitsuba scene (32 wavelengths). The maximum of a set
/// does not depend on the order it is taken in, so the result is the same number.
#[inline]
fn scale_and_largest(throughput: &mut [f32], weight: &[f32]) -> f32 {
    const LANES: usize = 8;
    let weight = &weight[..throughput.len()];
    let mut largest = [0.0f32; LANES];
    let (t_chunks, t_tail) = throughput.as_chunks_mut::<LANES>();
    let (w_chunks, w_tail) = weight.as_chunks::<LANES>();
    for (t, w) in t_chunks.iter_mut().zip(w_chunks) {
        for ((t, w), m) in t.iter_mut().zip(w).zip(largest.iter_mut()) {
            *t *= w;
            *m = m.max(*t);
        }
    }
    for (t, w) in t_tail.iter_mut().zip(w_tail) {
        *t *= w;
        largest[0] = largest[0].max(*t);
    }
    largest.into_iter().fold(0.0, f32::max)
}

/// Adds a surface's emitted radiance, seen through the path's throughput.
#[inline]
fn add_emission(out: &mut [f32], throughput: &[f32], emission: &[f32]) {
    for ((o, t), e) in out.iter_mut().zip(throughput).zip(emission) {
        *o += t * e;
    }
}

/// Veach's power heuristic (β = 2) for the strategy with density `a` against `b`.
#[inline]
pub(crate) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::WavelengthGrid;
    use crate::design::presets;
    use crate::render::camera::Camera;
    use crate::render::material::ShadingModel;
    use crate::scene::car::{CarParameters, generate};

    /// Records every call, to compare two tracings' decisions.
    #[derive(Debug, Default, Clone, PartialEq)]
    struct Log(Vec<String>);

    impl PathRecorder for Log {
        fn vertex(&mut self, vertex: &VertexRecord, light_transmittance: Option<&[f32]>) {
            self.0.push(format!("{vertex:?} {light_transmittance:?}"));
        }
        fn crossed(&mut self, factor: Option<&[f32]>) {
            self.0.push(format!("crossed {factor:?}"));
        }
        fn escape(&mut self, dir: [f32; 3], mis: f32) {
            self.0.push(format!("escape {dir:?} {mis}"));
        }
    }

    #[test]
    fn paths_traced_in_waves_equal_paths_traced_alone_bit_for_bit() {
        let grid = WavelengthGrid::visible(16).unwrap();
        let design = presets::all().into_iter().next().unwrap().design;
        let model = design.model(grid).unwrap();
        let scene = generate(&CarParameters::default());
        let shading = Shading::for_scene(&model, ShadingModel::Paint, &scene);
        let (width, height) = (24, 14);
        let camera = Camera::framing(scene.mesh.bounds().unwrap(), width, height);
        let geometry = RenderGeometry::new(scene.mesh, true).unwrap();
        let environment = Environment::studio(&grid);
        let tracer = PathTracer::new(
            &geometry,
            &environment,
            &shading,
            IntegratorSettings::default(),
        );
        let len = tracer.len();
        let mut jobs = Vec::new();
        for y in 0..height {
            for x in 0..width {
                for s in 0..2 {
                    let mut sampler = PixelSampler::new(5, y * width + x, s);
                    let [jx, jy] = sampler.next_2d();
                    jobs.push((camera.ray(x as f32 + jx, y as f32 + jy), sampler));
                }
            }
        }
        let mut buffers = PathBuffers::new(len);
        let (mut alone, mut alone_logs, mut alone_rays) = (Vec::new(), Vec::new(), 0);
        for ((origin, dir), sampler) in &jobs {
            let mut out = vec![0.0; len];
            let mut log = Log::default();
            let stats = tracer.radiance(
                *origin,
                *dir,
                &mut sampler.clone(),
                &mut buffers,
                &mut out,
                &mut log,
            );
            alone.extend(out);
            alone_logs.push(log);
            alone_rays += stats.rays;
        }
        // Waves of other sizes, and the odd remainder: no path's result or decisions
        // may depend on which others share its batches.
        for paths in [1, 3, WAVE_PATHS] {
            let (mut waves, mut logs, mut rays) = (Vec::new(), Vec::new(), 0);
            for chunk in jobs.chunks(paths) {
                let camera_rays: Vec<_> = chunk.iter().map(|(r, _)| *r).collect();
                let mut samplers: Vec<_> = chunk.iter().map(|(_, s)| s.clone()).collect();
                let mut out = vec![0.0; len * chunk.len()];
                let mut chunk_logs = vec![Log::default(); chunk.len()];
                let stats = tracer.radiance_wave(
                    &camera_rays,
                    &mut samplers,
                    &mut buffers,
                    &mut out,
                    &mut chunk_logs,
                );
                waves.extend(out);
                logs.extend(chunk_logs);
                rays += stats.rays;
            }
            let same_bits = alone
                .iter()
                .zip(&waves)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same_bits && alone.len() == waves.len(), "waves of {paths}");
            assert!(logs == alone_logs, "recorded decisions, waves of {paths}");
            assert_eq!(rays, alone_rays, "rays, waves of {paths}");
        }
        // The scene is not trivial: paths hit the car, the floor and the light.
        assert!(alone.iter().any(|&v| v > 0.0));
        assert!(alone_rays as usize > 2 * jobs.len());
    }

    #[test]
    fn roulette_keeps_dim_paths_at_the_least_survival_and_bright_ones_at_most_095() {
        assert_eq!(roulette_survival(0.01), ROULETTE_LEAST_SURVIVAL);
        assert_eq!(
            roulette_survival(ROULETTE_LEAST_SURVIVAL),
            ROULETTE_LEAST_SURVIVAL
        );
        assert_eq!(roulette_survival(0.6), 0.6);
        assert_eq!(roulette_survival(0.95), 0.95);
        assert_eq!(roulette_survival(3.0), 0.95);
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.1, 30.0), (5.0, 0.0), (1e15, 1e15)] {
            let s = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((s - 1.0).abs() < 1e-6, "{a} {b}: {s}");
        }
        assert_eq!(power_heuristic(f32::INFINITY, 3.0), 1.0);
    }
}
