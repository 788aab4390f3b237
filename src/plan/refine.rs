//! Re-assignment guided by what the order paid beyond the straight lines.
//!
//! The assignment minimises straight-line distance, but the order may have
//! to detour a move, push a particle to a buffer spot and back, or push an
//! unassigned particle off the way: on the CMU layouts those paths were
//! 5.7 % of LB_push above the executed straight lines (ninth pass). On
//! small instances the planner learns from the order it got: each executed
//! pair's excess (its particle's pushes minus its straight distance) is
//! added to that pair's cost, and each unassigned particle's pushes to its
//! parking cost; the assignment is solved again with these costs, ordered
//! again, and the plan with the shortest push distance is kept. The costs
//! accumulate over the tries, so a pair that keeps detouring is given up.

use super::layout::Layout;
use super::order::Ordered;
use super::{PlanConfig, Step, summarise};
use rustc_hash::FxHashMap;

/// Orders tried after the first (CMU, 100 layouts within 1.05 LB_push:
/// none 62, 1 order 69, 3 orders 72, 5 the same as 3; planning time per
/// layout about doubles with 3).
pub const REFINE_TRIES: usize = 3;

/// Extra costs learned from earlier orders, metres.
#[derive(Debug, Clone, Default)]
pub struct LearnedCosts {
    /// (particle index, site index) -> path excess paid when that pair was executed.
    pub pair_m: FxHashMap<(usize, usize), f64>,
    /// Particle index -> push distance paid while it was unassigned.
    pub park_m: FxHashMap<usize, f64>,
}

impl LearnedCosts {
    /// Adds what `ordered` paid beyond the straight lines of its pairs;
    /// false when it paid nothing (nothing to learn).
    pub fn learn(
        &mut self,
        layout: &Layout,
        sites: &[super::Site],
        assigned: &[(usize, usize)],
        ordered: &Ordered,
    ) -> bool {
        let index = layout.index_by_id();
        let mut path = vec![0.0; layout.particles.len()];
        for (particle, from_m, to_m) in ordered.steps.iter().filter_map(Step::push_move) {
            path[index[&particle]] += (to_m - from_m).norm();
        }
        let mut learned = false;
        let mut has_site = vec![false; layout.particles.len()];
        for &(p, s) in &ordered.pairs {
            has_site[p] = true;
            let straight = (layout.particles[p].centre_m - sites[s].centre_m).norm();
            // Rounding of split pushes is not an excess.
            let excess = path[p] - straight;
            if excess > 1e-3 * straight {
                *self.pair_m.entry((p, s)).or_insert(0.0) += excess;
                learned = true;
            }
        }
        for (p, &len) in path.iter().enumerate() {
            if !has_site[p] && len > 0.0 {
                *self.park_m.entry(p).or_insert(0.0) += len;
                learned = true;
            }
        }
        learned | self.learn_trades(layout, sites, assigned, &ordered.pairs)
    }

    /// Charges every assigned pair whose site went to another particle
    /// with what the trade added: the traded pairs run straight, so their
    /// path excess teaches nothing, yet the trade made the executed
    /// assignment longer than the one solved (CMU seed 46: 5.5 um). Trades
    /// are grouped by the sites they link (a particle's assigned and
    /// executed site); each group's added distance is shared out equally
    /// among its assigned pairs, so an assignment that asks for all of
    /// them again pays the trade once (charged in full to each, CMU seed
    /// 53's next assignment was 8 um longer and pushed no less).
    /// False when nothing was traded at a cost.
    fn learn_trades(
        &mut self,
        layout: &Layout,
        sites: &[super::Site],
        assigned: &[(usize, usize)],
        executed: &[(usize, usize)],
    ) -> bool {
        let straight =
            |p: usize, s: usize| (layout.particles[p].centre_m - sites[s].centre_m).norm();
        let site_of = |pairs: &[(usize, usize)]| -> FxHashMap<usize, usize> {
            pairs.iter().copied().collect()
        };
        let (assigned_site, executed_site) = (site_of(assigned), site_of(executed));
        // Union-find over sites: a particle links its two sites.
        let mut group: Vec<usize> = (0..sites.len()).collect();
        fn root(group: &mut [usize], mut s: usize) -> usize {
            while group[s] != s {
                group[s] = group[group[s]];
                s = group[s];
            }
            s
        }
        for &(p, s) in assigned {
            if let Some(&t) = executed_site.get(&p) {
                let (a, b) = (root(&mut group, s), root(&mut group, t));
                group[a] = b;
            }
        }
        // Each group's executed straight lines minus its assigned ones.
        let mut added: FxHashMap<usize, f64> = FxHashMap::default();
        let undone = |&&(p, s): &&(usize, usize)| executed_site.get(&p) != Some(&s);
        // And how many assigned pairs each group undid, to share it out.
        let mut undone_in: FxHashMap<usize, f64> = FxHashMap::default();
        for &(p, s) in assigned.iter().filter(undone) {
            let g = root(&mut group, s);
            *added.entry(g).or_insert(0.0) -= straight(p, s);
            *undone_in.entry(g).or_insert(0.0) += 1.0;
        }
        let made = |&&(p, s): &&(usize, usize)| assigned_site.get(&p) != Some(&s);
        for &(p, s) in executed.iter().filter(made) {
            *added.entry(root(&mut group, s)).or_insert(0.0) += straight(p, s);
        }
        let mut learned = false;
        for &(p, s) in assigned {
            let g = root(&mut group, s);
            match added.get(&g) {
                Some(&extra) if extra > TRADE_ROUNDING_M => {
                    *self.pair_m.entry((p, s)).or_insert(0.0) += extra / undone_in[&g];
                    learned = true;
                }
                _ => {}
            }
        }
        learned
    }

