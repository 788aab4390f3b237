//! `nanopush assemble`: assemble a pattern on the simulated rig, or resume a
//! run from its journal. Writes the journal, the simulated rig's state,
//! `report.json`, `final.png` and `sites.json` in the output folder.

use crate::exec::assemble::{
    Assembly, AssemblyInputs, AssemblySettings, FrameSink, PushIntent, PushRecord, RunEnd,
};
use crate::exec::events::{RunEvent, RunSpec, SeenParticle};
use crate::exec::journal::{JournalWriter, read_journal};
use crate::exec::observe::{Perception, Sighting};
use crate::exec::report::{
    AssemblyReport, REPORT_SCHEMA, count_journal, error_figures_nm, lower_bound_s,
};
use crate::model::{Scene, simulate_push};
use crate::plan::pattern::transform::{Reachable, place_optimised};
use crate::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use crate::plan::{DEFAULT_SITE_GAP_M, Layout, Pattern, PlanConfig, Site};
use crate::rig::Rig;
use crate::rig::sim::build::build_sim_rig;
use crate::rig::sim::rig::SimRig;
use crate::vision::detect::DetectSettings;
use crate::vision::frame_input::save_png;
use crate::vision::tip::TipSettings;
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};

/// Field of the simulated rig's random layouts, micrometres.
const SIM_FIELD_UM: [f64; 2] = [120.0, 100.0];

/// Arguments of `nanopush assemble`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Text to assemble in the built-in 3x5 font, e.g. CMU.
    #[arg(long, conflicts_with = "pattern", required_unless_present_any = ["pattern", "resume"])]
    pub text: Option<String>,
    /// Pattern file (site list TOML/JSON or bitmap image).
    #[arg(long)]
    pub pattern: Option<PathBuf>,
    /// Scene: probe, particle, materials, environment, push speed.
    #[arg(long, default_value = "calib/paper-ps-ito.toml")]
    pub scene: PathBuf,
    /// Layout file for the simulated rig (default: a random layout from --seed).
    #[arg(long)]
    pub layout: Option<PathBuf>,
    /// Seed of the random layout and of the simulated rig's noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Particles in the random layout.
    #[arg(long, default_value_t = 50)]
    pub particles: usize,
    /// Output folder (must not hold a journal yet).
    #[arg(long, default_value = "out/assemble")]
    pub out: PathBuf,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Continue the run whose journal this is, on the same world.
    #[arg(long, conflicts_with_all = ["text", "pattern", "layout"])]
    pub resume: Option<PathBuf>,
    /// Fault injection (tests): frames the camera drops, counted from 0.
    #[arg(long, hide = true, value_delimiter = ',')]
    pub drop_frames: Vec<usize>,
    /// Fault injection (tests): the stage move, counted from 0, that stops halfway with a fault.
    #[arg(long, hide = true)]
    pub fail_at_move: Option<usize>,
    /// Fault injection (tests): `particle:frame` pairs the camera does not show.
    #[arg(long, hide = true, value_delimiter = ',')]
    pub hide: Vec<String>,
    /// Hardware rig: --rig FILE, --dry-run, --yes-move-hardware.
    #[command(flatten)]
    pub hardware: super::assemble_rig::RigArgs,
}

const JOURNAL: &str = "journal.jsonl";
const SIM_STATE: &str = "sim-state.json";

/// Runs the assembly and prints the report.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.hardware.rig.is_some() {
        return super::assemble_rig::run(&args);
    }
    let report = match &args.resume {
        Some(journal) => resume(&args, journal)?,
        None => start(&args)?,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&json_summary(&report))?);
    } else {
        print_summary(&report, &args.out);
    }
    if report.outcome != "done" {
        bail!("assembly did not finish: {}", report.outcome);
    }
    Ok(())
}

fn start(args: &Args) -> anyhow::Result<AssemblyReport> {
    let scene = load_scene(&args.scene)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let layout = layout_for(args.layout.as_deref(), &scene, args.seed, args.particles)?;
    let sites = sites_for(args, &scene, &layout)?;
    let spec = RunSpec {
        pattern: args
            .text
            .clone()
            .or_else(|| args.pattern.as_ref().map(|p| p.display().to_string()))
            .unwrap_or_default(),
        scene: args.scene.display().to_string(),
        layout: args.layout.as_ref().map(|p| p.display().to_string()),
        seed: args.seed,
        sites_um: sites
            .iter()
            .map(|s| [s.centre_m.x * 1e6, s.centre_m.y * 1e6])
            .collect(),
        radius_um: scene.particle_radius_m * 1e6,
    };
    let journal_path = args.out.join(JOURNAL);
    let journal = JournalWriter::create(&journal_path).with_context(|| {
        format!(
            "{} exists: use --resume {0} or another --out",
            journal_path.display()
        )
    })?;
    let mut rig = build_sim_rig(&scene, &layout, args.seed)?;
    inject_faults(&mut rig, args)?;
    rig.persist_to(args.out.join(SIM_STATE))?;
    let inputs = inputs_for(&scene, sites, &rig, layout.field_m);
    let run = {
        let mut progress = Progress::new(inputs.sites.len());
        let mut assembly =
            Assembly::start(&mut rig, inputs, journal, spec)?.with_sink(&mut progress);
        let end = assembly.run()?;
        Finished::of(assembly, end)
    };
    finish(run, &rig, &scene, &args.out, &journal_path)
}

