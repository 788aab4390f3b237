//! `nanopush rig calibrate --rig FILE`: measures the camera's pixel-to-stage
//! map on the rig. The tip is moved over a grid that covers the view
//! ([`run_calibration`]), each frame is saved with the stage's position as
//! a recording (frames and stage.csv, what `nanopush calibrate` reads), and
//! the map is fitted from that recording and written where the rig file
//! looks for it, so that `assemble --rig` uses it next.

use super::calibrate::{FitArgs, check_output, fit_recording};
use super::made_folder::MadeFolder;
use super::stage_csv::{StageRow, parse_stage_csv, stage_csv};
use crate::calib::calibration_run::{CalibrationRunSettings, CalibrationShot, run_calibration};
use crate::calib::camera_map::CameraCalibration;
use crate::calib::fit_quality::{MIN_INLIERS, enough_to_fit};
use crate::rig::gcs::RigFile;
use crate::rig::hardware::{HardwareRigOptions, RigDevices};
use crate::rig::stage::NanoStage;
use crate::vision::frame_input::{Channel, save_png};
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};

/// Arguments of `nanopush rig calibrate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Rig file (TOML, e.g. calib/rig-gcs-sim-folder.toml). Its calibration
    /// file need not exist yet.
    #[arg(long)]
    pub rig: PathBuf,
    /// Where the calibration is written [default: the file the rig file
    /// names, so that `assemble --rig` and `rig probe --camera` use it].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder for the frames and their stage.csv, which `nanopush calibrate
    /// --recording` fits again [default: beside the calibration, its name
    /// with `-recording`].
    #[arg(long)]
    pub recording: Option<PathBuf>,
    /// Replace an existing calibration and recording.
    #[arg(long)]
    pub force: bool,
    /// Points per side of the grid laid over the view (2-20).
    #[arg(long, default_value_t = 4)]
    pub grid: usize,
    /// Length of the two first moves (x, then y) that find where the view
    /// lies on the stage, micrometres.
    #[arg(long, default_value_t = 5.0)]
    pub step_um: f64,
    /// Height of the tip above the substrate during the run, micrometres
    /// (the rig file's z_surface_um and z_lifts turn it into the stage's
    /// z) [default: the top of the stage's z travel, clear of the
    /// particles]. Nearer the pushing height maps the apex as the loop sees
    /// it then, but the tip must clear every particle in view.
    #[arg(long)]
    pub z_um: Option<f64>,
    /// On a stage without z (axes x, y): the tip has been lifted clear of
    /// the sample by hand. Without it such a rig is refused, since the run
    /// would sweep the tip across the sample at whatever height it is.
    #[arg(long)]
    pub tip_lifted_by_hand: bool,
    #[command(flatten)]
    pub fit: FitArgs,
    /// Move real hardware without asking first (the rig file's
    /// `real_hardware = true` otherwise asks for `yes` before the first move).
    #[arg(long)]
    pub yes_move_hardware: bool,
}

/// Travel speed of the run: slow enough for any piezo stage, capped by the
/// rig file's top speed.
const TRAVEL_SPEED_UM_S: f64 = 20.0;

/// Records the grid, fits the map and writes it.
pub fn run(args: Args) -> anyhow::Result<()> {
    args.fit.check()?;
    let rig = RigFile::load(&args.rig)?;
    let out = args.out.clone().unwrap_or_else(|| rig.calibration.clone());
    let recording = args
        .recording
        .clone()
        .unwrap_or_else(|| recording_beside(&out));
    // The folder `check_output` makes for the calibration, taken back when
    // the command ends with no frame saved.
    let out_folder = MadeFolder::create(
        out.parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new(".")),
    )?;
    let mut saved = 0;
    let measured = measure(&args, rig, &out, &recording, &mut saved);
    if measured.is_err() && saved == 0 {
        let _ = out_folder.undo();
    }
    measured
}

