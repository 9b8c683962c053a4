//! Assembling an environment: a set-up fills in a map of channel coefficients and
//! a list of emitters in arbitrary units; [`Builder::finish`] normalises them to
//! horizontal illuminance π and builds the sampling tables.

use std::f64::consts::PI;

use super::emitters::{Patch, Shape, lat_long_cosine_integral};
use super::facing_up::{FacingUpSampling, horizontal_irradiance};
use super::map::{MAX_MAP_CHANNELS, RadianceMap, Texel};
use super::{Environment, EnvironmentKind, Floor, dot_f32, luminance_weights};
use crate::colour::spectrum::Channels;
use crate::sampling::{AliasEntry, Distribution1D, alias_table};

/// Sampling weight of the map below the horizon relative to its power: the floor
/// hides it whenever the floor is present, so samples there are mostly wasted; it
/// stays positive so an environment without floor is still sampled everywhere.
const GROUND_SAMPLING_WEIGHT: f64 = 0.1;
/// Each texel's sampling weight is (luminance + this × its largest spectral value)
/// × solid angle: the second term keeps texels whose light lies outside ȳ (deep red
/// or violet) sampled.
const MAX_VALUE_SAMPLING_WEIGHT: f64 = 0.05;

/// Assembles an environment in arbitrary units, then normalises it.
pub(super) struct Builder {
    radiance_channels: Channels,
    channels: Vec<Vec<f32>>,
    /// Luminance of each channel spectrum.
    pub(super) channel_luminance: Vec<f64>,
    luminance_weights: Vec<f32>,
    width: usize,
    height: usize,
    /// cos θ at the row boundaries, from 1 (zenith) to −1, the horizon exactly 0
    /// when the height is even.
    pub(super) row_cos: Vec<f64>,
    /// Per texel (row-major), one coefficient per channel.
    pub(super) coeffs: Vec<f32>,
    /// (shape, channel, coefficient).
    pub(super) patches: Vec<(Shape, usize, f64)>,
}

impl Builder {
    /// A black map of `width × height` texels combining `channels` (1 to
    /// [`MAX_MAP_CHANNELS`] spectra on `radiance_channels`), and no emitters.
    pub(super) fn new(
        radiance_channels: &Channels,
        channels: Vec<Vec<f32>>,
        width: usize,
        height: usize,
    ) -> Self {
        assert!(
            (1..=MAX_MAP_CHANNELS).contains(&channels.len()),
            "a map combines 1 to {MAX_MAP_CHANNELS} channel spectra"
        );
        let luminance_weights = luminance_weights(radiance_channels);
        let channel_luminance = channels
            .iter()
            .map(|c| f64::from(dot_f32(&luminance_weights, c)))
            .collect();
        // The horizon exactly 0 (cos(π/2) rounds to 6e-17), so no row sits above it
        // by rounding.
        let row_cos = (0..=height)
            .map(|r| {
                if 2 * r == height {
                    0.0
                } else {
                    (PI * r as f64 / height as f64).cos()
                }
            })
            .collect();
        let coeffs = vec![0.0; width * height * channels.len()];
        Self {
            radiance_channels: *radiance_channels,
            channels,
            channel_luminance,
            luminance_weights,
            width,
            height,
            row_cos,
            coeffs,
            patches: Vec::new(),
        }
    }

    /// Horizontal irradiance from the upper hemisphere, per channel (coefficient
    /// units).
    pub(super) fn channel_irradiance(&self) -> Vec<f64> {
        let n = self.channels.len();
        let mut e = vec![0.0; n];
        for row in 0..self.height {
            let cos_integral = lat_long_cosine_integral(
                2.0 * PI / self.width as f64,
                [self.row_cos[row + 1], self.row_cos[row]],
            );
            if cos_integral <= 0.0 {
                continue;
            }
            for col in 0..self.width {
                let texel = row * self.width + col;
                for (c, e) in e.iter_mut().enumerate() {
                    *e += f64::from(self.coeffs[texel * n + c]) * cos_integral;
                }
            }
        }
        for (shape, channel, coefficient) in &self.patches {
            e[*channel] += coefficient * shape.cosine_integral();
        }
        e
    }

    /// Normalises to horizontal illuminance π, fills the rows wholly below the
    /// horizon with the floor's radiance when `fill_ground`, and builds the
    /// sampling tables. `None` if the upper hemisphere is black.
    pub(super) fn finish(
        mut self,
        kind: EnvironmentKind,
        floor_reflectance: f32,
        fill_ground: bool,
    ) -> Option<Environment> {
        let scale = self.normalise(floor_reflectance, fill_ground)?;
        let (row_weights, column_weights) = self.texel_weights();
        let map = self.map(&row_weights, &column_weights);
        let Builder {
            radiance_channels,
            luminance_weights,
            patches,
            ..
        } = self;
        // Emitters by power: luminance (plus a little of the peak) × solid angle.
        let mut component_weights = Vec::with_capacity(patches.len() + 1);
        let mut emitters = Vec::with_capacity(patches.len());
        for (shape, channel, coefficient) in patches {
            let radiance: Vec<f32> = map.channels[channel]
                .iter()
                .map(|&s| (f64::from(s) * coefficient * scale) as f32)
                .collect();
            let luminance = f64::from(dot_f32(&luminance_weights, &radiance));
            let peak = radiance.iter().fold(0.0f32, |a, &b| a.max(b));
            let solid_angle = shape.solid_angle();
            component_weights
                .push((luminance + MAX_VALUE_SAMPLING_WEIGHT * f64::from(peak)) * solid_angle);
            emitters.push(Patch {
                shape,
                solid_angle,
                radiance,
            });
        }
        component_weights.push(map.total_weight);
        let facing_up = FacingUpSampling::new(
            &row_weights,
            &map.row_cos,
            &map.rows,
            &emitters,
            &component_weights,
        );
        let horizontal_irradiance = facing_up
            .as_ref()
            .and_then(|sampling| horizontal_irradiance(&map, &emitters, sampling));
        Some(Environment {
            kind,
            horizontal_irradiance,
            channels: radiance_channels,
            luminance_weights,
            patches: emitters,
            map,
            components: Distribution1D::new(&component_weights),
            facing_up,
            floor: Some(Floor {
                reflectance: vec![floor_reflectance; radiance_channels.len()],
            }),
            sun_dir: None,
        })
    }

