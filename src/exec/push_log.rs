//! The report's list of pushes: one row a push decided, those made
//! numbered in order. Why: `report.json` ("this report, machine-readable")
//! gave only counts, so a user plotting error against push distance had to
//! read the journal; and report.md numbered the pushes not made too, so its
//! last row read 38 where the report counted 37 pushes.

use super::journal_pushes::JournalPush;
use serde::{Deserialize, Serialize};

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

/// The journal's pushes as the report lists them, those made numbered.
pub fn push_log(pushes: &[JournalPush]) -> Vec<PushRecord> {
    let mut made = 0;
    pushes
        .iter()
        .map(|p| PushRecord {
            n: p.made().then(|| {
                made += 1;
                made
            }),
            t_s: p.t_s,
            particle: p.particle,
            part: p.part,
            to_site: p.to_site,
            distance_um: p.distance_um,
            contact_angle_deg: p.contact_angle_deg,
            duration_s: p.duration_s,
            repush: p.repush,
            result: match (p.result.as_deref(), p.stroked) {
                (Some(r), _) => r.to_owned(),
                (None, true) => "not checked: the run stopped".to_owned(),
                (None, false) => "not made: the run stopped".to_owned(),
            },
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn push(particle: usize, result: Option<&str>, stroked: bool, part: usize) -> JournalPush {
        JournalPush {
            t_s: 1.0,
            particle,
            contact_angle_deg: 45.0,
            duration_s: 8.0,
            distance_um: 5.0,
            repush: false,
            result: result.map(str::to_owned),
            to_site: None,
            stroked,
            part,
        }
    }

    /// Made pushes are numbered 1, 2, ... past those not made (refused by
    /// the model, or cut off before the tip went down), which say why.
    #[test]
    fn pushes_made_are_numbered_and_the_others_say_why_not() {
        let log = push_log(&[
            push(4, Some("fell-short"), true, 0),
            push(7, Some("refused: too far"), false, 0),
            push(8, None, false, 0),
            push(9, None, true, 0),
            push(9, Some("placed"), true, 1),
        ]);
        let n: Vec<Option<usize>> = log.iter().map(|r| r.n).collect();
        assert_eq!(n, [Some(1), None, None, Some(2), Some(3)]);
        assert_eq!(log[1].result, "refused: too far");
        assert_eq!(log[2].result, "not made: the run stopped");
        assert_eq!(log[3].result, "not checked: the run stopped");
        assert_eq!(log[3].particle_label(), "9");
        assert_eq!(log[4].particle_label(), "r1:9");
    }
}
