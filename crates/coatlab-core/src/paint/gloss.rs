//! Gloss g in gloss units → lobe exponent m(g), through a simulated ISO 2813 /
//! ASTM D523 glossmeter (spec 4.3).
//!
//! | parameter | unit | range | default |
//! | --- | --- | --- | --- |
//! | geometry (angle of incidence = angle of the receptor) | degrees | 20, 60, 85 | 20 |
//! | gloss g | GU | (reading of m = 0, mirror reading of the coat] | — |
//! | exponent m | — | [0, 1e9], or the ideal mirror | — |
//!
//! The instrument: a collimated source whose rays fill the source aperture
//! (0.75° in the plane of incidence × 2.5° across it), a receptor that collects
//! the flux through a rectangular field stop (20°: 1.80° × 3.6°, 60°: 4.4° × 11.7°,
//! 85°: 4.0° × 6.0°). Apertures are rectangles in the focal plane of the
//! instrument's lenses, so a direction's coordinates are the tangents of its angles
//! to the optical axis. 100 GU is the reading of polished black glass (n = 1.567),
//! a pure mirror. Both apertures are sampled with Gauss–Legendre rules (4 × 4 over
//! the source; panels graded around the lobe peak over the receptor).
//!
//! The fraction F of the lobe's flux that reaches the receptor does not depend on
//! n, only the Fresnel factor does, so F is tabulated once per geometry and source
//! point over x = ln(1 + m) and m(g) is a root-find on the interpolated reading —
//! cheap enough for a slider (each node of the table is computed once per process,
//! when first needed).

use std::sync::OnceLock;

use glam::DVec3;

use super::fresnel::reflectance;
use super::lobe::{one_minus_cos_to_mirror, phong_normalisation};
use super::parameters::{Bounds, GLOSS, REFRACTIVE_INDEX};
use crate::parameter::RangeError;
use crate::quadrature::GaussLegendre;

/// Refractive index of the black glass standard that defines 100 GU (at 587.6 nm).
pub const BLACK_GLASS_INDEX: f64 = 1.567;
/// Wavelength at which a design's refractive index sets its gloss, nm.
pub const GLOSS_WAVELENGTH_NM: f64 = 587.6;
/// Exponents above this are indistinguishable from a mirror in any geometry
/// (lobe width ~3e-5 rad, far inside every aperture).
pub const MAX_EXPONENT: f64 = 1e9;

/// Source aperture: in the plane of incidence × perpendicular to it, degrees.
const SOURCE_APERTURE_DEG: (f64, f64) = (0.75, 2.5);

/// A glossmeter geometry of ISO 2813.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(try_from = "u32", into = "u32")]
pub enum GlossGeometry {
    /// 20°: high-gloss finishes (the automotive convention).
    #[default]
    Deg20,
    /// 60°: the general-purpose geometry.
    Deg60,
    /// 85°: low-gloss (sheen) finishes.
    Deg85,
}

impl GlossGeometry {
    /// All three, in order.
    pub const ALL: [GlossGeometry; 3] = [
        GlossGeometry::Deg20,
        GlossGeometry::Deg60,
        GlossGeometry::Deg85,
    ];

    /// Angle of incidence (and of the receptor), degrees.
    pub fn angle_deg(self) -> f64 {
        match self {
            GlossGeometry::Deg20 => 20.0,
            GlossGeometry::Deg60 => 60.0,
            GlossGeometry::Deg85 => 85.0,
        }
    }

    /// Receptor aperture: in the plane of incidence × perpendicular to it, degrees.
    pub fn receptor_aperture_deg(self) -> (f64, f64) {
        match self {
            GlossGeometry::Deg20 => (1.80, 3.6),
            GlossGeometry::Deg60 => (4.4, 11.7),
            GlossGeometry::Deg85 => (4.0, 6.0),
        }
    }

    fn index(self) -> usize {
        match self {
            GlossGeometry::Deg20 => 0,
            GlossGeometry::Deg60 => 1,
            GlossGeometry::Deg85 => 2,
        }
    }
}

impl From<GlossGeometry> for u32 {
    fn from(g: GlossGeometry) -> u32 {
        g.angle_deg() as u32
    }
}

impl TryFrom<u32> for GlossGeometry {
    type Error = GlossError;
    fn try_from(degrees: u32) -> Result<Self, GlossError> {
        match degrees {
            20 => Ok(GlossGeometry::Deg20),
            60 => Ok(GlossGeometry::Deg60),
            85 => Ok(GlossGeometry::Deg85),
            other => Err(GlossError::UnknownGeometry(other)),
        }
    }
}

