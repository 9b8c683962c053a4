//! Axis-aligned boxes: [`Bounds`], the box of the accel's interface and of the
//! stored trees, and [`BoundsA`], the same box in two SIMD registers for the
//! builders' inner loops (`accel/wide/build.rs`, `accel/split.rs`).
//!
//! `BoundsA` holds its minimum and maximum as glam's `Vec3A`, so that growing a
//! box is one `minps` and one `maxps` instead of six scalar `f32::min`/`f32::max`
//! (each of which LLVM builds from a `minss`, an unordered compare and a blend, to
//! honour NaN; no NaN arises in the builders, whose boxes are finite or empty).
//!
//! **Same results as the scalar code, bit for bit.** Minima and maxima are exact,
//! the lanes' sums and products are the scalar ones, and [`BoundsA::half_area`] adds
//! its three products in the scalar order. The one possible difference is the sign
//! of a zero (`minps` returns its second operand when both are zero), which no
//! comparison, area or bin index sees and which the stored child boxes lose when
//! they are widened by one ulp (`next_down(±0)` is the same number). Checked on the
//! Lamborghini, the default car and the torus: the same tree as the scalar builders
//! (docs/benchmarks.md, "Acceleration structure").

use glam::Vec3A;

/// An axis-aligned box, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

impl Bounds {
    /// The smallest box holding all `points`; `None` for none.
    pub fn from_points(points: &[[f32; 3]]) -> Option<Bounds> {
        let first = *points.first()?;
        let mut bounds = Bounds {
            min: first,
            max: first,
        };
        for p in &points[1..] {
            bounds.min = std::array::from_fn(|k| bounds.min[k].min(p[k]));
            bounds.max = std::array::from_fn(|k| bounds.max[k].max(p[k]));
        }
        Some(bounds)
    }

    /// Whether all six coordinates are finite.
    pub fn is_finite(&self) -> bool {
        self.min.iter().chain(&self.max).all(|x| x.is_finite())
    }

    /// Whether `other` lies inside this box (boundaries included).
    pub fn contains(&self, other: &Bounds) -> bool {
        (0..3).all(|k| self.min[k] <= other.min[k] && other.max[k] <= self.max[k])
    }

    /// The empty box `[+∞, −∞]`, which [`Bounds::grow`] grows from.
    pub(super) fn empty() -> Bounds {
        Bounds {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
        }
    }

    #[inline(always)]
    pub(super) fn grow(&mut self, other: &Bounds) {
        for k in 0..3 {
            self.min[k] = self.min[k].min(other.min[k]);
            self.max[k] = self.max[k].max(other.max[k]);
        }
    }

    /// Half the surface area (the SAH only compares areas); 0 for an empty box.
    pub(super) fn half_area(&self) -> f32 {
        let d: [f32; 3] = std::array::from_fn(|k| (self.max[k] - self.min[k]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct BoundsA {
    pub min: Vec3A,
    pub max: Vec3A,
}

impl BoundsA {
    /// The empty box (`[+∞, −∞]`: growing it by a box gives that box).
    pub const EMPTY: BoundsA = BoundsA {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline(always)]
    pub fn new(b: &Bounds) -> BoundsA {
        BoundsA {
            min: Vec3A::from(b.min),
            max: Vec3A::from(b.max),
        }
    }

    #[inline(always)]
    pub fn bounds(&self) -> Bounds {
        Bounds {
            min: self.min.into(),
            max: self.max.into(),
        }
    }

    #[inline(always)]
    pub fn grow(&mut self, other: &BoundsA) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    #[inline(always)]
    pub fn grow_point(&mut self, p: Vec3A) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Half the surface area, 0 for an empty box: the scalar `half_area` of
    /// `accel/wide.rs` and `accel/split.rs`, same operations in the same order.
    #[inline(always)]
    pub fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// The minimum plus the maximum: twice the centre.
    #[inline(always)]
    pub fn centre2(&self) -> Vec3A {
        self.min + self.max
    }
}

/// A node's box and the box of its primitives' centres (doubled centres in the
/// binary builder, plain ones in the spatial pass: the factor changes no decision),
/// gathered by the builders while they partition a node's parent.
#[derive(Debug, Clone, Copy)]
pub(super) struct NodeBoxes {
    pub bounds: BoundsA,
    pub centres: BoundsA,
}

impl NodeBoxes {
    pub const EMPTY: NodeBoxes = NodeBoxes {
        bounds: BoundsA::EMPTY,
        centres: BoundsA::EMPTY,
    };

    /// Adds a primitive's box and its centre.
    #[inline(always)]
    pub fn grow(&mut self, b: &BoundsA, centre: Vec3A) {
        self.bounds.grow(b);
        self.centres.grow_point(centre);
    }
}

/// The bins of three coordinates already scaled to bin units, each clamped to
/// `0..=last` (at most 2²³): exactly `(t as usize).min(last)` lane by lane, for
/// every t (NaN gives 0 either way, as does a negative t), but without the 17
/// instructions of a saturating f32 → usize conversion a lane.
#[inline(always)]
pub(super) fn bin_indices(t: Vec3A, last: usize) -> [usize; 3] {
    // `maxps` returns its second operand, 0, for a NaN lane.
    let t = t.max(Vec3A::ZERO).min(Vec3A::splat(last as f32));
    // An integer below 2²³ plus 2²³ is exact, and the integer is the low bits of
    // the sum's mantissa.
    let shifted = t.floor() + Vec3A::splat(8_388_608.0);
    shifted
        .to_array()
        .map(|s| (s.to_bits() & 0x7f_ffff) as usize)
}

/// [`bin_indices`] for one coordinate.
#[inline(always)]
pub(super) fn bin_index(t: f32, last: usize) -> usize {
    // `f32::max` returns 0 for a NaN `t`.
    let t = t.max(0.0).min(last as f32);
    ((t.floor() + 8_388_608.0).to_bits() & 0x7f_ffff) as usize
}
