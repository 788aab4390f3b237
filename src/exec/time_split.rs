//! Where a run's time went: pushing, lifted travel, and the rest, so that a
//! time above the lower bound says which part of it is above its own part
//! of the bound (the ratio alone had not).
//!
//! The moves are timed as commanded: each journalled move's distance from
//! the move before at its speed. The clock between journal entries would
//! count a hardware rig's frame waits and settling in the move before them;
//! on the simulated rig the two agree within a few per cent (CMU seed 5:
//! 269.4 s pushing both ways, 38.3 s travel against 40.4 s by the clock,
//! the difference the z moves' and coarse moves' settling).

use super::events::RunEvent;
use super::journal::Entry;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Seconds of a run (or of its lower bound) by what the stage did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TimeSplit {
    /// Moves at any speed but the travel speed: the tip down, pushing
    /// (its approach to the particle included).
    pub pushing_s: f64,
    /// Moves at the travel speed: the tip lifted between pushes, lowered
    /// and raised, and brought to the particle's slow approach.
    pub travel_s: f64,
    /// The rest: coarse moves, settling, frames and planning (none in a
    /// lower bound).
    pub other_s: f64,
}

impl TimeSplit {
    /// The journal's moves timed as commanded, and the rest of `time_s`.
    /// A move after a resume starts from where the stage was found, which
    /// the journal does not hold: it is counted in the rest.
    pub fn of_run(entries: &[Entry<RunEvent>], travel_speed_um_s: f64, time_s: f64) -> Self {
        let mut split = TimeSplit::default();
        let mut at: Option<[f64; 3]> = None;
        for entry in entries {
            match &entry.event {
                RunEvent::Move {
                    target_um,
                    speed_um_s,
                } => {
                    if let Some(from) = at.filter(|_| *speed_um_s > 0.0) {
                        let s =
                            (Vector3::from(*target_um) - Vector3::from(from)).norm() / speed_um_s;
                        if (speed_um_s - travel_speed_um_s).abs() <= 1e-9 * travel_speed_um_s {
                            split.travel_s += s;
                        } else {
                            split.pushing_s += s;
                        }
                    }
                    at = Some(*target_um);
                }
                RunEvent::Resume { .. } => at = None,
                _ => {}
            }
        }
        split.other_s = (time_s - split.pushing_s - split.travel_s).max(0.0);
        split
    }

    /// "269 s pushing (bound 207 s), 38 s lifted (bound 20 s), 2 s else",
    /// the bound's parts left out when `bound` is None; None for a run
    /// that made no move (a report written before the split).
    pub fn said(&self, bound: Option<&TimeSplit>) -> Option<String> {
        if self.pushing_s + self.travel_s <= 0.0 {
            return None;
        }
        let part = |s: f64, what: &str, b: Option<f64>| match b {
            Some(b) => format!("{s:.0} s {what} (bound {b:.0} s)"),
            None => format!("{s:.0} s {what}"),
        };
        Some(format!(
            "{}, {}, {:.0} s else (coarse moves, settling, frames, planning)",
            part(self.pushing_s, "pushing", bound.map(|b| b.pushing_s)),
            part(self.travel_s, "lifted", bound.map(|b| b.travel_s)),
            self.other_s
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moved(t_s: f64, target_um: [f64; 3], speed_um_s: f64) -> Entry<RunEvent> {
        let event = RunEvent::Move {
            target_um,
            speed_um_s,
        };
        Entry { seq: 0, t_s, event }
    }

    /// Each move timed at its own speed from the one before; the first,
    /// and the first after a resume, from nowhere known.
    #[test]
    fn moves_are_timed_at_their_speeds_and_the_rest_is_else() {
        let resume = Entry {
            seq: 0,
            t_s: 30.0,
            event: RunEvent::Resume {
                drift_follow: false,
            },
        };
        let entries = [
            moved(0.0, [0.0, 0.0, 12.0], 50.0),
            moved(0.1, [30.0, 40.0, 12.0], 50.0),
            moved(1.2, [30.0, 40.0, 7.0], 50.0),
            moved(1.4, [40.0, 40.0, 7.0], 1.0),
            moved(11.5, [40.0, 40.0, 12.0], 50.0),
            resume,
            moved(31.0, [90.0, 40.0, 12.0], 50.0),
            moved(32.0, [90.0, 40.0, 7.0], 50.0),
            moved(32.2, [90.0, 44.0, 7.0], 2.0),
        ];
        let split = TimeSplit::of_run(&entries, 50.0, 40.0);
        // 50 um + 5 + 5 + 5 at 50 um/s; 10 um at 1 and 4 um at 2 um/s.
        assert!((split.travel_s - 1.3).abs() < 1e-12, "{split:?}");
        assert!((split.pushing_s - 12.0).abs() < 1e-12, "{split:?}");
        assert!((split.other_s - 26.7).abs() < 1e-12, "{split:?}");
        let bound = TimeSplit {
            pushing_s: 10.0,
            travel_s: 1.0,
            other_s: 0.0,
        };
        assert_eq!(
            split.said(Some(&bound)).as_deref(),
            Some(
                "12 s pushing (bound 10 s), 1 s lifted (bound 1 s), 27 s else (coarse moves, settling, frames, planning)"
            )
        );
        assert_eq!(TimeSplit::default().said(None), None);
        let text = serde_json::to_string(&split).unwrap();
        assert_eq!(serde_json::from_str::<TimeSplit>(&text).unwrap(), split);
    }
}
