//! The closed loop: observe, plan, ask the model, push, check, recover.
//!
//! Every cycle starts from what the camera sees, so whatever happened (a lost
//! contact, a missed detection, a stage fault, a resumed run) is handled the
//! same way: the particles are re-tracked, the plan is made again from where
//! they are (particles already on a site stay), and its first push is executed
//! with the contact angle and duration the pushing model advises. After the
//! push the next frame tells whether the particle followed the tip; if not,
//! the contact was lost and the next cycle pushes it again from where it lies.
//! A particle that fails `max_tries` times is left where it is.
//!
//! Coarse-stage moves are chosen here, not taken from the plan: before each
//! push the window is moved only if the stroke does not fit the nanostage's
//! range as it is, which keeps re-planning free of window state.

use super::drift::{APEX_CLEAR_OF_PARTICLES_M, DriftFilter, DriftSettings};
use super::events::{RunEvent, RunSpec, SeenParticle};
use super::journal::{JournalError, JournalWriter};
use super::observe::{ObserveError, Perception, Sighting};
use super::particle_sizes::ParticleSizes;
use super::push_check::{CheckTolerances, PushCheck, check_push};
use super::stroke::{Stroke, StrokeError, StrokeRequest, plan_stroke};
use super::tracker::{Moved, Track, Tracker};
use crate::calib::camera_map::CameraCalibration;
use crate::model::advice::{PushAdvice, advise_push};
use crate::model::{ModelError, Scene};
use crate::plan::layout::{Layout, Particle};
use crate::plan::pattern::Site;
use crate::plan::rebase::{rebase_plan, without_first_push};
use crate::plan::{Plan, PlanConfig, Step, plan_assembly, verify_plan};
use crate::rig::stage::StageXyz;
use crate::rig::{Rig, RigError};
use nalgebra::Vector2;
use std::collections::HashMap;

/// Executor settings; the defaults suit 10 um particles on the simulated rig.
#[derive(Debug, Clone, PartialEq)]
pub struct AssemblySettings {
    /// A particle this close to its site is placed (default 0.2 um). It is
    /// also the smallest correction: shorter pushes are below what the stage
    /// noise and the onset prediction can deliver, and would only chatter.
    pub placed_tolerance_m: f64,
    /// A pushed particle this far off its push line turned around the tip (default 1.5 um).
    pub off_line_tolerance_m: f64,
    /// Lost contacts on one particle before it is left alone (default 3).
    pub max_tries: u32,
    /// A particle left alone this close to a site no other particle fills
    /// fills that site, short of `placed_tolerance_m`, and the run goes on
    /// (default 0.5 um, 5 % of a 10 um particle's diameter). Under drift a
    /// particle 0.21 um from its site with a neighbour above it was nudged
    /// in vain by every fresh plan, and one left 0.3 um short stopped the
    /// run: it covers its site and cannot be moved.
    pub left_short_m: f64,
    /// Pushes after which the run stops, done or not (default 400).
    pub max_pushes: usize,
    /// Stage faults in a row after which the run stops (default 3).
    pub max_stage_faults: u32,
    /// Speed of lifted travel and vertical moves (default 50 um/s: the tip is
    /// off the sample, piezo nanostages travel at mm/s, and the lower bound is
    /// computed at the same speed).
    pub travel_speed_m_per_s: f64,
    /// Gap between tip and particle where the tip is lowered (default 0.5 um:
    /// 25x the particle detection error and 2.5x the placed tolerance; the
    /// tip covers it at pushing speed, so every 0.1 um costs 0.1 s a push).
    pub clearance_m: f64,
    /// Farthest a particle may be from its predicted place and keep its identity (default 4 um).
    pub track_gate_m: f64,
    /// Width of the field the particles lie in, metres (the planner's layout field).
    pub field_m: [f64; 2],
    /// The plan in hand is kept while no particle it pushes is farther than
    /// this from where it expects it (default 0.5 um, and the kept steps must
    /// still verify collision-free); beyond, the loop plans afresh.
    pub keep_plan_shift_m: f64,
    /// How the tip's drift against the sample is followed in the frames and
    /// taken out of every move (`exec::drift`); None: not at all, every
    /// move goes where the calibration alone says.
    pub drift: Option<DriftSettings>,
}

impl AssemblySettings {
    /// These settings, the drift not followed when `drift_off` (every move
    /// goes where the calibration alone says).
    pub fn with_drift_off(self, drift_off: bool) -> Self {
        Self {
            drift: if drift_off { None } else { self.drift },
            ..self
        }
    }

    /// The planner's settings for a run: the scene's pushing speed, the
    /// executor's travel speed and placement tolerance (so the plan that
    /// places the pattern and the loop's plans agree on what is placed and
    /// which particles fit the sites), defaults otherwise.
    pub fn plan_config(&self, scene: &Scene) -> PlanConfig {
        PlanConfig {
            push_speed_m_per_s: scene.push.speed_m_per_s,
            travel_speed_m_per_s: self.travel_speed_m_per_s,
            on_site_tolerance_m: self.placed_tolerance_m,
            ..PlanConfig::default()
        }
    }
}

impl Default for AssemblySettings {
    fn default() -> Self {
        Self {
            placed_tolerance_m: 0.2e-6,
            off_line_tolerance_m: 1.5e-6,
            max_tries: 3,
            left_short_m: 0.5e-6,
            max_pushes: 400,
            max_stage_faults: 3,
            travel_speed_m_per_s: 50e-6,
            clearance_m: 0.5e-6,
            track_gate_m: 4e-6,
            field_m: [120e-6, 100e-6],
            keep_plan_shift_m: 0.5e-6,
            drift: Some(DriftSettings::default()),
        }
    }
}

/// Why the loop could not go on.
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// The journal could not be written: stop, or entries would be lost.
    #[error(transparent)]
    Journal(#[from] JournalError),
    /// No frame could be analysed.
    #[error(transparent)]
    Observe(#[from] ObserveError),
    /// The rig failed in a way that is not a recoverable fault.
    #[error("rig: {0}")]
    Rig(#[from] RigError),
}

/// How a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum RunEnd {
    /// Every site filled within tolerance.
    Done,
    /// `max_pushes` pushes made first: the end a dry run, which allows one
    /// push, expects (any other stop is a failure there).
    PushesSpent(usize),
    /// Stopped before that, with the reason.
    Stopped(String),
}

impl RunEnd {
    /// Why the run stopped, as the journal and the report say it; `None` when done.
    pub fn reason(&self) -> Option<String> {
        match self {
            RunEnd::Done => None,
            RunEnd::PushesSpent(n) => Some(format!("{n} pushes made without filling every site")),
            RunEnd::Stopped(why) => Some(why.clone()),
        }
    }
}

/// One executed push, for reports (rig times bracket every move of the push).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushRecord {
    /// Rig time when the tip started down.
    pub t_start_s: f64,
    /// Rig time when the tip was lifted again.
    pub t_end_s: f64,
    /// True when the camera showed the contact was lost.
    pub lost_contact_detected: bool,
    /// Where the pushed particle was seen before the push, metres.
    pub from_m: [f64; 2],
    /// Where the push aimed it, metres.
    pub to_m: [f64; 2],
}

