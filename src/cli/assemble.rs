//! `nanopush assemble`: not built yet (issue 5).

/// Arguments of `nanopush assemble`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 5 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush assemble` is not built yet (issue 5)")
}
