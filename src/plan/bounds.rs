//! Lower bounds a plan is measured against.
//!
//! LB_push: the optimal assignment's total straight-line distance (computed
//! in `plan_assembly`).
//!
//! LB_tip: a lower bound on the tip travel of *every* order of a plan's
//! pushes (each particle's pushes in their sequence; collisions ignored, so
//! it holds a fortiori for the collision-free ones). Why it is one: in any
//! order, push j's landing point is reached either from the tip's start (the
//! first push only) or from the end of the push i run just before it, and
//! each end and the start lead to at most one landing. So the order's hops
//! form an assignment of landings to {start} + push ends, and the cheapest
//! such assignment cannot cost more. Pairs no order can use are forbidden,
//! which keeps it a bound and makes it tighter (the assignment relaxation of
//! the asymmetric TSP path):
//! - i = j: a push never follows itself;
//! - i, j pushes of the same particle with i's end position not j's start:
//!   nothing else moves that particle between two consecutive pushes, so j
//!   could not start where its particle is.
//!
//! The start: the configured tip position, or, when the tip starts free (at
//! its first landing), a source that reaches any landing at no cost. Every
//! push also needs its standoff approach, added on top.
//!
//! Above [`LB_TIP_DENSE_MAX_PUSHES`] pushes the forbidden pairs are dropped
//! (which only lowers the bound) and a weak-duality bound of that relaxation
//! is used ([`dual_bound::bound_from_prices`], valid for any end prices; the
//! prices come from the auction on the chains' contracted problem, within
//! about [`LB_TIP_REL_GAP`] of it): a free start is then relaxed by closing
//! the path into a cycle, which costs at most the largest landing-to-end
//! distance `D`, so `path >= cycle assignment - D`.

use super::assignment::{auction, dense_jv, dual_bound};
use super::pushes::{landing_point, tip_end};
use super::{PlanConfig, Step};
use nalgebra::Vector2;

/// Above [`LB_TIP_DENSE_MAX_PUSHES`] LB_tip's relaxation is bounded from below
/// within this fraction instead of solved exactly (still a lower bound).
pub const LB_TIP_REL_GAP: f64 = 1e-2;

/// Largest plan whose LB_tip is the exact assignment with the forbidden
/// pairs (dense Jonker-Volgenant, O(n^3): about 1 ms at 150 pushes).
pub const LB_TIP_DENSE_MAX_PUSHES: usize = 150;

/// Cost that keeps a forbidden pair out of the assignment (metres, far
/// beyond any field); a solution using one is discarded.
const FORBIDDEN_M: f64 = 1e3;

/// A push as LB_tip sees it.
struct PushEnds {
    particle: u32,
    from: Vector2<f64>,
    to: Vector2<f64>,
    land: Vector2<f64>,
    end: Vector2<f64>,
}

/// LB_tip of the pushes in `steps` (metres, standoffs included), tip
/// starting at `start` (None: free, at whichever push goes first).
pub fn lb_tip(steps: &[Step], start: Option<Vector2<f64>>, config: &PlanConfig) -> f64 {
    let pushes = push_ends(steps, config);
    if pushes.is_empty() {
        return 0.0;
    }
    let finite = |p: &Vector2<f64>| p.x.is_finite() && p.y.is_finite();
    if !pushes.iter().all(|p| finite(&p.land) && finite(&p.end))
        || !start.is_none_or(|s| finite(&s))
    {
        return 0.0;
    }
    let standoffs = pushes.len() as f64 * config.standoff_m;
    let relaxation = if pushes.len() <= LB_TIP_DENSE_MAX_PUSHES {
        assignment_with_forbidden_pairs(&pushes, start)
    } else {
        large_plan_bound(&pushes, start)
    };
    relaxation + standoffs
}

/// The pushes of `steps`, in order.
fn push_ends(steps: &[Step], config: &PlanConfig) -> Vec<PushEnds> {
    steps
        .iter()
        .filter_map(|s| match s {
            Step::Push {
                particle,
                from_m,
                to_m,
                approach_m,
                ..
            } => Some(PushEnds {
                particle: *particle,
                from: *from_m,
                to: *to_m,
                land: landing_point(*from_m, *to_m, *approach_m, config),
                end: tip_end(*from_m, *to_m, *approach_m),
            }),
            _ => None,
        })
        .collect()
}

/// True when push `j` can never run right after push `i`.
fn forbidden(pushes: &[PushEnds], i: usize, j: usize) -> bool {
    let (a, b) = (&pushes[i], &pushes[j]);
    i == j || (a.particle == b.particle && (a.to - b.from).norm() > 1e-12)
}