    /// True when nothing has been learned.
    pub fn is_empty(&self) -> bool {
        self.pair_m.is_empty() && self.park_m.is_empty()
    }
}

/// Starting from `first`, re-assigns with the learned costs (`assign`)
/// and orders again (`order`; None when refused, which ends the search),
/// up to [`REFINE_TRIES`] orders; returns the shortest plan. An assignment
/// already ordered is not ordered again (the order is deterministic): the
/// last plan's excess is learned once more instead, so its pairs cost more.
pub fn refine<A: Clone + PartialEq>(
    layout: &Layout,
    sites: &[super::Site],
    first: (A, Ordered),
    config: &PlanConfig,
    mut assign: impl FnMut(&LearnedCosts) -> A,
    mut order: impl FnMut(&A) -> Option<Ordered>,
    pairs_of: impl Fn(&A) -> &[(usize, usize)],
) -> (A, Ordered) {
    let pushed = |o: &Ordered| summarise(&o.steps, config).push_distance_m;
    let mut costs = LearnedCosts::default();
    let mut best_len = pushed(&first.1);
    let mut tried = vec![first.0.clone()];
    let mut last = first.clone();
    let mut best = first;
    for _ in 0..MAX_SOLVES {
        if tried.len() > REFINE_TRIES || !costs.learn(layout, sites, pairs_of(&last.0), &last.1) {
            break;
        }
        let assigned = assign(&costs);
        if tried.contains(&assigned) {
            continue;
        }
        tried.push(assigned.clone());
        let Some(ordered) = order(&assigned) else {
            break;
        };
        let len = pushed(&ordered);
        last = (assigned.clone(), ordered.clone());
        if len < best_len {
            best_len = len;
            best = (assigned, ordered);
        }
    }
    best
}

/// A trade adding less than this (metres) is rounding, not a cost.
const TRADE_ROUNDING_M: f64 = 1e-12;

