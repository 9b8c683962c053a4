//! The background of an environment: piecewise-constant spectral radiance over an
//! equirectangular grid of texels, importance-sampled texel by texel (a row by its
//! cdf, then a column by the row's alias table), with a look-up from a direction
//! to its texel that needs neither `acos` nor, nearly always, `atan2`.

use std::f64::consts::PI;

use glam::DVec3;

use super::direction::{Query, azimuth_of_column, direction_from_azimuth_y_f32};
use super::fast_math::acos_approx;
use crate::sampling::{AliasEntry, Distribution1D, ONE_BELOW};

/// Piecewise-constant spectral radiance over an equirectangular grid of texels
/// (rows equal in polar angle θ, columns in azimuth), each texel a combination of a
/// few channel spectra. Sampled by texel (weight ∝ luminance × solid angle), then
/// uniformly in (azimuth, cos θ) inside it, so the pdf is constant per texel.
#[derive(Debug, Clone)]
pub(super) struct RadianceMap {
    pub(super) width: usize,
    pub(super) height: usize,
    /// cos θ at the row boundaries, from 1 (zenith) to −1.
    pub(super) row_cos: Vec<f64>,
    pub(super) channels: Vec<Vec<f32>>,
    /// Per texel, its coefficients and density together (16 bytes, aligned: a
    /// look-up of a map far larger than the caches, an image map of 1024 × 512
    /// texels, reads one cache line).
    pub(super) texels: Vec<Texel>,
    /// Per texel, its entry of its row's alias table (8 bytes), apart from
    /// `texels`: a light sample reads the entry of the column it lands on, and
    /// the record of the texel it takes; in an array of a third of the size,
    /// the rows the samples favour stay in the caches.
    pub(super) columns: Vec<AliasEntry>,
    pub(super) rows: Distribution1D,
    /// Sum of all texel weights.
    pub(super) total_weight: f64,
}

/// One texel of a [`RadianceMap`].
#[derive(Debug, Clone, Copy, Default)]
#[repr(align(16))]
pub(super) struct Texel {
    /// One coefficient per channel (at most [`MAX_MAP_CHANNELS`]; unused ones 0).
    pub(super) coeffs: [f32; MAX_MAP_CHANNELS],
    /// The map's sampling density in the texel, per unit solid angle:
    /// P(row) × P(column | row) / the texel's solid angle.
    pub(super) pdf: f32,
}

// One record per cache-line quarter: a look-up never straddles two lines.
const _: () = assert!(std::mem::size_of::<Texel>() == 16);

/// Channels (basis spectra) a map's texels combine: 3 for an RGB image.
pub(super) const MAX_MAP_CHANNELS: usize = 3;

/// What a map sample's numbers decide before its column's alias entry is read.
#[derive(Debug, Clone, Copy)]
pub(super) struct MapDraw {
    pub(super) row: usize,
    /// Where the row's number fell within the row, in [0, 1).
    pub(super) v: f64,
    /// The column u lands on, before its alias table decides.
    pub(super) first: usize,
    /// Where u fell within that column, in [0, 1).
    pub(super) frac: f64,
}

/// The texel a map sample was drawn in, and where within its column (in [0, 1)).
#[derive(Debug, Clone, Copy)]
pub(super) struct DrawnTexel {
    pub(super) texel: usize,
    pub(super) within_column: f64,
}

/// How far inside its column (radians of azimuth) a drawn direction must be for
/// its texel to be taken without a look-up: 12× the most that rounding the
/// direction to f32 can turn it ([`RadianceMap::surely_holds`]).
const AZIMUTH_SLACK: f64 = 1e-6;

/// How far inside its row (in cos θ) a drawn direction must be for its row to be
/// taken before the direction is rounded and normalised: 8× the most that can
/// move it ([`RadianceMap::surely_holds_unrounded`]).
const ROW_SLACK: f64 = 1e-6;

