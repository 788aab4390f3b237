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
//!
//! A second simulated controller may play the coarse stage ([`CoarseAxes`]):
//! it moves the sample under the probe (and the camera), so the tip on the
//! sample is the nanostage's position plus the coarse offset, as on the
//! simulated rig. The motions of both controllers are merged in time order
//! and cut at every change of either, so a coarse move with the tip lowered
//! drags it through the world like any other stroke. Both controllers must
//! run at the same time scale (the tip's speed on the sample is taken in the
//! nanostage controller's simulated seconds).

use super::simulator::Motion;
use crate::rig::sim::stage::TimedLanding;
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

/// How the coarse controller's axes move the nanostage's origin on the
/// sample: offset = sign * position * unit - zero, per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoarseAxes {
    /// Coarse controller axis indices (in `SAI?` order) of x and y.
    pub xy: [usize; 2],
    /// Metres per controller unit (1e-3 for millimetres).
    pub unit_m: f64,
    /// The rig file's `sign` (+1: the nanostage is carried, -1: the sample is).
    pub sign: [f64; 2],
    /// Signed axis positions, metres, at which the offset is zero.
    pub zero_m: [f64; 2],
}

impl CoarseAxes {
    /// Where the coarse stage puts the nanostage's origin on the sample,
    /// metres, for controller axis positions.
    pub fn offset_m(&self, positions: &[f64]) -> [f64; 2] {
        [0, 1].map(|i| {
            self.sign[i] * positions.get(self.xy[i]).copied().unwrap_or(0.0) * self.unit_m
                - self.zero_m[i]
        })
    }

    /// These axes, with the zero chosen so that `positions` give `offset_m`.
    pub fn with_offset_at(mut self, positions: &[f64], offset_m: [f64; 2]) -> Self {
        self.zero_m = [0.0, 0.0];
        let raw = self.offset_m(positions);
        self.zero_m = [raw[0] - offset_m[0], raw[1] - offset_m[1]];
        self
    }
}

/// Pieces shorter than this fraction of their interval are merged into the
/// neighbouring piece: axes of a straight-line move arrive together up to the
/// rounding of their velocities, and a sliver of a piece must not start a
/// contact of its own.
const MERGE_FRACTION: f64 = 1e-6;

