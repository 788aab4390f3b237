//! `nanopush simulate`: one push of the pushing model, summarised, as JSON,
//! or with plots and a CSV time series.

use crate::model::push_plots::write_push_outputs;
use crate::model::push_sim::{SeriesRow, SolverSettings, simulate_push_series};
use crate::model::summary::PushSummary;
use crate::model::{ModelError, Scene, plausible};
use anyhow::Context;
use std::path::PathBuf;

/// Arguments of `nanopush simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scene file (TOML), e.g. calib/paper-ps-ito.toml.
    #[arg(long)]
    pub scene: PathBuf,
    /// Contact angle (deg), overriding push.angle_deg.
    #[arg(long)]
    pub angle_deg: Option<f64>,
    /// Stage speed [um/s], overriding push.speed_um_s.
    #[arg(long)]
    pub speed_um_s: Option<f64>,
    /// Push duration (s), overriding push.duration_s.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Particle radius (um), overriding particle.radius_um.
    #[arg(long)]
    pub radius_um: Option<f64>,
    /// Write plots (SVG + PNG) and the time series (CSV) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// Loads the scene, applies the overrides (lab units, converted once here).
pub fn scene_with_overrides(args: &Args) -> anyhow::Result<Scene> {
    let mut scene =
        Scene::load(&args.scene).with_context(|| format!("scene {}", args.scene.display()))?;
    let check = |v: f64, flag: &str, ok: bool| -> anyhow::Result<f64> {
        anyhow::ensure!(v.is_finite() && ok, "--{flag} {v} is invalid");
        Ok(v)
    };
    // The scene's own range for the key the flag overrides: `--speed-um-s
    // 1e-6` (m/s written where um/s is wanted) had simulated a push at
    // 1 pm/s without a word, though the scene file refuses the same value.
    let in_range = |v: f64, flag: &str, key: &str| -> anyhow::Result<f64> {
        plausible(v, key).map_err(|e| match e {
            ModelError::Scene { problem, .. } => anyhow::anyhow!("--{flag}: {problem}"),
            other => other.into(),
        })
    };
    if let Some(a) = args.angle_deg {
        scene.push.contact_angle_rad = check(a, "angle-deg", a > 0.0 && a < 90.0)
            .context("contact angle must be inside 0..90 deg")?
            .to_radians();
    }
    if let Some(v) = args.speed_um_s {
        check(v, "speed-um-s", v > 0.0).context("speed must be positive")?;
        scene.push.speed_m_per_s = in_range(v, "speed-um-s", "push.speed_um_s")? * 1e-6;
    }
    if let Some(t) = args.duration_s {
        check(t, "duration-s", t > 0.0).context("duration must be positive")?;
        scene.push.duration_s = in_range(t, "duration-s", "push.duration_s")?;
    }
    if let Some(r) = args.radius_um {
        check(r, "radius-um", r > 0.0).context("radius must be positive")?;
        scene.particle_radius_m = in_range(r, "radius-um", "particle.radius_um")? * 1e-6;
    }
    Ok(scene)
}

/// The scene's own push, summarised, with its time series (601 rows) for plots.
pub(super) fn simulate_scene(scene: &Scene) -> anyhow::Result<(PushSummary, Vec<SeriesRow>)> {
    let p = scene.push;
    let (result, rows) = simulate_push_series(scene, &p, &SolverSettings::default(), 601)
        .context("simulation failed")?;
    let summary = PushSummary::from_result(
        &scene.name,
        p.contact_angle_rad.to_degrees(),
        p.speed_m_per_s * 1e6,
        p.duration_s,
        &result,
    );
    Ok((summary, rows))
}

/// Runs the simulation and prints or writes the result.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(dir) = &args.out {
        super::folder_flag::check_folder_flag("--out", dir, "a folder")?;
    }
    let scene = scene_with_overrides(&args)?;
    let (summary, rows) = simulate_scene(&scene)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print!("{}", summary.to_text());
    }
    if let Some(dir) = &args.out {
        let files = write_push_outputs(dir, &scene.name, &rows).map_err(anyhow::Error::msg)?;
        if !args.json {
            for f in files {
                println!("wrote {}", f.display());
            }
        }
    }
    Ok(())
}
