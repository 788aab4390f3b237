//! `nanopush assemble --rig FILE`: the same closed loop as on the simulated
//! rig, on the hardware a rig file describes ([`HardwareRig`]).
//!
//! On hardware there is no layout to start from: the first frames are the
//! layout (the first, and with the probe in view a second with it parked,
//! as the loop looks before its first plan). The pattern is placed where
//! the particles the camera sees can fill it in the least time. On a rig
//! without a coarse stage the planner's field is the nanostage's range and
//! every stroke must fit it. On a rig with one (the rig file's `[coarse]`
//! section), the field is what the first frame shows (grown by a particle
//! radius, so every particle seen lies inside), the run's sample frame has
//! its origin at the field's corner, and the executor moves the coarse
//! stage whenever a stroke leaves the nanostage's range. Safety is the
//! rig's: soft limits, step and speed checked before any byte is sent, the
//! confirmation before the first move on a rig file with
//! `real_hardware = true` (waived only by `--yes-move-hardware`), Ctrl-C
//! halting the stage (`HLT`). `--dry-run` sends nothing: an in-process
//! controller answers, the camera is still read, one push is made on paper
//! and every byte that would have gone to the stage is written to
//! `sent-bytes.log` in the output folder.
//!
//! A run stopped part way (Ctrl-C, a stage fault) goes on with `--resume
//! OUT/journal.jsonl`: its sites, field and scene come from the journal's
//! run spec, and on a rig with a coarse stage its sample frame is put back
//! (the coarse stage's reading it subtracted), so the pattern is finished
//! where it was begun; the loop looks first, so particles already on their
//! sites stay.
//!
//! The report's placement errors are what the camera measured (there is no
//! ground truth on a rig), and its time is wall time less the wait for
//! the operator's `yes` before the first move.

use super::assemble::{
    Args, check_out_free, open_recorder, print_recording, run_folder, write_sites,
};
use super::go_on::GoOn;
use super::made_folder::MadeFolder;
use super::rig_probe::camera_error;
use crate::calib::camera_map::CameraCalibration;
use crate::exec::assemble::{
    Assembly, AssemblyInputs, AssemblySettings, RunEnd, apex_beyond_doubt_m, calibration_doubt,
    layout_after_looks, too_few_in_field,
};
use crate::exec::camera_look::size_doubt;
use crate::exec::events::{RigFrame, RunEvent, RunSpec};
use crate::exec::journal::{JournalWriter, read_journal};
use crate::exec::observe::{Perception, Sighting};
use crate::exec::probe_parking::{FirstLooks, park_if_seen, parking_axis};
use crate::exec::push_reach::{longest_push_m, step_cap_note};
use crate::exec::report::{AssemblyReport, RunFacts};
use crate::exec::resume_point::ResumePoint;
use crate::exec::stop_cause::StopCause;
use crate::exec::travel_height::check_travel_height;
use crate::model::Scene;
use crate::plan::PlanConfig;
use crate::plan::pattern::PatternError;
use crate::plan::pattern::sites_um;
use crate::plan::pattern::transform::Reachable;
use crate::plan::pattern_request::PatternRequest;
use crate::plan::placement::PlacementGoal;
use crate::plan::pushes::max_push_len;
use crate::rig::Rig;
use crate::rig::error::RigError;
use crate::rig::gcs::{RigFile, SentLog};
use crate::rig::hardware::{HardwareRig, HardwareRigOptions};
use crate::rig::interrupt::{
    CAUSE, SetUpInterrupted, ctrlc_flag_answering_halting, stop_if_raised,
};
use crate::rig::stage::{CoarseStage, NanoStage};
use crate::vision::frame_input::save_png;
use anyhow::{Context, bail};
use nalgebra::Vector2;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// The hardware-rig flags of `nanopush assemble`.
#[derive(clap::Args, Debug, Default)]
pub struct RigArgs {
    /// Assemble on the rig this rig file describes (stage, camera,
    /// calibration, safety limits) instead of the simulated rig.
    #[arg(long, value_name = "FILE")]
    pub rig: Option<PathBuf>,
    /// With --rig: send nothing to the stage; log every byte that would be
    /// sent (sent-bytes.log) while an in-process controller answers. Makes
    /// one push on paper.
    #[arg(long, requires = "rig")]
    pub dry_run: bool,
    /// With --rig: move real hardware without asking first (the rig file's
    /// `real_hardware = true` otherwise asks for `yes` before the first move).
    #[arg(long, requires = "rig")]
    pub yes_move_hardware: bool,
}

const SENT_BYTES: &str = "sent-bytes.log";
const COARSE_SENT_BYTES: &str = "coarse-sent-bytes.log";
/// The files a rig run writes when it ends ([`finish_run`]), over the
/// stopped run's on a resume.
const REPORT_JSON: &str = "report.json";
const FINAL_PNG: &str = "final.png";
const SITES_JSON: &str = "sites.json";

