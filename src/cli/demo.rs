//! `nanopush demo`: the main job on the simulated rig. Assembles a pattern
//! ('CMU' by default) from a fixed seed with the full closed loop (camera,
//! detection, tracking, planning, model-advised pushes, checks, re-pushes) and
//! prints where the report is; also simulates the paper scene's single push
//! and writes its plots, the model's reference case.

use super::assemble::{self, check_text_fits_the_layout};
use super::simulate::simulate_scene;
use crate::model::Scene;
use crate::model::push_plots::write_push_outputs;
use anyhow::Context;
use clap::Parser;
use std::path::{Path, PathBuf};

/// Arguments of `nanopush demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory (its `assemble` and `paper-push` folders are replaced).
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Scene of the rig and of the single push.
    #[arg(long, default_value = "calib/paper-ps-ito.toml")]
    pub scene: PathBuf,
    /// Text to assemble.
    #[arg(long, default_value = "CMU")]
    pub text: String,
    /// Seed of the layout and the rig's noise.
    #[arg(long, default_value_t = DEMO_SEED)]
    pub seed: u64,
}

/// The demo's fixed seed.
pub const DEMO_SEED: u64 = 2;

/// `assemble`'s arguments, parsed from a command line the demo writes.
#[derive(Parser, Debug)]
struct AssembleCommand {
    #[command(flatten)]
    args: assemble::Args,
}

/// Simulates the paper push, then assembles the pattern; prints where everything is.
pub fn run(args: Args) -> anyhow::Result<()> {
    check_text_fits_the_layout(&args.text)?;
    // Refused before the single push runs (it had run, then the demo failed).
    super::folder_flag::check_folder_flag("--out", &args.out, "a folder")?;
    let push_dir = args.out.join("paper-push");
    paper_push(&args.scene, &push_dir)?;
    let assemble_dir = args.out.join("assemble");
    if assemble_dir.exists() {
        std::fs::remove_dir_all(&assemble_dir)
            .with_context(|| format!("clearing the previous demo in {}", assemble_dir.display()))?;
    }
    let seed = args.seed.to_string();
    // Its letters stand clear of the particles they do not use, as
    // `assemble` keeps them by default.
    let command = AssembleCommand::try_parse_from([
        "assemble".as_ref(),
        "--text".as_ref(),
        args.text.as_str().as_ref(),
        "--scene".as_ref(),
        args.scene.as_os_str(),
        "--seed".as_ref(),
        seed.as_str().as_ref(),
        "--out".as_ref(),
        assemble_dir.as_os_str(),
    ] as [&std::ffi::OsStr; 9])?;
    println!(
        "assembling '{}' on the simulated rig (seed {})",
        args.text, args.seed
    );
    // A run that stops short is still a demo of the loop: its report says
    // why, and where it is is said before the failing exit (a script
    // running the demo had read a stop as success). One that never started
    // (a bad --text) has no report to show.
    let report = assemble_dir.join("report.md");
    let assembled = assemble::run(command.args);
    if assembled.is_err() && !report.is_file() {
        return assembled.context("the assembly did not start");
    }
    // The assembly's own summary ends with its report's path.
    println!("paper-scene push: {}", push_dir.display());
    assembled.context("the assembly stopped short (its report says why)")
}

/// The paper scene's push: summary, plots, CSV and JSON.
fn paper_push(scene_path: &Path, out: &Path) -> anyhow::Result<()> {
    let scene =
        Scene::load(scene_path).with_context(|| format!("scene {}", scene_path.display()))?;
    let (summary, rows) = simulate_scene(&scene)?;
    print!("{}", summary.to_text());
    write_push_outputs(out, &scene.name, &rows).map_err(anyhow::Error::msg)?;
    let json = out.join("push-summary.json");
    std::fs::write(&json, serde_json::to_string_pretty(&summary)?)
        .with_context(|| format!("writing {}", json.display()))?;
    Ok(())
}
