//! The shortest tip path through the moves under the collision constraints,
//! solved exactly by dynamic programming over the sets of moves done.
//!
//! Why it can be exact: a particle's position is fixed by how many of its
//! own moves have run ([`super::blocking::Blocking`]), so whether a move may
//! run next depends only on the *set* of moves done, not on their order. The
//! least travel to have done the set `S` with move `m` last is then the
//! least over `l` in `S \ {m}` of the least travel to `(S \ {m}, l)` plus
//! the hop `l -> m` (Held-Karp for the sequential-ordering problem). Only
//! sets reachable under [`super::blocking::Blocking::allows_next`] are
//! expanded, layer by layer (layer k = the sets of k moves); on CMU's 30-37
//! moves that is 0.6-18 M sets of 2^31 or more (docs/plan-history.md, thirteenth
//! pass).
//!
//! Why a bound prunes: a state whose travel plus a lower bound on the rest
//! (`RestBound`: each move not done entered by its shortest hop from a
//! move not done, or left by its shortest hop out) exceeds a known valid
//! order's travel (the incumbent) is on no shorter path; dropping it keeps
//! the answer exact.
//!
//! Why a beam: when a layer still holds more than a cap of states, only the
//! cheapest are kept (and the incumbent's own prefix, so the answer is never
//! longer than the incumbent); the answer is then a valid order but not
//! proven optimal, and [`ExactTour::exact`] says so. The cap counts states,
//! not time, so a seed gives the same order on any machine.
//!
//! Used by the tour study (`tour::study`) to measure how far the local
//! search ([`super::search`]) is from the constrained optimum: on CMU, not
//! far (the product keeps the search; docs/plan.md).

use super::search::PathProblem;
use rustc_hash::FxHashMap;

/// Most moves a set of moves done can hold (one bit each).
pub const MAX_MOVES: usize = 128;

/// How much work [`optimal_path`] may do.
#[derive(Debug, Clone, Copy)]
pub struct DpBudget {
    /// States (set, last move) a layer may hold before it is cut to a beam.
    pub max_layer_states: usize,
    /// States a cut layer keeps (the cheapest).
    pub beam: usize,
    /// Drop states that cannot beat the incumbent (exact either way; off
    /// only to count every reachable state).
    pub prune: bool,
}

/// The answer of [`optimal_path`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExactTour {
    /// A valid order of the moves.
    pub order: Vec<usize>,
    /// Its tip travel (hops only, as [`PathProblem::travel`]).
    pub travel_m: f64,
    /// True when no layer was cut: `travel_m` is the least of every valid order.
    pub exact: bool,
    /// States kept per layer (layer k: k moves done), after pruning and cuts.
    pub states_per_layer: Vec<usize>,
    /// Distinct sets of moves done per layer, after pruning and cuts.
    pub sets_per_layer: Vec<usize>,
}

/// A state's last move, the move before it, and the least travel to it.
#[derive(Debug, Clone, Copy)]
struct Entry {
    last: u8,
    /// The last move of the predecessor state (`u8::MAX`: none, layer 1).
    prev: u8,
    cost: f64,
}

/// One layer: per set of moves done, its states (one per last move), as a
/// chain through one flat list (millions of sets: no list of their own each).
#[derive(Default)]
struct Layer {
    /// Per set, the index of its first state in `states`.
    heads: FxHashMap<u128, u32>,
    /// States, each with the index of the next state of its set (`u32::MAX`: none).
    states: Vec<(Entry, u32)>,
}

impl Layer {
    fn push(&mut self, set: u128, e: Entry) {
        let at = self.states.len() as u32;
        let head = self.heads.entry(set).or_insert(u32::MAX);
        self.states.push((e, *head));
        *head = at;
    }

    /// The states of the set whose chain starts at `head`.
    fn chain(&self, head: u32) -> impl Iterator<Item = &Entry> + '_ {
        let mut at = head;
        std::iter::from_fn(move || {
            let (e, next) = self.states.get(at as usize)?;
            at = *next;
            Some(e)
        })
    }
}