/// Everything the loop knows when a frame has been analysed: what the
/// animation, the recorder and the progress bar draw from.
pub struct FrameView<'s> {
    /// The analysed frame.
    pub sighting: &'s Sighting,
    /// Tracked particles after this frame (micrometres).
    pub tracks: &'s [SeenParticle],
    /// Target sites.
    pub sites: &'s [Site],
    /// The push whose result this frame shows, if any.
    pub push: Option<&'s PushIntent>,
    /// The pushes of the latest plan still to come (the first is next).
    pub plan: &'s [PlannedPush],
    /// Pixel -> nanostage map of the frame.
    pub calibration: &'s CameraCalibration,
}

/// Something that wants to see every analysed frame (animation, recorder, progress).
pub trait FrameSink {
    /// Called once per analysed frame.
    fn frame(&mut self, view: &FrameView<'_>);
}

/// Shows every frame to each of several sinks, in order.
pub struct FanOut<'a>(pub Vec<&'a mut dyn FrameSink>);

impl FrameSink for FanOut<'_> {
    fn frame(&mut self, view: &FrameView<'_>) {
        for sink in self.0.iter_mut() {
            sink.frame(view);
        }
    }
}

/// One push of a plan, on the sample, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedPush {
    /// Particle centre before.
    pub from: [f64; 2],
    /// Particle centre after.
    pub to: [f64; 2],
}

/// Distance from a tracked particle's centre to a site's, metres.
fn track_to_site_m(t: &Track, s: &Site) -> f64 {
    (t.last.x_m - s.centre_m.x).hypot(t.last.y_m - s.centre_m.y)
}

/// A site filled short by a particle the loop left alone near it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LeftShort {
    /// Index into the run's sites.
    site: usize,
    /// Track id of the particle.
    particle: usize,
    /// Its distance from the site when it was left, metres.
    error_m: f64,
}

/// A push the loop is about to make or has just made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushIntent {
    /// Track id of the particle.
    pub particle: usize,
    /// Centre before, on the sample.
    pub from: [f64; 2],
    /// Centre wanted after.
    pub to: [f64; 2],
    /// Particle radius.
    pub radius_m: f64,
}

/// The closed loop over one rig.
pub struct Assembly<'a> {
    rig: &'a mut dyn Rig,
    scene: Scene,
    sites: Vec<Site>,
    plan_config: PlanConfig,
    perception: Perception,
    settings: AssemblySettings,
    journal: JournalWriter,
    tracker: Tracker,
    failures: HashMap<usize, u32>,
    given_up: Vec<usize>,
    /// The particle the last push left unmoved within tolerance of its
    /// target (`PushCheck::Unmoved`): a failure if the plan in hand then no
    /// longer holds.
    unmoved: Option<usize>,
    /// Sites filled short by a particle left alone near them (`left_short_m`).
    left_short: Vec<LeftShort>,
    /// Sites the run left short before a resume, to be left so again on
    /// the first look.
    left_short_before: Vec<usize>,
    repush_next: Option<usize>,
    stage_faults: u32,
    coarse_offset: [f64; 2],
    /// The tip's drift as the frames show it; None when not followed.
    drift: Option<DriftFilter>,
    pushes_done: usize,
    frames_seen: usize,
    /// Every push executed in this process, in order.
    pub records: Vec<PushRecord>,
    /// The last analysed frame.
    pub last_sighting: Option<Sighting>,
    plan: Vec<PlannedPush>,
    /// The steps of the current plan not yet made.
    plan_in_hand: Option<Plan>,
    /// Track ids issued when this process made its first plan (None before):
    /// those tracks were all planned with, so they stay confirmed.
    first_plan_ids: Option<usize>,
    park_before_first_look: bool,
    tip_hint_m: Option<[f64; 2]>,
    sink: Option<&'a mut dyn FrameSink>,
}

/// What the loop needs besides the rig.
pub struct AssemblyInputs {
    /// The scene the model advises from.
    pub scene: Scene,
    /// Target sites on the sample.
    pub sites: Vec<Site>,
    /// Planner settings.
    pub plan_config: PlanConfig,
    /// Frame analysis.
    pub perception: Perception,
    /// Loop settings.
    pub settings: AssemblySettings,
}

impl<'a> Assembly<'a> {
    /// A new run: writes the run spec as the journal's first entry.
    pub fn start(
        rig: &'a mut dyn Rig,
        inputs: AssemblyInputs,
        mut journal: JournalWriter,
        spec: RunSpec,
    ) -> Result<Self, ExecError> {
        journal.append(rig.now_s(), &RunEvent::Start(spec))?;
        Ok(Self::with_journal(rig, inputs, journal, 0))
    }

    /// A resumed run: `pushes_done` counts the pushes journalled before the
    /// stop; `last_tip_nano_m` is the last nanostage target the journal
    /// holds; `left_short_sites` the sites it left short, whose particles
    /// (the nearest within `left_short_m` on the first look) are left there
    /// again rather than pushed three more times in vain.
    pub fn resume(
        rig: &'a mut dyn Rig,
        inputs: AssemblyInputs,
        mut journal: JournalWriter,
        pushes_done: usize,
        last_tip_nano_m: Option<[f64; 2]>,
        left_short_sites: Vec<usize>,
    ) -> Result<Self, ExecError> {
        journal.append(rig.now_s(), &RunEvent::Resume)?;
        let mut run = Self::with_journal(rig, inputs, journal, pushes_done);
        run.left_short_before = left_short_sites;
        // The process may have stopped anywhere, with the tip down or hiding the
        // particle it just pushed: lift it and look from where a new run starts.
        run.park_before_first_look = true;
        // Plan on from where the tip was, as the stopped run would have: the
        // planner's order depends on the tip's start.
        run.tip_hint_m =
            last_tip_nano_m.map(|t| [t[0] + run.coarse_offset[0], t[1] + run.coarse_offset[1]]);
        Ok(run)
    }

    fn with_journal(
        rig: &'a mut dyn Rig,
        inputs: AssemblyInputs,
        journal: JournalWriter,
        pushes_done: usize,
    ) -> Self {
        let coarse_offset = rig.coarse_position().unwrap_or([0.0, 0.0]);
        Self {
            rig,
            tracker: Tracker::new(inputs.settings.track_gate_m),
            drift: inputs.settings.drift.map(DriftFilter::new),
            scene: inputs.scene,
            sites: inputs.sites,
            plan_config: inputs.plan_config,
            perception: inputs.perception,
            settings: inputs.settings,
            journal,
            failures: HashMap::new(),
            given_up: Vec::new(),
            unmoved: None,
            left_short: Vec::new(),
            left_short_before: Vec::new(),
            repush_next: None,
            stage_faults: 0,
            coarse_offset,
            pushes_done,
            frames_seen: 0,
            records: Vec::new(),
            last_sighting: None,
            plan: Vec::new(),
            plan_in_hand: None,
            first_plan_ids: None,
            park_before_first_look: false,
            tip_hint_m: None,
            sink: None,
        }
    }