/// What a run on the rig starts from, checked before the rig is opened.
enum RigStart {
    /// A new run: its scene, pattern request, output folder and journal.
    New {
        scene: Scene,
        target: PatternRequest,
        journal_path: PathBuf,
    },
    /// A stopped run to go on with, and its scene.
    Resume {
        point: Box<ResumePoint>,
        scene: Scene,
        journal_path: PathBuf,
    },
}

/// Runs the assembly on the hardware rig named by `args.hardware.rig`, or
/// resumes the one whose journal `--resume` names.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let hw = &args.hardware;
    let Some(rig_path) = &hw.rig else {
        bail!("assemble on a rig needs --rig FILE");
    };
    if args.layout.is_some() {
        bail!("--layout is for the simulated rig: with --rig the camera shows the layout");
    }
    // First of all: a press during the set-up (the rig opened, the first
    // frame, the plan: seconds) had ended the program without a word, or
    // gone unseen until the run's first stage command.
    let interrupt = ctrlc_flag_answering_halting(&format!(
        "stopping ({CAUSE}) now: the stage is halted and the run stopped"
    ))
    .context("installing the Ctrl-C handler")?;
    let rig_file = RigFile::load(rig_path)?;
    if !rig_file.stage.has_z() {
        bail!(
            "{}: the stage has no z axis (stage.axes {:?}): the loop lifts the tip between pushes, and without z every travel would drag it across the sample; name the z axis in stage.axes",
            rig_path.display(),
            rig_file.stage.axes
        );
    }
    // A resume declined at its first move puts the run's folder back as it
    // was, journal and report alike: kept before the journal is reopened.
    let resumed_folder = match &args.resume {
        Some(journal) => Some(resumed_folder_kept(journal)?),
        None => None,
    };
    let start = match &args.resume {
        Some(journal) => resume_start(journal, hw.dry_run)?,
        None => new_start(args)?,
    };
    let (RigStart::New { journal_path, .. } | RigStart::Resume { journal_path, .. }) = &start;
    let journal = journal_path.clone();
    let out = run_folder(&journal);
    let clock_from_s = match &start {
        RigStart::Resume { point, .. } => point.last_t_s,
        RigStart::New { .. } => 0.0,
    };
    let opened = HardwareRig::from_rig_file(
        rig_file,
        HardwareRigOptions {
            dry_run: hw.dry_run,
            waive_confirmation: hw.yes_move_hardware,
            clock_from_s,
            interrupt: Some(Arc::clone(&interrupt)),
            ..Default::default()
        },
    );
    // Stopped before anything was made or moved, said so; a resumed run's
    // folder put back (the journal's torn last line, cut on reading it).
    let untouched = |during| {
        let stop = SetUpInterrupted { during };
        match (&args.resume, &resumed_folder) {
            (Some(journal), Some(kept)) => anyhow::anyhow!(
                "{stop}: nothing was moved and {} {}; {}",
                journal.display(),
                kept.undo_said(),
                GoOn::of_journal(Some(rig_path.clone()), journal.clone()).after(StopCause::Other)
            ),
            _ => anyhow::anyhow!("{stop}: nothing was moved, nothing was started"),
        }
    };
    let mut rig = match opened {
        Err(_) if interrupt.load(Ordering::SeqCst) => {
            return Err(untouched("while the rig was opened"));
        }
        opened => opened.with_context(|| format!("opening the rig {}", rig_path.display()))?,
    };
    if interrupt.load(Ordering::SeqCst) {
        let _ = rig.halt();
        return Err(untouched("once the rig was open"));
    }
    let folder = match resumed_folder {
        Some(kept) => kept,
        None => MadeFolder::create(&out)?,
    };
    let record_folder = (args.record.as_deref())
        .map(MadeFolder::before_making)
        .transpose()?;
    let new_run = matches!(start, RigStart::New { .. });
    let result = match start {
        RigStart::New {
            scene,
            target,
            journal_path,
        } => assemble(args, &scene, &target, &mut rig, &journal_path),
        RigStart::Resume {
            point,
            scene,
            journal_path,
        } => {
            let drift_off = point.drift_off_unless(args.drift_follow);
            resume(*point, drift_off, &scene, &mut rig, &journal_path)
        }
    };
    // Whatever happened, the stage is left still.
    let _ = rig.halt();
    let mut folders = vec![(&folder, out.as_path())];
    if let (Some(made), Some(dir)) = (&record_folder, &args.record) {
        folders.push((made, dir));
    }
    if rig.declined_before_any_move() {
        return Err(declined(&folders, new_run));
    }
    // A new run refused in its set-up (the first frame, the scene against
    // the rig, the pattern) began no journal: what it made is taken back,
    // as a declined run's is (it had left an empty --out). A dry run keeps
    // its sent-bytes.log, written below: the set-up's queries and `HLT`.
    let interrupted = interrupt.load(Ordering::SeqCst);
    let result = match result {
        Err(e) if new_run && !hw.dry_run && !journal.exists() => {
            let moved = if interrupted && !rig.moved_any() {
                "nothing was moved; "
            } else {
                ""
            };
            return Err(anyhow::anyhow!(
                "{}; {moved}nothing was started: {}",
                super::error_message::error_message(&e),
                folders_said(&folders)
            ));
        }
        // A resume stopped before its loop began: its folder is put back,
        // and its journal goes on as it was (the loop's own stop says how
        // to go on; this had not).
        Err(e) if interrupted && !new_run => {
            let halted = if halt_said(&e) {
                ""
            } else {
                "; the stage was halted"
            };
            return Err(anyhow::anyhow!(
                "{}{halted}; {}; {}",
                super::error_message::error_message(&e),
                folders_said(&folders),
                GoOn::of_journal(Some(rig_path.clone()), journal).after(StopCause::Other)
            ));
        }
        result => result,
    };
    if let Some(log) = rig.sent_log() {
        let path = out.join(SENT_BYTES);
        write_sent_log(log, &path)?;
        // On stderr: stdout holds the report, with --json a JSON document.
        eprintln!("bytes that would have been sent: {}", path.display());
    }
    if let Some(log) = rig.coarse_sent_log() {
        let path = out.join(COARSE_SENT_BYTES);
        write_sent_log(log, &path)?;
        eprintln!(
            "bytes that would have been sent to the coarse stage: {}",
            path.display()
        );
    }
    let (report, end) = result?;
    // As the journal now has it: a resume with --drift-follow is kept there.
    let go_on = GoOn::of_journal(Some(rig_path.clone()), journal);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_summary(&report, rig_path, &out, hw.dry_run);
        print_recording(args);
    }
    if rig
        .interrupt_flag()
        .load(std::sync::atomic::Ordering::SeqCst)
    {
        bail!(
            "interrupted: the stage was halted; {}",
            go_on.after(end.cause())
        );
    }
    check_end(&end, hw.dry_run, &go_on)
}