/// The least-travel valid order of `problem`'s moves, never longer than
/// `incumbent` (a valid order); None when there are more than
/// [`MAX_MOVES`] moves or `incumbent` is not a valid order.
pub fn optimal_path(
    problem: &PathProblem,
    incumbent: &[usize],
    budget: DpBudget,
) -> Option<ExactTour> {
    let bl = problem.blocking;
    let n = bl.len();
    if n > MAX_MOVES || !problem.valid(incumbent) {
        return None;
    }
    if n == 0 {
        return Some(ExactTour {
            order: Vec::new(),
            travel_m: 0.0,
            exact: true,
            states_per_layer: vec![1],
            sets_per_layer: vec![1],
        });
    }
    let upper = problem.travel(incumbent) * (1.0 + 1e-9);
    let hops = Hops::new(problem);
    let mut layers: Vec<Layer> = Vec::with_capacity(n + 1);
    let mut first = Layer::default();
    first.push(
        0,
        Entry {
            last: u8::MAX,
            prev: u8::MAX,
            cost: 0.0,
        },
    );
    layers.push(first);
    let mut exact = true;
    let mut state = bl.states_after(&[]);
    for k in 0..n {
        let mut next = Layer::default();
        let layer = &layers[k];
        for (&set, &head) in &layer.heads {
            state.iter_mut().for_each(|s| *s = 0);
            for m in (0..n).filter(|&m| set & bit(m) != 0) {
                state[bl.particle_of(m)] += 1;
            }
            let rest = budget.prune.then(|| RestBound::new(&hops, set));
            for m in (0..n).filter(|&m| set & bit(m) == 0) {
                if !bl.allows_next(m, &state) {
                    continue;
                }
                let best = layer
                    .chain(head)
                    .map(|e| (e.cost + problem.hop(last_of(e), m), e.last))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .expect("a kept set has a state");
                if rest.as_ref().is_some_and(|r| best.0 + r.after(m) > upper) {
                    continue;
                }
                next.push(
                    set | bit(m),
                    Entry {
                        last: m as u8,
                        prev: best.1,
                        cost: best.0,
                    },
                );
            }
        }
        if next.states.len() > budget.max_layer_states {
            exact = false;
            next = cut_to_beam(next, budget.beam, incumbent, k + 1);
        }
        layers.push(next);
    }
    let (&full, &head) = layers[n].heads.iter().next()?;
    debug_assert_eq!(full.count_ones() as usize, n);
    let end = layers[n]
        .chain(head)
        .min_by(|a, b| a.cost.total_cmp(&b.cost))?;
    let order = backtrack(&layers, full, *end);
    let travel_m = problem.travel(&order);
    Some(ExactTour {
        order,
        travel_m,
        exact,
        states_per_layer: layers.iter().map(|l| l.states.len()).collect(),
        sets_per_layer: layers.iter().map(|l| l.heads.len()).collect(),
    })
}

fn bit(m: usize) -> u128 {
    1u128 << m
}

fn last_of(e: &Entry) -> Option<usize> {
    (e.last != u8::MAX).then_some(e.last as usize)
}

/// Per move, the moves that may run right before it and right after it,
/// with the hop each way, shortest first (the start is not one: only the
/// first move uses it).
struct Hops {
    ways_in: Vec<Vec<(f64, usize)>>,
    ways_out: Vec<Vec<(f64, usize)>>,
}

impl Hops {
    fn new(problem: &PathProblem) -> Self {
        let bl = problem.blocking;
        let n = bl.len();
        let sorted = |mut w: Vec<(f64, usize)>| {
            w.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            w
        };
        let pairs = |j: usize| (0..n).filter(move |&i| i != j);
        Hops {
            ways_in: (0..n)
                .map(|j| {
                    let w = pairs(j).filter(|&i| bl.may_follow(i, j));
                    sorted(w.map(|i| (problem.hop(Some(i), j), i)).collect())
                })
                .collect(),
            ways_out: (0..n)
                .map(|i| {
                    let w = pairs(i).filter(|&j| bl.may_follow(i, j));
                    sorted(w.map(|j| (problem.hop(Some(i), j), j)).collect())
                })
                .collect(),
        }
    }
}