    /// Shows every analysed frame to `sink` (the animation writer).
    pub fn with_sink(mut self, sink: &'a mut dyn FrameSink) -> Self {
        self.sink = Some(sink);
        self
    }

    /// The target sites.
    pub fn sites(&self) -> &[Site] {
        &self.sites
    }

    /// Current particle tracks as journalled (micrometres).
    pub fn tracks(&self) -> Vec<SeenParticle> {
        self.tracker
            .tracks()
            .iter()
            .map(|t| SeenParticle {
                id: t.id,
                x_um: t.last.x_m * 1e6,
                y_um: t.last.y_m * 1e6,
                r_um: t.last.radius_m * 1e6,
            })
            .collect()
    }

    /// Distance from every site to the nearest tracked particle, metres.
    pub fn site_errors_m(&self) -> Vec<f64> {
        self.sites
            .iter()
            .map(|s| {
                self.nearest_track(s)
                    .map_or(f64::INFINITY, |t| track_to_site_m(t, s))
            })
            .collect()
    }

    /// The tracked particle nearest to site `s`.
    fn nearest_track(&self, s: &Site) -> Option<&Track> {
        let tracks = self.tracker.tracks().iter();
        tracks.min_by(|a, b| track_to_site_m(a, s).total_cmp(&track_to_site_m(b, s)))
    }

    /// Runs the loop until every site is filled or it has to stop.
    pub fn run(&mut self) -> Result<RunEnd, ExecError> {
        if std::mem::take(&mut self.park_before_first_look) {
            self.park_at_start()?;
        }
        // The first frame finds the probe. Parked where its body leaves the
        // frame, the next frame shows the particles it hid: one never seen
        // would be an obstacle no plan knows of.
        self.observe(&[], None)?;
        if self.probe_axis().is_some() {
            self.park_at_start()?;
        }
        self.leave_short_as_before()?;
        let mut pending: Option<PushIntent> = None;
        loop {
            let moved: Vec<Moved> = pending
                .iter()
                .map(|p| Moved {
                    id: p.particle,
                    from: p.from,
                    to: p.to,
                })
                .collect();
            self.observe(&moved, pending.as_ref())?;
            if let Some(intent) = pending.take() {
                if !self.seen_now(intent.particle) {
                    // Hidden under the probe, or not found: look again with the tip parked away.
                    self.park_away_from(intent.to)?;
                    self.observe(&moved, Some(&intent))?;
                }
                self.check(&intent)?;
            }
            if self.all_sites_filled() {
                // Confirm on a frame with the probe parked clear of the work
                // area: the last frame may hide particles under it, and the
                // run's final image should show the whole pattern.
                self.park_at_start()?;
                self.observe(&[], None)?;
                if self.all_sites_filled() {
                    self.journal.append(self.rig.now_s(), &RunEvent::Done)?;
                    return Ok(RunEnd::Done);
                }
            }
            if self.pushes_done >= self.settings.max_pushes {
                return self.stop(RunEnd::PushesSpent(self.pushes_done));
            }
            let intent = match self.next_push()? {
                Ok(intent) => intent,
                Err(reason) => return self.stop(RunEnd::Stopped(reason)),
            };
            match self.push(&intent) {
                Ok(()) => {
                    self.stage_faults = 0;
                    pending = Some(intent);
                }
                Err(PushError::Rig(RigError::StageFault(why))) => {
                    self.recover_from_fault(why)?;
                    if self.stage_faults > self.settings.max_stage_faults {
                        return self.stop(RunEnd::Stopped(format!(
                            "{} stage faults in a row",
                            self.stage_faults
                        )));
                    }
                }
                Err(PushError::Rig(e)) => {
                    let _ = self.rig.halt();
                    self.journal.append(
                        self.rig.now_s(),
                        &RunEvent::MoveFailed {
                            error: e.to_string(),
                        },
                    )?;
                    return self.stop(RunEnd::Stopped(format!("rig error: {e}")));
                }
                Err(PushError::Journal(e)) => return Err(e.into()),
                Err(PushError::Refused(why)) => {
                    self.fail(intent.particle)?;
                    self.journal.append(
                        self.rig.now_s(),
                        &RunEvent::Check {
                            particle: intent.particle,
                            result: format!("refused: {why}"),
                            error_nm: 0.0,
                            lost_contact: false,
                        },
                    )?;
                }
            }
        }
    }

    fn all_sites_filled(&self) -> bool {
        self.site_errors_m()
            .iter()
            .enumerate()
            .all(|(i, e)| *e <= self.settings.placed_tolerance_m || self.is_left_short(i))
    }

    /// Site `index` is filled short by a particle left alone near it.
    fn is_left_short(&self, index: usize) -> bool {
        self.left_short.iter().any(|l| l.site == index)
    }

    /// The particles the planner must not push: those given up on.
    fn immovable(&self) -> Vec<u32> {
        self.given_up.iter().map(|&id| id as u32).collect()
    }

    /// The sites the planner is asked to fill: all but those left short.
    fn open_sites(&self) -> Vec<Site> {
        (self.sites.iter().enumerate())
            .filter(|(i, _)| !self.is_left_short(*i))
            .map(|(_, s)| *s)
            .collect()
    }

    /// After a refusal: leaves every particle within `left_short_m` of an
    /// unfilled site there, filling it short. True if any was.
    fn leave_near_particles_short(&mut self) -> Result<bool, ExecError> {
        let errors = self.site_errors_m();
        let unfilled: Vec<usize> = (0..self.sites.len())
            .filter(|&i| errors[i] > self.settings.placed_tolerance_m && !self.is_left_short(i))
            .collect();
        self.leave_nearest_short(&unfilled)
    }

    /// A resumed run leaves the particle nearest each site it left short
    /// there again, if it still lies within `left_short_m`.
    fn leave_short_as_before(&mut self) -> Result<(), ExecError> {
        let sites = std::mem::take(&mut self.left_short_before);
        self.leave_nearest_short(&sites).map(|_| ())
    }

    /// Leaves the particle nearest each of `sites` (indices) short, where
    /// it lies within `left_short_m`. True if any fills a site.
    fn leave_nearest_short(&mut self, sites: &[usize]) -> Result<bool, ExecError> {
        let near: Vec<usize> = (sites.iter().filter_map(|&i| self.sites.get(i)))
            .filter_map(|s| {
                self.nearest_track(s)
                    .filter(|t| track_to_site_m(t, s) <= self.settings.left_short_m)
            })
            .map(|t| t.id)
            .collect();
        let mut left = false;
        for particle in near {
            left |= self.leave_short(particle)?;
        }
        Ok(left)
    }