impl RadianceMap {
    /// The texel (row-major index) holding `q`: row r holds cos θ in
    /// (row_cos[r + 1], row_cos[r]] (the same rows as ⌊θ/π · height⌋, found by
    /// comparing cos θ with the row boundaries instead of an `acos`), the column
    /// from the azimuth (no `atan2` for a map one texel wide).
    #[inline]
    pub(super) fn texel(&self, q: &mut Query) -> usize {
        let y = q.d.y.clamp(-1.0, 1.0);
        // A first guess from a cheap arccosine (error below 1e-4 rad, a row is
        // π/height wide), then the exact boundaries decide.
        let guess = (acos_approx(y) * (self.height as f64 / PI)) as usize;
        let mut row = guess.min(self.height - 1);
        while row > 0 && y > self.row_cos[row] {
            row -= 1;
        }
        while row + 1 < self.height && y <= self.row_cos[row + 1] {
            row += 1;
        }
        let col = if self.width == 1 {
            0
        } else {
            self.column_without_atan2(q).unwrap_or_else(|| {
                let u = 0.5 - q.azimuth() / (2.0 * PI);
                ((u * self.width as f64) as usize).min(self.width - 1)
            })
        };
        row * self.width + col
    }

    /// The column of `q` as [`Self::texel`] finds it from the exact azimuth, found
    /// from a polynomial arctangent (error below 2e-8 rad) where the azimuth is
    /// more than [`AZIMUTH_SLACK`] inside a column; `None` near a column edge (and
    /// at the poles), where only the exact `atan2` decides. An escape's look-up
    /// then costs no `atan2` but in a few cases in 10⁴.
    #[inline]
    pub(super) fn column_without_atan2(&self, q: &mut Query) -> Option<usize> {
        if q.azimuth.is_some() {
            return None;
        }
        let azimuth = q.azimuth_guess()?;
        let scale = self.width as f64 / (2.0 * PI);
        let x = (0.5 - azimuth / (2.0 * PI)) * self.width as f64;
        let col = x.floor();
        let slack = AZIMUTH_SLACK * scale;
        let inside = x - col > slack && col + 1.0 - x > slack;
        (inside && col >= 0.0 && col < self.width as f64).then_some(col as usize)
    }

    /// Adds the radiance of `texel` to `out`.
    #[inline]
    pub(super) fn add_radiance(&self, texel: usize, out: &mut [f32]) {
        let coeffs = self.texels[texel].coeffs;
        match &self.channels[..] {
            // Image maps: three bases, one pass over the spectrum.
            [a, b, c] => {
                let [ca, cb, cc] = coeffs;
                for (((o, a), b), c) in out.iter_mut().zip(a).zip(b).zip(c) {
                    *o += ca * a + cb * b + cc * c;
                }
            }
            channels => {
                for (channel, &c) in channels.iter().zip(&coeffs) {
                    if c != 0.0 {
                        for (o, s) in out.iter_mut().zip(channel) {
                            *o += c * s;
                        }
                    }
                }
            }
        }
    }

    /// Density of the map's own sampling at a direction in `texel`, per unit solid
    /// angle.
    #[inline]
    pub(super) fn pdf(&self, texel: usize) -> f64 {
        f64::from(self.texels[texel].pdf)
    }

    /// The part of a sample the numbers decide alone (the row by its cdf, the
    /// column u lands on); `None` if the map has no light.
    #[inline]
    pub(super) fn begin_sample(&self, rows: &Distribution1D, u: [f64; 2]) -> Option<MapDraw> {
        if self.total_weight <= 0.0 || rows.total() <= 0.0 {
            return None;
        }
        let (row, v) = rows.sample(u[0]);
        let x = u[1] * self.width as f64;
        let first = (x as usize).min(self.width - 1);
        let frac = (x - first as f64).clamp(0.0, ONE_BELOW);
        Some(MapDraw {
            row,
            v,
            first,
            frac,
        })
    }

