//! Lighting environments: sampling against the pdf, normalisation, spectra, maps
//! read from Radiance .hdr and OpenEXR files, and RGB emission (docs/lighting.md).
//! The readers' and the upsampler's own unit tests are in `io/` and
//! `colour/upsampling.rs`.

use std::f64::consts::PI;
use std::path::PathBuf;

use coatlab_core::colour::cie::Illuminant;
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::upsampling::RgbUpsampler;
use coatlab_core::io::hdr::{decode_hdr, read_hdr};
use coatlab_core::io::rgb_image::{ImageReadError, RgbImage};
use coatlab_core::render::environment::{
    Environment, EnvironmentError, EnvironmentKind, SUN_HALF_ANGLE_DEG,
};
use glam::DVec3;
use palette::LinSrgb;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

#[path = "support/bsdf_chi_square.rs"]
mod bsdf_chi_square;

fn grid() -> WavelengthGrid {
    WavelengthGrid::visible(16).expect("valid grid")
}

/// Visits quadrature points (direction, solid-angle weight) covering the sphere:
/// an equal-area grid in (azimuth, y), and, outdoors, a finer polar grid on the
/// sun's disc (whose grid points are left out of the first).
///
/// 2048 azimuths: with 1024, fewer than the 1367 columns of the wide test image,
/// the histogram test's bins inherited aliasing errors of a few per cent (χ² 190
/// over 64 bins for a correct sampler).
fn quadrature(env: &Environment, mut visit: impl FnMut([f32; 3], f64)) {
    let (na, ny) = (2048usize, 1024usize);
    let weight = 4.0 * PI / (na * ny) as f64;
    let sun = env
        .sun_direction()
        .map(|d| DVec3::from_array(d.map(f64::from)));
    let one_minus_cos_sun = 1.0 - SUN_HALF_ANGLE_DEG.to_radians().cos();
    for j in 0..ny {
        let y = -1.0 + 2.0 * (j as f64 + 0.5) / ny as f64;
        let r = (1.0 - y * y).sqrt();
        for i in 0..na {
            let a = 2.0 * PI * (i as f64 + 0.5) / na as f64;
            let d = DVec3::new(r * a.sin(), y, r * a.cos());
            if let Some(s) = sun
                && 1.0 - d.dot(s) <= one_minus_cos_sun
            {
                continue;
            }
            visit(d.as_vec3().to_array(), weight);
        }
    }
    if let Some(s) = sun {
        let across = DVec3::X.cross(s);
        let t = across / across.length();
        let b = s.cross(t);
        let (nr, nphi) = (64usize, 64usize);
        let w = 2.0 * PI * one_minus_cos_sun / (nr * nphi) as f64;
        for j in 0..nr {
            let omc = one_minus_cos_sun * (j as f64 + 0.5) / nr as f64;
            let (cos_t, sin_t) = (1.0 - omc, (omc * (2.0 - omc)).sqrt());
            for i in 0..nphi {
                let phi = 2.0 * PI * (i as f64 + 0.5) / nphi as f64;
                let d = sin_t * (phi.cos() * t + phi.sin() * b) + cos_t * s;
                visit(d.as_vec3().to_array(), w);
            }
        }
    }
}

/// Mean and standard error of the mean.
fn mean_and_error(sum: f64, sum_sq: f64, n: usize) -> (f64, f64) {
    let n = n as f64;
    let mean = sum / n;
    let var = (sum_sq / n - mean * mean).max(0.0);
    (mean, (var / n).sqrt())
}

/// Bin of a direction: 4 azimuth quadrants × 2 hemispheres.
fn bin(d: [f32; 3]) -> usize {
    let quadrant = usize::from(d[0] >= 0.0) + 2 * usize::from(d[2] >= 0.0);
    quadrant + 4 * usize::from(d[1] >= 0.0)
}

