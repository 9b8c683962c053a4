//! Tests of the whole environment's look-ups: the two-step (batch) versions
//! against the one-step ones, light samples against their directions' look-ups,
//! and sampling for a surface facing up.

use std::f64::consts::PI;

use super::map::MapDraw;
use super::*;
use crate::colour::spectrum::WavelengthGrid;
use crate::io::rgb_image::RgbImage;
use crate::sampling::ONE_BELOW;
use crate::sampling::test_support::uniform;

/// The look-ups in two steps (begun for a batch, then finished) return what the
/// one-step calls do, bit for bit: light samples (map texels and emitters) and
/// escapes (including a direction that cannot be normalised).
#[test]
fn look_ups_in_two_steps_are_those_in_one() {
    let mut state = 17;
    let (grid, image_env, mut a, mut b) = map_and_scratch((64, 32), 6, 50.0, &mut state);
    for env in [
        image_env,
        Environment::studio(&grid),
        Environment::outdoor(&grid),
    ] {
        for _ in 0..20_000 {
            let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
            let one = env.sample(u, &mut a);
            let two = env.finish_sample(&env.begin_sample(u), &mut b);
            assert_eq!(
                one.map(|s| (s.dir.map(f32::to_bits), s.pdf.to_bits())),
                two.map(|s| (s.dir.map(f32::to_bits), s.pdf.to_bits())),
                "sample {u:?}"
            );
            assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
            sample_is_its_directions_look_up(&env, u, &mut a, &mut b);
            let d = [0, 1, 2].map(|_| (2.0 * uniform(&mut state) - 1.0) as f32 * 3.0);
            for dir in [d, [0.0; 3]] {
                let one = env.radiance_and_pdf(dir, &mut a);
                let two = env
                    .finish_radiance_and_pdf(&env.begin_radiance_and_pdf_for(dir, false), &mut b);
                assert_eq!(one.to_bits(), two.to_bits(), "direction {dir:?}");
                assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
            }
        }
    }
}

/// Light samples for a surface facing up ([`Environment::sample_for`]): each
/// reports the density `pdf_for` gives its direction (bit for bit, in one step
/// or two), lies above the horizon, and as an estimator of the horizontal
/// illuminance ∫ L cos θ dω (π by the normalisation) is unbiased — and, its
/// purpose, far less noisy than the sphere's samples, at least ×3 lower in
/// variance. What noise is left per sample: cos θ varies within a row (32
/// rows here) and within an emitter (sampled uniformly), and a texel's weight
/// is its luminance plus a share of its peak (random colours on the test map).
///
/// Negative control: the same samples weighed with a density 10 % high over
/// half of the sphere (x ≥ 0), as a `pdf_for` wrong there alone would report
/// it, must fail the same Z-test. (A density 10 % off over half and
/// renormalised moves this estimate only by 0.1·(P − F), P and F the half's
/// shares of the density and of L cos θ, nearly 0 for a density that follows
/// the light: the histograms of `tests/environment.rs` are the test for that.)
#[test]
fn samples_facing_up_estimate_the_floors_irradiance_with_less_noise() {
    let mut state = 23;
    let (grid, image_env, mut a, mut b) = map_and_scratch((64, 32), 6, 50.0, &mut state);
    for (name, env, most) in [
        ("image", image_env, 0.2),
        ("studio", Environment::studio(&grid), 0.5),
        ("outdoor", Environment::outdoor(&grid), 0.5),
    ] {
        let n = 200_000;
        let mut moments = [[0.0f64; 2]; 2];
        // Facing up, with the density 10 % high for x ≥ 0.
        let mut wrong = [0.0f64; 2];
        for _ in 0..n {
            let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
            for (facing_up, m) in [(true, 0), (false, 1)] {
                let Some(sample) = env.sample_for(u, facing_up, &mut a) else {
                    continue;
                };
                let two = env.finish_sample(&env.begin_sample_for(u, facing_up), &mut b);
                assert_eq!(
                    two.map(|s| (s.dir.map(f32::to_bits), s.pdf.to_bits())),
                    Some((sample.dir.map(f32::to_bits), sample.pdf.to_bits())),
                    "{name}: sample {u:?} in two steps"
                );
                let pdf = env.pdf_for(sample.dir, facing_up);
                assert_eq!(pdf.to_bits(), sample.pdf.to_bits(), "{name}: {u:?}");
                let y = f64::from(sample.dir[1]);
                if facing_up {
                    assert!(y >= 0.0, "{name}: below the horizon");
                }
                let x = f64::from(env.luminance(&a)) * y.max(0.0) / f64::from(sample.pdf);
                moments[m][0] += x;
                moments[m][1] += x * x;
                if facing_up {
                    let x = if sample.dir[0] >= 0.0 { x / 1.1 } else { x };
                    wrong[0] += x;
                    wrong[1] += x * x;
                }
            }
        }
        let nf = n as f64;
        let [up, sphere] = moments.map(|[s, s2]| {
            let mean = s / nf;
            (mean, (s2 / nf - mean * mean).max(0.0))
        });
        for (label, (mean, var)) in [("facing up", up), ("sphere", sphere)] {
            let z = (mean - PI) / (var / nf).sqrt().max(1e-12);
            println!(
                "{name} {label}: E {mean:.5}, relative std {:.4}, Z {z:.2}",
                var.sqrt() / mean
            );
            assert!(
                z.abs() < 5.0 || (mean - PI).abs() < 1e-4,
                "{name} {label}: E = {mean} for π (Z {z:.1})"
            );
        }
        let (mean, var) = (
            wrong[0] / nf,
            (wrong[1] / nf - (wrong[0] / nf).powi(2)).max(0.0),
        );
        let z = (mean - PI) / (var / nf).sqrt().max(1e-12);
        println!("{name} facing up, density 10 % high for x ≥ 0: E {mean:.5}, Z {z:.1}");
        assert!(
            z.abs() >= 5.0,
            "{name}: a 10 % density error passed (Z {z:.1})"
        );
        let relative = up.1.sqrt() / up.0;
        assert!(relative < most, "{name}: relative std {relative:.4}");
        assert!(
            up.1 < sphere.1 / 3.0,
            "{name}: {} against {}",
            up.1,
            sphere.1
        );
    }
}