fn resume(args: &Args, journal_path: &Path) -> anyhow::Result<AssemblyReport> {
    let (journal, contents) = JournalWriter::resume::<RunEvent>(journal_path)?;
    let Some(RunEvent::Start(spec)) = contents.entries.first().map(|e| e.event.clone()) else {
        bail!("{} does not start with a run spec", journal_path.display());
    };
    let out = journal_path
        .parent()
        .unwrap_or(Path::new("."))
        .to_path_buf();
    let scene = load_scene(Path::new(&spec.scene))?;
    let layout = layout_for(
        spec.layout.as_deref().map(Path::new),
        &scene,
        spec.seed,
        args.particles,
    )?;
    let sites: Vec<Site> = spec
        .sites_um
        .iter()
        .enumerate()
        .map(|(id, s)| Site {
            id: id as u32,
            centre_m: nalgebra::Vector2::new(s[0] * 1e-6, s[1] * 1e-6),
        })
        .collect();
    let mut rig = build_sim_rig(&scene, &layout, spec.seed)?;
    rig.restore_from(&out.join(SIM_STATE))?;
    rig.persist_to(out.join(SIM_STATE))?;
    let tolerance_um = AssemblySettings::default().placed_tolerance_m * 1e6;
    let pushes_done = count_journal(&contents.entries, &spec.sites_um, tolerance_um).pushes;
    let inputs = inputs_for(&scene, sites, &rig, layout.field_m);
    let run = {
        let mut progress = Progress::new(inputs.sites.len());
        let mut assembly =
            Assembly::resume(&mut rig, inputs, journal, pushes_done)?.with_sink(&mut progress);
        let end = assembly.run()?;
        Finished::of(assembly, end)
    };
    finish(run, &rig, &scene, &out, journal_path)
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
/// and writes report.json, final.png and sites.json.
fn finish(
    run: Finished,
    rig: &SimRig,
    scene: &Scene,
    out: &Path,
    journal_path: &Path,
) -> anyhow::Result<AssemblyReport> {
    let entries = read_journal::<RunEvent>(journal_path)?.entries;
    let sites_um: Vec<[f64; 2]> = run
        .sites
        .iter()
        .map(|s| [s.centre_m.x * 1e6, s.centre_m.y * 1e6])
        .collect();
    let settings = AssemblySettings::default();
    let counts = count_journal(&entries, &sites_um, settings.placed_tolerance_m * 1e6);
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
    let (rms_error_nm, max_error_nm) = error_figures_nm(&errors_m);
    let contacts = rig.stage.contacts();
    let missed = run
        .records
        .iter()
        .filter(|r| {
            !r.lost_contact_detected
                && contacts
                    .iter()
                    .any(|c| c.t_s >= r.t_start_s && c.t_s <= r.t_end_s && c.event.lost_contact())
        })
        .count();
    let effects = simulate_push(scene, &scene.push)
        .map(|r| r.active_effects)
        .unwrap_or_default();
    let report = AssemblyReport {
        schema: REPORT_SCHEMA.to_owned(),
        outcome: match &run.end {
            RunEnd::Done => "done".to_owned(),
            RunEnd::Stopped(why) => format!("stopped: {why}"),
        },
        sites: run.sites.len(),
        filled: errors_m
            .iter()
            .filter(|e| **e <= settings.placed_tolerance_m)
            .count(),
        rms_error_nm,
        max_error_nm,
        error_source: "ground-truth".to_owned(),
        site_errors_nm: errors_m.iter().map(|e| e * 1e9).collect(),
        pushes: counts.pushes,
        repushes: counts.repushes,
        lost_contacts_detected: counts.lost_contacts_detected,
        lost_contacts_missed: Some(missed),
        time_s: rig.now_s(),
        lower_bound_s: lower_bound_s(
            &counts,
            scene.push.speed_m_per_s,
            settings.travel_speed_m_per_s,
        ),
        active_effects: effects,
    };
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    if let Some(last) = &run.last {
        save_png(&last.frame, &out.join("final.png"))?;
    }
    write_sites(&run.sites, rig, &out.join("sites.json"))?;
    Ok(report)
}

/// Writes each target site in um and in the final frame's pixels.
fn write_sites(sites: &[Site], rig: &SimRig, path: &Path) -> anyhow::Result<()> {
    let cal = rig.calibration();
    let offset = rig.stage.coarse_offset();
    let mut rows = Vec::new();
    for s in sites {
        let [x_px, y_px] =
            cal.stage_to_pixel(s.centre_m.x - offset[0], s.centre_m.y - offset[1])?;
        rows.push(serde_json::json!({
            "id": s.id,
            "x_um": s.centre_m.x * 1e6,
            "y_um": s.centre_m.y * 1e6,
            "x_px": x_px,
            "y_px": y_px,
        }));
    }
    let doc = serde_json::json!({"schema": "nanopush.sites/1", "sites": rows});
    std::fs::write(path, serde_json::to_string_pretty(&doc)?)?;
    Ok(())
}

fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    Scene::load(path).with_context(|| format!("scene {}", path.display()))
}

