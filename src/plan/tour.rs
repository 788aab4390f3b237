//! Shorter tip travel: the scheduler's order, reordered while it stays
//! collision-free.
//!
//! The scheduler takes the ready move nearest the tip, one at a time; on
//! CMU its tip travel between moves was about twice the assignment bound,
//! and relocating moves freely (ignoring collisions) removed about 40 % of
//! it. This pass does the relocating that stays safe: Or-opt (a run of one
//! to three moves taken out and put back elsewhere) over candidate places
//! next to the moves whose ends are nearest, each accepted only when the
//! pushes it reorders still start where their particles are and miss every
//! particle where it then is. A move is the run of consecutive pushes of one
//! particle (a route's legs stay together).

use super::grid::Grid;
use super::layout::Layout;
use super::occupancy::Occupancy;
use super::pushes::{Corridor, landing_point, tip_end};
use super::{PlanConfig, Step};
use nalgebra::Vector2;

/// Longest run of moves relocated at once.
const MAX_RUN: usize = 3;
/// Places tried for each run: after the moves whose ends are nearest its
/// landing, and before those whose landings are nearest its end.
const NEIGHBOURS: usize = 16;
/// Farthest a run is moved in the sequence (moves), which bounds the
/// pushes replayed per check at large N.
const MAX_SHIFT: usize = 60;
/// Rounds of improvement, at most.
const MAX_ROUNDS: usize = 100;

/// A run of consecutive pushes of one particle.
#[derive(Debug, Clone)]
struct Move {
    particle: usize,
    /// Indices into the original push list.
    pushes: std::ops::Range<usize>,
    land: Vector2<f64>,
    end: Vector2<f64>,
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
    if moves.len() < 3 {
        return steps;
    }
    let ends = Grid::new(moves.iter().map(|m| m.end), 0.0);
    let lands = Grid::new(moves.iter().map(|m| m.land), 0.0);
    let nearest = |grid: &Grid, p: Vector2<f64>| -> Vec<usize> {
        grid.nearest(p, NEIGHBOURS)
            .into_iter()
            .map(|(_, i)| i)
            .collect()
    };
    let tour = Tour {
        steps: &steps,
        ends_near_landing: moves.iter().map(|m| nearest(&ends, m.land)).collect(),
        landings_near_end: moves.iter().map(|m| nearest(&lands, m.end)).collect(),
        moves,
        layout,
        config,
        start: tip_start,
    };
    let mut order: Vec<usize> = (0..tour.moves.len()).collect();
    if !tour.collision_free(&order, 0, order.len()) {
        return steps;
    }
    for _ in 0..MAX_ROUNDS {
        if !tour.improve_once(&mut order) {
            break;
        }
    }
    let mut out = Vec::with_capacity(steps.len());
    for &m in &order {
        out.extend(tour.moves[m].pushes.clone().map(|i| steps[i].clone()));
    }
    out
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

struct Tour<'a> {
    steps: &'a [Step],
    moves: Vec<Move>,
    /// Per move: the moves whose tip ends are nearest its landing, and
    /// those whose landings are nearest its end (the places to try).
    ends_near_landing: Vec<Vec<usize>>,
    landings_near_end: Vec<Vec<usize>>,
    layout: &'a Layout,
    config: &'a PlanConfig,
    start: Option<Vector2<f64>>,
}

