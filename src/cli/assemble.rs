//! `nanopush assemble`: assemble a pattern on the simulated rig, or resume a
//! run from its journal. Writes, in the output folder: the journal, the
//! simulated rig's state, `report.json`, `report.md`, `final.png`,
//! `sites.json`, the run animation (`run.mp4`, `run-resume-<k>.mp4` after a
//! resume), force plots of the pushes, and with `--record` a recording that
//! `nanopush dry-run` replays.

use super::go_on::GoOn;
use super::pattern_args::PatternArgs;
use crate::calib::camera_map::CameraCalibration;
use crate::exec::animation::AnimationWriter;
use crate::exec::artifacts::{ReportFiles, write_force_plots, write_report_md};
use crate::exec::assemble::{
    Assembly, AssemblySettings, FanOut, FrameSink, FrameView, PushRecord, RunEnd,
};
use crate::exec::events::{RunEvent, RunSpec};
use crate::exec::journal::{JournalWriter, read_journal};
use crate::exec::observe::Sighting;
use crate::exec::recording::{RecordingSpec, RecordingWriter};
use crate::exec::report::{AssemblyReport, RunFacts};
use crate::exec::resume_point::ResumePoint;
use crate::exec::sim_run::{
    SimFaults, SimRun, SimRunRequest, inputs_for, layout_for, missed_lost_contacts, prepare_sim_run,
};
use crate::model::Scene;
use crate::plan::Pattern;
use crate::plan::Site;
use crate::plan::assignment::enough_particles;
use crate::plan::layout::um_in_file;
use crate::plan::pattern::sites_um;
use crate::rig::Rig;
use crate::rig::interrupt::{CAUSE, ctrlc_flag_answering, stop_if_raised};
use crate::rig::sim::build::build_sim_rig;
use crate::rig::sim::rig::SimRig;
use crate::vision::frame_input::save_png;
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// Particles in the simulated rig's random layout unless `--particles`
/// says otherwise: what `demo` and `study assemble` runs have.
pub const DEFAULT_PARTICLES: usize = 50;

/// Refuses `text` before any work when its sites outnumber the particles of
/// the simulated rig's layout (`assemble`'s default), in the planner's words.
pub fn check_text_fits_the_layout(text: &str) -> anyhow::Result<()> {
    let sites = Pattern::from_text(text, 1e-5)?.offsets_m.len();
    enough_particles(sites, DEFAULT_PARTICLES).map_err(|e| {
        anyhow::anyhow!(
            "--text {text:?}: {e} (the simulated rig's layout has {DEFAULT_PARTICLES}); give a shorter text"
        )
    })
}

