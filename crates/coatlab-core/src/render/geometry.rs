//! The scene as the tracer sees it: the triangle mesh in its BVH, the analytic
//! floor plane y = 0 of the lighting setup, and the local shading frame at a hit.

use glam::Vec3;

use crate::accel::{Accel, AccelError, Hit, RayQuery, offset_ray_origin};
use crate::scene::TriangleMesh;

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// Distance along the (unit) ray direction, m.
    pub t: f32,
    /// The hit point, world space.
    pub position: [f32; 3],
    /// Unit geometric normal, on the side the ray came from.
    pub geometric_normal: [f32; 3],
    /// Unit shading normal (interpolated), on the same side as the geometric one.
    pub shading_normal: [f32; 3],
    /// What was hit.
    pub surface: Surface,
    /// The mesh triangle hit (0 for the floor).
    pub triangle: u32,
    /// Barycentric coordinates (u, v) of the triangle's vertices 1 and 2 at the
    /// hit (0 for the floor), for texture look-ups.
    pub barycentric: [f32; 2],
}

/// The kind of surface hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// A mesh triangle with this material index (into the scene's materials).
    Mesh {
        /// Material index.
        material: u32,
    },
    /// The floor plane y = 0.
    Floor,
}

/// Reusable buffers of [`RenderGeometry::intersect_batch`] and
/// [`RenderGeometry::occluded_batch`].
#[derive(Debug, Clone, Default)]
pub struct BatchScratch {
    queries: Vec<RayQuery>,
    hits: Vec<Option<Hit>>,
    lanes: Vec<u32>,
}

/// The tracer's geometry.
#[derive(Debug, Clone)]
pub struct RenderGeometry {
    mesh: TriangleMesh,
    accel: Accel,
    floor: bool,
    /// The mesh's bounds (min, max), `None` when it is empty.
    bounds: Option<([f32; 3], [f32; 3])>,
}

impl RenderGeometry {
    /// Builds the acceleration structure; `floor` adds the plane y = 0 (seen from
    /// above only: it is the ground the car stands on).
    pub fn new(mesh: TriangleMesh, floor: bool) -> Result<Self, AccelError> {
        let accel = Accel::build(&mesh)?;
        let bounds = mesh.bounds();
        Ok(Self {
            mesh,
            accel,
            floor,
            bounds,
        })
    }