    /// Whether a direction `q` (the f32 rounding of the one drawn as `drawn`) is
    /// certainly in the drawn texel, so that [`Self::texel`] would return it. The
    /// row is checked exactly, against the same boundaries `texel` compares with.
    /// The column is not looked up: rounding each coordinate of a direction to f32
    /// turns its azimuth by at most √2·2⁻²⁴ rad (≈ 8.4e-8, whatever the distance
    /// from the pole, since x and z round relative to themselves), and the f64
    /// `sin_cos`, normalisation and `atan2` add errors near 1e-15; a drawn azimuth
    /// [`AZIMUTH_SLACK`] or more inside its column stays there. Rows of texels
    /// that close to a column edge (a few in 10⁴ draws) answer `false`.
    #[inline]
    pub(super) fn surely_holds(&self, drawn: &DrawnTexel, q: &Query) -> bool {
        let row = drawn.texel / self.width;
        let y = q.d.y.clamp(-1.0, 1.0);
        let in_row = (row == 0 || y <= self.row_cos[row])
            && (row + 1 == self.height || y > self.row_cos[row + 1]);
        // At a pole (x = z = 0) the azimuth is atan2's convention, not the drawn one.
        let off_pole = q.d.x != 0.0 || q.d.z != 0.0;
        in_row && off_pole && self.surely_in_column(drawn)
    }

    /// [`Self::surely_holds`] before the direction is normalised: `d` is the
    /// drawn direction (unit, f64) and `dir` its f32 rounding. Rounding each
    /// coordinate to f32 and normalising again moves y by at most
    /// |y|·(2·2⁻²⁴ + 1e-15) < 1.3e-7 (each coordinate gains a factor 1 ± 2⁻²⁴, the
    /// length as well), so a y [`ROW_SLACK`] or more inside the drawn row stays in
    /// it. `false` where only the exact test can tell (y near a row boundary, and
    /// everywhere [`Self::surely_holds`] answers `false` for the column or pole).
    #[inline]
    pub(super) fn surely_holds_unrounded(
        &self,
        drawn: &DrawnTexel,
        d: DVec3,
        dir: [f32; 3],
    ) -> bool {
        let row = drawn.texel / self.width;
        let y = d.y;
        let in_row = (row == 0 || y <= self.row_cos[row] - ROW_SLACK)
            && (row + 1 == self.height || y > self.row_cos[row + 1] + ROW_SLACK);
        // Zero stays zero and non-zero non-zero under normalisation.
        let off_pole = dir[0] != 0.0 || dir[2] != 0.0;
        in_row && off_pole && self.surely_in_column(drawn)
    }

    /// Whether the drawn azimuth is [`AZIMUTH_SLACK`] or more inside its column
    /// (always, for a map one texel wide).
    #[inline]
    fn surely_in_column(&self, drawn: &DrawnTexel) -> bool {
        self.width == 1
            || drawn.within_column.min(1.0 - drawn.within_column) * (2.0 * PI / self.width as f64)
                > AZIMUTH_SLACK
    }

