//! `nanopush study model`: solver settings against error and wall time.

use crate::model::Scene;
use crate::model::scene::built_in_scene_paths;
use crate::model::study::{output_paths, run_study, to_markdown, write_outputs};
use anyhow::Context;
use std::path::PathBuf;

/// Arguments of `nanopush study model`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Write the table (Markdown + CSV) and the error-vs-time plot here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Scene files (default: the paper scene and two hard scenes in calib/).
    #[arg(long = "scene")]
    pub scenes: Vec<PathBuf>,
    /// Timing repeats per setting (median reported), 1 to 10,000.
    #[arg(long, default_value_t = 51, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeats: u32,
    /// Replace a study already in --out.
    #[arg(long)]
    pub force: bool,
}

/// Runs the study, prints the table, optionally writes it.
pub fn run(args: Args) -> anyhow::Result<()> {
    // Before the study's minute of work: a table kept from another machine
    // or scene set was replaced without a word.
    if let Some(dir) = &args.out {
        for path in output_paths(dir) {
            super::calibrate::check_output_in(&path, &[], args.force, "folder")?;
        }
    }
    let paths: Vec<PathBuf> = if args.scenes.is_empty() {
        built_in_scene_paths().map(PathBuf::from).collect()
    } else {
        args.scenes.clone()
    };
    let mut scenes = Vec::new();
    for p in &paths {
        let s = Scene::load(p).with_context(|| format!("scene {}", p.display()))?;
        scenes.push((s.name.clone(), s));
    }
    let rows = run_study(&scenes, args.repeats as usize).context("study failed")?;
    print!("{}", to_markdown(&rows));
    if let Some(dir) = &args.out {
        for f in write_outputs(dir, &rows).map_err(anyhow::Error::msg)? {
            println!("wrote {}", f.display());
        }
    }
    Ok(())
}
