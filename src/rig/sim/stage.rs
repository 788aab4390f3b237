//! The simulated nanostage: moves the tip through the [`World`], with the
//! stage's precision noise and a slow drift between tip and sample, and can be
//! told to fail mid-move (for fault tests).

use super::state::{SIM_STATE_SCHEMA, SavedParticle, SimState};
use super::world::{ContactEvent, PushPhysics, SimParticle, World};
use crate::rig::RigError;
use crate::rig::stage::{AxisRange, NanoStage, StageXyz, check_in_range};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Stage properties of the simulated rig.
#[derive(Debug, Clone, PartialEq)]
pub struct SimStageConfig {
    /// Travel of x, y, z.
    pub range: [AxisRange; 3],
    /// Fastest allowed move.
    pub max_speed_m_per_s: f64,
    /// One-sigma position noise of every move (the stage's precision).
    pub precision_m: f64,
    /// Drift of the tip against the sample, metres per second in x and y.
    pub drift_m_per_s: [f64; 2],
}

impl Default for SimStageConfig {
    /// A 100 x 100 x 15 um piezo stage, +-10 nm, 100 um/s top speed, no drift.
    fn default() -> Self {
        let axis = |max_um: f64| AxisRange {
            min_m: 0.0,
            max_m: max_um * 1e-6,
        };
        Self {
            range: [axis(100.0), axis(100.0), axis(15.0)],
            max_speed_m_per_s: 100e-6,
            precision_m: 10e-9,
            drift_m_per_s: [0.0, 0.0],
        }
    }
}

/// A contact, with the rig time it happened at (ground truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedContact {
    /// Rig time at the end of the move, seconds.
    pub t_s: f64,
    /// What happened.
    pub event: ContactEvent,
}

/// A move that lowered the tip onto a particle (ground truth; see
/// [`World::landed_on`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedLanding {
    /// Rig time at the end of the move, seconds.
    pub t_s: f64,
    /// The particle landed on (its id in the world).
    pub particle: usize,
    /// Where the apex came down, metres on the sample.
    pub at_m: [f64; 2],
}

/// The simulated nanostage and the world it moves the tip through.
pub struct SimStage {
    /// Ground truth: particles and tip friction.
    pub world: World,
    physics: Box<dyn PushPhysics>,
    config: SimStageConfig,
    commanded: StageXyz,
    actual: StageXyz,
    clock_s: f64,
    seed: u64,
    contacts: Vec<TimedContact>,
    landings: Vec<TimedLanding>,
    moves: usize,
    fail_at_move: Option<usize>,
    coarse_offset: [f64; 2],
}

impl SimStage {
    /// A stage parked at the top of its z travel over (0, 0).
    pub fn new(
        world: World,
        physics: Box<dyn PushPhysics>,
        config: SimStageConfig,
        seed: u64,
    ) -> Self {
        let park = [
            config.range[0].min_m,
            config.range[1].min_m,
            config.range[2].max_m,
        ];
        Self {
            world,
            physics,
            config,
            commanded: park,
            actual: park,
            clock_s: 0.0,
            seed,
            contacts: Vec::new(),
            landings: Vec::new(),
            moves: 0,
            fail_at_move: None,
            coarse_offset: [0.0, 0.0],
        }
    }

    /// Rig time, seconds: advances with every move.
    pub fn clock_s(&self) -> f64 {
        self.clock_s
    }

    /// Lets time pass without moving (frame grabs, settling).
    pub fn wait(&mut self, seconds: f64) {
        self.clock_s += seconds.max(0.0);
    }

    /// Every contact so far (ground truth).
    pub fn contacts(&self) -> &[TimedContact] {
        &self.contacts
    }

    /// Every move so far that lowered the tip onto a particle (ground truth).
    pub fn landings(&self) -> &[TimedLanding] {
        &self.landings
    }

    /// Contacts so far that evaluated each model effect (see [`PushPhysics::effect_work`]).
    pub fn effect_work(&self) -> std::collections::BTreeMap<String, u64> {
        self.physics.effect_work()
    }

    /// Makes move number `n` (counted from 0 over the stage's life) stop halfway with a fault.
    pub fn fail_at_move(&mut self, n: usize) {
        self.fail_at_move = Some(n);
    }

    /// Number of moves commanded so far.
    pub fn moves(&self) -> usize {
        self.moves
    }

