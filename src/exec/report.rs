//! The end-of-run report, built from the journal (so a resumed run counts the
//! pushes made before the stop) and the final site errors.
//!
//! The time lower bound is the least time any plan can take with this
//! physics: the optimal assignment's push distance plus, for every particle
//! that must move, the stage travel the cantilever needs before the particle
//! starts (the model's predicted onset), at the push speed; plus the tip
//! travel lower bound at the travel speed.

use super::assemble::{AssemblySettings, RunEnd};
use super::drift::DriftEstimate;
use super::events::{RunEvent, RunSpec};
use super::journal::Entry;
use super::push_log::{PushRecord, push_log};
use super::time_split::TimeSplit;
use crate::model::effects::ActiveEffect;
use crate::model::{Scene, simulate_push};
use crate::plan::Site;
use crate::plan::pattern::sites_um;
use crate::vision::exposure::Exposure;
use crate::vision::line_defects::LineAxis;
use crate::wording::counted;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Schema of `report.json`.
pub const REPORT_SCHEMA: &str = "nanopush.assembly-report/1";

/// Everything `nanopush assemble` reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AssemblyReport {
    /// Always [`REPORT_SCHEMA`].
    pub schema: String,
    /// `"done"`, or `"stopped: <reason>"`. Done means every site is
    /// within the placement tolerance or in `left_short`.
    pub outcome: String,
    /// Target sites.
    pub sites: usize,
    /// Sites with a particle within the placement tolerance.
    pub filled: usize,
    /// Root-mean-square placement error over the sites that have a particle
    /// (see [`placed_errors_m`]), nanometres; 0 when none has.
    pub rms_error_nm: f64,
    /// Largest placement error over the sites that have a particle,
    /// nanometres; 0 when none has.
    pub max_error_nm: f64,
    /// "ground-truth" (simulated rig) or "camera".
    pub error_source: String,
    /// Distance from every site to its nearest particle, nanometres: the
    /// placement error where the site has a particle; for an unfilled site
    /// that particle may be another site's, so the figures leave it out.
    /// Infinite (`null` in JSON) when no particle is tracked at all.
    #[serde(deserialize_with = "infinite_if_null")]
    pub site_errors_nm: Vec<f64>,
    /// Sites without a particle at the end (neither within the tolerance
    /// nor left short), which `rms_error_nm` and `max_error_nm` leave out;
    /// 0 in reports written before this field, whose figures counted them.
    #[serde(default)]
    pub unfilled: usize,
    /// Pushes made (and checked; see [`super::push_log`]).
    pub pushes: usize,
    /// Pushes made that repeated one whose contact was lost.
    pub repushes: usize,
    /// Pushes decided but not made: cut short by a stop or a stage fault
    /// (a resumed run decides them again), or refused by the model; 0 in
    /// reports written before this field.
    #[serde(default)]
    pub pushes_not_made: usize,
    /// Every push decided, in order, those made numbered (report.md's
    /// table); empty in reports written before this field.
    #[serde(default)]
    pub push_log: Vec<PushRecord>,
    /// Lost contacts the camera showed.
    pub lost_contacts_detected: usize,
    /// Lost contacts the simulated rig caused that the executor did not see
    /// (null on a real rig, where nobody knows).
    pub lost_contacts_missed: Option<usize>,
    /// Moves that lowered the tip onto a particle, by the simulated rig's
    /// ground truth (absent on a real rig, where nobody knows, and in
    /// reports written before this field).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_landings_on_particles: Option<usize>,
    /// Rig time of the run, seconds, less [`Self::operator_wait_s`].
    pub time_s: f64,
    /// Rig time the run spent waiting for the operator (the confirmation
    /// before real hardware's first move, once a process), seconds: no
    /// work of the rig's, so not in `time_s`, which had counted it against
    /// the lower bound. 0 on a simulated rig, and in reports written before
    /// this field.
    #[serde(default)]
    pub operator_wait_s: f64,
    /// Least time any plan could take with this physics, seconds (module doc).
    pub lower_bound_s: f64,
    /// Where `time_s` went: pushing, lifted travel and the rest (zero in
    /// reports written before this field).
    #[serde(default)]
    pub time_split: TimeSplit,
    /// `lower_bound_s` by the same parts.
    #[serde(default)]
    pub lower_bound_split: TimeSplit,
    /// Effects the scene made active, with why.
    pub active_effects: Vec<ActiveEffect>,
    /// Simulated contacts that evaluated each effect (effect name -> count);
    /// an effect the scene turns off never appears. Null on a real rig.
    #[serde(default)]
    pub effect_work: Option<BTreeMap<String, u64>>,
    /// Camera lines (dead, hot or off-gain) the frames were repaired along
    /// before detection, with how many frames each was repaired in: a
    /// particle placed on one was measured from the lines beside it. Empty
    /// when none (and in reports written before this field).
    #[serde(default)]
    pub repaired_lines: Vec<RepairedLine>,
    /// Frames clipped beyond the warning level (over-exposed or with the
    /// black level clipping), and the worst fractions seen; zero when none
    /// (and in reports written before this field).
    #[serde(default)]
    pub clipped_frames: ClippedFrames,
    /// The tip's drift against the sample as the last frame that measured
    /// it left the estimate, taken out of every move after it; null when
    /// no frame showed the apex clear of particles, when the run did not
    /// follow drift, and in reports written before this field.
    #[serde(default)]
    pub drift: Option<DriftEstimate>,
    /// Sites taken as filled by a particle the loop gave up on near them
    /// (`AssemblySettings::left_short_m`); empty when none (and in reports
    /// written before this field).
    #[serde(default)]
    pub left_short: Vec<LeftShortSite>,
    /// A site counts as filled with a particle this close, nanometres
    /// (absent in reports written before this field).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub placed_tolerance_nm: Option<f64>,
    /// What the run was asked (its journal's start entry): enough to make
    /// it again. Absent in reports written before this field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub asked: Option<RunAsked>,
    /// How many times the run was resumed after a stop. The effects' work
    /// and the lost contacts missed are counted by the simulated rig of the
    /// last process only; every other figure covers the whole run.
    #[serde(default)]
    pub resumes: usize,
    /// Least free space, um, between the pattern's particles where the run
    /// ended and any particle on no site: how clearly the pattern stands
    /// out (a stray 0.5 um beside a letter reads as part of it). Absent
    /// when the run has no such figure (a dry run, which moved nothing; no
    /// site filled) and in reports written before this field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nearest_stray_gap_um: Option<f64>,
}

