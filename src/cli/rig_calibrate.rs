//! `nanopush rig calibrate --rig FILE`: measures the camera's pixel-to-stage
//! map on the rig. The tip is moved over a grid that covers the view
//! ([`run_calibration`]), each frame is saved with the stage's position as
//! a recording (frames and stage.csv, what `nanopush calibrate` reads), and
//! the map is fitted from that recording and written where the rig file
//! looks for it, so that `assemble --rig` uses it next.

use super::calibrate::{FitArgs, check_output, fit_recording};
use super::folder_flag::check_folder_flag;
use super::made_folder::MadeFolder;
use super::rig_probe::camera_error;
use super::stage_csv::{StageRow, parse_stage_csv, stage_csv};
use crate::calib::calibration_run::{
    CalibrationRunError, CalibrationRunSettings, CalibrationShot, StageLeft, run_calibration,
};
use crate::calib::camera_map::CameraCalibration;
use crate::calib::fit_quality::{MIN_INLIERS, enough_to_fit};
use crate::exec::camera_look::LOOK_GRABS;
use crate::exec::observe::{ObserveError, grab_frame};
use crate::exec::travel_height::{check_travel_height, clear_height_m};
use crate::model::Scene;
use crate::rig::gcs::RigFile;
use crate::rig::hardware::{HardwareRigOptions, RigDevices};
use crate::rig::stage::{NanoStage, StageXyz};
use crate::vision::frame_input::{Channel, save_png};
use crate::wording::counted;
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
    /// The scene whose particles the tip must clear: its travel height is
    /// at least their tops plus 2 um, as `assemble --rig` travels.
    #[arg(long, default_value = "calib/paper-ps-ito.toml")]
    pub scene: PathBuf,
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

/// What a refusal after the rig is opened, before its first move, says first.
const UNMOVED: &str = "refused before anything moved";

/// What `--recording` takes, for a file given there.
const RECORDING_FOLDER: &str =
    "a recording folder (frames and stage.csv; --recording takes the folder, made if missing)";

/// Travel speed of the run: slow enough for any piezo stage, capped by the
/// rig file's top speed.
const TRAVEL_SPEED_UM_S: f64 = 20.0;

