//! Linear sRGB to smooth, non-negative spectra: how RGB colours (an image map's
//! texels, a scene material's base colour) become reflectance and emission
//! spectra on a wavelength grid. A fixed linear combination of three smooth basis
//! spectra, one per primary (Jakob & Hanika's sigmoid polynomials, refitted to
//! each grid's colorimetry), so the map is linear and an RGB triple round-trips.

use palette::LinSrgb;

use crate::colour::cie::{Colorimeter, Illuminant, Observer};
use crate::colour::spectrum::{Channels, VISIBLE, WavelengthGrid};
use crate::colour::{Xyz, xyz_from_linear_srgb};

/// Jakob–Hanika sigmoid-polynomial coefficients (c₂, c₁, c₀ of
/// S(c₂t² + c₁t + c₀), t = (λ − 580 nm)/200 nm, S(x) = ½ + x/(2√(1 + x²))) of the
/// three basis reflectances. Fitted jointly offline (Levenberg–Marquardt on the
/// CIE 1931 5 nm tables) so that D65 × basis has the chromaticity of the sRGB red,
/// green and blue primaries (to 5e-6) while the three, scaled to the primaries'
/// luminances, sum to nearly 1 (0.77–1.44, mostly 0.9–1.15): white light stays
/// close to D65. Each grid refits them exactly ([`refit_basis`]).
const RGB_BASIS_COEFFICIENTS: [[f64; 3]; 3] = [
    [15.278_909_716_9, 14.156_045_384_5, -1.396_364_337_8],
    [-28.213_178_528_6, -11.369_104_624_1, 0.601_796_464_1],
    [6.353_649_784_7, -6.196_147_115_2, -4.317_131_247_5],
];

/// Linear sRGB to smooth, non-negative spectra: a fixed linear combination of three
/// smooth basis spectra, one per primary, so the map is linear (an RGB image's
/// spectra are three coefficients per texel) and an RGB triple round-trips.
///
/// Basis i is the sigmoid polynomial of `RGB_BASIS_COEFFICIENTS` scaled so that,
/// as a reflectance under D65 (CIE 1931, on this grid's colorimetry), its XYZ is
/// exactly that of sRGB primary i; chromaticity holds to the fit. Negative RGB
/// components are clamped to 0, so the spectra are never negative.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbUpsampler {
    reflectance_bases: [Vec<f32>; 3],
    emission_bases: [Vec<f32>; 3],
}

impl RgbUpsampler {
    /// The bases on `channels`.
    pub fn new(channels: &(impl Into<Channels> + Copy)) -> Self {
        let grid = match (*channels).into() {
            Channels::Spectral(grid) => grid,
            Channels::LinearSrgb => {
                // A colour is its own "spectrum"; (1, 1, 1) has luminance 1 under
                // the sRGB luminance weights.
                let unit = |i: usize| (0..3).map(|k| if k == i { 1.0 } else { 0.0 }).collect();
                return Self {
                    reflectance_bases: std::array::from_fn(unit),
                    emission_bases: std::array::from_fn(unit),
                };
            }
        };
        let grid = &grid;
        let colorimeter = Colorimeter::new(Illuminant::D65, Observer::Cie1931TwoDegree, grid);
        let unit = [
            LinSrgb::new(1.0, 0.0, 0.0),
            LinSrgb::new(0.0, 1.0, 0.0),
            LinSrgb::new(0.0, 0.0, 1.0),
        ];
        let reflectance_bases: [Vec<f64>; 3] = std::array::from_fn(|i| {
            let target = xyz_from_linear_srgb(unit[i]);
            let coefficients = refit_basis(&colorimeter, RGB_BASIS_COEFFICIENTS[i], target);
            let raw = sigmoid_polynomial(grid, coefficients);
            let scale = target.y / colorimeter.xyz(&raw).y;
            raw.into_iter().map(|v| v * scale).collect()
        });
        // Emission: D65 × reflectance, scaled so RGB (1, 1, 1) has luminance 1.
        let d65 = Illuminant::D65.spd(grid);
        let weights = spectral_luminance_weights(grid);
        let white: Vec<f64> = (0..grid.len())
            .map(|k| d65.values()[k] * reflectance_bases.iter().map(|b| b[k]).sum::<f64>())
            .collect();
        let white_luminance: f64 = white
            .iter()
            .zip(&weights)
            .map(|(v, &w)| v * f64::from(w))
            .sum();
        let emission_bases = std::array::from_fn(|i| {
            reflectance_bases[i]
                .iter()
                .zip(d65.values())
                .map(|(r, s)| (r * s / white_luminance) as f32)
                .collect()
        });
        Self {
            reflectance_bases: reflectance_bases.map(|b| b.into_iter().map(|v| v as f32).collect()),
            emission_bases,
        }
    }