/// Whether a stray `gap_um` off the pattern is nearer than the `kept_um`
/// asked of the plans (none asked: never), to the 0.01 um the figures are
/// said to.
pub fn nearer_than_asked(gap_um: f64, kept_um: f64) -> bool {
    kept_um > 0.0 && gap_um < kept_um - 0.005
}

/// What a run was asked, for its report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunAsked {
    /// Text of the pattern, or the pattern file.
    pub pattern: String,
    /// Scene file.
    pub scene: String,
    /// Layout file of the simulated rig, if one was given.
    pub layout: Option<String>,
    /// Seed of the simulated rig; none on a hardware rig.
    #[serde(default)]
    pub seed: Option<u64>,
    /// "nanopush VERSION: COMMAND LINE", when the journal has it.
    pub command: Option<String>,
    /// Free space the plans kept round the pattern, um (`--keep-clear-um`);
    /// 0 when none, and in reports written before this field.
    #[serde(default)]
    pub keep_clear_um: f64,
}

impl From<&RunSpec> for RunAsked {
    fn from(s: &RunSpec) -> Self {
        RunAsked {
            pattern: s.pattern.clone(),
            scene: s.scene.clone(),
            layout: s.layout.clone(),
            seed: s.seed,
            command: s.command.clone(),
            keep_clear_um: s.keep_clear_um,
        }
    }
}

/// A site filled by a particle the loop gave up on near it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LeftShortSite {
    /// Index of the site (as in `site_errors_nm`).
    pub site: usize,
    /// Track id of the particle.
    pub particle: usize,
    /// Its distance from the site when it was left, nanometres (as the
    /// camera saw it).
    pub error_nm: f64,
}

/// The frames of a run whose camera clipped more than the warning level.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ClippedFrames {
    /// How many.
    pub frames: usize,
    /// The largest fraction of a frame at the full count.
    pub max_saturated_fraction: f64,
    /// The largest fraction of a frame at 0.
    pub max_dark_fraction: f64,
}

impl ClippedFrames {
    /// One more clipped frame.
    fn add(&mut self, e: &Exposure) {
        self.frames += 1;
        self.max_saturated_fraction = self.max_saturated_fraction.max(e.saturated_fraction);
        self.max_dark_fraction = self.max_dark_fraction.max(e.dark_fraction);
    }
}

/// A camera line repaired in some of a run's frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct RepairedLine {
    /// Column or row.
    pub axis: LineAxis,
    /// Its x (column) or y (row), pixels.
    pub index: usize,
    /// Frames it was repaired in.
    pub frames: usize,
}

impl std::fmt::Display for RepairedLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {} ({})",
            self.axis,
            self.index,
            crate::wording::counted(self.frames, "frame")
        )
    }
}

/// What a finished run tells the report besides its journal; the parts that
/// differ between the simulated rig (ground truth) and a hardware rig (camera).
#[derive(Debug, Clone)]
pub struct RunFacts<'a> {
    /// How the loop ended.
    pub end: &'a RunEnd,
    /// Target sites.
    pub sites: &'a [Site],
    /// Placement error of every site, metres.
    pub site_errors_m: &'a [f64],
    /// Where the errors come from: "ground-truth" or "camera".
    pub error_source: &'a str,
    /// Lost contacts the loop missed, where somebody knows.
    pub lost_contacts_missed: Option<usize>,
    /// Moves that lowered the tip onto a particle, where somebody knows.
    pub tip_landings_on_particles: Option<usize>,
    /// Rig time at the end, seconds.
    pub time_s: f64,
    /// Effect work counted by a simulated rig.
    pub effect_work: Option<BTreeMap<String, u64>>,
    /// Least free space between the pattern and a stray where the run
    /// ended, metres ([`seen_stray_gap_m`](crate::plan::stray_gap::seen_stray_gap_m)).
    pub nearest_stray_gap_m: Option<f64>,
}

impl AssemblyReport {
    /// True when the run ended done (every site filled or left short), not
    /// stopped.
    pub fn finished(&self) -> bool {
        self.outcome == "done"
    }

    /// "346 s (lower bound 238 s, ratio 1.45)"; no ratio when no plan gave a
    /// lower bound (the run stopped before its first push), nor for a run
    /// that stopped (its bound is the whole pattern's: a ratio of 0.14 read
    /// as a fast run).
    pub fn time_summary(&self) -> String {
        if !self.finished() && self.lower_bound_s > 0.0 {
            format!(
                "{:.0} s before the stop (the whole pattern's lower bound {:.0} s)",
                self.time_s, self.lower_bound_s
            )
        } else if self.lower_bound_s > 0.0 {
            format!(
                "{:.0} s (lower bound {:.0} s, ratio {:.2})",
                self.time_s,
                self.lower_bound_s,
                self.time_s / self.lower_bound_s
            )
        } else {
            format!("{:.0} s (no lower bound: no push was planned)", self.time_s)
        }
    }

