//! `nanopush synth layout`: not built yet (issue 4).

/// Arguments of `nanopush synth layout`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 4 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush synth layout` is not built yet (issue 4)")
}
