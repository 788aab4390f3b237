//! Shortest tip path through the moves under the collision constraints: a
//! sequential-ordering problem (asymmetric TSP path with precedences).
//!
//! Local search by segment swaps (two neighbouring runs of moves exchanged,
//! each keeping its direction: the path-preserving 3-exchange of
//! Gambardella and Dorigo's SOP-3-exchange, which contains Or-opt), first
//! improvement, to a local optimum; then iterated local search: a random
//! swap kicks the best order, the local search descends again, and the
//! result is kept when shorter. For a fixed start of the two runs the second
//! run is grown one move at a time from the particle states there, so the
//! growth stops at its first move that could not run (every longer run
//! fails the same way). Every order is tested with [`Blocking`] (no replay),
//! so thousands fit in the planning budget. Work is counted, not timed, so
//! a seed gives the same plan on any machine.
//!
//! Written by hand: the Rust TSP crates found solve symmetric tours without
//! side constraints; the precedence-and-collision test is ours.

use super::blocking::Blocking;
use nalgebra::Vector2;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Up to this many moves, runs of any length are swapped; above it one of
/// the two runs is at most [`SHORT_RUN`] moves and the other at most
/// [`LONG_RUN`] (a sweep stays linear in the moves).
const FULL_SCAN_MAX_MOVES: usize = 200;
/// The short run on large plans.
const SHORT_RUN: usize = 3;
/// The long run on large plans.
const LONG_RUN: usize = 60;
/// Longest run a kick swaps.
const KICK_RUN: usize = 6;
/// Random kicks tried for one that keeps the order valid.
const KICK_TRIES: usize = 40;

/// The tip's path problem: move k is entered at `lands[k]` and left at `ends[k]`.
pub struct PathProblem<'a> {
    /// Where the tip lands for each move's first push.
    lands: &'a [Vector2<f64>],
    /// Where the tip lifts after each move's last push.
    ends: &'a [Vector2<f64>],
    /// The tip's start (None: free, the first landing costs nothing).
    start: Option<Vector2<f64>>,
    /// Which orders are valid.
    pub blocking: &'a Blocking,
    /// Hop lengths `ends[i] -> lands[j]` at `i * n + j`, on plans of at most
    /// [`FULL_SCAN_MAX_MOVES`] moves (a lookup is several times cheaper than
    /// the square root, and the full scan evaluates many).
    hops: Vec<f64>,
}

impl<'a> PathProblem<'a> {
    /// The problem of moves entered at `lands` and left at `ends` (same
    /// length as `blocking`'s moves), the tip starting at `start`.
    pub fn new(
        lands: &'a [Vector2<f64>],
        ends: &'a [Vector2<f64>],
        start: Option<Vector2<f64>>,
        blocking: &'a Blocking,
    ) -> Self {
        let n = lands.len();
        let hops = if n <= FULL_SCAN_MAX_MOVES {
            ends.iter()
                .flat_map(|e| lands.iter().map(move |l| (l - e).norm()))
                .collect()
        } else {
            Vec::new()
        };
        PathProblem {
            lands,
            ends,
            start,
            blocking,
            hops,
        }
    }

    /// Tip travel into move `to` after `from` (None: from the start).
    pub fn hop(&self, from: Option<usize>, to: usize) -> f64 {
        match from {
            Some(f) if self.hops.is_empty() => (self.lands[to] - self.ends[f]).norm(),
            Some(f) => self.hops[f * self.lands.len() + to],
            None => self.start.map_or(0.0, |s| (self.lands[to] - s).norm()),
        }
    }

    /// Tip travel between the moves of `order` (from the start).
    pub fn travel(&self, order: &[usize]) -> f64 {
        let mut prev = None;
        let mut total = 0.0;
        for &m in order {
            total += self.hop(prev, m);
            prev = Some(m);
        }
        total
    }