/// [`run`] once the paths are known: refusals, the grid, the fit; `saved`
/// counts the frames it saved.
fn measure(
    args: &Args,
    rig: RigFile,
    out: &Path,
    recording: &Path,
    saved: &mut usize,
) -> anyhow::Result<()> {
    let rig_calibration = rig.calibration.clone();
    // Refused before anything moves: a good calibration or recording is
    // not lost to a re-run.
    check_output(out, &[], args.force)?;
    if !rig.stage.has_z() && !args.tip_lifted_by_hand {
        anyhow::bail!(
            "{}: the stage has no z axis (stage.axes {:?}), so the tip cannot be lifted and the grid would sweep it across the sample (particles moved 6 um on a simulated run): lift it clear by hand, then pass --tip-lifted-by-hand",
            args.rig.display(),
            rig.stage.axes
        );
    }
    let csv = recording.join("stage.csv");
    if csv.exists() && !args.force {
        bail!(
            "{} holds a recording already: pass --force to replace it, or --recording another folder",
            recording.display()
        );
    }
    let settings = CalibrationRunSettings {
        grid: args.grid,
        probe_step_m: args.step_um * 1e-6,
        speed_m_per_s: TRAVEL_SPEED_UM_S.min(rig.safety.top_speed_um_s) * 1e-6,
        travel_z_m: args.z_um.map(|z| z * 1e-6),
        ..Default::default()
    };
    settings.check()?;
    let mut devices = RigDevices::open(
        rig,
        HardwareRigOptions {
            waive_confirmation: args.yes_move_hardware,
            ..Default::default()
        },
    )
    .with_context(|| format!("opening the rig {}", args.rig.display()))?;
    let previous = CameraCalibration::load(out).ok();
    if args.force {
        clear_recording(recording, out)?;
    }
    let folder = MadeFolder::create(recording)?;
    let mut rows: Vec<StageRow> = Vec::new();
    let mut with_tip = 0;
    let mut view = (0, 0);
    let ran = run_calibration(&mut devices, &settings, &mut |shot| {
        view = (shot.frame.width(), shot.frame.height());
        with_tip += usize::from(shot.apex_px.is_some());
        save_shot(recording, shot, &mut rows).map_err(|e| format!("{e:#}"))
    });
    *saved = rows.len();
    // Whatever happened, the stage is left still.
    let _ = devices.halt();
    if let Err(e) = ran {
        // The stage goes back to where it started only when the run ends by
        // itself: after Ctrl-C or a fault it stays where it stopped, and
        // the frames already saved are worth a fit (neither had been said).
        // A run that ends before its first move says nothing moved.
        let moved = devices.moved_any();
        let at = match devices.position() {
            Ok(p) => {
                let here = format!(
                    "({:.2}, {:.2}) um, the tip {:.2} um above the substrate",
                    p[0] * 1e6,
                    p[1] * 1e6,
                    p[2] * 1e6
                );
                if moved {
                    format!("the stage stopped at {here}; it was not put back")
                } else {
                    format!("nothing moved: the stage is where it was, at {here}")
                }
            }
            Err(_) if moved => "where the stage stopped could not be read".to_string(),
            Err(_) => "nothing moved".to_string(),
        };
        let kept = saved_frames(&folder, recording, out, rows.len(), with_tip);
        return Err(e).with_context(|| {
            format!(
                "calibration run on {} stopped: {at}; {kept}",
                args.rig.display()
            )
        });
    }
    let new = fit_recording(recording, out, Channel::Luminance, &args.fit, args.force)?;
    println!("recording: {} ({} frames)", recording.display(), rows.len());
    if let Some(old) = previous {
        // A camera or stage that moved since the last calibration shows here.
        let moved = new.largest_difference_m(&old, view.0, view.1);
        println!(
            "the calibration replaced put the view up to {:.3} um ({:.2} px) elsewhere",
            moved * 1e6,
            moved / new.m_per_px()
        );
    }
    if std::fs::canonicalize(out).ok() == std::fs::canonicalize(&rig_calibration).ok() {
        println!(
            "the rig file names this calibration: `nanopush rig probe --rig {} --camera` shows the view in stage um",
            args.rig.display()
        );
    } else {
        // The rig file reads its paths from its own folder: an absolute
        // path works wherever the rig file lies (`out` as given, relative
        // to where this ran, did not).
        let named = std::path::absolute(out).unwrap_or_else(|_| out.to_path_buf());
        println!(
            "to use it, name it in {}: calibration = {:?}",
            args.rig.display(),
            named.display().to_string()
        );
    }
    Ok(())
}

