//! Looking the environment up: the radiance and density of a direction (an
//! escaping path), and light samples (a direction drawn toward the light, with its
//! radiance and density), each also in two steps for a batch of paths, whose
//! memory reads then overlap. Emitters are tested one by one; the map's texel is
//! found once per direction.

use super::direction::{Query, normalised};
use super::map::{DrawnTexel, MapDraw};
use super::{EnvSample, Environment};
use crate::sampling::{Distribution1D, ONE_BELOW};

impl Environment {
    /// Spectral radiance arriving from `dir` (a ray travelling along `dir` sees it),
    /// written to `out` (one value per grid sample).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn radiance(&self, dir: [f32; 3], out: &mut [f32]) {
        self.radiance_and_pdf(dir, out);
    }

    /// Density (per unit solid angle) with which [`Self::sample`] returns `dir`.
    pub fn pdf(&self, dir: [f32; 3]) -> f32 {
        self.pdf_for(dir, false)
    }

    /// Density (per unit solid angle) with which a light sample for a surface
    /// facing straight up (`facing_up`, the floor: [`Self::sample_for`]) or for
    /// any other returns `dir`.
    pub fn pdf_for(&self, dir: [f32; 3], facing_up: bool) -> f32 {
        let Some(d) = normalised(dir) else {
            return 0.0;
        };
        let mut q = Query::new(d);
        let texel = self.map.texel(&mut q);
        self.evaluate_texel(texel, &mut q, None, facing_up) as f32
    }

    /// [`Self::radiance`] and [`Self::pdf`] of one direction together: the texel and
    /// the emitters containing `dir` are found once (a path that escapes needs both).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn radiance_and_pdf(&self, dir: [f32; 3], out: &mut [f32]) -> f32 {
        assert_eq!(out.len(), self.channels.len(), "radiance buffer length");
        out.fill(0.0);
        let Some(d) = normalised(dir) else { return 0.0 };
        self.evaluate(&mut Query::new(d), Some(out)) as f32
    }

    /// A direction toward the light for the two uniform numbers `u` in [0, 1)²:
    /// emitters chosen in proportion to their power, then a point uniform in solid
    /// angle on them, or a texel of the background map by luminance × solid angle.
    /// `out` receives the radiance from the direction. `None` if the sample
    /// carries no density (never for the setups here).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn sample(&self, u: [f32; 2], out: &mut [f32]) -> Option<EnvSample> {
        self.finish_sample(&self.begin_sample(u), out)
    }

    /// [`Self::sample`] for a surface facing straight up (`facing_up`: the floor,
    /// normal +Y) or any other. Facing up, emitters and the map's rows are chosen
    /// in proportion to their power times their mean cosine to the vertical
    /// (the texel within a row and the point within an emitter as before), so the
    /// light sample's weight L·cos θ/pdf is nearly constant over the unshadowed
    /// sky: the floor's direct light without the noise of sampling by power
    /// alone, which spends samples on bright light near the horizon that reaches
    /// the floor at a grazing cosine.
    pub fn sample_for(&self, u: [f32; 2], facing_up: bool, out: &mut [f32]) -> Option<EnvSample> {
        self.finish_sample(&self.begin_sample_for(u, facing_up), out)
    }

    /// [`Self::sample`] in two steps, for a batch of paths: this one draws what the
    /// numbers decide without reading the map's tables (the emitter, the map's row
    /// and the column u lands on) and starts reading that column's alias-table
    /// entry into the cache;
    /// [`Self::finish_sample`], called after the batch's other look-ups have been
    /// begun, completes the draw. The result is bit for bit `sample(u, out)`.
    pub(crate) fn begin_sample(&self, u: [f32; 2]) -> SampleLookUp {
        self.begin_sample_for(u, false)
    }

    /// [`Self::begin_sample`] of [`Self::sample_for`].
    pub(crate) fn begin_sample_for(&self, u: [f32; 2], facing_up: bool) -> SampleLookUp {
        let (components, rows, facing_up) = match (&self.facing_up, facing_up) {
            (Some(up), true) => (&up.components, &up.rows, true),
            _ => (&self.components, &self.map.rows, false),
        };
        let (component, u0) = components.sample(f64::from(u[0]));
        let u1 = f64::from(u[1]).clamp(0.0, ONE_BELOW);
        let draw = if component < self.patches.len() {
            None
        } else {
            let draw = self.map.begin_sample(rows, [u0, u1]);
            if let Some(draw) = &draw {
                prefetch(&self.map.columns[draw.row * self.map.width + draw.first]);
            }
            draw
        };
        SampleLookUp {
            component,
            u: [u0, u1],
            draw,
            facing_up,
        }
    }

    /// The second step of [`Self::begin_sample`].
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub(crate) fn finish_sample(&self, begun: &SampleLookUp, out: &mut [f32]) -> Option<EnvSample> {
        self.finish_located_sample(&self.locate_sample(begun)?, out)
    }

    /// [`Self::finish_sample`]'s first half, for a batch: the sample's direction
    /// and the texel it lies in, whose record it starts reading into the cache.
    /// `None` where `finish_sample` returns `None` without writing `out` (a map
    /// without light).
    pub(crate) fn locate_sample(&self, begun: &SampleLookUp) -> Option<LocatedSample> {
        let (d, dir, drawn) = if begun.component < self.patches.len() {
            let d = self.patches[begun.component].shape.sample(begun.u);
            (d, d.as_vec3().to_array(), None)
        } else {
            let (d, dir, drawn) = self.map.finish_sample(begun.draw?);
            (d, dir, Some(drawn))
        };
        // Radiance and density of the direction as returned (rounded to f32), the
        // same function of `dir` that `radiance`, `pdf` and a re-shading replay of
        // the recorded `dir` evaluate: the texel is that of the rounded direction.
        // The drawn texel is that texel unless the rounding could have moved the
        // direction across one of its boundaries; only then is it searched for
        // (an `atan2` and a row search saved on all but a few samples in 10⁴).
        // Without emitters the normalised direction is needed for nothing else,
        // so where the drawn direction is safely inside its texel's row it is not
        // normalised at all (a square root and a division saved).
        if self.patches.is_empty()
            && let Some(drawn) = drawn
            && self.map.surely_holds_unrounded(&drawn, d, dir)
        {
            prefetch(&self.map.texels[drawn.texel]);
            let look_up = DirectionLookUp {
                query: LookUpQuery::NoEmitters,
                texel: drawn.texel,
                facing_up: begun.facing_up,
            };
            return Some(LocatedSample { dir, look_up });
        }
        let look_up = self.begin_look_up(dir, drawn, begun.facing_up);
        Some(LocatedSample { dir, look_up })
    }

    /// [`Self::finish_sample`]'s second half: the radiance (to `out`) and density
    /// of a located sample.
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub(crate) fn finish_located_sample(
        &self,
        located: &LocatedSample,
        out: &mut [f32],
    ) -> Option<EnvSample> {
        let pdf = self.finish_radiance_and_pdf(&located.look_up, out);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(EnvSample {
            dir: located.dir,
            pdf,
        })
    }

    /// [`Self::radiance_and_pdf`] in two steps, for a batch of escapes: this one
    /// finds the direction's texel and starts reading its record into the cache;
    /// [`Self::finish_radiance_and_pdf`] returns what `radiance_and_pdf` does, bit
    /// for bit. Begun for a whole batch first, the batch's cache misses overlap.
    ///
    /// With `facing_up` the density is that of [`Self::sample_for`] for a surface
    /// facing up (an escape from the floor), else that of [`Self::sample`].
    pub(crate) fn begin_radiance_and_pdf_for(
        &self,
        dir: [f32; 3],
        facing_up: bool,
    ) -> DirectionLookUp {
        self.begin_look_up(dir, None, facing_up)
    }

    /// The look-up of `dir` begun: its texel found (the `drawn` one where `dir`
    /// surely lies in it) and its record prefetched.
    fn begin_look_up(
        &self,
        dir: [f32; 3],
        drawn: Option<DrawnTexel>,
        facing_up: bool,
    ) -> DirectionLookUp {
        let Some(d) = normalised(dir) else {
            return DirectionLookUp {
                query: LookUpQuery::Degenerate,
                texel: 0,
                facing_up,
            };
        };
        let mut query = Query::new(d);
        let texel = match drawn {
            Some(drawn) if self.map.surely_holds(&drawn, &query) => drawn.texel,
            _ => self.map.texel(&mut query),
        };
        prefetch(&self.map.texels[texel]);
        DirectionLookUp {
            query: LookUpQuery::Direction(query),
            texel,
            facing_up,
        }
    }

    /// The second step of [`Self::begin_radiance_and_pdf_for`].
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub(crate) fn finish_radiance_and_pdf(&self, begun: &DirectionLookUp, out: &mut [f32]) -> f32 {
        assert_eq!(out.len(), self.channels.len(), "radiance buffer length");
        out.fill(0.0);
        match begun.query {
            LookUpQuery::Degenerate => 0.0,
            LookUpQuery::NoEmitters => {
                self.evaluate_map_texel(begun.texel, Some(out), begun.facing_up) as f32
            }
            LookUpQuery::Direction(mut query) => {
                self.evaluate_texel(begun.texel, &mut query, Some(out), begun.facing_up) as f32
            }
        }
    }

    /// The density of `q` (f64), and its radiance added to `out` when given: one
    /// texel look-up and one containment test per emitter.
    fn evaluate(&self, q: &mut Query, out: Option<&mut [f32]>) -> f64 {
        let texel = self.map.texel(q);
        self.evaluate_texel(texel, q, out, false)
    }

    /// The map's share of [`Self::evaluate_texel`] (all of it for an environment
    /// without emitters), the density that of [`Self::sample_for`] with
    /// `facing_up`.
    fn evaluate_map_texel(&self, texel: usize, out: Option<&mut [f32]>, facing_up: bool) -> f64 {
        if let Some(out) = out {
            self.map.add_radiance(texel, out);
        }
        let (components, row_factor) = self.components_for(texel, facing_up);
        components.probability(self.patches.len()) * self.map.pdf(texel) * row_factor
    }

    /// The component distribution of [`Self::sample_for`] with `facing_up`, and the
    /// factor its row distribution gives `texel`'s row against the plain one.
    fn components_for(&self, texel: usize, facing_up: bool) -> (&Distribution1D, f64) {
        match (&self.facing_up, facing_up) {
            (Some(up), true) => (
                &up.components,
                f64::from(up.row_factor[texel / self.map.width]),
            ),
            _ => (&self.components, 1.0),
        }
    }

    /// [`Self::evaluate`] with the map's texel of `q` already found, the density
    /// that of [`Self::sample_for`] with `facing_up`.
    fn evaluate_texel(
        &self,
        texel: usize,
        q: &mut Query,
        mut out: Option<&mut [f32]>,
        facing_up: bool,
    ) -> f64 {
        let mut pdf = self.evaluate_map_texel(texel, out.as_deref_mut(), facing_up);
        let (components, _) = self.components_for(texel, facing_up);
        for (k, patch) in self.patches.iter().enumerate() {
            if patch.shape.contains(q) {
                pdf += components.probability(k) / patch.solid_angle;
                if let Some(out) = out.as_deref_mut() {
                    for (o, r) in out.iter_mut().zip(&patch.radiance) {
                        *o += r;
                    }
                }
            }
        }
        pdf
    }
}

