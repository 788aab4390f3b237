//! Dry-run: detection, tracking and planning on a recording, frame by frame,
//! saying what the loop would command without moving anything. The same
//! perception, tracker, planner and model decision as the closed loop
//! ([`super::assemble`]); only the rig is replaced by the recorded frames.

use super::assemble::{
    AssemblySettings, FrameView, PlannedPush, PushIntent, calibration_doubt, decide_push,
    layout_measured, planning_particles, too_few_in_field, track_to_site_m,
};
use super::camera_look::warn_of_pieces;
use super::dry_run_plan::{kept_plan, not_made};
use super::events::SeenParticle;
use super::observe::{ObserveError, Perception, Sighting};
use super::particle_sizes::ParticleSizes;
use super::recording::{RECORDING_FILE, Recording, RecordingError};
use super::recording_check::{check_sites_in_field, sites_of};
use super::tracker::{Moved, Tracker};
use crate::model::Scene;
use crate::plan::pattern::sites_um;
use crate::plan::pattern::transform::Reachable;
use crate::plan::pattern_request::{PatternRequest, PatternSource};
use crate::plan::placement::PlacementGoal;
use crate::plan::tip_scale::DEFAULT_GEOMETRY_RADIUS_M;
use crate::plan::verify::pushable_later;
use crate::plan::{Layout, Plan, PlanConfig, Site, Step, plan_assembly, verify_plan};
use crate::rig::RigError;
use crate::rig::camera::{Camera, TimedFrame};
use crate::vision::exposure::Exposure;
use crate::vision::line_defects::LineDefect;
use crate::wording::counted;
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

/// Schema of `dry-run.json`.
pub const DRY_RUN_SCHEMA: &str = "nanopush.dry-run/1";

/// What the loop would command after one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DryCommand {
    /// The next push, with the model's choice when a scene is known.
    Push {
        /// Track id.
        particle: usize,
        /// Centre now, micrometres.
        from_um: [f64; 2],
        /// Centre wanted, micrometres.
        to_um: [f64; 2],
        /// Model's contact angle, degrees.
        contact_angle_deg: Option<f64>,
        /// Model's push duration, seconds.
        duration_s: Option<f64>,
        /// Why the model gave no advice, if it refused.
        model_refused: Option<String>,
    },
    /// Every site is filled: nothing to command.
    Done,
    /// The planner found no push; the reason it gave.
    Refused {
        /// Why.
        reason: String,
    },
}

/// One frame of a dry-run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DryRunFrame {
    /// Frame number.
    pub frame: usize,
    /// What the frame is called in the recording: its file's name, or the
    /// video's name and frame number (absent in files written before this
    /// field).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// Time of the frame, seconds.
    pub t_s: f64,
    /// Tracked particles.
    pub particles: Vec<SeenParticle>,
    /// Tip apex on the sample, micrometres.
    pub tip_um: Option<[f64; 2]>,
    /// Sites with a particle within the placement tolerance.
    pub filled: usize,
    /// What the loop would command.
    pub command: DryCommand,
    /// Camera lines repaired from their neighbours before detection (absent
    /// when none, and in files written before this field).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub repaired_lines: Vec<LineDefect>,
    /// The frame's clipped fractions when either is above the warning level
    /// (absent otherwise, and in files written before this field).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clipped: Option<Exposure>,
    /// True when this frame shows that the recorded run did not make the
    /// push the frame before commanded (frame 0's, which the loop never
    /// makes: it parks the probe first; or a run that chose another
    /// order): from here the dry-run plans from what the recording shows,
    /// and its commands may differ from the run's (absent when false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub last_command_not_made: bool,
}