    /// True when the whole order is valid.
    pub fn valid(&self, order: &[usize]) -> bool {
        let mut state = self.blocking.states_after(&[]);
        order.len() == self.blocking.len() && self.blocking.allows(order, &mut state)
    }
}

/// How much search [`shortest_path`] may do.
#[derive(Debug, Clone, Copy)]
pub struct SearchBudget {
    /// Candidate orders looked at, in total.
    pub evaluations: usize,
    /// Seed of the kicks.
    pub seed: u64,
}

/// Shortens `order` (valid for `problem`) within `budget`; returns a valid
/// order no longer than the given one.
pub fn shortest_path(problem: &PathProblem, order: Vec<usize>, budget: SearchBudget) -> Vec<usize> {
    let n = order.len();
    if n < 3 {
        return order;
    }
    let mut work = 0usize;
    let mut best = order;
    segment_swaps(problem, &mut best, &mut work, budget.evaluations);
    let mut best_travel = problem.travel(&best);
    let mut rng = ChaCha8Rng::seed_from_u64(budget.seed);
    let constructions = if n <= FULL_SCAN_MAX_MOVES {
        CONSTRUCTIONS
    } else {
        0
    };
    for k in 0..constructions {
        let noise = if k == 0 { 0.0 } else { CONSTRUCTION_NOISE };
        let Some(mut cand) = construct(problem, &mut rng, noise) else {
            work += n * n;
            continue;
        };
        work += n * n;
        segment_swaps(problem, &mut cand, &mut work, budget.evaluations);
        let t = problem.travel(&cand);
        if t < best_travel - 1e-12 {
            best = cand;
            best_travel = t;
        }
    }
    while work < budget.evaluations {
        let Some(mut cand) = kick(problem, &best, &mut rng) else {
            break;
        };
        work += n;
        segment_swaps(problem, &mut cand, &mut work, budget.evaluations);
        let t = problem.travel(&cand);
        if t < best_travel - 1e-12 {
            best = cand;
            best_travel = t;
        }
    }
    best
}

/// Travel saved by swapping the runs `order[a..b]` and `order[b..c]`.
fn swap_gain(p: &PathProblem, order: &[usize], a: usize, b: usize, c: usize) -> f64 {
    let prev = a.checked_sub(1).map(|k| order[k]);
    let next = order.get(c).copied();
    let (a0, a1, b0, b1) = (order[a], order[b - 1], order[b], order[c - 1]);
    let old = p.hop(prev, a0) + p.hop(Some(a1), b0) + next.map_or(0.0, |x| p.hop(Some(b1), x));
    let new = p.hop(prev, b0) + p.hop(Some(b1), a0) + next.map_or(0.0, |x| p.hop(Some(a1), x));
    old - new
}

/// Segment swaps to a local optimum (or until `work` reaches `limit`).
fn segment_swaps(p: &PathProblem, order: &mut [usize], work: &mut usize, limit: usize) {
    let n = order.len();
    let full = n <= FULL_SCAN_MAX_MOVES;
    let bl = p.blocking;
    let mut improved = true;
    while improved && *work < limit {
        improved = false;
        // Particle states after order[..a].
        let mut state = bl.states_after(&[]);
        let mut a = 0;
        'a: while a + 1 < n {
            let max_a = if full { n } else { LONG_RUN };
            for b in a + 1..(a + 1 + max_a).min(n) {
                let max_b = match (full, b - a <= SHORT_RUN) {
                    (true, _) => n,
                    (false, true) => LONG_RUN,
                    (false, false) => SHORT_RUN,
                };
                // Grow the run B = order[b..c] from the states after order[..a].
                let mut c = b;
                let mut swapped = false;
                while c < (b + max_b).min(n) {
                    let m = order[c];
                    if !bl.allows_next(m, &state) {
                        break;
                    }
                    state[bl.particle_of(m)] += 1;
                    c += 1;
                    *work += 1;
                    if swap_gain(p, order, a, b, c) > 1e-12
                        && runs_after(bl, &order[a..b], &mut state)
                    {
                        order[a..c].rotate_left(b - a);
                        swapped = true;
                        break;
                    }
                }
                // Undo B's moves: the states are again those after order[..a]
                // (a swap keeps the moves of order[..a] where they were).
                let run = if swapped {
                    &order[a..a + c - b]
                } else {
                    &order[b..c]
                };
                for &m in run {
                    state[bl.particle_of(m)] -= 1;
                }
                if swapped {
                    improved = true;
                    continue 'a;
                }
                if *work >= limit {
                    return;
                }
            }
            state[bl.particle_of(order[a])] += 1;
            a += 1;
        }
    }
}