    /// Scales every coefficient so the horizontal illuminance is π, and, when
    /// `fill_ground`, gives the rows wholly below the horizon the radiance of a
    /// Lambertian floor of `floor_reflectance` in that light. The scale applied,
    /// or `None` if the upper hemisphere is black.
    fn normalise(&mut self, floor_reflectance: f32, fill_ground: bool) -> Option<f64> {
        let n = self.channels.len();
        let irradiance = self.channel_irradiance();
        let illuminance: f64 = irradiance
            .iter()
            .zip(&self.channel_luminance)
            .map(|(e, l)| e * l)
            .sum();
        if !(illuminance > 0.0 && illuminance.is_finite()) {
            return None;
        }
        let scale = PI / illuminance;
        for c in &mut self.coeffs {
            *c = (f64::from(*c) * scale) as f32;
        }
        if fill_ground {
            // A Lambertian floor of reflectance ρ under irradiance E has radiance ρE/π.
            let ground: Vec<f32> = irradiance
                .iter()
                .map(|e| (f64::from(floor_reflectance) * e * scale / PI) as f32)
                .collect();
            for row in (0..self.height).filter(|&r| self.row_cos[r] <= 0.0) {
                for col in 0..self.width {
                    let texel = row * self.width + col;
                    self.coeffs[texel * n..(texel + 1) * n].copy_from_slice(&ground);
                }
            }
        }
        Some(scale)
    }

    /// Texel sampling weights, (luminance + a little of the peak) × solid angle
    /// (less below the horizon): per row their sum, and per row each texel's.
    fn texel_weights(&self) -> (Vec<f64>, Vec<Vec<f64>>) {
        let n = self.channels.len();
        let mut row_weights = vec![0.0; self.height];
        let mut column_weights = Vec::with_capacity(self.height);
        let mut texel_spectrum = vec![0.0f32; self.radiance_channels.len()];
        for (row, row_weight) in row_weights.iter_mut().enumerate() {
            let solid_angle =
                2.0 * PI / self.width as f64 * (self.row_cos[row] - self.row_cos[row + 1]);
            let ground = if self.row_cos[row] <= 0.0 {
                GROUND_SAMPLING_WEIGHT
            } else {
                1.0
            };
            let weights: Vec<f64> = (0..self.width)
                .map(|col| {
                    let texel = row * self.width + col;
                    texel_spectrum.fill(0.0);
                    for (channel, &c) in self.channels.iter().zip(&self.coeffs[texel * n..]) {
                        for (o, s) in texel_spectrum.iter_mut().zip(channel) {
                            *o += c * s;
                        }
                    }
                    let luminance = f64::from(dot_f32(&self.luminance_weights, &texel_spectrum));
                    let peak = texel_spectrum.iter().fold(0.0f32, |a, &b| a.max(b));
                    (luminance.max(0.0) + MAX_VALUE_SAMPLING_WEIGHT * f64::from(peak))
                        * solid_angle
                        * ground
                })
                .collect();
            *row_weight = weights.iter().map(|w| w.max(0.0)).sum();
            column_weights.push(weights);
        }
        (row_weights, column_weights)
    }

    /// The radiance map with its sampling tables: rows by `row_weights`, texels
    /// within a row by their `column_weights` through the row's alias table. The
    /// row boundaries and channel spectra move from the builder into the map.
    fn map(&mut self, row_weights: &[f64], column_weights: &[Vec<f64>]) -> RadianceMap {
        let (width, height, n) = (self.width, self.height, self.channels.len());
        let rows = Distribution1D::new(row_weights);
        let total_weight = rows.total();
        let mut texels = vec![Texel::default(); width * height];
        let mut columns = vec![AliasEntry::default(); width * height];
        for (row, weights) in column_weights.iter().enumerate() {
            let texels = &mut texels[row * width..(row + 1) * width];
            let solid_angle = 2.0 * PI / width as f64 * (self.row_cos[row] - self.row_cos[row + 1]);
            let row_probability = if total_weight > 0.0 {
                rows.probability(row)
            } else {
                0.0
            };
            let row_weight = row_weights[row];
            for (col, (texel, &weight)) in texels.iter_mut().zip(weights).enumerate() {
                let texel_index = row * width + col;
                texel.coeffs[..n]
                    .copy_from_slice(&self.coeffs[texel_index * n..(texel_index + 1) * n]);
                if row_weight > 0.0 {
                    texel.pdf =
                        (row_probability * weight.max(0.0) / row_weight / solid_angle) as f32;
                }
            }
            columns[row * width..(row + 1) * width].copy_from_slice(&alias_table(weights));
        }
        RadianceMap {
            width,
            height,
            row_cos: std::mem::take(&mut self.row_cos),
            channels: std::mem::take(&mut self.channels),
            texels,
            columns,
            rows,
            total_weight,
        }
    }
}