/// A lower bound on the rest of any order from the set `done`, per next
/// move `m`. After `m`, each other move not done is entered from a move
/// not done before `m` (`m` included): at least its shortest hop in from
/// those. And each move not done but the final one leaves to another move
/// not done: at least its shortest hop out to those, less the largest of
/// them. The larger of the two sums.
struct RestBound {
    /// Sum of the finite shortest hops in, and how many moves have none.
    in_sum: f64,
    in_none: usize,
    /// Per move not done, its shortest hop in (infinite: none).
    least_in: Vec<f64>,
    /// The bound from the hops out (infinite when two moves have none).
    out: f64,
}

impl RestBound {
    fn new(hops: &Hops, done: u128) -> Self {
        let least = |w: &Vec<(f64, usize)>| {
            w.iter()
                .find(|&&(_, i)| done & bit(i) == 0)
                .map_or(f64::INFINITY, |&(h, _)| h)
        };
        let n = hops.ways_in.len();
        let mut least_in = vec![0.0; n];
        let (mut in_sum, mut in_none) = (0.0, 0);
        let (mut out_sum, mut out_none, mut out_max) = (0.0, 0, 0.0f64);
        for j in (0..n).filter(|&j| done & bit(j) == 0) {
            least_in[j] = least(&hops.ways_in[j]);
            if least_in[j].is_finite() {
                in_sum += least_in[j];
            } else {
                in_none += 1;
            }
            let o = least(&hops.ways_out[j]);
            if o.is_finite() {
                out_sum += o;
                out_max = out_max.max(o);
            } else {
                out_none += 1;
            }
        }
        let out = match out_none {
            0 => out_sum - out_max,
            1 => out_sum,
            _ => f64::INFINITY,
        };
        RestBound {
            in_sum,
            in_none,
            least_in,
            out,
        }
    }

    /// The bound on the travel after `m` runs next.
    fn after(&self, m: usize) -> f64 {
        let own_none = usize::from(self.least_in[m].is_infinite());
        let ins = match self.in_none - own_none {
            0 if own_none == 1 => self.in_sum,
            0 => self.in_sum - self.least_in[m],
            _ => f64::INFINITY,
        };
        ins.max(self.out)
    }
}

/// Keeps the `beam` cheapest states of `layer` and the incumbent's state
/// after its first `done` moves (so the incumbent's path survives every cut).
fn cut_to_beam(layer: Layer, beam: usize, incumbent: &[usize], done: usize) -> Layer {
    let keep_set: u128 = incumbent[..done].iter().fold(0, |s, &m| s | bit(m));
    let keep_last = incumbent[done - 1] as u8;
    let mut all: Vec<(u128, Entry)> = layer
        .heads
        .iter()
        .flat_map(|(&set, &head)| layer.chain(head).map(move |&e| (set, e)))
        .collect();
    // Ties broken by the set and the last move: the same beam on any machine.
    all.sort_by(|a, b| {
        a.1.cost
            .total_cmp(&b.1.cost)
            .then(a.0.cmp(&b.0))
            .then(a.1.last.cmp(&b.1.last))
    });
    let mut out = Layer::default();
    for (k, (set, e)) in all.into_iter().enumerate() {
        if k < beam || (set == keep_set && e.last == keep_last) {
            out.push(set, e);
        }
    }
    out
}

