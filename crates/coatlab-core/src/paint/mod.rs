//! The gloss solid paint model (spec sections 3–5).

pub mod coat;
pub mod fresnel;
pub mod lobe;
pub mod gloss;