/// Arguments of `nanopush assemble`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// What to assemble and where (one of --text and --pattern, unless --resume).
    #[command(flatten)]
    pub target: PatternArgs,
    /// Scene: probe, particle, materials, environment, push speed.
    #[arg(long, default_value = "calib/paper-ps-ito.toml")]
    pub scene: PathBuf,
    /// Layout file for the simulated rig (default: a random layout from --seed).
    #[arg(long)]
    pub layout: Option<PathBuf>,
    /// Seed of the random layout and of the simulated rig's noise (not
    /// with --rig: the hardware has its own).
    #[arg(long, default_value_t = 1, conflicts_with = "rig")]
    pub seed: u64,
    /// Particles in the random layout (not with --layout or --rig, whose
    /// particles are the file's or the camera's).
    #[arg(long, default_value_t = DEFAULT_PARTICLES, conflicts_with_all = ["layout", "rig"])]
    pub particles: usize,
    /// Output folder (must not hold a journal yet; a resumed run writes
    /// next to its journal, so not with --resume).
    #[arg(long, default_value = "out/assemble", conflicts_with = "resume")]
    pub out: PathBuf,
    /// Print the report as one JSON object (what report.json holds).
    #[arg(long)]
    pub json: bool,
    /// Continue the run whose journal this is: on the same simulated world,
    /// or with --rig on the rig where it stopped (its pattern, scene, seed
    /// and world are the journal's).
    #[arg(long, conflicts_with_all = ["text", "pattern", "pitch_um", "rotation_deg", "at", "layout", "scene", "seed", "particles"])]
    pub resume: Option<PathBuf>,
    /// Also write a recording of the run (frames, stage log, calibration,
    /// scene) to this folder, for `nanopush dry-run`; on the simulated rig
    /// or a real one. Not with --resume: a recording holds a run from its
    /// start.
    // (A resumed run's --record had been ignored without a word.)
    #[arg(long, conflicts_with = "resume")]
    pub record: Option<PathBuf>,
    /// Fault injection (tests): frames the camera drops, counted from 0.
    #[arg(long, hide = true, value_delimiter = ',')]
    pub drop_frames: Vec<usize>,
    /// Fault injection (tests): the stage move, counted from 0, that stops halfway with a fault.
    #[arg(long, hide = true)]
    pub fail_at_move: Option<usize>,
    /// Fault injection (tests): `particle:frame` pairs the camera does not show.
    #[arg(long, hide = true, value_delimiter = ',')]
    pub hide: Vec<String>,
    /// Do not follow the tip's drift against the sample in the frames:
    /// every move goes where the calibration alone says. For a rig whose
    /// camera sees the tip's apex poorly; a resumed run keeps its run's
    /// choice (unless --drift-follow), so not with --resume.
    #[arg(long, conflicts_with = "resume")]
    pub no_drift_follow: bool,
    /// Free space, um, the plans keep between a particle on no site and the
    /// pattern's particles, so no stray reads as part of a letter (default:
    /// half the particle radius; 0 keeps none, as `plan` by default). A
    /// resumed run keeps its run's, so not with --resume.
    #[arg(long, conflicts_with = "resume")]
    pub keep_clear_um: Option<f64>,
    /// With --resume: follow the tip's drift from here in a run started
    /// with --no-drift-follow (its journal keeps that choice otherwise), as
    /// such a run stopped for drift needs. The journal keeps this choice
    /// too: later resumes follow the drift without the flag.
    #[arg(long, requires = "resume")]
    pub drift_follow: bool,
    /// Hardware rig: --rig FILE, --dry-run, --yes-move-hardware.
    #[command(flatten)]
    pub hardware: super::assemble_rig::RigArgs,
}

const JOURNAL: &str = "journal.jsonl";
/// The animation shows frames at half size (a 560 px frame becomes 280 px).
const ANIMATION_SCALE: f64 = 0.5;
const SIM_STATE: &str = "sim-state.json";

/// Runs the assembly and prints the report.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.hardware.rig.is_some() {
        return super::assemble_rig::run(&args);
    }
    // First of all, answered at once: a press while the pattern was being
    // placed (seconds on a crowded field) had ended the run without a word
    // (or, where the shell ignores SIGINT, gone unseen and let it finish).
    let interrupt = ctrlc_flag_answering(&format!(
        "stopping ({CAUSE}) now: the simulated rig stops at its next frame or move"
    ))
    .context("installing the Ctrl-C handler")?;
    let (report, end) = match &args.resume {
        Some(journal) => resume(&args, journal, interrupt)?,
        None => start(&args, interrupt)?,
    };
    let out = match &args.resume {
        Some(journal) => run_folder(journal),
        None => args.out.clone(),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_summary(&report, &out);
        print_recording(&args);
    }
    if !report.finished() {
        let journal = args.resume.clone().unwrap_or_else(|| out.join(JOURNAL));
        let after = GoOn::of_journal(None, journal).after(end.cause());
        bail!("assembly did not finish: {}; {after}", report.outcome);
    }
    Ok(())
}

/// The journal's folder, where a run writes ("." for a bare file name,
/// whose parent is empty).
pub(super) fn run_folder(journal: &Path) -> PathBuf {
    let parent = journal.parent().filter(|p| !p.as_os_str().is_empty());
    parent.unwrap_or(Path::new(".")).to_path_buf()
}

