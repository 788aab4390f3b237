//! The simulated world under the GCS controller simulator: particles that the
//! simulated controller's probe pushes, so that a rig made of the controller
//! simulator and a camera fed by the simulated microscope behaves like the
//! simulated rig.
//!
//! The controller knows only its axes. Every change of their motion is a
//! [`Motion`] ([`SimController::record_motions`](super::SimController::record_motions));
//! this replays each one as the straight pieces the axes really travelled
//! (between axis arrivals; one piece for the straight-line moves
//! [`GcsNanoStage`](crate::rig::hardware::GcsNanoStage) makes) and sweeps the tip through the
//! world along each lateral piece with the pushing model, exactly as the
//! simulated stage does ([`World::sweep`]). A move is applied once it is over
//! (on target, or cut short by the next command such as `HLT`), so the
//! particles jump at the end of a stroke: the camera is only read with the
//! stage at rest.

use super::simulator::Motion;
use crate::rig::sim::world::{ContactEvent, PushPhysics, World};
use crate::rig::stage::StageXyz;
use std::time::Instant;

/// Which controller axes carry the tip, and their unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipAxes {
    /// Controller axis indices (in `SAI?` order) of stage x, y and z.
    pub xyz: [usize; 3],
    /// Metres per controller unit (1e-6 for micrometres).
    pub unit_m: f64,
}

/// Pieces shorter than this fraction of their motion are merged into the
/// neighbouring piece: axes of a straight-line move arrive together up to the
/// rounding of their velocities, and a sliver of a piece must not start a
/// contact of its own.
const MERGE_FRACTION: f64 = 1e-6;

/// The world the simulated controller's tip moves through.
pub struct GcsSimWorld {
    /// Ground truth: the particles and the tip friction.
    pub world: World,
    physics: Box<dyn PushPhysics + Send>,
    axes: TipAxes,
    start: Instant,
    pending: Option<Motion>,
    contacts: Vec<ContactEvent>,
    applied: usize,
}

impl GcsSimWorld {
    /// A world whose session starts at `start` (charge build-up grows from there).
    pub fn new(
        world: World,
        physics: Box<dyn PushPhysics + Send>,
        axes: TipAxes,
        start: Instant,
    ) -> Self {
        Self {
            world,
            physics,
            axes,
            start,
            pending: None,
            contacts: Vec::new(),
            applied: 0,
        }
    }

    /// Motions applied so far: the same count means the same stage state.
    pub fn motions_applied(&self) -> usize {
        self.applied
    }

    /// Every contact so far (ground truth).
    pub fn contacts(&self) -> &[ContactEvent] {
        &self.contacts
    }

    /// The tip in stage metres for controller axis positions.
    pub fn tip_m(&self, positions: &[f64]) -> StageXyz {
        self.axes
            .xyz
            .map(|i| positions.get(i).copied().unwrap_or(0.0) * self.axes.unit_m)
    }

    /// Applies `motions` (oldest first, as the controller recorded them) and,
    /// if the last one is over by `now`, that one too.
    pub fn advance(&mut self, motions: Vec<Motion>, now: Instant) {
        for m in motions {
            if let Some(previous) = self.pending.take() {
                let lasted = m.at.saturating_duration_since(previous.at).as_secs_f64();
                self.apply(&previous, lasted);
            }
            self.pending = Some(m);
        }
        let over = self.pending.as_ref().and_then(|m| {
            let arrive = m.arrivals_s().into_iter().fold(0.0, f64::max);
            let elapsed = now.saturating_duration_since(m.at).as_secs_f64();
            (elapsed >= arrive).then_some(arrive)
        });
        if let Some(arrive) = over
            && let Some(m) = self.pending.take()
        {
            self.apply(&m, arrive);
        }
    }

