//! Independent verification of the body term (spec 4.1) by a Monte Carlo random walk.
//!
//! Photons go through the film by first principles only: Snell's law, the Fresnel
//! equations (written again here), Beer–Lambert absorption over the path length
//! h/cos θ′ and a Lambertian pigment. Nothing uses the summed series of spec 4.1 or
//! the coat integral C, so the tally checks `body_brdf` (with `c_integral`) and
//! `body_albedo` end to end. Comparisons are Z-tests against the binomial standard
//! error with a fixed seed; |Z| < 4 everywhere. See docs/verification.md.
//!
//! Estimator. A collimated beam of power Φi falls on an area A (irradiance Φi/A,
//! whatever θi). Radiance leaving is L = f·Φi/A, and the power it carries into the
//! solid angle dω from A is L cos θo dω A = f Φi cos θo dω. So the fraction of
//! photons leaving into a bin of outside polar angle is
//!     p_bin = ∫_bin f_body cos θo dω = 2π ∫_bin f_body cos θo sin θo dθo
//! (f_body does not depend on azimuth), and count/N estimates p_bin with
//! variance p_bin(1 − p_bin)/N.

use std::f64::consts::PI;
use std::sync::OnceLock;

use coatlab_core::paint::coat::{body_albedo, body_brdf, c_integral};
use coatlab_core::paint::fresnel::reflectance;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// Bins of the outside polar angle, 5° wide.
const BINS: usize = 18;
const BIN_WIDTH: f64 = PI / 2.0 / BINS as f64;
/// |Z| bound. With ~130 Z-scores the chance that a correct model trips it is ~1 %,
/// and the seed is fixed, so the test is deterministic.
const Z_MAX: f64 = 4.0;
/// A photon still inside after this many pigment bounces is counted as lost; none
/// should be (the longest walks here, n = 4 with ρ = 0.95, average ~10 bounces).
const MAX_BOUNCES: u32 = 10_000;

#[derive(Clone, Copy, Debug)]
struct Case {
    name: &'static str,
    n: f64,
    rho: f64,
    tau: f64,
    theta_i_deg: f64,
    photons: u64,
    seed: u64,
}

#[derive(Debug)]
struct Tally {
    photons: u64,
    specular: u64,
    escaped: u64,
    absorbed: u64,
    lost: u64,
    bins: [u64; BINS],
}

/// Snell and Fresnel at the surface for a ray in air at outside cosine `mu_out`:
/// returns (R, inside cosine).
fn enter(mu_out: f64, n: f64) -> (f64, f64) {
    let sin2_in = (1.0 - mu_out * mu_out) / (n * n);
    let mu_in = (1.0 - sin2_in).sqrt();
    (fresnel(mu_out, mu_in, n), mu_in)
}

/// Snell and Fresnel for a ray inside at cosine `mu_in` arriving at the surface:
/// `None` for total internal reflection, else (R, outside cosine).
fn leave(mu_in: f64, n: f64) -> Option<(f64, f64)> {
    let sin2_out = n * n * (1.0 - mu_in * mu_in);
    if sin2_out >= 1.0 {
        return None;
    }
    let mu_out = (1.0 - sin2_out).sqrt();
    Some((fresnel(mu_out, mu_in, n), mu_out))
}

/// Unpolarised Fresnel reflectance from the cosines on the air side and coat side;
/// the same value whichever way the light goes.
fn fresnel(mu_out: f64, mu_in: f64, n: f64) -> f64 {
    if n == 1.0 {
        // No interface. (The formula would give 1 at exact grazing, where Snell
        // rounds the inside cosine to 0 and rs is 0/0 in the limit.)
        return 0.0;
    }
    let rs = (mu_out - n * mu_in) / (mu_out + n * mu_in);
    let rp = (n * mu_out - mu_in) / (n * mu_out + mu_in);
    0.5 * (rs * rs + rp * rp)
}

fn simulate(case: &Case) -> Tally {
    let mut rng = Pcg64::seed_from_u64(case.seed);
    let mut tally = Tally {
        photons: case.photons,
        specular: 0,
        escaped: 0,
        absorbed: 0,
        lost: 0,
        bins: [0; BINS],
    };
    let (n, rho, tau) = (case.n, case.rho, case.tau);
    // Survival of one pass through the coat at inside cosine u (path length h/u).
    let survives = |rng: &mut Pcg64, u: f64| tau == 0.0 || rng.random::<f64>() < (-tau / u).exp();
    let (r_entry, mu_entry) = enter(case.theta_i_deg.to_radians().cos(), n);

    for _ in 0..case.photons {
        if rng.random::<f64>() < r_entry {
            tally.specular += 1; // first-surface reflection: f_spec, not the body
            continue;
        }
        let mut u = mu_entry; // inside cosine of the downward ray
        let mut fate = None;
        for _ in 0..MAX_BOUNCES {
            // Down through the coat, onto the pigment.
            if !survives(&mut rng, u) || rng.random::<f64>() >= rho {
                fate = Some(None);
                break;
            }
            // Lambertian re-emission: cosine-weighted, pdf 2u on [0, 1], so u² is
            // uniform. 1 − ξ keeps u > 0.
            u = (1.0 - rng.random::<f64>()).sqrt();
            // Up through the coat.
            if !survives(&mut rng, u) {
                fate = Some(None);
                break;
            }
            // At the surface: TIR or Fresnel reflection send it down again at the
            // same cosine; otherwise it leaves into air.
            if let Some((r, mu_out)) = leave(u, n)
                && rng.random::<f64>() >= r
            {
                fate = Some(Some(mu_out));
                break;
            }
        }
        match fate {
            Some(Some(mu_out)) => {
                tally.escaped += 1;
                let bin = (mu_out.acos() / BIN_WIDTH) as usize;
                tally.bins[bin.min(BINS - 1)] += 1;
            }
            Some(None) => tally.absorbed += 1,
            None => tally.lost += 1,
        }
    }
    tally
}