    /// The direction of a sample begun by [`Self::begin_sample`] (f64, and
    /// rounded to f32 as [`super::direction::direction_from_azimuth_y`] would give
    /// it), and the texel it was drawn in.
    #[inline]
    pub(super) fn finish_sample(&self, draw: MapDraw) -> (DVec3, [f32; 3], DrawnTexel) {
        let MapDraw {
            row,
            v,
            first,
            frac,
        } = draw;
        // The column by the row's alias table (Walker; Vose's construction): u's
        // column, kept with its texel's probability, else its alias; what is left
        // of u places the direction inside the texel.
        let (col, w) = self.columns[row * self.width + first].pick(first, frac);
        let y = self.row_cos[row] + v * (self.row_cos[row + 1] - self.row_cos[row]);
        let azimuth = azimuth_of_column(col as f64 + w, self.width);
        let drawn = DrawnTexel {
            texel: row * self.width + col,
            within_column: w,
        };
        let (d, dir) = direction_from_azimuth_y_f32(azimuth, y);
        (d, dir, drawn)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::WavelengthGrid;
    use crate::io::rgb_image::RgbImage;
    use crate::render::environment::Environment;
    use crate::render::environment::direction::direction_from_azimuth_y;
    use crate::sampling::test_support::uniform;

    #[test]
    fn texels_found_without_acos_are_those_of_the_polar_angle() {
        let map = Environment::outdoor(&WavelengthGrid::new(380.0, 50.0, 9).unwrap()).map;
        let mut state = 7;
        let mut agree = 0;
        let n = 200_000;
        for _ in 0..n {
            let y = 2.0 * uniform(&mut state) - 1.0;
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            let d = direction_from_azimuth_y(a, y);
            let theta = d.y.clamp(-1.0, 1.0).acos();
            let row = ((theta / PI * map.height as f64) as usize).min(map.height - 1);
            let u = 0.5 - d.x.atan2(d.z) / (2.0 * PI);
            let col = ((u * map.width as f64) as usize).min(map.width - 1);
            let texel = map.texel(&mut Query::new(d));
            // Only a direction within rounding of a row boundary may differ.
            if texel == row * map.width + col {
                agree += 1;
            } else {
                let found = texel / map.width;
                assert!(found.abs_diff(row) == 1, "row {found} for {row}");
                let boundary = map.row_cos[found.max(row)];
                assert!(
                    (d.y - boundary).abs() < 1e-12,
                    "y {} boundary {boundary}",
                    d.y
                );
            }
        }
        assert!(agree >= n - 2, "{agree} of {n}");
        // Poles, horizon, row boundaries themselves.
        for (r, &c) in map.row_cos.iter().enumerate() {
            let t = map.texel(&mut Query::new(direction_from_azimuth_y(0.3, c)));
            assert_eq!(t / map.width, r.min(map.height - 1), "boundary {r}");
        }
    }

    /// Columns found without `atan2` are the ones `atan2` gives, on a map as wide
    /// as the side-by-side's, for random directions and for directions at and
    /// near every kind of column edge (including ±π and the poles).
    #[test]
    fn columns_found_without_atan2_are_those_of_atan2() {
        let mut map = Environment::outdoor(&WavelengthGrid::new(380.0, 50.0, 9).unwrap()).map;
        map.width = 1024;
        let exact_column = |d: DVec3| {
            let u = 0.5 - d.x.atan2(d.z) / (2.0 * PI);
            ((u * map.width as f64) as usize).min(map.width - 1)
        };
        let mut state = 9;
        let mut directions = Vec::new();
        for _ in 0..100_000 {
            let y = 2.0 * uniform(&mut state) - 1.0;
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            directions.push(direction_from_azimuth_y(a, y));
        }
        for k in 0..=map.width {
            for offset in [0.0, 1e-12, 1e-9, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3] {
                for column in [k as f64 + offset, k as f64 - offset] {
                    let y = 2.0 * uniform(&mut state) - 1.0;
                    directions.push(direction_from_azimuth_y(
                        azimuth_of_column(column, map.width),
                        y,
                    ));
                }
            }
        }
        directions
            .extend([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-0.0, 1.0, -0.0]].map(DVec3::from_array));
        directions
            .extend([[0.0, 0.0, -1.0], [-0.0, 0.0, -1.0], [1.0, 0.0, 0.0]].map(DVec3::from_array));
        let mut fast = 0;
        for d in directions.iter().map(|&d| d / d.length()) {
            let texel = map.texel(&mut Query::new(d));
            assert_eq!(texel % map.width, exact_column(d), "direction {d:?}");
            fast += usize::from(map.column_without_atan2(&mut Query::new(d)).is_some());
        }
        // The shortcut answers nearly every random direction.
        assert!(fast > 100_000 * 99 / 100, "{fast}");
    }

