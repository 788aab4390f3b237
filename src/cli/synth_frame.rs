//! `nanopush synth frame`: not built yet (issue 3).

/// Arguments of `nanopush synth frame`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Refuses with a clear message until issue 3 builds this command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`nanopush synth frame` is not built yet (issue 3)")
}
