//! One module per subcommand. Each `run` reads and writes through the handles it is
//! given, so the end-to-end tests and the binary share one code path.

pub mod batch;
pub mod brdf;
pub mod color;
pub mod delta_e;
pub mod export;
pub mod failure;
pub mod fit;
pub mod gloss;
pub mod measure;
pub mod merge;
pub mod render;
mod table;
