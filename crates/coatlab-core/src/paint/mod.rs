//! The gloss solid paint model (spec sections 3–5).
//!
//! - [`fresnel`]: R(μ) and friends (section 3);
//! - [`coat`]: the coat integral C and the body term (4.1);
//! - [`lobe`]: the specular lobe, its normalisation and sampling (4.2);
//! - [`gloss`]: the simulated glossmeter and m(g) (4.3);
//! - [`parameters`]: the table of the parameters a designer sets: name, unit, range,
//!   control span, default;
//! - [`model`]: the whole model on a wavelength grid, parameters and derived tables,
//!   in double precision for reference work and single precision for the renderer;
//! - [`phong`]: the Phong comparison model (5).

pub mod coat;
pub mod fresnel;
pub mod gloss;
pub mod lobe;
pub mod model;
pub mod parameters;
pub mod phong;