    /// A reflectance whose colour under D65 is `rgb` (linear sRGB, white (1, 1, 1)).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn reflectance(&self, rgb: LinSrgb<f32>, out: &mut [f32]) {
        combine(&self.reflectance_bases, rgb, out);
    }

    /// An emission (radiance) spectrum whose colour is `rgb`: D65 × the
    /// reflectance, scaled so (1, 1, 1) has luminance 1 under
    /// [`spectral_luminance_weights`] (the environment's luminance).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn emission(&self, rgb: LinSrgb<f32>, out: &mut [f32]) {
        combine(&self.emission_bases, rgb, out);
    }

    /// The three emission spectra whose combination [`Self::emission`] returns,
    /// one per primary (R, G, B).
    pub fn emission_bases(&self) -> &[Vec<f32>; 3] {
        &self.emission_bases
    }
}

fn combine(bases: &[Vec<f32>; 3], rgb: LinSrgb<f32>, out: &mut [f32]) {
    assert_eq!(out.len(), bases[0].len(), "spectrum buffer length");
    let c = [rgb.red, rgb.green, rgb.blue].map(|v| v.max(0.0));
    for (k, o) in out.iter_mut().enumerate() {
        *o = c[0] * bases[0][k] + c[1] * bases[1][k] + c[2] * bases[2][k];
    }
}

fn sigmoid_polynomial(grid: &WavelengthGrid, [c2, c1, c0]: [f64; 3]) -> Vec<f64> {
    grid.wavelengths_nm()
        .map(|l| {
            let t = (l - 580.0) / 200.0;
            sigmoid(c2 * t * t + c1 * t + c0)
        })
        .collect()
}

/// The sigmoid-polynomial coefficients nearest `start` whose spectrum has the
/// chromaticity of `target` under this grid's colorimetry: minimum-norm
/// Gauss–Newton steps on the two chromaticity equations, halved until they help.
/// On the 5 nm grid `start` already fits; coarse grids, which read a spectrum as
/// piecewise linear between fewer samples, move it a little. Where a grid is too
/// coarse to reach the target the best coefficients found are kept.
fn refit_basis(colorimeter: &Colorimeter, start: [f64; 3], target: Xyz) -> [f64; 3] {
    let grid = *colorimeter.grid();
    let chromaticity = |xyz: Xyz| {
        let sum = xyz.x + xyz.y + xyz.z;
        [xyz.x / sum, xyz.y / sum]
    };
    let goal = chromaticity(target);
    let residual = |c: [f64; 3]| {
        let xy = chromaticity(colorimeter.xyz(&sigmoid_polynomial(&grid, c)));
        [xy[0] - goal[0], xy[1] - goal[1]]
    };
    let norm = |r: [f64; 2]| r[0].hypot(r[1]);
    let mut c = start;
    let mut r = residual(c);
    for _ in 0..30 {
        if norm(r) < 1e-10 {
            break;
        }
        // Jacobian (2×3) by forward differences.
        let jacobian: [[f64; 2]; 3] = std::array::from_fn(|k| {
            let mut shifted = c;
            let h = 1e-6 * c[k].abs().max(1.0);
            shifted[k] += h;
            let rs = residual(shifted);
            [(rs[0] - r[0]) / h, (rs[1] - r[1]) / h]
        });
        // Δc = −Jᵀ (J Jᵀ)⁻¹ r.
        let mut jjt = [[0.0; 2]; 2];
        for col in &jacobian {
            for a in 0..2 {
                for b in 0..2 {
                    jjt[a][b] += col[a] * col[b];
                }
            }
        }
        let det = jjt[0][0] * jjt[1][1] - jjt[0][1] * jjt[1][0];
        if det.abs() < 1e-300 {
            break;
        }
        let lambda = [
            (jjt[1][1] * r[0] - jjt[0][1] * r[1]) / det,
            (jjt[0][0] * r[1] - jjt[1][0] * r[0]) / det,
        ];
        let step: [f64; 3] =
            std::array::from_fn(|k| -(jacobian[k][0] * lambda[0] + jacobian[k][1] * lambda[1]));
        let mut scale = 1.0;
        let mut improved = false;
        for _ in 0..20 {
            let trial = std::array::from_fn(|k| c[k] + scale * step[k]);
            let rt = residual(trial);
            if norm(rt) < norm(r) {
                c = trial;
                r = rt;
                improved = true;
                break;
            }
            scale *= 0.5;
        }
        if !improved {
            break;
        }
    }
    c
}