/// `--keep-clear-um` as the planner takes it, metres, refused before any
/// work in the flag's own name (None: not given).
pub(super) fn keep_clear_flag_m(um: Option<f64>) -> anyhow::Result<Option<f64>> {
    let Some(um) = um else { return Ok(None) };
    super::plan::validate_in_flags(&crate::plan::PlanConfig {
        keep_clear_m: um * 1e-6,
        ..Default::default()
    })?;
    Ok(Some(um * 1e-6))
}

/// The library request these arguments make.
fn request(args: &Args) -> anyhow::Result<SimRunRequest> {
    let keep_clear_m = keep_clear_flag_m(args.keep_clear_um)?;
    let mut hide = Vec::new();
    for pair in &args.hide {
        let parsed = pair
            .split_once(':')
            .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
            .with_context(|| format!("--hide takes particle:frame, got {pair}"))?;
        hide.push(parsed);
    }
    Ok(SimRunRequest {
        target: Some(args.target.request()?),
        scene: args.scene.clone(),
        layout: args.layout.clone(),
        seed: args.seed,
        particles: args.particles,
        faults: SimFaults {
            drop_frames: args.drop_frames.clone(),
            fail_at_move: args.fail_at_move,
            hide,
        },
        drift_off: args.no_drift_follow,
        keep_clear_m,
    })
}

fn start(args: &Args, interrupt: Arc<AtomicBool>) -> anyhow::Result<(AssemblyReport, RunEnd)> {
    // Everything that can refuse the input does so before the folder is touched.
    let prepared = prepare_sim_run(&request(args)?, Some(&interrupt));
    // Whatever placing the pattern ended with, a press during it is what is said.
    if let Err(stop) = stop_if_raised(&interrupt, "while the pattern was placed") {
        bail!(
            "{stop}; nothing was started: {} is as it was before",
            args.out.display()
        );
    }
    let SimRun {
        scene,
        layout,
        sites,
        spec,
        mut rig,
    } = prepared?;
    let source = format!(
        "nanopush assemble on the simulated rig: pattern {:?}, seed {}, {}",
        spec.pattern,
        args.seed,
        crate::wording::counted(args.particles, "particle")
    );
    let journal_path = check_out_free(&args.out, None)?;
    let mut recorder = open_recorder(args, source, &spec, layout.field_m, rig.calibration())?;
    // The journal comes last: a journal holding no run could not be resumed
    // and would block this --out.
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    // Its being there already was refused by `check_out_free`.
    let journal = JournalWriter::create(&journal_path)
        .with_context(|| format!("creating {}", journal_path.display()))?;
    rig.persist_to(args.out.join(SIM_STATE))?;
    rig.stop_on(interrupt);
    let inputs = inputs_for(
        &scene,
        sites,
        &rig,
        layout.field_m,
        spec.drift_off,
        spec.keep_clear_um * 1e-6,
    );
    let mut animation = AnimationWriter::new(&args.out.join("run.mp4"), ANIMATION_SCALE);
    let run = {
        let mut progress = Progress::new(inputs.sites.len());
        let mut sinks: Vec<&mut dyn FrameSink> = vec![&mut progress, &mut animation];
        if let Some(r) = recorder.as_mut() {
            sinks.push(r);
        }
        let mut fan = FanOut(sinks);
        let mut assembly = Assembly::start(&mut rig, inputs, journal, spec)?.with_sink(&mut fan);
        let end = assembly.run()?;
        Finished::of(assembly, end)
    };
    if let Some(r) = recorder {
        r.finish().context("writing the recording")?;
    }
    animation.finish().context("writing the animation")?;
    finish(run, &rig, &scene, &args.out, &journal_path)
}