/// True when `e` is a move stopped by the press ([`RigError::Interrupted`]),
/// whose words already say the stage was halted: a resume's set-up stopped
/// so had said it twice ("...; the stage was halted; the stage was halted;
/// go on with it: ...").
fn halt_said(e: &anyhow::Error) -> bool {
    e.chain()
        .any(|c| matches!(c.downcast_ref(), Some(RigError::Interrupted)))
}

/// The folder of the run whose journal a resume goes on with, keeping what
/// the resume writes before its first move can be declined, so that a
/// decline puts it back: the journal (only appended to, once a torn last
/// line is cut off: `JournalWriter::resume`) and the files [`finish_run`]
/// rewrites. (Sent-byte logs are a dry run's, which does not resume; files
/// the resume makes are removed by undo.) Nothing else is read: keeping
/// every file had read the run's videos on every resume.
fn resumed_folder_kept(journal: &Path) -> anyhow::Result<MadeFolder> {
    let appended = journal.file_name().and_then(|n| n.to_str());
    MadeFolder::before_making(&run_folder(journal))?
        .keeping(&[REPORT_JSON, FINAL_PNG, SITES_JSON], appended.as_slice())
}

/// A run whose first move was not confirmed: nothing moved, so each of
/// its `folders` (`--out` and `--record`, or the resumed run's) is put
/// back as it was. A new run's journal had blocked the same command
/// ("journal.jsonl exists: use --resume") for a run that never began, its
/// `--record` folder ("already holds recording.toml") likewise, and a
/// declined resume had appended to its journal.
fn declined(folders: &[(&MadeFolder, &Path)], new_run: bool) -> anyhow::Error {
    let then = if new_run {
        "start"
    } else {
        "go on with the run"
    };
    anyhow::anyhow!(
        "{}; {}: run the same command again to {then}",
        RigError::NotConfirmed,
        folders_said(folders)
    )
}

/// Each of `folders` (`--out`, `--record`) taken back, said: "OUT is as it
/// was before; ...".
fn folders_said(folders: &[(&MadeFolder, &Path)]) -> String {
    folders
        .iter()
        .map(|(made, dir)| format!("{} {}", dir.display(), made.undo_said()))
        .collect::<Vec<_>>()
        .join("; ")
}

/// A new run's scene, pattern and journal, checked before the rig is opened.
fn new_start(args: &Args) -> anyhow::Result<RigStart> {
    let scene =
        Scene::load(&args.scene).with_context(|| format!("scene {}", args.scene.display()))?;
    let target = args.target.request()?;
    // Checked before the rig is opened; built again for the batch the
    // first frame shows.
    target.pattern(scene.particle_radius_m)?;
    let journal_path = check_out_free(&args.out, args.hardware.rig.as_deref())?;
    Ok(RigStart::New {
        scene,
        target,
        journal_path,
    })
}