    /// The map's sampling, with its alias tables, against its own density: texel
    /// counts agree with P(texel) (per-texel Z, and Pearson's χ² over all texels,
    /// which sees an error spread over many texels that no single texel's Z
    /// shows), and the estimate of ∫ g dω with g(d) = 1 + d_x + d_y² (4π + 4π/3)
    /// agrees within its standard error. The negative control: the same samples
    /// against the density ×1.1 on the map's left half (renormalised) must fail.
    #[test]
    fn map_samples_follow_the_density_the_map_reports() {
        let (width, height) = (16, 8);
        let mut state = 11;
        let pixels: Vec<[f32; 3]> = (0..width * height)
            .map(|i| {
                let v = if i % 5 == 0 {
                    0.0
                } else {
                    uniform(&mut state).powi(3) as f32
                };
                [v, 0.5 * v, uniform(&mut state) as f32]
            })
            .collect();
        let image = RgbImage::new(width, height, pixels).unwrap();
        let grid = WavelengthGrid::new(380.0, 50.0, 9).unwrap();
        let env = Environment::from_rgb_image(&image, "test", &grid).unwrap();
        let n = 400_000;
        let mut texels = Vec::with_capacity(n);
        let mut out = vec![0.0; grid.len()];
        for _ in 0..n {
            let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
            let sample = env.sample(u, &mut out).expect("a sample");
            let d = DVec3::from_array(sample.dir.map(f64::from));
            texels.push((env.map.texel(&mut Query::new(d)), d, sample.pdf));
        }
        let solid_angle = |texel: usize| {
            let row = texel / width;
            2.0 * PI / width as f64 * (env.map.row_cos[row] - env.map.row_cos[row + 1])
        };
        // The statistics for a density given as a factor on the map's own.
        let failures = |factor: &dyn Fn(usize) -> f64| -> Vec<String> {
            let mut failed = Vec::new();
            let mut counts = vec![0u64; width * height];
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for &(texel, d, pdf) in &texels {
                counts[texel] += 1;
                let g = 1.0 + d.x + d.y * d.y;
                let x = g / (f64::from(pdf) * factor(texel));
                sum += x;
                sum2 += x * x;
            }
            let nf = n as f64;
            let (mut chi2, mut dof) = (0.0_f64, 0.0_f64);
            for (texel, &count) in counts.iter().enumerate() {
                let p = env.map.pdf(texel) * factor(texel) * solid_angle(texel);
                let expected = p * nf;
                let z = (count as f64 - expected) / expected.max(1e-9).sqrt();
                if z.abs() >= 5.0 {
                    failed.push(format!("texel {texel}: {count} for {expected:.1}"));
                }
                if expected >= 5.0 {
                    chi2 += z * z;
                    dof += 1.0;
                }
            }
            // χ² with dof − 1 degrees of freedom: mean dof − 1, sd √(2(dof − 1)).
            let bound = dof - 1.0 + 5.0 * (2.0 * (dof - 1.0)).sqrt();
            if chi2 >= bound {
                failed.push(format!("χ² {chi2:.0} over {dof} texels (bound {bound:.0})"));
            }
            let mean = sum / nf;
            let error = ((sum2 / nf - mean * mean) / nf).sqrt();
            let want = 4.0 * PI + 4.0 * PI / 3.0;
            if (mean - want).abs() >= 5.0 * error {
                failed.push(format!("∫ g: {mean} ± {error} vs {want}"));
            }
            failed
        };
        let own = failures(&|_| 1.0);
        assert!(own.is_empty(), "{own:#?}");
        let left = |texel: usize| texel % width < width / 2;
        let share: f64 = (0..width * height)
            .filter(|&t| left(t))
            .map(|t| env.map.pdf(t) * solid_angle(t))
            .sum();
        let renormalised = 1.0 / (1.0 + 0.1 * share);
        let wrong = failures(&|t| if left(t) { 1.1 } else { 1.0 } * renormalised);
        println!("density ×1.1 on the left half ({share:.3} of it): {wrong:#?}");
        assert!(
            wrong.iter().any(|f| f.starts_with("χ²")),
            "a 10 % density error passed: {wrong:#?}"
        );
    }
}