/// The journal a new run in `out` writes, refused before anything is
/// written when `out` is a file or holds a run already (a `--record`
/// folder made first had then blocked the corrected command).
/// `rig` is the rig file of a hardware run, which its resume needs too.
pub(super) fn check_out_free(out: &Path, rig: Option<&Path>) -> anyhow::Result<PathBuf> {
    super::folder_flag::check_folder_flag("--out", out, "a folder")?;
    let journal = out.join(JOURNAL);
    // A finished run cannot be resumed: --resume was offered, then refused.
    let finished = || {
        read_journal::<RunEvent>(&journal)
            .is_ok_and(|c| c.entries.last().is_some_and(|e| e.event == RunEvent::Done))
    };
    if journal.exists() && finished() {
        // A hardware rig's run writes report.json only.
        let report = ["report.md", "report.json"]
            .into_iter()
            .find(|r| out.join(r).exists())
            .map_or(String::new(), |r| format!(" (its report is {r} there)"));
        bail!(
            "{} holds a finished run{report}: give another --out",
            out.display()
        );
    }
    if journal.exists() {
        bail!(
            "{} exists: use --resume {0}{} or another --out",
            journal.display(),
            super::go_on::rig_flag(rig)
        );
    }
    Ok(journal)
}

/// Where `--record` wrote, and how to replay it (it went unsaid).
pub(super) fn print_recording(args: &Args) {
    if let Some(dir) = &args.record {
        println!(
            "recording: {} (replay it with nanopush dry-run --recording {0})",
            dir.display()
        );
    }
}

/// The recording `--record` asks for, made before the journal (a set-up
/// failure leaves the same command free to run again): the run's sites,
/// field, calibration and scene (its text, the built-in copy's when the
/// run used that), described by `source`.
pub(super) fn open_recorder(
    args: &Args,
    source: String,
    spec: &RunSpec,
    field_m: [f64; 2],
    calibration: &CameraCalibration,
) -> anyhow::Result<Option<RecordingWriter>> {
    let Some(dir) = &args.record else {
        return Ok(None);
    };
    let description = RecordingSpec {
        schema: String::new(),
        source,
        frames: String::new(),
        calibration: String::new(),
        particle_radius_um: spec.radius_um,
        frame_interval_s: None,
        stage_log: None,
        sites_um: Some(spec.sites_um.clone()),
        pattern_text: None,
        pattern: None,
        field_um: Some(field_m.map(|v| v * 1e6)),
        scene: None,
        detect_tip: true,
        channel: Default::default(),
        keep_clear_um: Some(spec.keep_clear_um),
    };
    let scene = crate::model::scene::scene_text(&args.scene).ok();
    RecordingWriter::create(dir, description, calibration, scene.as_deref())
        .map(Some)
        .with_context(|| format!("--record {}", dir.display()))
}

fn resume(
    args: &Args,
    journal_path: &Path,
    interrupt: Arc<AtomicBool>,
) -> anyhow::Result<(AssemblyReport, RunEnd)> {
    let point = ResumePoint::read(journal_path)?;
    let spec = &point.spec;
    if let Some(frame) = &spec.rig {
        bail!(
            "{journal} is the journal of a run on the rig {rig}: resume it with --rig {rig} --resume {journal}",
            journal = journal_path.display(),
            rig = frame.rig_file
        );
    }
    let out = run_folder(journal_path);
    spec.warn_if_scene_changed();
    let seed = spec.seed.with_context(|| {
        format!(
            "{}: its start entry has no seed, which the simulated rig's world needs",
            journal_path.display()
        )
    })?;
    let scene = load_scene(Path::new(&spec.scene))?;
    let layout = layout_for(
        spec.layout.as_deref().map(Path::new),
        &scene,
        seed,
        args.particles,
    )?;
    let sites = point.sites();
    let mut rig = build_sim_rig(&scene, &layout, seed)?;
    rig.restore_from(&out.join(SIM_STATE))?;
    rig.persist_to(out.join(SIM_STATE))?;
    rig.stop_on(interrupt);
    let drift_off = point.drift_off_unless(args.drift_follow);
    let inputs = inputs_for(
        &scene,
        sites,
        &rig,
        layout.field_m,
        drift_off,
        point.spec.keep_clear_um * 1e-6,
    );
    let mut animation = AnimationWriter::new(
        &out.join(format!("run-resume-{}.mp4", point.resumes + 1)),
        ANIMATION_SCALE,
    );
    let run = {
        let mut progress = Progress::new(inputs.sites.len());
        let mut fan = FanOut(vec![&mut progress, &mut animation]);
        let mut assembly = Assembly::resume(&mut rig, inputs, point)?.with_sink(&mut fan);
        let end = assembly.run()?;
        Finished::of(assembly, end)
    };
    animation.finish().context("writing the animation")?;
    finish(run, &rig, &scene, &out, journal_path)
}