/// p_bin = 2π ∫ f_body cos θ sin θ dθ over each bin, by composite Simpson (64 panels
/// per bin: far below the statistical error).
fn expected_bins(case: &Case) -> [f64; BINS] {
    let c = c_integral(case.n, case.tau);
    let mu_i = case.theta_i_deg.to_radians().cos();
    let weighted = |theta: f64| {
        let (s, mu_o) = theta.sin_cos();
        body_brdf(case.rho, case.n, case.tau, c, mu_i, mu_o) * mu_o * s
    };
    let mut out = [0.0; BINS];
    const PANELS: usize = 64;
    for (k, p) in out.iter_mut().enumerate() {
        let a = k as f64 * BIN_WIDTH;
        let h = BIN_WIDTH / PANELS as f64;
        let mut sum = weighted(a) + weighted(a + BIN_WIDTH);
        for j in 1..PANELS {
            sum += weighted(a + j as f64 * h) * if j % 2 == 1 { 4.0 } else { 2.0 };
        }
        *p = 2.0 * PI * sum * h / 3.0;
    }
    out
}

/// Z-score of a binomial count against probability p.
fn z_score(count: u64, photons: u64, p: f64) -> f64 {
    let n = photons as f64;
    (count as f64 - n * p) / (n * p * (1.0 - p)).sqrt()
}

/// Z-scores of every bin, and of the total escaped fraction against `albedo`, with
/// the model's probabilities multiplied by `scale` (1 for the test proper).
fn z_scores(tally: &Tally, expected: &[f64; BINS], albedo: f64, scale: f64) -> (Vec<f64>, f64) {
    let bins = tally
        .bins
        .iter()
        .zip(expected)
        .map(|(&count, &p)| z_score(count, tally.photons, p * scale))
        .collect();
    (bins, z_score(tally.escaped, tally.photons, albedo * scale))
}

fn run_case(case: &Case) -> Tally {
    let tally = simulate(case);
    assert_eq!(
        tally.lost, 0,
        "{}: photons still bouncing after {MAX_BOUNCES}",
        case.name
    );
    assert_eq!(
        tally.specular + tally.escaped + tally.absorbed,
        tally.photons,
        "{}: photon count not conserved",
        case.name
    );
    tally
}

/// Simulates `case` and Z-tests the bins and the albedo.
fn check_case(case: &Case) {
    check_tally(case, &run_case(case));
}

/// Z-tests a tally's bins and escaped fraction against the model; prints the scores.
fn check_tally(case: &Case, tally: &Tally) {
    let expected = expected_bins(case);
    let mu_i = case.theta_i_deg.to_radians().cos();
    let albedo = body_albedo(case.rho, case.n, case.tau, mu_i);

    // body_albedo must be the hemispherical integral of body_brdf (deterministic;
    // Simpson's error is ~1e-12 here).
    let summed: f64 = expected.iter().sum();
    assert!(
        (summed - albedo).abs() <= 1e-9 * albedo,
        "{}: ∫ body_brdf cos θo dω = {summed}, body_albedo = {albedo}",
        case.name
    );

    let (bins, z_total) = z_scores(tally, &expected, albedo, 1.0);
    let chi2: f64 = bins.iter().map(|z| z * z).sum();
    let z_max = bins.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    println!(
        "{}: escaped {:.6} (body_albedo {albedo:.6}, Z = {z_total:+.2}); \
         bins max |Z| = {z_max:.2}, Σ Z² = {chi2:.1} over {BINS} bins; Z = {}",
        case.name,
        tally.escaped as f64 / tally.photons as f64,
        bins.iter()
            .map(|z| format!("{z:+.2}"))
            .collect::<Vec<_>>()
            .join(" "),
    );
    let bad: Vec<String> = bins
        .iter()
        .enumerate()
        .filter(|(_, z)| z.abs() >= Z_MAX || !z.is_finite())
        .map(|(k, z)| {
            format!(
                "θo in [{}°, {}°): count {}, expected {:.1}, Z = {z:.2}",
                5 * k,
                5 * (k + 1),
                tally.bins[k],
                expected[k] * tally.photons as f64
            )
        })
        .collect();
    assert!(bad.is_empty(), "{}:\n{}", case.name, bad.join("\n"));
    assert!(
        z_total.abs() < Z_MAX,
        "{}: escaped fraction Z = {z_total:.2}",
        case.name
    );
}

