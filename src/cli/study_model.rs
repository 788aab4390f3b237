//! `nanopush study model`: not built yet (issue 2).

/// Arguments of `nanopush study model`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 2 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush study model` is not built yet (issue 2)")
}
