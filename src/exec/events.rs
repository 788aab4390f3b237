//! What the executor writes to its journal: every command, observation and
//! decision, in lab units. The journal is enough to resume a run and to
//! rebuild its report.

use super::drift::DriftEstimate;
use super::stop_cause::StopCause;
use crate::vision::exposure::Exposure;
use crate::vision::line_defects::LineDefect;
use serde::{Deserialize, Serialize};

/// What a run was asked to do; the first journal entry, and what `--resume` restarts from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Text of the pattern (`--text`) or the pattern file it came from.
    pub pattern: String,
    /// Scene file the model and the simulated rig use.
    pub scene: String,
    /// Layout file of the simulated rig, if one was given.
    pub layout: Option<String>,
    /// Seed of the simulated rig's random layout and noise; absent on a
    /// hardware rig, which has no seed (rig journals from before
    /// 2026-11-30 say `"seed":1`, which nothing reads).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Target sites on the sample, micrometres.
    pub sites_um: Vec<[f64; 2]>,
    /// Particle radius the run was planned for, micrometres.
    pub radius_um: f64,
    /// On a hardware rig, what a resume needs to put the run's frame back;
    /// absent on the simulated rig (and in journals from before 2026-11-28).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigFrame>,
    /// The run does not follow the tip's drift (`assemble
    /// --no-drift-follow`), and neither does its resume; absent when it
    /// does (and in journals from before 2026-11-29).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub drift_off: bool,
    /// Free space the run's plans keep between a particle on no site and
    /// the pattern's particles, um (`assemble --keep-clear-um`), which its
    /// resume keeps too; absent when 0 (and in journals from before
    /// 2026-11-30).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub keep_clear_um: f64,
    /// The command line that started the run and the nanopush version, so
    /// that a report says how to make the run again (`nanopush 0.1.0:
    /// nanopush assemble --text CMU --seed 7`); absent in journals from
    /// before 2026-11-29.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<String>,
    /// CRC-32 of the scene file when the run started ([`scene_file_crc`]),
    /// so that a resume notices a scene edited since; absent for the
    /// built-in copy of a scene, and in journals from before 2026-11-29.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_crc32: Option<u32>,
}

/// CRC-32 of the file at `scene`, None when there is none to read (a
/// built-in scene).
pub fn scene_file_crc(scene: &str) -> Option<u32> {
    std::fs::read(scene)
        .ok()
        .map(|bytes| crc32fast::hash(&bytes))
}

/// True for 0 (a spec's field left out of the journal).
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl RunSpec {
    /// The spec with this process's provenance: its command line
    /// ("nanopush VERSION: COMMAND LINE") and its scene file's CRC
    /// ([`scene_file_crc`]), as a new run's start entry keeps them.
    pub fn stamped(self) -> Self {
        RunSpec {
            command: Some(this_command()),
            scene_crc32: scene_file_crc(&self.scene),
            ..self
        }
    }

    /// True when the scene file's CRC is not the one the run started with
    /// (false without either: a built-in scene, an older journal).
    pub fn scene_changed(&self) -> bool {
        matches!(
            (self.scene_crc32, scene_file_crc(&self.scene)),
            (Some(then), Some(now)) if then != now
        )
    }

    /// Says (stderr) when the run's scene file is not the one it started
    /// with: the physics of the part before the stop was the old file's,
    /// and a resume had carried on with the new one without a word.
    pub fn warn_if_scene_changed(&self) {
        if self.scene_changed() {
            eprintln!(
                "warning: scene {} has changed since the run started: the rest of the run uses it as it is now",
                self.scene
            );
        }
    }
}

/// This process's command line as a shell would take it back, after the
/// nanopush version: "nanopush 0.1.0: nanopush assemble --text CMU --seed 7"
/// ([`RunSpec::command`]).
fn this_command() -> String {
    let quoted = |a: String| {
        let plain = |c: char| c.is_ascii_alphanumeric() || "-_./,=:+@%".contains(c);
        if !a.is_empty() && a.chars().all(plain) {
            a
        } else {
            format!("'{}'", a.replace('\'', r"'\''"))
        }
    };
    let args: Vec<String> = std::iter::once("nanopush".to_owned())
        .chain(std::env::args().skip(1).map(quoted))
        .collect();
    format!("nanopush {}: {}", env!("CARGO_PKG_VERSION"), args.join(" "))
}

