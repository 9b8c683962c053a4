//! How to build the acceleration structure: the tree layout, the build quality,
//! which triangles are cut into several references, and the build's threads
//! ([`BuildOptions`]).

/// Tree layout. The library ships `Simd8`; the others come with the feature
/// `bvh-experiments`, for comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BvhLayout {
    /// Our own 8-wide BVH (`accel/wide.rs`): binned-SAH binary build collapsed to 8
    /// children per 224-byte node, f32 child boxes tested 8 at a time, leaves of up to
    /// 8 triangles stored lane by lane (one pack) for the watertight test; ordered
    /// closest-hit and separate any-hit traversal. Through [`Accel`](super::Accel), triangles far
    /// larger than the average enter the tree as several references
    /// (`accel/split.rs`). The `quality` sets the SAH bins per axis.
    Simd8,
    /// obvhs's compressed wide BVH: 8 children per 80-byte node, child boxes quantised
    /// to 8 bits, traversed 4 boxes at a time with SIMD; up to 3 triangles per leaf.
    #[cfg(feature = "bvh-experiments")]
    Wide8,
    /// obvhs's binary BVH (one box per node, up to 8 triangles per leaf after the
    /// collapse pass). Simpler, and editable in place, but slower to traverse.
    #[cfg(feature = "bvh-experiments")]
    Binary,
}

/// Build quality. Slower builds give trees that traverse faster. For the obvhs
/// layouts these are obvhs's presets; for `Simd8` the number of SAH bins per axis
/// (8, 16, 32, 64).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildQuality {
    /// obvhs: PLOC with the smallest search radius, no reinsertion, one primitive per
    /// leaf. `Simd8`: 8 bins.
    Fastest,
    /// obvhs: PLOC search radius "low", 2 % reinsertion. `Simd8`: 16 bins. The
    /// interactive default.
    Fast,
    /// obvhs: PLOC search radius "medium", 5 % reinsertion ("about Embree's build
    /// time"). `Simd8`: 32 bins.
    Medium,
    /// obvhs: PLOC search radius "high", 20 % reinsertion, 128-bit Morton codes
    /// (spatial pre-splits of the preset are not used: the builder sees boxes, not
    /// triangles). `Simd8`: 64 bins.
    Slow,
}

impl BuildQuality {
    pub(super) fn sah_bins(self) -> usize {
        match self {
            BuildQuality::Fastest => 8,
            BuildQuality::Fast => 16,
            BuildQuality::Medium => 32,
            BuildQuality::Slow => 64,
        }
    }
}

/// How to build a [`Bvh`](super::Bvh).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuildOptions {
    pub layout: BvhLayout,
    pub quality: BuildQuality,
    /// Which triangles are cut into several references (`Simd8` through
    /// [`Accel`](super::Accel) only).
    pub reference_splits: ReferenceSplits,
    /// Threads for the `Simd8` build (scoped threads of its own, each subtree of
    /// 4096 or more primitives split between two); 0 for
    /// `std::thread::available_parallelism`. The obvhs layouts build on rayon's
    /// current thread pool regardless.
    pub threads: usize,
}

impl BuildOptions {
    /// `threads`, with 0 resolved.
    pub(super) fn build_threads(&self) -> usize {
        match self.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
    }
}

impl Default for BuildOptions {
    /// `Simd8` with `Fast` and spatial splits: see docs/benchmarks.md,
    /// "Acceleration structure".
    fn default() -> Self {
        BuildOptions {
            layout: BvhLayout::Simd8,
            quality: BuildQuality::Fast,
            reference_splits: ReferenceSplits::Spatial,
            threads: 0,
        }
    }
}

/// Which triangles [`Accel`](super::Accel) cuts into several references for `Simd8`
/// (`accel/split.rs`; measured in docs/benchmarks.md, "Acceleration structure").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceSplits {
    /// Triangles far larger than the average, halved at the middle of the widest
    /// axis until small enough (almost free to build).
    LargeTriangles,
    /// As `LargeTriangles`, then spatial splits where the SAH prefers them to the
    /// best object split, down to nodes of 64 references, at most 30 % more
    /// references (SBVH-style, on `threads` threads, the same result for any
    /// count); its partition is kept as the top of the tree. The default: on the
    /// Lamborghini ×1.13–1.30 the rays per second, at about 1.7 times the
    /// build's time, within the 150 ms target (docs/benchmarks.md); no loss on the
    /// default car or the torus. Real car models are Lamborghini-like
    /// (long, thin, overlapping triangles), and a preview traces one tree for
    /// seconds to minutes.
    Spatial,
}
