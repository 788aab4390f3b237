//! `nanopush rig probe --rig FILE`: read-only look at a rig's stage
//! controller: identity, syntax version, axes, travel ranges, positions,
//! targets, servo and on-target state, velocities and the pending error.
//! It sends queries only (and `ERR?`, which clears the error it reports).
//! A rig file with a `[coarse]` section gets the same look at the coarse
//! stage's controller. With `--camera` it also grabs one frame from the
//! rig file's camera and says what the loop sees in it.
//!
//! It checks the rig file against what it saw, with the code `assemble
//! --rig` opens the rig and looks at its first frame with: the stage's
//! axes on the controller, the soft limits within the controller's travel
//! in the rig file's unit (a coarse stage in mm written as um), and the
//! probe's apex where the calibration puts the stage. Each problem is
//! reported, and the command fails (it had passed all three, which
//! `assemble` then refused).

use super::error_message::error_message;
use crate::exec::assemble::calibration_doubt;
use crate::exec::camera_look::{look, look_uncalibrated};
use crate::exec::observe::ObserveError;
use crate::model::Scene;
use crate::rig::camera_clock::WallClock;
use crate::rig::camera_open::open_camera;
use crate::rig::camera_source::CameraSource;
use crate::rig::gcs::{self, GcsController, RigFile, StageOpening};
use crate::rig::gcs_coarse_stage::GcsCoarseStage;
use crate::rig::hardware::{GcsNanoStage, HardwareRigError, load_rig_calibration};
use crate::rig::stage::{NanoStage, StageXyz};
use anyhow::Context;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// Arguments of `nanopush rig probe`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Rig file (TOML, e.g. calib/rig-gcs-sim.toml).
    #[arg(long)]
    pub rig: PathBuf,
    /// Do not open the link: log the bytes that would be sent, answer from a simulator.
    #[arg(long)]
    pub dry_run: bool,
    /// Also grab one frame from the rig file's camera and say what the
    /// loop sees in it (particles, the tip, exposure, repaired lines).
    #[arg(long)]
    pub camera: bool,
    /// With --camera: the scene whose particle radius sizes the detection
    /// (as `assemble --rig --scene` does).
    #[arg(long, default_value = "calib/paper-ps-ito.toml", requires = "camera")]
    pub scene: PathBuf,
}

/// Connects, queries and prints; never moves anything. Each part (stage,
/// coarse stage, camera) is looked at even when one before it failed, so a
/// user setting up the camera with the controller off still sees the
/// frame; the command then fails naming every part that could not be seen.
pub fn run(args: Args) -> anyhow::Result<()> {
    let rig = RigFile::load(&args.rig)?;
    // The checked stages are only queried: no move is asked of them.
    let opening = StageOpening {
        dry_run: args.dry_run,
        waive_confirmation: false,
        interrupt: Arc::new(AtomicBool::new(false)),
        operator_wait: Default::default(),
    };
    let mut parts = Vec::new();
    // A dry run's bytes are listed once the rig file's checks have sent
    // theirs too, in the order sent (they had been listed before the
    // checks' queries, which were left out).
    let mut stage_log = None;
    let stage = gcs::connect(&rig, args.dry_run)
        .with_context(|| format!("connecting to the stage of {}", args.rig.display()))
        .and_then(|(ctrl, log)| {
            stage_log = log;
            controller_section("stage", ctrl, rig.stage.unit_um, &mut parts)
        });
    let mut nanostage = stage.and_then(|ctrl| {
        GcsNanoStage::on_controller(ctrl, &rig, &opening)
            .map_err(|e| against_rig_file(&args, HardwareRigError::Stage(e)))
    });
    // A dry run's stage is a simulator's, not where the real one is.
    let stage_at = match &mut nanostage {
        Ok(stage) if !args.dry_run => stage.position().ok(),
        _ => None,
    };
    parts.extend(nanostage.err().map(Err));
    parts.extend(stage_log.map(|log| sent_bytes("stage", &log)));
    if let Some(coarse) = &rig.coarse {
        let mut coarse_log = None;
        let checked = gcs::connect_coarse(coarse, args.dry_run)
            .with_context(|| format!("connecting to the coarse stage of {}", args.rig.display()))
            .and_then(|(ctrl, log)| {
                coarse_log = log;
                controller_section("coarse stage", ctrl, coarse.stage.unit_um, &mut parts)
            })
            .and_then(|ctrl| {
                GcsCoarseStage::on_controller(ctrl, coarse, &opening)
                    .map_err(|e| against_rig_file(&args, HardwareRigError::Coarse(e)))
            });
        parts.extend(checked.err().map(Err));
        parts.extend(coarse_log.map(|log| sent_bytes("coarse stage", &log)));
    }
    if args.camera {
        parts.extend(camera_section(&rig, &args, stage_at));
    }
    let (mut seen, mut failures) = (Vec::new(), Vec::new());
    for part in parts {
        match part {
            Ok(text) => seen.push(text),
            Err(err) => failures.push(err),
        }
    }
    print!("{}", seen.join("\n"));
    match failures.len() {
        0 => Ok(()),
        1 => Err(failures.remove(0)),
        n => Err(anyhow::anyhow!(
            "{n} parts of the rig could not be seen, or do not fit the rig file: {}",
            failures
                .iter()
                .map(error_message)
                .collect::<Vec<_>>()
                .join("; ")
        )),
    }
}