    /// The stage's changing state, for saving (frames are the camera's, set by the rig).
    pub fn snapshot(&self) -> SimState {
        SimState {
            schema: SIM_STATE_SCHEMA.to_owned(),
            particles: self
                .world
                .particles
                .iter()
                .map(|p| SavedParticle {
                    id: p.id,
                    x_m: p.x_m,
                    y_m: p.y_m,
                    radius_m: p.radius_m,
                })
                .collect(),
            commanded: self.commanded,
            actual: self.actual,
            clock_s: self.clock_s,
            coarse_offset: self.coarse_offset,
            moves: self.moves,
            frames: 0,
        }
    }

    /// Puts the stage and the world back to a saved state.
    pub fn restore(&mut self, state: &SimState) {
        self.world.particles = state
            .particles
            .iter()
            .map(|p| SimParticle {
                id: p.id,
                x_m: p.x_m,
                y_m: p.y_m,
                radius_m: p.radius_m,
            })
            .collect();
        self.commanded = state.commanded;
        self.actual = state.actual;
        self.clock_s = state.clock_s;
        self.coarse_offset = state.coarse_offset;
        self.moves = state.moves;
    }

    /// Where the coarse stage has put the nanostage's origin on the sample.
    pub fn coarse_offset(&self) -> [f64; 2] {
        self.coarse_offset
    }

    /// Moves the sample under the nanostage (coarse stage). The tip must be up,
    /// at the top of its z travel, or it would be dragged through the sample.
    pub fn move_coarse(&mut self, offset: [f64; 2]) -> Result<(), RigError> {
        let top = self.config.range[2].max_m;
        if self.commanded[2] < top - 1e-9 {
            return Err(RigError::StageFault(
                "coarse move refused: the tip is not retracted".to_owned(),
            ));
        }
        if !(offset[0].is_finite() && offset[1].is_finite()) {
            return Err(RigError::StageFault(
                "coarse target is not finite".to_owned(),
            ));
        }
        self.coarse_offset = offset;
        self.actual = self.realise(self.commanded);
        Ok(())
    }

    /// Ground-truth tip position on the sample (nanostage position plus the coarse offset).
    pub fn actual_on_sample(&self) -> StageXyz {
        self.actual
    }