    /// The mesh's axis-aligned bounds (min, max); `None` when it is empty.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        self.bounds
    }

    /// The mesh.
    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    /// Whether the floor plane is part of the scene.
    pub fn has_floor(&self) -> bool {
        self.floor
    }

    /// The closest hit along a ray with unit direction, up to `t_max`.
    pub fn intersect(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<SurfaceHit> {
        self.intersect_with_floor(origin, dir, t_max, self.floor)
    }

    /// [`Self::intersect`] with the floor plane included or not, whatever the
    /// geometry was built with: one BVH serves lighting setups with and without a
    /// floor.
    pub fn intersect_with_floor(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        t_max: f32,
        floor: bool,
    ) -> Option<SurfaceHit> {
        let mut best = if floor {
            Self::floor_hit(origin, dir, t_max)
        } else {
            None
        };
        let limit = best.map_or(t_max, |f| f.t);
        if let Some(hit) = self.accel.closest_hit(origin, dir, limit) {
            best = Some(self.mesh_hit(origin, dir, hit));
        }
        best
    }

    /// The floor's hit on a ray when nearer than `t_max`: the hit and its distance.
    fn floor_hit(origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<SurfaceHit> {
        floor_distance(origin, dir, t_max).map(|t| SurfaceHit {
            t,
            position: [origin[0] + t * dir[0], 0.0, origin[2] + t * dir[2]],
            geometric_normal: [0.0, 1.0, 0.0],
            shading_normal: [0.0, 1.0, 0.0],
            surface: Surface::Floor,
            triangle: 0,
            barycentric: [0.0; 2],
        })
    }

    /// [`Self::intersect_with_floor`] for a batch of rays (each `t_max` as given),
    /// the mesh traced by [`Accel::closest_hits`], several rays in flight: the same
    /// hits bit for bit. `scratch` holds the batch's queries and mesh hits between
    /// calls, so a batch allocates nothing once it has grown.
    ///
    /// # Panics
    /// If `hits` is not as long as `rays`.
    pub fn intersect_batch(
        &self,
        rays: &[RayQuery],
        floor: bool,
        hits: &mut [Option<SurfaceHit>],
        scratch: &mut BatchScratch,
    ) {
        assert_eq!(rays.len(), hits.len(), "intersect_batch: rays and hits");
        scratch.queries.clear();
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            *hit = None;
            let mut query = *ray;
            if floor && let Some(f) = Self::floor_hit(ray.origin, ray.dir, ray.t_max) {
                query.t_max = f.t;
                *hit = Some(f);
            }
            scratch.queries.push(query);
        }
        scratch.hits.clear();
        scratch.hits.resize(rays.len(), None);
        self.accel.closest_hits(&scratch.queries, &mut scratch.hits);
        for ((ray, mesh), hit) in rays.iter().zip(&scratch.hits).zip(hits.iter_mut()) {
            if let Some(mesh) = mesh {
                *hit = Some(self.mesh_hit(ray.origin, ray.dir, *mesh));
            }
        }
    }

    /// [`Self::occluded`] (with the floor included or not) for a batch of shadow rays, the mesh traced by
    /// [`Accel::closest_hits`] (which agrees with [`Accel::occluded`]): rays the
    /// floor blocks are not traced.
    ///
    /// # Panics
    /// If `occluded` is not as long as `rays`.
    pub fn occluded_batch(
        &self,
        rays: &[RayQuery],
        floor: bool,
        occluded: &mut [bool],
        scratch: &mut BatchScratch,
    ) {
        assert_eq!(
            rays.len(),
            occluded.len(),
            "occluded_batch: rays and results"
        );
        scratch.queries.clear();
        scratch.lanes.clear();
        for (i, (ray, blocked)) in rays.iter().zip(occluded.iter_mut()).enumerate() {
            *blocked = floor && floor_distance(ray.origin, ray.dir, ray.t_max).is_some();
            if !*blocked {
                scratch.queries.push(*ray);
                scratch.lanes.push(i as u32);
            }
        }
        scratch.hits.clear();
        scratch.hits.resize(scratch.queries.len(), None);
        self.accel.closest_hits(&scratch.queries, &mut scratch.hits);
        for (&lane, hit) in scratch.lanes.iter().zip(&scratch.hits) {
            occluded[lane as usize] = hit.is_some();
        }
    }

    /// The shading data of a mesh hit on the ray `origin + t·dir`.
    fn mesh_hit(&self, origin: [f32; 3], dir: [f32; 3], hit: Hit) -> SurfaceHit {
        let tri = self.mesh.triangles[hit.triangle as usize];
        let [a, b, c] = tri.map(|i| Vec3::from(self.mesh.positions[i as usize]));
        let mut ng = unit((b - a).cross(c - a));
        let [u, v] = hit.barycentric;
        let w = 1.0 - u - v;
        let [na, nb, nc] = tri.map(|i| Vec3::from(self.mesh.normals[i as usize]));
        let mut ns = unit(w * na + u * nb + v * nc);
        // Face the ray: the film and the tracer treat surfaces as two-sided.
        if ng.dot(dir.into()) > 0.0 {
            ng = -ng;
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        if !ns.is_finite() {
            ns = ng;
        }
        SurfaceHit {
            t: hit.t,
            position: (Vec3::from(origin) + hit.t * Vec3::from(dir)).into(),
            geometric_normal: ng.into(),
            shading_normal: ns.into(),
            surface: Surface::Mesh {
                material: self.mesh.triangle_material[hit.triangle as usize],
            },
            triangle: hit.triangle,
            barycentric: hit.barycentric,
        }
    }

    /// Whether anything blocks the segment from `origin` along unit `dir` up to `t_max`.
    pub fn occluded(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
        (self.floor && floor_distance(origin, dir, t_max).is_some())
            || self.accel.occluded(origin, dir, t_max)
    }

    /// A ray origin just off the surface of `hit`, on the side `dir` leaves toward.
    pub fn spawn_origin(hit: &SurfaceHit, dir: [f32; 3]) -> [f32; 3] {
        let n = Vec3::from(hit.geometric_normal);
        let n = if Vec3::from(dir).dot(n) >= 0.0 { n } else { -n };
        offset_ray_origin(hit.position, n.into())
    }
}

/// Distance along the ray to the floor plane y = 0, when the ray goes down onto it
/// from above nearer than `t_max`.
fn floor_distance(origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<f32> {
    let t = -origin[1] / dir[1];
    (dir[1] < 0.0 && origin[1] > 0.0 && t > 0.0 && t < t_max).then_some(t)
}

/// An orthonormal frame with z along a unit normal: world ↔ local shading space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Local x axis in world space.
    pub tangent: [f32; 3],
    /// Local y axis in world space.
    pub bitangent: [f32; 3],
    /// Local z axis (the normal) in world space.
    pub normal: [f32; 3],
}

impl Frame {
    /// The frame about a unit normal (Duff et al. 2017).
    pub fn from_normal(n: [f32; 3]) -> Self {
        let (tangent, bitangent) = crate::paint::lobe::orthonormal_basis(n);
        Self {
            tangent,
            bitangent,
            normal: n,
        }
    }

    /// World direction → local.
    #[inline]
    pub fn to_local(&self, w: [f32; 3]) -> [f32; 3] {
        let w = Vec3::from(w);
        [
            w.dot(self.tangent.into()),
            w.dot(self.bitangent.into()),
            w.dot(self.normal.into()),
        ]
    }

    /// Local direction → world.
    #[inline]
    pub fn to_world(&self, l: [f32; 3]) -> [f32; 3] {
        (l[0] * Vec3::from(self.tangent)
            + l[1] * Vec3::from(self.bitangent)
            + l[2] * Vec3::from(self.normal))
        .into()
    }
}

/// The dot product of two directions held as arrays (the tracer's form).
#[inline]
pub(crate) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    Vec3::from(a).dot(Vec3::from(b))
}