/// A stopped rig run's journal, reopened, and its scene.
fn resume_start(journal: &Path, dry_run: bool) -> anyhow::Result<RigStart> {
    if dry_run {
        bail!("--dry-run does not go on with a run: resume without it, or dry-run a new --out");
    }
    let point = ResumePoint::read(journal)?;
    if point.spec.rig.is_none() {
        bail!(
            "{} is the journal of a run on the simulated rig: resume it without --rig",
            journal.display()
        );
    }
    point.spec.warn_if_scene_changed();
    let scene = Scene::load(Path::new(&point.spec.scene))
        .with_context(|| format!("scene {} of the run", point.spec.scene))?;
    Ok(RigStart::Resume {
        point: Box::new(point),
        scene,
        journal_path: journal.to_path_buf(),
    })
}

/// Fails unless every site was filled, or a dry run spent its one push (it
/// stops there by design); any other end, a stage error above all, is a
/// non-zero exit even though the journal and report are written, saying
/// how to `go_on` (a dry run is not resumed, nor a run stopped for its
/// calibration).
fn check_end(end: &RunEnd, dry_run: bool, go_on: &GoOn) -> anyhow::Result<()> {
    let reason = end.reason().unwrap_or_default();
    match (end, dry_run) {
        (RunEnd::Done, _) | (RunEnd::PushesSpent(_), true) => Ok(()),
        (_, true) => bail!("assembly did not finish: stopped: {reason}"),
        (_, false) => bail!(
            "assembly did not finish: stopped: {reason}; {}",
            go_on.after(end.cause())
        ),
    }
}

/// Warns when a dry run's first frame shows the apex farther than
/// [`CALIBRATION_DOUBT_M`](crate::exec::assemble::CALIBRATION_DOUBT_M)
/// from its in-process stage ([`apex_beyond_doubt_m`]): a real run stops
/// there, but the real stage may simply be elsewhere (a dry run reads no
/// position from the controller), so the dry run cannot tell (it had
/// stopped blaming the calibration).
fn warn_of_unchecked_calibration(first: &Sighting) {
    if let (Some(off), Some(stage)) = (apex_beyond_doubt_m(first), first.stage_m) {
        tracing::warn!(
            "the dry run cannot check the calibration: its in-process stage starts at ({:.2}, {:.2}, {:.2}) um, \
             where the real stage may not be (nothing is read from the controller), and the camera sees the \
             apex {:.1} um from where the calibration puts that position; if the real stage is there, the \
             calibration does not fit this rig: make it again (nanopush rig calibrate). A real run checks \
             every frame and stops on it",
            stage[0] * 1e6,
            stage[1] * 1e6,
            stage[2] * 1e6,
            off * 1e6
        );
    }
}

/// `settings` fitted to the rig: the lifted travel no faster than the rig
/// file's top speed (the loop's 50 um/s had stopped a run on the E-727
/// templates' top speed of 50 and would on any lower one). Refused: a
/// scene that pushes faster than it (its pushes cannot be slowed without
/// changing what the model predicts of them), and a z travel that cannot
/// lift the tip clear of the scene's particles (a z_surface_um at the top
/// of the travel, or 10 um below it, had the tip travel sideways at 0 or
/// 5 um, among 10 um particles, before a push was refused as out of range).
/// Pushes are planned no longer than one nanostage move holds
/// ([`longest_push_m`]): the E-727 templates' 10 um step had cut pushes
/// into pieces, the particle sticking at every stop and ending short
/// (L: 10 pushes and 2 re-pushes where a 150 um step took 8 and none);
/// when that is shorter than the planner's own longest push, a note says
/// so ([`step_cap_note`]).
fn fitted_to_rig(
    mut settings: AssemblySettings,
    rig: &mut HardwareRig,
    scene: &Scene,
) -> anyhow::Result<AssemblySettings> {
    if rig.rig_file().stage.has_z() {
        let top_m = rig.range()[2].max_m;
        check_travel_height(None, top_m, scene.particle_radius_m, &rig.rig_file().stage)?;
    }
    let limits = rig.rig_file().safety_limits();
    let top_m_per_s = limits.max_speed_m_per_s;
    let push_m_per_s = scene.push.speed_m_per_s;
    if limits.check_speed(push_m_per_s).is_err() {
        bail!(
            "the scene pushes at {:.3} um/s, faster than the rig file's top_speed_um_s {:.3}: \
             slow the scene's push (speed_um_s) or allow the stage more",
            push_m_per_s * 1e6,
            top_m_per_s * 1e6
        );
    }
    settings.travel_speed_m_per_s = settings.travel_speed_m_per_s.min(top_m_per_s);
    let longest_m = longest_push_m(limits.max_step_m, scene, settings.stroke_allowance())
        .map_err(anyhow::Error::msg)?;
    let uncapped_m = max_push_len(scene.particle_radius_m, &settings.plan_config(scene));
    if let Some(note) = step_cap_note(longest_m, uncapped_m, limits.max_step_m) {
        eprintln!("note: {note}");
    }
    settings.longest_push_m = Some(longest_m);
    Ok(settings)
}

