use std::io::Write;

#[derive(clap::Args, Debug)]
pub struct GlossArgs {
    /// Refractive index of the clear coat at 587.6 nm.
    #[arg(long)]
    pub n: f64,
    /// Glossmeter geometry in degrees: 20, 60 or 85.
    #[arg(long, default_value = "20")]
    pub geometry: u32,
    /// Reading in gloss units: prints the lobe exponent m.
    #[arg(long, conflicts_with = "m", required_unless_present = "m")]
    pub gu: Option<f64>,
    /// Lobe exponent: prints the reading in gloss units.
    #[arg(long)]
    pub m: Option<f64>,
}

pub fn run(_args: &GlossArgs, _out: &mut impl Write) -> anyhow::Result<()> {
    anyhow::bail!("in progress")
}
