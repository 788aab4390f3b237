//! `nanopush dry-run`: not built yet (issue 5).

/// Arguments of `nanopush dry-run`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 5 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush dry-run` is not built yet (issue 5)")
}