fn assemble(
    args: &Args,
    scene: &Scene,
    target: &PatternRequest,
    rig: &mut HardwareRig,
    journal_path: &Path,
) -> anyhow::Result<(AssemblyReport, RunEnd)> {
    // The run starts before its first frame is taken (the journal's start).
    let started_s = rig.now_s();
    let r = scene.particle_radius_m;
    let rig_file = args.hardware.rig.as_deref().unwrap_or(Path::new("RIG"));
    let keep_clear_m = crate::plan::keep_clear_or_default_m(
        super::assemble::keep_clear_flag_m(args.keep_clear_um)?,
        r,
    );
    let mut settings = fitted_to_rig(
        AssemblySettings {
            keep_clear_m,
            ..AssemblySettings::default()
        }
        .with_drift_off(args.no_drift_follow),
        rig,
        scene,
    )?;
    if args.hardware.dry_run {
        settings.max_pushes = 1;
        settings.check_apex = false;
    }
    let perception = perception_for(scene, rig);
    let calibration = *rig.calibration();
    let offset = if rig.has_coarse() {
        rig.coarse_position().context("reading the coarse stage")?
    } else {
        [0.0, 0.0]
    };
    stop_if_raised(rig.interrupt_flag(), "before the first frame")?;
    let first = perception.sight(rig, &calibration, offset);
    // A press while waiting for the frame is said as such, not as a camera fault.
    stop_if_raised(rig.interrupt_flag(), "at the first frame")?;
    let mut first = first
        .map_err(|e| camera_error(&rig.rig_file().camera, e))
        .context("the first frame")?;
    // A camera's newest frame may have been exposed before it was asked
    // for: the start is no later than it, so that no frame the loop
    // journals comes before the start.
    let started_s = started_s.min(first.t_s);
    first.stage_m = rig.position().ok();
    if args.hardware.dry_run {
        warn_of_unchecked_calibration(&first);
    }
    if first.particles.is_empty() {
        let other = size_doubt(&first, &perception.detect, calibration.m_per_px())
            .map_or(String::new(), |d| format!("; {d}"));
        bail!(
            "no particles of radius {:.2} um in the first frame{other} \
             (`nanopush rig probe --rig {} --camera --scene {}` shows what the camera sees)",
            r * 1e6,
            rig_file.display(),
            args.scene.display()
        );
    }
    let mut looks = first_looks_on_rig(
        rig,
        first,
        (&perception, &calibration, offset),
        settings.travel_speed_m_per_s,
        args.hardware.dry_run,
    )?;
    // `--at` is in the calibration's coordinates (those `rig probe --camera`
    // prints the view in); the run's field is the nanostage's range, or with
    // a coarse stage what the first frame shows, shifted.
    let (reachable, calibrated_to_field) = if rig.has_coarse() {
        let (corner, shift) = field_on_first_frame(rig, &mut looks, &mut settings, r)?;
        let margin = r + settings.clearance_m;
        let reachable = Reachable {
            lo_m: Vector2::new(margin, margin),
            hi_m: Vector2::new(corner[0] - margin, corner[1] - margin),
        };
        (reachable, Vector2::from(shift))
    } else {
        let range = rig.range();
        settings.field_m = [range[0].max_m, range[1].max_m];
        (
            reachable_sites(rig, r, settings.clearance_m),
            Vector2::zeros(),
        )
    };
    let in_field = PatternRequest {
        at_m: target.at_m.map(|at| at + calibrated_to_field),
        ..target.clone()
    };
    let plan_config = settings.plan_config(scene);
    // At --at, else where the full plan on what the loop's first plan will
    // see is fastest, from where the tip stands, as on the simulated rig.
    let layout = layout_after_looks(settings.field_m, looks.in_order(), r, settings.track_gate_m);
    // Built again for the batch the camera shows: wider when its radii spread.
    let radii: Vec<f64> = layout.particles.iter().map(|p| p.radius_m).collect();
    let pattern = &target.pattern_for_batch(r, &radii, &reachable)?;
    let shown_by = match looks.before_parking {
        Some(_) => "the first frames, the probe parked for the second, show",
        None => "the first frame shows",
    };
    if let Some(why) = too_few_in_field(&layout, pattern.offsets_m.len(), shown_by) {
        bail!("{why}");
    }
    let sites = in_field
        .sites(
            pattern,
            &reachable,
            &layout,
            &PlanConfig {
                tip_start_m: looks.last.tip_m.map(Vector2::from),
                ..plan_config.clone()
            },
            PlacementGoal::LeastTime,
            Some(rig.interrupt_flag()),
        )
        .map_err(|e| match (e, target.at_m) {
            // Said where the user asked, not in the shifted field.
            (PatternError::OutsideAtPlacement { lo_um, hi_um, .. }, Some(at)) => {
                let back = |v: [f64; 2]| [0, 1].map(|k| v[k] - calibrated_to_field[k] * 1e6);
                PatternError::OutsideAtPlacement {
                    x_um: at.x * 1e6,
                    y_um: at.y * 1e6,
                    lo_um: back(lo_um),
                    hi_um: back(hi_um),
                }
            }
            (e, _) => e,
        });
    // Planning takes seconds on a big pattern: a press during it ends the
    // placement after its round of centres and stops here, before the
    // journal is begun, whatever the placement ended with.
    stop_if_raised(rig.interrupt_flag(), "while the pattern was placed")?;
    let sites = sites.context("placing the pattern among the particles of the first frames")?;
    let spec = RunSpec {
        pattern: target.label(),
        scene: args.scene.display().to_string(),
        layout: None,
        seed: None,
        sites_um: sites_um(&sites),
        radius_um: r * 1e6,
        rig: Some(RigFrame {
            rig_file: rig_file.display().to_string(),
            field_um: settings.field_m.map(|v| v * 1e6),
            coarse_shift_um: rig.sample_frame_shift_m().map(|s| s.map(|v| v * 1e6)),
            first_view_coarse_um: rig
                .has_coarse()
                .then(|| [0, 1].map(|k| calibrated_to_field[k] * 1e6)),
        }),
        drift_off: args.no_drift_follow,
        keep_clear_um: settings.keep_clear_m * 1e6,
        command: None,
        scene_crc32: None,
    }
    .stamped();
    let inputs = AssemblyInputs {
        scene: scene.clone(),
        sites,
        plan_config,
        perception,
        settings: settings.clone(),
    };
    let source = format!(
        "nanopush assemble on the rig {}: pattern {:?}",
        rig_file.display(),
        spec.pattern
    );
    let mut recorder =
        open_recorder(args, source, &spec, settings.field_m, &calibration)?.map(|r| {
            if args.hardware.dry_run {
                r.without_stage_positions()
            } else {
                r
            }
        });
    // Created only now, when the run spec is known: a journal without one
    // (the first frame failed, say) would block this --out for nothing.
    let journal = JournalWriter::create(journal_path)
        .with_context(|| format!("creating {}", journal_path.display()))?;
    let mut assembly = Assembly::started_at(rig, inputs, journal, spec, started_s)?;
    if let Some(r) = recorder.as_mut() {
        assembly = assembly.with_sink(r);
    }
    let ran = RunResult::of(assembly, !args.hardware.dry_run);
    if let Some(r) = recorder {
        r.finish().context("writing the recording")?;
    }
    finish_run(ran, rig, &args.out, scene, &settings, journal_path)
}