/// Bin of a direction for the histogram test: 8 bands of equal solid angle in y
/// (the vertical) × 8 sectors of azimuth about it. Both halves of the controls
/// (y ≥ 0, x ≥ 0) are unions of bins.
fn fine_bin(d: [f32; 3]) -> usize {
    let band = ((f64::from(d[1]) + 1.0) * 4.0).clamp(0.0, 7.0) as usize;
    let azimuth = f64::from(d[0]).atan2(f64::from(d[2])).rem_euclid(2.0 * PI);
    let sector = ((azimuth / (2.0 * PI) * 8.0) as usize).min(7);
    band * 8 + sector
}

/// A density to test the environment's samples against: its own `pdf`, or a
/// negative control.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Density {
    /// `Environment::pdf`.
    Own,
    /// `pdf` ×1.1 where `half` holds and renormalised: what a sampler whose density
    /// is 10 % off over half of the sphere reports, for its sample and its `pdf`
    /// alike (a product bug would change both).
    TenPercentOff(Half),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Half {
    /// The sky (y ≥ 0): a wrong weight of the upper rows of a map.
    Upper,
    /// x ≥ 0: a wrong weight of half of the azimuths.
    East,
}

impl Half {
    fn holds(self, d: [f32; 3]) -> bool {
        match self {
            Half::Upper => d[1] >= 0.0,
            Half::East => d[0] >= 0.0,
        }
    }
}

