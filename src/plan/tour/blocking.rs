//! Which orders of the moves replay free of collisions, decided without
//! replaying them.
//!
//! A particle's position at any point of an order is fixed by how many of
//! its own moves have run (its *state*), because each particle's moves keep
//! their order. So a move collides exactly when some other particle is then
//! in a state whose position its corridor hits. Those states are found once
//! per (move, particle) pair with the same corridor test as the replay
//! ([`Corridor::hits`]); checking an order is then a scan of small bit masks,
//! cheap enough for a local search to test thousands of orders.

use super::Move;
use crate::plan::grid::Grid;
use crate::plan::layout::Layout;
use crate::plan::pushes::Corridor;
use crate::plan::{PlanConfig, Step};

/// Most moves of one particle a state mask can hold.
pub const MAX_MOVES_PER_PARTICLE: usize = 63;

/// The collision constraints of a set of moves.
#[derive(Debug, Clone)]
pub struct Blocking {
    /// Per move: (other particle, bit mask of its states the move collides with).
    blocked_by: Vec<Vec<(usize, u64)>>,
    /// Per move: its rank among its particle's moves (the state its particle
    /// must be in when it runs).
    rank: Vec<u8>,
    /// Per move: its particle.
    particle: Vec<usize>,
    /// Number of particles (size of a state vector).
    particles: usize,
    /// Per particle: its number of moves (its last state).
    last_state: Vec<u8>,
}

impl Blocking {
    /// Constraints of `moves` (in a valid order: each particle's moves in
    /// sequence) over `layout`; None when a particle has more than
    /// [`MAX_MOVES_PER_PARTICLE`] moves or a step is not a push.
    pub fn new(
        moves: &[Move],
        steps: &[Step],
        layout: &Layout,
        config: &PlanConfig,
    ) -> Option<Self> {
        let np = layout.particles.len();
        let mut rank = Vec::with_capacity(moves.len());
        let mut count = vec![0usize; np];
        // State positions: (particle, state) -> centre; state 0 is the layout's.
        let mut states: Vec<(usize, usize)> = (0..np).map(|q| (q, 0)).collect();
        let mut points: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        for m in moves {
            count[m.particle] += 1;
            if count[m.particle] > MAX_MOVES_PER_PARTICLE {
                return None;
            }
            rank.push((count[m.particle] - 1) as u8);
            let Step::Push { to_m, .. } = steps[m.pushes.end - 1] else {
                return None;
            };
            states.push((m.particle, count[m.particle]));
            points.push(to_m);
        }
        let max_radius = layout.max_radius_m();
        let grid = Grid::new(points.iter().copied(), 2.0 * max_radius);
        let mut blocked_by = Vec::with_capacity(moves.len());
        for m in moves {
            let mut masks: Vec<(usize, u64)> = Vec::new();
            for i in m.pushes.clone() {
                let Step::Push { from_m, to_m, .. } = steps[i] else {
                    return None;
                };
                let radius = layout.particles[m.particle].radius_m;
                let c = Corridor::new(from_m, to_m, radius, config);
                let (a, b, r) = c.spine_m;
                grid.for_each_near_segment(a, b, r + max_radius + config.clearance_m, |k| {
                    let (q, s) = states[k];
                    if q != m.particle
                        && c.hits(points[k], layout.particles[q].radius_m, config.clearance_m)
                    {
                        match masks.iter_mut().find(|e| e.0 == q) {
                            Some(e) => e.1 |= 1u64 << s,
                            None => masks.push((q, 1u64 << s)),
                        }
                    }
                    true
                });
            }
            blocked_by.push(masks);
        }
        Some(Blocking {
            last_state: count.iter().map(|&c| c as u8).collect(),
            blocked_by,
            rank,
            particle: moves.iter().map(|m| m.particle).collect(),
            particles: np,
        })
    }

    /// Particle states after the moves `done` (a prefix of an order).
    pub fn states_after(&self, done: &[usize]) -> Vec<u8> {
        let mut state = vec![0u8; self.particles];
        for &m in done {
            state[self.particle[m]] += 1;
        }
        state
    }

    /// True when `order[lo..hi]`, run from the states `state` (those after
    /// `order[..lo]`), keeps every particle's moves in sequence and collides
    /// with nothing. `state` is advanced past the checked moves (left
    /// partly advanced when false).
    pub fn allows(&self, order: &[usize], state: &mut [u8]) -> bool {
        for &m in order {
            if !self.allows_next(m, state) {
                return false;
            }
            state[self.particle[m]] += 1;
        }
        true
    }

    /// True when move `m` may run next from `state` (its particle's previous
    /// moves done, no particle in a state it collides with).
    pub fn allows_next(&self, m: usize, state: &[u8]) -> bool {
        state[self.particle[m]] == self.rank[m]
            && self.blocked_by[m]
                .iter()
                .all(|&(q, mask)| mask & (1u64 << state[q]) == 0)
    }

    /// False when move `j` can never run right after move `i`: the same move,
    /// not the next of the same particle, or colliding with `i`'s particle
    /// where `i` leaves it.
    pub fn may_follow(&self, i: usize, j: usize) -> bool {
        let q = self.particle[i];
        let after_i = self.rank[i] + 1;
        if q == self.particle[j] {
            return self.rank[j] == after_i;
        }
        self.blocked_by[j]
            .iter()
            .all(|&(p, mask)| p != q || mask & (1u64 << after_i) == 0)
    }

    /// True when move `m` could still run from `state` as far as particle
    /// `q` goes: some state `q` has yet to pass through is not one `m`
    /// collides with (a necessary condition only).
    pub fn may_still_run(&self, m: usize, q: usize, state: &[u8]) -> bool {
        self.blocked_by[m].iter().all(|&(p, mask)| {
            p != q || (state[q]..=self.last_state[q]).any(|s| mask & (1u64 << s) == 0)
        })
    }

    /// The particle move `m` pushes.
    pub fn particle_of(&self, m: usize) -> usize {
        self.particle[m]
    }

    /// Number of moves.
    pub fn len(&self) -> usize {
        self.rank.len()
    }

    /// True when there is no move.
    pub fn is_empty(&self) -> bool {
        self.rank.is_empty()
    }
}

/// Which constraints a study's relaxed tour ignores, to show what each one
/// costs in tip travel (docs/plan-history.md, the eleventh and twenty-third passes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Relaxation {
    /// Every collision: only each particle's own moves keep their sequence.
    Collisions,
    /// A moving particle where it starts: the ceiling of any first leg that
    /// takes particles out of other pushes' way, were such legs free.
    MovingStarts,
    /// A moving particle where its last move leaves it (a filled site, or
    /// its parking spot).
    FinalPlaces,
}

impl Blocking {
    /// The same moves with the constraints `relaxation` names dropped.
    pub fn relaxed(&self, relaxation: Relaxation) -> Blocking {
        let dropped = |q: usize| -> u64 {
            let last = self.last_state[q];
            match relaxation {
                Relaxation::Collisions => u64::MAX,
                Relaxation::MovingStarts if last > 0 => 1,
                Relaxation::FinalPlaces if last > 0 => 1u64 << last,
                _ => 0,
            }
        };
        let blocked_by = self
            .blocked_by
            .iter()
            .map(|masks| {
                masks
                    .iter()
                    .map(|&(q, mask)| (q, mask & !dropped(q)))
                    .filter(|&(_, mask)| mask != 0)
                    .collect()
            })
            .collect();
        Blocking {
            blocked_by,
            ..self.clone()
        }
    }
}