/// Least free space between the pattern and a stray where the simulated
/// rig's particles truly are.
fn stray_gap_m(sites: &[Site], truth: &[crate::rig::sim::world::SimParticle]) -> Option<f64> {
    let centres: Vec<_> = sites.iter().map(|s| s.centre_m).collect();
    let discs: Vec<_> = (truth.iter())
        .map(|p| (nalgebra::Vector2::new(p.x_m, p.y_m), p.radius_m))
        .collect();
    crate::plan::stray_gap::seen_stray_gap_m(&centres, &discs)
}

/// What is kept of a run once the executor hands the rig back.
struct Finished {
    end: RunEnd,
    sites: Vec<Site>,
    records: Vec<PushRecord>,
    last: Option<Sighting>,
}

impl Finished {
    fn of(assembly: Assembly<'_>, end: RunEnd) -> Self {
        Self {
            end,
            sites: assembly.sites().to_vec(),
            records: assembly.records.clone(),
            last: assembly.last_sighting.clone(),
        }
    }
}

/// Builds the report from the journal and the simulated rig's ground truth,
/// and writes report.json, final.png and sites.json; the report and how
/// the run ended.
fn finish(
    run: Finished,
    rig: &SimRig,
    scene: &Scene,
    out: &Path,
    journal_path: &Path,
) -> anyhow::Result<(AssemblyReport, RunEnd)> {
    let entries = read_journal::<RunEvent>(journal_path)?.entries;
    let truth = &rig.stage.world.particles;
    let errors_m: Vec<f64> = run
        .sites
        .iter()
        .map(|s| {
            truth
                .iter()
                .map(|p| (p.x_m - s.centre_m.x).hypot(p.y_m - s.centre_m.y))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let missed = missed_lost_contacts(
        &run.records,
        rig.stage.contacts(),
        scene.particle_radius_m,
        AssemblySettings::default().placed_tolerance_m,
    );
    let facts = RunFacts {
        end: &run.end,
        sites: &run.sites,
        site_errors_m: &errors_m,
        error_source: "ground-truth",
        lost_contacts_missed: Some(missed),
        tip_landings_on_particles: Some(rig.stage.landings().len()),
        time_s: rig.now_s(),
        effect_work: Some(rig.stage.effect_work()),
        nearest_stray_gap_m: stray_gap_m(&run.sites, truth),
    };
    let report = AssemblyReport::from_run(facts, &entries, scene, &AssemblySettings::default());
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    if let Some(last) = &run.last {
        save_png(&last.frame, &out.join("final.png"))?;
    }
    write_sites(
        &run.sites,
        rig.calibration(),
        rig.stage.coarse_offset(),
        &out.join("sites.json"),
    )?;
    let plots = write_force_plots(&report.push_log, scene, out)
        .map_err(anyhow::Error::msg)
        .context("writing the force plots")?;
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    let mut animations: Vec<String> = std::fs::read_dir(out)?
        .filter_map(|e| e.ok().and_then(|e| name(&e.path())))
        .filter(|n| n.starts_with("run") && n.ends_with(".mp4"))
        .collect();
    // In run order: the first part's, then each resume's (run-resume-10
    // after run-resume-9).
    animations.sort_by(|a, b| {
        (a != "run.mp4")
            .cmp(&(b != "run.mp4"))
            .then_with(|| crate::natural_order::natural_cmp(Path::new(a), Path::new(b)))
    });
    let files = ReportFiles {
        final_frame: run.last.as_ref().map(|_| "final.png".to_owned()),
        animations,
        force_plots: plots
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "png"))
            .filter_map(|p| name(p))
            .collect(),
        journal: name(journal_path).unwrap_or_else(|| JOURNAL.to_owned()),
        sites: "sites.json".to_owned(),
        report_json: "report.json".to_owned(),
    };
    write_report_md(
        &out.join("report.md"),
        &report,
        &sites_um(&run.sites),
        &files,
    )
    .context("writing report.md")?;
    Ok((report, run.end))
}

