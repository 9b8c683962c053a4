//! The designer's GUI as a library, so that the `coatlab` binary starts it and the
//! workspace's GUI tests (`tests/gui*.rs`) drive the very same code headless.
//!
//! Only this crate knows egui; everything it shows is computed by `coatlab-core`.

pub mod gui;
