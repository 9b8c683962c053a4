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
//! After [`IntegratorSettings::roulette_start`] bounces, Russian roulette ends paths
//! with probability 1 − min(0.95, max_λ throughput) and divides the survivors by
//! the survival probability, which keeps the estimate unbiased. Paths also end at
//! [`IntegratorSettings::max_bounces`] (a bias toward darker images, measured to be
//! far below the noise for the car: see `docs/benchmarks.md`).
//!
//! Surfaces reflect only (no transmission): the car's glass is a dark, glossy
//! reflector, which is how it reads in a paint preview. Every surface is two-sided.

use crate::paint::model::SpectralBsdf;
use crate::render::environment::Environment;
use crate::render::geometry::{Frame, RenderGeometry, Surface, dot};
use crate::render::material::{Shading, SimpleMaterial};
use crate::render::sampler::PixelSampler;

/// How far and how long paths run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IntegratorSettings {
    /// Most surface interactions on a path (0: only what the camera sees directly
    /// of the environment).
    pub max_bounces: u32,
    /// Number of bounces after which Russian roulette may end a path.
    pub roulette_start: u32,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            max_bounces: 8,
            roulette_start: 3,
        }
    }
}

/// Per-thread scratch spectra, so tracing a path allocates nothing.
#[derive(Debug, Clone)]
pub struct PathBuffers {
    throughput: Vec<f32>,
    bsdf: Vec<f32>,
    light: Vec<f32>,
    weight: Vec<f32>,
}

impl PathBuffers {
    /// Buffers for `len` wavelengths.
    pub fn new(len: usize) -> Self {
        Self {
            throughput: vec![0.0; len],
            bsdf: vec![0.0; len],
            light: vec![0.0; len],
            weight: vec![0.0; len],
        }
    }
}

/// The tracer for one scene, lighting and shading.
#[derive(Debug, Clone)]
pub struct PathTracer<'a> {
    geometry: &'a RenderGeometry,
    environment: &'a Environment,
    shading: &'a Shading,
    floor: Option<SimpleMaterial>,
    settings: IntegratorSettings,
}

/// What one path did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PathStats {
    /// Rays traced: closest-hit and shadow rays.
    pub rays: u32,
}

/// The light sample at a vertex that reached the light (unoccluded, non-zero
/// weight): enough to re-evaluate its contribution with another BSDF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightRecord {
    /// Direction toward the light, local frame.
    pub wi: [f32; 3],
    /// The same direction in world space (to look up the environment again).
    pub dir: [f32; 3],
    /// Density of the light sample.
    pub light_pdf: f32,
    /// Density with which the BSDF in use would have sampled it (for MIS).
    pub bsdf_pdf: f32,
}

/// The BSDF sample that continued the path from a vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NextRecord {
    /// Sampled direction, local frame.
    pub wi: [f32; 3],
    /// The same direction in world space.
    pub dir: [f32; 3],
    /// Its density (for a delta: the probability of choosing the delta).
    pub pdf: f32,
    /// Whether it came from a delta (mirror) component.
    pub delta: bool,
    /// Russian roulette's survival probability after it (1 when no roulette).
    pub survive: f32,
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
/// ([`crate::render::reshade`]): every surface vertex, then, when the path ended
/// in the environment, its escape (along the last vertex's continuation, or the
/// camera ray).
pub trait PathRecorder {
    /// A surface vertex was shaded.
    fn vertex(&mut self, vertex: &VertexRecord);
    /// The path escaped to the environment along `dir`.
    fn escape(&mut self, dir: [f32; 3]);
}

/// Records nothing (ordinary rendering; compiles to nothing).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoRecord;

impl PathRecorder for NoRecord {
    #[inline]
    fn vertex(&mut self, _: &VertexRecord) {}
    #[inline]
    fn escape(&mut self, _: [f32; 3]) {}
}

