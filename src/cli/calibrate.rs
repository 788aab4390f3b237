//! `nanopush calibrate`: not built yet (issue 3).

/// Arguments of `nanopush calibrate`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 3 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush calibrate` is not built yet (issue 3)")
}