/// The world the simulated controllers' tip moves through.
pub struct GcsSimWorld {
    /// Ground truth: the particles and the tip friction.
    pub world: World,
    physics: Box<dyn PushPhysics + Send>,
    axes: TipAxes,
    coarse_axes: Option<CoarseAxes>,
    start: Instant,
    /// The nanostage controller's current motion.
    nano: Option<Motion>,
    /// The coarse controller's current motion.
    coarse: Option<Motion>,
    /// The world has been swept up to this instant.
    swept_to: Option<Instant>,
    contacts: Vec<ContactEvent>,
    landings: Vec<TimedLanding>,
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
            coarse_axes: None,
            start,
            nano: None,
            coarse: None,
            swept_to: None,
            contacts: Vec::new(),
            landings: Vec::new(),
            applied: 0,
        }
    }

    /// The same world with a coarse stage: pass its motions to
    /// [`GcsSimWorld::advance_with_coarse`].
    pub fn with_coarse(mut self, coarse: CoarseAxes) -> Self {
        self.coarse_axes = Some(coarse);
        self
    }

    /// Motions applied so far: the same count means the same stage state.
    pub fn motions_applied(&self) -> usize {
        self.applied
    }

    /// Every contact so far (ground truth).
    pub fn contacts(&self) -> &[ContactEvent] {
        &self.contacts
    }

    /// Every move so far that lowered the tip onto a particle (ground
    /// truth, as the simulated stage logs them: [`World::landed_on`]), at
    /// the nanostage controller's simulated seconds since the session began.
    pub fn landings(&self) -> &[TimedLanding] {
        &self.landings
    }

    /// The tip in nanostage metres for controller axis positions.
    pub fn tip_m(&self, positions: &[f64]) -> StageXyz {
        self.axes
            .xyz
            .map(|i| positions.get(i).copied().unwrap_or(0.0) * self.axes.unit_m)
    }

    /// The coarse offset for coarse controller positions (zero without a coarse stage).
    pub fn coarse_offset_m(&self, coarse_positions: &[f64]) -> [f64; 2] {
        self.coarse_axes
            .map_or([0.0, 0.0], |c| c.offset_m(coarse_positions))
    }

    /// The tip on the sample: nanostage position plus coarse offset.
    pub fn tip_on_sample_m(&self, positions: &[f64], coarse_positions: &[f64]) -> StageXyz {
        let [x, y, z] = self.tip_m(positions);
        let o = self.coarse_offset_m(coarse_positions);
        [x + o[0], y + o[1], z]
    }

    /// Applies the nanostage controller's `motions` (oldest first, as it
    /// recorded them) and, if the last one is over by `now`, that one too.
    pub fn advance(&mut self, motions: Vec<Motion>, now: Instant) {
        self.advance_with_coarse(motions, Vec::new(), now);
    }

    /// [`GcsSimWorld::advance`] for both controllers: `now` must be one
    /// instant at which neither could record a motion unseen here (the
    /// caller holds both controllers while taking their motions).
    pub fn advance_with_coarse(&mut self, nano: Vec<Motion>, coarse: Vec<Motion>, now: Instant) {
        let mut events: Vec<(bool, Motion)> = nano
            .into_iter()
            .map(|m| (false, m))
            .chain(coarse.into_iter().map(|m| (true, m)))
            .collect();
        // Stable: at equal instants the nanostage's motion comes first.
        events.sort_by_key(|(_, m)| m.at);
        for (is_coarse, m) in events {
            if let Some(from) = self.swept_to
                && m.at > from
            {
                self.sweep(from, m.at);
            }
            self.swept_to = Some(self.swept_to.map_or(m.at, |t| t.max(m.at)));
            if is_coarse {
                self.coarse = Some(m);
            } else {
                self.nano = Some(m);
            }
            self.applied += 1;
        }
        // At rest by now: sweep up to the last arrival.
        let rest = [&self.nano, &self.coarse]
            .into_iter()
            .flatten()
            .map(|m| m.at + std::time::Duration::from_secs_f64(latest_arrival_s(m)))
            .max();
        if let (Some(rest), Some(from)) = (rest, self.swept_to)
            && rest <= now
            && rest > from
        {
            self.sweep(from, rest);
            self.swept_to = Some(rest);
            self.applied += 1;
        }
    }

    /// Tip on the sample at instant `t` under the current motions.
    fn tip_at(&self, t: Instant) -> StageXyz {
        let positions =
            |m: &Motion| m.positions_after(t.saturating_duration_since(m.at).as_secs_f64());
        let nano = self.nano.as_ref().map(positions).unwrap_or_default();
        let coarse = self.coarse.as_ref().map(positions).unwrap_or_default();
        self.tip_on_sample_m(&nano, &coarse)
    }

    /// Sweeps the tip through the world from `t0` to `t1` under the current
    /// motions, in straight pieces cut where an axis of either controller arrives.
    fn sweep(&mut self, t0: Instant, t1: Instant) {
        let span = t1.saturating_duration_since(t0).as_secs_f64();
        let Some(time_scale) = self.nano.as_ref().map(|m| m.time_scale) else {
            return;
        };
        if span <= 0.0 {
            return;
        }
        let merge = span * MERGE_FRACTION;
        let mut cuts: Vec<f64> = [&self.nano, &self.coarse]
            .into_iter()
            .flatten()
            .flat_map(|m| {
                let offset = m.at.saturating_duration_since(t0).as_secs_f64()
                    - t0.saturating_duration_since(m.at).as_secs_f64();
                m.arrivals_s().into_iter().map(move |a| a + offset)
            })
            .filter(|&t| t > merge && t < span - merge)
            .collect();
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() <= merge);
        cuts.push(span);
        let mut a = 0.0;
        for b in cuts {
            let from = self.tip_at(t0 + std::time::Duration::from_secs_f64(a));
            let to = self.tip_at(t0 + std::time::Duration::from_secs_f64(b));
            let lateral = (to[0] - from[0]).hypot(to[1] - from[1]);
            let simulated_s = (b - a) * time_scale;
            let end = t0 + std::time::Duration::from_secs_f64(b);
            let session_s = end.saturating_duration_since(self.start).as_secs_f64() * time_scale;
            // As on the simulated stage: only level strokes push, and a
            // lowering move is checked for a particle under the apex.
            if lateral > 0.0 && (to[2] - from[2]).abs() < 1e-12 && simulated_s > 0.0 {
                let events = self.world.sweep(
                    from,
                    to,
                    lateral / simulated_s,
                    session_s,
                    self.physics.as_ref(),
                );
                self.contacts.extend(events);
            } else if to[2] < from[2]
                && let Some(particle) = self.world.landed_on([to[0], to[1]], to[2])
            {
                self.landings.push(TimedLanding {
                    t_s: session_s,
                    particle,
                    at_m: [to[0], to[1]],
                });
            }
            a = b;
        }
    }
}