/// The whole dry-run (`dry-run.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DryRunReport {
    /// Always [`DRY_RUN_SCHEMA`].
    pub schema: String,
    /// The recording's folder.
    pub recording: String,
    /// Target sites, micrometres.
    pub sites_um: Vec<[f64; 2]>,
    /// Frame by frame.
    pub frames: Vec<DryRunFrame>,
    /// Why the replay ended before the recording's end, if it did: Ctrl-C,
    /// or a frame that could not be read (a recorder that crashed mid-write
    /// leaves its last frame cut short). The frames before are kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ended_early: Option<String>,
    /// Frames after an unreadable one the replay did not reach (0 when it
    /// was the last): a damaged frame mid-recording is a failed dry-run,
    /// not a finished one.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unread_after: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Why a dry-run could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DryRunError {
    /// The target pattern could not be read or placed on the recorded particles.
    #[error("target: {0}")]
    Target(String),
    /// The recording's frames could not be read, or do not fit together.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A frame could not be analysed.
    #[error("frame {frame}: {source}")]
    Frame {
        frame: usize,
        #[source]
        source: ObserveError,
    },
}

/// One recorded frame as a camera: the grab gives it.
struct Replay(Option<TimedFrame>);

impl Camera for Replay {
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        self.0
            .take()
            .map(Some)
            .ok_or_else(|| RigError::Io("the recording has no more frames".into()))
    }
}