    /// Journals and keeps the site a particle left alone fills, if any
    /// (`site_left_short_by`), and plans around the particle from then on.
    /// True if it fills one.
    fn leave_short(&mut self, particle: usize) -> Result<bool, ExecError> {
        let Some(short) = self.site_left_short_by(particle) else {
            return Ok(false);
        };
        if !self.given_up.contains(&particle) {
            self.given_up.push(particle);
        }
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::LeftShort {
                site: short.site,
                particle,
                error_nm: short.error_m * 1e9,
            },
        )?;
        self.left_short.push(short);
        Ok(true)
    }

    /// The site the particle just left alone fills, if it is within
    /// `left_short_m` of one that no other particle fills. The planner is
    /// then no longer asked to fill that site: the particle covers it and
    /// cannot be moved (one left 0.18 um from its site, within tolerance,
    /// had stopped the run all the same).
    fn site_left_short_by(&self, particle: usize) -> Option<LeftShort> {
        let t = self.tracker.track(particle)?;
        let filled_by_another = |s: &Site| {
            self.tracker.tracks().iter().any(|o| {
                o.id != particle && track_to_site_m(o, s) <= self.settings.placed_tolerance_m
            })
        };
        self.sites
            .iter()
            .enumerate()
            .filter(|(i, s)| !self.is_left_short(*i) && !filled_by_another(s))
            .map(|(i, s)| (i, track_to_site_m(t, s)))
            .filter(|(_, d)| *d <= self.settings.left_short_m)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(site, d)| LeftShort {
                site,
                particle,
                error_m: d,
            })
    }

    fn stop(&mut self, end: RunEnd) -> Result<RunEnd, ExecError> {
        let reason = end.reason().unwrap_or_default();
        self.journal
            .append(self.rig.now_s(), &RunEvent::Stopped { reason })?;
        Ok(end)
    }

    /// Grabs, detects, tracks and journals one frame.
    fn observe(&mut self, moved: &[Moved], push: Option<&PushIntent>) -> Result<(), ExecError> {
        let calibration = *self.rig.calibration();
        let mut sighting =
            self.perception
                .sight(&mut *self.rig, &calibration, self.coarse_offset)?;
        sighting.stage_m = self.rig.position().ok();
        for _ in 0..sighting.dropped {
            self.journal
                .append(self.rig.now_s(), &RunEvent::FrameDropped)?;
        }
        self.tracker
            .update(&sighting.particles, moved, &|x, y| sighting.shows(x, y));
        self.follow_drift(&sighting, push);
        let tracks = self.tracks();
        self.journal.append(
            sighting.t_s,
            &RunEvent::Observation {
                frame: self.frames_seen,
                particles: tracks.clone(),
                tip_um: sighting.tip_m.map(|t| [t[0] * 1e6, t[1] * 1e6]),
                repaired_lines: sighting.repaired_lines.clone(),
                clipped: sighting.exposure.clipped(),
                drift: self
                    .drift
                    .as_ref()
                    .and_then(|d| d.estimate_at(sighting.t_s)),
            },
        )?;
        if let Some(sink) = self.sink.as_mut() {
            sink.frame(&FrameView {
                sighting: &sighting,
                tracks: &tracks,
                sites: &self.sites,
                push,
                plan: &self.plan,
                calibration: &calibration,
            });
        }
        self.last_sighting = Some(sighting);
        self.frames_seen += 1;
        Ok(())
    }

    /// Takes the frame's apex against where the stage was sent into the drift
    /// estimate, when the apex is clear of every tracked particle and of
    /// where the push just made aimed its particle (beside one the apex's
    /// fit is pulled by up to 0.3 um on the simulated microscope; a pushed
    /// particle under the probe keeps its old track). Not before the first
    /// plan: until the loop has looked with the probe parked away, a
    /// particle under the probe is not tracked (the frame drops detections
    /// the probe's outline cuts).
    fn follow_drift(&mut self, sighting: &Sighting, push: Option<&PushIntent>) {
        let (Some(drift), Some(_), Some(tip), Some(stage)) = (
            self.drift.as_mut(),
            self.first_plan_ids,
            sighting.tip_m,
            sighting.stage_m,
        ) else {
            return;
        };
        let tracked = self
            .tracker
            .tracks()
            .iter()
            .map(|t| ([t.last.x_m, t.last.y_m], t.last.radius_m));
        let pushed = push.map(|p| (p.to, p.radius_m));
        let clear = tracked.chain(pushed).all(|(centre, radius)| {
            (centre[0] - tip[0]).hypot(centre[1] - tip[1]) >= radius + APEX_CLEAR_OF_PARTICLES_M
        });
        if clear {
            let sent = [0, 1].map(|i| stage[i] + sighting.coarse_offset_m[i]);
            let update = drift.add(sighting.t_s, [0, 1].map(|i| tip[i] - sent[i]));
            tracing::debug!(?update, t_s = sighting.t_s, "tip drift");
        }
    }

    /// The drift to take out of a move made now (zero when not followed).
    fn drift_now(&self) -> [f64; 2] {
        self.drift
            .as_ref()
            .map_or([0.0, 0.0], |d| d.correction_at(self.rig.now_s()))
    }

    /// True when the last frame showed this particle (a track outside the
    /// view or under the probe keeps its old place and is not seen).
    fn seen_now(&self, particle: usize) -> bool {
        self.tracker.track(particle).is_some_and(|t| {
            t.missed_frames == 0
                && self
                    .last_sighting
                    .as_ref()
                    .is_some_and(|s| s.shows(t.last.x_m, t.last.y_m))
        })
    }

    /// Lifts the tip, brings `point` into the camera's view if it is not, and
    /// moves the tip to the corner of the nanostage's range farthest from it.
    fn park_away_from(&mut self, point: [f64; 2]) -> Result<(), ExecError> {
        let range = self.rig.range();
        let here = self.rig.position()?;
        let top = range[2].max_m;
        let speed = self.settings.travel_speed_m_per_s;
        self.move_on_sample_raw([here[0], here[1], top], speed)
            .map_err(ExecError::from)?;
        if let Some(view) = self.view_local()
            && let Some(offset) = offset_fitting(self.coarse_offset, &[(point, view)])
            && offset != self.coarse_offset
        {
            self.move_coarse_lifted(offset).map_err(ExecError::from)?;
        }
        let local = [
            point[0] - self.coarse_offset[0],
            point[1] - self.coarse_offset[1],
        ];
        let far = |i: usize| {
            if (local[i] - range[i].min_m).abs() > (local[i] - range[i].max_m).abs() {
                range[i].min_m
            } else {
                range[i].max_m
            }
        };
        self.move_on_sample_raw([far(0), far(1), top], speed)
            .map_err(ExecError::from)
    }

    /// Lifts the tip and moves it where a run starts and ends: the corner of
    /// the nanostage's range the cantilever comes from, at the top of its
    /// travel, so that the probe's body lies outside the frame and hides no
    /// particle (the origin corner while the probe's direction is unknown).
    fn park_at_start(&mut self) -> Result<(), ExecError> {
        let range = self.rig.range();
        let here = self.rig.position()?;
        let top = range[2].max_m;
        let speed = self.settings.travel_speed_m_per_s;
        let corner = match self.probe_axis() {
            // Farthest along the body's direction (-axis).
            Some(axis) => [0, 1].map(|i| {
                if axis[i] > 0.0 {
                    range[i].min_m
                } else {
                    range[i].max_m
                }
            }),
            None => [range[0].min_m, range[1].min_m],
        };
        self.move_on_sample_raw([here[0], here[1], top], speed)
            .and_then(|()| self.move_on_sample_raw([corner[0], corner[1], top], speed))
            .map_err(ExecError::from)
    }

    /// Was the last push a success? Journals the check and counts failures.
    fn check(&mut self, intent: &PushIntent) -> Result<(), ExecError> {
        let seen = self
            .tracker
            .track(intent.particle)
            .filter(|t| t.missed_frames == 0)
            .map(|t| [t.last.x_m, t.last.y_m]);
        let tol = CheckTolerances {
            placed_m: self.settings.placed_tolerance_m,
            off_line_m: self.settings.off_line_tolerance_m,
        };
        let (result, error_nm, lost) = match seen {
            None => ("unseen".to_owned(), 0.0, false),
            Some(at) => {
                let c = check_push(intent.from, intent.to, at, &tol);
                let error_nm = (at[0] - intent.to[0]).hypot(at[1] - intent.to[1]) * 1e9;
                let name = match c {
                    PushCheck::Placed { .. } => "placed",
                    PushCheck::Unmoved { .. } => "unmoved",
                    PushCheck::FellShort { .. } => "fell-short",
                    PushCheck::LeftLine { .. } => "left-line",
                    PushCheck::Overshot { .. } => "overshot",
                };
                (name.to_owned(), error_nm, c.lost_contact())
            }
        };
        if let Some(r) = self.records.last_mut() {
            r.lost_contact_detected = lost;
        }
        if result == "placed" || result == "unmoved" {
            self.plan_in_hand = self.plan_in_hand.take().map(|p| without_first_push(&p));
        }
        if result == "unmoved" {
            self.unmoved = Some(intent.particle);
        }
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Check {
                particle: intent.particle,
                result,
                error_nm,
                lost_contact: lost,
            },
        )?;
        if lost {
            self.fail(intent.particle)?;
            self.repush_next = Some(intent.particle);
        }
        Ok(())
    }

    fn fail(&mut self, particle: usize) -> Result<(), ExecError> {
        let tries = self.failures.entry(particle).or_insert(0);
        *tries += 1;
        if *tries >= self.settings.max_tries && !self.given_up.contains(&particle) {
            let tries = *tries;
            self.given_up.push(particle);
            // The plan in hand still moves it: plan afresh around it.
            self.plan_in_hand = None;
            self.journal
                .append(self.rig.now_s(), &RunEvent::GiveUp { particle, tries })?;
            self.leave_short(particle)?;
        }
        Ok(())
    }

    /// The tracks the planner is told about. The first plan takes every track
    /// (the run's first looks find every particle) and they stay; a track new
    /// after it must be seen twice: a one-frame false detection between
    /// particles had become an obstacle that blocked the plan in hand and
    /// every fresh plan. (A first-plan track seen once, then out of view, had
    /// vanished from the next plan, which pushed a particle through it.)
    fn confirmed_tracks(&self) -> Vec<Track> {
        let first = self.first_plan_ids.unwrap_or(usize::MAX);
        self.tracker
            .tracks()
            .iter()
            .filter(|t| t.hits >= 2 || t.id < first)
            .cloned()
            .collect()
    }

    /// The next push: from the plan in hand if, moved onto the particles as
    /// seen now, it still verifies; otherwise from a fresh plan. Returns why
    /// there is none when the planner refuses.
    fn next_push(&mut self) -> Result<Result<PushIntent, String>, ExecError> {
        let confirmed = self.confirmed_tracks();
        // The particles' measured sizes, for the plan and for the push.
        // Not the scene's: a batch 2 % off its nominal size (4.9 um
        // particles in a 5 um scene) put the tip's contact 0.15 um off
        // along the push at a 70 deg contact angle, and every push, re-push
        // included, fell 0.35 um short (or, 2 % over, overshot 0.3 um, back
        // and forth 400 times): CMU stopped at 0 of 31.
        let sizes = ParticleSizes::of(&confirmed, self.scene.particle_radius_m);
        let layout = Layout {
            field_m: self.settings.field_m,
            particles: planning_particles(&confirmed, &sizes),
        };
        let mut config = self.plan_config.clone();
        config.immovable = self.immovable();
        let repushed = self.repush_next.map(|id| id as u32);
        let kept = self.plan_in_hand.take().map(|p| {
            let p = rebase_plan(&p, &layout, self.settings.keep_plan_shift_m, repushed)
                .map_err(|e| e.to_string())?;
            let report = verify_plan(&p, &layout, &config);
            if report.ok {
                Ok(p)
            } else {
                Err(format!("it no longer verifies: {}", report.summary()))
            }
        });
        let unmoved = self.unmoved.take();
        if let (Some(Err(_)), Some(particle)) = (&kept, unmoved) {
            // A fresh plan would ask for the push that did nothing again.
            self.fail(particle)?;
            config.immovable = self.immovable();
        }
        let plan = match kept {
            Some(Ok(plan)) => plan,
            dropped => {
                config.tip_start_m = self
                    .tip_hint_m
                    .take()
                    .or_else(|| self.last_sighting.as_ref().and_then(|s| s.tip_m))
                    .map(|t| Vector2::new(t[0], t[1]));
                let because = dropped.and_then(Result::err);
                let mut planned = plan_assembly(&layout, &self.open_sites(), &config);
                if planned.is_err() && self.leave_near_particles_short()? {
                    // Boxed in a hair from its site (one 0.21 um off, between
                    // three filled sites, had stopped the run): plan without it.
                    config.immovable = self.immovable();
                    planned = plan_assembly(&layout, &self.open_sites(), &config);
                }
                match planned {
                    Ok(plan) => {
                        self.journal_plan(&plan, because)?;
                        plan
                    }
                    Err(e) => {
                        let kept = because
                            .map(|b| format!(" (the plan in hand was dropped: {b})"))
                            .unwrap_or_default();
                        return Ok(Err(format!("planner: {e}{kept}")));
                    }
                }
            }
        };
        self.plan = plan
            .steps
            .iter()
            .filter_map(|step| match step {
                Step::Push { from_m, to_m, .. } => Some(PlannedPush {
                    from: [from_m.x, from_m.y],
                    to: [to_m.x, to_m.y],
                }),
                _ => None,
            })
            .collect();
        let first = plan.steps.iter().find_map(|step| match step {
            Step::Push {
                particle,
                from_m,
                to_m,
                ..
            } => Some((*particle as usize, *from_m, *to_m)),
            _ => None,
        });
        // Its first push leaves the plan when the camera shows it placed (`check`).
        self.plan_in_hand = Some(plan);
        self.first_plan_ids.get_or_insert(self.tracker.ids_issued());
        Ok(first
            .ok_or_else(|| "the plan has no push left".to_owned())
            .map(|(particle, from, to)| PushIntent {
                particle,
                from: [from.x, from.y],
                to: [to.x, to.y],
                radius_m: sizes.radius_of(&confirmed, particle),
            }))
    }

    fn journal_plan(
        &mut self,
        plan: &Plan,
        replaced_because: Option<String>,
    ) -> Result<(), ExecError> {
        let s = &plan.summary;
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Plan {
                pushes: s.pushes,
                push_distance_um: s.push_distance_m * 1e6,
                tip_travel_um: s.tip_travel_m * 1e6,
                lb_push_um: s.lb_push_m * 1e6,
                lb_tip_um: s.lb_tip_m * 1e6,
                planning_ms: s.planning_time_s * 1e3,
                replaced_because,
            },
        )?;
        Ok(())
    }

    /// Asks the model, lays out the stroke, moves the stage.
    fn push(&mut self, intent: &PushIntent) -> Result<(), PushError> {
        let scene = scene_for_push(&self.scene, intent.radius_m, self.rig.now_s());
        let advice = decide_push(&self.scene, intent, self.rig.now_s())
            .map_err(|e| PushError::Refused(e.to_string()))?;
        let repush = self.repush_next.take() == Some(intent.particle);
        self.journal_decision(intent, &advice, repush)?;
        let range = self.rig.range();
        let safe_z = (2.0 * intent.radius_m + 2e-6).min(range[2].max_m);
        let stroke = plan_stroke(&StrokeRequest {
            from: intent.from,
            to: intent.to,
            radius_m: intent.radius_m,
            contact_angle_rad: advice.contact_angle_rad,
            travel_after_contact_m: advice.duration_s * scene.push.speed_m_per_s,
            clearance_m: self.settings.clearance_m,
            safe_z_m: safe_z,
        })
        .map_err(|e: StrokeError| PushError::Refused(e.to_string()))?;
        let retreat = match self.probe_axis() {
            Some(axis) => {
                let others: Vec<([f64; 2], f64)> = self
                    .tracker
                    .tracks()
                    .iter()
                    .filter(|t| t.id != intent.particle)
                    .map(|t| ([t.last.x_m, t.last.y_m], t.last.radius_m))
                    .collect();
                // Within the nanostage's range where it is now: a farther
                // retreat must not move the coarse stage or refuse the push.
                let (drift, offset) = (self.drift_now(), self.coarse_offset);
                let reachable = |p: [f64; 2]| {
                    (0..2).all(|i| {
                        (range[i].min_m..=range[i].max_m).contains(&(p[i] - offset[i] - drift[i]))
                    })
                };
                retreat_clear_of_probe(&stroke, intent, axis, &others, reachable)
            }
            None => retreat_point(&stroke, intent.radius_m),
        };
        self.fit_window(&stroke, retreat, intent)?;
        let t_start_s = self.rig.now_s();
        let travel = self.settings.travel_speed_m_per_s;
        let here = self.rig.position()?;
        if here[2] < safe_z {
            self.move_on_sample_raw([here[0], here[1], safe_z], travel)?;
        }
        self.move_on_sample(stroke.above, travel)?;
        self.move_on_sample(stroke.approach, travel)?;
        self.move_on_sample(stroke.end, scene.push.speed_m_per_s)?;
        self.move_on_sample(stroke.lift, travel)?;
        self.move_on_sample(retreat, travel)?;
        self.pushes_done += 1;
        self.records.push(PushRecord {
            t_start_s,
            t_end_s: self.rig.now_s(),
            lost_contact_detected: false,
            from_m: intent.from,
            to_m: intent.to,
        });
        Ok(())
    }

    fn journal_decision(
        &mut self,
        intent: &PushIntent,
        a: &PushAdvice,
        repush: bool,
    ) -> Result<(), JournalError> {
        let um = |p: [f64; 2]| [p[0] * 1e6, p[1] * 1e6];
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Decision {
                particle: intent.particle,
                from_um: um(intent.from),
                to_um: um(intent.to),
                contact_angle_deg: a.contact_angle_rad.to_degrees(),
                duration_s: a.duration_s,
                onset_s: a.onset_s,
                critical_force_un: a.critical_force_n * 1e6,
                ride_over_margin: a.ride_over_margin,
                mode: format!("{:?}", a.mode).to_lowercase(),
                repush,
                radius_um: Some(intent.radius_m * 1e6),
            },
        )?;
        Ok(())
    }

    /// Moves the coarse stage when the stroke does not fit the nanostage's
    /// range or the camera would not see the particle before and after.
    fn fit_window(
        &mut self,
        stroke: &Stroke,
        retreat: StageXyz,
        intent: &PushIntent,
    ) -> Result<(), PushError> {
        let range = self.rig.range();
        let reach = [0, 1].map(|i| [range[i].min_m, range[i].max_m]);
        // The stage is sent to each point less the drift.
        let drift = self.drift_now();
        let mut needs: Vec<([f64; 2], [[f64; 2]; 2])> = [
            stroke.above,
            stroke.approach,
            stroke.end,
            stroke.lift,
            retreat,
        ]
        .iter()
        .map(|p| ([p[0] - drift[0], p[1] - drift[1]], reach))
        .collect();
        if let Some(view) = self.view_local() {
            needs.extend([intent.from, intent.to].map(|p| (p, view)));
        }
        match offset_fitting(self.coarse_offset, &needs) {
            Some(offset) if offset == self.coarse_offset => Ok(()),
            Some(offset) => self.move_coarse_lifted(offset),
            None => Err(PushError::Refused(
                "the stroke and the particle's path do not fit the nanostage's range and the camera's view"
                    .to_owned(),
            )),
        }
    }

    /// Unit direction from the cantilever body to the apex on the sample, from
    /// the last frame that found the probe.
    fn probe_axis(&self) -> Option<[f64; 2]> {
        let (tip, calibration) = self.last_sighting.as_ref()?.probe.as_ref()?;
        let v = calibration.linear * Vector2::new(tip.angle_rad.cos(), tip.angle_rad.sin());
        (v.norm() > 0.0).then(|| [v.x / v.norm(), v.y / v.norm()])
    }

    /// The part of the nanostage's frame the camera shows whole particles in
    /// (from the last frame), or None before the first frame.
    fn view_local(&self) -> Option<[[f64; 2]; 2]> {
        let s = self.last_sighting.as_ref()?;
        let [lo, hi] = s.view_m;
        let o = s.coarse_offset_m;
        Some([[lo[0] - o[0], hi[0] - o[0]], [lo[1] - o[1], hi[1] - o[1]]])
    }

    /// Lifts the tip and moves the coarse stage to `offset`.
    fn move_coarse_lifted(&mut self, offset: [f64; 2]) -> Result<(), PushError> {
        let range = self.rig.range();
        let here = self.rig.position()?;
        self.move_on_sample_raw(
            [here[0], here[1], range[2].max_m],
            self.settings.travel_speed_m_per_s,
        )?;
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::CoarseMove {
                offset_um: [offset[0] * 1e6, offset[1] * 1e6],
            },
        )?;
        self.rig.move_coarse(offset)?;
        self.coarse_offset = offset;
        Ok(())
    }

    /// Moves the tip to a point given on the sample: the stage is sent
    /// there less the coarse offset and the tip's drift. The drift is
    /// predicted at the move's own time, a little later than `fit_window`
    /// asked, so a point the window put on the range's edge may come out a
    /// few nanometres beyond it: it is held at the edge (every point the
    /// window checked is otherwise inside the range, where this changes
    /// nothing).
    fn move_on_sample(&mut self, target: StageXyz, speed: f64) -> Result<(), PushError> {
        let drift = self.drift_now();
        let range = self.rig.range();
        let on_stage = |i: usize| {
            (target[i] - self.coarse_offset[i] - drift[i]).clamp(range[i].min_m, range[i].max_m)
        };
        let nano = [on_stage(0), on_stage(1), target[2]];
        self.move_on_sample_raw(nano, speed)
    }

    /// Moves the nanostage to `nano` (nanostage coordinates), journalling it first.
    fn move_on_sample_raw(&mut self, nano: StageXyz, speed: f64) -> Result<(), PushError> {
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Move {
                target_um: [nano[0] * 1e6, nano[1] * 1e6, nano[2] * 1e6],
                speed_um_s: speed * 1e6,
            },
        )?;
        self.rig.move_to(nano, speed)?;
        Ok(())
    }

    /// After a stage fault: halt, lift the tip, and let the next cycle re-observe.
    fn recover_from_fault(&mut self, why: String) -> Result<(), ExecError> {
        self.stage_faults += 1;
        let _ = self.rig.halt();
        self.journal
            .append(self.rig.now_s(), &RunEvent::MoveFailed { error: why })?;
        let range = self.rig.range();
        let here = self.rig.position()?;
        if let Err(e) = self.move_on_sample_raw(
            [here[0], here[1], range[2].max_m],
            self.settings.travel_speed_m_per_s,
        ) {
            let _ = self.rig.halt();
            return Err(e.into());
        }
        Ok(())
    }
}