    /// What went wrong at the camera, for the summaries: ("camera lines
    /// repaired", ...) and ("camera clipped", ...), each only when it
    /// happened.
    pub fn notes(&self) -> Vec<(&'static str, String)> {
        let short = self.left_short_summary().map(|s| ("left short", s));
        let lines = self
            .repaired_lines_summary()
            .map(|s| ("camera lines repaired", s));
        let clipped = self.clipped_frames_summary().map(|s| ("camera clipped", s));
        let drift = self.drift_summary().map(|s| ("tip drift", s));
        let stray = self.stray_gap_summary().map(|s| ("nearest stray", s));
        let bound = self.finished().then_some(&self.lower_bound_split);
        let spent = self.time_split.said(bound).map(|s| ("time spent", s));
        let waited = (self.operator_wait_s > 0.0).then(|| {
            let s = self.operator_wait_s;
            (
                "operator",
                format!("{s:.1} s waiting for `yes`, not in the run's time"),
            )
        });
        short
            .into_iter()
            .chain(lines)
            .chain(clipped)
            .chain(drift)
            .chain(stray)
            .chain(spent)
            .chain(waited)
            .collect()
    }

    /// "2.71 um off the pattern (its plans kept 2.50 um)", saying so when
    /// nearer than asked (the planner could not keep it, or a push moved
    /// it); None without the figure.
    pub fn stray_gap_summary(&self) -> Option<String> {
        let gap = self.nearest_stray_gap_um?;
        let kept = self.asked.as_ref().map_or(0.0, |a| a.keep_clear_um);
        let plans = if kept <= 0.0 {
            "no gap asked of its plans: --keep-clear-um 0".to_owned()
        } else if nearer_than_asked(gap, kept) {
            format!("nearer than the {kept:.2} um asked of its plans")
        } else {
            format!("its plans kept {kept:.2} um")
        };
        Some(format!("{gap:.2} um off the pattern ({plans})"))
    }

    /// "site 24 by particle 14 (264 nm off by the camera when left), ...:
    /// ...". The distance is the camera's at the time, not the site's error
    /// at the end, and the particle was given up on or boxed in: the line
    /// had said "given up on near its site, which it fills" beside a table
    /// showing that site unfilled by the ground truth.
    /// None when no site was left short.
    pub fn left_short_summary(&self) -> Option<String> {
        let sites: Vec<String> = self
            .left_short
            .iter()
            .map(|l| {
                format!(
                    "site {} by particle {} ({:.0} nm off by the camera when left)",
                    l.site, l.particle, l.error_nm
                )
            })
            .collect();
        (!sites.is_empty()).then(|| {
            format!(
                "{}: each particle left alone near its site (given up on, or boxed in), and the site no longer planned for",
                sites.join(", ")
            )
        })
    }

    /// "offset (0.29, -0.01) um, rate (1.00, -0.02) nm/s, from 24 frames";
    /// None when the run has no estimate.
    pub fn drift_summary(&self) -> Option<String> {
        self.drift.map(|d| {
            format!(
                "offset ({:.2}, {:.2}) um, rate ({:.2}, {:.2}) nm/s, from {}",
                d.offset_um[0],
                d.offset_um[1],
                d.rate_nm_s[0],
                d.rate_nm_s[1],
                crate::wording::counted(d.sightings, "frame")
            )
        })
    }

    /// "column 200 (12 frames), row 7 (3 frames)"; None when no camera
    /// line was repaired.
    pub fn repaired_lines_summary(&self) -> Option<String> {
        let lines: Vec<String> = self
            .repaired_lines
            .iter()
            .map(ToString::to_string)
            .collect();
        (!lines.is_empty()).then(|| lines.join(", "))
    }

    /// "12 frames (up to 61.0 % saturated, 0.0 % at 0 counts)"; None when
    /// no frame clipped beyond the warning level.
    pub fn clipped_frames_summary(&self) -> Option<String> {
        let c = &self.clipped_frames;
        let worst = Exposure {
            saturated_fraction: c.max_saturated_fraction,
            dark_fraction: c.max_dark_fraction,
        };
        (c.frames > 0).then(|| {
            format!(
                "{} (up to {worst})",
                crate::wording::counted(c.frames, "frame")
            )
        })
    }

    /// "rms 12 nm, max 30 nm (camera)", with "over 19 sites with a
    /// particle; 1 site unfilled" when some site has none.
    pub fn placement_error_summary(&self) -> String {
        let placed = self.sites - self.unfilled;
        let unfilled = counted(self.unfilled, "site");
        if placed == 0 {
            return format!("none: no site has a particle ({unfilled} unfilled)");
        }
        let figures = format!(
            "rms {:.0} nm, max {:.0} nm ({})",
            self.rms_error_nm, self.max_error_nm, self.error_source
        );
        if self.unfilled == 0 {
            figures
        } else {
            format!(
                "{figures} over {} with a particle; {unfilled} unfilled",
                counted(placed, "site")
            )
        }
    }