/// A hardware run's frame on its rig: the planner's field, and with a
/// coarse stage where the field's origin lies in the coarse stage's own
/// coordinates (the run moved its sample frame there).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RigFrame {
    /// The rig file the run was on, as given.
    pub rig_file: String,
    /// The run's field, micrometres.
    pub field_um: [f64; 2],
    /// What the run subtracted from the coarse stage's readings, in the
    /// stage's own fixed coordinates (not its readings', which start at
    /// zero where a process opened it), micrometres; absent on a rig
    /// without a coarse stage.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse_shift_um: Option<[f64; 2]>,
    /// The coarse stage's reading in the run's sample frame where it first
    /// looked, micrometres: a resume looks from there first, and so sees
    /// the field the run planned on (elsewhere a particle may lie out of
    /// view, and be planned through). Absent without a coarse stage.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_view_coarse_um: Option<[f64; 2]>,
}

/// A particle seen in a frame, with its track id.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SeenParticle {
    /// Track id.
    pub id: usize,
    /// Centre on the sample, micrometres.
    pub x_um: f64,
    /// Centre on the sample, micrometres.
    pub y_um: f64,
    /// Radius, micrometres.
    pub r_um: f64,
}

/// One journal event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum RunEvent {
    /// The run started.
    Start(RunSpec),
    /// The run was resumed after a stop; entries before this one came before the stop.
    Resume {
        /// This resume follows the tip's drift in a run that had not
        /// (`--resume --drift-follow` on a run started with
        /// `--no-drift-follow`), and so does every later resume
        /// ([`drift_off`](super::resume_point::drift_off)); absent
        /// otherwise, and in journals from before 2026-11-30.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        drift_follow: bool,
    },
    /// A frame was grabbed and analysed.
    Observation {
        /// Frame number.
        frame: usize,
        /// Particles seen (tracked).
        particles: Vec<SeenParticle>,
        /// Tip apex on the sample, micrometres, when seen.
        tip_um: Option<[f64; 2]>,
        /// Camera lines repaired from their neighbours in this frame (absent
        /// when none, and in journals written before this field).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        repaired_lines: Vec<LineDefect>,
        /// The frame's clipped fractions when either is above the warning
        /// level (absent otherwise, and in journals written before this field).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        clipped: Option<Exposure>,
        /// The tip's drift as estimated after this frame (absent before the
        /// first sighting of the apex clear of particles, when the loop does
        /// not follow drift, and in journals written before this field).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        drift: Option<DriftEstimate>,
    },
    /// The camera dropped a frame.
    FrameDropped,
    /// A (re-)plan.
    Plan {
        /// Pushes in the plan.
        pushes: usize,
        /// Total particle travel, micrometres.
        push_distance_um: f64,
        /// Lifted tip travel, micrometres.
        tip_travel_um: f64,
        /// Lower bound of push distance, micrometres.
        lb_push_um: f64,
        /// Lower bound of tip travel, micrometres.
        lb_tip_um: f64,
        /// Wall time spent planning, milliseconds.
        planning_ms: f64,
        /// Why the plan in hand was not kept (absent on the first plan and in
        /// journals written before this field).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        replaced_because: Option<String>,
    },
    /// The model's choice for the next push.
    Decision {
        /// Track id of the particle.
        particle: usize,
        /// Centre before, micrometres.
        from_um: [f64; 2],
        /// Centre wanted after, micrometres.
        to_um: [f64; 2],
        /// Chosen contact angle, degrees.
        contact_angle_deg: f64,
        /// Push duration after first touch, seconds.
        duration_s: f64,
        /// Predicted onset of motion, seconds after first touch.
        onset_s: f64,
        /// Critical force of the predicted mode, micronewtons.
        critical_force_un: f64,
        /// Margin against the tip riding over, when the model computed it.
        ride_over_margin: Option<f64>,
        /// Predicted motion mode.
        mode: String,
        /// True when this push repeats one whose contact was lost.
        repush: bool,
        /// The particle radius the push was decided and made with,
        /// micrometres: the batch's measured size (absent in journals
        /// written before this field).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        radius_um: Option<f64>,
        /// How much further along the push the stroke was laid out than
        /// the particle was seen, nanometres: the shortfall of the push of
        /// it before, or less than none (back) by its overshoot
        /// (`exec::assemble`'s miss lead; absent when none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lead_nm: Option<f64>,
    },
    /// A nanostage move was commanded (nanostage coordinates).
    Move {
        /// Target, micrometres.
        target_um: [f64; 3],
        /// Speed, micrometres per second.
        speed_um_s: f64,
    },
    /// A coarse-stage move was commanded.
    CoarseMove {
        /// New offset of the nanostage origin on the sample, micrometres.
        offset_um: [f64; 2],
    },
    /// The move journalled before waited for the operator's answer (the
    /// confirmation before real hardware's first move): seconds of rig
    /// time that are no work of the rig's, left out of the report's time.
    OperatorWait {
        /// Seconds waited.
        waited_s: f64,
    },
    /// A move failed; the stage was halted.
    MoveFailed {
        /// What the rig said.
        error: String,
    },
    /// The result of a push as the camera saw it.
    Check {
        /// Track id.
        particle: usize,
        /// placed, fell-short, left-line, overshot, unseen.
        result: String,
        /// Distance to the wanted position, nanometres.
        error_nm: f64,
        /// True when the tip lost the particle.
        lost_contact: bool,
    },
    /// A particle failed too often and is planned around from now on.
    GiveUp {
        /// Track id.
        particle: usize,
        /// Failed pushes.
        tries: u32,
    },
    /// The particle just given up on lies within `left_short_m` of a site
    /// no other particle fills: the site counts as filled, short.
    LeftShort {
        /// Index of the site in the run's sites (as in the report's table).
        site: usize,
        /// Track id.
        particle: usize,
        /// Its distance from the site, nanometres.
        error_nm: f64,
    },
    /// Every site is filled within tolerance, or short by a particle left
    /// alone near it (`LeftShort`).
    Done,
    /// The run stopped before it was done.
    Stopped {
        /// Why.
        reason: String,
        /// What the stop means for going on with the run (a calibration
        /// that does not fit is not to be resumed); absent in journals from
        /// before 2026-11-30, whose `reason` tells
        /// ([`StopCause::journalled`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cause: Option<StopCause>,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A decision says its lead only when the push had one, and reads it
    /// back; one from before the field reads as none.
    #[test]
    fn a_decision_keeps_its_lead() {
        let decision = |lead_nm| RunEvent::Decision {
            particle: 3,
            from_um: [1.0, 2.0],
            to_um: [1.0, 2.2],
            contact_angle_deg: 70.0,
            duration_s: 0.8,
            onset_s: 0.6,
            critical_force_un: 2.3,
            ride_over_margin: None,
            mode: "rolling".into(),
            repush: true,
            radius_um: Some(5.0),
            lead_nm,
        };
        for lead in [Some(215.0), Some(-180.0), None] {
            let text = serde_json::to_string(&decision(lead)).unwrap();
            assert_eq!(text.contains("lead_nm"), lead.is_some(), "{text}");
            let back: RunEvent = serde_json::from_str(&text).unwrap();
            assert_eq!(back, decision(lead));
        }
    }

    /// A run spec says `drift_off` (and `keep_clear_um`) only when the drift
    /// is not followed (strays are kept clear), reads it back, and a spec
    /// from before the fields reads as followed (none kept).
    #[test]
    fn a_run_spec_keeps_whether_the_drift_is_followed() {
        let spec = RunSpec {
            pattern: "I".into(),
            scene: "scene.toml".into(),
            layout: None,
            seed: Some(1),
            sites_um: vec![[1.0, 2.0]],
            radius_um: 5.0,
            rig: None,
            drift_off: true,
            keep_clear_um: 2.5,
            command: Some(this_command()),
            scene_crc32: None,
        };
        let text = serde_json::to_string(&spec).unwrap();
        assert!(text.contains(r#""drift_off":true"#), "{text}");
        assert!(text.contains(r#""keep_clear_um":2.5"#), "{text}");
        assert_eq!(serde_json::from_str::<RunSpec>(&text).unwrap(), spec);
        let followed = RunSpec {
            drift_off: false,
            keep_clear_um: 0.0,
            ..spec
        };
        let older = serde_json::to_string(&followed).unwrap();
        assert!(!older.contains("drift_off"), "{older}");
        assert!(!older.contains("keep_clear"), "{older}");
        assert_eq!(serde_json::from_str::<RunSpec>(&older).unwrap(), followed);
    }

    /// A hardware rig's run has no seed: its start entry says none and
    /// reads back without one, and a rig journal from before (`"seed":1`)
    /// still reads; a simulated run's seed is kept.
    #[test]
    fn a_rig_runs_start_entry_has_no_seed() {
        let older = r#"{"pattern":"L","scene":"s.toml","layout":null,"seed":1,"sites_um":[[1.0,2.0]],"radius_um":5.0,"rig":{"rig_file":"rig.toml","field_um":[100.0,100.0]}}"#;
        let read = serde_json::from_str::<RunSpec>(older).unwrap();
        assert_eq!(read.seed, Some(1));
        let rig = RunSpec { seed: None, ..read };
        let text = serde_json::to_string(&rig).unwrap();
        assert!(!text.contains("seed"), "{text}");
        assert_eq!(serde_json::from_str::<RunSpec>(&text).unwrap(), rig);
        let simulated = RunSpec {
            seed: Some(7),
            rig: None,
            ..rig
        };
        let text = serde_json::to_string(&simulated).unwrap();
        assert!(text.contains(r#""seed":7"#), "{text}");
        assert_eq!(serde_json::from_str::<RunSpec>(&text).unwrap(), simulated);
    }

    /// A resume that follows the drift and a stop's cause are journalled
    /// and read back; the lines older journals hold read as a plain resume
    /// and a stop without a cause, and a plain resume is written as before.
    #[test]
    fn resumes_and_stops_read_back_old_and_new() {
        let plain = RunEvent::Resume {
            drift_follow: false,
        };
        assert_eq!(
            serde_json::to_string(&plain).unwrap(),
            r#"{"kind":"resume"}"#
        );
        let old: RunEvent = serde_json::from_str(r#"{"kind":"resume"}"#).unwrap();
        assert_eq!(old, plain);
        let followed = RunEvent::Resume { drift_follow: true };
        let text = serde_json::to_string(&followed).unwrap();
        assert_eq!(text, r#"{"kind":"resume","drift_follow":true}"#);
        assert_eq!(serde_json::from_str::<RunEvent>(&text).unwrap(), followed);
        let old: RunEvent = serde_json::from_str(r#"{"kind":"stopped","reason":"x"}"#).unwrap();
        assert_eq!(
            old,
            RunEvent::Stopped {
                reason: "x".into(),
                cause: None
            }
        );
        let stop = RunEvent::Stopped {
            reason: "x".into(),
            cause: Some(StopCause::CalibrationUnfit),
        };
        let text = serde_json::to_string(&stop).unwrap();
        assert!(text.contains(r#""cause":"calibration_unfit""#), "{text}");
        assert_eq!(serde_json::from_str::<RunEvent>(&text).unwrap(), stop);
    }

    /// A scene file edited between a stop and the resume is noticed; the
    /// same file, or a journal without the CRC, is not.
    #[test]
    fn a_scene_edited_since_the_start_is_noticed() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.toml");
        std::fs::write(&scene, "name = \"a\"\n").unwrap();
        let path = scene.display().to_string();
        let spec = RunSpec {
            pattern: "I".into(),
            scene: path.clone(),
            layout: None,
            seed: Some(1),
            sites_um: Vec::new(),
            radius_um: 5.0,
            rig: None,
            drift_off: false,
            keep_clear_um: 0.0,
            command: None,
            scene_crc32: scene_file_crc(&path),
        };
        assert!(!spec.scene_changed());
        std::fs::write(&scene, "name = \"b\"\n").unwrap();
        assert!(spec.scene_changed());
        let older = RunSpec {
            scene_crc32: None,
            ..spec
        };
        assert!(!older.scene_changed());
    }
}
