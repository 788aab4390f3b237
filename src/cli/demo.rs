//! `nanopush demo`: not built yet (issue 2).

/// Arguments of `nanopush demo`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 2 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush demo` is not built yet (issue 2)")
}