/// The statistical checks every environment must pass, for the environment's own
/// density and for the two negative controls; returns what failed for each.
///
/// The checks: the density integrates to 1; E[L/pdf] = ∫ L dω for the luminance
/// and each wavelength (the estimator of every light sample is unbiased), and
/// E[1_B/pdf] = Ω_B for 8 bins B (the samples' histogram matches the density), each
/// within 5 standard errors plus 2e-3 of the quadrature's value.
fn sampling_checks(
    env: &Environment,
    name: &str,
    densities: &[Density],
) -> (Vec<Vec<String>>, [f64; 2]) {
    let n = env.channels().len();
    let mut l = vec![0.0f32; n];

    // Quadrature: ∫ pdf and ∫ pdf over each half, ∫ L (luminance and per
    // wavelength), E/π, bin solid angles.
    let mut pdf_integral = 0.0;
    let mut half_integral = [0.0; 2];
    let mut luminance_integral = 0.0;
    let mut spectral_integral = vec![0.0f64; n];
    let mut illuminance = 0.0;
    let mut bin_solid_angle = [0.0f64; 8];
    let mut fine_probability = [0.0f64; 64];
    quadrature(env, |d, w| {
        let pdf = env.pdf(d);
        assert!(pdf.is_finite() && pdf >= 0.0, "{name}: pdf {pdf} at {d:?}");
        pdf_integral += f64::from(pdf) * w;
        fine_probability[fine_bin(d)] += f64::from(pdf) * w;
        for (k, half) in [Half::Upper, Half::East].into_iter().enumerate() {
            if half.holds(d) {
                half_integral[k] += f64::from(pdf) * w;
            }
        }
        env.radiance(d, &mut l);
        let lum = f64::from(env.luminance(&l));
        luminance_integral += lum * w;
        for (s, &v) in spectral_integral.iter_mut().zip(&l) {
            *s += f64::from(v) * w;
        }
        illuminance += lum * f64::from(d[1]).max(0.0) * w;
        bin_solid_angle[bin(d)] += w;
    });
    assert!(
        (illuminance / PI - 1.0).abs() < 5e-3,
        "{name}: a white Lambertian facing up has luminance {}",
        illuminance / PI
    );
    // The density each check reads at a direction whose own density is `pdf`.
    let density = |which: Density, d: [f32; 3], pdf: f32| -> f64 {
        match which {
            Density::Own => f64::from(pdf),
            Density::TenPercentOff(half) => {
                let share = half_integral[usize::from(half == Half::East)];
                let factor = if half.holds(d) { 1.1 } else { 1.0 };
                f64::from(pdf) * factor / (pdf_integral + 0.1 * share)
            }
        }
    };

    // Monte Carlo with the environment's own sampling.
    let samples = 200_000;
    let mut rng = Pcg64::seed_from_u64(0xE4F1_u64 ^ name.len() as u64);
    struct Sums {
        luminance: (f64, f64),
        spectral: Vec<(f64, f64)>,
        bins: [(f64, f64); 8],
    }
    let mut sums: Vec<Sums> = densities
        .iter()
        .map(|_| Sums {
            luminance: (0.0, 0.0),
            spectral: vec![(0.0, 0.0); n],
            bins: [(0.0, 0.0); 8],
        })
        .collect();
    let mut counts = [0.0f64; 64];
    let mut l2 = vec![0.0f32; n];
    for _ in 0..samples {
        let u = [rng.random::<f32>(), rng.random::<f32>()];
        let s = env.sample(u, &mut l).expect("a sample");
        // The sample's pdf and radiance are what pdf() and radiance() say.
        assert_eq!(s.pdf, env.pdf(s.dir), "{name}: sample pdf");
        env.radiance(s.dir, &mut l2);
        assert_eq!(l, l2, "{name}: sample radiance");
        let len = s.dir.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((len - 1.0).abs() < 1e-5, "{name}: direction length {len}");
        counts[fine_bin(s.dir)] += 1.0;
        for (&which, acc) in densities.iter().zip(&mut sums) {
            let pdf = density(which, s.dir, s.pdf);
            let est = f64::from(env.luminance(&l)) / pdf;
            acc.luminance.0 += est;
            acc.luminance.1 += est * est;
            for (a, &v) in acc.spectral.iter_mut().zip(&l) {
                let e = f64::from(v) / pdf;
                a.0 += e;
                a.1 += e * e;
            }
            let b = &mut acc.bins[bin(s.dir)];
            b.0 += 1.0 / pdf;
            b.1 += 1.0 / (pdf * pdf);
        }
    }
    let mut failures = Vec::new();
    for (&which, acc) in densities.iter().zip(&sums) {
        let mut failed = Vec::new();
        let normalisation = match which {
            Density::Own => pdf_integral,
            // Renormalised by construction, so the check sees the quadrature's own
            // error only.
            Density::TenPercentOff(_) => 1.0,
        };
        if (normalisation - 1.0).abs() >= 2e-3 {
            failed.push(format!("{name}: pdf integrates to {normalisation}"));
        }
        // E[L/pdf] = ∫ L dω.
        let (mean, error) = mean_and_error(acc.luminance.0, acc.luminance.1, samples);
        if (mean - luminance_integral).abs() >= 5.0 * error + 2e-3 * luminance_integral {
            failed.push(format!(
                "{name}: E[Y/pdf] = {mean} ± {error}, quadrature {luminance_integral}"
            ));
        }
        for (k, (&(s, s2), &q)) in acc.spectral.iter().zip(&spectral_integral).enumerate() {
            let (mean, error) = mean_and_error(s, s2, samples);
            if (mean - q).abs() >= 5.0 * error + 2e-3 * q {
                failed.push(format!(
                    "{name}: wavelength {k}: E[L/pdf] = {mean} ± {error}, quadrature {q}"
                ));
            }
        }
        // E[1_B/pdf] = solid angle of B: the sampled histogram matches the pdf.
        for (k, (&(s, s2), &omega)) in acc.bins.iter().zip(&bin_solid_angle).enumerate() {
            let (mean, error) = mean_and_error(s, s2, samples);
            if (mean - omega).abs() >= 5.0 * error + 2e-3 * omega {
                failed.push(format!(
                    "{name}: bin {k}: E[1/pdf] = {mean} ± {error}, solid angle {omega}"
                ));
            }
        }
        // The histogram of the samples against ∫_B pdf dω (Pearson's χ², 64 bins of
        // equal solid angle). Where the density varies strongly, counts see a
        // density error that E[1_B/pdf] (whose variance grows with ∫_B 1/pdf) does
        // not: a 10 % error over the ground of a map whose sky holds most of the
        // light, say.
        let probabilities: Vec<f64> = (0..64)
            .map(|k| {
                let centre = fine_bin_centre(k);
                let p = fine_probability[k];
                match which {
                    Density::Own => p / pdf_integral,
                    Density::TenPercentOff(_) => {
                        // `density` at the bin's centre scales its whole bin: each
                        // bin lies on one side of each half.
                        p * density(which, centre, 1.0)
                    }
                }
            })
            .collect();
        let test = bsdf_chi_square::pearson(&counts, &probabilities);
        println!(
            "{name}, {which:?}: histogram χ² {:.1}, p {:.2e}",
            test.chi2, test.p_value
        );
        if test.p_value <= 1e-3 {
            failed.push(format!("{name}: histogram {test:?}"));
        }
        failures.push(failed);
    }
    (failures, half_integral.map(|h| h / pdf_integral))
}