/// The scene as the model sees one push: the particle's measured radius, and
/// the session time grown by the run time so far (charge build-up).
pub fn scene_for_push(scene: &Scene, radius_m: f64, run_time_s: f64) -> Scene {
    let mut scene = scene.clone();
    scene.particle_radius_m = radius_m;
    scene.environment.session_time_s += run_time_s;
    scene
}

/// The executor's decision for one push: the model's contact angle and
/// duration for this particle, this distance, at this point of the run. The
/// loop journals exactly these numbers (a `decision` entry).
pub fn decide_push(
    scene: &Scene,
    intent: &PushIntent,
    run_time_s: f64,
) -> Result<PushAdvice, ModelError> {
    let distance = (intent.to[0] - intent.from[0]).hypot(intent.to[1] - intent.from[1]);
    advise_push(
        &scene_for_push(scene, intent.radius_m, run_time_s),
        distance,
    )
}

/// The coarse offset nearest `current` that puts every point inside its
/// bounds (points on the sample, bounds in the nanostage's frame, per axis
/// [min, max]); None when no offset does.
fn offset_fitting(current: [f64; 2], needs: &[([f64; 2], [[f64; 2]; 2])]) -> Option<[f64; 2]> {
    let mut offset = current;
    for (i, o) in offset.iter_mut().enumerate() {
        // point - offset in [min, max]  <=>  offset in [point - max, point - min]
        let lo = needs
            .iter()
            .map(|(p, b)| p[i] - b[i][1])
            .fold(f64::NEG_INFINITY, f64::max);
        let hi = needs
            .iter()
            .map(|(p, b)| p[i] - b[i][0])
            .fold(f64::INFINITY, f64::min);
        if lo > hi {
            return None;
        }
        *o = o.clamp(lo, hi);
    }
    Some(offset)
}