/// Goes on with a stopped run: the rig's sample frame put back as the run
/// had it, its sites, field and scene from the journal, the drift followed
/// unless `drift_off`; the loop looks first, so particles already on their
/// sites stay.
fn resume(
    point: ResumePoint,
    drift_off: bool,
    scene: &Scene,
    rig: &mut HardwareRig,
    journal_path: &Path,
) -> anyhow::Result<(AssemblyReport, RunEnd)> {
    let frame = point
        .spec
        .rig
        .clone()
        .context("the run spec names no rig")?;
    match (frame.coarse_shift_um, rig.has_coarse()) {
        (Some(shift), true) => rig
            .restore_sample_frame(shift.map(|v| v * 1e-6))
            .context("putting the run's sample frame back on the coarse stage")?,
        (None, false) => {}
        (Some(_), false) => bail!(
            "the run was on a rig with a coarse stage ({}); this rig file has none",
            frame.rig_file
        ),
        (None, true) => bail!(
            "the run was on a rig without a coarse stage ({}); this rig file has one",
            frame.rig_file
        ),
    }
    let settings = fitted_to_rig(
        AssemblySettings {
            field_m: frame.field_um.map(|v| v * 1e-6),
            keep_clear_m: point.spec.keep_clear_um * 1e-6,
            ..Default::default()
        }
        .with_drift_off(drift_off),
        rig,
        scene,
    )?;
    if let Some(view) = frame.first_view_coarse_um {
        // The tip up first: the coarse stage refuses to drag it.
        let (top, here) = (rig.range()[2].max_m, rig.position()?);
        rig.move_to([here[0], here[1], top], settings.travel_speed_m_per_s)?;
        rig.move_coarse(view.map(|v| v * 1e-6))
            .context("moving the coarse stage to where the run first looked")?;
    }
    let sites = point.sites();
    let inputs = AssemblyInputs {
        scene: scene.clone(),
        sites,
        plan_config: settings.plan_config(scene),
        perception: perception_for(scene, rig),
        settings: settings.clone(),
    };
    let out = &run_folder(journal_path);
    stop_if_raised(rig.interrupt_flag(), "before the run went on")?;
    let ran = RunResult::of(Assembly::resume(rig, inputs, point)?, true);
    finish_run(ran, rig, out, scene, &settings, journal_path)
}

/// What a run of the loop left: how it ended, its sites, what the camera
/// measured of them last, and that last look.
struct RunResult {
    end: Result<RunEnd, crate::exec::assemble::ExecError>,
    sites: Vec<crate::plan::Site>,
    errors_m: Vec<f64>,
    stray_gap_m: Option<f64>,
    last: Option<Sighting>,
}

