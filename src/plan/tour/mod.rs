//! Shorter tip travel: the scheduler's order of moves, re-sequenced while
//! it stays collision-free.
//!
//! The scheduler takes the ready move nearest the tip, one at a time, which
//! leaves the tip crossing the field back and forth. Here the moves (a move
//! = the consecutive pushes of one particle: a route's legs stay together)
//! are re-sequenced as a shortest-path problem with side constraints
//! ([`search`]): the tip's hop from a move's end to the next move's landing
//! is the cost, and an order is valid when each particle's moves keep their
//! sequence and no push's corridor hits a particle where it then is
//! ([`blocking`], the replay's own test precomputed per particle state). The
//! result is replayed once more before it is returned; a sequence that does
//! not replay cleanly is never returned.

pub mod blocking;
pub mod exact;
pub mod search;

use super::layout::Layout;
use super::occupancy::Occupancy;
use super::pushes::{landing_point, tip_end};
use super::{PlanConfig, Step};
use blocking::{Blocking, Relaxation};
use nalgebra::Vector2;
use search::{PathProblem, SearchBudget, shortest_path};

/// Candidate orders the tour search may look at (on CMU's 40-60 moves the
/// ratios hardly change beyond it: see docs/plan.md).
pub const SEARCH_EVALUATIONS: usize = 100_000;
/// Seed of the search's kicks (plans are reproducible).
const SEARCH_SEED: u64 = 0x7001;

/// A run of consecutive pushes of one particle.
#[derive(Debug, Clone)]
pub struct Move {
    /// Particle index in the layout.
    pub particle: usize,
    /// Indices into the push list.
    pub pushes: std::ops::Range<usize>,
    /// Where the tip lands for the first push.
    pub land: Vector2<f64>,
    /// Where the tip lifts after the last push.
    pub end: Vector2<f64>,
}

/// Reorders `steps` (pushes only, as the scheduler made them, collision-free
/// in that order) to shorten the tip's travel between them; returns the
/// same pushes in the new order. Pushes of unknown particles, or a sequence
/// that does not replay cleanly, come back unchanged.
pub fn shorten_tip_travel(
    steps: Vec<Step>,
    layout: &Layout,
    tip_start: Option<Vector2<f64>>,
    config: &PlanConfig,
) -> Vec<Step> {
    let Some(moves) = moves_of(&steps, layout, config) else {
        return steps;
    };
    if moves.len() < 3 || !collision_free(&steps, &moves, layout, config, &identity(moves.len())) {
        return steps;
    }
    let Some(blocking) = Blocking::new(&moves, &steps, layout, config) else {
        return steps;
    };
    let (lands, ends) = endpoints(&moves);
    let problem = PathProblem::new(&lands, &ends, tip_start, &blocking);
    let order = shortest_path(&problem, identity(moves.len()), budget());
    if !collision_free(&steps, &moves, layout, config, &order) {
        debug_assert!(false, "the blocking masks let a colliding order through");
        return steps;
    }
    let mut out = Vec::with_capacity(steps.len());
    for &m in &order {
        out.extend(moves[m].pushes.clone().map(|i| steps[i].clone()));
    }
    out
}

/// Tip travel between the moves of a push list, three ways (metres, hops
/// only, no standoffs): as given, re-sequenced under the collision
/// constraints (what [`shorten_tip_travel`] returns), and re-sequenced
/// with only each particle's sequence kept (collisions ignored). Shows
/// whether the constraints or the search leave the gap to LB_tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TourStudy {
    /// Travel of the given order.
    pub given_m: f64,
    /// Travel after the constrained search.
    pub constrained_m: f64,
    /// Travel after the same search, from the constrained order, without
    /// collision constraints.
    pub unconstrained_m: f64,
    /// The same without the constraints of moving particles where they
    /// start ([`Relaxation::MovingStarts`]).
    pub without_moving_starts_m: f64,
    /// The same without the constraints of moving particles where they end
    /// ([`Relaxation::FinalPlaces`]).
    pub without_final_places_m: f64,
    /// Assignment bound of the constrained problem: LB_tip's relaxation with
    /// also the pairs forbidden where the second move would hit the first
    /// one's particle where it was just left (hops only, no standoffs).
    pub constrained_bound_m: f64,
    /// Travel of the least-travel constrained order ([`exact::optimal_path`]
    /// from the search's order), when the moves fit its set type.
    pub optimal_m: Option<f64>,
    /// True when `optimal_m` is proven least (no layer of the DP was cut to a beam).
    pub exact: bool,
    /// True when the DP's order replays free of collisions (it must: the
    /// DP only tests the blocking masks); false when no DP ran.
    pub optimal_replays: bool,
    /// States the DP kept, in total over its layers, and in its largest layer.
    pub dp_states: (usize, usize),
    /// Number of moves.
    pub moves: usize,
}

