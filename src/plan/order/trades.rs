//! Trades of sites between a blocked move and its blocker, and hand-overs
//! to a blocker nearer the site.

use super::Role;
use super::Scheduler;
use crate::plan::route::route_length;
use nalgebra::Vector2;

/// Hand-overs to a nearer blocker per move. At N = 10,000 a move crosses
/// 600 um of crowd on average (15 particles in its corridor at 10 %
/// coverage); with 8, over 2,000 blockers on spent moves were buffered out
/// and back (a third of the excess push distance), and the order took 20 s.
const MAX_NEARER_SWAPS: u8 = 32;

/// A thrifty order's swap whose routes need a waypoint is left until the
/// reroutes and early fills have failed when it adds more than so many
/// particle radii beyond what rerouting the blocked move adds (CMU seed 84:
/// a swap took a particle 26 um round to its new site). CMU: 79 -> 88 of
/// 100 layouts within 1.05 LB_push; N = 1,000 1.003011 -> 1.002560. With
/// no slack CMU had 88 but N = 1,000 1.003304, with 2 radii 86 and
/// 1.002943.
const SWAP_OVER_REROUTE_RADII: f64 = 1.0;

impl Scheduler<'_> {
    /// Hands move k to particle q, which is in the way of k's particle:
    /// an idle q takes over (k's particle becomes idle), a pending q trades
    /// sites with it; true when q has a route free of every particle now
    /// (so the swap makes progress) and the other changed move has a route
    /// (with at most `waypoints` waypoints). When `weighed`, not when the
    /// swap adds more to the two moves' paths than rerouting move k would,
    /// plus [`SWAP_OVER_REROUTE_RADII`].
    pub(super) fn swap_with(
        &mut self,
        k: usize,
        q: usize,
        waypoints: usize,
        weighed: bool,
    ) -> bool {
        self.swap_if(
            k,
            q,
            |s, m, particle, taker| {
                s.route_for(
                    m,
                    particle,
                    s.occ.pos[particle],
                    taker,
                    waypoints,
                    f64::INFINITY,
                )
            },
            |s| s.trade_allowance(k, weighed),
        )
    }

    /// Most a trade for blocked move k may add to the two moves' paths:
    /// when `weighed`, what rerouting k would add plus
    /// [`SWAP_OVER_REROUTE_RADII`]; else no limit.
    fn trade_allowance(&self, k: usize, weighed: bool) -> f64 {
        if weighed {
            self.reroute_added(k) + SWAP_OVER_REROUTE_RADII * self.occ.max_radius_m
        } else {
            f64::INFINITY
        }
    }

    /// Hands move k to particle q when q is nearer k's site than k's
    /// particle: its route need only miss the sites (it may be blocked by
    /// particles nearer still, swapped in their turn). A blocker on the way
    /// costs nothing to swap with (triangle inequality), and each swap
    /// brings move k's particle nearer its site, so chains of them end.
    /// Routes are straight or along the changed move's waypoints
    /// ([`Self::straight_or_along`]): with straight ones only, a blocker on
    /// the first leg of a detour was buffered instead, 2,158 pushes out and
    /// back at N = 10,000 (a third of its excess push distance).
    /// `capped`: at most [`MAX_NEARER_SWAPS`] per move; `weighed`: see
    /// [`Self::trade_allowance`].
    pub(super) fn swap_nearer(&mut self, k: usize, q: usize, capped: bool, weighed: bool) -> bool {
        let site = self.obstacles.site(k);
        let p = self.moves[k].particle;
        let ok = (!capped || self.nearer_swaps[k] < MAX_NEARER_SWAPS)
            && (self.occ.pos[q] - site).norm() < (self.occ.pos[p] - site).norm()
            && self.swap_if(
                k,
                q,
                |s, m, particle, _| s.straight_or_along(m, particle),
                |s| s.trade_allowance(k, weighed),
            );
        if ok {
            self.nearer_swaps[k] = self.nearer_swaps[k].saturating_add(1);
        }
        ok
    }

    /// [`Self::swap_with`] with the routes from `route(self, move,
    /// particle, taker)`, `taker` true for q's route for move k; not when
    /// it lengthens the changed moves' routes (from where their particles
    /// are now) by more than `max_added(self)`, asked only then.
    fn swap_if(
        &mut self,
        k: usize,
        q: usize,
        route: impl Fn(&Self, usize, usize, bool) -> Option<Vec<Vector2<f64>>>,
        max_added: impl Fn(&Self) -> f64,
    ) -> bool {
        let p = self.moves[k].particle;
        let length =
            |particle: usize, route: &[Vector2<f64>]| route_length(self.occ.pos[particle], route);
        let too_long = |added: f64| added > 0.0 && added > max_added(self);
        let banned =
            |particle: usize, m: usize| self.banned.contains(&(particle, self.moves[m].site_index));
        if banned(q, k) || matches!(self.role[q], Role::Pending(m) if banned(p, m)) {
            return false;
        }
        // An unassigned particle may be one too wide for the sites.
        if self.role[q] == Role::Idle && self.layout.particles[q].radius_m > self.site_radius_m {
            return false;
        }
        match self.role[q] {
            Role::Idle => {
                let Some(route) = route(self, k, q, true) else {
                    return false;
                };
                if too_long(length(q, &route) - length(p, &self.moves[k].route)) {
                    return false;
                }
                self.moves[k].particle = q;
                self.moves[k].route = route;
                self.role[q] = Role::Pending(k);
                self.role[p] = Role::Idle;
                self.leave_clear(p, k);
                self.compute_conflicts(k);
                true
            }
            Role::Pending(m) => {
                let Some(route_k) = route(self, k, q, true) else {
                    return false;
                };
                let Some(route_m) = route(self, m, p, false) else {
                    return false;
                };
                let before = length(p, &self.moves[k].route) + length(q, &self.moves[m].route);
                if too_long(length(q, &route_k) + length(p, &route_m) - before) {
                    return false;
                }
                self.moves[k].particle = q;
                self.moves[k].route = route_k;
                self.moves[m].particle = p;
                self.moves[m].route = route_m;
                self.role[q] = Role::Pending(k);
                self.role[p] = Role::Pending(m);
                self.compute_conflicts(k);
                self.compute_conflicts(m);
                true
            }
            Role::Placed => false,
        }
    }
}
