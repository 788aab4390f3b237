//! Setting up a run on the simulated rig: the scene, the world's layout (a
//! file or a seeded random one), the pattern placed on it, the rig with any
//! injected faults, and the executor's inputs. What `nanopush assemble` does
//! before the loop starts, as a library call so tests can drive the loop
//! in-process and watch the ground truth.

use super::assemble::{AssemblyInputs, AssemblySettings, PushRecord, layout_after_looks};
use super::events::RunSpec;
use super::observe::Perception;
use super::probe_parking::first_looks;
use crate::model::{ModelError, Scene};
use crate::plan::pattern::PatternError;
use crate::plan::pattern::sites_um;
use crate::plan::pattern::transform::Reachable;
use crate::plan::pattern_request::PatternRequest;
use crate::plan::placement::PlacementGoal;
use crate::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use crate::plan::{Layout, PlanConfig, Site};
use crate::rig::RigError;
use crate::rig::sim::build::{
    SIM_FINEST_UM_PER_PX, build_sim_rig, sim_px_across, sim_um_per_px, smallest_radius_m,
};
use crate::rig::sim::rig::SimRig;
use crate::rig::sim::stage::TimedContact;
use crate::vision::detect::RING_MODEL_MIN_DIAMETER_PX;
use crate::wording::counted;
use nalgebra::Vector2;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Field of the simulated rig's random layouts, micrometres.
pub const SIM_FIELD_UM: [f64; 2] = [120.0, 100.0];

/// What to assemble, on which world.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimRunRequest {
    /// The pattern, its pitch, rotation and placement.
    pub target: Option<PatternRequest>,
    /// Scene TOML.
    pub scene: PathBuf,
    /// Layout file (default: a random layout from `seed`).
    pub layout: Option<PathBuf>,
    /// Seed of the random layout and the rig's noise.
    pub seed: u64,
    /// Particles in the random layout.
    pub particles: usize,
    /// Faults to inject.
    pub faults: SimFaults,
    /// Do not follow the tip's drift (`assemble --no-drift-follow`).
    pub drift_off: bool,
    /// Free space the plans keep round the pattern, metres
    /// ([`AssemblySettings::keep_clear_m`]; `assemble --keep-clear-um`);
    /// None: half the scene's particle radius
    /// ([`crate::plan::keep_clear_or_default_m`]).
    pub keep_clear_m: Option<f64>,
}

/// Faults the simulated rig injects (tests).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimFaults {
    /// Frames the camera drops, counted from 0.
    pub drop_frames: Vec<usize>,
    /// The stage move, counted from 0, that stops halfway with a fault.
    pub fail_at_move: Option<usize>,
    /// (world particle id, frame) pairs the camera does not show.
    pub hide: Vec<(usize, usize)>,
}

/// Why a simulated run could not be set up; nothing has been written yet.
#[derive(Debug, thiserror::Error)]
pub enum SimRunError {
    /// The scene file.
    #[error("scene {path}: {source}")]
    Scene {
        path: PathBuf,
        #[source]
        source: ModelError,
    },
    /// The layout file or the random layout (the message says which).
    #[error("{0}")]
    Layout(String),
    /// No pattern asked for.
    #[error("give a text or a pattern file")]
    NoPattern,
    /// The pattern could not be read or placed.
    #[error(transparent)]
    Pattern(#[from] PatternError),
    /// Pattern and scene do not fit each other.
    #[error("the pattern does not fit the scene's particles (radius {radius_um:.2} um): {why}")]
    Mismatch { radius_um: f64, why: String },
    /// The simulated camera cannot show the layout's smallest particles as
    /// the rings the loop tracks ([`crate::rig::sim::build::sim_px_across`]).
    #[error(
        "particles of radius {radius_um:.2} um are {px_across:.1} px across in the simulated camera at its finest {um_per_px:.2} um/px, which draws them as rings the detector fits only from {ring_px:.0} px across: the simulated rig runs particles of radius {least_radius_um:.2} um and up"
    )]
    TooSmallToSee {
        radius_um: f64,
        px_across: f64,
        um_per_px: f64,
        ring_px: f64,
        least_radius_um: f64,
    },
    /// The simulated rig refused.
    #[error("simulated rig: {0}")]
    Rig(#[from] RigError),
    /// The first frame, which the pattern is placed on, could not be analysed.
    #[error("the first frame: {0}")]
    FirstFrame(String),
}