    /// Sweeps the tip along motion `m` for its first `lasted_s` wall seconds.
    fn apply(&mut self, m: &Motion, lasted_s: f64) {
        self.applied += 1;
        if lasted_s <= 0.0 {
            return;
        }
        let merge = lasted_s * MERGE_FRACTION;
        let mut cuts: Vec<f64> = m
            .arrivals_s()
            .into_iter()
            .filter(|&t| t > merge && t < lasted_s - merge)
            .collect();
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() <= merge);
        cuts.push(lasted_s);
        let mut t0 = 0.0;
        for t1 in cuts {
            let from = self.tip_m(&m.positions_after(t0));
            let to = self.tip_m(&m.positions_after(t1));
            let lateral = (to[0] - from[0]).hypot(to[1] - from[1]);
            let simulated_s = (t1 - t0) * m.time_scale;
            // As on the simulated stage: only level strokes push.
            if lateral > 0.0 && (to[2] - from[2]).abs() < 1e-12 && simulated_s > 0.0 {
                let session_s = m.at.saturating_duration_since(self.start).as_secs_f64()
                    * m.time_scale
                    + t1 * m.time_scale;
                let events = self.world.sweep(
                    from,
                    to,
                    lateral / simulated_s,
                    session_s,
                    self.physics.as_ref(),
                );
                self.contacts.extend(events);
            }
            t0 = t1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::gcs::{SimConfig, SimController};
    use crate::rig::sim::world::{
        ContactOutcome, ContactQuery, ContactResponse, SimParticle, height_for_contact_angle,
    };
    use std::time::Duration;

    /// The particle starts to move after 2 um of travel, at any speed.
    struct Onset2um;
    impl PushPhysics for Onset2um {
        fn respond(&self, _: &ContactQuery) -> ContactResponse {
            ContactResponse::Moves {
                onset_travel_m: 2e-6,
            }
        }
    }

    fn world_at(x_um: f64, y_um: f64) -> World {
        World {
            particles: vec![SimParticle {
                id: 4,
                x_m: x_um * 1e-6,
                y_m: y_um * 1e-6,
                radius_m: 5e-6,
            }],
            tip_friction: 0.3,
        }
    }

    const AXES: TipAxes = TipAxes {
        xyz: [0, 1, 2],
        unit_m: 1e-6,
    };

    fn controller(t0: Instant, scale: f64) -> SimController {
        let mut c = SimController::new(SimConfig::default(), t0);
        c.set_time_scale(scale, t0);
        c.record_motions(t0);
        c.handle_line("SVO 1 1 2 1 3 1", t0);
        c
    }

    /// Up, across to (20, 30) and down to push height `z_um`, each move
    /// over (at any time scale >= 1) before the next.
    fn approach(c: &mut SimController, t0: Instant, z_um: f64) {
        c.handle_line("MOV 3 14", t0);
        c.handle_line("MOV 1 20 2 30", t0 + Duration::from_millis(200));
        c.handle_line(&format!("MOV 3 {z_um}"), t0 + Duration::from_millis(700));
    }

    #[test]
    fn a_level_stroke_pushes_the_particle_once_it_is_over() {
        let t0 = Instant::now();
        // 10x faster than the wall clock.
        let mut c = controller(t0, 10.0);
        let z = height_for_contact_angle(45f64.to_radians(), 5e-6) * 1e6;
        let mut w = GcsSimWorld::new(world_at(50.0, 30.0), Box::new(Onset2um), AXES, t0);
        // Down to push height at (20, 30), then 40 um along x at 100 um/s.
        approach(&mut c, t0, z);
        let t1 = t0 + Duration::from_secs(1);
        c.handle_line("MOV 1 60", t1);
        // Half way: nothing is applied yet.
        let mid = t1 + Duration::from_millis(20);
        w.advance(c.take_motions(), mid);
        assert!(w.contacts().is_empty());
        assert_eq!(w.world.particles, world_at(50.0, 30.0).particles);
        // 40 um at 100 um/s, 10x: 40 ms of wall time.
        let end = t1 + Duration::from_millis(41);
        assert!(!c.any_moving(end));
        w.advance(c.take_motions(), end);
        assert_eq!(w.contacts().len(), 1, "{:?}", w.contacts());
        assert_eq!(w.contacts()[0].outcome, ContactOutcome::Carried);
        let rc = (25e-12_f64 - (z * 1e-6 - 5e-6).powi(2)).sqrt();
        // Contact at x = 50 - rc, 2 um to onset, then carried to the end.
        let expected = 60e-6 - (50e-6 - rc) - 2e-6;
        let moved = w.world.particles[0].x_m - 50e-6;
        assert!((moved - expected).abs() < 1e-9, "moved {moved}");
        // Nothing more happens when asked again.
        w.advance(c.take_motions(), end + Duration::from_millis(50));
        assert_eq!(w.contacts().len(), 1);
    }

    #[test]
    fn a_halted_stroke_pushes_only_as_far_as_the_tip_went() {
        let t0 = Instant::now();
        let mut c = controller(t0, 1.0);
        let z = height_for_contact_angle(45f64.to_radians(), 5e-6) * 1e6;
        let mut w = GcsSimWorld::new(world_at(30.0, 30.0), Box::new(Onset2um), AXES, t0);
        approach(&mut c, t0, z);
        let t1 = t0 + Duration::from_secs(1);
        c.handle_line("VEL 1 10", t1);
        c.handle_line("MOV 1 60", t1);
        // HLT after 1.5 s at 10 um/s: the tip stops at x = 35 um.
        let t2 = t1 + Duration::from_millis(1500);
        c.handle_line("HLT", t2);
        w.advance(c.take_motions(), t2 + Duration::from_secs(1));
        let tip = w.tip_m(&[c.position(0, t2).unwrap()]);
        assert!((tip[0] - 35e-6).abs() < 1e-9, "{tip:?}");
        let rc = (25e-12_f64 - (z * 1e-6 - 5e-6).powi(2)).sqrt();
        let expected = 35e-6 - (30e-6 - rc) - 2e-6;
        let moved = w.world.particles[0].x_m - 30e-6;
        assert!((moved - expected).abs() < 1e-9, "moved {moved}");
    }

    #[test]
    fn lifted_travel_and_vertical_moves_push_nothing() {
        let t0 = Instant::now();
        let mut c = controller(t0, 100.0);
        let mut w = GcsSimWorld::new(world_at(50.0, 50.0), Box::new(Onset2um), AXES, t0);
        // Start (50, 50, 7.5): straight down onto the particle's top, then
        // up, then across above it.
        c.handle_line("MOV 3 11", t0);
        c.handle_line("MOV 1 10", t0 + Duration::from_secs(1));
        c.handle_line("MOV 1 90 3 14", t0 + Duration::from_secs(2));
        w.advance(c.take_motions(), t0 + Duration::from_secs(3));
        assert!(w.contacts().is_empty(), "{:?}", w.contacts());
        assert_eq!(w.world.particles, world_at(50.0, 50.0).particles);
    }
}