/// The study's DP budget: a layer above 5 M states is cut to the best 1 M.
pub const STUDY_DP: exact::DpBudget = exact::DpBudget {
    max_layer_states: 5_000_000,
    beam: 1_000_000,
    prune: true,
};

/// Measures [`TourStudy`] for `steps` (pushes in a collision-free order),
/// with the DP when `dp` gives it a budget; None when the pushes do not
/// split into moves. Each relaxed search starts from the constrained
/// search's order (valid without any constraint), so it is never longer.
pub fn study(
    steps: &[Step],
    layout: &Layout,
    tip_start: Option<Vector2<f64>>,
    config: &PlanConfig,
    dp: Option<exact::DpBudget>,
) -> Option<TourStudy> {
    let moves = moves_of(steps, layout, config)?;
    let blocking = Blocking::new(&moves, steps, layout, config)?;
    let (lands, ends) = endpoints(&moves);
    let problem = PathProblem::new(&lands, &ends, tip_start, &blocking);
    let given = identity(moves.len());
    let given_m = problem.travel(&given);
    let searched = shortest_path(&problem, given, budget());
    let constrained_m = problem.travel(&searched);
    let dp = dp.and_then(|budget| exact::optimal_path(&problem, &searched, budget));
    let relaxed_m = |relaxation: Relaxation| {
        let relaxed = blocking.relaxed(relaxation);
        let problem = PathProblem::new(&lands, &ends, tip_start, &relaxed);
        problem.travel(&shortest_path(&problem, searched.clone(), budget()))
    };
    let constrained_bound_m =
        crate::plan::bounds::path_assignment_bound(&lands, &ends, tip_start, |i, j| {
            !blocking.may_follow(i, j)
        })?;
    Some(TourStudy {
        constrained_bound_m,
        given_m,
        constrained_m,
        unconstrained_m: relaxed_m(Relaxation::Collisions),
        without_moving_starts_m: relaxed_m(Relaxation::MovingStarts),
        without_final_places_m: relaxed_m(Relaxation::FinalPlaces),
        optimal_m: dp.as_ref().map(|d| d.travel_m),
        exact: dp.as_ref().is_some_and(|d| d.exact),
        optimal_replays: dp
            .as_ref()
            .is_some_and(|d| collision_free(steps, &moves, layout, config, &d.order)),
        dp_states: dp.as_ref().map_or((0, 0), |d| {
            let s = &d.states_per_layer;
            (s.iter().sum(), s.iter().copied().max().unwrap_or(0))
        }),
        moves: moves.len(),
    })
}

fn budget() -> SearchBudget {
    SearchBudget {
        evaluations: SEARCH_EVALUATIONS,
        seed: SEARCH_SEED,
    }
}

fn identity(n: usize) -> Vec<usize> {
    (0..n).collect()
}

fn endpoints(moves: &[Move]) -> (Vec<Vector2<f64>>, Vec<Vector2<f64>>) {
    (
        moves.iter().map(|m| m.land).collect(),
        moves.iter().map(|m| m.end).collect(),
    )
}

/// Splits the pushes into moves; None if a step is not a push of a known particle.
fn moves_of(steps: &[Step], layout: &Layout, config: &PlanConfig) -> Option<Vec<Move>> {
    let index = layout.index_by_id();
    let mut moves: Vec<Move> = Vec::new();
    for (i, step) in steps.iter().enumerate() {
        let Step::Push {
            particle,
            from_m,
            to_m,
            approach_m,
            ..
        } = step
        else {
            return None;
        };
        let p = *index.get(particle)?;
        let end = tip_end(*from_m, *to_m, *approach_m);
        match moves.last_mut() {
            Some(m) if m.particle == p => {
                m.pushes.end = i + 1;
                m.end = end;
            }
            _ => moves.push(Move {
                particle: p,
                pushes: i..i + 1,
                land: landing_point(*from_m, *to_m, *approach_m, config),
                end,
            }),
        }
    }
    Some(moves)
}