/// A simulated run ready to start.
pub struct SimRun {
    /// The scene.
    pub scene: Scene,
    /// The world's layout.
    pub layout: Layout,
    /// Target sites.
    pub sites: Vec<Site>,
    /// The journal's first entry.
    pub spec: RunSpec,
    /// The simulated rig, faults injected.
    pub rig: SimRig,
}

/// A file's path as the journal keeps it: absolute when the file is there,
/// so that a run resumed from another folder finds it; as given otherwise
/// (a built-in scene's name).
fn as_resumable(path: &Path) -> String {
    match std::path::absolute(path) {
        Ok(full) if path.is_file() => full.display().to_string(),
        _ => path.display().to_string(),
    }
}

/// Loads, generates, places and builds everything a run needs; a raised
/// `interrupt` ends the placement ([`PatternError::Interrupted`]).
pub fn prepare_sim_run(
    req: &SimRunRequest,
    interrupt: Option<&AtomicBool>,
) -> Result<SimRun, SimRunError> {
    let scene = Scene::load(&req.scene).map_err(|source| SimRunError::Scene {
        path: req.scene.clone(),
        source,
    })?;
    let layout = layout_for(req.layout.as_deref(), &scene, req.seed, req.particles)?;
    visible_to_sim_camera(&layout)?;
    let first_seen = layout_first_seen(&scene, &layout, req.seed)?;
    let keep_clear_m =
        crate::plan::keep_clear_or_default_m(req.keep_clear_m, scene.particle_radius_m);
    let sites = sites_for(req, &scene, &first_seen, keep_clear_m, interrupt)?;
    let spec = RunSpec {
        pattern: req
            .target
            .as_ref()
            .map(PatternRequest::label)
            .unwrap_or_default(),
        scene: as_resumable(&req.scene),
        layout: req.layout.as_deref().map(as_resumable),
        seed: Some(req.seed),
        sites_um: sites_um(&sites),
        radius_um: scene.particle_radius_m * 1e6,
        rig: None,
        drift_off: req.drift_off,
        keep_clear_um: keep_clear_m * 1e6,
        command: None,
        scene_crc32: None,
    }
    .stamped();
    let mut rig = build_sim_rig(&scene, &layout, req.seed)?;
    for &n in &req.faults.drop_frames {
        rig.drop_frame(n);
    }
    if let Some(n) = req.faults.fail_at_move {
        rig.stage.fail_at_move(n);
    }
    for &(id, frame) in &req.faults.hide {
        rig.hide_particle_in_frame(id, frame);
    }
    Ok(SimRun {
        scene,
        layout,
        sites,
        spec,
        rig,
    })
}

/// Refuses a layout whose smallest particle the simulated camera shows
/// under the ring model's size: the detector then fits pieces of its drawn
/// ring as spots, centres jumping by most of a radius between frames, and
/// the loop's pushes miss (0.3 um particles at 6 px: 0 of 8 runs done,
/// stopped after up to 56 lost contacts).
fn visible_to_sim_camera(layout: &Layout) -> Result<(), SimRunError> {
    let radius_m = smallest_radius_m(layout);
    // A rounding's worth below the size still shows it (0.6 um: 11.999... px).
    let px_across = sim_px_across(radius_m);
    if px_across >= RING_MODEL_MIN_DIAMETER_PX * (1.0 - 1e-9) {
        return Ok(());
    }
    Err(SimRunError::TooSmallToSee {
        radius_um: radius_m * 1e6,
        px_across,
        um_per_px: sim_um_per_px(radius_m),
        ring_px: RING_MODEL_MIN_DIAMETER_PX,
        least_radius_um: RING_MODEL_MIN_DIAMETER_PX * SIM_FINEST_UM_PER_PX / 2.0,
    })
}