/// `v` divided by its length. Not glam's `normalize`, which multiplies by the
/// reciprocal length: that rounds differently and would change every render's
/// bits.
#[inline]
fn unit(v: Vec3) -> Vec3 {
    v / v.length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::car::{CarParameters, generate};

    #[test]
    fn frames_round_trip_and_are_orthonormal() {
        for n in [
            [0.0, 1.0, 0.0],
            [0.0, 0.0, -1.0],
            Vec3::new(0.3, -0.5, 0.8).normalize().to_array(),
        ] {
            let f = Frame::from_normal(n);
            let w = Vec3::new(0.2, 0.7, -0.4).normalize().to_array();
            let back = f.to_world(f.to_local(w));
            for k in 0..3 {
                assert!((back[k] - w[k]).abs() < 1e-6);
            }
            assert!(
                dot(f.tangent, f.normal).abs() < 1e-6 && dot(f.bitangent, f.normal).abs() < 1e-6
            );
            assert!((f.to_local(n)[2] - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn rays_hit_the_car_and_the_floor_and_shadows_fall_under_the_car() {
        let scene = generate(&CarParameters::default());
        let geometry = RenderGeometry::new(scene.mesh, true).expect("the default car builds");
        // Straight down onto the roof: the car, not the floor.
        let hit = geometry
            .intersect([0.0, 5.0, 0.0], [0.0, -1.0, 0.0], f32::INFINITY)
            .expect("a hit");
        assert!(matches!(hit.surface, Surface::Mesh { .. }));
        assert!(
            hit.position[1] > 1.0 && hit.shading_normal[1] > 0.5,
            "{hit:?}"
        );
        // Beside the car: the floor.
        let hit = geometry
            .intersect([5.0, 5.0, 0.0], [0.0, -1.0, 0.0], f32::INFINITY)
            .expect("a hit");
        assert_eq!(hit.surface, Surface::Floor);
        assert!(hit.position[1].abs() < 1e-6);
        // Under the car the sky is blocked: the contact shadow.
        let under = [0.0, 0.0, 0.0];
        let origin = RenderGeometry::spawn_origin(
            &SurfaceHit {
                position: under,
                ..hit
            },
            [0.0, 1.0, 0.0],
        );
        assert!(geometry.occluded(origin, [0.0, 1.0, 0.0], f32::INFINITY));
        let beside = RenderGeometry::spawn_origin(&hit, [0.0, 1.0, 0.0]);
        assert!(!geometry.occluded(beside, [0.0, 1.0, 0.0], f32::INFINITY));
        // Rays from below never hit the floor.
        assert!(
            geometry
                .intersect([5.0, -1.0, 0.0], [0.0, 1.0, 0.0], f32::INFINITY)
                .is_none()
        );
    }
}