/// A controller that is not what the rig file says, in the words
/// `assemble --rig` refuses it with.
fn against_rig_file(args: &Args, e: HardwareRigError) -> anyhow::Error {
    anyhow::Error::new(e).context(format!(
        "{} does not fit its controller (assemble --rig refuses it)",
        args.rig.display()
    ))
}

/// Why no frame of the rig's camera could be seen, with what to check: no
/// frame at all is not "dropped frames" (a watched folder nobody writes
/// to), and is said as `rig probe --camera` and `assemble --rig` both say it.
pub fn camera_error(source: &CameraSource, e: ObserveError) -> anyhow::Error {
    match e {
        ObserveError::NoFrame(grabs) => anyhow::anyhow!(
            "no frame from the camera ({}) in {} of its timeout: {}",
            source.describe(),
            crate::wording::counted(grabs, "try"),
            source.when_no_frame()
        ),
        other => anyhow::Error::new(other)
            .context(format!("a frame from the camera ({})", source.describe())),
    }
}
/// One frame of the rig's camera, as the loop sees it; without a
/// calibration (none made yet), what can be seen in pixels, and the
/// missing calibration as a part that could not be seen.
/// With the stage's position (`stage_at`), the apex is checked against
/// where the calibration puts it, as `assemble --rig`'s first frame is
/// ([`calibration_doubt`]).
fn camera_section(
    rig: &RigFile,
    args: &Args,
    stage_at: Option<StageXyz>,
) -> Vec<anyhow::Result<String>> {
    let scene = match Scene::load(&args.scene) {
        Ok(scene) => scene,
        Err(e) => return vec![Err(e).context(format!("scene {}", args.scene.display()))],
    };
    let calibration = load_rig_calibration(rig);
    let source = &rig.camera;
    let no_frame = |e: ObserveError| camera_error(source, e);
    let mut camera = match open_camera(source, WallClock::start()) {
        Ok(camera) => camera,
        Err(e) => {
            let mut parts =
                vec![Err(e).context(format!("opening the camera ({})", source.describe()))];
            if let Err(missing) = calibration {
                parts.push(Err(missing.into()));
            }
            return parts;
        }
    };
    match calibration {
        Ok(calibration) => {
            match look(
                source,
                camera.as_mut(),
                &calibration,
                scene.particle_radius_m,
            ) {
                Ok(mut seen) => {
                    seen.sighting.stage_m = stage_at;
                    let doubt = calibration_doubt(&seen.sighting);
                    let mut parts = vec![Ok(format!("camera:\n{seen}"))];
                    parts.extend(doubt.map(|why| {
                        Err(anyhow::anyhow!(why).context(format!(
                            "calibration {} named by {}",
                            rig.calibration.display(),
                            args.rig.display()
                        )))
                    }));
                    parts
                }
                Err(e) => vec![Err(no_frame(e))],
            }
        }
        Err(missing) => vec![
            look_uncalibrated(source, camera.as_mut())
                .map(|seen| format!("camera:\n{seen}"))
                .map_err(no_frame),
            Err(missing.into()),
        ],
    }
}

