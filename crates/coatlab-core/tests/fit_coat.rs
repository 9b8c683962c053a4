//! Fitting a design with its coat free (coatlab_core::fit with `--free` naming
//! gloss, h, k or n): a design's virtual measurement — the five multi-angle
//! spectra and the three glossmeter readings, written as CGATS.17 and read back —
//! fitted back from a perturbed start; the same with 0.5 % noise; what the
//! physics leaves undetermined.
//!
//! Identifiability: the readings depend on h and k only through τ = k·h, τ trades
//! off partly against ρ, the gloss partly against n. So these tests judge the
//! readings a fit reproduces (ΔE00, spectral RMS, gloss units), and a parameter
//! only where the readings pin it down (the gloss, from gloss readings).

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::tolerance::Tolerance;
use coatlab_core::design::{Absorption, PaintDesign, RefractiveIndex, presets};
use coatlab_core::fit::{FitError, FitRequest, FreeParameters, Method, fit, report};
use coatlab_core::instruments::measure;
use coatlab_core::measurement::cgats_write::write_cgats;
use coatlab_core::measurement::{
    self, Geometry, GlossValue, Reflectance, Sample, StatedColour, StatedValue,
};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn preset(slug: &str) -> PaintDesign {
    presets::by_slug(slug).expect("preset").design
}

/// The design's five-angle reflectance at 10 nm (as instruments write it) and its
/// total gloss at 20°, 60° and 85°, as one standard's samples; `noise` draws a
/// relative error for each value.
fn virtual_measurement(design: &PaintDesign, mut noise: impl FnMut() -> f64) -> Vec<Sample> {
    let model = design.model(WavelengthGrid::reference()).expect("model");
    let m = measure(&model).expect("spectral");
    let mut samples = m.multi_angle_samples(&design.name, 2).expect("samples");
    // The gloss repeats on every row: one noisy reading per geometry, repeated.
    let gloss: Vec<GlossValue> = samples[0]
        .gloss
        .iter()
        .map(|g| GlossValue {
            gu: g.gu * (1.0 + noise()),
            ..*g
        })
        .collect();
    for s in &mut samples {
        let spectrum = s.spectrum.as_ref().expect("spectrum");
        let noisy = spectrum
            .factors()
            .iter()
            .map(|r| r * (1.0 + noise()))
            .collect();
        s.spectrum =
            Some(Reflectance::new(spectrum.wavelengths_nm().to_vec(), noisy).expect("valid"));
        s.gloss.clone_from(&gloss);
    }
    samples
}

/// Through a CGATS.17 file and back, as a measurement reaches `coatlab fit`.
fn as_file(samples: &[Sample]) -> measurement::Measurement {
    let text = write_cgats("test", samples).expect("writable");
    measurement::read(text.as_bytes(), "virtual.cgats").expect("readable")
}

/// The design with its coat moved: gloss −6 GU, h × 1.3, k × 2, n + 0.03.
fn perturbed(design: &PaintDesign) -> PaintDesign {
    let mut start = design.clone();
    start.gloss.gu -= 6.0;
    start.thickness_um *= 1.3;
    start.absorption_per_um = match &design.absorption_per_um {
        Absorption::Constant(k) => Absorption::Constant(2.0 * k),
        Absorption::Table(t) => Absorption::Table(
            coatlab_core::colour::spectrum::TabulatedSpectrum::new(
                t.wavelengths_nm().to_vec(),
                t.values().iter().map(|k| 2.0 * k).collect(),
            )
            .expect("table"),
        ),
    };
    start.refractive_index = match &design.refractive_index {
        RefractiveIndex::Cauchy { a, b_um2 } => RefractiveIndex::Cauchy {
            a: a + 0.03,
            b_um2: *b_um2,
        },
        other => other.clone(),
    };
    start
}

fn all_free() -> FitRequest {
    FitRequest {
        free: FreeParameters::parse("rho,gloss,h,k,n").expect("names"),
    }
}

fn worst_de00(r: &coatlab_core::fit::FitReport) -> f64 {
    r.comparison
        .angles
        .iter()
        .map(|a| a.difference.de00)
        .fold(0.0, f64::max)
}

#[test]
fn a_virtual_measurement_is_fitted_back_with_the_coat_free() {
    // A glossy paint with the normalised lobe and a satin one with the paper's
    // lobe, specified at 60°, whose near-specular angles see the lobe.
    for slug in ["signal-red", "satin-grey"] {
        let design = preset(slug);
        let m = as_file(&virtual_measurement(&design, || 0.0));
        let standard = m.select(None).expect("one standard");
        let start = perturbed(&design);
        let fitted = fit(&start, &standard, &all_free()).expect("fit");
        assert_eq!(fitted.method, Method::LeastSquares);
        assert_eq!(fitted.free.names(), ["rho", "gloss", "h", "k", "n"]);
        let names: Vec<&str> = fitted.coat.iter().map(|p| p.name).collect();
        assert_eq!(names, ["n", "gloss", "h", "k"]);
        for p in &fitted.coat {
            assert!(p.lower <= p.fitted && p.fitted <= p.upper, "{slug}: {p}");
        }
        let r = report(&fitted, &standard, &Tolerance::default()).expect("report");
        assert_eq!(r.comparison.angles.len(), 5);
        for a in &r.comparison.angles {
            assert!(a.difference.de00 <= 0.05, "{slug}: {a:?}");
        }
        assert!(r.spectral_rms.iter().all(|(_, rms)| *rms < 1e-3), "{r:?}");
        // The three gloss readings (repeated on each angle's row) within 0.1 GU.
        assert_eq!(r.comparison.gloss.len(), 15);
        for g in &r.comparison.gloss {
            assert!((g.design_gu - g.target_gu).abs() < 0.1, "{slug}: {g:?}");
        }
        // The coat mattered: ρ alone under the perturbed coat does worse.
        let rho_alone = fit(&start, &standard, &FitRequest::default()).expect("ρ alone");
        let before = report(&rho_alone, &standard, &Tolerance::default()).expect("report");
        assert!(
            worst_de00(&before) > 2.0 * worst_de00(&r),
            "{slug}: ρ alone {} vs coat free {}",
            worst_de00(&before),
            worst_de00(&r)
        );
        // h and k both free: only τ = k·h is determined, and the report says so.
        assert!(
            fitted.notes.iter().any(|n| n.contains("h and k trade off")),
            "{:?}",
            fitted.notes
        );
    }
}