/// The order ending in state (`set`, `end.last`), followed back through the layers.
fn backtrack(layers: &[Layer], mut set: u128, end: Entry) -> Vec<usize> {
    let mut order = Vec::with_capacity(layers.len() - 1);
    let mut e = end;
    loop {
        order.push(e.last as usize);
        set &= !bit(e.last as usize);
        if e.prev == u8::MAX {
            break;
        }
        let layer = &layers[set.count_ones() as usize];
        e = *layer
            .chain(layer.heads[&set])
            .find(|x| x.last == e.prev)
            .expect("a state's predecessor is in the layer it was built from");
    }
    order.reverse();
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::PlanConfig;
    use crate::plan::tour::blocking::Blocking;
    use crate::plan::tour::tests::{layout, push, v};
    use crate::plan::tour::{endpoints, moves_of};
    use nalgebra::Vector2;
    use rand::{RngExt, SeedableRng};

    /// Every order of `0..n`.
    fn permutations(n: usize) -> Vec<Vec<usize>> {
        if n == 0 {
            return vec![Vec::new()];
        }
        let mut out = Vec::new();
        for p in permutations(n - 1) {
            for k in 0..=p.len() {
                let mut q = p.clone();
                q.insert(k, n - 1);
                out.push(q);
            }
        }
        out
    }

    /// Seven particles 10 um apart, pushed 6-16 um in random directions
    /// (the first one twice: eight moves); the instances where at least half
    /// the orders collide, but not all, are kept (18 of the 60 seeds). The
    /// DP's travel equals the least over every valid order found by brute
    /// force, with and without pruning, from the longest valid order as
    /// incumbent; a one-state beam still returns a valid order no longer
    /// than its incumbent.
    #[test]
    fn the_dp_finds_the_least_valid_order_of_the_brute_force() {
        let cfg = PlanConfig::default();
        let mut checked = 0;
        for seed in 0..60u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let centres: Vec<Vector2<f64>> = (0..7)
                .map(|k| v(60.0 + 20.0 * (k % 4) as f64, 60.0 + 20.0 * (k / 4) as f64))
                .collect();
            let l = layout(&centres);
            let mut at = centres.clone();
            let mut steps = Vec::new();
            for k in 0..8 {
                let p = if k == 7 { 0 } else { k };
                let angle = rng.random_range(0.0..std::f64::consts::TAU);
                let len = rng.random_range(6.0..16.0);
                let to = at[p] + v(len * angle.cos(), len * angle.sin());
                steps.push(push(p as u32, at[p], to, &cfg));
                at[p] = to;
            }
            let moves = moves_of(&steps, &l, &cfg).unwrap();
            let bl = Blocking::new(&moves, &steps, &l, &cfg).unwrap();
            let (lands, ends) = endpoints(&moves);
            let start = (seed % 2 == 1).then(|| v(0.0, 0.0));
            let problem = PathProblem::new(&lands, &ends, start, &bl);
            let all = permutations(moves.len());
            let valid: Vec<&Vec<usize>> = all.iter().filter(|o| problem.valid(o)).collect();
            if valid.is_empty() || valid.len() * 2 > all.len() {
                continue; // no valid order, or too few constraints to be a test
            }
            let travel = |o: &Vec<usize>| problem.travel(o);
            let least = valid
                .iter()
                .map(|o| travel(o))
                .fold(f64::INFINITY, f64::min);
            let longest = *valid
                .iter()
                .max_by(|a, b| travel(a).total_cmp(&travel(b)))
                .unwrap();
            for prune in [false, true] {
                let budget = DpBudget {
                    max_layer_states: usize::MAX,
                    beam: 0,
                    prune,
                };
                let dp = optimal_path(&problem, longest, budget).unwrap();
                assert!(dp.exact);
                assert!(problem.valid(&dp.order), "seed {seed}: {:?}", dp.order);
                assert!(
                    (dp.travel_m - least).abs() <= 1e-12,
                    "seed {seed}, prune {prune}: DP {} brute force {least}",
                    dp.travel_m
                );
            }
            let one = DpBudget {
                max_layer_states: 1,
                beam: 1,
                prune: false,
            };
            let beam = optimal_path(&problem, longest, one).unwrap();
            assert!(problem.valid(&beam.order));
            assert!(beam.travel_m <= travel(longest) + 1e-12);
            assert!(beam.states_per_layer.iter().all(|&s| s <= 2));
            checked += 1;
        }
        assert!(checked >= 10, "only {checked} constrained instances");
    }
}