/// The 10 nm grid of these tests, a [`random_map`] on it, and two spectra's worth
/// of scratch space for its look-ups.
fn map_and_scratch(
    (width, height): (usize, usize),
    power: i32,
    scale: f32,
    state: &mut u64,
) -> (WavelengthGrid, Environment, Vec<f32>, Vec<f32>) {
    let grid = WavelengthGrid::new(380.0, 10.0, 33).unwrap();
    let map = random_map(width, height, power, scale, state, &grid);
    (
        grid,
        map,
        vec![0.0f32; grid.len()],
        vec![0.0f32; grid.len()],
    )
}

/// A map of random texels, each channel `scale` × a uniform number to the
/// `power` (high powers: a few bright texels, as in a studio map).
fn random_map(
    width: usize,
    height: usize,
    power: i32,
    scale: f32,
    state: &mut u64,
    grid: &WavelengthGrid,
) -> Environment {
    let pixels: Vec<[f32; 3]> = (0..width * height)
        .map(|_| [0, 1, 2].map(|_| uniform(state).powi(power) as f32 * scale))
        .collect();
    let image = RgbImage::new(width, height, pixels).unwrap();
    Environment::from_rgb_image(&image, "test", grid).unwrap()
}

/// A light sample's radiance and density are, bit for bit, those that
/// `radiance_and_pdf` finds for its direction (the sample's texel is taken
/// from the draw, without a look-up, when the direction is surely in it).
fn sample_is_its_directions_look_up(env: &Environment, u: [f32; 2], a: &mut [f32], b: &mut [f32]) {
    let Some(sample) = env.sample(u, a) else {
        return;
    };
    let pdf = env.radiance_and_pdf(sample.dir, b);
    assert_eq!(sample.pdf.to_bits(), pdf.to_bits(), "sample {u:?}");
    assert!(
        a.iter()
            .zip(b.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
}

/// Map samples drawn at and near column edges (where the drawn texel is not
/// trusted) and a little further in (where it is) still find their
/// direction's texel, on a map as large as the side-by-side's.
#[test]
fn map_samples_near_column_edges_find_their_directions_texel() {
    let (width, height) = (1024, 512);
    let mut state = 5;
    let (_, env, mut a, mut b) = map_and_scratch((width, height), 4, 20.0, &mut state);
    let offsets = [0.0, 1e-9, 1e-7, 1e-6, 5e-6, 1e-5, 2e-5, 1e-4, 0.5];
    for _ in 0..2_000 {
        let u0 = uniform(&mut state) as f32;
        let column = (uniform(&mut state) * width as f64) as usize;
        for offset in offsets {
            for edge in [column as f64 + offset, (column + 1) as f64 - offset] {
                let u1 = (edge / width as f64).min(ONE_BELOW) as f32;
                sample_is_its_directions_look_up(&env, [u0, u1], &mut a, &mut b);
            }
        }
        let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
        sample_is_its_directions_look_up(&env, u, &mut a, &mut b);
    }
}

/// Map samples drawn at and near row boundaries (where the drawn row is
/// checked on the normalised f32 direction) and further inside (where it is
/// taken from the unrounded one) have, bit for bit, the radiance and density
/// of their direction's look-up; rows at the poles and the horizon included.
#[test]
fn map_samples_near_row_edges_find_their_directions_texel() {
    let (width, height) = (1024, 512);
    let mut state = 9;
    let (_, env, mut a, mut b) = map_and_scratch((width, height), 4, 20.0, &mut state);
    assert!(
        env.patches.is_empty(),
        "a map without emitters takes the shortcut"
    );
    let offsets = [0.0, 1e-12, 1e-9, 1e-7, 1e-6, 2e-6, 1e-5, 1e-3, 0.01, 0.5];
    let mut rows: Vec<usize> = (0..300)
        .map(|_| (uniform(&mut state) * height as f64) as usize)
        .collect();
    rows.extend([0, 1, height / 2 - 1, height / 2, height - 2, height - 1]);
    for row in rows {
        let row_width = env.map.row_cos[row] - env.map.row_cos[row + 1];
        for offset in offsets {
            // v is the fraction of the row's cos range; offsets are in cos θ.
            let dv = (offset / row_width).min(0.5);
            for v in [dv, 1.0 - dv] {
                let v = v.clamp(0.0, ONE_BELOW);
                let frac = uniform(&mut state).clamp(0.0, ONE_BELOW);
                let first = (uniform(&mut state) * width as f64) as usize;
                let begun = SampleLookUp {
                    component: 0,
                    u: [0.0, 0.0],
                    draw: Some(MapDraw {
                        row,
                        v,
                        first,
                        frac,
                    }),
                    facing_up: false,
                };
                let located = env.locate_sample(&begun).expect("a lit map");
                let sample = env
                    .finish_located_sample(&located, &mut a)
                    .expect("density");
                let pdf = env.radiance_and_pdf(sample.dir, &mut b);
                assert_eq!(sample.pdf.to_bits(), pdf.to_bits(), "row {row} v {v}");
                assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
            }
        }
    }
}

/// [`Environment::horizontal_irradiance`] is what a facing-up light sample's
/// L · cos θ / pdf estimates, wavelength by wavelength (a Z-test over 200 000
/// samples, each wavelength's mean within 5 standard errors), for a random
/// image map, the studio, the booth and outdoors; its luminance is π (the
/// normalisation). Negative control: the irradiance 1 % high at one wavelength
/// fails the same test. An emitter reaching below the horizon that is not cut
/// there exactly (a cap) gives none.
#[test]
fn the_horizontal_irradiance_is_what_facing_up_samples_estimate() {
    let mut state = 31;
    let (grid, image_env, mut a, _) = map_and_scratch((64, 32), 6, 50.0, &mut state);
    for (name, env) in [
        ("image", image_env),
        ("studio", Environment::studio(&grid)),
        ("booth", Environment::booth(Illuminant::D65, &grid)),
        ("outdoor", Environment::outdoor(&grid)),
    ] {
        let irradiance = env
            .horizontal_irradiance()
            .unwrap_or_else(|| panic!("{name}: an irradiance"))
            .to_vec();
        let luminance = f64::from(env.luminance(&irradiance));
        assert!(
            (luminance - PI).abs() < 1e-4 * PI,
            "{name}: luminance {luminance}"
        );
        let n = 200_000;
        let mut sums = vec![[0.0f64; 2]; grid.len()];
        for _ in 0..n {
            let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
            let Some(sample) = env.sample_for(u, true, &mut a) else {
                continue;
            };
            let weight = f64::from(sample.dir[1].max(0.0)) / f64::from(sample.pdf);
            for (s, &l) in sums.iter_mut().zip(&a) {
                let x = f64::from(l) * weight;
                s[0] += x;
                s[1] += x * x;
            }
        }
        let nf = n as f64;
        let z_of = |e: f64, [s, s2]: [f64; 2]| {
            let mean = s / nf;
            let standard_error = ((s2 / nf - mean * mean).max(0.0) / nf).sqrt();
            (mean - e) / standard_error.max(1e-12 * e.abs().max(1e-30))
        };
        let worst = irradiance
            .iter()
            .zip(&sums)
            .map(|(&e, &s)| z_of(f64::from(e), s).abs())
            .fold(0.0, f64::max);
        println!("{name}: largest |Z| over the wavelengths {worst:.2}");
        assert!(worst < 5.0, "{name}: |Z| {worst:.1}");
        let middle = grid.len() / 2;
        let high = z_of(1.01 * f64::from(irradiance[middle]), sums[middle]);
        assert!(high.abs() >= 5.0, "{name}: 1 % high passed (Z {high:.1})");
    }

    let mut builder = builder::Builder::new(&grid.into(), vec![vec![1.0; grid.len()]], 1, 8);
    builder.coeffs.fill(0.2);
    builder.patches.push((
        emitters::Shape::cap(glam::DVec3::new(0.0, 0.1, 1.0).normalize(), 0.3),
        0,
        5.0,
    ));
    let env = builder
        .finish(EnvironmentKind::Studio, 0.25, false)
        .expect("lit");
    assert!(env.horizontal_irradiance().is_none());
}
