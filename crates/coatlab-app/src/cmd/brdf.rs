use std::io::{Read, Write};

pub fn run(_input: impl Read, _out: &mut impl Write) -> anyhow::Result<()> {
    anyhow::bail!("in progress")
}