/// What a stopped run left and what to do with it. Only a fit the saved
/// frames can pass is advised (the 5 frames of a stopped run had been
/// advised to `calibrate`, which refuses under 6); with no frame the
/// folder the run made goes (empty folders had been left behind), so the
/// same command is accepted again.
fn saved_frames(
    folder: &MadeFolder,
    recording: &Path,
    out: &Path,
    frames: usize,
    with_tip: usize,
) -> String {
    let dir = recording.display();
    if frames == 0 {
        let left = folder.undo_said();
        return format!("no frame was taken, {dir} {left}; run the same command again");
    }
    if enough_to_fit(with_tip) {
        return format!(
            "{frames} frames saved in {dir} (fit them with `nanopush calibrate --recording {dir} --out {}`, or run the same command again with --force)",
            out.display()
        );
    }
    format!(
        "{frames} frames saved in {dir}, {with_tip} with a tip: too few to fit a map (at least {MIN_INLIERS}); run the same command again with --force"
    )
}

/// `calibration.toml` -> `calibration-recording/` beside it.
fn recording_beside(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "calibration".into());
    out.with_file_name(format!("{stem}-recording"))
}

/// Removes the recording `dir` holds, before a new one is taken there: the
/// frames its stage.csv lists, stage.csv itself, and the calibration
/// `calibrate --recording` fits into it (unless it is `out`, which the new
/// fit replaces). A 12-frame recording over a 19-frame one had left 7 old
/// frames beside the new stage.csv, and a calibration of the old frames
/// that then blocked `calibrate --recording`. Files it does not list, and
/// listed ones outside the folder, stay.
fn clear_recording(dir: &Path, out: &Path) -> anyhow::Result<()> {
    let csv = dir.join("stage.csv");
    let Ok(text) = std::fs::read_to_string(&csv) else {
        return Ok(());
    };
    let rows = parse_stage_csv(&text).with_context(|| format!("reading {}", csv.display()))?;
    let fitted = dir.join("calibration.toml");
    let fitted_kept = std::fs::canonicalize(&fitted).ok() == std::fs::canonicalize(out).ok();
    // Only plain names in the folder: a hand-edited `../x.png` is not ours.
    let plain = |name: &str| {
        let mut parts = Path::new(name).components();
        matches!(parts.next(), Some(std::path::Component::Normal(_))) && parts.next().is_none()
    };
    let listed = rows
        .iter()
        .filter(|r| plain(&r.frame))
        .map(|r| dir.join(&r.frame));
    let old_files = listed
        .chain([csv.clone()])
        .chain((!fitted_kept).then_some(fitted));
    let mut removed = 0;
    for path in old_files.filter(|p| p.is_file()) {
        std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        removed += 1;
    }
    println!(
        "replacing the recording in {}: {removed} files of the earlier one removed",
        dir.display()
    );
    Ok(())
}

/// Writes the shot's frame, adds its row and rewrites stage.csv, so that an
/// interrupted run leaves a recording of what it took.
fn save_shot(dir: &Path, shot: &CalibrationShot, rows: &mut Vec<StageRow>) -> anyhow::Result<()> {
    let name = format!("frame_{:03}.png", rows.len());
    let path = dir.join(&name);
    save_png(&shot.frame, &path).with_context(|| format!("writing {}", path.display()))?;
    let (x_um, y_um) = (shot.stage_m[0] * 1e6, shot.stage_m[1] * 1e6);
    match shot.apex_px {
        Some([x, y]) => {
            println!("{name}: stage ({x_um:.3}, {y_um:.3}) um, tip at ({x:.2}, {y:.2}) px")
        }
        None => println!("{name}: stage ({x_um:.3}, {y_um:.3}) um, no tip found"),
    }
    rows.push(StageRow {
        frame: name,
        x_um,
        y_um,
    });
    let csv = dir.join("stage.csv");
    std::fs::write(&csv, stage_csv(rows)).with_context(|| format!("writing {}", csv.display()))
}