    /// The report of a run: counts from its journal, errors and the rest from `facts`.
    pub fn from_run(
        facts: RunFacts<'_>,
        entries: &[Entry<RunEvent>],
        scene: &Scene,
        settings: &AssemblySettings,
    ) -> Self {
        let counts = count_journal(
            entries,
            &sites_um(facts.sites),
            settings.placed_tolerance_m * 1e6,
        );
        let errors_m = facts.site_errors_m;
        let tolerance_m = settings.placed_tolerance_m;
        let placed = placed_errors_m(errors_m, tolerance_m, &counts.left_short);
        let (rms_error_nm, max_error_nm) = error_figures_nm(&placed);
        let bound = lower_bound(
            &counts,
            scene.push.speed_m_per_s,
            settings.travel_speed_m_per_s,
        );
        let time_s = (facts.time_s - counts.operator_wait_s).max(0.0);
        let travel_um_s = settings.travel_speed_m_per_s * 1e6;
        AssemblyReport {
            schema: REPORT_SCHEMA.to_owned(),
            outcome: match facts.end.reason() {
                None => "done".to_owned(),
                Some(why) => format!("stopped: {why}"),
            },
            sites: facts.sites.len(),
            filled: errors_m
                .iter()
                .filter(|e| **e <= settings.placed_tolerance_m)
                .count(),
            rms_error_nm,
            max_error_nm,
            error_source: facts.error_source.to_owned(),
            site_errors_nm: errors_m.iter().map(|e| e * 1e9).collect(),
            unfilled: errors_m.len() - placed.len(),
            pushes: counts.pushes,
            repushes: counts.repushes,
            pushes_not_made: counts.pushes_not_made,
            push_log: counts.push_log,
            lost_contacts_detected: counts.lost_contacts_detected,
            lost_contacts_missed: facts.lost_contacts_missed,
            tip_landings_on_particles: facts.tip_landings_on_particles,
            time_s,
            operator_wait_s: counts.operator_wait_s,
            lower_bound_s: bound.pushing_s + bound.travel_s,
            time_split: TimeSplit::of_run(entries, travel_um_s, time_s),
            lower_bound_split: bound,
            active_effects: simulate_push(scene, &scene.push)
                .map(|r| r.active_effects)
                .unwrap_or_default(),
            effect_work: facts.effect_work,
            repaired_lines: counts.repaired_lines,
            clipped_frames: counts.clipped_frames,
            drift: counts.drift,
            left_short: counts.left_short,
            placed_tolerance_nm: Some(settings.placed_tolerance_m * 1e9),
            asked: counts.spec.as_ref().map(RunAsked::from),
            resumes: counts.resumes,
            nearest_stray_gap_um: facts.nearest_stray_gap_m.map(|g| g * 1e6),
        }
    }
}

/// Counts read off a journal.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JournalCounts {
    /// The start entry's spec.
    pub spec: Option<RunSpec>,
    /// Resume entries.
    pub resumes: usize,
    /// Pushes made (numbered in [`Self::push_log`]).
    pub pushes: usize,
    /// Pushes made that were repushes.
    pub repushes: usize,
    /// Decisions whose push was not made.
    pub pushes_not_made: usize,
    /// Check entries that found a lost contact.
    pub lost_contacts_detected: usize,
    /// Push distance and tip travel lower bounds of the first plan, micrometres.
    pub first_plan_bounds_um: Option<(f64, f64)>,
    /// Onset of the first push decision, seconds.
    pub first_onset_s: Option<f64>,
    /// Sites without a particle in the first observation.
    pub sites_to_fill: Option<usize>,
    /// The last entry's time.
    pub last_t_s: f64,
    /// Seconds waited for the operator (operator-wait entries).
    pub operator_wait_s: f64,
    /// `"done"`, or `"stopped: <reason>"` of the last end entry; None while running.
    pub outcome: Option<String>,
    /// Camera lines repaired in the observations, columns first, by index.
    pub repaired_lines: Vec<RepairedLine>,
    /// Observations whose frame clipped beyond the warning level.
    pub clipped_frames: ClippedFrames,
    /// The last observation's drift estimate.
    pub drift: Option<DriftEstimate>,
    /// Sites left short, in the journal's order (one entry a site).
    pub left_short: Vec<LeftShortSite>,
    /// Every push decided, those made numbered.
    pub push_log: Vec<PushRecord>,
}

/// Reads the counts off a journal's entries; `sites_um` and `tolerance_um`
/// decide which sites the first observation shows empty.
pub fn count_journal(
    entries: &[Entry<RunEvent>],
    sites_um: &[[f64; 2]],
    tolerance_um: f64,
) -> JournalCounts {
    let mut c = JournalCounts {
        push_log: push_log(entries),
        ..JournalCounts::default()
    };
    for p in &c.push_log {
        if p.n.is_some() {
            c.pushes += 1;
            c.repushes += usize::from(p.repush);
        } else {
            c.pushes_not_made += 1;
        }
    }
    for e in entries {
        c.last_t_s = c.last_t_s.max(e.t_s);
        match &e.event {
            RunEvent::Start(spec) => {
                c.spec.get_or_insert_with(|| spec.clone());
            }
            RunEvent::Decision { onset_s, .. } => {
                c.first_onset_s.get_or_insert(*onset_s);
            }
            RunEvent::Check {
                lost_contact: true, ..
            } => c.lost_contacts_detected += 1,
            RunEvent::Plan {
                lb_push_um,
                lb_tip_um,
                ..
            } => {
                c.first_plan_bounds_um
                    .get_or_insert((*lb_push_um, *lb_tip_um));
            }
            RunEvent::Observation {
                particles,
                repaired_lines,
                clipped,
                drift,
                ..
            } => {
                if drift.is_some() {
                    c.drift = *drift;
                }
                for line in repaired_lines {
                    count_repaired(&mut c.repaired_lines, line.axis, line.index);
                }
                if let Some(exposure) = clipped {
                    c.clipped_frames.add(exposure);
                }
                c.sites_to_fill.get_or_insert_with(|| {
                    sites_um
                        .iter()
                        .filter(|s| {
                            !particles
                                .iter()
                                .any(|p| (p.x_um - s[0]).hypot(p.y_um - s[1]) <= tolerance_um)
                        })
                        .count()
                });
            }
            RunEvent::LeftShort {
                site,
                particle,
                error_nm,
            } => {
                // A resumed run forgets what it left and may leave a site
                // short again: the latest word on it stands.
                c.left_short.retain(|l| l.site != *site);
                c.left_short.push(LeftShortSite {
                    site: *site,
                    particle: *particle,
                    error_nm: *error_nm,
                });
            }
            RunEvent::OperatorWait { waited_s } => c.operator_wait_s += waited_s,
            RunEvent::Done => c.outcome = Some("done".to_owned()),
            RunEvent::Stopped { reason, .. } => c.outcome = Some(format!("stopped: {reason}")),
            RunEvent::Resume { .. } => {
                c.outcome = None;
                c.resumes += 1;
            }
            _ => {}
        }
    }
    c
}