/// A direction inside fine bin `k` (its centre).
fn fine_bin_centre(k: usize) -> [f32; 3] {
    let (band, sector) = (k / 8, k % 8);
    let y = -1.0 + (band as f64 + 0.5) / 4.0;
    let a = 2.0 * PI * (sector as f64 + 0.5) / 8.0;
    let r = (1.0 - y * y).sqrt();
    [(r * a.sin()) as f32, y as f32, (r * a.cos()) as f32]
}

/// The statistical checks every environment must pass, and their negative
/// controls: a density 10 % off over the sky or over half of the azimuths must
/// fail them, wherever that half holds 10–90 % of the samples. (Beyond, the
/// renormalised density moves less than 1 % of the samples: the sky of the test
/// image holds 99.6 % of its light, and its ground's 10 % error passes.)
fn check_environment(env: &Environment, name: &str) {
    let densities = [
        Density::Own,
        Density::TenPercentOff(Half::Upper),
        Density::TenPercentOff(Half::East),
    ];
    let (failures, shares) = sampling_checks(env, name, &densities);
    assert!(failures[0].is_empty(), "{}", failures[0].join("\n"));
    let mut controls = 0;
    for ((which, failed), share) in densities.iter().zip(&failures).skip(1).zip(shares) {
        println!(
            "{name}, {which:?} (its half holds {:.1} % of the density): {} checks fail: {failed:#?}",
            100.0 * share,
            failed.len()
        );
        if (0.1..=0.9).contains(&share) {
            controls += 1;
            assert!(
                !failed.is_empty(),
                "{name}: the checks accept a density {which:?}"
            );
        }
    }
    assert!(controls > 0, "{name}: no negative control applies");
}

fn check_radiance_is_finite_and_non_negative(env: &Environment, name: &str) {
    let mut rng = Pcg64::seed_from_u64(11);
    let mut l = vec![0.0f32; env.channels().len()];
    let special = [
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [0.0, 0.0, 0.0],
        [3.0, 4.0, 0.0],
        [f32::NAN, 0.0, 1.0],
    ];
    let random = (0..20_000).map(|_| {
        let v: [f32; 3] = std::array::from_fn(|_| 2.0 * rng.random::<f32>() - 1.0);
        v
    });
    for d in special.into_iter().chain(random) {
        env.radiance(d, &mut l);
        let pdf = env.pdf(d);
        assert!(pdf.is_finite() && pdf >= 0.0, "{name}: pdf {pdf} at {d:?}");
        for &v in &l {
            assert!(v.is_finite() && v >= 0.0, "{name}: radiance {v} at {d:?}");
        }
    }
}

#[test]
fn environments_are_send_and_sync() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Environment>();
    assert_send_sync::<RgbUpsampler>();
}

#[test]
fn studio_samples_match_its_pdf_and_is_normalised() {
    let env = Environment::studio(&grid());
    assert_eq!(env.kind(), EnvironmentKind::Studio);
    check_environment(&env, "studio");
    check_radiance_is_finite_and_non_negative(&env, "studio");
    let floor = env.floor().expect("the studio has a floor");
    assert!(floor.reflectance.iter().all(|&r| r == 0.25));
}

