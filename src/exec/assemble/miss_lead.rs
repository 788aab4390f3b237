//! A push that moved its particle less than half its length leads the
//! next push of the same particle by the shortfall: the tip stood about
//! that much behind where the loop put it along the push (the drift
//! estimate lagging the drift, the apex unseen near particles), and a
//! push again as short would touch nothing again. Under 5 nm/s of drift,
//! CMU seed 20 along 225 deg pushed a particle 0.12 um three times, each
//! moving it about 20 nm, gave it up and stopped the run: it covered a
//! site. A long push that falls short says nothing of the tip: the
//! particle may have rolled away from it (leading the re-push of 5 nm/s
//! seed 32 along y by its whole 0.2 um shortfall overshot by as much).
//!
//! Likewise a push that overshot by more than half its length leads the
//! next push of the particle back by the excess: the particle slid on after
//! the tip stopped (a sphere larger than the size it was planned with, met
//! higher on its side than the contact angle asked), and the push back
//! would overshoot as much again. A 4.2 um sphere of a polydisperse batch,
//! never seen clear of its neighbours, was pushed to and fro 355 times by
//! 0.2-0.3 um. Only where the drift is followed (see `Assembly::check`).

use crate::exec::push_check::{PushFrame, push_frame};

/// The lead the next push of one particle takes: its stroke laid out as if
/// the particle stood this much further along the push (less, when
/// negative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct MissLead {
    /// Track id of the particle.
    pub(super) particle: usize,
    /// How much further along the push the stroke is laid out, metres.
    pub(super) lead_m: f64,
}

/// The lead after a push of `particle` from `from` to `to`, made with a
/// lead of `used_m`, left it `seen`: when it moved the particle less than
/// half the push along its line, the lead plus what it fell short of, at
/// most `max_m`; None otherwise.
pub(super) fn lead_after(
    particle: usize,
    (from, to): ([f64; 2], [f64; 2]),
    seen: [f64; 2],
    used_m: f64,
    max_m: f64,
) -> Option<MissLead> {
    let PushFrame { length, along, .. } = push_frame(from, to, seen)?;
    (along < 0.5 * length).then(|| MissLead {
        particle,
        lead_m: (used_m + length - along).min(max_m),
    })
}

/// The lead after a push of `particle` from `from` to `to`, made with a
/// lead of `used_m`, overshot by `excess_m`: when the excess is more than
/// half the push, the lead less the excess, at most `max_m` back; None
/// otherwise (a long push that overshoots a little says nothing of the
/// particle).
pub(super) fn lead_back_after(
    particle: usize,
    (from, to): ([f64; 2], [f64; 2]),
    excess_m: f64,
    used_m: f64,
    max_m: f64,
) -> Option<MissLead> {
    let length = (to[0] - from[0]).hypot(to[1] - from[1]);
    (excess_m > 0.5 * length).then(|| MissLead {
        particle,
        lead_m: (used_m - excess_m).max(-max_m),
    })
}

