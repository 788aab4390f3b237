//! `nanopush dry-run --recording DIR`: detection, tracking and planning on a
//! recording (docs/exec.md has the format), printing frame by frame what the
//! loop would command; writes `dry-run.json` and an annotated animation
//! `dry-run.mp4` in `--out`. The recording itself is only read.

use super::dry_run_worker::{Replayed, replay};
use super::pattern_args::PatternArgs;
use crate::exec::animation::AnimationWriter;
use crate::exec::dry_run::DryRunFrame;
use crate::exec::recording::open_recording;
use crate::model::Scene;
use crate::rig::interrupt::{CAUSE, ctrlc_flag_answering};
use crate::vision::analyse::camera_notes;
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

/// Arguments of `nanopush dry-run`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording folder (recording.toml, frames, calibration, optional stage log).
    #[arg(long)]
    pub recording: PathBuf,
    /// Scene for the model's advice (default: the recording's scene, if it names one).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Output folder for dry-run.json and dry-run.mp4 (must not hold a dry-run yet).
    #[arg(long, default_value = "out/dry-run")]
    pub out: PathBuf,
    /// Print the whole dry-run as JSON instead of one line per frame.
    #[arg(long)]
    pub json: bool,
    /// A pattern to try on the recording instead of its own target (what
    /// `assemble` would do with `--text`, `--at`, ... on these frames).
    #[command(flatten)]
    pub target: PatternArgs,
}

/// Replays the recording and prints what would be commanded.
pub fn run(args: Args) -> anyhow::Result<()> {
    let recording = open_recording(&args.recording)?;
    let scene_path = args
        .scene
        .clone()
        .or_else(|| recording.spec.scene.as_ref().map(|s| recording.file(s)));
    let scene = match &scene_path {
        Some(p) => Some(Scene::load(p).with_context(|| format!("scene {}", p.display()))?),
        None => None,
    };
    if let (Some(s), Some(path)) = (&scene, &scene_path) {
        let want = recording.spec.particle_radius_um;
        let have = s.particle_radius_m * 1e6;
        if (want - have).abs() > 0.05 * want {
            // Naming the scene, and which gave it: "give a scene with
            // --scene" had answered a --scene given.
            let given = if args.scene.is_some() {
                "--scene"
            } else {
                "the recording"
            };
            bail!(
                "the scene {} ({given}) has particles of radius {have:.2} um, the recording's are {want:.2} um: \
                 give a scene for these particles with --scene",
                path.display()
            );
        }
    }
    super::folder_flag::check_folder_flag("--out", &args.out, "a folder")?;
    let t = &args.target;
    let asked = if t.text.is_some() || t.pattern.is_some() {
        Some(t.request()?)
    } else if t.pitch_um.is_some() || t.rotation_deg != 0.0 || t.at.is_some() {
        bail!("--pitch-um, --rotation-deg and --at shape a pattern: give --text or --pattern too");
    } else {
        None
    };
    let report_path = args.out.join("dry-run.json");
    let animation_path = args.out.join("dry-run.mp4");
    if let Some(there) = [&report_path, &animation_path]
        .into_iter()
        .find(|p| p.exists())
    {
        bail!(
            "{} exists: choose another --out (nothing was overwritten)",
            there.display()
        );
    }
    // The frames may lie outside the recording's folder (`frames` is a
    // path): written among them, the animation would join the frames.
    let frames = recording.file(&recording.spec.frames);
    for (what, folder) in [
        ("the recording", &args.recording),
        ("its frames' folder", &frames),
    ] {
        if inside(&args.out, folder) {
            bail!(
                "--out {} is inside {what} {}: a dry-run only reads its recording; \
                 choose an --out outside it",
                args.out.display(),
                folder.display()
            );
        }
    }
    // The outermost folder of --out this run makes, if any: removed, with
    // those inside it, when the run is refused.
    let made_out = args
        .out
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .last()
        .map(Path::to_path_buf);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let animation = AnimationWriter::new(&animation_path, 1.0);
    let interrupt = ctrlc_flag_answering(&format!(
        "stopping the dry-run ({CAUSE}) now: the frames analysed are kept in {}",
        args.out.display()
    ))
    .context("installing the Ctrl-C handler")?;
    if !args.json {
        // Where the times come from: the model's advice depends on them.
        println!("replay: {}", recording.frame_times);
    }
    // Each frame is printed as it is analysed: a long recording shows its
    // progress, and a frame that stops it is seen after those before.
    let print = if args.json {
        |_: &DryRunFrame, _| {}
    } else {
        print_frame
    };
    let Replayed { report, animation } =
        replay(recording, scene, asked, animation, print, &interrupt)?;
    let report = match report {
        Ok(report) => report,
        Err(e) => {
            // A refused recording leaves no part-written animation, nor the
            // empty folders of --out it made, behind (remove_dir takes only
            // an empty folder).
            animation.discard();
            if let Some(made) = &made_out {
                for folder in args.out.ancestors() {
                    let _ = std::fs::remove_dir(folder);
                    if folder == made {
                        break;
                    }
                }
            }
            return Err(e.into());
        }
    };
    let animated = animation.finish().context("writing the animation")?;
    std::fs::write(&report_path, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("writing {}", report_path.display()))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "dry-run: {} and {}",
            report_path.display(),
            args.out.join("dry-run.mp4").display()
        );
    }
    match &report.ended_early {
        Some(why) if interrupt.load(Ordering::SeqCst) || report.unread_after > 0 => {
            let video = animated.map_or(String::new(), |(path, _)| {
                format!(" and {}", path.display())
            });
            bail!(
                "dry-run {why}: what was analysed is in {}{video}",
                report_path.display()
            )
        }
        Some(why) => {
            tracing::warn!("dry-run ended early: {why}");
            Ok(())
        }
        None => Ok(()),
    }
}

/// True when `path` (which need not exist yet) is `folder` or lies within
/// it, through `..` and symbolic links: its nearest existing ancestor is
/// resolved.
fn inside(path: &Path, folder: &Path) -> bool {
    let Ok(folder) = std::fs::canonicalize(folder) else {
        return false;
    };
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    absolute
        .ancestors()
        .find_map(|a| std::fs::canonicalize(a).ok())
        .is_some_and(|real| real.starts_with(&folder))
}

/// One line of the printed dry-run: frame `f` of a target of `sites` sites.
fn print_frame(f: &DryRunFrame, sites: usize) {
    let tip = f.tip_um.map_or("tip not seen".to_owned(), |t| {
        format!("tip ({:.1}, {:.1}) um", t[0], t[1])
    });
    let camera = camera_notes(&f.repaired_lines, f.clipped);
    let source = match f.source.as_str() {
        "" => String::new(),
        name => format!(" ({name})"),
    };
    let not_made = if f.last_command_not_made {
        "  (the recording does not show the last command made: planned from what it shows)"
    } else {
        ""
    };
    println!(
        "frame {:>4}{source}  t {:>8.2} s  {:>13}  {tip}  filled {}/{}  -> {}{camera}{not_made}",
        f.frame,
        f.t_s,
        crate::wording::counted(f.particles.len(), "particle"),
        f.filled,
        sites,
        f.command.describe()
    );
}
