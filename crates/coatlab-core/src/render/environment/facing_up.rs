//! Light sampling for a surface facing straight up (the floor): the environment's
//! emitters and map rows reweighted by their mean cosine to the vertical, so the
//! floor's direct light is sampled in proportion to what it receives.

use std::f64::consts::PI;

use super::emitters::{Patch, lat_long_cosine_integral};
use super::map::RadianceMap;
use crate::sampling::Distribution1D;

/// The least mean cosine an emitter is given in [`FacingUpSampling`].
const MIN_PATCH_MEAN_UP: f64 = 1e-3;

/// Light sampling for a surface facing straight up
/// ([`super::Environment::sample_for`]): the same emitters and texels, each
/// emitter's and each map row's weight times its mean max(y, 0) (cos θ to the
/// vertical, 0 below the horizon).
#[derive(Debug, Clone)]
pub(super) struct FacingUpSampling {
    /// Selection of a component: the patches in order, then the map.
    pub(super) components: Distribution1D,
    /// Selection of the map's row.
    pub(super) rows: Distribution1D,
    /// Per map row: its probability here over its probability in the map's own
    /// sampling (the texel densities scale by it; 0 below the horizon).
    pub(super) row_factor: Vec<f32>,
}

impl FacingUpSampling {
    /// From the map's row weights and boundaries and the components' weights
    /// (patches, then the map); `None` when nothing above the horizon has weight.
    pub(super) fn new(
        row_weights: &[f64],
        row_cos: &[f64],
        rows: &Distribution1D,
        patches: &[Patch],
        component_weights: &[f64],
    ) -> Option<Self> {
        // Mean of max(y, 0) over a row, y uniform between its boundaries.
        let mean_up = |top: f64, bottom: f64| {
            if bottom >= 0.0 {
                0.5 * (top + bottom)
            } else if top <= 0.0 {
                0.0
            } else {
                0.5 * top * top / (top - bottom)
            }
        };
        let up_row_weights: Vec<f64> = row_weights
            .iter()
            .enumerate()
            .map(|(r, w)| w.max(0.0) * mean_up(row_cos[r], row_cos[r + 1]))
            .collect();
        let up_rows = Distribution1D::new(&up_row_weights);
        let row_factor = (0..row_weights.len())
            .map(|r| {
                let p = rows.probability(r);
                if p > 0.0 {
                    (up_rows.probability(r) / p) as f32
                } else {
                    0.0
                }
            })
            .collect();
        let map_total = rows.total();
        let mut up_components: Vec<f64> = patches
            .iter()
            .zip(component_weights)
            // The mean cosine, at least 1e-3: the cap's formula is exact only for
            // a cap wholly above the horizon, and a density of 0 over any part of
            // an emitter that lights the floor would lose that light (the floor's
            // escapes count nothing).
            .map(|(patch, w)| {
                w * (patch.shape.cosine_integral() / patch.solid_angle).max(MIN_PATCH_MEAN_UP)
            })
            .collect();
        up_components.push(if map_total > 0.0 {
            component_weights[patches.len()] * up_rows.total() / map_total
        } else {
            0.0
        });
        let components = Distribution1D::new(&up_components);
        (components.total() > 0.0).then_some(Self {
            components,
            rows: up_rows,
            row_factor,
        })
    }
}

/// The horizontal irradiance, per channel, that [`FacingUpSampling`]'s light
/// samples estimate: ∫ L(ω) max(y, 0) dω over the directions they can draw (the
/// map's texels with a density, every emitter), in closed form — each texel's
/// radiance is constant over it, and ∫ y dω over a texel or an emitter is known.
/// `None` where that form is not exact: an emitter that reaches below the
/// horizon other than a lat-long rectangle (which is cut there exactly).
///
/// The floor uses it as a control variate (docs/rendering.md): its direct light
/// is this irradiance, less what the shadow rays find missing, so an unshadowed
/// floor carries no noise from its light samples.
pub(super) fn horizontal_irradiance(
    map: &RadianceMap,
    patches: &[Patch],
    sampling: &FacingUpSampling,
) -> Option<Vec<f32>> {
    if !patches.iter().all(|p| p.shape.above_horizon()) {
        return None;
    }
    let len = map.channels.first().map_or(0, Vec::len);
    let mut sum = vec![0.0f64; len];
    let mut texel_spectrum = vec![0.0f32; len];
    for row in 0..map.height {
        let cosine_integral = lat_long_cosine_integral(
            2.0 * PI / map.width as f64,
            [map.row_cos[row + 1], map.row_cos[row]],
        );
        if cosine_integral <= 0.0 || sampling.row_factor[row] <= 0.0 {
            continue;
        }
        for texel in row * map.width..(row + 1) * map.width {
            if map.pdf(texel) <= 0.0 {
                continue;
            }
            texel_spectrum.fill(0.0);
            map.add_radiance(texel, &mut texel_spectrum);
            for (s, &l) in sum.iter_mut().zip(&texel_spectrum) {
                *s += f64::from(l) * cosine_integral;
            }
        }
    }
    for patch in patches {
        let cosine_integral = patch.shape.cosine_integral();
        for (s, &l) in sum.iter_mut().zip(&patch.radiance) {
            *s += f64::from(l) * cosine_integral;
        }
    }
    Some(sum.into_iter().map(|s| s as f32).collect())
}