/// The world's layout: the file, or a seeded uniform random layout of `n` particles.
pub fn layout_for(
    path: Option<&Path>,
    scene: &Scene,
    seed: u64,
    n: usize,
) -> Result<Layout, SimRunError> {
    match path {
        Some(p) => Layout::read(p).map_err(|e| SimRunError::Layout(e.to_string())),
        None => synth_layout(&SynthParams {
            n,
            field_m: [SIM_FIELD_UM[0] * 1e-6, SIM_FIELD_UM[1] * 1e-6],
            radius_m: scene.particle_radius_m,
            min_gap_m: 1e-6,
            polydisperse: false,
            kind: LayoutKind::Uniform,
            seed,
        })
        .map_err(|e| SimRunError::Layout(format!("random layout: {e}"))),
    }
}

/// What the loop's first plan sees: the particles, each with the size the
/// loop will plan it with, and where the tip is.
struct FirstSeen {
    layout: Layout,
    tip_m: Option<[f64; 2]>,
}

/// The particles as the run's first looks show them ([`first_looks`],
/// [`layout_after_looks`]): the pattern is placed on these, not on the
/// world's true layout. A place planned on true
/// radii could leave the loop, which plans on measured ones, with no order
/// at its first plan (CMU on a 5 % spread batch, seed 10). Seen on a twin
/// of the run's rig (same world, seed, moves and frames), so that the
/// run's own frame count and faults are untouched and the placement plans
/// on what the loop's first plan will see.
fn layout_first_seen(scene: &Scene, layout: &Layout, seed: u64) -> Result<FirstSeen, SimRunError> {
    use crate::rig::Rig;
    let mut twin = build_sim_rig(scene, layout, seed)?;
    let (calibration, offset) = (*twin.calibration(), twin.stage.coarse_offset());
    let r = scene.particle_radius_m;
    let perception = Perception::for_run(r, &calibration);
    let settings = AssemblySettings::default();
    let speed = settings.travel_speed_m_per_s;
    let looks = first_looks(&mut twin, &perception, &calibration, offset, speed)
        .map_err(|e| SimRunError::FirstFrame(e.to_string()))?;
    Ok(FirstSeen {
        layout: layout_after_looks(layout.field_m, looks.in_order(), r, settings.track_gate_m),
        tip_m: looks.last.tip_m,
    })
}

/// The pattern, checked against the particles and placed on them by
/// plans keeping `keep_clear_m` round it, from where the tip is, until
/// `interrupt` is raised.
fn sites_for(
    req: &SimRunRequest,
    scene: &Scene,
    first_seen: &FirstSeen,
    keep_clear_m: f64,
    interrupt: Option<&AtomicBool>,
) -> Result<Vec<Site>, SimRunError> {
    let layout = &first_seen.layout;
    let r = scene.particle_radius_m;
    let target = req.target.as_ref().ok_or(SimRunError::NoPattern)?;
    let mismatch = |why: String| SimRunError::Mismatch {
        radius_um: r * 1e6,
        why,
    };
    let radii: Vec<f64> = layout.particles.iter().map(|p| p.radius_m).collect();
    let area = Reachable::for_field(layout.field_m, r);
    let pattern = target
        .pattern_for_batch(r, &radii, &area)
        .map_err(|e| match e {
            PatternError::OverlappingSites { .. } => mismatch(e.to_string()),
            e => e.into(),
        })?;
    if pattern.offsets_m.len() > layout.particles.len() {
        return Err(mismatch(format!(
            "{} but only {}",
            counted(pattern.offsets_m.len(), "site"),
            counted(layout.particles.len(), "particle")
        )));
    }
    Ok(target.sites(
        &pattern,
        &area,
        layout,
        &PlanConfig {
            tip_start_m: first_seen.tip_m.map(Vector2::from),
            ..AssemblySettings {
                keep_clear_m,
                ..AssemblySettings::default()
            }
            .plan_config(scene)
        },
        PlacementGoal::LeastTime,
        interrupt,
    )?)
}