/// Wall-clock seconds after its start at which every axis of `m` is on target.
fn latest_arrival_s(m: &Motion) -> f64 {
    m.arrivals_s().into_iter().fold(0.0, f64::max)
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

    #[test]
    fn the_tip_lowered_onto_a_particle_is_logged_and_beside_it_is_not() {
        let t0 = Instant::now();
        let mut c = controller(t0, 100.0);
        let mut w = GcsSimWorld::new(world_at(50.0, 50.0), Box::new(Onset2um), AXES, t0);
        let s = |k: u64| t0 + Duration::from_secs(k);
        // Up above the 10 um sphere, over it 2 um off its centre, down to
        // 5 um (its top there is at 9.6 um); then up, 8 um off, down again.
        c.handle_line("MOV 3 14", s(0));
        c.handle_line("MOV 1 50 2 52", s(1));
        c.handle_line("MOV 3 5", s(2));
        c.handle_line("MOV 3 14", s(3));
        c.handle_line("MOV 1 58 2 50", s(4));
        c.handle_line("MOV 3 5", s(5));
        w.advance(c.take_motions(), s(6));
        assert_eq!(w.landings().len(), 1, "{:?}", w.landings());
        let landing = w.landings()[0];
        assert_eq!(landing.particle, 4);
        assert!((landing.at_m[0] - 50e-6).abs() < 1e-9 && (landing.at_m[1] - 52e-6).abs() < 1e-9);
        // Nothing pushed it: the knock is not modelled.
        assert_eq!(w.world.particles, world_at(50.0, 50.0).particles);
    }

    /// The coarse stage carries the sample: `MOV 1 12.46` (mm) moves the
    /// nanostage's origin 40 um in +x across it.
    fn coarse(t0: Instant, scale: f64) -> (SimController, CoarseAxes) {
        let mut k = SimController::new(SimConfig::coarse(), t0);
        k.set_time_scale(scale, t0);
        k.record_motions(t0);
        k.handle_line("SVO 1 1 2 1", t0);
        let axes = CoarseAxes {
            xy: [0, 1],
            unit_m: 1e-3,
            sign: [-1.0, -1.0],
            zero_m: [0.0, 0.0],
        }
        .with_offset_at(&[12.5, 12.5], [0.0, 0.0]);
        (k, axes)
    }

    #[test]
    fn a_coarse_move_under_a_lowered_tip_pushes_like_a_stroke() {
        let t0 = Instant::now();
        let mut c = controller(t0, 10.0);
        let (mut k, axes) = coarse(t0, 10.0);
        let z = height_for_contact_angle(45f64.to_radians(), 5e-6) * 1e6;
        let mut w =
            GcsSimWorld::new(world_at(50.0, 30.0), Box::new(Onset2um), AXES, t0).with_coarse(axes);
        approach(&mut c, t0, z);
        // The sample moves 40 um in -x under the tip at 1 mm/s: 4 ms of wall time.
        let t1 = t0 + Duration::from_secs(1);
        k.handle_line("MOV 1 12.46", t1);
        let end = t1 + Duration::from_millis(10);
        assert!(!k.any_moving(end));
        w.advance_with_coarse(c.take_motions(), k.take_motions(), end);
        let coarse_at = [k.position(0, end).unwrap(), k.position(1, end).unwrap()];
        let offset = w.coarse_offset_m(&coarse_at);
        assert!(
            (offset[0] - 40e-6).abs() < 1e-12 && offset[1].abs() < 1e-12,
            "{offset:?}"
        );
        assert_eq!(w.contacts().len(), 1, "{:?}", w.contacts());
        // As the 40 um nanostage stroke from x = 20 um in the test above.
        let rc = (25e-12_f64 - (z * 1e-6 - 5e-6).powi(2)).sqrt();
        let expected = 60e-6 - (50e-6 - rc) - 2e-6;
        let moved = w.world.particles[0].x_m - 50e-6;
        assert!((moved - expected).abs() < 1e-9, "moved {moved}");
    }

    #[test]
    fn a_coarse_move_with_the_tip_lifted_pushes_nothing_and_shifts_the_tip() {
        let t0 = Instant::now();
        let mut c = controller(t0, 10.0);
        let (mut k, axes) = coarse(t0, 10.0);
        let mut w =
            GcsSimWorld::new(world_at(50.0, 30.0), Box::new(Onset2um), AXES, t0).with_coarse(axes);
        approach(&mut c, t0, 14.0);
        let t1 = t0 + Duration::from_secs(1);
        k.handle_line("MOV 1 12.46 2 12.51", t1);
        let end = t1 + Duration::from_millis(10);
        w.advance_with_coarse(c.take_motions(), k.take_motions(), end);
        assert!(w.contacts().is_empty(), "{:?}", w.contacts());
        assert_eq!(w.world.particles, world_at(50.0, 30.0).particles);
        let nano = [
            c.position(0, end).unwrap(),
            c.position(1, end).unwrap(),
            14.0,
        ];
        let coarse_at = [k.position(0, end).unwrap(), k.position(1, end).unwrap()];
        let tip = w.tip_on_sample_m(&nano, &coarse_at);
        assert!(
            (tip[0] - 60e-6).abs() < 1e-12 && (tip[1] - 20e-6).abs() < 1e-12,
            "{tip:?}"
        );
    }
}