impl std::fmt::Display for GlossGeometry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}°", self.angle_deg())
    }
}

/// The lobe exponent of a design: finite, or the ideal mirror (gloss at its maximum).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GlossExponent {
    /// Phong exponent m ≥ 0.
    Finite(f64),
    /// The ideal mirror: f_spec = R δ(ωo − ωr)/μi.
    Mirror,
}

/// Errors converting between gloss units and exponents.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GlossError {
    /// Not 20, 60 or 85.
    #[error("glossmeter geometry {0}° is not one of ISO 2813's 20°, 60°, 85°")]
    UnknownGeometry(u32),
    /// A gloss or refractive index outside its parameter's range (NaN, infinite,
    /// a negative gloss, an index below 1); the message names the parameter.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// NaN, infinite or negative exponent.
    #[error("lobe exponent {0} is not a finite, non-negative number")]
    InvalidExponent(f64),
    /// Below what the broadest lobe (m = 0) reads.
    #[error(
        "gloss {gu} GU at {geometry} is below the lowest reading a gloss lobe can give ({min:.4} GU, m = 0)"
    )]
    BelowRange {
        /// The requested reading.
        gu: f64,
        /// The reading at m = 0.
        min: f64,
        /// Where.
        geometry: GlossGeometry,
    },
}

/// One ray direction from the source aperture, with its quadrature weight.
#[derive(Debug, Clone, Copy)]
struct SourceRay {
    /// Toward the source (the BRDF's ωi), local frame.
    wi: [f64; 3],
    weight: f64,
}

/// A simulated glossmeter for one geometry.
#[derive(Debug, Clone)]
pub struct Glossmeter {
    geometry: GlossGeometry,
    sources: Vec<SourceRay>,
    /// Receptor axis (the nominal mirror direction) and its focal-plane axes.
    axis: DVec3,
    across_in_plane: DVec3,
    across_perpendicular: DVec3,
    /// Half-widths of the receptor field stop in tangent units.
    half_x: f64,
    half_y: f64,
}

impl Glossmeter {
    /// Sets up the instrument's geometry.
    pub fn new(geometry: GlossGeometry) -> Self {
        let theta = geometry.angle_deg().to_radians();
        let (sin_t, cos_t) = theta.sin_cos();
        // Source toward −x, receptor toward +x, plane of incidence = xz.
        let source_axis = DVec3::new(-sin_t, 0.0, cos_t);
        let source_in_plane = DVec3::new(cos_t, 0.0, sin_t);
        let perpendicular = DVec3::Y;
        let half_sx = (0.5 * SOURCE_APERTURE_DEG.0).to_radians().tan();
        let half_sy = (0.5 * SOURCE_APERTURE_DEG.1).to_radians().tan();
        let rule = GaussLegendre::new(4);
        let mut sources = Vec::with_capacity(16);
        let mut total_weight = 0.0;
        rule.for_each_node(-half_sx, half_sx, |x, wx| {
            rule.for_each_node(-half_sy, half_sy, |y, wy| {
                let wi = (source_axis + (source_in_plane * x + perpendicular * y)).normalize();
                sources.push(SourceRay {
                    wi: wi.to_array(),
                    weight: wx * wy,
                });
                total_weight += wx * wy;
            });
        });
        for s in &mut sources {
            s.weight /= total_weight;
        }
        let (rx, ry) = geometry.receptor_aperture_deg();
        Self {
            geometry,
            sources,
            axis: DVec3::new(sin_t, 0.0, cos_t),
            across_in_plane: DVec3::new(cos_t, 0.0, -sin_t),
            across_perpendicular: perpendicular,
            half_x: (0.5 * rx).to_radians().tan(),
            half_y: (0.5 * ry).to_radians().tan(),
        }
    }

    /// The geometry.
    pub fn geometry(&self) -> GlossGeometry {
        self.geometry
    }

