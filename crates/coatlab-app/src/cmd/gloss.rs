//! `coatlab gloss`: glossmeter reading (GU) ↔ lobe exponent m, through the simulated
//! ISO 2813 glossmeter of spec 4.3.
//!
//! - `--gu G` prints m(G), or `inf` when G is at or above the reading of the ideal
//!   mirror (no finite exponent reads that high): `inf` means the ideal mirror.
//! - `--m M` prints the reading of exponent M in GU; `--m inf` is the ideal mirror.
//!
//! One line, the number printed in Rust's shortest round-trip form, so feeding the
//! output of one direction into the other reproduces the input.

use std::io::Write;

use anyhow::Context;
use coatlab_core::paint::gloss::{
    GlossExponent, GlossGeometry, exponent_from_reading, reading_from_exponent,
};

use super::failure::{Classify, Failure};

#[derive(clap::Args, Debug)]
pub struct GlossArgs {
    // Hyphen values are allowed so that `--gu -1` or `--m -inf` reach the range
    // checks (and their messages) instead of being taken for unknown flags.
    /// Refractive index of the clear coat at 587.6 nm.
    #[arg(long, allow_hyphen_values = true)]
    pub n: f64,
    /// Glossmeter geometry in degrees: 20, 60 or 85.
    #[arg(long, default_value = "20")]
    pub geometry: u32,
    /// Reading in gloss units: prints the lobe exponent m, or `inf` (the ideal
    /// mirror) for a reading at or above the mirror's own.
    #[arg(
        long,
        conflicts_with = "m",
        required_unless_present = "m",
        allow_hyphen_values = true
    )]
    pub gu: Option<f64>,
    /// Lobe exponent: prints the reading in gloss units. `inf` is the ideal mirror.
    #[arg(long, allow_hyphen_values = true)]
    pub m: Option<f64>,
}

pub fn run(args: &GlossArgs, out: &mut impl Write) -> anyhow::Result<()> {
    // Every number here is a flag's value: what the core refuses is a usage error.
    let geometry = GlossGeometry::try_from(args.geometry)
        .context("--geometry")
        .or_fail(Failure::Usage)?;
    match (args.gu, args.m) {
        (Some(gu), _) => {
            let m = exponent_from_reading(geometry, args.n, gu)
                .with_context(|| format!("--gu {gu} at {geometry} with --n {}", args.n))
                .or_fail(Failure::Usage)?;
            match m {
                GlossExponent::Finite(m) => writeln!(out, "{m}")?,
                GlossExponent::Mirror => writeln!(out, "inf")?,
            }
        }
        (None, Some(m)) => {
            // +∞ is the mirror; NaN and −∞ go on to the core, which rejects them.
            let exponent = if m == f64::INFINITY {
                GlossExponent::Mirror
            } else {
                GlossExponent::Finite(m)
            };
            let gu = reading_from_exponent(geometry, args.n, exponent)
                .with_context(|| format!("--m {m} at {geometry} with --n {}", args.n))
                .or_fail(Failure::Usage)?;
            writeln!(out, "{gu}")?;
        }
        // clap requires one of the two.
        (None, None) => return Err(Failure::Usage.error("give --gu or --m")),
    }
    Ok(())
}