/// Where the tip waits after a push: back along the push line, a radius and
/// a few micrometres behind the lift point, so that the probe does not hide
/// the particle in the next frame; kept inside the nanostage's range.
fn retreat_point(stroke: &Stroke, radius_m: f64) -> StageXyz {
    let d = [
        stroke.end[0] - stroke.approach[0],
        stroke.end[1] - stroke.approach[1],
    ];
    let len = d[0].hypot(d[1]).max(f64::MIN_POSITIVE);
    let back = radius_m + RETREAT_EXTRA_M;
    [
        stroke.lift[0] - d[0] / len * back,
        stroke.lift[1] - d[1] / len * back,
        stroke.lift[2],
    ]
}

/// Where the tip waits after a push when the probe's direction is known: a
/// radius and a few micrometres from the particle's target, on the side the
/// cantilever comes from. The probe's body then lies away from the particle
/// whatever the push direction, so the next frame shows it and no re-look
/// (a lifted trip to the nanostage's far corner and back) is needed.
/// Farther back along that line, up to [`RETREAT_FARTHEST_EXTRA_M`], when
/// that puts the apex clear of every other particle (`others`: centre and
/// radius) and `reachable`: the next frame's apex is then a sighting of the
/// tip's drift. Among the letters of a pattern the nearest point seldom is
/// (5 sightings in 16 frames on CMU seed 1 at 5 nm/s), and at 5 nm/s the
/// drift's rate was never taken and a push fell 0.2 um short three times.
fn retreat_clear_of_probe(
    stroke: &Stroke,
    intent: &PushIntent,
    axis: [f64; 2],
    others: &[([f64; 2], f64)],
    reachable: impl Fn([f64; 2]) -> bool,
) -> StageXyz {
    let at = |extra: f64| {
        let back = intent.radius_m + extra;
        [intent.to[0] - axis[0] * back, intent.to[1] - axis[1] * back]
    };
    let clear = |p: [f64; 2]| {
        others.iter().all(|(c, r)| {
            (c[0] - p[0]).hypot(c[1] - p[1]) >= r + APEX_CLEAR_OF_PARTICLES_M + RETREAT_ROOM_M
        })
    };
    let steps = ((RETREAT_FARTHEST_EXTRA_M - RETREAT_EXTRA_M) / RETREAT_STEP_M).round() as usize;
    let [x, y] = (0..=steps)
        .map(|k| at(RETREAT_EXTRA_M + k as f64 * RETREAT_STEP_M))
        .find(|&p| clear(p) && reachable(p))
        .unwrap_or_else(|| at(RETREAT_EXTRA_M));
    [x, y, stroke.lift[2]]
}