/// Runs perception, tracking and planning over every frame of `recording`,
/// read one at a time; with a `scene`, also the model's decision for each
/// push; the pattern `asked` for instead of the recording's target, when
/// given. `on_frame` sees each frame as it is analysed, with what the loop
/// knew then and its outcome, in one call: what the caller keeps of a
/// replay stopped part way (Ctrl-C, `cli/dry_run.rs`) holds every frame it
/// saw whole, animated and printed alike. A frame after the first that
/// cannot be read ends the replay there ([`DryRunReport::ended_early`]):
/// what was analysed is kept.
pub fn dry_run(
    recording: &Recording,
    scene: Option<&Scene>,
    asked: Option<&PatternRequest>,
    on_frame: &mut dyn FnMut(&FrameView<'_>, &DryRunFrame),
) -> Result<DryRunReport, DryRunError> {
    let radius_m = recording.spec.particle_radius_um * 1e-6;
    let keep_clear_m = crate::plan::keep_clear_or_default_m(
        recording.spec.keep_clear_um.map(|um| um * 1e-6),
        radius_m,
    );
    let planning = plan_config(scene, keep_clear_m);
    let calibration = recording.calibration;
    let perception = Perception::for_particles(radius_m, calibration.m_per_px(), 1);
    // The loop's own tracking gate and placed tolerance.
    let loop_settings = AssemblySettings::default();
    let mut tracker = Tracker::new(loop_settings.track_gate_m);
    let mut sites: Option<Vec<Site>> = None;
    let mut field_m = [0.0, 0.0];
    let mut frames = Vec::new();
    let mut commanded: Option<Moved> = None;
    let mut in_hand: Option<Plan> = None;
    // The loop's first look checks the calibration against the stage (the
    // dry-run had commanded pushes through a mirrored one, exit 0): once a
    // frame shows the apex where the stage log was not, every later frame
    // says the loop stopped there.
    let mut calibration_checked = false;
    let mut loop_stopped: Option<String> = None;
    let mut ended_early = None;
    let mut unread_after = 0;
    let frames_in = recording.frames()?;
    let exact_len = frames_in.exact_len();
    for (i, recorded) in frames_in.enumerate() {
        let recorded = match recorded {
            Ok(recorded) => recorded,
            Err(e @ RecordingError::Format { .. }) if i > 0 => {
                unread_after = exact_len.map_or(0, |n| n.saturating_sub(i + 1));
                let rest = if unread_after > 0 {
                    format!("; {} after it not analysed", counted(unread_after, "frame"))
                } else {
                    String::new()
                };
                ended_early = Some(format!(
                    "{e}; the replay ends there, after {}{rest}",
                    counted(i, "frame")
                ));
                break;
            }
            Err(e) => return Err(e.into()),
        };
        let mut camera = Replay(Some(TimedFrame {
            t_s: recording.time_s(i),
            frame: recorded.frame,
        }));
        let mut sighting = perception
            .sight(&mut camera, &calibration, recording.coarse_offset_m(i))
            .map_err(|source| DryRunError::Frame { frame: i, source })?;
        if !recording.spec.detect_tip {
            sighting.tip_m = None;
        }
        sighting.stage_m = recording
            .stage_log
            .as_ref()
            .and_then(|log| log[i].stage_um)
            .map(|p| [p[0] * 1e-6, p[1] * 1e-6, p[2] * 1e-6]);
        // The push the last frame commanded is taken as made, as the loop
        // takes its own: the particle is matched along its line. Matched
        // as unpushed, a particle pushed out from under the probe got a
        // new id, and its old place stayed behind as a ghost the planner
        // pushed.
        tracker.update(&sighting.particles, commanded.as_slice(), &|x, y| {
            sighting.shows(x, y)
        });
        let last_command_not_made = commanded.is_some_and(|m| not_made(m, &tracker));
        if sites.is_none() {
            warn_of_pieces(
                "first frame",
                &sighting,
                &perception.detect,
                calibration.m_per_px(),
            );
            field_m = recording
                .spec
                .field_um
                .map_or(sighting.view_m[1], |f| [f[0] * 1e-6, f[1] * 1e-6]);
            sites = Some(target_sites(
                recording,
                asked,
                &sighting.particles,
                field_m,
                radius_m,
                &planning,
            )?);
        }
        let sites = sites.as_deref().unwrap_or_default();
        let tracks: Vec<SeenParticle> = tracker
            .tracks()
            .iter()
            .filter(|t| t.missed_frames == 0)
            .map(|t| SeenParticle {
                id: t.id,
                x_um: t.last.x_m * 1e6,
                y_um: t.last.y_m * 1e6,
                r_um: t.last.radius_m * 1e6,
            })
            .collect();
        // Over every track, as the loop judges: a particle on its site but
        // hidden under the probe in this frame is still there (counted over
        // the particles seen, its site was empty, and the dry-run commanded
        // a push the run never made).
        let filled = sites
            .iter()
            .filter(|s| {
                tracker
                    .tracks()
                    .iter()
                    .any(|t| track_to_site_m(t, s) <= loop_settings.placed_tolerance_m)
            })
            .count();
        if !calibration_checked && sighting.tip_m.is_some() && sighting.stage_m.is_some() {
            calibration_checked = true;
            loop_stopped = calibration_doubt(&sighting)
                .map(|why| format!("the loop stops on its first look: {why}"));
        }
        let (command, plan) = if let Some(reason) = &loop_stopped {
            (
                DryCommand::Refused {
                    reason: reason.clone(),
                },
                Vec::new(),
            )
        } else if filled == sites.len() {
            (DryCommand::Done, Vec::new())
        } else {
            next_command(
                &tracker,
                (&mut in_hand, commanded),
                sites,
                field_m,
                &sighting,
                scene,
                &planning,
            )
        };
        let outcome = DryRunFrame {
            frame: i,
            source: recorded.name,
            t_s: sighting.t_s,
            particles: tracks.clone(),
            tip_um: sighting.tip_m.map(|t| [t[0] * 1e6, t[1] * 1e6]),
            filled,
            command,
            repaired_lines: sighting.repaired_lines.clone(),
            clipped: sighting.exposure.clipped(),
            last_command_not_made,
        };
        let view = FrameView {
            sighting: &sighting,
            tracks: &tracks,
            sites,
            push: None,
            plan: &plan,
            calibration: &calibration,
        };
        on_frame(&view, &outcome);
        commanded = match outcome.command {
            DryCommand::Push {
                particle,
                from_um,
                to_um,
                ..
            } => Some(Moved {
                id: particle,
                from: from_um.map(|v| v * 1e-6),
                to: to_um.map(|v| v * 1e-6),
            }),
            _ => None,
        };
        frames.push(outcome);
    }
    Ok(DryRunReport {
        schema: DRY_RUN_SCHEMA.to_owned(),
        recording: recording.dir.display().to_string(),
        sites_um: sites_um(&sites.unwrap_or_default()),
        frames,
        ended_early,
        unread_after,
    })
}

/// The planner's settings without the tip's start, as the loop's: its
/// placed tolerance and travel speed, the scene's push speed and particle
/// size (1 um/s and 10 um spheres without a scene), the free space kept
/// round the pattern. (At the planner's default
/// travel speed, 10 um/s, not the loop's 50, the tour weighed travel more
/// and chose other orders than the loop's.)
fn plan_config(scene: Option<&Scene>, keep_clear_m: f64) -> PlanConfig {
    AssemblySettings {
        keep_clear_m,
        ..AssemblySettings::default()
    }
    .plan_config_for(
        scene.map_or(1e-6, |s| s.push.speed_m_per_s),
        particle_radius_m(scene),
    )
}

/// The scene's particle radius; without a scene, the 10 um spheres' the
/// planner's defaults are drawn for.
fn particle_radius_m(scene: Option<&Scene>) -> f64 {
    scene.map_or(DEFAULT_GEOMETRY_RADIUS_M, |s| s.particle_radius_m)
}

/// The sites: the pattern `asked` for (the recording's target aside), as
/// recorded, or the recording's pattern placed where the full plan on the
/// first frame's particles is fastest, as the closed loop places it.
fn target_sites(
    recording: &Recording,
    asked: Option<&PatternRequest>,
    first: &[super::tracker::Observation],
    field_m: [f64; 2],
    radius_m: f64,
    config: &PlanConfig,
) -> Result<Vec<Site>, DryRunError> {
    let spec = &recording.spec;
    let target = |e: String| DryRunError::Target(e);
    let recorded: PatternRequest;
    // Where the pattern comes from, for its errors: the flags, or the file.
    let from = match (asked, &spec.pattern_text) {
        (Some(_), _) => String::new(),
        (None, Some(_)) => format!("{RECORDING_FILE} `pattern_text`: "),
        (None, None) => format!("{RECORDING_FILE} `pattern`: "),
    };
    let request = match asked {
        Some(request) => request,
        None => {
            if let Some(sites_um) = &spec.sites_um {
                // Checked on read against `field_um`; here against the field
                // the first frame shows when the recording gives none.
                let sites = sites_of(sites_um).map_err(DryRunError::Target)?;
                check_sites_in_field(&sites, field_m, radius_m).map_err(DryRunError::Target)?;
                return Ok(sites);
            }
            recorded = match (&spec.pattern_text, &spec.pattern) {
                (Some(text), _) => PatternSource::Text(text.clone()).into(),
                (None, Some(rel)) => PatternSource::File(recording.file(rel)).into(),
                (None, None) => return Err(target("the recording names no target".into())),
            };
            &recorded
        }
    };
    let radii: Vec<f64> = first.iter().map(|o| o.radius_m).collect();
    let area = Reachable::for_field(field_m, radius_m);
    let pattern = request
        .pattern_for_batch(radius_m, &radii, &area)
        .map_err(|e| target(format!("{from}{e}")))?;
    // Counted in the field: particles beyond it are never pushed.
    let layout = layout_measured(field_m, first, radius_m);
    if let Some(why) = too_few_in_field(&layout, pattern.offsets_m.len(), "the first frame shows") {
        return Err(target(why));
    }
    request
        // Ctrl-C leaves this worker thread to end with the process
        // (`cli/dry_run_worker.rs`): no flag here.
        .sites(
            &pattern,
            &area,
            &layout,
            config,
            PlacementGoal::LeastTime,
            None,
        )
        .map_err(|e| target(e.to_string()))
}

/// Plans from the tracks with `planning` (from the tip `sighting` shows)
/// and names the first push (with the model's choice).
fn next_command(
    tracker: &Tracker,
    (in_hand, commanded): (&mut Option<Plan>, Option<Moved>),
    sites: &[Site],
    field_m: [f64; 2],
    sighting: &Sighting,
    scene: Option<&Scene>,
    planning: &PlanConfig,
) -> (DryCommand, Vec<PlannedPush>) {
    // As the loop does: the particles' measured sizes, the scene's (or 5
    // um) before any is seen.
    let tracks = tracker.tracks();
    let sizes = ParticleSizes::of(tracks, particle_radius_m(scene));
    let layout = Layout {
        field_m,
        particles: planning_particles(tracks, &sizes, field_m),
    };
    let config = PlanConfig {
        tip_start_m: sighting.tip_m.map(|t| Vector2::new(t[0], t[1])),
        ..planning.clone()
    };
    let kept = kept_plan(in_hand.take(), commanded, tracker, &layout);
    let plan = match kept {
        Some(p) if verify_plan(&p, &layout, &config).ok => p,
        faulty => match plan_assembly(&layout, sites, &config) {
            Ok(p) => p,
            // As the loop: push on with a plan in hand that fails only later.
            Err(e) => {
                let lowered_m = AssemblySettings::default().clearance_m;
                match faulty.and_then(|p| pushable_later(p, &layout, &config, lowered_m)) {
                    Some(p) => p,
                    None => {
                        let reason = format!("planner: {e}");
                        return (DryCommand::Refused { reason }, Vec::new());
                    }
                }
            }
        },
    };
    *in_hand = Some(plan.clone());
    let pushes: Vec<(u32, PlannedPush)> = plan
        .steps
        .iter()
        .filter_map(Step::push_move)
        .map(|(particle, from_m, to_m)| {
            let (from, to) = ([from_m.x, from_m.y], [to_m.x, to_m.y]);
            (particle, PlannedPush { from, to })
        })
        .collect();
    let Some(&(particle, first)) = pushes.first() else {
        return (
            DryCommand::Refused {
                reason: "the plan has no push left".into(),
            },
            Vec::new(),
        );
    };
    // The particle's size, as the loop does.
    let intent = PushIntent {
        particle: particle as usize,
        from: first.from,
        to: first.to,
        radius_m: sizes.radius_of(tracks, particle as usize),
    };
    let advice = scene.map(|s| decide_push(s, &intent, sighting.t_s));
    let um = |p: [f64; 2]| [p[0] * 1e6, p[1] * 1e6];
    let command = DryCommand::Push {
        particle: intent.particle,
        from_um: um(first.from),
        to_um: um(first.to),
        contact_angle_deg: advice
            .as_ref()
            .and_then(|a| a.as_ref().ok())
            .map(|a| a.contact_angle_rad.to_degrees()),
        duration_s: advice
            .as_ref()
            .and_then(|a| a.as_ref().ok())
            .map(|a| a.duration_s),
        model_refused: advice.and_then(|a| a.err()).map(|e| e.to_string()),
    };
    (command, pushes.into_iter().map(|p| p.1).collect())
}

impl DryCommand {
    /// One line for the terminal.
    pub fn describe(&self) -> String {
        match self {
            DryCommand::Push {
                particle,
                from_um,
                to_um,
                contact_angle_deg,
                duration_s,
                model_refused,
            } => {
                let mut s = format!(
                    "push particle {particle} from ({:.2}, {:.2}) to ({:.2}, {:.2}) um",
                    from_um[0], from_um[1], to_um[0], to_um[1]
                );
                match (contact_angle_deg, duration_s, model_refused) {
                    (Some(a), Some(d), _) => {
                        s.push_str(&format!(" at {a:.1} deg for {d:.2} s"));
                    }
                    (_, _, Some(why)) => s.push_str(&format!(" (model refuses: {why})")),
                    _ => {}
                }
                s
            }
            DryCommand::Done => "nothing: every site is filled".to_owned(),
            DryCommand::Refused { reason } => format!("nothing: {reason}"),
        }
    }
}
