//! The report's list of pushes, read off the journal: one row a push
//! decided, each with the check that followed it, those made numbered in
//! order. Why: `report.json` ("this report, machine-readable") gave only
//! counts, so a user plotting error against push distance had to read the
//! journal; and report.md numbered the pushes not made too, so its last
//! row read 38 where the report counted 37 pushes.
//!
//! A `decision` entry is written before the tip moves. A push is made when
//! its check came (and does not say the model refused it), or, with no
//! check (the run stopped, or the stage faulted, during it), when the tip
//! went down on it: a move slower than the travel before it was journalled.
//! A push cut off before that is not made: a resumed run decides it again,
//! and it had been counted twice.

use super::events::RunEvent;
use super::journal::Entry;
use serde::{Deserialize, Serialize};

/// Where a push's end counts as its site (the planner ends a particle's
/// last push on the site's centre).
const ON_SITE_UM: f64 = 0.01;

/// One push as the report lists it (report.md's table, the force charts'
/// legends and `report.json`'s `push_log`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PushRecord {
    /// Its number among the pushes made (1 first); null for one not made.
    pub n: Option<usize>,
    /// Rig time of the decision, seconds.
    pub t_s: f64,
    /// Track id of the particle (ids start again at each resume: `part`).
    pub particle: usize,
    /// Which part of the run: 0 before any resume, k after the k-th.
    pub part: usize,
    /// The site (index into the run's sites) the push ends on; null for a
    /// leg of a bent route or a push out of the way.
    pub to_site: Option<usize>,
    /// Push distance, micrometres.
    pub distance_um: f64,
    /// Contact angle, degrees.
    pub contact_angle_deg: f64,
    /// Push duration after first touch, seconds.
    pub duration_s: f64,
    /// A re-push after a lost contact.
    pub repush: bool,
    /// The check's result ("placed", "fell-short", ...), or why there is none.
    pub result: String,
}

impl PushRecord {
    /// The particle as the report names it: its track id, after a resume
    /// with the part ("r1:18").
    pub fn particle_label(&self) -> String {
        match self.part {
            0 => self.particle.to_string(),
            k => format!("r{k}:{}", self.particle),
        }
    }
}

/// What the journal has said of a push so far.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Heard {
    /// Only its decision.
    Decided,
    /// The tip went down on the particle: a move after the decision slower
    /// than the first (the travel to it).
    Stroked,
    /// Its check.
    Checked,
}

