//! Fitting a design to a measured standard (issue 19: ≤ 10 ms for ρ(λ) alone,
//! ≤ 1 s with every coat parameter free), the signal-red preset's own virtual
//! measurement at 10 nm, 380–780 nm:
//!
//!     cargo bench -p coatlab-core --bench fit
//!
//! - `one_geometry`: ρ alone, the closed form at 45°as45°;
//! - `five_angles`: ρ alone, the bounded least-squares fit of the five instrument
//!   angles;
//! - `lab_only`: ρ alone, the smoothest ρ with one stated CIELAB (D65/10°,
//!   45°as45°);
//! - `coat_free`: ρ, gloss, h, k and n, the five angles and the three glossmeter
//!   readings, from the preset with its coat moved (gloss −6 GU, h × 1.3, a
//!   constant k of twice its k at 587.6 nm, n + 0.03).
//!
//! Each includes building the start design's model (the coat's tables), as
//! `coatlab fit` does.

use std::hint::black_box;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::design::{Absorption, RefractiveIndex};
use coatlab_core::fit::{FitRequest, FreeParameters, fit, fit_albedo};
use coatlab_core::instruments::measure;
use coatlab_core::measurement::{
    Geometry, Reflectance, Sample, Standard, StatedColour, StatedValue,
};
use criterion::{Criterion, criterion_group, criterion_main};

fn sample(
    geometry: Geometry,
    spectrum: Option<Reflectance>,
    colour: Option<StatedColour>,
) -> Sample {
    Sample {
        name: "Signal red".to_owned(),
        id: None,
        geometry,
        spectrum,
        colour,
        gloss: Vec::new(),
    }
}

fn bench_fit(c: &mut Criterion) {
    let design = presets::by_slug("signal-red").expect("preset").design;
    let model = design.model(WavelengthGrid::reference()).expect("model");
    let m = measure(&model).expect("spectral");
    // Five angles at 10 nm with the three gloss readings on each row; the ρ-only
    // fits get the spectra alone.
    let with_gloss = m.multi_angle_samples("Signal red", 2).expect("samples");
    let spectral: Vec<Sample> = with_gloss
        .iter()
        .map(|s| Sample {
            gloss: Vec::new(),
            ..s.clone()
        })
        .collect();
    let one = Standard {
        name: "Signal red",
        readings: vec![&spectral[2]],
    };
    let five = Standard {
        name: "Signal red",
        readings: spectral.iter().collect(),
    };
    let lab_only = sample(
        Geometry::directional(45.0, 45.0),
        None,
        Some(StatedColour {
            value: StatedValue::Lab(m.angles[2].lab),
            illuminant: Some(coatlab_core::colour::cie::Illuminant::D65),
            observer: Some(coatlab_core::colour::cie::Observer::Cie1964TenDegree),
        }),
    );
    let lab = Standard {
        name: "Signal red",
        readings: vec![&lab_only],
    };
    let with_gloss = Standard {
        name: "Signal red",
        readings: with_gloss.iter().collect(),
    };
    let mut moved = design.clone();
    moved.gloss.gu -= 6.0;
    moved.thickness_um *= 1.3;
    moved.absorption_per_um = Absorption::Constant(2.0 * design.absorption_per_um.at_nm(587.6));
    if let RefractiveIndex::Cauchy { a, .. } = &mut moved.refractive_index {
        *a += 0.03;
    }
    let every = FitRequest {
        free: FreeParameters::parse("rho,gloss,h,k,n").expect("names"),
    };
    let mut group = c.benchmark_group("fit");
    group.bench_function("one_geometry", |b| {
        b.iter(|| fit_albedo(black_box(&design), black_box(&one)).expect("fit"));
    });
    group.bench_function("five_angles", |b| {
        b.iter(|| fit_albedo(black_box(&design), black_box(&five)).expect("fit"));
    });
    group.bench_function("lab_only", |b| {
        b.iter(|| fit_albedo(black_box(&design), black_box(&lab)).expect("fit"));
    });
    group.sample_size(10);
    group.bench_function("coat_free", |b| {
        b.iter(|| fit(black_box(&moved), black_box(&with_gloss), &every).expect("fit"));
    });
    group.finish();
}

criterion_group!(benches, bench_fit);
criterion_main!(benches);
