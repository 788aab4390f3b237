//! Did the push work? Compares where the camera sees the particle after a push
//! with where it was meant to go, in the push's own frame (along and across
//! the push line), and names what happened. This is how lost contact is
//! detected from images alone: a particle that did not follow the tip either
//! stayed short on the line (the tip rode over it) or left the line sideways
//! (it turned around the tip).

/// Tolerances of the check, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckTolerances {
    /// A particle this close to its target is placed.
    pub placed_m: f64,
    /// A particle this far off the push line left it.
    pub off_line_m: f64,
}

/// What the camera shows after a push.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PushCheck {
    /// At its target within tolerance.
    Placed { error_m: f64 },
    /// Within tolerance of its target but moved less than half the push: a
    /// push shorter than the tolerance that did nothing. Harmless when the
    /// rest of the plan still holds; the loop counts it as a failure when it
    /// does not (a fresh plan would ask for the same push again).
    Unmoved { error_m: f64 },
    /// On the line but short of its target: contact was lost (or never made).
    FellShort { missing_m: f64 },
    /// Left the push line sideways: it turned around the tip.
    LeftLine { off_line_m: f64 },
    /// On the line, past its target.
    Overshot { excess_m: f64 },
}

impl PushCheck {
    /// True when the push is done with: its step leaves the plan in hand
    /// (placed, or a push under the tolerance that did nothing).
    pub fn completes_step(&self) -> bool {
        matches!(self, PushCheck::Placed { .. } | PushCheck::Unmoved { .. })
    }

    /// True for the outcomes that mean the tip lost the particle.
    pub fn lost_contact(&self) -> bool {
        matches!(
            self,
            PushCheck::FellShort { .. } | PushCheck::LeftLine { .. }
        )
    }
}

/// Pushes shorter than this are not asked to show movement: two positions
/// measured 20-30 nm apart by the camera cannot tell half of it from none.
const SMALLEST_CHECKED_MOVE_M: f64 = 50e-9;

/// Where a particle was seen after a push, in the push's own frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushFrame {
    /// Length of the push asked, metres.
    pub length: f64,
    /// How far the particle moved along the push line, metres.
    pub along: f64,
    /// How far it lies off the push line, metres.
    pub across: f64,
}

/// `seen` in the frame of the push from `from` to `to`; None when the two
/// coincide (or are not finite): no push line.
pub fn push_frame(from: [f64; 2], to: [f64; 2], seen: [f64; 2]) -> Option<PushFrame> {
    let d = [to[0] - from[0], to[1] - from[1]];
    let length = d[0].hypot(d[1]);
    if length <= 0.0 || !length.is_finite() {
        return None;
    }
    let u = [d[0] / length, d[1] / length];
    let w = [seen[0] - from[0], seen[1] - from[1]];
    Some(PushFrame {
        length,
        along: w[0] * u[0] + w[1] * u[1],
        across: (u[0] * w[1] - u[1] * w[0]).abs(),
    })
}

/// Classifies the observed end position of a push from `from` to `to`.
///
/// Within `placed_m` of `to` is placed when the particle moved at least half
/// the push along its line (or the push is shorter than
/// `SMALLEST_CHECKED_MOVE_M`), else unmoved: a push shorter than the
/// tolerance passes the distance test with the particle where it started
/// (a 0.12 um first leg of a bent route that never moved its particle
/// passed as placed 91 times in a row under drift, each fresh plan asking
/// for it again).
pub fn check_push(
    from: [f64; 2],
    to: [f64; 2],
    seen: [f64; 2],
    tol: &CheckTolerances,
) -> PushCheck {
    let error_m = (seen[0] - to[0]).hypot(seen[1] - to[1]);
    let Some(PushFrame {
        length,
        along,
        across,
    }) = push_frame(from, to, seen)
    else {
        return if error_m <= tol.placed_m {
            PushCheck::Placed { error_m }
        } else {
            PushCheck::LeftLine {
                off_line_m: error_m,
            }
        };
    };
    let moved_enough = length <= SMALLEST_CHECKED_MOVE_M || along >= 0.5 * length;
    if error_m <= tol.placed_m {
        return if moved_enough {
            PushCheck::Placed { error_m }
        } else {
            PushCheck::Unmoved { error_m }
        };
    }
    if across > tol.off_line_m {
        PushCheck::LeftLine { off_line_m: across }
    } else if along < length {
        PushCheck::FellShort {
            missing_m: length - along,
        }
    } else {
        PushCheck::Overshot {
            excess_m: along - length,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOL: CheckTolerances = CheckTolerances {
        placed_m: 0.1e-6,
        off_line_m: 1e-6,
    };
    /// The loop's default placed tolerance.
    const TOL_WIDE: CheckTolerances = CheckTolerances {
        placed_m: 0.2e-6,
        off_line_m: 1.5e-6,
    };
    const FROM: [f64; 2] = [0.0, 0.0];
    const TO: [f64; 2] = [20e-6, 0.0];

    #[test]
    fn a_particle_at_its_target_is_placed() {
        let c = check_push(FROM, TO, [20.05e-6, 0.03e-6], &TOL);
        assert!(matches!(c, PushCheck::Placed { error_m } if error_m < 0.1e-6));
        assert!(!c.lost_contact());
    }

    #[test]
    fn a_particle_left_behind_on_the_line_fell_short() {
        let c = check_push(FROM, TO, [3e-6, 0.2e-6], &TOL);
        assert!(
            matches!(c, PushCheck::FellShort { missing_m } if (missing_m - 17e-6).abs() < 1e-12)
        );
        assert!(c.lost_contact());
    }

    #[test]
    fn a_particle_beside_the_line_turned_around_the_tip() {
        let c = check_push(FROM, TO, [12e-6, 6e-6], &TOL);
        assert!(
            matches!(c, PushCheck::LeftLine { off_line_m } if (off_line_m - 6e-6).abs() < 1e-12)
        );
        assert!(c.lost_contact());
    }

    #[test]
    fn a_short_push_that_did_not_move_its_particle_is_unmoved() {
        // 0.12 um asked, within the 0.2 um tolerance of its target where it
        // started, and it did not move: not placed.
        let to = [0.12e-6, 0.0];
        let c = check_push(FROM, to, [0.01e-6, 0.0], &TOL_WIDE);
        assert!(
            matches!(c, PushCheck::Unmoved { error_m } if (error_m - 0.11e-6).abs() < 1e-12),
            "{c:?}"
        );
        assert!(!c.lost_contact());
        // Out of tolerance it fell short, as any push.
        let c = check_push(FROM, [0.3e-6, 0.0], [0.01e-6, 0.0], &TOL_WIDE);
        assert!(matches!(c, PushCheck::FellShort { .. }), "{c:?}");
        // Moved most of the way: placed.
        let c = check_push(FROM, to, [0.09e-6, 0.01e-6], &TOL_WIDE);
        assert!(matches!(c, PushCheck::Placed { .. }), "{c:?}");
        // Too short to tell movement from camera noise: placed where it is.
        let c = check_push(FROM, [0.04e-6, 0.0], [0.0, 0.0], &TOL_WIDE);
        assert!(matches!(c, PushCheck::Placed { .. }), "{c:?}");
    }

    #[test]
    fn a_particle_past_its_target_overshot_without_losing_contact() {
        let c = check_push(FROM, TO, [20.5e-6, 0.0], &TOL);
        assert!(matches!(c, PushCheck::Overshot { excess_m } if (excess_m - 0.5e-6).abs() < 1e-12));
        assert!(!c.lost_contact());
    }
}
