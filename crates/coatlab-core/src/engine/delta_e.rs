//! The ΔE00 map between the two views of a comparison: per-pixel CIEDE2000 of
//! the colours as displayed, with its statistics.

use rayon::prelude::*;

use crate::colour::{Xyz, ciede2000};
use crate::render::film::{DisplaySettings, DisplayTransform, Film};

/// Per-pixel ΔE00 between two renders of the same view.
#[derive(Debug, Clone, PartialEq)]
pub struct DeltaEMap {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Row-major from the top-left; NaN where either pixel has no sample.
    pub values: Vec<f32>,
    /// Mean over the pixels with a value.
    pub mean: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest value.
    pub max: f64,
    /// Samples per pixel of both renders when the map was made.
    pub samples_per_pixel: u32,
}

impl DeltaEMap {
    /// CIEDE2000 between the colours `a` and `b` are shown in with `display` (the same
    /// settings for both, so exposure cannot hide or invent a difference). `None` when
    /// the films differ in size or hold no samples.
    pub fn between(a: &Film, b: &Film, display: &DisplaySettings) -> Option<DeltaEMap> {
        let (width, height) = (a.width(), a.height());
        if (b.width(), b.height()) != (width, height) || width == 0 || height == 0 {
            return None;
        }
        let transform = DisplayTransform::of(display);
        let lab = |film: &Film, x, y| transform.lab_of_xyz(film.mean_xyz(x, y));
        // Rows in parallel: a 640×400 map is ~0.25 M CIEDE2000 evaluations.
        let values: Vec<f32> = (0..height)
            .into_par_iter()
            .flat_map_iter(|y| {
                (0..width).map(move |x| {
                    if a.sample_count(x, y) == 0 || b.sample_count(x, y) == 0 {
                        return f32::NAN;
                    }
                    ciede2000(lab(a, x, y), lab(b, x, y)) as f32
                })
            })
            .collect();
        Self::of_values(width, height, values)
    }

    /// [`Self::between`] for two images given as mean XYZ per pixel (row-major,
    /// `width` × `height`): the comparison's panes re-shaded from one set of paths.
    pub fn between_xyz(
        width: u32,
        height: u32,
        a: &[[f32; 3]],
        b: &[[f32; 3]],
        display: &DisplaySettings,
    ) -> Option<DeltaEMap> {
        let n = (width as usize) * (height as usize);
        if a.len() != n || b.len() != n || n == 0 {
            return None;
        }
        let transform = DisplayTransform::of(display);
        let lab = |v: [f32; 3]| {
            transform.lab_of_xyz(Xyz::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])))
        };
        let values: Vec<f32> = a
            .par_iter()
            .zip(b.par_iter())
            .map(|(&va, &vb)| {
                if va == vb {
                    // The same paths with the same value (the backdrop, or a design
                    // against itself): 0 without two colour conversions.
                    0.0
                } else {
                    ciede2000(lab(va), lab(vb)) as f32
                }
            })
            .collect();
        Self::of_values(width, height, values)
    }

    /// The map of per-pixel `values` with its statistics.
    fn of_values(width: u32, height: u32, values: Vec<f32>) -> Option<DeltaEMap> {
        let mut sorted: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_by(f32::total_cmp);
        let mean = sorted.iter().map(|&v| f64::from(v)).sum::<f64>() / sorted.len() as f64;
        let p95 = f64::from(sorted[((sorted.len() - 1) as f64 * 0.95).round() as usize]);
        let max = f64::from(sorted[sorted.len() - 1]);
        Some(DeltaEMap {
            width,
            height,
            values,
            mean,
            p95,
            max,
            samples_per_pixel: 0,
        })
    }
}