#[test]
fn booth_samples_match_its_pdf_for_every_illuminant() {
    for illuminant in [Illuminant::D65, Illuminant::A, Illuminant::F11] {
        let env = Environment::booth(illuminant, &grid());
        let name = format!("booth {illuminant}");
        check_environment(&env, &name);
        check_radiance_is_finite_and_non_negative(&env, &name);
        assert!(env.floor().is_some());
    }
}

#[test]
fn outdoor_samples_match_its_pdf_and_the_sun_dominates() {
    let env = Environment::outdoor(&grid());
    check_environment(&env, "outdoor");
    check_radiance_is_finite_and_non_negative(&env, "outdoor");
    let sun = env.sun_direction().expect("a sun");
    assert!((f64::from(sun[1]) - 45f64.to_radians().sin()).abs() < 1e-6);
    let mut l = vec![0.0f32; env.channels().len()];
    env.radiance(sun, &mut l);
    let sun_luminance = env.luminance(&l);
    env.radiance([0.0, 1.0, 0.0], &mut l);
    let zenith = env.luminance(&l);
    assert!(
        sun_luminance > 1e4 * zenith,
        "sun {sun_luminance}, zenith {zenith}"
    );
    // The sky is bluer than the sun: more short-wave relative to long-wave.
    let first_last = |l: &[f32]| l[0] / l[l.len() - 1];
    let sun_ratio = {
        env.radiance(sun, &mut l);
        first_last(&l)
    };
    env.radiance([0.0, 1.0, 0.0], &mut l);
    assert!(first_last(&l) > sun_ratio);
}

#[test]
fn booth_under_a_rises_toward_red_and_d65_does_not() {
    let grid = WavelengthGrid::reference();
    let up = [0.0, 1.0, 0.0];
    let mut a = vec![0.0f32; grid.len()];
    let mut d65 = vec![0.0f32; grid.len()];
    let env_a = Environment::booth(Illuminant::A, &grid);
    let env_d65 = Environment::booth(Illuminant::D65, &grid);
    env_a.radiance(up, &mut a);
    env_d65.radiance(up, &mut d65);
    // Illuminant A (2856 K) rises monotonically over the visible range.
    assert!(a.windows(2).all(|w| w[1] > w[0]), "A is not increasing");
    let at = |l: &[f32], nm: usize| l[(nm - 380) / 5];
    assert!(at(&a, 700) / at(&a, 450) > 3.0);
    let r = at(&d65, 700) / at(&d65, 450);
    assert!((0.5..1.0).contains(&r), "D65 700/450 nm ratio {r}");
    // Same geometry, same normalisation: the diffuser has the same luminance.
    let (la, ld) = (env_a.luminance(&a), env_d65.luminance(&d65));
    assert!((la / ld - 1.0).abs() < 1e-3, "luminance {la} vs {ld}");
}

/// A `w` × `h` image whose pixel in `row`, `col` is `pixel(row, col)`.
fn image_of(w: usize, h: usize, pixel: impl Fn(usize, usize) -> [f32; 3]) -> RgbImage {
    let pixels = (0..w * h).map(|i| pixel(i / w, i % w)).collect();
    RgbImage::new(w, h, pixels).expect("valid image")
}

#[test]
fn image_environment_samples_match_its_pdf() {
    // A gradient sky with a bright spot, a darker ground; odd height so one row
    // straddles the horizon.
    let (w, h) = (64, 33);
    let image = image_of(w, h, |row, col| {
        let sky = row < h / 2;
        let base = if sky { 0.5 + 0.02 * row as f32 } else { 0.1 };
        let spot = if (8..12).contains(&row) && (40..44).contains(&col) {
            200.0
        } else {
            0.0
        };
        [base + spot, base + 0.5 * spot, 0.8 * base]
    });
    let env = Environment::from_rgb_image(&image, "test image", &grid()).expect("lit");
    assert_eq!(env.kind(), EnvironmentKind::Image);
    check_environment(&env, "image");
    check_radiance_is_finite_and_non_negative(&env, "image");
}

