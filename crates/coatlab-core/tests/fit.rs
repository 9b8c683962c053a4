//! Fitting a design to a measurement (coatlab_core::fit): a design's own virtual
//! measurement, written as CGATS and CxF3 and read back, is fitted back to the
//! design's ρ(λ); noisy, unreachable and colour-only targets.

#[path = "support/measurement_files.rs"]
mod measurement_files;

use coatlab_core::colour::cie::{Illuminant, Observer, summation_weights};
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::tolerance::Tolerance;
use coatlab_core::design::{PaintDesign, presets};
use coatlab_core::fit::{Beyond, Method, SMOOTHNESS_WEIGHT, fit_albedo, report};
use coatlab_core::instruments::{self, measure};
use coatlab_core::measurement::{self, Geometry};
use measurement_files::{Spectra, as_cgats, as_cxf, lab_only_cgats};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn preset(slug: &str) -> PaintDesign {
    presets::by_slug(slug).expect("preset").design
}

/// The design's five-angle reflectance on every `step`-th grid wavelength, and its ρ
/// there (as the model holds it).
fn virtual_measurement(design: &PaintDesign, step: usize) -> (Spectra, Vec<f64>) {
    let model = design.model(WavelengthGrid::reference()).expect("model");
    let m = measure(&model).expect("spectral");
    let keep: Vec<usize> = (0..m.wavelength_nm.len()).step_by(step).collect();
    let w = keep.iter().map(|&i| m.wavelength_nm[i]).collect();
    let angles = m
        .angles
        .iter()
        .map(|a| {
            (
                a.aspecular_deg,
                keep.iter().map(|&i| a.reflectance_factor[i]).collect(),
            )
        })
        .collect();
    let rho = keep.iter().map(|&i| model.albedo()[i]).collect();
    ((w, angles), rho)
}

fn read(text: &str, file: &str) -> measurement::Measurement {
    measurement::read(text.as_bytes(), file).expect("readable")
}