impl<'a> PathTracer<'a> {
    /// A tracer. The floor plane takes part when both the geometry and the lighting
    /// setup have one.
    ///
    /// # Panics
    /// If the environment and the shading are on grids of different lengths (a
    /// programming error: the renderer builds both on one grid).
    pub fn new(
        geometry: &'a RenderGeometry,
        environment: &'a Environment,
        shading: &'a Shading,
        settings: IntegratorSettings,
    ) -> Self {
        assert_eq!(
            environment.grid().len(),
            shading.len(),
            "environment and shading on different wavelength grids"
        );
        let floor = environment
            .floor()
            .filter(|_| geometry.has_floor())
            .map(|f| SimpleMaterial::lambertian(&f.reflectance));
        Self {
            geometry,
            environment,
            shading,
            floor,
            settings,
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

    /// Spectral radiance arriving at `origin` from direction `-dir` (the camera ray
    /// `origin + t·dir`, `dir` a unit vector), one estimate, written to `out`.
    /// Random numbers come from `sampler` in a fixed order, so the estimate is a
    /// function of the sampler's key alone.
    pub fn radiance(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        sampler: &mut PixelSampler,
        buffers: &mut PathBuffers,
        out: &mut [f32],
    ) -> PathStats {
        self.radiance_recorded(origin, dir, sampler, buffers, out, &mut NoRecord)
    }

    /// [`Self::radiance`], telling `recorder` every decision the path made.
    pub fn radiance_recorded(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        sampler: &mut PixelSampler,
        buffers: &mut PathBuffers,
        out: &mut [f32],
        recorder: &mut impl PathRecorder,
    ) -> PathStats {
        let len = self.len();
        let out = &mut out[..len];
        let PathBuffers {
            throughput,
            bsdf: f,
            light,
            weight,
        } = buffers;
        out.fill(0.0);
        throughput.fill(1.0);
        let use_floor = self.floor.is_some();
        let mut stats = PathStats::default();
        let (mut ray_origin, mut ray_dir) = (origin, dir);
        // The density with which the previous bounce chose `ray_dir`; a delta (or the
        // camera) gives the environment its full weight.
        let mut previous_pdf = 0.0f32;
        let mut previous_delta = true;
        for bounce in 0..=self.settings.max_bounces {
            stats.rays += 1;
            let Some(hit) =
                self.geometry
                    .intersect_with_floor(ray_origin, ray_dir, f32::INFINITY, use_floor)
            else {
                self.environment.radiance(ray_dir, light);
                let mis = if previous_delta {
                    1.0
                } else {
                    power_heuristic(previous_pdf, self.environment.pdf(ray_dir))
                };
                for ((o, t), l) in out.iter_mut().zip(throughput.iter()).zip(light.iter()) {
                    *o += t * l * mis;
                }
                recorder.escape(ray_dir);
                break;
            };
            if bounce == self.settings.max_bounces {
                break;
            }
            let material: &dyn SpectralBsdf = match (hit.surface, &self.floor) {
                (Surface::Floor, Some(floor)) => floor,
                (Surface::Mesh { material }, _) => self.shading.material(material),
                // The geometry reports the floor only when asked to.
                (Surface::Floor, None) => break,
            };
            let to_viewer = [-ray_dir[0], -ray_dir[1], -ray_dir[2]];
            // Interpolated normals can face away from the viewer near silhouettes;
            // shading with them would put ωo below the surface.
            let normal = if dot(hit.shading_normal, to_viewer) > 0.0 {
                hit.shading_normal
            } else {
                hit.geometric_normal
            };
            let frame = Frame::from_normal(normal);
            let wo = frame.to_local(to_viewer);
            let mut record = VertexRecord {
                surface: hit.surface,
                wo,
                light: None,
                next: None,
            };

            // Next-event estimation.
            let u_light = sampler.next_2d();
            if let Some(light_sample) = self.environment.sample(u_light, light)
                && dot(light_sample.dir, hit.geometric_normal) > 0.0
            {
                let wi = frame.to_local(light_sample.dir);
                if wi[2] > 0.0 {
                    material.eval(wi, wo, f);
                    let bsdf_pdf = material.pdf(wo, wi);
                    let mis = power_heuristic(light_sample.pdf, bsdf_pdf);
                    let scale = wi[2] * mis / light_sample.pdf;
                    if scale > 0.0 {
                        stats.rays += 1;
                        let shadow_origin = RenderGeometry::spawn_origin(&hit, light_sample.dir);
                        if !self.geometry.occluded_with_floor(
                            shadow_origin,
                            light_sample.dir,
                            f32::INFINITY,
                            use_floor,
                        ) {
                            for (((o, t), fv), l) in out
                                .iter_mut()
                                .zip(throughput.iter())
                                .zip(f.iter())
                                .zip(light.iter())
                            {
                                *o += t * fv * l * scale;
                            }
                            record.light = Some(LightRecord {
                                wi,
                                dir: light_sample.dir,
                                light_pdf: light_sample.pdf,
                                bsdf_pdf,
                            });
                        }
                    }
                }
            }

            // The BSDF sample continues the path.
            let u_bsdf = [sampler.next_1d(), sampler.next_1d(), sampler.next_1d()];
            let u_roulette = sampler.next_1d();
            let Some(sample) = material.sample(wo, u_bsdf, weight) else {
                recorder.vertex(&record);
                break;
            };
            let next_dir = frame.to_world(sample.wi);
            // A direction above the shading normal but below the geometric surface
            // would pass through it.
            if dot(next_dir, hit.geometric_normal) <= 0.0 {
                recorder.vertex(&record);
                break;
            }
            let mut largest = 0.0f32;
            for (t, w) in throughput.iter_mut().zip(weight.iter()) {
                *t *= w;
                largest = largest.max(*t);
            }
            if !(largest > 0.0 && largest.is_finite()) {
                recorder.vertex(&record);
                break;
            }
            let mut survive = 1.0;
            if bounce + 1 >= self.settings.roulette_start {
                survive = largest.min(0.95);
                if u_roulette >= survive {
                    recorder.vertex(&record);
                    break;
                }
                throughput.iter_mut().for_each(|t| *t /= survive);
            }
            record.next = Some(NextRecord {
                wi: sample.wi,
                dir: next_dir,
                pdf: sample.pdf,
                delta: sample.delta,
                survive,
            });
            recorder.vertex(&record);
            previous_pdf = sample.pdf;
            previous_delta = sample.delta;
            ray_origin = RenderGeometry::spawn_origin(&hit, next_dir);
            ray_dir = next_dir;
        }
        stats
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

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.1, 30.0), (5.0, 0.0), (1e15, 1e15)] {
            let s = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((s - 1.0).abs() < 1e-6, "{a} {b}: {s}");
        }
        assert_eq!(power_heuristic(f32::INFINITY, 3.0), 1.0);
    }
}