#[test]
fn wide_images_are_box_filtered_and_keep_their_light() {
    // 4100 px wide: filtered by 3 to 1367 px; a column of light stays lit.
    let image = image_of(4100, 6, |row, col| {
        let v = if row < 3 && col % 1000 < 90 {
            50.0
        } else {
            0.2
        };
        [v, v, v]
    });
    let env = Environment::from_rgb_image(&image, "wide", &grid()).expect("lit");
    check_environment(&env, "wide image");
}

#[test]
fn a_black_sky_cannot_be_normalised() {
    let pixels = (0..8 * 4)
        .map(|i| if i < 16 { [0.0; 3] } else { [1.0; 3] })
        .collect();
    let image = RgbImage::new(8, 4, pixels).expect("valid");
    let err = Environment::from_rgb_image(&image, "night.hdr", &grid()).unwrap_err();
    assert!(matches!(err, EnvironmentError::NoLight { .. }));
    assert!(err.to_string().contains("night.hdr"), "{err}");
}

#[test]
fn rgb_images_must_be_whole_and_finite() {
    assert!(RgbImage::new(2, 2, vec![[0.0; 3]; 3]).is_err());
    assert!(RgbImage::new(0, 0, vec![]).is_err());
    let err = RgbImage::new(1, 1, vec![[f32::NAN, 0.0, 0.0]]).unwrap_err();
    assert!(err.to_string().contains("not finite"), "{err}");
}

// ---------------------------------------------------------------------------
// Radiance .hdr

const HEADER: &[u8] =
    b"#?RADIANCE\n# written by the Coatlab tests\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n";

fn decoded(rgbe: [u8; 4]) -> [f32; 3] {
    if rgbe[3] == 0 {
        return [0.0; 3];
    }
    let f = 2f32.powi(i32::from(rgbe[3]) - 136);
    [rgbe[0], rgbe[1], rgbe[2]].map(|m| (f32::from(m) + 0.5) * f)
}

/// A pixel value per (row, column), varied across channels and exponents.
fn pixel(row: usize, col: usize) -> [u8; 4] {
    [
        (17 * row + 3 * col) as u8 | 0x80,
        (5 * col + 40) as u8,
        (200 - 7 * row) as u8,
        (128 + row % 3) as u8,
    ]
}

fn temp_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name)
}

/// Flat scanlines (width 4 < 8), one of them an old-style run.
fn flat_file() -> (Vec<u8>, Vec<[f32; 3]>) {
    let (w, h) = (4, 3);
    let mut bytes = HEADER.to_vec();
    bytes.extend_from_slice(format!("-Y {h} +X {w}\n").as_bytes());
    let mut expected = Vec::new();
    for row in 0..h {
        if row == 1 {
            // One pixel, then "repeat the previous pixel 3 times".
            let p = pixel(row, 0);
            bytes.extend_from_slice(&p);
            bytes.extend_from_slice(&[1, 1, 1, 3]);
            expected.extend(std::iter::repeat_n(decoded(p), w));
            continue;
        }
        for col in 0..w {
            let p = pixel(row, col);
            bytes.extend_from_slice(&p);
            expected.push(decoded(p));
        }
    }
    (bytes, expected)
}

/// New-style run-length scanlines (width 16): per channel, a run of the first 6
/// values then 10 literals.
fn rle_file() -> (Vec<u8>, Vec<[f32; 3]>) {
    let (w, h) = (16usize, 3usize);
    let mut bytes = HEADER.to_vec();
    bytes.extend_from_slice(format!("-Y {h} +X {w}\n").as_bytes());
    let mut expected = Vec::new();
    for row in 0..h {
        let line: Vec<[u8; 4]> = (0..w)
            .map(|col| pixel(row, if col < 6 { 0 } else { col }))
            .collect();
        bytes.extend_from_slice(&[2, 2, 0, w as u8]);
        for channel in 0..4 {
            bytes.extend_from_slice(&[128 + 6, line[0][channel]]);
            bytes.push(10);
            bytes.extend(line[6..].iter().map(|p| p[channel]));
        }
        expected.extend(line.iter().map(|&p| decoded(p)));
    }
    (bytes, expected)
}