/// `spectra` written as CGATS and as CxF3 and read back, each with its file name.
fn in_both_formats(name: &str, spectra: &Spectra) -> [(measurement::Measurement, &'static str); 2] {
    [
        (read(&as_cgats(name, spectra), "v.cgats"), "v.cgats"),
        (read(&as_cxf(name, spectra), "v.cxf"), "v.cxf"),
    ]
}

fn only(spectra: &Spectra, aspecular: f64) -> Spectra {
    (
        spectra.0.clone(),
        spectra
            .1
            .iter()
            .filter(|(a, _)| *a == aspecular)
            .cloned()
            .collect(),
    )
}

#[test]
fn one_geometry_noiseless_is_fitted_back_to_within_1e_4() {
    for slug in ["signal-red", "deep-blue", "pure-white", "jet-black"] {
        let design = preset(slug);
        let (spectra, rho) = virtual_measurement(&design, 1);
        for aspecular in [45.0, 15.0, 110.0] {
            let single = only(&spectra, aspecular);
            for (m, file) in in_both_formats(slug, &single) {
                let standard = m.select(None).expect("one standard");
                let fit = fit_albedo(&design, &standard).expect("fit");
                assert_eq!(fit.method, Method::ClosedForm);
                assert!(fit.unreachable.is_empty(), "{slug}: {:?}", fit.unreachable);
                assert_eq!(fit.smoothness_weight, None);
                let worst = fit
                    .albedo
                    .iter()
                    .zip(&rho)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(worst < 1e-4, "{slug} {file} as{aspecular}: {worst}");
                // The fitted design keeps the coat, and covers the grid: no note.
                assert_eq!(fit.design.thickness_um, design.thickness_um);
                assert!(fit.notes.is_empty(), "{:?}", fit.notes);
            }
        }
    }
}

#[test]
fn several_angles_noiseless_fit_within_0_05_de00_at_every_angle() {
    for slug in ["signal-red", "deep-blue", "sunflower-yellow"] {
        let design = preset(slug);
        // 10 nm steps, as instruments write.
        let (spectra, rho) = virtual_measurement(&design, 2);
        for (m, file) in in_both_formats(slug, &spectra) {
            let standard = m.select(None).expect("one standard");
            let fit = fit_albedo(&design, &standard).expect("fit");
            assert_eq!(fit.method, Method::LeastSquares);
            assert_eq!(fit.smoothness_weight, Some(SMOOTHNESS_WEIGHT));
            assert!(fit.unreachable.is_empty(), "{:?}", fit.unreachable);
            let r = report(&fit, &standard, &Tolerance::default()).expect("report");
            assert_eq!(r.comparison.angles.len(), 5);
            for a in &r.comparison.angles {
                assert!(a.difference.de00 <= 0.05, "{slug} {file}: {a:?}");
            }
            // ρ itself: the smoothness term's bias is small inside, larger at the two
            // end points, which have one neighbour (deep blue's 380 nm kink: 0.007).
            let error: Vec<f64> = fit
                .albedo
                .iter()
                .zip(&rho)
                .map(|(a, b)| (a - b).abs())
                .collect();
            let inner = error[1..error.len() - 1]
                .iter()
                .fold(0.0, |a: f64, b| a.max(*b));
            assert!(inner < 5e-4, "{slug}: ρ off by {inner}");
            assert!(
                error[0] < 1e-2 && error[error.len() - 1] < 1e-2,
                "{slug}: {error:?}"
            );
            assert_eq!(r.spectral_rms.len(), 5);
            assert!(r.spectral_rms.iter().all(|(_, rms)| *rms < 1e-3));
        }
    }
}

#[test]
fn noisy_measurements_are_fitted_to_within_their_noise() {
    // 0.5 % multiplicative noise, independent per wavelength and angle. Criterion:
    // the fit explains the data down to the noise — at every angle the residual RMS
    // is at most 1.25 times the RMS of the noise added there (with one ρ per
    // wavelength for five readings an unbiased fit leaves √(4/5) of it; the
    // smoothness term adds a little bias) — and ρ is recovered to within the noise
    // level (the RMS difference from the noiseless fit ≤ 0.5 % of ρ's RMS).
    let mut rng = Pcg64::seed_from_u64(19);
    for slug in ["signal-red", "deep-blue", "pure-white"] {
        let design = preset(slug);
        let ((w, angles), rho) = virtual_measurement(&design, 2);
        let mut noise_rms = Vec::new();
        let noisy: Vec<(f64, Vec<f64>)> = angles
            .iter()
            .map(|(a, r)| {
                let mut sum = 0.0;
                let v: Vec<f64> = r
                    .iter()
                    .map(|x| {
                        // Uniform with the standard deviation 0.5 %.
                        let e = 0.005 * 3f64.sqrt() * (2.0 * rng.random::<f64>() - 1.0);
                        sum += (x * e).powi(2);
                        x * (1.0 + e)
                    })
                    .collect();
                noise_rms.push((sum / r.len() as f64).sqrt());
                (*a, v)
            })
            .collect();
        let clean = read(&as_cgats(slug, &(w.clone(), angles.clone())), "clean.cgats");
        let clean = fit_albedo(&design, &clean.select(None).expect("standard")).expect("fit");
        let m = read(&as_cgats(slug, &(w, noisy)), "noisy.cgats");
        let standard = m.select(None).expect("one standard");
        let fit = fit_albedo(&design, &standard).expect("fit");
        let r = report(&fit, &standard, &Tolerance::default()).expect("report");
        for ((geometry, rms), noise) in r.spectral_rms.iter().zip(&noise_rms) {
            assert!(
                *rms <= 1.25 * noise,
                "{slug} {geometry}: residual {rms} vs noise {noise}"
            );
        }
        let error: f64 = fit
            .albedo
            .iter()
            .zip(&clean.albedo)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / rho.len() as f64;
        let scale: f64 = rho.iter().map(|x| x * x).sum::<f64>() / rho.len() as f64;
        assert!(
            error.sqrt() <= 0.005 * scale.sqrt(),
            "{slug}: ρ RMS error {} vs {}",
            error.sqrt(),
            0.005 * scale.sqrt()
        );
        // Still within the default tolerance everywhere.
        assert!(r.comparison.angles.iter().all(|a| a.difference.de00 < 1.0));
    }
}

#[test]
fn an_unreachable_target_is_reported_by_wavelength_and_angle() {
    let design = preset("pure-white");
    let (spectra, _) = virtual_measurement(&design, 2);
    let mut single = only(&spectra, 45.0);
    // Brighter than any pigment under this coat from 600 nm on.
    for (nm, v) in single.0.iter().zip(single.1[0].1.iter_mut()) {
        if *nm >= 600.0 {
            *v = 1.2;
        }
    }
    let m = read(&as_cgats("white", &single), "bright.cgats");
    let standard = m.select(None).expect("standard");
    let fit = fit_albedo(&design, &standard).expect("fit");
    let expected: Vec<f64> = single.0.iter().copied().filter(|nm| *nm >= 600.0).collect();
    let found: Vec<f64> = fit.unreachable.iter().map(|u| u.wavelength_nm).collect();
    assert_eq!(found, expected);
    for u in &fit.unreachable {
        assert_eq!(u.beyond, Beyond::Brighter);
        assert_eq!(u.geometry, Geometry::directional(45.0, 45.0));
        assert!(u.limit < u.target);
        assert!(u.to_string().contains("brighter than ρ = 1"), "{u}");
    }
    // ρ is kept in [0, 1]: at 1 where the target is too bright.
    for (r, nm) in fit.albedo.iter().zip(&single.0) {
        assert!(
            (0.0..=1.0).contains(r) && (*nm < 600.0 || *r == 1.0),
            "{nm} nm: ρ = {r}"
        );
    }

    let mut near_specular = only(&spectra, 15.0);
    let at = near_specular
        .0
        .iter()
        .position(|nm| *nm == 450.0)
        .expect("450 nm");
    // Below zero, as black-sample noise reads: below the surface reflection.
    near_specular.1[0].1[at] = -0.01;
    let m = read(&as_cgats("white", &near_specular), "dark.cgats");
    let standard = m.select(None).expect("standard");
    let fit = fit_albedo(&design, &standard).expect("fit");
    assert_eq!(fit.unreachable.len(), 1, "{:?}", fit.unreachable);
    let u = &fit.unreachable[0];
    assert_eq!((u.wavelength_nm, u.beyond), (450.0, Beyond::Darker));
    assert_eq!(u.geometry, Geometry::directional(45.0, 15.0));
    assert_eq!(fit.albedo[at], 0.0);
}

#[test]
fn a_narrow_measurement_is_extended_flat_and_says_so() {
    let design = preset("signal-red");
    let (spectra, rho) = virtual_measurement(&design, 2);
    // 420–680 nm only.
    let keep: Vec<usize> = (0..spectra.0.len())
        .filter(|&i| (420.0..=680.0).contains(&spectra.0[i]))
        .collect();
    let narrow: Spectra = (
        keep.iter().map(|&i| spectra.0[i]).collect(),
        vec![(45.0, keep.iter().map(|&i| spectra.1[2].1[i]).collect())],
    );
    let m = read(&as_cgats("red", &narrow), "narrow.cgats");
    let standard = m.select(None).expect("standard");
    let fit = fit_albedo(&design, &standard).expect("fit");
    assert!(
        fit.notes
            .iter()
            .any(|n| n.contains("outside the measured 420–680 nm")),
        "{:?}",
        fit.notes
    );
    let table = &fit.design.albedo;
    assert_eq!(table.wavelengths_nm().first(), Some(&380.0));
    assert_eq!(table.wavelengths_nm().last(), Some(&780.0));
    let first = keep[0];
    assert!((table.values()[0] - rho[first]).abs() < 1e-4);
    assert_eq!(table.values()[0], table.values()[1]);
}

#[test]
fn a_lab_only_target_is_reproduced_by_the_smoothest_curve() {
    let design = preset("signal-red");
    let model = design.model(WavelengthGrid::reference()).expect("model");
    let w: Vec<f64> = WavelengthGrid::reference().wavelengths_nm().collect();
    let reading = instruments::directional_reading(&model, 45.0, 45.0).expect("spectral");
    let weights =
        summation_weights(Illuminant::D50, Observer::Cie1931TwoDegree, &w).expect("weights");
    let lab = weights.lab(&reading.reflectance_factor);
    // The file states the colour to two decimals, as instruments print it.
    let round = |x: f64| (x * 100.0).round() / 100.0;
    let stated = [round(lab.l), round(lab.a), round(lab.b)];
    let m = read(
        &lab_only_cgats("red", stated, "D50", "2 degree"),
        "lab.cgats",
    );
    let standard = m.select(None).expect("standard");
    let fit = fit_albedo(&design, &standard).expect("fit");
    assert_eq!(fit.method, Method::SmoothestMetamer);
    assert!(
        fit.notes.iter().any(|n| n.contains("metamer")),
        "{:?}",
        fit.notes
    );
    let r = report(&fit, &standard, &Tolerance::default()).expect("report");
    let a = &r.comparison.angles[0];
    assert_eq!(a.conditions, "D50/CIE 1931 2°");
    assert!(a.difference.de00 < 0.01, "{a:?}");
    // Smoothest: the design's own ρ has the same colour (to the rounding) and is
    // rougher.
    let roughness = |rho: &[f64]| {
        rho.windows(3)
            .map(|v| (v[0] - 2.0 * v[1] + v[2]).powi(2))
            .sum::<f64>()
    };
    assert!(
        roughness(&fit.albedo) < roughness(model.albedo()),
        "{} vs {}",
        roughness(&fit.albedo),
        roughness(model.albedo())
    );
    assert!(fit.albedo.iter().all(|r| (0.0..=1.0).contains(r)));
}

#[test]
fn a_standard_with_nothing_directional_is_refused_by_name() {
    let text = "CGATS.17\nNUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nSAMPLE_NAME GEOMETRY SPECTRAL_NM_400 SPECTRAL_NM_700\n\
                END_DATA_FORMAT\nNUMBER_OF_SETS 1\nBEGIN_DATA\n\"Grey\" \"d:8 SCI\" 0.4 0.4\nEND_DATA\n";
    let m = read(text, "sphere.cgats");
    let standard = m.select(None).expect("standard");
    let e = fit_albedo(&preset("signal-red"), &standard).expect_err("nothing to fit");
    assert!(e.to_string().contains("\"Grey\""), "{e}");
    assert!(e.to_string().contains("sphere"), "{e}");
}