fn sigmoid(x: f64) -> f64 {
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// Luminance weights on a spectral grid: CIE 1931 ȳ at 1 nm over 380–780 nm (or
/// the grid's span if wider), split between the two grid samples around each
/// wavelength (linear-interpolation hats, the end hats extended), normalised to
/// sum 1, so Σ wᵢ Lᵢ is the luminance of the spectrum L on the grid and a flat
/// spectrum of 1 has luminance 1. Not for the RGB shortcut
/// ([`Channels::LinearSrgb`]), whose
/// weights are the sRGB luminance coefficients
/// (`render::environment::luminance_weights` handles both).
pub fn spectral_luminance_weights(grid: &WavelengthGrid) -> Vec<f32> {
    let n = grid.len();
    let mut w = vec![0.0f64; n];
    let first = VISIBLE.start_nm.min(grid.start_nm()).floor() as i32;
    let last = VISIBLE.end_nm.max(grid.end_nm()).ceil() as i32;
    for nm in first..=last {
        let l = f64::from(nm);
        let y = Observer::Cie1931TwoDegree.cmf_at_nm(l)[1];
        let position = (l - grid.start_nm()) / grid.step_nm();
        if n == 1 || position <= 0.0 {
            w[0] += y;
        } else if position >= (n - 1) as f64 {
            w[n - 1] += y;
        } else {
            let i = position.floor() as usize;
            let t = position - i as f64;
            w[i] += y * (1.0 - t);
            w[i + 1] += y * t;
        }
    }
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|v| (v / sum) as f32).collect()
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    use super::*;
    use crate::colour::{linear_srgb_from_xyz, srgb_white};

    /// Linear sRGB of a reflectance seen under D65 (sRGB white scale).
    fn round_trip(grid: &WavelengthGrid, upsampler: &RgbUpsampler, rgb: [f32; 3]) -> [f64; 3] {
        let colorimeter = Colorimeter::new(Illuminant::D65, Observer::Cie1931TwoDegree, grid);
        let mut r = vec![0.0f32; grid.len()];
        upsampler.reflectance(LinSrgb::new(rgb[0], rgb[1], rgb[2]), &mut r);
        assert!(
            r.iter().all(|&v| v >= 0.0),
            "negative reflectance for {rgb:?}"
        );
        let values: Vec<f64> = r.iter().map(|&v| f64::from(v)).collect();
        let out = linear_srgb_from_xyz(colorimeter.xyz(&values), srgb_white());
        [out.red, out.green, out.blue]
    }

    #[test]
    fn rgb_upsampling_round_trips_and_is_non_negative() {
        // The bases are refitted to each grid's colorimetry: exact to f32 storage
        // (measured 5e-8, 9e-8, 1.2e-7 on 81, 16, 8 samples). Three samples cannot
        // reach the primaries (0.84 off): not held there.
        for (grid, tolerance) in [
            (WavelengthGrid::reference(), 1e-6),
            (WavelengthGrid::visible(16).expect("grid"), 1e-6),
            (WavelengthGrid::visible(8).expect("grid"), 1e-6),
        ] {
            let upsampler = RgbUpsampler::new(&grid);
            let mut rng = Pcg64::seed_from_u64(5);
            let mut worst = 0.0f64;
            let corners = (0..8).map(|k| [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| b as f32));
            let random = (0..500).map(|_| std::array::from_fn(|_| rng.random::<f32>()));
            for rgb in corners.chain(random) {
                let back = round_trip(&grid, &upsampler, rgb);
                for k in 0..3 {
                    worst = worst.max((back[k] - f64::from(rgb[k])).abs());
                }
            }
            assert!(
                worst < tolerance,
                "{} samples: worst error {worst}",
                grid.len()
            );
        }
    }

    #[test]
    fn the_emission_bases_are_what_emission_combines() {
        let grid = WavelengthGrid::visible(16).expect("grid");
        let upsampler = RgbUpsampler::new(&grid);
        let mut e = vec![0.0f32; grid.len()];
        upsampler.emission(LinSrgb::new(0.0, 1.0, 0.0), &mut e);
        assert_eq!(&e, &upsampler.emission_bases()[1]);
    }

    #[test]
    fn luminance_weights_sum_to_one_and_follow_y_bar() {
        for grid in [
            WavelengthGrid::reference(),
            WavelengthGrid::visible(16).expect("grid"),
            WavelengthGrid::visible(1).expect("grid"),
        ] {
            let w = spectral_luminance_weights(&grid);
            assert_eq!(w.len(), grid.len());
            let sum: f32 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "{sum}");
            assert!(w.iter().all(|&v| v >= 0.0));
        }
        // ȳ peaks at 555 nm: the 81-sample grid's largest weight is at 555 nm.
        let w = spectral_luminance_weights(&WavelengthGrid::reference());
        let peak = (0..w.len()).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap();
        assert_eq!(peak, (555 - 380) / 5);
    }
}
