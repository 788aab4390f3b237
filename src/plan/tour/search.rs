//! Shortest tip path through the moves under the collision constraints: a
//! sequential-ordering problem (asymmetric TSP path with precedences).
//!
//! Or-opt (a run of one to three moves taken out and put back elsewhere,
//! first improvement) to a local optimum, then iterated local search: a
//! double bridge (two neighbouring runs swapped) kicks the best order, the
//! local search descends again, and the result is kept when shorter. Every
//! candidate order is tested with [`Blocking`] (no replay), so thousands fit
//! in the planning budget. The work is counted, not timed, so a seed gives
//! the same plan on any machine.
//!
//! Written by hand: the Rust TSP crates found handle symmetric tours without
//! side constraints; the precedence-and-collision test is ours.

use super::blocking::Blocking;
use nalgebra::Vector2;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Longest run of moves relocated at once.
const MAX_RUN: usize = 3;
/// Up to this many moves every insertion place is tried; above it only the
/// places next to the [`NEIGHBOURS`] nearest moves, at most [`MAX_SHIFT`] away.
const FULL_SCAN_MAX_MOVES: usize = 200;
/// Places tried per run on large plans.
const NEIGHBOURS: usize = 16;
/// Farthest a run is moved on large plans (moves).
const MAX_SHIFT: usize = 60;
/// Longest run a kick swaps.
const KICK_RUN: usize = 6;
/// Random kicks tried for one that keeps the order valid.
const KICK_TRIES: usize = 40;

/// The tip's path problem: move k is entered at `lands[k]` and left at `ends[k]`.
pub struct PathProblem<'a> {
    /// Where the tip lands for each move's first push.
    pub lands: &'a [Vector2<f64>],
    /// Where the tip lifts after each move's last push.
    pub ends: &'a [Vector2<f64>],
    /// The tip's start (None: free, the first landing costs nothing).
    pub start: Option<Vector2<f64>>,
    /// Which orders are valid.
    pub blocking: &'a Blocking,
}