const REFERENCE: Case = Case {
    name: "n 1.5, ρ 0.8, τ 0.05, θi 30°",
    n: 1.5,
    rho: 0.8,
    tau: 0.05,
    theta_i_deg: 30.0,
    photons: 10_000_000,
    seed: 1,
};

/// The reference case's tally, shared by its test and the negative control.
fn reference_tally() -> &'static Tally {
    static TALLY: OnceLock<Tally> = OnceLock::new();
    TALLY.get_or_init(|| run_case(&REFERENCE))
}

#[test]
fn reference_case() {
    check_tally(&REFERENCE, reference_tally());
}

#[test]
fn estimator_detects_a_two_percent_error() {
    // Negative control: the same tally against body_brdf × 1.02 must fail the test,
    // or the test above could not fail either.
    let tally = reference_tally();
    let expected = expected_bins(&REFERENCE);
    let albedo = body_albedo(
        REFERENCE.rho,
        REFERENCE.n,
        REFERENCE.tau,
        30f64.to_radians().cos(),
    );
    let (bins, z_total) = z_scores(tally, &expected, albedo, 1.02);
    let failing = bins.iter().filter(|z| z.abs() >= Z_MAX).count();
    println!("×1.02: escaped Z = {z_total:+.2}, {failing} of {BINS} bins with |Z| ≥ {Z_MAX}");
    assert!(
        z_total.abs() >= 10.0,
        "2 % off in albedo gave only Z = {z_total:.2}"
    );
    assert!(
        failing >= BINS / 2,
        "2 % off in f_body flagged only {failing} bins"
    );
}

#[test]
fn strong_total_internal_reflection() {
    // n = 2.5: 84 % of the pigment's light is trapped at τ = 0 (C/π ≈ 0.87).
    check_case(&Case {
        name: "n 2.5, ρ 0.8, τ 0.05, θi 30°",
        n: 2.5,
        seed: 2,
        photons: 8_000_000,
        ..REFERENCE
    });
}

#[test]
fn thick_absorbing_coat() {
    check_case(&Case {
        name: "n 1.5, ρ 0.8, τ 1, θi 30°",
        tau: 1.0,
        seed: 3,
        photons: 8_000_000,
        ..REFERENCE
    });
}

#[test]
fn grazing_incidence() {
    check_case(&Case {
        name: "n 1.5, ρ 0.8, τ 0.05, θi 80°",
        theta_i_deg: 80.0,
        seed: 4,
        photons: 8_000_000,
        ..REFERENCE
    });
}

#[test]
fn no_interface() {
    // n = 1: no Fresnel, no TIR; f_body = ρ/π e^{−τ(1/μi + 1/μo)}.
    check_case(&Case {
        name: "n 1, ρ 0.7, τ 0.3, θi 60°",
        n: 1.0,
        rho: 0.7,
        tau: 0.3,
        theta_i_deg: 60.0,
        seed: 5,
        photons: 6_000_000,
    });
}

#[test]
fn dense_bright_coat_at_normal_incidence() {
    // Many round trips (ρC/π ≈ 0.92): long walks test the geometric series' sum.
    check_case(&Case {
        name: "n 4, ρ 0.95, τ 0.01, θi 0°",
        n: 4.0,
        rho: 0.95,
        tau: 0.01,
        theta_i_deg: 0.0,
        seed: 6,
        photons: 6_000_000,
    });
}

#[test]
fn white_furnace() {
    // ρ = 1, τ = 0: nothing is absorbed, so every photon ends specular or escaped,
    // and the model must give body albedo + R(μi) = 1.
    let case = Case {
        name: "white furnace: n 1.5, ρ 1, τ 0, θi 45°",
        n: 1.5,
        rho: 1.0,
        tau: 0.0,
        theta_i_deg: 45.0,
        seed: 7,
        photons: 8_000_000,
    };
    let tally = run_case(&case);
    assert_eq!(tally.absorbed, 0);
    assert_eq!(tally.specular + tally.escaped, tally.photons);
    for theta_deg in [0.0f64, 30.0, 45.0, 60.0, 80.0, 89.0] {
        let mu = theta_deg.to_radians().cos();
        for n in [1.0, 1.5, 2.5, 4.0] {
            let total = body_albedo(1.0, n, 0.0, mu) + reflectance(mu, n);
            assert!(
                (total - 1.0).abs() <= 1e-9,
                "n = {n}, θi = {theta_deg}°: body albedo + R = {total}"
            );
        }
    }
    check_tally(&case, &tally);
}

#[test]
fn walk_fresnel_agrees_with_the_implementation() {
    // Not a test of the body term: it localises a failure above to Fresnel or not.
    for n in [1.0, 1.3, 1.5, 2.5, 4.0] {
        for i in 0..=90 {
            let mu = (f64::from(i)).to_radians().cos();
            let (r, _) = enter(mu, n);
            let r_impl = reflectance(mu, n);
            assert!(
                (r - r_impl).abs() <= 1e-14,
                "n = {n}, θ = {i}°: {r} vs {r_impl}"
            );
        }
    }
}
