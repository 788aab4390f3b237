//! `nanopush plan`: not built yet (issue 4).

/// Arguments of `nanopush plan`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 4 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush plan` is not built yet (issue 4)")
}