/// A light sample begun by [`Environment::begin_sample`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct SampleLookUp {
    pub(super) component: usize,
    /// The numbers left for the component's own draw.
    pub(super) u: [f64; 2],
    /// The map's part of the draw when the component is the map (`None` also for
    /// a map without light, which draws nothing).
    pub(super) draw: Option<MapDraw>,
    /// Drawn for a surface facing up ([`Environment::sample_for`]).
    pub(super) facing_up: bool,
}

/// A light sample located by [`Environment::locate_sample`]: its direction, and
/// the radiance look-up of that direction begun.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LocatedSample {
    dir: [f32; 3],
    look_up: DirectionLookUp,
}

/// An escape's look-up begun by [`Environment::begin_radiance_and_pdf_for`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct DirectionLookUp {
    query: LookUpQuery,
    texel: usize,
    /// The density is that of a light sample for a surface facing up.
    facing_up: bool,
}

/// What a begun look-up still needs of its direction besides the texel.
#[derive(Debug, Clone, Copy)]
enum LookUpQuery {
    /// A direction that cannot be normalised: radiance and density 0.
    Degenerate,
    /// Nothing: the environment has no emitters to test the direction against.
    NoEmitters,
    /// The normalised direction, for the emitters' containment tests.
    Direction(Query),
}

/// Starts reading the cache line of `item` (a hint: no effect on any result).
#[inline(always)]
fn prefetch<T>(item: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch never faults and reads nothing the program sees; the
        // address is that of a live reference.
        #[allow(unused_unsafe)]
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>((item as *const T).cast::<i8>())
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = item;
}
