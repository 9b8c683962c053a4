use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct ColorArgs {
    /// Illuminant: D65, D50, A, F2, F7 or F11.
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// Standard observer: 2 (CIE 1931) or 10 (CIE 1964).
    #[arg(long, default_value = "10")]
    pub observer: u32,
    /// CSV file with a `wavelength_nm` column and one column per sample.
    pub file: PathBuf,
}

pub fn run(_args: &ColorArgs, _out: &mut impl Write) -> anyhow::Result<()> {
    anyhow::bail!("in progress")
}