#[test]
fn hdr_reader_reads_flat_and_run_length_scanlines() {
    for (name, (bytes, expected), width) in
        [("flat.hdr", flat_file(), 4), ("rle.hdr", rle_file(), 16)]
    {
        let path = temp_path(name);
        std::fs::write(&path, &bytes).expect("write test file");
        let image = read_hdr(&path).expect("readable");
        assert_eq!((image.width(), image.height()), (width, 3), "{name}");
        assert_eq!(image.pixels(), expected.as_slice(), "{name}");
        // And as an environment.
        let env = Environment::from_image(&path, &grid()).expect("an environment");
        assert_eq!(env.kind(), EnvironmentKind::Image);
    }
}

#[test]
fn hdr_reader_flips_bottom_up_files() {
    let (bytes, expected) = rle_file();
    let at = bytes
        .windows(4)
        .position(|w| w == b"-Y 3")
        .expect("resolution line");
    let mut flipped = bytes.clone();
    flipped[at] = b'+';
    let image = decode_hdr(&flipped, "up.hdr").expect("readable");
    let rows: Vec<&[[f32; 3]]> = expected.chunks(16).rev().collect();
    assert_eq!(image.pixels(), rows.concat().as_slice());
}

#[test]
fn hdr_reader_refuses_truncated_and_foreign_files_with_clear_messages() {
    for (name, (bytes, _)) in [("cut_rle.hdr", rle_file()), ("cut_flat.hdr", flat_file())] {
        let path = temp_path(name);
        std::fs::write(&path, &bytes[..bytes.len() - 5]).expect("write test file");
        let err = read_hdr(&path).unwrap_err();
        let message = err.to_string();
        assert!(
            matches!(err, ImageReadError::Truncated { row: 2, .. }),
            "{message}"
        );
        assert!(
            message.contains(name) && message.contains("truncated"),
            "{message}"
        );
    }
    let err = decode_hdr(b"P6\n4 4\n255\n", "photo.ppm").unwrap_err();
    assert!(err.to_string().contains("photo.ppm"), "{err}");
    assert!(matches!(err, ImageReadError::BadHeader { .. }));
    let err = decode_hdr(
        b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0",
        "x.hdr",
    )
    .unwrap_err();
    assert!(err.to_string().contains("32-bit_rle_xyze"), "{err}");
    // A run longer than the scanline.
    let mut bytes = HEADER.to_vec();
    bytes.extend_from_slice(b"-Y 1 +X 8\n");
    bytes.extend_from_slice(&[2, 2, 0, 8, 128 + 9, 1]);
    let err = decode_hdr(&bytes, "bad.hdr").unwrap_err();
    assert!(
        matches!(err, ImageReadError::CorruptScanline { .. }),
        "{err}"
    );

    let err = Environment::from_image(&temp_path("studio.exr"), &grid()).unwrap_err();
    assert!(
        matches!(err, EnvironmentError::Read(ImageReadError::Io { .. })),
        "{err}"
    );
    assert!(err.to_string().contains("studio.exr"), "{err}");
    let err = Environment::from_image(&temp_path("missing.hdr"), &grid()).unwrap_err();
    assert!(matches!(
        err,
        EnvironmentError::Read(ImageReadError::Io { .. })
    ));
    assert!(err.to_string().contains("missing.hdr"), "{err}");
}

// ---------------------------------------------------------------------------
// RGB upsampling

// The round trip of reflectances is tested in colour/upsampling.rs.