/// The journal's pushes as the report lists them, those made numbered,
/// each with the site it ends on (the sites of the journal's start entry).
pub fn push_log(entries: &[Entry<RunEvent>]) -> Vec<PushRecord> {
    let mut sites_um: &[[f64; 2]] = &[];
    let mut heard: Vec<(PushRecord, Heard)> = Vec::new();
    // The speed of the first move after the last decision.
    let mut travel_um_s: Option<f64> = None;
    let mut part = 0;
    for e in entries {
        match &e.event {
            RunEvent::Start(spec) => sites_um = &spec.sites_um,
            RunEvent::Resume { .. } => part += 1,
            RunEvent::Move { speed_um_s, .. } => {
                let travel = *travel_um_s.get_or_insert(*speed_um_s);
                if let Some((_, h)) = heard.last_mut().filter(|(_, h)| *h != Heard::Checked)
                    && *speed_um_s < travel
                {
                    *h = Heard::Stroked;
                }
            }
            RunEvent::Decision {
                particle,
                from_um,
                to_um,
                contact_angle_deg,
                duration_s,
                repush,
                ..
            } => {
                travel_um_s = None;
                let record = PushRecord {
                    n: None,
                    t_s: e.t_s,
                    particle: *particle,
                    part,
                    to_site: sites_um
                        .iter()
                        .position(|s| (s[0] - to_um[0]).hypot(s[1] - to_um[1]) <= ON_SITE_UM),
                    distance_um: (to_um[0] - from_um[0]).hypot(to_um[1] - from_um[1]),
                    contact_angle_deg: *contact_angle_deg,
                    duration_s: *duration_s,
                    repush: *repush,
                    result: String::new(),
                };
                heard.push((record, Heard::Decided));
            }
            RunEvent::Check {
                particle, result, ..
            } => {
                if let Some((r, h)) = heard
                    .last_mut()
                    .filter(|(r, h)| r.particle == *particle && *h != Heard::Checked)
                {
                    r.result = result.clone();
                    *h = Heard::Checked;
                }
            }
            _ => {}
        }
    }
    let mut made = 0;
    heard
        .into_iter()
        .map(|(mut r, h)| {
            let was_made = match h {
                Heard::Checked => !r.result.starts_with("refused"),
                Heard::Stroked => true,
                Heard::Decided => false,
            };
            match h {
                Heard::Checked => {}
                Heard::Stroked => r.result = "not checked: the run stopped".to_owned(),
                Heard::Decided => r.result = "not made: the run stopped".to_owned(),
            }
            if was_made {
                made += 1;
                r.n = Some(made);
            }
            r
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::events::RunSpec;

    fn e(seq: u64, t_s: f64, event: RunEvent) -> Entry<RunEvent> {
        Entry { seq, t_s, event }
    }

    fn decision(particle: usize, repush: bool) -> RunEvent {
        RunEvent::Decision {
            particle,
            from_um: [0.0, 0.0],
            to_um: [3.0, 4.0],
            contact_angle_deg: 45.0,
            duration_s: 8.0,
            onset_s: 1.0,
            critical_force_un: 2.0,
            ride_over_margin: None,
            mode: "rolling".into(),
            repush,
            radius_um: None,
            lead_nm: None,
        }
    }

    fn travel(speed_um_s: f64) -> RunEvent {
        RunEvent::Move {
            target_um: [0.0, 0.0, 10.0],
            speed_um_s,
        }
    }

    fn check(particle: usize, result: &str) -> RunEvent {
        RunEvent::Check {
            particle,
            result: result.into(),
            error_nm: 10.0,
            lost_contact: result != "placed",
        }
    }

    #[test]
    fn pushes_are_paired_with_their_check_and_those_made_numbered() {
        let spec = RunSpec {
            pattern: "I".into(),
            scene: "s.toml".into(),
            layout: None,
            seed: Some(1),
            sites_um: vec![[9.0, 9.0], [3.0, 4.0]],
            radius_um: 5.0,
            rig: None,
            drift_off: false,
            keep_clear_um: 0.0,
            command: None,
            scene_crc32: None,
        };
        let entries = vec![
            e(0, 0.0, RunEvent::Start(spec)),
            e(1, 1.0, decision(4, false)),
            e(2, 9.0, check(4, "fell-short")),
            e(3, 10.0, decision(4, true)),
            e(4, 19.0, check(4, "placed")),
            e(5, 20.0, decision(7, false)),
            e(6, 21.0, check(7, "refused: too far")),
            e(7, 22.0, decision(8, false)),
            e(8, 22.0, travel(50.0)),
            e(9, 23.0, decision(9, false)),
            e(10, 23.0, travel(50.0)),
            e(11, 24.0, travel(50.0)),
            e(12, 25.0, travel(1.0)),
            e(
                13,
                30.0,
                RunEvent::Resume {
                    drift_follow: false,
                },
            ),
        ];
        let p = push_log(&entries);
        assert_eq!(p.len(), 5);
        assert_eq!(p[0].result, "fell-short");
        assert!(p[1].repush && p[1].result == "placed");
        assert!((p[0].distance_um - 5.0).abs() < 1e-12);
        assert_eq!(p[0].to_site, Some(1));
        // Made, numbered past the others: checked and not refused by the
        // model, or, cut off by the stop, stroked (a move slower than the
        // travel to it).
        let n: Vec<Option<usize>> = p.iter().map(|r| r.n).collect();
        assert_eq!(n, [Some(1), Some(2), None, None, Some(3)]);
        assert_eq!(p[2].result, "refused: too far");
        assert_eq!(p[3].result, "not made: the run stopped");
        assert_eq!(p[4].result, "not checked: the run stopped");
        assert_eq!((p[4].part, p[4].particle_label()), (0, "9".to_owned()));
        // After the resume, the part names the track.
        let mut resumed = entries.clone();
        resumed.push(e(14, 31.0, decision(9, false)));
        resumed.push(e(15, 32.0, check(9, "placed")));
        let r = &push_log(&resumed)[5];
        assert_eq!(
            (r.part, r.particle_label(), r.n),
            (1, "r1:9".to_owned(), Some(4))
        );
    }
}