/// Extra distance of the retreat beyond one particle radius.
const RETREAT_EXTRA_M: f64 = 3e-6;
/// Farthest the retreat goes back for an apex clear of the other particles:
/// 12 um more is 0.25 s at the travel speed, against pushes of seconds.
const RETREAT_FARTHEST_EXTRA_M: f64 = 15e-6;
/// Steps of the search back along the probe's line.
const RETREAT_STEP_M: f64 = 0.5e-6;
/// Room beyond [`APEX_CLEAR_OF_PARTICLES_M`] for the apex's placement
/// error and the drift left in the move, so the frame's apex still counts.
const RETREAT_ROOM_M: f64 = 0.5e-6;

/// The particles the planner is told about. A track the camera has missed
/// for a few frames is dropped; one missed more recently is kept unless a
/// particle seen in this frame overlaps it (then the stale one is wrong).
/// Each particle has its size from `sizes`. Radii are capped so
/// that no two discs overlap: touching spheres cannot, so a few nanometres
/// of apparent overlap must not make the layout invalid.
pub fn planning_particles(tracks: &[Track], sizes: &ParticleSizes) -> Vec<Particle> {
    let overlaps = |a: &Track, b: &Track| {
        (a.last.x_m - b.last.x_m).hypot(a.last.y_m - b.last.y_m) < a.last.radius_m + b.last.radius_m
    };
    let seen: Vec<(usize, [f64; 2], f64)> = tracks
        .iter()
        .filter(|t| t.missed_frames < 3)
        .filter(|t| {
            t.missed_frames == 0
                || !tracks
                    .iter()
                    .any(|u| u.id != t.id && u.missed_frames == 0 && overlaps(t, u))
        })
        .map(|t| (t.id, [t.last.x_m, t.last.y_m], sizes.radius_m(t)))
        .collect();
    particles_seen(&seen)
}