/// The executor's inputs for a run on the simulated rig, following the
/// tip's drift unless `drift_off`, its plans keeping `keep_clear_m` round
/// the pattern.
pub fn inputs_for(
    scene: &Scene,
    sites: Vec<Site>,
    rig: &SimRig,
    field_m: [f64; 2],
    drift_off: bool,
    keep_clear_m: f64,
) -> AssemblyInputs {
    use crate::rig::Rig;
    let settings = AssemblySettings {
        field_m,
        keep_clear_m,
        ..AssemblySettings::default()
    }
    .with_drift_off(drift_off);
    AssemblyInputs {
        scene: scene.clone(),
        sites,
        plan_config: settings.plan_config(scene),
        perception: Perception::for_run(scene.particle_radius_m, rig.calibration()),
        settings,
    }
}

/// Pushes whose particle the simulated rig let go (tip brushed over it, it
/// turned around the tip, or it stopped against another) while the camera
/// check called the push fine. The push's contact is the first one during the
/// push with a particle within a radius of where the push expected it: a
/// neighbour the tip grazed is not the pushed particle, and a later touch of
/// the placed particle is not the push losing it. A particle already within
/// `placed_tolerance_m` of the push's target when touched (a push repeated
/// because the check did not see the first one land) lost nothing.
pub fn missed_lost_contacts(
    records: &[PushRecord],
    contacts: &[TimedContact],
    radius_m: f64,
    placed_tolerance_m: f64,
) -> usize {
    let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
    records
        .iter()
        .filter(|r| {
            !r.lost_contact_detected
                && contacts
                    .iter()
                    .find(|c| {
                        c.t_s >= r.t_start_s
                            && c.t_s <= r.t_end_s
                            && dist(c.event.at_m, r.from_m) < radius_m
                    })
                    .is_some_and(|c| {
                        c.event.lost_contact() && dist(c.event.at_m, r.to_m) > placed_tolerance_m
                    })
        })
        .count()
}

#[cfg(test)]
mod missed_tests {
    use super::*;
    use crate::rig::sim::world::{ContactEvent, ContactOutcome};

    fn contact(t_s: f64, at_m: [f64; 2], outcome: ContactOutcome) -> TimedContact {
        TimedContact {
            t_s,
            event: ContactEvent {
                particle: 0,
                at_m,
                moved_m: 0.0,
                outcome,
            },
        }
    }

    #[test]
    fn only_the_pushed_particle_losing_contact_unseen_is_missed() {
        let record = |detected| PushRecord {
            t_start_s: 10.0,
            t_end_s: 20.0,
            lost_contact_detected: detected,
            from_m: [50e-6, 50e-6],
            to_m: [53e-6, 50e-6],
        };
        let (r, tol) = (5e-6, 0.2e-6);
        let pushed_lost = contact(15.0, [50.2e-6, 50e-6], ContactOutcome::LeftBehind);
        let neighbour_grazed = contact(15.0, [60.5e-6, 50e-6], ContactOutcome::LeftBehind);
        let pushed_carried = contact(15.0, [50e-6, 50e-6], ContactOutcome::Carried);
        let too_late = contact(25.0, [50e-6, 50e-6], ContactOutcome::TurnedAroundTip);
        assert_eq!(
            missed_lost_contacts(&[record(false)], &[pushed_lost], r, tol),
            1
        );
        assert_eq!(
            missed_lost_contacts(&[record(true)], &[pushed_lost], r, tol),
            0
        );
        assert_eq!(
            missed_lost_contacts(
                &[record(false)],
                &[neighbour_grazed, pushed_carried, too_late],
                r,
                tol
            ),
            0
        );
        // Carried, then touched again where it was left: the push did not lose it.
        let touched_after = contact(19.0, [53e-6, 50e-6], ContactOutcome::LeftBehind);
        assert_eq!(
            missed_lost_contacts(&[record(false)], &[pushed_carried, touched_after], r, tol),
            0
        );
        // Pushed again while already on its target (the check had not seen it
        // land): the tip stops against it without moving it, nothing is lost.
        let already_there = contact(15.0, [53.1e-6, 50e-6], ContactOutcome::LeftBehind);
        let repeated = PushRecord {
            from_m: [53.1e-6, 50e-6],
            ..record(false)
        };
        assert_eq!(
            missed_lost_contacts(&[repeated], &[already_there], r, tol),
            0
        );
    }
}