impl PathProblem<'_> {
    /// Tip travel into move `to` after `from` (None: from the start).
    pub fn hop(&self, from: Option<usize>, to: usize) -> f64 {
        match from {
            Some(f) => (self.lands[to] - self.ends[f]).norm(),
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

    /// True when `order[lo..hi]` is valid after `order[..lo]` (assumed valid).
    fn valid_window(&self, order: &[usize], lo: usize, hi: usize) -> bool {
        let mut state = self.blocking.states_after(&order[..lo]);
        self.blocking.allows(&order[lo..hi], &mut state)
    }
}

/// How much search [`shortest_path`] may do, in gain evaluations.
#[derive(Debug, Clone, Copy)]
pub struct SearchBudget {
    /// Gain evaluations, in total (about 2-3 ns each).
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
    let near = Neighbours::new(problem, n);
    let mut work = 0usize;
    let mut best = order;
    or_opt(problem, &near, &mut best, &mut work, budget.evaluations);
    let mut best_travel = problem.travel(&best);
    let mut rng = ChaCha8Rng::seed_from_u64(budget.seed);
    while work < budget.evaluations {
        let Some(mut cand) = kick(problem, &best, &mut rng) else {
            break;
        };
        work += n;
        or_opt(problem, &near, &mut cand, &mut work, budget.evaluations);
        let t = problem.travel(&cand);
        if t < best_travel - 1e-12 {
            best = cand;
            best_travel = t;
        }
    }
    best
}

/// Insertion places to try on large plans.
struct Neighbours {
    /// Per move: the moves whose ends are nearest its landing.
    ends_near_landing: Vec<Vec<usize>>,
    /// Per move: the moves whose landings are nearest its end.
    landings_near_end: Vec<Vec<usize>>,
}

impl Neighbours {
    fn new(p: &PathProblem, n: usize) -> Option<Self> {
        if n <= FULL_SCAN_MAX_MOVES {
            return None;
        }
        use crate::plan::grid::Grid;
        let ends = Grid::new(p.ends.iter().copied(), 0.0);
        let lands = Grid::new(p.lands.iter().copied(), 0.0);
        let nearest = |grid: &Grid, q: Vector2<f64>| -> Vec<usize> {
            grid.nearest(q, NEIGHBOURS)
                .into_iter()
                .map(|(_, i)| i)
                .collect()
        };
        Some(Neighbours {
            ends_near_landing: p.lands.iter().map(|&l| nearest(&ends, l)).collect(),
            landings_near_end: p.ends.iter().map(|&e| nearest(&lands, e)).collect(),
        })
    }
}

/// Or-opt to a local optimum (or until `work` reaches `limit`).
fn or_opt(
    p: &PathProblem,
    near: &Option<Neighbours>,
    order: &mut Vec<usize>,
    work: &mut usize,
    limit: usize,
) {
    let n = order.len();
    let mut at = vec![0; n];
    let mut places: Vec<usize> = Vec::new();
    let mut scratch: Vec<usize> = Vec::with_capacity(n);
    let mut improved = true;
    let mut stale = true;
    while improved && *work < limit {
        improved = false;
        for len in 1..=MAX_RUN.min(n - 1) {
            let mut i = 0;
            while i + len <= n {
                places.clear();
                match near {
                    None => places.extend(0..=n),
                    Some(nb) => {
                        if stale {
                            for (k, &m) in order.iter().enumerate() {
                                at[m] = k;
                            }
                            stale = false;
                        }
                        let (first, last) = (order[i], order[i + len - 1]);
                        places.extend(nb.ends_near_landing[first].iter().map(|&u| at[u] + 1));
                        places.extend(nb.landings_near_end[last].iter().map(|&w| at[w]));
                        places.extend([0, n]);
                        places.retain(|&j| j.abs_diff(i) <= MAX_SHIFT);
                    }
                }
                *work += places.len();
                let mut moved = false;
                for &j in &places {
                    if j >= i && j <= i + len {
                        continue;
                    }
                    if gain(p, order, i, len, j) <= 1e-12 {
                        continue;
                    }
                    relocate_into(order, i, len, j, &mut scratch);
                    let (lo, hi) = (i.min(j), (i + len).max(j));
                    if p.valid_window(&scratch, lo, hi) {
                        std::mem::swap(order, &mut scratch);
                        improved = true;
                        stale = true;
                        moved = true;
                        break;
                    }
                }
                if !moved {
                    i += 1;
                }
                if *work >= limit {
                    return;
                }
            }
        }
    }
}

/// Travel saved by moving the run `order[i..i + len]` to before position
/// `j` of the original order (j outside the run).
fn gain(p: &PathProblem, order: &[usize], i: usize, len: usize, j: usize) -> f64 {
    let n = order.len();
    let get = |k: usize| (k < n).then(|| order[k]);
    let before = |k: usize| k.checked_sub(1).map(|k| order[k]);
    let (first, last) = (order[i], order[i + len - 1]);
    let (a, b) = (before(i), get(i + len));
    let mut g = p.hop(a, first) + b.map_or(0.0, |b| p.hop(Some(last), b));
    g -= b.map_or(0.0, |b| p.hop(a, b));
    let (a, b) = (before(j), get(j));
    g += b.map_or(0.0, |b| p.hop(a, b));
    g -= p.hop(a, first) + b.map_or(0.0, |b| p.hop(Some(last), b));
    g
}

/// Writes into `out` the order with the run `order[i..i + len]` moved to
/// before position `j`.
fn relocate_into(order: &[usize], i: usize, len: usize, j: usize, out: &mut Vec<usize>) {
    out.clear();
    for (k, &m) in order.iter().enumerate() {
        if k == j {
            out.extend_from_slice(&order[i..i + len]);
        }
        if k < i || k >= i + len {
            out.push(m);
        }
    }
    if j == order.len() {
        out.extend_from_slice(&order[i..i + len]);
    }
}

/// A valid order with two neighbouring runs swapped (a double bridge that
/// keeps every move's direction), or None when no try was valid.
fn kick(p: &PathProblem, order: &[usize], rng: &mut ChaCha8Rng) -> Option<Vec<usize>> {
    let n = order.len();
    for _ in 0..KICK_TRIES {
        let l1 = rng.random_range(1..=KICK_RUN.min(n - 1));
        let l2 = rng.random_range(1..=KICK_RUN.min(n - l1));
        let a = rng.random_range(0..=n - l1 - l2);
        let (b, c) = (a + l1, a + l1 + l2);
        let mut out = Vec::with_capacity(n);
        out.extend_from_slice(&order[..a]);
        out.extend_from_slice(&order[b..c]);
        out.extend_from_slice(&order[a..b]);
        out.extend_from_slice(&order[c..]);
        if p.valid_window(&out, a, c) {
            return Some(out);
        }
    }
    None
}