/// True when the moves in `order` replay cleanly: every push starts where
/// its particle is at that moment and misses every other particle where it
/// then is (the replay the scheduler's own checks use).
fn collision_free(
    steps: &[Step],
    moves: &[Move],
    layout: &Layout,
    config: &PlanConfig,
    order: &[usize],
) -> bool {
    let mut occ = Occupancy::new(layout);
    for &m in order {
        let p = moves[m].particle;
        for i in moves[m].pushes.clone() {
            let Step::Push { from_m, to_m, .. } = steps[i] else {
                return false;
            };
            if !occ.replay_push(p, (from_m, to_m), config) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::layout::Particle;
    use crate::plan::pushes::approach_point;

    const UM: f64 = 1e-6;

    pub(super) fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x * UM, y * UM)
    }

    pub(super) fn layout(centres: &[Vector2<f64>]) -> Layout {
        Layout {
            field_m: [200.0 * UM, 200.0 * UM],
            particles: centres
                .iter()
                .enumerate()
                .map(|(i, &c)| Particle {
                    id: i as u32,
                    centre_m: c,
                    radius_m: 5.0 * UM,
                })
                .collect(),
        }
    }

    pub(super) fn push(
        particle: u32,
        from: Vector2<f64>,
        to: Vector2<f64>,
        cfg: &PlanConfig,
    ) -> Step {
        Step::Push {
            particle,
            from_m: from,
            to_m: to,
            approach_m: approach_point(from, to, 5.0 * UM, cfg),
            contact_angle_rad: 0.0,
        }
    }

    fn particles(steps: &[Step]) -> Vec<u32> {
        steps
            .iter()
            .map(|s| match s {
                Step::Push { particle, .. } => *particle,
                _ => u32::MAX,
            })
            .collect()
    }

    /// A at the left, B far right, C back at the left: the tip should do
    /// A and C before crossing to B, unless C's push needs B gone first.
    #[test]
    fn far_move_goes_last_unless_a_collision_needs_it_first() {
        let cfg = PlanConfig::default();
        let (a, b) = (v(20.0, 20.0), v(150.0, 20.0));
        // C pushed down next to A's end: free whatever B does.
        let c_free = (v(30.0, 60.0), v(30.0, 40.0));
        let l = layout(&[a, b, c_free.0]);
        let steps = vec![
            push(0, a, v(20.0, 30.0), &cfg),
            push(1, b, v(170.0, 20.0), &cfg),
            push(2, c_free.0, c_free.1, &cfg),
        ];
        let out = shorten_tip_travel(steps.clone(), &l, None, &cfg);
        assert_eq!(particles(&out)[2], 1, "B last: {:?}", particles(&out));
        // C now pushed down onto B's start: it must wait for B to leave.
        let c_blocked = (v(150.0, 60.0), v(150.0, 18.0));
        let l = layout(&[a, b, c_blocked.0]);
        let mut steps = steps;
        steps[1] = push(1, b, v(120.0, 20.0), &cfg);
        steps[2] = push(2, c_blocked.0, c_blocked.1, &cfg);
        let out = shorten_tip_travel(steps.clone(), &l, None, &cfg);
        let order = particles(&out);
        let at = |p: u32| order.iter().position(|&q| q == p).unwrap();
        assert!(at(1) < at(2), "C cannot go before B: {order:?}");
        // The tip still saves what it can: A no longer sits between B and C.
        assert_eq!(order, vec![1, 2, 0]);
    }

    /// A particle's two moves (a buffer push, then its site) keep their order
    /// even where swapping them would save travel.
    #[test]
    fn a_particle_s_moves_keep_their_order() {
        let cfg = PlanConfig::default();
        let (a, b) = (v(20.0, 20.0), v(150.0, 150.0));
        let l = layout(&[a, b]);
        let steps = vec![
            push(0, a, v(20.0, 40.0), &cfg),
            push(1, b, v(150.0, 170.0), &cfg),
            push(0, v(20.0, 40.0), v(40.0, 40.0), &cfg),
        ];
        let out = shorten_tip_travel(steps.clone(), &l, None, &cfg);
        let order = particles(&out);
        let first_a = order.iter().position(|&p| p == 0).unwrap();
        let Step::Push { from_m, .. } = &out[first_a] else {
            panic!()
        };
        assert_eq!(*from_m, a, "the buffer push stays first: {order:?}");
    }

    /// On a real CMU plan, the precomputed masks accept exactly the orders
    /// the replay accepts (orders near the planned one: random swaps of
    /// neighbouring moves, many valid, many not), and the search returns a
    /// valid order no longer than the scheduler's.
    #[test]
    fn blocking_masks_agree_with_the_replay_and_the_search_stays_valid() {
        use crate::plan::pattern::transform::{Reachable, place_optimised};
        use crate::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
        use crate::plan::{Pattern, plan_assembly};
        use rand::{RngExt, SeedableRng};
        let cfg = PlanConfig::default();
        let layout = synth_layout(&SynthParams::cmu_field(50, LayoutKind::Uniform, 3)).unwrap();
        let pattern = Pattern::from_text("CMU", 10.5e-6).unwrap();
        let pts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        let sites = place_optimised(
            &pattern,
            &Reachable::for_field(layout.field_m, 5e-6),
            5e-6,
            &pts,
        )
        .unwrap();
        let plan = plan_assembly(&layout, &sites, &cfg).unwrap();
        let steps: Vec<Step> = plan
            .steps
            .into_iter()
            .filter(|s| matches!(s, Step::Push { .. }))
            .collect();
        let moves = moves_of(&steps, &layout, &cfg).unwrap();
        let blocking = Blocking::new(&moves, &steps, &layout, &cfg).unwrap();
        let (lands, ends) = endpoints(&moves);
        let problem = PathProblem::new(&lands, &ends, None, &blocking);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let (mut valid, mut invalid) = (0, 0);
        for _ in 0..400 {
            let mut order = identity(moves.len());
            for _ in 0..rng.random_range(1..6) {
                let k = rng.random_range(0..order.len() - 1);
                order.swap(k, k + 1);
            }
            let replay = collision_free(&steps, &moves, &layout, &cfg, &order);
            assert_eq!(problem.valid(&order), replay, "order {order:?}");
            if replay { valid += 1 } else { invalid += 1 }
        }
        assert!(
            valid > 20 && invalid > 20,
            "valid {valid}, invalid {invalid}"
        );
        let given = identity(moves.len());
        let best = shortest_path(&problem, given.clone(), budget());
        assert!(problem.valid(&best));
        assert!(collision_free(&steps, &moves, &layout, &cfg, &best));
        assert!(problem.travel(&best) <= problem.travel(&given) + 1e-12);
    }

    /// Each relaxation drops its own class of constraint and keeps the
    /// others: move 0 crosses particle 1's start, move 3 crosses particle
    /// 2's final place, move 4 crosses particle 4, which never moves.
    #[test]
    fn each_relaxation_drops_only_its_own_constraints() {
        let cfg = PlanConfig::default();
        let l = layout(&[
            v(20.0, 50.0),
            v(50.0, 50.0),
            v(120.0, 180.0),
            v(80.0, 140.0),
            v(170.0, 60.0),
            v(170.0, 20.0),
        ]);
        let steps = [
            push(0, v(20.0, 50.0), v(90.0, 50.0), &cfg),
            push(1, v(50.0, 50.0), v(50.0, 110.0), &cfg),
            push(2, v(120.0, 180.0), v(120.0, 140.0), &cfg),
            push(3, v(80.0, 140.0), v(160.0, 140.0), &cfg),
            push(5, v(170.0, 20.0), v(170.0, 100.0), &cfg),
        ];
        let moves = moves_of(&steps, &l, &cfg).unwrap();
        let full = Blocking::new(&moves, &steps, &l, &cfg).unwrap();
        let allowed = |b: &Blocking, order: &[usize]| b.allows(order, &mut [0; 6]);
        let starts = full.relaxed(Relaxation::MovingStarts);
        let finals = full.relaxed(Relaxation::FinalPlaces);
        let none = full.relaxed(Relaxation::Collisions);
        for b in [&full, &starts, &finals, &none] {
            assert!(allowed(b, &[1, 0, 3, 2]), "the valid order is refused");
        }
        assert!(!allowed(&full, &[0, 1]) && !allowed(&finals, &[0, 1]));
        assert!(allowed(&starts, &[0, 1]) && allowed(&none, &[0, 1]));
        assert!(!allowed(&full, &[2, 3]) && !allowed(&starts, &[2, 3]));
        assert!(allowed(&finals, &[2, 3]) && allowed(&none, &[2, 3]));
        for b in [&full, &starts, &finals] {
            assert!(
                !allowed(b, &[4]),
                "an idle particle's constraint was dropped"
            );
        }
        assert!(allowed(&none, &[4]));
    }
}