impl RunResult {
    /// Runs the loop to its end; the stray gap only where the stage moved
    /// (a dry run's would be the sample's as found).
    fn of(mut assembly: Assembly<'_>, stage_moved: bool) -> Self {
        let end = assembly.run();
        Self {
            end,
            errors_m: assembly.site_errors_m(),
            stray_gap_m: assembly.nearest_stray_gap_m().filter(|_| stage_moved),
            sites: assembly.sites().to_vec(),
            last: assembly.last_sighting.clone(),
        }
    }
}

/// Writes report.json, final.png and sites.json into `out` from the
/// journal and the camera's last look.
fn finish_run(
    ran: RunResult,
    rig: &mut HardwareRig,
    out: &Path,
    scene: &Scene,
    settings: &AssemblySettings,
    journal_path: &Path,
) -> anyhow::Result<(AssemblyReport, RunEnd)> {
    let RunResult {
        end,
        sites,
        errors_m,
        stray_gap_m,
        last,
    } = ran;
    let end = end?;
    let entries = read_journal::<RunEvent>(journal_path)?.entries;
    let facts = RunFacts {
        end: &end,
        sites: &sites,
        site_errors_m: &errors_m,
        error_source: "camera",
        // Nobody knows the lost contacts a real rig's loop missed.
        lost_contacts_missed: None,
        tip_landings_on_particles: None,
        time_s: rig.now_s(),
        // A hardware rig has no model inside to count.
        effect_work: None,
        nearest_stray_gap_m: stray_gap_m,
    };
    let report = AssemblyReport::from_run(facts, &entries, scene, settings);
    std::fs::write(
        out.join(REPORT_JSON),
        serde_json::to_string_pretty(&report)?,
    )?;
    if let Some(last) = &last {
        save_png(&last.frame, &out.join(FINAL_PNG))?;
    }
    // Pixels as the camera sees the sites now (the coarse stage may have
    // moved the sample under it).
    if let Some(offset) = sites_coarse_offset(rig) {
        write_sites(&sites, rig.calibration(), offset, &out.join(SITES_JSON))?;
    }
    Ok((report, end))
}

/// The coarse offset to put the sites into the camera's pixels through:
/// zero without a coarse stage, else its reading, else where it was last
/// known to stand ([`RigDevices::coarse_position_known`](crate::rig::hardware::RigDevices::coarse_position_known)),
/// said so. A coarse stage that does not answer at the end (its link lost
/// with the nanostage's) had ended the run on its error, naming neither
/// stage, with no summary, no word that the tip may be down and no
/// `--resume` line, and sites.json left as it was; `None` when where it
/// stands is not known either, said plainly: sites.json is not rewritten.
fn sites_coarse_offset(rig: &mut HardwareRig) -> Option<[f64; 2]> {
    if !rig.has_coarse() {
        return Some([0.0, 0.0]);
    }
    let e = match rig.coarse_position() {
        Ok(offset) => return Some(offset),
        Err(e) => e,
    };
    let known = rig.coarse_position_known();
    if known.is_some() {
        eprintln!(
            "note: the coarse stage did not answer ({e}): {SITES_JSON}'s pixels are through where it last stood"
        );
    } else {
        eprintln!(
            "warning: {SITES_JSON} not rewritten: the coarse stage did not answer ({e}), and where it stands is not known"
        );
    }
    known
}

/// Frame analysis for this rig's camera: the particles' size in its pixels.
fn perception_for(scene: &Scene, rig: &HardwareRig) -> Perception {
    Perception::for_run(scene.particle_radius_m, rig.calibration())
}

/// The run's field on a rig with a coarse stage: what the first frame shows
/// whole particles in, grown by a particle radius on every side so that
/// every particle seen lies inside; the sample frame is moved so that the
/// field's lower-left corner is its origin (the planner's field starts at
/// 0), and the first looks with it. Returns the field's size
/// and what a point in the calibration's coordinates (no coarse offset)
/// adds to be in the field's.
fn field_on_first_frame(
    rig: &mut HardwareRig,
    looks: &mut FirstLooks,
    settings: &mut AssemblySettings,
    radius_m: f64,
) -> anyhow::Result<([f64; 2], [f64; 2])> {
    let [lo, hi] = looks.last.view_m;
    let corner = [lo[0] - radius_m, lo[1] - radius_m];
    let offset = [
        looks.last.coarse_offset_m[0] - corner[0],
        looks.last.coarse_offset_m[1] - corner[1],
    ];
    rig.reframe_sample(offset)
        .context("setting the run's sample frame on the coarse stage")?;
    looks.reframe(corner);
    settings.field_m = [
        hi[0] - lo[0] + 2.0 * radius_m,
        hi[1] - lo[1] + 2.0 * radius_m,
    ];
    Ok((settings.field_m, offset))
}

