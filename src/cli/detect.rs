//! `nanopush detect`: not built yet (issue 3).

/// Arguments of `nanopush detect`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 3 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush detect` is not built yet (issue 3)")
}