/// Records the grid, fits the map and writes it.
pub fn run(args: Args) -> anyhow::Result<()> {
    args.fit.check()?;
    if let Some(recording) = &args.recording {
        check_folder_flag("--recording", recording, RECORDING_FOLDER)?;
    }
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
    let no_z = format!(
        "{}: the stage has no z axis (stage.axes {:?})",
        args.rig.display(),
        rig.stage.axes
    );
    // Said before the run: on a stage without z, the run's refusal of the
    // height had advised running the same command again.
    if let (false, Some(z_um)) = (rig.stage.has_z(), args.z_um) {
        let lift = match args.tip_lifted_by_hand {
            true => "",
            false => ", lift the tip clear by hand and pass --tip-lifted-by-hand",
        };
        bail!(
            "{no_z}, so --z-um {z_um} does not apply: the tip stays at the height it is lifted to by hand. Leave --z-um out{lift}"
        );
    }
    if !rig.stage.has_z() && !args.tip_lifted_by_hand {
        bail!(
            "{no_z}, so the tip cannot be lifted and the grid would sweep it across the sample (particles moved 6 um on a simulated run): lift it clear by hand, then pass --tip-lifted-by-hand"
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
    check_z_flag(args, &devices).context(UNMOVED)?;
    first_frame(&mut devices).context(UNMOVED)?;
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
    if let Err(stop) = ran {
        // The stage goes back to where it started unless Ctrl-C or a fault
        // stopped it, and the frames already saved are worth a fit (neither
        // had been said). Said as it happened: a run that had only lifted
        // the tip had been said to have "stopped ...; not put back".
        let moved = devices.moved_any();
        let at = where_left(moved, stop.left, devices.position().ok());
        let fix = flag_fix(&stop.error, args);
        let kept = saved_frames(
            &folder,
            recording,
            out,
            rows.len(),
            with_tip,
            fix.as_deref(),
        );
        return Err(stop.error).with_context(|| {
            format!(
                "calibration run on {} stopped: {at}; {kept}",
                args.rig.display()
            )
        });
    }
    let new = fit_recording(recording, out, Channel::Luminance, &args.fit, args.force)?;
    println!(
        "recording: {} ({})",
        recording.display(),
        counted(rows.len(), "frame")
    );
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

/// Where the stopped run left the stage, as it happened: untouched, put
/// back (after only a lift, or after moving in x and y), or stopped where
/// it was (Ctrl-C, a fault).
fn where_left(moved: bool, left: StageLeft, position: Option<StageXyz>) -> String {
    let here = position.map(|p| {
        format!(
            "({:.2}, {:.2}) um, the tip {:.2} um above the substrate",
            p[0] * 1e6,
            p[1] * 1e6,
            p[2] * 1e6
        )
    });
    let at = |what: &str| {
        here.as_ref()
            .map_or(what.to_owned(), |h| format!("{what}, at {h}"))
    };
    match left {
        StageLeft::Untouched => at("nothing moved: the stage is where it was"),
        StageLeft::PutBack { .. } if !moved => at("nothing moved: the stage is where it was"),
        StageLeft::PutBack { xy_moved: false } => at(
            "only the tip's height changed (x and y never moved), and it was put back where it was",
        ),
        StageLeft::PutBack { xy_moved: true } => at("the stage was put back where it started"),
        StageLeft::NotPutBack if !moved => at("nothing moved: the stage is where it was"),
        StageLeft::NotPutBack => here.map_or(
            "where the stage stopped could not be read".to_owned(),
            |h| format!("the stage stopped at {h}; it was not put back"),
        ),
    }
}

/// The flag to give instead, when the run stopped on a value the user
/// gave (a `--step-um` with no room in the stage's range): the same
/// command again would stop the same way.
fn flag_fix(error: &CalibrationRunError, args: &Args) -> Option<String> {
    match error {
        CalibrationRunError::NoRoom { room_um, .. } => {
            let default_um = CalibrationRunSettings::default().probe_step_m * 1e6;
            let step_um = default_um.min((room_um * 10.0).floor() / 10.0);
            Some(format!("--step-um {step_um} instead of {}", args.step_um))
        }
        _ => None,
    }
}

/// Refuses, before anything moves, a `--z-um` the tip could not travel
/// at: among the particles (the rule `assemble --rig` travels by,
/// [`check_travel_height`], so that neither takes a height the other
/// refuses), or above the top of z travel; the refusal names the heights
/// that would do. A stage whose z cannot rise clear at all is refused as
/// `assemble --rig` refuses it.
fn check_z_flag(args: &Args, devices: &RigDevices) -> anyhow::Result<()> {
    let stage = &devices.rig_file().stage;
    if !stage.has_z() {
        return Ok(());
    }
    let radius_m = Scene::load(&args.scene)
        .with_context(|| format!("scene {} (--scene)", args.scene.display()))?
        .particle_radius_m;
    let top_m = devices.range()[2].max_m;
    let z_m = args.z_um.map(|z| z * 1e-6);
    // Heights to 0.1 um, inside the accepted range (15 um read back from
    // the controller is 14.999999999999998, not to be said as 14.9).
    let accepted = |lo_um: f64, hi_um: f64| {
        format!(
            "give --z-um from {:.1} to {:.1}, or leave it out (the top of z travel)",
            (lo_um * 10.0 - 1e-6).ceil() / 10.0,
            (hi_um * 10.0 + 1e-6).floor() / 10.0
        )
    };
    if let Err(e) = check_travel_height(z_m, top_m, radius_m, stage) {
        return Err(match e.accepted_um(top_m * 1e6) {
            Some((lo, hi)) => anyhow::anyhow!(
                "--z-um {}: {e}: {}",
                args.z_um.unwrap_or(0.0),
                accepted(lo, hi)
            ),
            None => e.into(),
        });
    }
    match (args.z_um, z_m) {
        (Some(z_um), Some(z)) if z > top_m => bail!(
            "--z-um {z_um}: above the top of the stage's z travel, {:.3} um above the substrate: {}",
            top_m * 1e6,
            accepted(clear_height_m(radius_m) * 1e6, top_m * 1e6)
        ),
        _ => Ok(()),
    }
}

/// Waits for the camera's first frame before anything moves: a camera
/// that gives none fails in [`LOOK_GRABS`] tries of its timeout, saying
/// what to check (as `rig probe --camera` does), where the run had waited
/// 10 tries at its first stop, 51 s with no word, after lifting the tip.
/// An empty first try is said on stderr, since the second takes as long.
fn first_frame(devices: &mut RigDevices) -> anyhow::Result<()> {
    let source = devices.rig_file().camera.clone();
    let tried = match grab_frame(devices, 1) {
        Err(ObserveError::NoFrame(_)) => {
            eprintln!(
                "waiting for a frame from the camera ({}): {}",
                source.describe(),
                source.when_no_frame()
            );
            grab_frame(devices, LOOK_GRABS - 1).map_err(|e| match e {
                ObserveError::NoFrame(_) => ObserveError::NoFrame(LOOK_GRABS),
                other => other,
            })
        }
        other => other,
    };
    tried.map(drop).map_err(|e| camera_error(&source, e))
}

/// What a stopped run left and what to do with it. Only a fit the saved
/// frames can pass is advised (the 5 frames of a stopped run had been
/// advised to `calibrate`, which refuses under 6); with no frame the
/// folder the run made goes (empty folders had been left behind), so the
/// same command is accepted again. `fix` is the flag to give instead, when
/// one of the user's stopped it.
fn saved_frames(
    folder: &MadeFolder,
    recording: &Path,
    out: &Path,
    frames: usize,
    with_tip: usize,
    fix: Option<&str>,
) -> String {
    let dir = recording.display();
    if frames == 0 {
        let left = folder.undo_said();
        return format!("no frame was taken, {dir} {left}; {}", again(fix, false));
    }
    if enough_to_fit(with_tip) {
        return format!(
            "{} saved in {dir} (fit them with `nanopush calibrate --recording {dir} --out {}`, or {})",
            counted(frames, "frame"),
            out.display(),
            again(fix, true)
        );
    }
    format!(
        "{} saved in {dir}, {with_tip} with a tip: too few to fit a map (at least {MIN_INLIERS}); {}",
        counted(frames, "frame"),
        again(fix, true)
    )
}

/// The command to run next: the same again (with `--force` over a
/// recording it left), or with `fix` instead of the flag that stopped it.
fn again(fix: Option<&str>, force: bool) -> String {
    match (fix, force) {
        (None, false) => "run the same command again".into(),
        (None, true) => "run the same command again with --force".into(),
        (Some(fix), false) => format!("run it again with {fix}"),
        (Some(fix), true) => format!("run it again with --force and {fix}"),
    }
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
        "replacing the recording in {}: {} of the earlier one removed",
        dir.display(),
        counted(removed, "file")
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
