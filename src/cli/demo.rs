//! `nanopush demo`: until the assembly demo exists, simulates the paper scene
//! and writes its plots and time series.

use crate::model::Scene;
use crate::model::push_plots::write_push_outputs;
use crate::model::push_sim::{SolverSettings, simulate_push_series};
use crate::model::summary::PushSummary;
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Arguments of `nanopush demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Scene to simulate.
    #[arg(long, default_value = "calib/paper-ps-ito.toml")]
    pub scene: PathBuf,
}

/// Simulates the scene, writes plots, CSV and the JSON summary, prints where.
pub fn run(args: Args) -> anyhow::Result<()> {
    let scene =
        Scene::load(&args.scene).with_context(|| format!("scene {}", args.scene.display()))?;
    let p = scene.push;
    let (r, rows) = simulate_push_series(&scene, &p, &SolverSettings::default(), 601)
        .context("simulation failed")?;
    let summary = PushSummary::from_result(
        &scene.name,
        p.contact_angle_rad.to_degrees(),
        p.speed_m_per_s * 1e6,
        p.duration_s,
        &r,
    );
    print!("{}", summary.to_text());
    let files = write_push_outputs(&args.out, &scene.name, &rows).map_err(anyhow::Error::msg)?;
    let json = Path::new(&args.out).join("push-summary.json");
    std::fs::write(&json, serde_json::to_string_pretty(&summary)?)
        .with_context(|| format!("writing {}", json.display()))?;
    println!("demo outputs in {}:", args.out.display());
    for f in files.iter().chain(std::iter::once(&json)) {
        println!("  {}", f.display());
    }
    Ok(())
}