/// The exact relaxation: landings (rows) to push ends plus the start
/// (columns, the start last), forbidden pairs excluded.
fn assignment_with_forbidden_pairs(pushes: &[PushEnds], start: Option<Vector2<f64>>) -> f64 {
    let lands: Vec<Vector2<f64>> = pushes.iter().map(|p| p.land).collect();
    let ends: Vec<Vector2<f64>> = pushes.iter().map(|p| p.end).collect();
    // None cannot happen (the start and the other particles' ends always
    // give a feasible assignment); the bound without forbidden pairs stays valid.
    path_assignment_bound(&lands, &ends, start, |i, j| forbidden(pushes, i, j))
        .unwrap_or_else(|| large_plan_bound(pushes, start))
}

/// Cheapest assignment of every landing `lands[j]` to a distinct
/// predecessor: the start (None: free, costs nothing) or an end `ends[i]`
/// with `forbidden(i, j)` false. A lower bound on the hops of every path
/// through the items (entered at their landing, left at their end) that
/// never puts j right after i where `forbidden(i, j)`. None when no such
/// assignment exists. Dense Jonker-Volgenant: O(n^3), for small n.
pub fn path_assignment_bound(
    lands: &[Vector2<f64>],
    ends: &[Vector2<f64>],
    start: Option<Vector2<f64>>,
    forbidden: impl Fn(usize, usize) -> bool,
) -> Option<f64> {
    let n = lands.len();
    if n == 0 {
        return Some(0.0);
    }
    let mut cols = ends.to_vec();
    cols.push(start.unwrap_or(lands[0]));
    let cost = |j: usize, i: usize| -> f64 {
        if i == n {
            start.map_or(0.0, |s| (lands[j] - s).norm())
        } else if forbidden(i, j) {
            FORBIDDEN_M
        } else {
            (lands[j] - cols[i]).norm()
        }
    };
    let chosen = dense_jv::solve(lands, &cols, cost);
    if chosen
        .iter()
        .enumerate()
        .any(|(j, &i)| i < n && forbidden(i, j))
    {
        return None;
    }
    Some(chosen.iter().enumerate().map(|(j, &i)| cost(j, i)).sum())
}

/// Alternations of best responses after the contracted prices
/// ([`dual_bound::bound_from_prices`]).
const LB_TIP_DUAL_ROUNDS: usize = 1;