/// `from` and `to` moved `lead_m` further along the push from one to the
/// other (back when negative): where the stroke is laid out for.
pub(super) fn led(from: [f64; 2], to: [f64; 2], lead_m: f64) -> ([f64; 2], [f64; 2]) {
    let d = [to[0] - from[0], to[1] - from[1]];
    let length = d[0].hypot(d[1]);
    if length <= 0.0 || !length.is_finite() || lead_m == 0.0 || !lead_m.is_finite() {
        return (from, to);
    }
    let shift = [d[0] / length * lead_m, d[1] / length * lead_m];
    (
        [from[0] + shift[0], from[1] + shift[1]],
        [to[0] + shift[0], to[1] + shift[1]],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const UM: f64 = 1e-6;

    #[test]
    fn a_push_that_moved_a_fifth_of_its_length_leads_the_next_by_the_rest() {
        let lead = lead_after(
            7,
            ([0.0, 0.0], [0.1 * UM, 0.0]),
            [0.02 * UM, 0.003 * UM],
            0.0,
            0.25 * UM,
        )
        .expect("it fell short");
        assert_eq!(lead.particle, 7);
        assert!((lead.lead_m - 0.08 * UM).abs() < 1e-12, "{}", lead.lead_m);
    }

    #[test]
    fn leads_add_up_to_the_cap() {
        let push = ([0.0, 0.0], [0.0, 0.2 * UM]);
        let lead = lead_after(1, push, [0.0, 0.05 * UM], 0.1 * UM, 0.5 * UM).unwrap();
        assert!((lead.lead_m - 0.25 * UM).abs() < 1e-12);
        let capped = lead_after(1, push, [0.0, 0.0], 0.2 * UM, 0.25 * UM).unwrap();
        assert!((capped.lead_m - 0.25 * UM).abs() < 1e-12);
    }

    #[test]
    fn a_push_that_moved_half_its_length_or_more_leads_nothing() {
        // 10 um asked, 9.8 um moved: the particle may have rolled away.
        let long = ([0.0, 0.0], [10.0 * UM, 0.0]);
        assert_eq!(lead_after(1, long, [9.8 * UM, 0.0], 0.0, 0.25 * UM), None);
        let short = ([0.0, 0.0], [0.2 * UM, 0.0]);
        assert_eq!(lead_after(1, short, [0.11 * UM, 0.0], 0.0, 0.25 * UM), None);
        assert_eq!(
            lead_after(1, short, [0.3 * UM, 0.0], 0.1 * UM, 0.25 * UM),
            None
        );
        let none = ([1.0, 1.0], [1.0, 1.0]);
        assert_eq!(lead_after(1, none, [0.0, 0.0], 0.0, 0.25 * UM), None);
    }

    #[test]
    fn a_short_push_that_overshot_by_more_than_half_leads_the_next_back() {
        // 0.2 um asked, 0.3 um too far (the 4.2 um sphere taken for 4.0).
        let short = ([0.0, 0.0], [0.2 * UM, 0.0]);
        let back = lead_back_after(4, short, 0.3 * UM, 0.0, 0.25 * UM).expect("it overshot");
        assert_eq!(back.particle, 4);
        assert!(
            (back.lead_m + 0.25 * UM).abs() < 1e-12,
            "capped: {}",
            back.lead_m
        );
        let back = lead_back_after(4, short, 0.15 * UM, -0.05 * UM, 0.25 * UM).unwrap();
        assert!((back.lead_m + 0.2 * UM).abs() < 1e-12, "{}", back.lead_m);
        // A lead forward that overshot is taken back first.
        let back = lead_back_after(4, short, 0.12 * UM, 0.1 * UM, 0.25 * UM).unwrap();
        assert!((back.lead_m + 0.02 * UM).abs() < 1e-12, "{}", back.lead_m);
    }

    #[test]
    fn a_push_that_overshot_by_half_its_length_or_less_leads_nothing_back() {
        let long = ([0.0, 0.0], [10.0 * UM, 0.0]);
        assert_eq!(lead_back_after(1, long, 0.3 * UM, 0.0, 0.25 * UM), None);
        let short = ([0.0, 0.0], [0.2 * UM, 0.0]);
        assert_eq!(lead_back_after(1, short, 0.1 * UM, 0.0, 0.25 * UM), None);
    }

    #[test]
    fn a_lead_back_moves_both_ends_back_along_the_push() {
        let (from, to) = led([1.0 * UM, 1.0 * UM], [1.0 * UM, 3.0 * UM], -0.1 * UM);
        assert!((from[0] - 1.0 * UM).abs() < 1e-15 && (from[1] - 0.9 * UM).abs() < 1e-15);
        assert!((to[0] - 1.0 * UM).abs() < 1e-15 && (to[1] - 2.9 * UM).abs() < 1e-15);
        let push = ([0.0, 0.0], [0.0, 1.0 * UM]);
        assert_eq!(led(push.0, push.1, f64::NAN), push);
    }

    #[test]
    fn a_lead_moves_both_ends_along_the_push() {
        let (from, to) = led([1.0 * UM, 1.0 * UM], [1.0 * UM, 3.0 * UM], 0.1 * UM);
        assert!((from[0] - 1.0 * UM).abs() < 1e-15 && (from[1] - 1.1 * UM).abs() < 1e-15);
        assert!((to[0] - 1.0 * UM).abs() < 1e-15 && (to[1] - 3.1 * UM).abs() < 1e-15);
        assert_eq!(
            led([0.0, 0.0], [0.0, 0.0], 0.1 * UM),
            ([0.0, 0.0], [0.0, 0.0])
        );
    }
}