/// Writes each target site in um and in the camera's pixels. `coarse_offset_m`
/// is where the coarse stage has moved the sample (zero on a rig without one).
pub(super) fn write_sites(
    sites: &[Site],
    cal: &CameraCalibration,
    coarse_offset_m: [f64; 2],
    path: &Path,
) -> anyhow::Result<()> {
    let mut rows = Vec::new();
    for s in sites {
        let [x_px, y_px] = cal.stage_to_pixel(
            s.centre_m.x - coarse_offset_m[0],
            s.centre_m.y - coarse_offset_m[1],
        )?;
        // Rounded as the planner's files are (`um_in_file`): 35.0 um, not
        // 35.00000000000001; pixels to a micro-pixel.
        let px = |v: f64| (v * 1e6).round() / 1e6;
        rows.push(serde_json::json!({
            "id": s.id,
            "x_um": um_in_file(s.centre_m.x),
            "y_um": um_in_file(s.centre_m.y),
            "x_px": px(x_px),
            "y_px": px(y_px),
        }));
    }
    let doc = serde_json::json!({"schema": "nanopush.sites/1", "sites": rows});
    std::fs::write(path, serde_json::to_string_pretty(&doc)?)?;
    Ok(())
}

fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    Scene::load(path).with_context(|| format!("scene {}", path.display()))
}

/// Shows sites filled on a progress bar (hidden when stderr is not a terminal).
struct Progress {
    bar: indicatif::ProgressBar,
}

impl Progress {
    fn new(sites: usize) -> Self {
        let bar = indicatif::ProgressBar::new(sites as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} sites filled {pos}/{len} {wide_bar} {msg}",
            )
            .expect("valid template"),
        );
        Self { bar }
    }
}

impl FrameSink for Progress {
    fn frame(&mut self, view: &FrameView<'_>) {
        let filled = view
            .sites
            .iter()
            .filter(|s| {
                view.tracks.iter().any(|t| {
                    (t.x_um * 1e-6 - s.centre_m.x).hypot(t.y_um * 1e-6 - s.centre_m.y) <= 0.1e-6
                })
            })
            .count();
        self.bar.set_position(filled as u64);
        if let Some(p) = view.push {
            self.bar
                .set_message(format!("pushing particle {}", p.particle));
        }
    }
}

fn print_summary(r: &AssemblyReport, out: &Path) {
    println!("assembly {}", r.outcome);
    println!("  sites filled     {}/{}", r.filled, r.sites);
    println!("  placement error  {}", r.placement_error_summary());
    println!(
        "  pushes           {} ({})",
        r.pushes,
        crate::wording::counted(r.repushes, "re-push")
    );
    if r.pushes_not_made > 0 {
        println!(
            "  not made         {} (decided, then cut off by a stop or a stage fault before the tip went down, or refused)",
            r.pushes_not_made
        );
    }
    match r.lost_contacts_missed {
        Some(m) => println!(
            "  lost contacts    {} detected, {} missed",
            r.lost_contacts_detected, m
        ),
        None => println!("  lost contacts    {} detected", r.lost_contacts_detected),
    }
    if let Some(n) = r.tip_landings_on_particles {
        println!("  tip landings     {n} on a particle (ground truth)");
    }
    println!("  time             {}", r.time_summary());
    for e in &r.active_effects {
        println!("  effect           {}: {}", e.name, e.reason);
    }
    for (what, note) in r.notes() {
        println!("  {what}: {note}");
    }
    println!("report: {}", out.join("report.md").display());
}