/// A dual bound on the relaxation without forbidden pairs. Its prices come
/// from the contracted problem: most landings are a split push's, 1 um
/// behind the end of the same particle's push before (its chain
/// predecessor), so the auction's relaxation is solved only for the chains'
/// first landings against their last ends (and the start) and the prices
/// of the inner ends follow from best responses. That choice only makes the
/// bound tight or loose: weak duality keeps it a bound.
fn large_plan_bound(pushes: &[PushEnds], start: Option<Vector2<f64>>) -> f64 {
    let lands: Vec<Vector2<f64>> = pushes.iter().map(|p| p.land).collect();
    let mut ends: Vec<Vector2<f64>> = pushes.iter().map(|p| p.end).collect();
    let (heads, tails) = chain_heads_and_tails(pushes);
    let head_lands: Vec<Vector2<f64>> = heads.iter().map(|&j| lands[j]).collect();
    let mut tail_ends: Vec<Vector2<f64>> = tails.iter().map(|&i| ends[i]).collect();
    if let Some(s) = start {
        ends.push(s);
        tail_ends.push(s);
    }
    let contracted = auction::particle_prices_m(&head_lands, &tail_ends, LB_TIP_REL_GAP);
    let mut prices = vec![f64::INFINITY; ends.len()];
    for (&i, &p) in tails.iter().zip(&contracted) {
        prices[i] = p;
    }
    if start.is_some() {
        prices[pushes.len()] = contracted[tails.len()];
    }
    let bound = dual_bound::bound_from_prices(&lands, &ends, &prices, LB_TIP_DUAL_ROUNDS);
    match start {
        Some(_) => bound,
        None => {
            // Close the path into a cycle: every landing takes an end.
            let (lo, hi) = lands
                .iter()
                .chain(&ends)
                .fold((lands[0], lands[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
            (bound - (hi - lo).norm()).max(0.0)
        }
    }
}

/// The pushes no push of the same particle leads into (heads: first
/// landings) and those that lead into none (tails: last ends), where push
/// `i` leads into push `j` when `j` is the particle's next push and starts
/// where `i` left it. As many heads as tails.
fn chain_heads_and_tails(pushes: &[PushEnds]) -> (Vec<usize>, Vec<usize>) {
    let mut last_of_particle: std::collections::HashMap<u32, usize> = Default::default();
    let mut has_pred = vec![false; pushes.len()];
    let mut has_succ = vec![false; pushes.len()];
    for (j, p) in pushes.iter().enumerate() {
        if let Some(i) = last_of_particle.insert(p.particle, j)
            && !forbidden(pushes, i, j)
        {
            has_pred[j] = true;
            has_succ[i] = true;
        }
    }
    let heads = (0..pushes.len()).filter(|&j| !has_pred[j]).collect();
    let tails = (0..pushes.len()).filter(|&i| !has_succ[i]).collect();
    (heads, tails)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::assignment::{AssignmentMethod, assign};
    use crate::plan::pushes::{approach_point, with_tip_travel};
    use crate::plan::summarise;
    use proptest::prelude::*;

    const UM: f64 = 1e-6;

    /// Pushes of `chains[p]` (particle p's successive centres, um), in the
    /// order given by `order` (particle ids; each occurrence runs that
    /// particle's next push).
    fn pushes_in_order(chains: &[Vec<(f64, f64)>], order: &[usize], cfg: &PlanConfig) -> Vec<Step> {
        let mut next = vec![0; chains.len()];
        order
            .iter()
            .map(|&p| {
                let k = next[p];
                next[p] += 1;
                let (a, b) = (chains[p][k], chains[p][k + 1]);
                let (from, to) = (Vector2::new(a.0, a.1) * UM, Vector2::new(b.0, b.1) * UM);
                Step::Push {
                    particle: p as u32,
                    from_m: from,
                    to_m: to,
                    approach_m: approach_point(from, to, 5.0 * UM, cfg),
                    contact_angle_rad: 0.0,
                }
            })
            .collect()
    }

    fn tip_travel(steps: &[Step], start: Option<Vector2<f64>>, cfg: &PlanConfig) -> f64 {
        let start = start.or_else(|| {
            steps.first().map(|s| match s {
                Step::Push {
                    from_m,
                    to_m,
                    approach_m,
                    ..
                } => landing_point(*from_m, *to_m, *approach_m, cfg),
                _ => unreachable!(),
            })
        });
        summarise(&with_tip_travel(steps.to_vec(), start, cfg), cfg).tip_travel_m
    }

    proptest! {
        /// LB_tip is below the tip travel of every order of the same pushes
        /// (each particle's pushes in sequence), free start or given, and
        /// at least the old bound (self pairs allowed).
        #[test]
        fn lb_tip_is_below_every_order_and_above_the_self_pair_bound(
            chains in prop::collection::vec(
                prop::collection::vec((0.0..100.0f64, 0.0..100.0f64), 2..5), 1..5),
            keys in prop::collection::vec(0.0..1.0f64, 16),
            start in (0.0..100.0f64, 0.0..100.0f64),
        ) {
            let cfg = PlanConfig::default();
            let start = Vector2::new(start.0, start.1) * UM;
            // A random interleaving: each particle's pushes keep their sequence.
            let mut slots: Vec<(f64, usize)> = Vec::new();
            for (p, c) in chains.iter().enumerate() {
                for k in 0..c.len() - 1 {
                    slots.push((keys[(p * 4 + k) % keys.len()] + k as f64 * 1e-9, p));
                }
            }
            slots.sort_by(|a, b| a.0.total_cmp(&b.0));
            let order: Vec<usize> = slots.iter().map(|s| s.1).collect();
            let steps = pushes_in_order(&chains, &order, &cfg);
            let free = lb_tip(&steps, None, &cfg);
            prop_assert!(free <= tip_travel(&steps, None, &cfg) + 1e-12);
            let fixed = lb_tip(&steps, Some(start), &cfg);
            prop_assert!(fixed <= tip_travel(&steps, Some(start), &cfg) + 1e-12);
            // The bound before: landings to {ends, start}, self pairs allowed.
            let mut lands = Vec::new();
            let mut ends = Vec::new();
            for s in &steps {
                if let Step::Push { from_m, to_m, approach_m, .. } = s {
                    lands.push(landing_point(*from_m, *to_m, *approach_m, &cfg));
                    ends.push(tip_end(*from_m, *to_m, *approach_m));
                }
            }
            ends.push(start);
            let old = assign(&lands, &ends, AssignmentMethod::Dense).unwrap().cost_m
                + lands.len() as f64 * cfg.standoff_m;
            prop_assert!(fixed >= old - 1e-12, "{fixed} < {old}");
        }
    }

    proptest! {
        /// The large-plan bound (contracted prices, best responses) is below
        /// the exact relaxation with forbidden pairs, free start or given, on
        /// plans mixing split pushes (a few um) and long ones.
        #[test]
        fn large_plan_bound_is_below_the_exact_relaxation(
            chains in prop::collection::vec(
                ((0.0..100.0f64, 0.0..100.0f64),
                 prop::collection::vec((-12.0..12.0f64, -12.0..12.0f64, 0.0..1.0f64), 1..6)),
                1..10),
            keys in prop::collection::vec(0.0..1.0f64, 64),
            start in (0.0..100.0f64, 0.0..100.0f64),
        ) {
            let cfg = PlanConfig::default();
            // Each chain: a start and steps, a third of them long jumps.
            let chains: Vec<Vec<(f64, f64)>> = chains
                .iter()
                .map(|(s, steps)| {
                    let mut at = *s;
                    let mut c = vec![at];
                    for &(dx, dy, long) in steps {
                        let k = if long < 0.33 { 5.0 } else { 0.3 };
                        at = (at.0 + k * dx, at.1 + k * dy);
                        c.push(at);
                    }
                    c
                })
                .collect();
            let mut slots: Vec<(f64, usize)> = Vec::new();
            for (p, c) in chains.iter().enumerate() {
                for k in 0..c.len() - 1 {
                    slots.push((keys[(p * 6 + k) % keys.len()] + k as f64, p));
                }
            }
            slots.sort_by(|a, b| a.0.total_cmp(&b.0));
            let order: Vec<usize> = slots.iter().map(|s| s.1).collect();
            let pushes = push_ends(&pushes_in_order(&chains, &order, &cfg), &cfg);
            for start in [None, Some(Vector2::new(start.0, start.1) * UM)] {
                let exact = assignment_with_forbidden_pairs(&pushes, start);
                let bound = large_plan_bound(&pushes, start);
                prop_assert!(bound <= exact + 1e-12, "{bound} > {exact} (start {start:?})");
            }
        }
    }

    /// On a real plan (a block of 150 sites, about 230 pushes) the
    /// large-plan bound is within 1 % of the relaxation it bounds (no
    /// forbidden pairs, exact by dense Jonker-Volgenant).
    #[test]
    fn large_plan_bound_is_near_the_relaxation_on_a_block_plan() {
        use crate::plan::assignment::block_instance;
        use crate::plan::{pattern::numbered_sites, plan_assembly};
        let cfg = PlanConfig::default();
        for seed in [1, 2] {
            let (sites, layout) = block_instance(150, seed);
            let plan = plan_assembly(&layout, &numbered_sites(sites), &cfg).unwrap();
            let pushes = push_ends(&plan.steps, &cfg);
            assert!(
                pushes.len() > LB_TIP_DENSE_MAX_PUSHES,
                "{} pushes",
                pushes.len()
            );
            let lands: Vec<Vector2<f64>> = pushes.iter().map(|p| p.land).collect();
            let mut ends: Vec<Vector2<f64>> = pushes.iter().map(|p| p.end).collect();
            let start = lands[0] + Vector2::new(30.0, -20.0) * UM;
            ends.push(start);
            let relaxation = assign(&lands, &ends, AssignmentMethod::Dense)
                .unwrap()
                .cost_m;
            let bound = large_plan_bound(&pushes, Some(start));
            assert!(
                bound <= relaxation + 1e-12 && bound >= 0.99 * relaxation,
                "seed {seed}: bound {bound} vs relaxation {relaxation}"
            );
        }
    }

    /// Two pushes far apart, each returning near its own landing: allowing
    /// self pairs would give LB_tip = standoffs only; forbidding them forces
    /// one crossing (the free start pays the other).
    #[test]
    fn self_pairs_are_forbidden() {
        let cfg = PlanConfig::default();
        let chains = vec![
            vec![(10.0, 10.0), (10.0, 11.0)],
            vec![(90.0, 10.0), (90.0, 11.0)],
        ];
        let steps = pushes_in_order(&chains, &[0, 1], &cfg);
        let lb = lb_tip(&steps, None, &cfg) - 2.0 * cfg.standoff_m;
        let travel = tip_travel(&steps, None, &cfg) - 2.0 * cfg.standoff_m;
        assert!(lb > 75.0 * UM, "one crossing of 80 um: {lb}");
        assert!(
            (lb - travel).abs() < 1e-12,
            "two pushes: the bound is the tour"
        );
    }
}
