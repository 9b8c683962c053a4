//! Rebuilds `tests/data/render_reference.csv`, the converged reference the render
//! tests compare against: run it after a change that is meant to change the
//! expected image (the car, the studio, the materials), never to make a test pass.
//!
//!     cargo run --release -p coatlab-core --example make_render_reference

#[path = "../tests/support/render_reference.rs"]
mod render_reference;

use std::path::PathBuf;

use render_reference::{REFERENCE_FILE, REFERENCE_SEED, Reference, reference_render};

fn main() -> std::io::Result<()> {
    let film = reference_render(REFERENCE_SEED, 2048);
    let path = PathBuf::from(REFERENCE_FILE);
    Reference::from_film(&film).write(&path)?;
    println!("wrote {}", path.display());
    Ok(())
}