/// Most assignments solved by one [`refine`] (repeats included).
const MAX_SOLVES: usize = 3 * REFINE_TRIES;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Particle, Site};
    use nalgebra::Vector2;

    fn push(particle: u32, from: (f64, f64), to: (f64, f64)) -> Step {
        Step::Push {
            particle,
            from_m: Vector2::new(from.0, from.1),
            to_m: Vector2::new(to.0, to.1),
            approach_m: Vector2::new(from.0, from.1),
            contact_angle_rad: 0.0,
        }
    }

    fn scene() -> (Layout, Vec<Site>) {
        let particle = |id: u32, x: f64| Particle {
            id,
            centre_m: Vector2::new(x, 0.0),
            radius_m: 1.0,
        };
        let layout = Layout {
            field_m: [100.0, 100.0],
            particles: vec![particle(7, 0.0), particle(8, 50.0), particle(9, 80.0)],
        };
        let sites = vec![Site {
            id: 0,
            centre_m: Vector2::new(10.0, 0.0),
        }];
        (layout, sites)
    }

    /// Particle 7 goes to the site (10 straight) by pushes of 4, 5 and 7
    /// (16 in all); particle 8, unassigned, is pushed 2 off the way.
    fn detoured() -> Ordered {
        Ordered {
            steps: vec![
                push(8, (50.0, 0.0), (50.0, 2.0)),
                push(7, (0.0, 0.0), (0.0, 4.0)),
                push(7, (0.0, 4.0), (3.0, 0.0)),
                push(7, (3.0, 0.0), (10.0, 0.0)),
            ],
            buffer_pushes: 2,
            pairs: vec![(0, 0)],
        }
    }

    #[test]
    fn learning_charges_the_detour_to_its_pair_and_idle_pushes_to_parking() {
        let (layout, sites) = scene();
        let mut costs = LearnedCosts::default();
        assert!(costs.learn(&layout, &sites, &[(0, 0)], &detoured()));
        assert!((costs.pair_m[&(0, 0)] - 6.0).abs() < 1e-12);
        assert!((costs.park_m[&1] - 2.0).abs() < 1e-12);
        assert!(!costs.park_m.contains_key(&2), "particle 9 never moved");
        // A straight plan teaches nothing.
        let straight = Ordered {
            steps: vec![push(7, (0.0, 0.0), (10.0, 0.0))],
            buffer_pushes: 0,
            pairs: vec![(0, 0)],
        };
        assert!(!LearnedCosts::default().learn(&layout, &sites, &[(0, 0)], &straight));
    }

    /// Sites at x = 10 and 60: particle 7 (x = 0) and 8 (x = 50) are
    /// assigned 10 each; traded, they run 60 and 40 straight (+80), and
    /// each assigned pair is charged half the trade's 80, so asking for
    /// both again costs the 80 once. A hand-over of site 1
    /// to idle particle 9 (x = 80, 20 straight) charges pair (8, 1) +10.
    /// An even trade teaches nothing.
    #[test]
    fn learning_charges_a_trade_to_the_pairs_it_undid() {
        let (layout, mut sites) = scene();
        sites.push(Site {
            id: 1,
            centre_m: Vector2::new(60.0, 0.0),
        });
        let straight = |sites: &[Site], pairs: Vec<(usize, usize)>| Ordered {
            steps: pairs
                .iter()
                .map(|&(p, s)| {
                    let c = layout.particles[p].centre_m;
                    let t = sites[s].centre_m;
                    push(layout.particles[p].id, (c.x, c.y), (t.x, t.y))
                })
                .collect(),
            buffer_pushes: 0,
            pairs,
        };
        let assigned = [(0, 0), (1, 1)];
        // What one plan executing `pairs` straight teaches, and whether it did.
        let learn = |sites: &[Site], pairs: Vec<(usize, usize)>| {
            let mut costs = LearnedCosts::default();
            let learned = costs.learn(&layout, sites, &assigned, &straight(sites, pairs));
            (learned, costs)
        };
        let (learned, costs) = learn(&sites, vec![(0, 1), (1, 0)]);
        assert!(learned);
        assert_eq!(costs.pair_m.len(), 2);
        assert!((costs.pair_m[&(0, 0)] - 40.0).abs() < 1e-9);
        assert!((costs.pair_m[&(1, 1)] - 40.0).abs() < 1e-9);
        let (learned, costs) = learn(&sites, vec![(0, 0), (2, 1)]);
        assert!(learned);
        assert_eq!(costs.pair_m.len(), 1);
        assert!((costs.pair_m[&(1, 1)] - 10.0).abs() < 1e-9);
        // Sites at x = 60 and 70: 60 + 20 assigned, 70 + 10 traded.
        sites[0].centre_m.x = 60.0;
        sites[1].centre_m.x = 70.0;
        assert!(!learn(&sites, vec![(0, 1), (1, 0)]).0);
    }

    #[test]
    fn the_shortest_plan_is_kept_and_a_refusal_ends_the_search() {
        let (layout, sites) = scene();
        let config = PlanConfig::default();
        let mut calls = 0;
        // Longer, the same again, shorter (no idle push), then refused: the
        // shorter one is kept and the search stops at the refusal.
        let assign = |costs: &LearnedCosts| {
            assert!(!costs.is_empty());
            calls += 1;
            // The second solve repeats the first: it is not ordered again.
            ["longer", "longer", "shorter", "refused"][calls - 1]
        };
        let order = |tag: &&str| match *tag {
            "longer" => {
                let mut longer = detoured();
                longer.steps.push(push(9, (80.0, 0.0), (90.0, 0.0)));
                Some(longer)
            }
            "shorter" => {
                let mut shorter = detoured();
                shorter.steps.remove(0);
                Some(shorter)
            }
            _ => None,
        };
        let (tag, best) = refine(
            &layout,
            &sites,
            ("first", detoured()),
            &config,
            assign,
            order,
            |_| &[],
        );
        assert_eq!(tag, "shorter");
        assert_eq!(best.steps.len(), 3);
        assert_eq!(calls, 4);
    }
}
