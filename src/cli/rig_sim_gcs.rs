//! `nanopush rig sim-gcs`: not built yet (issue 6).

/// Arguments of `nanopush rig sim-gcs`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 6 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush rig sim-gcs` is not built yet (issue 6)")
}