impl Tour<'_> {
    /// Tip travel into move `to` after move `from` (or from the start).
    fn hop(&self, from: Option<usize>, to: usize) -> f64 {
        match from {
            Some(f) => (self.moves[to].land - self.moves[f].end).norm(),
            None => self.start.map_or(0.0, |s| (self.moves[to].land - s).norm()),
        }
    }

    /// Tip travel of the whole order.
    fn travel(&self, order: &[usize]) -> f64 {
        let mut prev = None;
        let mut total = 0.0;
        for &m in order {
            total += self.hop(prev, m);
            prev = Some(m);
        }
        total
    }

    /// One accepted relocation (the best-gaining one that stays free of
    /// collisions and keeps each particle's moves in order); false when
    /// none gains.
    fn improve_once(&self, order: &mut Vec<usize>) -> bool {
        let n = order.len();
        let mut at = vec![0; n];
        for (i, &m) in order.iter().enumerate() {
            at[m] = i;
        }
        let mut candidates: Vec<(f64, usize, usize, usize)> = Vec::new();
        for len in 1..=MAX_RUN.min(n - 1) {
            for i in 0..=n - len {
                let first = order[i];
                let last = order[i + len - 1];
                // Places: after a move whose end is near the run's landing,
                // or before one whose landing is near the run's end.
                let after = self.ends_near_landing[first].iter().map(|&u| at[u] + 1);
                let before = self.landings_near_end[last].iter().map(|&w| at[w]);
                for j in after.chain(before).chain([0, n]) {
                    if (j >= i && j <= i + len) || j.abs_diff(i) > MAX_SHIFT {
                        continue;
                    }
                    let gain = self.gain(order, i, len, j);
                    if gain > 1e-12 {
                        candidates.push((gain, i, len, j));
                    }
                }
            }
        }
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
        candidates.dedup_by(|a, b| a.1 == b.1 && a.2 == b.2 && a.3 == b.3);
        for &(_, i, len, j) in candidates.iter().take(4 * NEIGHBOURS) {
            let moved = relocated(order, i, len, j);
            let (lo, hi) = (i.min(j), (i + len).max(j));
            if self.collision_free(&moved, lo, hi) {
                debug_assert!(self.travel(&moved) < self.travel(order));
                *order = moved;
                return true;
            }
        }
        false
    }

    /// Travel saved by moving the run `order[i..i + len]` to before position
    /// `j` of the original order (j outside the run).
    fn gain(&self, order: &[usize], i: usize, len: usize, j: usize) -> f64 {
        let n = order.len();
        let get = |k: usize| (k < n).then(|| order[k]);
        let before = |k: usize| k.checked_sub(1).map(|k| order[k]);
        let (first, last) = (order[i], order[i + len - 1]);
        // Removing the run joins its neighbours.
        let (p, q) = (before(i), get(i + len));
        let mut gain = self.hop(p, first) + q.map_or(0.0, |q| self.hop(Some(last), q));
        gain -= q.map_or(0.0, |q| self.hop(p, q));
        // Inserting it between order[j - 1] and order[j].
        let (a, b) = (before(j), get(j));
        gain += b.map_or(0.0, |b| self.hop(a, b));
        gain -= self.hop(a, first) + b.map_or(0.0, |b| self.hop(Some(last), b));
        gain
    }

    /// True when every push of the moves in `order[lo..hi]` starts where its
    /// particle is at that moment (so each particle's moves keep their
    /// order) and misses every other particle where it then is.
    fn collision_free(&self, order: &[usize], lo: usize, hi: usize) -> bool {
        let mut occ = Occupancy::new(self.layout);
        for &m in &order[..lo] {
            let Step::Push { to_m, .. } = self.steps[self.moves[m].pushes.end - 1] else {
                continue;
            };
            occ.set(self.moves[m].particle, to_m);
        }
        for &m in &order[lo..hi.min(order.len())] {
            let p = self.moves[m].particle;
            for i in self.moves[m].pushes.clone() {
                let Step::Push { from_m, to_m, .. } = self.steps[i] else {
                    continue;
                };
                if (occ.pos[p] - from_m).norm() > 1e-12 {
                    return false;
                }
                let c = Corridor::new(from_m, to_m, occ.radius[p], self.config);
                if occ.first_hit(&c, p, self.config.clearance_m).is_some() {
                    return false;
                }
                occ.set(p, to_m);
            }
        }
        true
    }
}

/// The order with the run `order[i..i + len]` moved to before position `j`.
fn relocated(order: &[usize], i: usize, len: usize, j: usize) -> Vec<usize> {
    let run = &order[i..i + len];
    let mut out = Vec::with_capacity(order.len());
    for (k, &m) in order.iter().enumerate() {
        if k == j {
            out.extend_from_slice(run);
        }
        if k < i || k >= i + len {
            out.push(m);
        }
    }
    if j == order.len() {
        out.extend_from_slice(run);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::layout::Particle;
    use crate::plan::pushes::approach_point;

    const UM: f64 = 1e-6;

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x * UM, y * UM)
    }

    fn layout(centres: &[Vector2<f64>]) -> Layout {
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

    fn push(particle: u32, from: Vector2<f64>, to: Vector2<f64>, cfg: &PlanConfig) -> Step {
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
}