/// One more frame for the line at `axis`, `index`; the list stays sorted
/// (columns first, by index) so that reports compare and read the same.
fn count_repaired(lines: &mut Vec<RepairedLine>, axis: LineAxis, index: usize) {
    let key = |l: &RepairedLine| (l.axis == LineAxis::Row, l.index);
    let wanted = (axis == LineAxis::Row, index);
    match lines.binary_search_by_key(&wanted, key) {
        Ok(i) => lines[i].frames += 1,
        Err(i) => lines.insert(
            i,
            RepairedLine {
                axis,
                index,
                frames: 1,
            },
        ),
    }
}

/// The time lower bound (module doc), seconds, by its parts.
pub fn lower_bound(
    c: &JournalCounts,
    push_speed_m_per_s: f64,
    travel_speed_m_per_s: f64,
) -> TimeSplit {
    let (lb_push_um, lb_tip_um) = c.first_plan_bounds_um.unwrap_or((0.0, 0.0));
    let onset_travel_um = c.first_onset_s.unwrap_or(0.0) * push_speed_m_per_s * 1e6;
    let moves = c.sites_to_fill.unwrap_or(0) as f64;
    TimeSplit {
        pushing_s: (lb_push_um + moves * onset_travel_um) * 1e-6 / push_speed_m_per_s,
        travel_s: lb_tip_um * 1e-6 / travel_speed_m_per_s,
        other_s: 0.0,
    }
}

/// The errors of the sites that have a particle: within `tolerance_m`, or
/// left short (a particle left near the site on purpose). An unfilled
/// site's distance is to the nearest particle, often another site's: a
/// stopped run's figures had counted them, "rms 14 um" for 20 nm placements.
pub fn placed_errors_m(
    errors_m: &[f64],
    tolerance_m: f64,
    left_short: &[LeftShortSite],
) -> Vec<f64> {
    errors_m
        .iter()
        .enumerate()
        .filter(|(i, e)| **e <= tolerance_m || left_short.iter().any(|l| l.site == *i))
        .map(|(_, e)| *e)
        .collect()
}

/// Reads `site_errors_nm` back: JSON writes an infinite distance (no
/// particle tracked at all) as `null`, which a plain `f64` refuses, so
/// such a report had not read back.
fn infinite_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let read = Vec::<Option<f64>>::deserialize(d)?;
    Ok(read
        .into_iter()
        .map(|e| e.unwrap_or(f64::INFINITY))
        .collect())
}

