//! The spectral progressive ray tracer behind the car preview.
//!
//! Every path carries all wavelengths of one [`crate::colour::spectrum::WavelengthGrid`]: the
//! paint's path geometry does not depend on wavelength, so there is no colour noise,
//! only luminance noise. Radiance values are spectral radiance in relative units
//! (W·sr⁻¹·m⁻²·nm⁻¹ up to one scale factor per environment); the film turns them into
//! CIE XYZ.
//!
//! Frames: world space is metres, Y up, the car on the ground plane y = 0 (see
//! [`crate::scene`]). Directions are unit `[f32; 3]`.
//!
//! - [`lighting`]: the user's choice of lighting and the one builder from it;
//! - [`environment`]: what lights the scene (studio, booth, outdoor, image maps);
//! - [`camera`] and [`film`]: rays from pixels, and accumulation into an image;
//! - [`material`]: the design as paint or Phong, the other parts' materials, the floor;
//! - [`microfacet`]: GGX conductors, rough dielectrics and clear coats (glTF materials);
//! - [`glass`]: glass (thin panes, refracting volumes) and alpha MASK/BLEND;
//! - [`texturing`]: a textured material's parameters at a hit (mip level from a ray cone);
//! - [`integrator`]: the path tracer;
//! - [`progressive`]: passes over tiles on all cores, restarts, noise estimates;
//! - [`adaptive`]: adaptive sampling, a pass's samples spent by each pixel's noise;
//! - [`image_error`]: the error of a render against a reference (ΔE00 as displayed);
//! - [`reshade`]: a paint edit's picture from the recorded paths, without tracing;
//! - [`view`]: the named views, the free camera and the scene's own cameras.

pub mod geometry;
pub mod sampler;

pub mod adaptive;
pub mod camera;
pub mod environment;
pub mod film;
pub mod glass;
pub mod image_error;
pub mod integrator;
pub mod lighting;
pub mod material;
pub mod microfacet;
pub mod pick;
pub mod progressive;
pub mod reshade;
pub mod texturing;
pub mod view;
