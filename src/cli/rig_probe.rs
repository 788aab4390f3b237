//! `nanopush rig probe`: not built yet (issue 6).

/// Arguments of `nanopush rig probe`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 6 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush rig probe` is not built yet (issue 6)")
}