fn layout_for(path: Option<&Path>, scene: &Scene, seed: u64, n: usize) -> anyhow::Result<Layout> {
    match path {
        Some(p) => Ok(Layout::read(p)?),
        None => Ok(synth_layout(&SynthParams {
            n,
            field_m: [SIM_FIELD_UM[0] * 1e-6, SIM_FIELD_UM[1] * 1e-6],
            radius_m: scene.particle_radius_m,
            min_gap_m: 1e-6,
            polydisperse: false,
            kind: LayoutKind::Uniform,
            seed,
        })?),
    }
}

fn sites_for(args: &Args, scene: &Scene, layout: &Layout) -> anyhow::Result<Vec<Site>> {
    let r = scene.particle_radius_m;
    let pitch = 2.0 * r + DEFAULT_SITE_GAP_M;
    let pattern = match (&args.text, &args.pattern) {
        (Some(text), _) => Pattern::from_text(text, pitch)?,
        (None, Some(path)) => crate::plan::pattern::site_list::read_pattern(path, pitch)?,
        (None, None) => bail!("give --text or --pattern"),
    };
    let centres: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
    Ok(place_optimised(
        &pattern,
        &Reachable::for_field(layout.field_m, r),
        r,
        &centres,
    )?)
}

fn inputs_for(scene: &Scene, sites: Vec<Site>, rig: &SimRig, field_m: [f64; 2]) -> AssemblyInputs {
    let m_per_px = rig.calibration().m_per_px();
    let settings = AssemblySettings {
        field_m,
        ..AssemblySettings::default()
    };
    AssemblyInputs {
        scene: scene.clone(),
        sites,
        plan_config: PlanConfig {
            push_speed_m_per_s: scene.push.speed_m_per_s,
            travel_speed_m_per_s: settings.travel_speed_m_per_s,
            ..PlanConfig::default()
        },
        perception: Perception {
            detect: DetectSettings {
                diameter_px: 2.0 * scene.particle_radius_m / m_per_px,
                ..DetectSettings::default()
            },
            tip: TipSettings::default(),
            max_grabs: 5,
        },
        settings,
    }
}

fn inject_faults(rig: &mut SimRig, args: &Args) -> anyhow::Result<()> {
    for &n in &args.drop_frames {
        rig.drop_frame(n);
    }
    if let Some(n) = args.fail_at_move {
        rig.stage.fail_at_move(n);
    }
    for pair in &args.hide {
        let (id, frame) = pair
            .split_once(':')
            .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
            .with_context(|| format!("--hide takes particle:frame, got {pair}"))?;
        rig.hide_particle_in_frame(id, frame);
    }
    Ok(())
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
    fn frame(
        &mut self,
        _: &Sighting,
        tracks: &[SeenParticle],
        sites: &[Site],
        push: Option<&PushIntent>,
    ) {
        let filled = sites
            .iter()
            .filter(|s| {
                tracks.iter().any(|t| {
                    (t.x_um * 1e-6 - s.centre_m.x).hypot(t.y_um * 1e-6 - s.centre_m.y) <= 0.1e-6
                })
            })
            .count();
        self.bar.set_position(filled as u64);
        if let Some(p) = push {
            self.bar
                .set_message(format!("pushing particle {}", p.particle));
        }
    }
}

fn json_summary(r: &AssemblyReport) -> serde_json::Value {
    serde_json::json!({
        "sites": r.sites,
        "filled": r.filled,
        "rms_error_nm": r.rms_error_nm,
        "max_error_nm": r.max_error_nm,
        "pushes": r.pushes,
        "repushes": r.repushes,
        "lost_contacts_detected": r.lost_contacts_detected,
        "lost_contacts_missed": r.lost_contacts_missed,
        "time_s": r.time_s,
        "lower_bound_s": r.lower_bound_s,
        "active_effects": r.active_effects,
        "outcome": r.outcome,
    })
}

fn print_summary(r: &AssemblyReport, out: &Path) {
    println!("assembly {}", r.outcome);
    println!("  sites filled     {}/{}", r.filled, r.sites);
    println!(
        "  placement error  rms {:.0} nm, max {:.0} nm ({})",
        r.rms_error_nm, r.max_error_nm, r.error_source
    );
    println!("  pushes           {} ({} re-pushes)", r.pushes, r.repushes);
    match r.lost_contacts_missed {
        Some(m) => println!(
            "  lost contacts    {} detected, {} missed",
            r.lost_contacts_detected, m
        ),
        None => println!("  lost contacts    {} detected", r.lost_contacts_detected),
    }
    println!(
        "  time             {:.0} s (lower bound {:.0} s, ratio {:.2})",
        r.time_s,
        r.lower_bound_s,
        r.time_s / r.lower_bound_s.max(1e-9)
    );
    for e in &r.active_effects {
        println!("  effect           {}: {}", e.name, e.reason);
    }
    println!("report: {}", out.join("report.json").display());
}