    /// Where a commanded target really puts the tip. The noise of move `n` is
    /// drawn from a generator seeded by (seed, n), so a world restored from a
    /// saved state goes on exactly as the original would have.
    fn realise(&mut self, target: StageXyz) -> StageXyz {
        let noise = Normal::new(0.0, self.config.precision_m.max(0.0)).expect("finite sigma");
        let mut rng = ChaCha8Rng::seed_from_u64(
            self.seed ^ (self.moves as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        let d = self.config.drift_m_per_s;
        [
            target[0] + self.coarse_offset[0] + d[0] * self.clock_s + noise.sample(&mut rng),
            target[1] + self.coarse_offset[1] + d[1] * self.clock_s + noise.sample(&mut rng),
            target[2],
        ]
    }
}

impl NanoStage for SimStage {
    fn range(&self) -> [AxisRange; 3] {
        self.config.range
    }

    fn position(&mut self) -> Result<StageXyz, RigError> {
        Ok(self.commanded)
    }

    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
        check_in_range(target, &self.config.range)?;
        let max = self.config.max_speed_m_per_s;
        if !(speed_m_per_s.is_finite() && speed_m_per_s > 0.0 && speed_m_per_s <= max) {
            return Err(RigError::BadSpeed {
                speed_um_s: speed_m_per_s * 1e6,
                max_um_s: max * 1e6,
            });
        }
        let faulty = self.fail_at_move == Some(self.moves);
        self.moves += 1;
        let target = if faulty {
            std::array::from_fn(|i| 0.5 * (self.commanded[i] + target[i]))
        } else {
            target
        };
        let length: f64 = (0..3)
            .map(|i| (target[i] - self.commanded[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        self.clock_s += length / speed_m_per_s;
        let from = self.actual;
        let to = self.realise(target);
        let lateral = (to[0] - from[0]).hypot(to[1] - from[1]);
        if lateral > 0.0 && (to[2] - from[2]).abs() < 1e-9 {
            let events =
                self.world
                    .sweep(from, to, speed_m_per_s, self.clock_s, self.physics.as_ref());
            let t_s = self.clock_s;
            self.contacts
                .extend(events.into_iter().map(|event| TimedContact { t_s, event }));
        } else if to[2] < from[2]
            && let Some(particle) = self.world.landed_on([to[0], to[1]], to[2])
        {
            self.landings.push(TimedLanding {
                t_s: self.clock_s,
                particle,
                at_m: [to[0], to[1]],
            });
        }
        self.commanded = target;
        self.actual = to;
        if faulty {
            return Err(RigError::StageFault(
                "simulated fault: stage stopped halfway".to_owned(),
            ));
        }
        Ok(())
    }

    fn halt(&mut self) -> Result<(), RigError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::sim::world::{
        ContactOutcome, ContactQuery, ContactResponse, SimParticle, height_for_contact_angle,
    };

    struct Immediate;
    impl PushPhysics for Immediate {
        fn respond(&self, _: &ContactQuery) -> ContactResponse {
            ContactResponse::Moves {
                onset_travel_m: 0.0,
            }
        }
    }

    fn stage(seed: u64) -> SimStage {
        let world = World {
            particles: vec![SimParticle {
                id: 7,
                x_m: 50e-6,
                y_m: 50e-6,
                radius_m: 5e-6,
            }],
            tip_friction: 0.3,
        };
        SimStage::new(world, Box::new(Immediate), SimStageConfig::default(), seed)
    }

    fn push(s: &mut SimStage) -> Result<(), RigError> {
        let z = height_for_contact_angle(45f64.to_radians(), 5e-6);
        s.move_to([30e-6, 50e-6, 14e-6], 50e-6)?;
        s.move_to([30e-6, 50e-6, z], 10e-6)?;
        s.move_to([70e-6, 50e-6, z], 1e-6)
    }

    #[test]
    fn a_tip_lowered_onto_the_particle_is_logged_and_one_lowered_beside_it_not() {
        let mut s = stage(1);
        push(&mut s).unwrap();
        assert!(s.landings().is_empty(), "{:?}", s.landings());
        let on_top = [s.world.particles[0].x_m, 50e-6];
        s.move_to([on_top[0], on_top[1], 14e-6], 50e-6).unwrap();
        s.move_to([on_top[0], on_top[1], 6e-6], 10e-6).unwrap();
        assert_eq!(s.landings().len(), 1);
        assert_eq!(s.landings()[0].particle, 7);
        assert!((s.landings()[0].at_m[0] - on_top[0]).abs() < 0.1e-6);
        // Lifting off it is no landing.
        s.move_to([on_top[0], on_top[1], 14e-6], 10e-6).unwrap();
        assert_eq!(s.landings().len(), 1);
    }

    #[test]
    fn a_push_moves_the_particle_and_logs_the_contact() {
        let mut s = stage(1);
        push(&mut s).unwrap();
        assert_eq!(s.contacts().len(), 1);
        assert_eq!(s.contacts()[0].event.outcome, ContactOutcome::Carried);
        assert!(s.world.particles[0].x_m > 70e-6);
        assert!(s.clock_s() > 40.0, "40 um at 1 um/s takes 40 s");
    }

    #[test]
    fn out_of_range_and_bad_speed_move_nothing() {
        let mut s = stage(1);
        assert!(matches!(
            s.move_to([120e-6, 0.0, 1e-6], 1e-6),
            Err(RigError::OutOfRange { axis: 'x', .. })
        ));
        assert!(matches!(
            s.move_to([10e-6, 0.0, 1e-6], f64::NAN),
            Err(RigError::BadSpeed { .. })
        ));
        assert!(matches!(
            s.move_to([10e-6, 0.0, f64::INFINITY], 1e-6),
            Err(RigError::OutOfRange { axis: 'z', .. })
        ));
        assert_eq!(s.moves(), 0);
    }

    #[test]
    fn an_injected_fault_stops_the_move_halfway() {
        let mut s = stage(1);
        s.fail_at_move(2);
        assert!(matches!(push(&mut s), Err(RigError::StageFault(_))));
        let x = s.position().unwrap()[0];
        assert!((x - 50e-6).abs() < 1e-12, "stopped at {x}");
    }

    #[test]
    fn a_restored_stage_goes_on_exactly_as_the_original() {
        let mut a = stage(3);
        push(&mut a).unwrap();
        let saved = a.snapshot();
        let mut b = stage(3);
        b.restore(&saved);
        for s in [&mut a, &mut b] {
            s.move_to([30e-6, 60e-6, 14e-6], 10e-6).unwrap();
        }
        assert_eq!(a.snapshot(), b.snapshot());
    }

    #[test]
    fn the_same_seed_gives_the_same_world() {
        let (mut a, mut b) = (stage(9), stage(9));
        push(&mut a).unwrap();
        push(&mut b).unwrap();
        assert_eq!(a.world.particles, b.world.particles);
        assert_eq!(a.actual_on_sample(), b.actual_on_sample());
    }
}