    /// The source rays (toward the source) and their weights, which sum to 1.
    pub fn source_rays(&self) -> impl Iterator<Item = ([f64; 3], f64)> + '_ {
        self.sources.iter().map(|s| (s.wi, s.weight))
    }

    /// Source-averaged reflectance of a mirror of index n: what the instrument
    /// compares everything with (the black glass at n = 1.567).
    fn mirror_flux(&self, n: f64) -> f64 {
        self.sources
            .iter()
            .map(|s| s.weight * reflectance(s.wi[2], n))
            .sum()
    }

    /// Reading of an ideal mirror coat of index n, GU: all of its reflection falls
    /// inside the receptor (the source aperture is smaller than every receptor).
    pub fn mirror_reading(&self, n: f64) -> f64 {
        100.0 * self.mirror_flux(n) / self.mirror_flux(BLACK_GLASS_INDEX)
    }

    /// ∫ over the receptor of `g(ωo)·μo dωo` for source ray `source`, with panels
    /// graded around `peak` (a direction where g is sharp) on the angular scale
    /// `width`; for a smooth g pass a large width.
    pub fn receptor_integral(
        &self,
        peak: [f64; 3],
        width: f64,
        mut g: impl FnMut([f64; 3]) -> f64,
    ) -> f64 {
        let peak = DVec3::from(peak);
        let along = peak.dot(self.axis);
        let (px, py) = if along > 0.0 {
            (
                peak.dot(self.across_in_plane) / along,
                peak.dot(self.across_perpendicular) / along,
            )
        } else {
            (0.0, 0.0)
        };
        let xs = graded_breakpoints(px, width, self.half_x);
        let ys = graded_breakpoints(py, width, self.half_y);
        let rule = GaussLegendre::order6();
        let mut total = 0.0;
        for xw in xs.windows(2) {
            for yw in ys.windows(2) {
                rule.for_each_node(xw[0], xw[1], |x, wx| {
                    rule.for_each_node(yw[0], yw[1], |y, wy| {
                        let v =
                            self.axis + (self.across_in_plane * x + self.across_perpendicular * y);
                        let len2 = v.length_squared();
                        let wo = v * (1.0 / len2.sqrt());
                        // Solid angle of a focal-plane element: dx dy / (1 + x² + y²)^{3/2}.
                        let jacobian = 1.0 / (len2 * len2.sqrt());
                        total += wx * wy * jacobian * wo.z.max(0.0) * g(wo.to_array());
                    });
                });
            }
        }
        total
    }

    /// Fraction of the normalised lobe's flux (exponent m) from source ray `i` that
    /// reaches the receptor: ∫_rec D μo dωo / N(μi, m). Evaluated directly.
    fn lobe_fraction(&self, i: usize, m: f64) -> f64 {
        let wi = self.sources[i].wi;
        let peak = [-wi[0], -wi[1], wi[2]];
        let width = 1.0 / (m + 1.0).sqrt();
        let captured = self.receptor_integral(peak, width, |wo| {
            let d = one_minus_cos_to_mirror(wi, wo);
            if d >= 1.0 {
                0.0
            } else if m == 0.0 {
                1.0
            } else {
                (m * (-d).ln_1p()).exp()
            }
        });
        captured / phong_normalisation(wi[2], m)
    }

    /// Reading of the specular part of a coat of index n with the normalised lobe of
    /// exponent m, GU, by direct integration (slow; [`reading_from_exponent`] uses
    /// the tabulated fractions).
    pub fn specular_reading_direct(&self, n: f64, m: f64) -> f64 {
        let flux: f64 = (0..self.sources.len())
            .map(|i| {
                self.sources[i].weight
                    * reflectance(self.sources[i].wi[2], n)
                    * self.lobe_fraction(i, m)
            })
            .sum();
        100.0 * flux / self.mirror_flux(BLACK_GLASS_INDEX)
    }

    /// Reading, GU, of a reflector whose flux into the receptor for each source ray
    /// is given by `captured(wi)` (fraction of the incident flux).
    pub fn reading_of(&self, mut captured: impl FnMut([f64; 3]) -> f64) -> f64 {
        let flux: f64 = self.sources.iter().map(|s| s.weight * captured(s.wi)).sum();
        100.0 * flux / self.mirror_flux(BLACK_GLASS_INDEX)
    }
}

/// Breakpoints of the quadrature panels on [−half, half]: graded around the peak
/// at `centre` on the scale `width`, and dropped where the lobe has decayed below
/// e^{−40} (beyond 9 widths).
fn graded_breakpoints(centre: f64, width: f64, half: f64) -> Vec<f64> {
    const STEPS: [f64; 6] = [0.5, 1.0, 2.0, 3.0, 5.0, 9.0];
    let mut points = vec![-half, half];
    let c = centre.clamp(-half, half);
    points.push(c);
    for s in STEPS {
        for p in [c - s * width, c + s * width] {
            if p > -half && p < half {
                points.push(p);
            }
        }
    }
    points.sort_by(f64::total_cmp);
    points.dedup();
    // Cut away panels entirely beyond 9 widths of the peak: the lobe is < e^{-40} there.
    let reach = 9.0 * width;
    let lo = (c - reach).max(-half);
    let hi = (c + reach).min(half);
    points.retain(|&p| p >= lo && p <= hi);
    if points.first() != Some(&lo) {
        points.insert(0, lo);
    }
    if points.last() != Some(&hi) {
        points.push(hi);
    }
    points
}