/// Probes one controller: its report, its lengths in um through the rig
/// file's `unit_um`, goes into `parts`; the controller is handed back for
/// the rig file's checks.
fn controller_section(
    what: &str,
    mut ctrl: GcsController,
    unit_um: f64,
    parts: &mut Vec<anyhow::Result<String>>,
) -> anyhow::Result<GcsController> {
    let report = probe(&mut ctrl, unit_um)
        .with_context(|| format!("probing the {what} at {}", ctrl.endpoint()))?;
    parts.push(Ok(format!("{what}:\n{report}")));
    Ok(ctrl)
}

/// A dry run's bytes for the controller `what`, in the order sent: the
/// report's queries, then the rig file's checks'.
fn sent_bytes(what: &str, log: &gcs::SentLog) -> anyhow::Result<String> {
    use std::fmt::Write;
    let sent = log
        .lock()
        .map_err(|_| anyhow::anyhow!("dry-run log poisoned"))?;
    let mut s = format!(
        "dry run: bytes that would have been sent to the {what}, in order (the report's queries above, then the rig file's checks):\n"
    );
    for bytes in sent.iter() {
        let _ = writeln!(s, "  {:?}", String::from_utf8_lossy(bytes));
    }
    Ok(s)
}

/// The controller's report; ranges, positions, targets and velocities in um
/// (controller units times `unit_um`), to 3 decimals (the nanostage's
/// nanometre) in right-aligned columns: the controller's own numbers had
/// been printed as they came, `49.99999999999999` beside `50`, in mm on a
/// coarse stage.
fn probe(ctrl: &mut GcsController, unit_um: f64) -> Result<String, gcs::GcsError> {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "endpoint:       {}", ctrl.endpoint());
    let _ = writeln!(s, "identity:       {}", ctrl.identify()?);
    let _ = writeln!(s, "GCS syntax:     {}", ctrl.syntax_version()?);
    let _ = writeln!(s, "ready (#7):     {}", ctrl.is_ready()?);
    let axes = ctrl.axes()?;
    let refs: Vec<&str> = axes.iter().map(String::as_str).collect();
    let _ = writeln!(s, "axes:           {}", axes.join(" "));
    let _ = writeln!(
        s,
        "unit:           1 controller unit = {unit_um} um (the rig file's unit_um)"
    );
    let (tmn, tmx) = (ctrl.travel_min(&refs)?, ctrl.travel_max(&refs)?);
    let (pos, target) = (ctrl.positions(&refs)?, ctrl.targets(&refs)?);
    let (servo, ont, vel) = (
        ctrl.servo(&refs)?,
        ctrl.on_target(&refs)?,
        ctrl.velocity(&refs)?,
    );
    let _ = writeln!(s, "moving (#5):    0x{:X}", ctrl.motion_mask()?);
    let _ = writeln!(
        s,
        "{:<5} {:>24}  {:>12} {:>12}  {:<6} {:<9} {:>14}",
        "axis", "range um", "position um", "target um", "servo", "on-target", "velocity um/s"
    );
    let um = |v: f64| v * unit_um;
    for i in 0..axes.len() {
        let _ = writeln!(
            s,
            "{:<5} {:>10.3} .. {:>10.3}  {:>12.3} {:>12.3}  {:<6} {:<9} {:>14.3}",
            axes[i],
            um(tmn[i]),
            um(tmx[i]),
            um(pos[i]),
            um(target[i]),
            servo[i],
            ont[i],
            um(vel[i])
        );
    }
    let pending = match ctrl.last_error()? {
        None => "none".to_string(),
        Some(e) => e.to_string(),
    };
    let _ = writeln!(s, "pending error:  {pending}");
    Ok(s)
}
