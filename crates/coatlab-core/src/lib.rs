//! Coatlab's core: spectra, colour science and the gloss solid paint model.
//!
//! The physics is specified in `docs/model.md` (the "spec"); section numbers in
//! comments refer to it. This crate has no GUI dependency.
//!
//! Layers, each depending only on those above it (docs/architecture.md):
//! - [`units`], [`quadrature`], [`sampling`]: small numeric foundations;
//! - [`colour`]: wavelength grids and channels, CIE data, colorimetry, RGB → spectrum;
//! - [`paint`]: the parameter table, Fresnel, the coat integral C, the body and
//!   specular terms, the gloss lobe and its normalisation, m(g), sampling, Phong;
//! - [`measurement`]: spectrophotometer files (CGATS.17, CxF3) read into readings;
//! - [`instruments`]: the virtual multi-angle spectrophotometer and glossmeter;
//!   [`target`]: a design against a target design or a measured standard;
//! - [`design`]: paint design files; [`fit`]: a design fitted to a measured standard;
//! - [`io`]: image files in and out, atomic writes;
//! - [`scene`]: glTF scenes and the built-in car;
//! - [`accel`]: the BVH over triangles;
//! - [`render`]: the spectral path tracer (lighting, camera, materials, film, passes);
//! - [`engine`]: the live-rendering engine behind the designer's preview.

pub mod accel;
pub mod analysis;
pub mod colour;
pub mod design;
pub mod engine;
pub mod export;
pub mod fit;
pub mod instruments;
pub mod io;
pub mod measurement;
pub mod names;
pub mod paint;
pub mod parameter;
pub mod quadrature;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod simd_path;
pub mod target;
pub mod units;
