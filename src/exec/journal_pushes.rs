//! The pushes of a journal, each with the check that followed it: for the
//! report's counts and its list of pushes ([`super::push_log`]).
//!
//! A `decision` entry is written before the tip moves. A push is made when
//! its check came (and does not say the model refused it), or, with no
//! check (the run stopped, or the stage faulted, during it), when the tip
//! went down on it: a move slower than the travel before it was journalled.
//! A push cut off before that is not made: a resumed run decides it again,
//! and it had been counted twice.

use super::events::RunEvent;
use super::journal::Entry;

/// Where a push's end counts as its site (the planner ends a particle's
/// last push on the site's centre).
const ON_SITE_UM: f64 = 0.01;

/// One push as the journal has it, for plots and tables.
#[derive(Debug, Clone, PartialEq)]
pub struct JournalPush {
    /// Rig time of the decision, seconds.
    pub t_s: f64,
    /// Track id.
    pub particle: usize,
    /// Contact angle, degrees.
    pub contact_angle_deg: f64,
    /// Push duration after first touch, seconds.
    pub duration_s: f64,
    /// Push distance, micrometres.
    pub distance_um: f64,
    /// True for a re-push after a lost contact.
    pub repush: bool,
    /// The check that followed, if any ("placed", "fell-short", ...).
    pub result: Option<String>,
    /// The site (index into the run's sites) the push ends on; None for a
    /// leg of a bent route, or a push out of the way.
    pub to_site: Option<usize>,
    /// The tip went down on the particle: a move after the decision slower
    /// than the first (the travel to it).
    pub stroked: bool,
    /// Which part of the run: 0 before any resume, k after the k-th (track
    /// ids start again at each resume).
    pub part: usize,
}

impl JournalPush {
    /// True when the push was made (module doc).
    pub fn made(&self) -> bool {
        match self.result.as_deref() {
            Some(r) => !r.starts_with("refused"),
            None => self.stroked,
        }
    }
}

/// The pushes of a journal, each with the check that followed it and the
/// site it ends on (the sites of the journal's start entry).
pub fn journal_pushes(entries: &[Entry<RunEvent>]) -> Vec<JournalPush> {
    let mut sites_um: &[[f64; 2]] = &[];
    let mut out: Vec<JournalPush> = Vec::new();
    // The speed of the first move after the last decision.
    let mut travel_um_s: Option<f64> = None;
    let mut part = 0;
    for e in entries {
        match &e.event {
            RunEvent::Start(spec) => sites_um = &spec.sites_um,
            RunEvent::Resume { .. } => part += 1,
            RunEvent::Move { speed_um_s, .. } => {
                let travel = *travel_um_s.get_or_insert(*speed_um_s);
                if let Some(last) = out.last_mut().filter(|p| p.result.is_none()) {
                    last.stroked |= *speed_um_s < travel;
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
                out.push(JournalPush {
                    t_s: e.t_s,
                    particle: *particle,
                    contact_angle_deg: *contact_angle_deg,
                    duration_s: *duration_s,
                    distance_um: (to_um[0] - from_um[0]).hypot(to_um[1] - from_um[1]),
                    repush: *repush,
                    result: None,
                    to_site: sites_um
                        .iter()
                        .position(|s| (s[0] - to_um[0]).hypot(s[1] - to_um[1]) <= ON_SITE_UM),
                    stroked: false,
                    part,
                });
            }
            RunEvent::Check {
                particle, result, ..
            } => {
                if let Some(last) = out
                    .last_mut()
                    .filter(|p| p.particle == *particle && p.result.is_none())
                {
                    last.result = Some(result.clone());
                }
            }
            _ => {}
        }
    }
    out
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
    fn pushes_are_paired_with_the_check_that_followed() {
        let spec = RunSpec {
            pattern: "I".into(),
            scene: "s.toml".into(),
            layout: None,
            seed: 1,
            sites_um: vec![[9.0, 9.0], [3.0, 4.0]],
            radius_um: 5.0,
            rig: None,
            drift_off: false,
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
        let p = journal_pushes(&entries);
        assert_eq!(p.len(), 5);
        assert_eq!(p[0].result.as_deref(), Some("fell-short"));
        assert!(p[1].repush && p[1].result.as_deref() == Some("placed"));
        assert_eq!(p[3].result, None);
        assert!((p[0].distance_um - 5.0).abs() < 1e-12);
        assert_eq!(p[0].to_site, Some(1));
        let made: Vec<bool> = p.iter().map(JournalPush::made).collect();
        // Made: checked and not refused by the model, or, cut off by the
        // stop, stroked (a move slower than the travel to it).
        assert_eq!(made, [true, true, false, false, true]);
        assert!(p[3].result.is_none() && !p[3].stroked);
        assert!(p[4].result.is_none() && p[4].stroked);
        assert_eq!(p[4].part, 0);
        // After the resume, the part names the track.
        let mut resumed = entries.clone();
        resumed.push(e(14, 31.0, decision(9, false)));
        assert_eq!(journal_pushes(&resumed)[5].part, 1);
    }
}
