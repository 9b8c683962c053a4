//! Rebuilds `tests/data/render_reference.csv`, the converged reference the render
//! tests compare against: run it after a change that is meant to change the
//! expected image (the car, the studio, the materials), never to make a test pass.
//!
//!     cargo run --release -p coatlab-core --example make_render_reference

#[path = "../tests/support/image_stats.rs"]
mod image_stats;
#[path = "../tests/support/progressive.rs"]
mod progressive;
#[path = "../tests/support/render_reference.rs"]
mod render_reference;

use std::path::PathBuf;
use std::time::Instant;

use render_reference::{
    REFERENCE_FILE, REFERENCE_REPLICAS, REFERENCE_SEED, Reference, reference_replicas,
};

fn main() -> std::io::Result<()> {
    let start = Instant::now();
    let (k, spp) = REFERENCE_REPLICAS;
    let replicas = reference_replicas(REFERENCE_SEED, k, spp);
    let path = PathBuf::from(REFERENCE_FILE);
    Reference::from_replicas(&replicas).write(&path)?;
    println!(
        "wrote {} ({k} replicas of {spp} spp) in {:.1} s",
        path.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
