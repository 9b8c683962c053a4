//! Fitting ρ(λ) alone to a measured standard (issue 19: ≤ 10 ms), the signal-red
//! preset's own virtual measurement at 10 nm, 380–780 nm:
//!
//!     cargo bench -p coatlab-core --bench fit
//!
//! - `one_geometry`: the closed form at 45°as45°;
//! - `five_angles`: the bounded least-squares fit of the five instrument angles;
//! - `lab_only`: the smoothest ρ with one stated CIELAB (D65/10°, 45°as45°).
//!
//! Each includes building the start design's model (the coat's tables), as
//! `coatlab fit` does.

use std::hint::black_box;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::fit::fit_albedo;
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
    let keep: Vec<usize> = (0..m.wavelength_nm.len()).step_by(2).collect();
    let w: Vec<f64> = keep.iter().map(|&i| m.wavelength_nm[i]).collect();
    let spectral: Vec<Sample> = m
        .angles
        .iter()
        .map(|a| {
            let r = keep.iter().map(|&i| a.reflectance_factor[i]).collect();
            sample(
                Geometry::directional(45.0, a.aspecular_deg),
                Some(Reflectance::new(w.clone(), r).expect("valid")),
                None,
            )
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
    group.finish();
}

criterion_group!(benches, bench_fit);
criterion_main!(benches);
