//! Where a push lowers the tip: behind its particle, and never farther
//! back than the plan in hand checked the tip may land (its tip disc plus
//! its standoff behind the contact point). A micron particle's plan checks
//! 0.2 um there, and the settings' 0.5 um clearance had lowered the tip
//! onto a neighbour (ground truth: `exec_particle_size`'s dense fields of
//! 1 um spheres).

use super::Assembly;

impl Assembly<'_> {
    /// How far behind the particle the plan in hand checked the tip may
    /// come down: its tip disc and its standoff.
    fn landing_room_m(&self) -> f64 {
        let standoff_m =
            (self.plan_in_hand.as_ref()).map_or(self.plan_config.standoff_m, |p| p.standoff_m);
        self.plan_config.tip_radius_m + standoff_m
    }

    /// Gap between the particle and the tip where the push being made
    /// lowers it ([`landing_gap_m`]).
    pub(super) fn landing_gap_m(&self) -> f64 {
        landing_gap_m(self.settings.clearance_m, self.landing_room_m())
    }

    /// A lead the stroke is shifted by, bounded by where it lowers the tip
    /// ([`lead_within_landing`]).
    pub(super) fn lead_within_landing(&self, lead_m: f64) -> f64 {
        let room_m = self.landing_room_m();
        lead_within_landing(
            lead_m,
            landing_gap_m(self.settings.clearance_m, room_m),
            room_m,
        )
    }
}

/// The settings' `clearance_m`, within the plan's landing room `room_m`.
fn landing_gap_m(clearance_m: f64, room_m: f64) -> f64 {
    clearance_m.min(room_m)
}

/// `lead_m` bounded so that the stroke it shifts still lowers the tip at
/// least half the gap `gap_m` behind the particle (a lead ahead), and
/// within the landing room `room_m` (a lead back).
fn lead_within_landing(lead_m: f64, gap_m: f64, room_m: f64) -> f64 {
    lead_m.clamp(-(room_m - gap_m).max(0.0), 0.5 * gap_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    const UM: f64 = 1e-6;

    #[test]
    fn ten_micron_spheres_keep_the_clearance_and_the_leads() {
        // Tip disc 1 um, standoff 1 um: 2 um of room; 0.5 um clearance.
        let gap = landing_gap_m(0.5 * UM, 2.0 * UM);
        assert_eq!(gap, 0.5 * UM);
        assert_eq!(lead_within_landing(0.25 * UM, gap, 2.0 * UM), 0.25 * UM);
        assert_eq!(lead_within_landing(-0.25 * UM, gap, 2.0 * UM), -0.25 * UM);
    }

    #[test]
    fn a_micron_spheres_tip_comes_down_where_its_plan_checked() {
        // Tip disc 0.1 um, standoff 0.1 um: the tip lands 0.2 um behind,
        // leads ahead at most half that, and none back (no room).
        let room = 0.2 * UM;
        let gap = landing_gap_m(0.5 * UM, room);
        assert!((gap - room).abs() < 1e-15);
        assert!((lead_within_landing(0.25 * UM, gap, room) - 0.1 * UM).abs() < 1e-15);
        assert_eq!(lead_within_landing(-0.25 * UM, gap, room), 0.0);
        // A plan at a farther standoff leaves room for a lead back.
        let room = 0.35 * UM;
        let back = lead_within_landing(-0.25 * UM, landing_gap_m(0.2 * UM, room), room);
        assert!((back + 0.15 * UM).abs() < 1e-15, "{back}");
    }
}
