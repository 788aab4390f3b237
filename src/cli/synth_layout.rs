//! `nanopush synth layout`: seeded synthetic particle layouts.

use super::distinct_outputs::prepare_outputs;
use crate::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use std::path::PathBuf;

/// Arguments of `nanopush synth layout`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Number of particles.
    #[arg(long)]
    pub n: usize,
    /// Field "WxH" in um.
    #[arg(long, default_value = "120x100", value_parser = parse_wh, allow_hyphen_values = true)]
    pub field_um: (f64, f64),
    /// Particle radius in um.
    #[arg(long, default_value_t = 5.0)]
    pub radius_um: f64,
    /// Minimum gap between particles in um.
    #[arg(long, default_value_t = 1.0)]
    pub min_gap_um: f64,
    /// Radii with 5 % spread.
    #[arg(long)]
    pub polydisperse: bool,
    /// Layout kind.
    #[arg(long, value_enum, default_value_t = LayoutKind::Uniform)]
    pub kind: LayoutKind,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output layout file.
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_wh(s: &str) -> Result<(f64, f64), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH in um, got {s:?}"))?;
    let w: f64 = w
        .trim()
        .parse()
        .map_err(|e| format!("bad width {w:?}: {e}"))?;
    let h: f64 = h
        .trim()
        .parse()
        .map_err(|e| format!("bad height {h:?}: {e}"))?;
    Ok((w, h))
}

/// Generates and writes the layout.
pub fn run(args: Args) -> anyhow::Result<()> {
    let p = SynthParams {
        n: args.n,
        field_m: [args.field_um.0 * 1e-6, args.field_um.1 * 1e-6],
        radius_m: args.radius_um * 1e-6,
        min_gap_m: args.min_gap_um * 1e-6,
        polydisperse: args.polydisperse,
        kind: args.kind,
        seed: args.seed,
    };
    prepare_outputs(&[], &[("--out", &args.out)])?;
    let layout = synth_layout(&p)?;
    layout.write(&args.out)?;
    println!(
        "wrote {} to {}",
        crate::wording::counted(layout.particles.len(), "particle"),
        args.out.display()
    );
    Ok(())
}