/// True when the moves of `run` can run one after another from `state`;
/// `state` is left as it was.
fn runs_after(bl: &Blocking, run: &[usize], state: &mut [u8]) -> bool {
    let mut done = 0;
    let mut ok = true;
    for &m in run {
        if !bl.allows_next(m, state) {
            ok = false;
            break;
        }
        state[bl.particle_of(m)] += 1;
        done += 1;
    }
    for &m in &run[..done] {
        state[bl.particle_of(m)] -= 1;
    }
    ok
}

/// Greedy orders built (the first without noise) before the kicks, on
/// plans of at most [`FULL_SCAN_MAX_MOVES`] moves (each costs O(n^3)).
const CONSTRUCTIONS: usize = 4;
/// Relative noise on the hop lengths a randomised greedy order compares.
const CONSTRUCTION_NOISE: f64 = 0.5;

/// A valid order built greedily: the tip goes next to the nearest move that
/// may run now (hop lengths scaled by a random factor up to 1 + `noise`),
/// skipping those after which some remaining move could never run; None
/// when that dead-ends.
fn construct(p: &PathProblem, rng: &mut ChaCha8Rng, noise: f64) -> Option<Vec<usize>> {
    let bl = p.blocking;
    let n = bl.len();
    let mut state = bl.states_after(&[]);
    let mut remaining: Vec<usize> = (0..n).collect();
    let mut order = Vec::with_capacity(n);
    let mut prev = None;
    while !remaining.is_empty() {
        let mut scored: Vec<(f64, usize)> = remaining
            .iter()
            .enumerate()
            .filter(|&(_, &m)| bl.allows_next(m, &state))
            .map(|(k, &m)| {
                let f = if noise > 0.0 {
                    1.0 + noise * rng.random::<f64>()
                } else {
                    1.0
                };
                (p.hop(prev, m) * f, k)
            })
            .collect();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut chosen = None;
        for &(_, k) in &scored {
            let m = remaining[k];
            let q = bl.particle_of(m);
            state[q] += 1;
            let keeps_all = remaining
                .iter()
                .all(|&x| x == m || bl.may_still_run(x, q, &state));
            if keeps_all {
                chosen = Some(k);
                break;
            }
            state[q] -= 1;
        }
        let k = chosen?;
        let m = remaining.swap_remove(k);
        order.push(m);
        prev = Some(m);
    }
    Some(order)
}

/// A valid order with two neighbouring short runs swapped (a double bridge
/// that keeps every move's direction), or None when no try was valid.
fn kick(p: &PathProblem, order: &[usize], rng: &mut ChaCha8Rng) -> Option<Vec<usize>> {
    let n = order.len();
    for _ in 0..KICK_TRIES {
        let l1 = rng.random_range(1..=KICK_RUN.min(n - 1));
        let l2 = rng.random_range(1..=KICK_RUN.min(n - l1));
        let a = rng.random_range(0..=n - l1 - l2);
        let mut out = order.to_vec();
        out[a..a + l1 + l2].rotate_left(l1);
        let mut state = p.blocking.states_after(&out[..a]);
        if p.blocking.allows(&out[a..a + l1 + l2], &mut state) {
            return Some(out);
        }
    }
    None
}