/// The tabulated lobe fractions F_s(x) for one geometry, x = ln(1 + m).
struct FractionTable {
    meter: Glossmeter,
    /// fractions[node][source], each node computed when first read: a node costs
    /// thousands of receptor quadratures, and a reading needs only the four nodes
    /// around its x. Converting a mirror-like gloss reads six of the 129 (the
    /// ends); computing them all up front was a visible part of every render's
    /// start-up.
    fractions: Vec<OnceLock<Vec<f64>>>,
}

const TABLE_NODES: usize = 129;

fn x_max() -> f64 {
    MAX_EXPONENT.ln_1p()
}

fn fraction_table(geometry: GlossGeometry) -> &'static FractionTable {
    static TABLES: [OnceLock<FractionTable>; 3] =
        [OnceLock::new(), OnceLock::new(), OnceLock::new()];
    TABLES[geometry.index()].get_or_init(|| FractionTable {
        meter: Glossmeter::new(geometry),
        fractions: (0..TABLE_NODES).map(|_| OnceLock::new()).collect(),
    })
}

impl FractionTable {
    /// The lobe fractions of every source ray at node j (m = e^{x_j} − 1).
    fn node(&self, j: usize) -> &[f64] {
        self.fractions[j].get_or_init(|| {
            let x = x_max() * j as f64 / (TABLE_NODES - 1) as f64;
            let m = x.exp_m1();
            (0..self.meter.sources.len())
                .map(|i| self.meter.lobe_fraction(i, m))
                .collect()
        })
    }

    /// Reading at x = ln(1+m) for index n: Catmull–Rom in x of the per-node readings.
    fn reading(&self, n: f64, x: f64) -> f64 {
        let weights: Vec<f64> = self
            .meter
            .sources
            .iter()
            .map(|s| s.weight * reflectance(s.wi[2], n))
            .collect();
        let glass = self.meter.mirror_flux(BLACK_GLASS_INDEX);
        let node_reading = |j: usize| -> f64 {
            let f = self.node(j);
            100.0 * weights.iter().zip(f).map(|(w, f)| w * f).sum::<f64>() / glass
        };
        let last = TABLE_NODES - 1;
        let pos = (x / x_max()).clamp(0.0, 1.0) * last as f64;
        let j = (pos as usize).min(last - 1);
        let t = pos - j as f64;
        let at = |k: isize| -> f64 {
            if k < 0 {
                2.0 * node_reading(0) - node_reading(1)
            } else if k as usize > last {
                2.0 * node_reading(last) - node_reading(last - 1)
            } else {
                node_reading(k as usize)
            }
        };
        let j = j as isize;
        let (p0, p1, p2, p3) = (at(j - 1), at(j), at(j + 1), at(j + 2));
        p1 + 0.5
            * t
            * (p2 - p0
                + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)))
    }
}

fn check_index(n: f64) -> Result<(), GlossError> {
    Ok(REFRACTIVE_INDEX.check(n)?)
}

/// The reading, GU, of the specular part of a coat of index n (at 587.6 nm) with
/// the normalised lobe of exponent m, in the given geometry.
pub fn reading_from_exponent(
    geometry: GlossGeometry,
    n: f64,
    m: GlossExponent,
) -> Result<f64, GlossError> {
    check_index(n)?;
    let table = fraction_table(geometry);
    match m {
        GlossExponent::Mirror => Ok(table.meter.mirror_reading(n)),
        GlossExponent::Finite(m) => {
            if !(m.is_finite() && m >= 0.0) {
                return Err(GlossError::InvalidExponent(m));
            }
            if m >= MAX_EXPONENT {
                return Ok(table.meter.mirror_reading(n));
            }
            Ok(table.reading(n, m.ln_1p()))
        }
    }
}

/// The readings a gloss lobe can give on a coat of index n (at 587.6 nm) in
/// `geometry`: from the broadest lobe's (m = 0) to the ideal mirror's. Below it no
/// exponent exists; at and above its top the paint is the mirror. The GUI's gloss
/// control spans it.
pub fn reading_range(geometry: GlossGeometry, n: f64) -> Result<Bounds, GlossError> {
    let broadest = reading_from_exponent(geometry, n, GlossExponent::Finite(0.0))?;
    let mirror = reading_from_exponent(geometry, n, GlossExponent::Mirror)?;
    Ok(Bounds::new(broadest, mirror))
}

