//! Assignment that also pays for moving unassigned particles off the sites.
//!
//! An unassigned particle that overlaps a site must be pushed away before
//! that site can be filled; the plain assignment ignores that push. Here
//! every particle carries a `park_cost_m` (0 when it may stay where it is,
//! else the length of the push that clears it) and the assignment minimises
//! sum d(site, particle) + sum park_cost(unassigned particle), which is the
//! plain assignment with cost d(s, p) - park_cost(p) (shifted to stay
//! non-negative). Solved with the dense method: the planner only calls this
//! for the small instances where a site is covered (re-planning per push),
//! where a refused order banned some particle-site pairs, or where
//! `plan::refine` adds the costs an earlier order paid beyond the straight
//! lines.

use super::{dense_jv, dist};
use nalgebra::Vector2;
use rustc_hash::FxHashMap;

/// Cost that keeps a banned pair out of the assignment whenever any other
/// assignment exists, metres (far beyond any field).
const BANNED_PAIR_COST_M: f64 = 1.0;

/// Site -> particle indices minimising push distance plus parking pushes;
/// `park_cost_m` may be empty (no parking cost), `banned` (particle, site)
/// pairs are taken only when nothing else fills the sites, and `pair_cost_m`
/// adds to the cost of (particle, site) pairs (what an earlier order found
/// a pair's path to cost beyond the straight line; non-negative).
pub fn solve(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    park_cost_m: &[f64],
    banned: &[(usize, usize)],
    pair_cost_m: &FxHashMap<(usize, usize), f64>,
) -> Vec<usize> {
    let park = |p: usize| park_cost_m.get(p).copied().unwrap_or(0.0);
    let shift = park_cost_m.iter().copied().fold(0.0, f64::max);
    dense_jv::solve(sites, particles, |s, p| {
        let ban = if banned.contains(&(p, s)) {
            BANNED_PAIR_COST_M
        } else {
            0.0
        };
        let extra = pair_cost_m.get(&(p, s)).copied().unwrap_or(0.0);
        dist(&sites[s], &particles[p]) - park(p) + shift + ban + extra
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_particle_covering_a_site_is_taken_when_parking_it_costs_more() {
        // Site at 0; particle A exactly 4 from it (covers it), particle B at 1.
        // Plain optimum takes B (1) and A stays (cost 1); parking A costs 6,
        // so taking A (4) and leaving B (0) is cheaper in total (4 < 1 + 6).
        let sites = [Vector2::new(0.0, 0.0)];
        let parts = [Vector2::new(4.0, 0.0), Vector2::new(0.0, 1.0)];
        let none = FxHashMap::default();
        assert_eq!(solve(&sites, &parts, &[0.0, 0.0], &[], &none), vec![1]);
        assert_eq!(solve(&sites, &parts, &[6.0, 0.0], &[], &none), vec![0]);
        // Parking cheaper than the difference: plain choice again.
        assert_eq!(solve(&sites, &parts, &[2.0, 0.0], &[], &none), vec![1]);
        // The nearer particle banned from the site: the other one takes it
        // (micrometre distances, as the planner gives them).
        let um = [Vector2::new(4e-6, 0.0), Vector2::new(0.0, 1e-6)];
        assert_eq!(solve(&sites, &um, &[], &[], &none), vec![1]);
        assert_eq!(solve(&sites, &um, &[], &[(1, 0)], &none), vec![0]);
        // A learned cost on the nearer pair (4 um beyond its 1 um line)
        // makes the other particle (4 um) the cheaper choice; 2 um does not.
        let learned = |c: f64| FxHashMap::from_iter([((1, 0), c)]);
        assert_eq!(solve(&sites, &um, &[], &[], &learned(4e-6)), vec![0]);
        assert_eq!(solve(&sites, &um, &[], &[], &learned(2e-6)), vec![1]);
    }
}
