use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct MeasureArgs {
    /// Paint design file (TOML).
    pub design: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_args: &MeasureArgs, _out: &mut impl Write) -> anyhow::Result<()> {
    anyhow::bail!("in progress")
}