/// Root mean square and maximum of errors in metres, as nanometres.
pub fn error_figures_nm(errors_m: &[f64]) -> (f64, f64) {
    if errors_m.is_empty() {
        return (0.0, 0.0);
    }
    let rms = (errors_m.iter().map(|e| e * e).sum::<f64>() / errors_m.len() as f64).sqrt();
    let max = errors_m.iter().copied().fold(0.0, f64::max);
    (rms * 1e9, max * 1e9)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::exec::events::SeenParticle;
    use crate::vision::line_defects::LineDefect;

    fn entry(seq: u64, t_s: f64, event: RunEvent) -> Entry<RunEvent> {
        Entry { seq, t_s, event }
    }

    fn decision(repush: bool) -> RunEvent {
        RunEvent::Decision {
            particle: 1,
            from_um: [0.0, 0.0],
            to_um: [10.0, 0.0],
            contact_angle_deg: 45.0,
            duration_s: 19.0,
            onset_s: 9.0,
            critical_force_un: 3.0,
            ride_over_margin: None,
            mode: "rolling".to_owned(),
            repush,
            radius_um: None,
            lead_nm: None,
        }
    }

    #[test]
    fn counts_and_bound_follow_the_journal() {
        let seen = |x: f64| SeenParticle {
            id: 0,
            x_um: x,
            y_um: 0.0,
            r_um: 5.0,
        };
        let entries = vec![
            entry(
                0,
                0.0,
                RunEvent::Observation {
                    frame: 0,
                    particles: vec![seen(0.0), seen(50.0)],
                    tip_um: None,
                    repaired_lines: Vec::new(),
                    clipped: None,
                    drift: None,
                },
            ),
            entry(
                1,
                0.1,
                RunEvent::Plan {
                    pushes: 1,
                    push_distance_um: 10.0,
                    tip_travel_um: 5.0,
                    lb_push_um: 10.0,
                    lb_tip_um: 5.0,
                    planning_ms: 1.0,
                    replaced_because: None,
                },
            ),
            entry(2, 0.2, decision(false)),
            entry(
                3,
                20.0,
                RunEvent::Check {
                    particle: 1,
                    result: "fell-short".into(),
                    error_nm: 9000.0,
                    lost_contact: true,
                },
            ),
            entry(4, 21.0, decision(true)),
            entry(
                5,
                40.0,
                RunEvent::Stopped {
                    reason: "test".into(),
                    cause: None,
                },
            ),
        ];
        let c = count_journal(&entries, &[[10.0, 0.0], [50.0, 0.0]], 0.1);
        // The re-push was decided, and the run stopped before the tip moved.
        assert_eq!((c.pushes, c.repushes, c.lost_contacts_detected), (1, 0, 1));
        assert_eq!(c.pushes_not_made, 1);
        assert_eq!(c.sites_to_fill, Some(1));
        assert_eq!(c.outcome.as_deref(), Some("stopped: test"));
        // (10 um + 1 x 9 um onset travel) at 1 um/s + 5 um at 10 um/s.
        let bound = lower_bound(&c, 1e-6, 10e-6);
        assert!((bound.pushing_s - 19.0).abs() < 1e-9, "{bound:?}");
        assert!((bound.travel_s - 0.5).abs() < 1e-9, "{bound:?}");
    }

    /// Each repaired camera line is counted once per frame it was repaired
    /// in, columns before rows, and the clipped frames with their worst
    /// fractions; a journal line written before the fields reads as a frame
    /// without either.
    #[test]
    fn camera_lines_and_clipped_frames_are_counted_from_the_journal() {
        let line = |axis, index| LineDefect {
            axis,
            index,
            mean_counts: 0.0,
            beside_counts: 900.0,
        };
        let observation = |repaired_lines, clipped| RunEvent::Observation {
            frame: 0,
            particles: Vec::new(),
            tip_um: None,
            repaired_lines,
            clipped,
            drift: None,
        };
        let clipped = |saturated_fraction, dark_fraction| {
            Some(Exposure {
                saturated_fraction,
                dark_fraction,
            })
        };
        let older: RunEvent = serde_json::from_str(
            r#"{"kind":"observation","frame":0,"particles":[],"tip_um":null}"#,
        )
        .unwrap();
        assert_eq!(older, observation(Vec::new(), None));
        let events = [
            observation(vec![line(LineAxis::Column, 200)], clipped(0.3, 0.0)),
            observation(
                vec![line(LineAxis::Row, 7), line(LineAxis::Column, 200)],
                None,
            ),
            older,
            observation(
                vec![line(LineAxis::Column, 3), line(LineAxis::Column, 200)],
                clipped(0.6, 0.02),
            ),
        ];
        let entries: Vec<_> = events
            .into_iter()
            .enumerate()
            .map(|(i, e)| entry(i as u64, i as f64, e))
            .collect();
        let c = count_journal(&entries, &[], 0.1);
        let counted = |axis, index, frames| RepairedLine {
            axis,
            index,
            frames,
        };
        assert_eq!(
            c.repaired_lines,
            [
                counted(LineAxis::Column, 3, 1),
                counted(LineAxis::Column, 200, 3),
                counted(LineAxis::Row, 7, 1),
            ]
        );
        assert_eq!(
            c.clipped_frames,
            ClippedFrames {
                frames: 2,
                max_saturated_fraction: 0.6,
                max_dark_fraction: 0.02
            }
        );
        // A frame without defects or clipping writes neither field.
        let text = serde_json::to_string(&observation(Vec::new(), None)).unwrap();
        assert!(
            !text.contains("repaired_lines") && !text.contains("clipped"),
            "{text}"
        );
    }

    /// The report takes the last drift estimate a frame journalled; frames
    /// without one (the apex beside a particle, older journals) keep it.
    #[test]
    fn the_last_drift_estimate_is_the_runs_and_reads_back_from_the_journal() {
        let estimate = |x_um: f64, sightings| DriftEstimate {
            offset_um: [x_um, 0.0],
            rate_nm_s: [1.0, 0.0],
            sightings,
        };
        let observation = |drift| RunEvent::Observation {
            frame: 0,
            particles: Vec::new(),
            tip_um: Some([1.0, 2.0]),
            repaired_lines: Vec::new(),
            clipped: None,
            drift,
        };
        let with = observation(Some(estimate(0.25, 7)));
        let text = serde_json::to_string(&with).unwrap();
        assert!(
            text.contains(r#""drift":{"offset_um":[0.25,0.0]"#),
            "{text}"
        );
        assert_eq!(serde_json::from_str::<RunEvent>(&text).unwrap(), with);
        let older: RunEvent = serde_json::from_str(
            r#"{"kind":"observation","frame":0,"particles":[],"tip_um":[1.0,2.0]}"#,
        )
        .unwrap();
        assert_eq!(older, observation(None));
        let events = [
            observation(None),
            observation(Some(estimate(0.1, 1))),
            observation(Some(estimate(0.2, 2))),
            older,
        ];
        let entries: Vec<_> = events
            .into_iter()
            .enumerate()
            .map(|(i, e)| entry(i as u64, i as f64, e))
            .collect();
        assert_eq!(
            count_journal(&entries, &[], 0.1).drift,
            Some(estimate(0.2, 2))
        );
        assert_eq!(count_journal(&entries[..1], &[], 0.1).drift, None);
    }

    #[test]
    fn error_figures_are_rms_and_max() {
        let (rms, max) = error_figures_nm(&[3e-9, 4e-9]);
        assert!((rms - (12.5f64).sqrt()).abs() < 1e-9);
        assert_eq!(max, 4.0);
        assert_eq!(error_figures_nm(&[]), (0.0, 0.0));
    }

    /// Sites left short are counted from the journal, one entry a site
    /// (a resumed run may leave one short again: its latest word stands),
    /// named first among the notes, and read back from report.json.
    #[test]
    fn sites_left_short_are_counted_named_and_read_back() {
        let short = |site, particle, error_nm| RunEvent::LeftShort {
            site,
            particle,
            error_nm,
        };
        let entries = vec![
            entry(0, 1.0, short(4, 11, 260.0)),
            entry(
                1,
                2.0,
                RunEvent::Resume {
                    drift_follow: false,
                },
            ),
            entry(2, 3.0, short(7, 2, 180.0)),
            entry(3, 4.0, short(4, 9, 310.0)),
        ];
        let c = count_journal(&entries, &[], 0.2);
        let site = |site, particle, error_nm| LeftShortSite {
            site,
            particle,
            error_nm,
        };
        assert_eq!(c.left_short, [site(7, 2, 180.0), site(4, 9, 310.0)]);
        let r = AssemblyReport {
            left_short: c.left_short,
            ..small_report()
        };
        assert_eq!(
            r.notes().first().map(|n| (n.0, n.1.as_str())),
            Some((
                "left short",
                "site 7 by particle 2 (180 nm off by the camera when left), site 4 by particle 9 (310 nm off by the camera when left): each particle left alone near its site (given up on, or boxed in), and the site no longer planned for"
            ))
        );
        let text = serde_json::to_string(&r).unwrap();
        assert_eq!(serde_json::from_str::<AssemblyReport>(&text).unwrap(), r);
        assert!(small_report().notes().is_empty());
    }

    /// A stopped run's placement error covers the sites with a particle
    /// (within the tolerance, or left short), the unfilled ones counted
    /// apart; the report reads back, and one without `unfilled` still reads.
    #[test]
    fn a_stopped_runs_placement_error_leaves_unfilled_sites_out() {
        let scene = Scene::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"),
        )
        .unwrap();
        let settings = AssemblySettings::default();
        let tol = settings.placed_tolerance_m;
        let sites = crate::plan::pattern::numbered_sites(
            (0..4).map(|i| nalgebra::Vector2::new(f64::from(i) * 20e-6, 0.0)),
        );
        // Two placed, one left short beyond the tolerance, one unfilled
        // whose nearest particle is 14 um off.
        let errors_m = [0.2 * tol, 0.6 * tol, 1.5 * tol, 14e-6];
        let end = RunEnd::Stopped("interrupted".into());
        let facts = RunFacts {
            end: &end,
            sites: &sites,
            site_errors_m: &errors_m,
            error_source: "ground-truth",
            lost_contacts_missed: None,
            tip_landings_on_particles: None,
            time_s: 10.0,
            effect_work: None,
            nearest_stray_gap_m: None,
        };
        let journal = [entry(
            0,
            1.0,
            RunEvent::LeftShort {
                site: 2,
                particle: 7,
                error_nm: errors_m[2] * 1e9,
            },
        )];
        let r = AssemblyReport::from_run(facts, &journal, &scene, &settings);
        let placed = &errors_m[..3];
        let (rms, max) = error_figures_nm(placed);
        assert_eq!((r.rms_error_nm, r.max_error_nm), (rms, max));
        assert!(r.max_error_nm < errors_m[3] * 1e9, "{r:?}");
        assert_eq!((r.filled, r.unfilled, r.sites), (2, 1, 4));
        assert_eq!(r.site_errors_nm.len(), 4, "every site keeps its distance");
        assert_eq!(
            r.placement_error_summary(),
            format!(
                "rms {rms:.0} nm, max {max:.0} nm (ground-truth) over 3 sites with a particle; 1 site unfilled"
            )
        );
        let old = read_back_without(&r, &["unfilled"]);
        assert_eq!(old.unfilled, 0);
        let none = AssemblyReport { unfilled: 4, ..r };
        assert_eq!(
            none.placement_error_summary(),
            "none: no site has a particle (4 sites unfilled)"
        );
    }

    /// With no particle tracked at all every site's distance is infinite,
    /// written as `null`: the report reads back (it had been refused).
    #[test]
    fn a_report_without_any_particle_reads_back() {
        let r = AssemblyReport {
            site_errors_nm: vec![f64::INFINITY, 3.0],
            ..small_report()
        };
        let text = serde_json::to_string(&r).unwrap();
        assert!(text.contains("\"site_errors_nm\":[null,3.0]"), "{text}");
        assert_eq!(serde_json::from_str::<AssemblyReport>(&text).unwrap(), r);
    }

    /// `r` read back from its JSON, checked equal, and read again with
    /// `fields` taken out: a report written before those fields.
    fn read_back_without(r: &AssemblyReport, fields: &[&str]) -> AssemblyReport {
        let text = serde_json::to_string(r).unwrap();
        assert_eq!(&serde_json::from_str::<AssemblyReport>(&text).unwrap(), r);
        let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
        for field in fields {
            old.as_object_mut().unwrap().remove(*field);
        }
        serde_json::from_value(old).unwrap()
    }

    /// A finished one-site run, 30 s against a 20 s bound.
    pub(crate) fn small_report() -> AssemblyReport {
        AssemblyReport {
            schema: REPORT_SCHEMA.to_owned(),
            outcome: "done".into(),
            sites: 1,
            filled: 1,
            rms_error_nm: 0.0,
            max_error_nm: 0.0,
            error_source: "ground-truth".into(),
            site_errors_nm: vec![0.0],
            unfilled: 0,
            pushes: 1,
            repushes: 0,
            pushes_not_made: 0,
            push_log: Vec::new(),
            lost_contacts_detected: 0,
            lost_contacts_missed: Some(0),
            tip_landings_on_particles: Some(0),
            time_s: 30.0,
            lower_bound_s: 20.0,
            active_effects: Vec::new(),
            effect_work: None,
            repaired_lines: Vec::new(),
            clipped_frames: ClippedFrames::default(),
            drift: None,
            left_short: Vec::new(),
            placed_tolerance_nm: Some(200.0),
            asked: None,
            resumes: 0,
            nearest_stray_gap_um: None,
            operator_wait_s: 0.0,
            time_split: TimeSplit::default(),
            lower_bound_split: TimeSplit::default(),
        }
    }

    /// The time a run waited for its operator's `yes` (once a process: a
    /// new run and each resume) is left out of its time and said apart;
    /// report.json keeps it, and one written before the field reads as none.
    #[test]
    fn the_operators_waits_are_not_the_runs_time() {
        let scene = Scene::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"),
        )
        .unwrap();
        let end = RunEnd::Done;
        let facts = RunFacts {
            end: &end,
            sites: &[],
            site_errors_m: &[],
            error_source: "camera",
            lost_contacts_missed: None,
            tip_landings_on_particles: None,
            time_s: 100.0,
            effect_work: None,
            nearest_stray_gap_m: None,
        };
        let waited = |seq, t_s, waited_s| entry(seq, t_s, RunEvent::OperatorWait { waited_s });
        let resume = RunEvent::Resume {
            drift_follow: false,
        };
        let journal = [
            waited(0, 14.0, 12.5),
            entry(1, 40.0, resume),
            waited(2, 44.0, 3.0),
        ];
        let settings = AssemblySettings::default();
        let r = AssemblyReport::from_run(facts, &journal, &scene, &settings);
        assert_eq!((r.time_s, r.operator_wait_s), (84.5, 15.5));
        let said = r.notes().into_iter().find(|(what, _)| *what == "operator");
        assert_eq!(
            said.map(|(_, s)| s).as_deref(),
            Some("15.5 s waiting for `yes`, not in the run's time")
        );
        let old = read_back_without(&r, &["operator_wait_s"]);
        assert_eq!(old.operator_wait_s, 0.0);
        assert!(old.notes().iter().all(|(what, _)| *what != "operator"));
    }

    /// The stray gap is said against the gap asked of the plans, and
    /// read back from report.json.
    #[test]
    fn the_stray_gap_is_said_against_the_gap_asked() {
        let mut r = small_report();
        assert_eq!(r.stray_gap_summary(), None);
        assert!(r.notes().iter().all(|(what, _)| *what != "nearest stray"));
        r.nearest_stray_gap_um = Some(2.714);
        let said = r.stray_gap_summary().unwrap();
        assert!(
            said.contains("2.71 um off the pattern (no gap asked"),
            "{said}"
        );
        r.asked = Some(RunAsked {
            pattern: "CMU".into(),
            scene: "s.toml".into(),
            layout: None,
            seed: Some(3),
            command: None,
            keep_clear_um: 2.5,
        });
        assert_eq!(
            r.stray_gap_summary().unwrap(),
            "2.71 um off the pattern (its plans kept 2.50 um)"
        );
        r.nearest_stray_gap_um = Some(0.87);
        let said = r.stray_gap_summary().unwrap();
        assert!(said.contains("nearer than the 2.50 um asked"), "{said}");
        assert!(r.notes().iter().any(|(what, _)| *what == "nearest stray"));
        let text = serde_json::to_string(&r).unwrap();
        assert_eq!(serde_json::from_str::<AssemblyReport>(&text).unwrap(), r);
    }

    /// No ratio without a lower bound, nor for a stopped run (the bound is
    /// the whole pattern's: 0.14 had read as a fast run).
    #[test]
    fn time_summary_gives_no_ratio_without_a_lower_bound() {
        let mut r = small_report();
        assert_eq!(r.time_summary(), "30 s (lower bound 20 s, ratio 1.50)");
        r.outcome = "stopped: interrupted".into();
        assert_eq!(
            r.time_summary(),
            "30 s before the stop (the whole pattern's lower bound 20 s)"
        );
        r.lower_bound_s = 0.0;
        assert!(!r.time_summary().contains("ratio"), "{}", r.time_summary());
    }

    /// The repaired lines and the clipped frames read back from report.json
    /// and are named in the summary; a report written before the fields
    /// reads as none.
    #[test]
    fn a_report_names_its_camera_troubles_and_reads_back() {
        let mut r = small_report();
        assert_eq!(r.repaired_lines_summary(), None);
        assert_eq!(r.clipped_frames_summary(), None);
        assert_eq!(r.drift_summary(), None);
        assert!(r.notes().is_empty());
        r.drift = Some(DriftEstimate {
            offset_um: [0.291, -0.012],
            rate_nm_s: [1.004, -0.021],
            sightings: 24,
        });
        assert_eq!(
            r.drift_summary().as_deref(),
            Some("offset (0.29, -0.01) um, rate (1.00, -0.02) nm/s, from 24 frames")
        );
        r.clipped_frames = ClippedFrames {
            frames: 12,
            max_saturated_fraction: 0.61,
            max_dark_fraction: 0.0,
        };
        assert_eq!(
            r.clipped_frames_summary().as_deref(),
            Some("12 frames (up to 61.0 % saturated, 0.0 % at 0 counts)")
        );
        // One frame is said as one ("row 7 (1 frames)" had been).
        r.repaired_lines = vec![
            RepairedLine {
                axis: LineAxis::Column,
                index: 200,
                frames: 12,
            },
            RepairedLine {
                axis: LineAxis::Row,
                index: 7,
                frames: 1,
            },
        ];
        assert_eq!(
            r.repaired_lines_summary().as_deref(),
            Some("column 200 (12 frames), row 7 (1 frame)")
        );
        let text = serde_json::to_string(&r).unwrap();
        assert!(
            text.contains(r#""repaired_lines":[{"axis":"column","index":200,"frames":12},{"axis":"row","index":7,"frames":1}]"#),
            "{text}"
        );
        let notes: Vec<&str> = r.notes().iter().map(|n| n.0).collect();
        assert_eq!(
            notes,
            ["camera lines repaired", "camera clipped", "tip drift"]
        );
        let fields = ["repaired_lines", "clipped_frames", "drift", "left_short"];
        let older = read_back_without(&r, &fields);
        assert_eq!(
            older,
            AssemblyReport {
                repaired_lines: Vec::new(),
                clipped_frames: ClippedFrames::default(),
                drift: None,
                ..r
            }
        );
    }
}