#[test]
fn the_gloss_alone_is_fitted_back_from_the_gloss_readings() {
    // With ρ and the coat right, the gloss readings pin the gloss down.
    let design = preset("signal-red");
    let m = as_file(&virtual_measurement(&design, || 0.0));
    let standard = m.select(None).expect("one standard");
    let mut start = design.clone();
    start.gloss.gu -= 6.0;
    let request = FitRequest {
        free: FreeParameters::parse("gloss").expect("names"),
    };
    let fitted = fit(&start, &standard, &request).expect("fit");
    assert_eq!(fitted.coat.len(), 1);
    assert!(
        (fitted.design.gloss.gu - design.gloss.gu).abs() < 0.05,
        "{} vs {}",
        fitted.design.gloss.gu,
        design.gloss.gu
    );
    // ρ was not free: the start's table is kept, and no smoothness was applied.
    assert_eq!(fitted.design.albedo, start.albedo);
    assert_eq!(fitted.smoothness_weight, None);
}

#[test]
fn noisy_measurements_are_fitted_to_within_their_noise_with_the_coat_free() {
    // 0.5 % multiplicative noise, independent per wavelength, angle and gloss
    // reading. Criterion: at every angle the residual RMS against the noisy data is
    // at most 1.25 times the RMS of the noise added there (a fit with fewer
    // parameters than readings leaves a little less than the noise; the smoothness
    // term adds a little bias), and the fitted readings are closer to the noiseless
    // ones than the data are (RMS(fit − truth) below the noise RMS): the fit
    // follows the paint, not the noise.
    let mut rng = Pcg64::seed_from_u64(1919);
    let design = preset("signal-red");
    // Uniform with the standard deviation 0.5 %.
    let samples = virtual_measurement(&design, || {
        0.005 * 3f64.sqrt() * (2.0 * rng.random::<f64>() - 1.0)
    });
    let clean = virtual_measurement(&design, || 0.0);
    let m = as_file(&samples);
    let standard = m.select(None).expect("standard");
    let fitted = fit(&perturbed(&design), &standard, &all_free()).expect("fit");
    let r = report(&fitted, &standard, &Tolerance::default()).expect("report");
    let truth = measurement::Standard {
        name: &design.name,
        readings: clean.iter().collect(),
    };
    let against_truth = report(&fitted, &truth, &Tolerance::default()).expect("report");
    for (((g, rms), (_, off)), (noisy, clean)) in r
        .spectral_rms
        .iter()
        .zip(&against_truth.spectral_rms)
        .zip(samples.iter().zip(&clean))
    {
        let (a, b) = (
            noisy.spectrum.as_ref().expect("spectrum").factors(),
            clean.spectrum.as_ref().expect("spectrum").factors(),
        );
        let noise =
            (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
        assert!(*rms <= 1.25 * noise, "{g}: residual {rms} vs noise {noise}");
        assert!(*off < noise, "{g}: fit − truth {off} vs noise {noise}");
    }
    assert!(
        worst_de00(&against_truth) < 0.3,
        "{:?}",
        against_truth.comparison.angles
    );
}

#[test]
fn colours_alone_cannot_fix_a_coat() {
    let design = preset("signal-red");
    let model = design.model(WavelengthGrid::reference()).expect("model");
    let m = measure(&model).expect("spectral");
    let sample = Sample {
        name: "red".to_owned(),
        id: None,
        geometry: Geometry::directional(45.0, 45.0),
        spectrum: None,
        colour: Some(StatedColour {
            value: StatedValue::Lab(m.angles[2].lab),
            illuminant: None,
            observer: None,
        }),
        gloss: Vec::new(),
    };
    let standard = measurement::Standard {
        name: "red",
        readings: vec![&sample],
    };
    let e = fit(&design, &standard, &all_free()).expect_err("colours only");
    assert!(matches!(e, FitError::CoatNeedsSpectra { .. }), "{e}");
    assert!(e.to_string().contains("\"red\""), "{e}");
}

#[test]
fn a_fit_with_nothing_free_is_refused() {
    let design = preset("signal-red");
    let m = as_file(&virtual_measurement(&design, || 0.0));
    let standard = m.select(None).expect("one standard");
    let mut nothing = FreeParameters::RHO;
    nothing.rho = false;
    let e = fit(&design, &standard, &FitRequest { free: nothing }).expect_err("nothing free");
    assert!(matches!(e, FitError::NothingFree), "{e}");
    assert!(e.to_string().contains("nothing is free"), "{e}");
}