#[test]
fn rgb_emission_is_d65_shaped_with_unit_luminance_for_white() {
    let grid = WavelengthGrid::reference();
    let upsampler = RgbUpsampler::new(&grid);
    let env = Environment::studio(&grid);
    let mut e = vec![0.0f32; grid.len()];
    let mut r = vec![0.0f32; grid.len()];
    upsampler.emission(LinSrgb::new(1.0, 1.0, 1.0), &mut e);
    assert!((env.luminance(&e) - 1.0).abs() < 1e-5);
    upsampler.reflectance(LinSrgb::new(0.2, 0.7, 0.4), &mut r);
    upsampler.emission(LinSrgb::new(0.2, 0.7, 0.4), &mut e);
    let d65 = Illuminant::D65.spd(&grid);
    let ratios: Vec<f64> = (0..grid.len())
        .map(|k| f64::from(e[k]) / (f64::from(r[k]) * d65.values()[k]))
        .collect();
    assert!(ratios.iter().all(|q| (q / ratios[0] - 1.0).abs() < 1e-5));
    // White light stays close to D65: the bases sum to nearly 1.
    upsampler.reflectance(LinSrgb::new(1.0, 1.0, 1.0), &mut r);
    let (lo, hi) = r
        .iter()
        .fold((f32::MAX, 0.0f32), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(lo > 0.7 && hi < 1.5, "white reflectance spans {lo}–{hi}");
    // Negative components are clamped, never giving negative spectra.
    upsampler.emission(LinSrgb::new(-1.0, 0.5, -0.2), &mut e);
    assert!(e.iter().all(|&v| v >= 0.0));
}

// ---------------------------------------------------------------------------
// OpenEXR maps

/// An OpenEXR map gives the same lighting as the same pixels in a Radiance file
/// (up to RGBE's 8-bit mantissas), and broken EXR files are refused by name.
#[test]
fn exr_maps_light_the_scene_like_the_same_hdr_map() {
    let (width, height) = (64usize, 32usize);
    let texel = |x: usize, y: usize| -> [f32; 3] {
        let sky = 0.2 + 0.8 * (1.0 - y as f32 / height as f32);
        let sun = if (10..14).contains(&x) && (6..9).contains(&y) {
            40.0
        } else {
            0.0
        };
        [sky * 0.7 + sun, sky * 0.8 + sun, sky + sun * 0.9]
    };
    let exr_path = temp_path("sky.exr");
    exr::prelude::write_rgb_file(&exr_path, width, height, |x, y| {
        let [r, g, b] = texel(x, y);
        (r, g, b)
    })
    .expect("write exr");
    let pixels: Vec<[f32; 3]> = (0..height)
        .flat_map(|y| (0..width).map(move |x| texel(x, y)))
        .collect();
    let image = RgbImage::new(width, height, pixels).expect("image");
    let from_exr = Environment::from_image(&exr_path, &grid()).expect("exr map");
    let direct = Environment::from_rgb_image(&image, "direct", &grid()).expect("direct map");
    assert_eq!(from_exr.kind(), EnvironmentKind::Image);
    let (mut a, mut b) = (vec![0.0; grid().len()], vec![0.0; grid().len()]);
    for dir in [
        [0.0, 1.0, 0.0],
        [0.3, 0.5, 0.8],
        [-0.6, 0.2, -0.7],
        [0.1, 0.05, 0.99],
    ] {
        from_exr.radiance(dir, &mut a);
        direct.radiance(dir, &mut b);
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() <= 1e-5 * y.abs().max(1.0),
                "{dir:?}: {x} vs {y}"
            );
        }
        assert!((from_exr.pdf(dir) - direct.pdf(dir)).abs() <= 1e-4 * direct.pdf(dir));
    }

    // Truncated: the decoder's complaint, with the file's name.
    let bytes = std::fs::read(&exr_path).expect("read");
    let cut = temp_path("cut.exr");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    let err = Environment::from_image(&cut, &grid()).unwrap_err();
    assert!(
        matches!(err, EnvironmentError::Read(ImageReadError::BadExr { .. })),
        "{err}"
    );
    assert!(err.to_string().contains("cut.exr"), "{err}");
    // Not an EXR at all.
    let fake = temp_path("fake.exr");
    std::fs::write(&fake, b"#?RADIANCE\nnot an exr").expect("write");
    let err = Environment::from_image(&fake, &grid()).unwrap_err();
    assert!(
        matches!(err, EnvironmentError::Read(ImageReadError::BadExr { .. })),
        "{err}"
    );
}