/// The first frame's particles as a layout of `field_m` (ids by order
/// seen), each with the size the loop will plan it with
/// ([`ParticleSizes`]; `nominal_m` is the scene's radius), for placing the
/// pattern on a rig: placed with the nominal radius for all, a spread
/// batch's sites could count on particles the loop then finds too wide.
pub fn layout_measured(
    field_m: [f64; 2],
    seen: &[super::tracker::Observation],
    nominal_m: f64,
) -> Layout {
    let mut tracker = Tracker::new(f64::INFINITY);
    tracker.update(seen, &[], &|_, _| true);
    let sizes = ParticleSizes::of(tracker.tracks(), nominal_m);
    Layout {
        field_m,
        particles: planning_particles(tracker.tracks(), &sizes),
    }
}

/// Particles `(id, centre, radius)`, each radius capped at its share of
/// the distance to every neighbour it would overlap (see
/// [`planning_particles`]).
pub fn particles_seen(seen: &[(usize, [f64; 2], f64)]) -> Vec<Particle> {
    seen.iter()
        .map(|&(id, c, r)| {
            let capped = seen
                .iter()
                .filter(|&&(other, _, _)| other != id)
                .map(|&(_, u, ru)| {
                    let d = (c[0] - u[0]).hypot(c[1] - u[1]);
                    d * r / (r + ru) * (1.0 - 1e-6)
                })
                .fold(r, f64::min);
            Particle {
                id: id as u32,
                centre_m: Vector2::new(c[0], c[1]),
                radius_m: capped,
            }
        })
        .collect()
}

/// Why one push was not made.
#[derive(Debug, thiserror::Error)]
enum PushError {
    #[error(transparent)]
    Rig(#[from] RigError),
    #[error(transparent)]
    Journal(#[from] JournalError),
    /// The model or the geometry refused this push; the particle counts a failure.
    #[error("{0}")]
    Refused(String),
}

/// Outside a push (parking, lifting after a fault) a refused move is a stage fault.
impl From<PushError> for ExecError {
    fn from(e: PushError) -> Self {
        match e {
            PushError::Rig(r) => ExecError::Rig(r),
            PushError::Journal(j) => ExecError::Journal(j),
            PushError::Refused(s) => ExecError::Rig(RigError::StageFault(s)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::tracker::Observation;

    /// After a push the tip waits on the probe's line behind the target:
    /// 3 um beyond the particle's edge when that is clear of the others,
    /// else at the first point 3 um clear of them, else (nothing clear
    /// within reach) at the nearest.
    #[test]
    fn the_tip_waits_where_its_apex_is_clear_of_the_other_particles() {
        let stroke = Stroke {
            above: [0.0, 0.0, 12e-6],
            approach: [0.0, 0.0, 6e-6],
            end: [0.0, 0.0, 6e-6],
            lift: [0.0, 0.0, 12e-6],
            travel_after_contact_m: 0.0,
        };
        let intent = PushIntent {
            particle: 0,
            from: [40e-6, 50e-6],
            to: [50e-6, 50e-6],
            radius_m: 5e-6,
        };
        // The cantilever comes from -x: the apex points +x.
        let axis = [1.0, 0.0];
        let wait = |others: &[([f64; 2], f64)], reach: f64| {
            retreat_clear_of_probe(&stroke, &intent, axis, others, |p| p[0] >= reach)[0] * 1e6
        };
        assert!((wait(&[], 0.0) - 42.0).abs() < 1e-9);
        // A particle at x = 40.2 um: the apex must be at x <= 40.2 - 5 - 3,
        // and the search steps 0.5 um from x = 42.
        let left = [([40.2e-6, 50e-6], 5e-6)];
        assert!(
            (wait(&left, 0.0) - 32.0).abs() < 1e-9,
            "{}",
            wait(&left, 0.0)
        );
        assert!((wait(&left, 33e-6) - 42.0).abs() < 1e-9);
        // At x = 35 um the first clear point (27) is beyond the 15 um searched.
        assert!((wait(&[([35e-6, 50e-6], 5e-6)], 0.0) - 42.0).abs() < 1e-9);
    }

    /// A first frame of a spread batch (4.6-5.4 um) places the pattern
    /// with each particle's measured size; two touching get the batch's
    /// median.
    #[test]
    fn the_first_frames_layout_has_the_sizes_the_loop_plans_with() {
        let at = |x_um: f64, r_um: f64| Observation {
            x_m: x_um * 1e-6,
            y_m: 20e-6,
            radius_m: r_um * 1e-6,
        };
        let seen = [
            at(10.0, 4.6),
            at(30.0, 5.0),
            at(50.0, 5.4),
            at(70.0, 4.8),
            at(79.9, 5.0),
        ];
        let layout = layout_measured([100e-6, 40e-6], &seen, 5e-6);
        let r: Vec<f64> = layout.particles.iter().map(|p| p.radius_m * 1e6).collect();
        // The last two, 0.1 um apart, get the median (5 um), capped to
        // half their 9.9 um distance.
        for (got, want) in r.iter().zip([4.6, 5.0, 5.4, 4.95, 4.95]) {
            assert!((got - want).abs() < 0.01, "{r:?}");
        }
    }

    /// Particles of their own sizes, 5.2 and 4.8 um, seen 9.99 um apart
    /// share the 10 nm of apparent overlap by size; a lone one keeps its own.
    #[test]
    fn touching_particles_of_two_sizes_share_the_overlap_by_size() {
        let particles = particles_seen(&[
            (3, [10e-6, 20e-6], 5.2e-6),
            (8, [19.99e-6, 20e-6], 4.8e-6),
            (9, [60e-6, 20e-6], 4.5e-6),
        ]);
        let ids: Vec<u32> = particles.iter().map(|p| p.id).collect();
        assert_eq!(ids, [3, 8, 9]);
        let near = |a: f64, b: f64| (a - b).abs() < 1e-11;
        assert!(near(particles[0].radius_m, 5.2e-6 * 0.999), "{particles:?}");
        assert!(near(particles[1].radius_m, 4.8e-6 * 0.999), "{particles:?}");
        assert_eq!(particles[2].radius_m, 4.5e-6);
        let gap = 9.99e-6 - particles[0].radius_m - particles[1].radius_m;
        assert!(gap > 0.0, "overlap {gap}");
    }
}