/// The loop's first looks, taken before the pattern is placed so that it
/// is placed on what the loop's first plan sees: with the probe in view,
/// lifted and parked where its body leaves the frame, and a second frame
/// of the particles it hid (placed on the first frame alone, a site could
/// lie on one). The probe stays where it stands on a dry run, which moves
/// nothing, and when the first frame doubts the calibration or the
/// stage's unit: the loop's first look stops on that, with the apex in
/// view.
fn first_looks_on_rig(
    rig: &mut HardwareRig,
    first: Sighting,
    (perception, calibration, offset): (&Perception, &CameraCalibration, [f64; 2]),
    travel_speed_m_per_s: f64,
    dry_run: bool,
) -> anyhow::Result<FirstLooks> {
    if dry_run && parking_axis(&first).is_some() {
        eprintln!(
            "note: the dry run places the pattern on the first frame as the probe stands; \
             a real run parks the probe first and places on what it hid too, so its sites may differ"
        );
    }
    if dry_run || calibration_doubt(&first).is_some() {
        return Ok(FirstLooks::one(first));
    }
    let parked = park_if_seen(rig, &first, travel_speed_m_per_s)
        .context("parking the probe out of the camera's view")?;
    if !parked {
        return Ok(FirstLooks::one(first));
    }
    let last = perception.sight(rig, calibration, offset);
    stop_if_raised(rig.interrupt_flag(), "at the frame with the probe parked")?;
    let last = last
        .map_err(|e| camera_error(&rig.rig_file().camera, e))
        .context("the frame with the probe parked")?;
    Ok(FirstLooks {
        before_parking: Some(first),
        last,
    })
}

/// Where sites may lie on a rig without a coarse stage: a radius and the
/// clearance inside the nanostage's range, so that a particle on a site is
/// whole inside it and the tip can reach around it. (Strokes still leave the
/// range when a particle must be approached from beyond its edge; the
/// executor then stops with the rig's out-of-range error, as such a rig has
/// no coarse stage to bring it closer.)
fn reachable_sites(rig: &HardwareRig, radius_m: f64, clearance_m: f64) -> Reachable {
    let range = rig.range();
    let margin = radius_m + clearance_m;
    Reachable {
        lo_m: Vector2::new(range[0].min_m + margin, range[1].min_m + margin),
        hi_m: Vector2::new(range[0].max_m - margin, range[1].max_m - margin),
    }
}

/// One line per message, bytes outside printable ASCII escaped (`\n` ends each command).
fn write_sent_log(log: &SentLog, path: &Path) -> anyhow::Result<()> {
    let sent = log.lock().unwrap_or_else(|p| p.into_inner());
    let text: String = sent
        .iter()
        .map(|bytes| format!("{}\n", bytes.escape_ascii()))
        .collect();
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// The run's summary. A dry run moved nothing, so what the camera saw
/// after its push on paper is the sample unmoved: its placement error,
/// lost contact and drift (4.9 um, 1 lost contact, a 39 um tip offset)
/// had read as a calibration fault; they are left out, and said why.
fn print_summary(r: &AssemblyReport, rig: &Path, out: &Path, dry_run: bool) {
    println!("assembly on {}: {}", rig.display(), r.outcome);
    println!("  sites filled     {}/{}", r.filled, r.sites);
    if dry_run {
        println!(
            "  pushes           {} on paper: the stage did not move, so the camera's placement error, contact check and drift are of an unmoved sample, and not shown",
            r.pushes
        );
    } else {
        println!("  placement error  {}", r.placement_error_summary());
        println!(
            "  pushes           {} ({}, {})",
            r.pushes,
            crate::wording::counted(r.repushes, "re-push"),
            crate::wording::counted(r.lost_contacts_detected, "lost contact")
        );
    }
    println!("  run time         {:.1} s", r.time_s);
    for (what, note) in r.notes() {
        if !(dry_run && what == "tip drift") {
            println!("  {what}: {note}");
        }
    }
    println!("report: {}", out.join("report.json").display());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dry_run_fails_on_a_stage_error_and_passes_on_its_one_push() {
        let stage = RunEnd::Stopped("rig error: stage did not answer within 10000 ms".into());
        let go_on = &GoOn {
            rig: Some(PathBuf::from("R")),
            journal: PathBuf::from("J"),
            drift_off: false,
        };
        let said = "go on with it: nanopush assemble --rig R --resume J";
        let err = check_end(&stage, true, go_on).unwrap_err().to_string();
        assert!(err.contains("did not answer within 10000 ms"), "{err}");
        assert!(!err.contains(said), "a dry run is not resumed: {err}");
        let err = check_end(&stage, false, go_on).unwrap_err().to_string();
        assert!(err.ends_with(said), "{err}");
        assert!(check_end(&RunEnd::PushesSpent(1), true, go_on).is_ok());
        assert!(check_end(&RunEnd::PushesSpent(40), false, go_on).is_err());
        assert!(check_end(&RunEnd::Done, false, go_on).is_ok());
    }
}
