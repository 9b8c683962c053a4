//! Coatlab's core: spectra, colour science and the gloss solid paint model.
//!
//! The physics is specified in `docs/model.md` (the "spec"); section numbers in
//! comments refer to it. This crate has no GUI dependency.
//!
//! Layers, each depending only on those above it:
//! - [`units`], [`quadrature`], [`sampling`]: small numeric foundations;
//! - [`colour`]: wavelength grids and spectra, CIE data, colorimetry;
//! - [`paint`]: Fresnel, the coat integral C, the body and specular terms, the gloss
//!   lobe and its normalisation, m(g), sampling, Phong;
//! - [`instruments`]: the virtual multi-angle spectrophotometer and glossmeter;
//! - [`design`]: paint design files.

pub mod accel;
pub mod colour;
pub mod design;
pub mod instruments;
pub mod io;
pub mod paint;
pub mod quadrature;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod units;