/// m(g): the exponent whose simulated reading is `gu` (spec 4.3). Readings at or
/// above what m = 1e9 reads (within 1e-6 GU of the mirror's own reading) give the
/// ideal mirror; readings below the broadest lobe's are an error.
pub fn exponent_from_reading(
    geometry: GlossGeometry,
    n: f64,
    gu: f64,
) -> Result<GlossExponent, GlossError> {
    check_index(n)?;
    GLOSS.check(gu)?;
    let table = fraction_table(geometry);
    let (mut lo, mut hi) = (0.0, x_max());
    let min = table.reading(n, lo);
    if gu < min {
        return Err(GlossError::BelowRange { gu, min, geometry });
    }
    if gu >= table.reading(n, hi) {
        return Ok(GlossExponent::Mirror);
    }
    // The reading increases with m; bisection in x = ln(1+m) to full precision.
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if table.reading(n, mid) < gu {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(GlossExponent::Finite((0.5 * (lo + hi)).exp_m1()))
}

/// The solid angle of the receptor, to check the receptor quadrature in tests.
#[cfg(test)]
fn receptor_solid_angle(meter: &Glossmeter) -> f64 {
    meter.receptor_integral(meter.axis.to_array(), 10.0, |wo| 1.0 / wo[2].max(1e-300))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn black_glass_reads_100_and_a_mirror_coat_of_1_5_reads_82_89_99() {
        let want = [82.0, 89.1, 99.0];
        for (geometry, want) in GlossGeometry::ALL.into_iter().zip(want) {
            let meter = Glossmeter::new(geometry);
            assert!((meter.mirror_reading(BLACK_GLASS_INDEX) - 100.0).abs() < 1e-12);
            let got = meter.mirror_reading(1.5);
            assert!((got - want).abs() < 0.1, "{geometry}: {got} vs {want}");
        }
    }

    #[test]
    fn receptor_solid_angle_matches_the_rectangle() {
        let meter = Glossmeter::new(GlossGeometry::Deg60);
        let got = receptor_solid_angle(&meter);
        // For small apertures the solid angle is ≈ the product of the angular widths.
        let (a, b) = GlossGeometry::Deg60.receptor_aperture_deg();
        let want = a.to_radians() * b.to_radians();
        assert!((got / want - 1.0).abs() < 5e-3, "{got} vs {want}");
    }

    #[test]
    fn exponent_round_trips_through_the_reading() {
        for geometry in GlossGeometry::ALL {
            for gu in [1.0, 10.0, 40.0, 70.0, 81.0] {
                let n = 1.5;
                let Ok(GlossExponent::Finite(m)) = exponent_from_reading(geometry, n, gu) else {
                    panic!("{geometry} {gu} GU did not give a finite exponent");
                };
                let back = reading_from_exponent(geometry, n, GlossExponent::Finite(m))
                    .unwrap_or(f64::NAN);
                assert!(
                    (back - gu).abs() < 1e-9,
                    "{geometry}: {gu} → m {m} → {back}"
                );
            }
        }
    }

    #[test]
    fn tabulated_reading_matches_direct_integration() {
        for geometry in GlossGeometry::ALL {
            let meter = Glossmeter::new(geometry);
            for m in [0.0, 3.0, 100.0, 3000.0, 1e5, 1e7] {
                let direct = meter.specular_reading_direct(1.5, m);
                let table = reading_from_exponent(geometry, 1.5, GlossExponent::Finite(m))
                    .unwrap_or(f64::NAN);
                assert!(
                    (direct - table).abs() < 1e-3 * direct.max(1.0),
                    "{geometry} m {m}: {direct} vs {table}"
                );
            }
        }
    }

    #[test]
    fn reading_increases_with_the_exponent_and_limits_are_reported() {
        let geometry = GlossGeometry::Deg20;
        let mut previous = -1.0;
        for m in [0.0, 1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6] {
            let r =
                reading_from_exponent(geometry, 1.5, GlossExponent::Finite(m)).unwrap_or(f64::NAN);
            assert!(r > previous, "m {m}: {r} ≤ {previous}");
            previous = r;
        }
        assert_eq!(
            exponent_from_reading(geometry, 1.5, 95.0),
            Ok(GlossExponent::Mirror)
        );
        assert!(matches!(
            exponent_from_reading(geometry, 1.5, 1e-9),
            Err(GlossError::BelowRange { .. })
        ));
        assert!(matches!(
            exponent_from_reading(geometry, 0.9, 50.0),
            Err(GlossError::OutOfRange(e)) if e.parameter.name == REFRACTIVE_INDEX.name
        ));
        assert!(matches!(
            exponent_from_reading(geometry, 1.5, f64::NAN),
            Err(GlossError::OutOfRange(e)) if e.parameter.name == GLOSS.name
        ));
    }
}
