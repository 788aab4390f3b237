//! `nanopush study plan`: not built yet (issue 4).

/// Arguments of `nanopush study plan`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 4 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush study plan` is not built yet (issue 4)")
}
