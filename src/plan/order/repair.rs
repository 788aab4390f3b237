//! The repairs tried, in order, when every ready move is blocked, and the
//! first of them: filling a blocker's site early.

use super::Role;
use super::Scheduler;
use super::buffers::Blockers;
use crate::plan::route::route_length;

/// How far an early fill may lengthen the routes of the moves that waited
/// for its site: in particle radii each, with at most so many waypoints.
#[derive(Debug, Clone, Copy)]
struct EarlyFill {
    extra_radii: f64,
    waypoints: usize,
}

/// Early fills tried before any swap: nearly free ones. Cheap searches
/// only: with two waypoints or a radius of slack, N = 1,000's order took
/// 0.35-1.1 s (0.07 s without) for no gain there.
const NEAR_FREE_FILL: EarlyFill = EarlyFill {
    extra_radii: 0.1,
    waypoints: 1,
};

/// An early fill may reroute the filled move's own way only when its
/// particle is within so many radii of its site (beside it, where the way
/// back from a buffer spot costs most). CMU: 72 of 100 layouts within 1.05
/// LB_push, as with no limit; N = 1,000's order 187 ms against 357 ms with
/// none (170 ms without own reroutes, where CMU had 59).
const OWN_DETOUR_MAX_RADII: f64 = 4.0;

/// Early fills tried before a particle still to move is buffered (which
/// costs it a push away and back).
const DETOUR_FILL: EarlyFill = EarlyFill {
    extra_radii: 1.0,
    waypoints: 2,
};

impl Scheduler<'_> {
    /// Tries one repair for the blocked ready moves; true on success.
    pub(super) fn repair(&mut self, blocked: &[(usize, usize)]) -> bool {
        if self.detour_first && blocked.iter().any(|&(k, q)| self.detour(k, q)) {
            return true;
        }
        // A blocker still to move whose own way is free goes to its site
        // first when that costs the moves waiting for the site next to
        // nothing (CMU: mean push ratio 1.0751 -> 1.0695, 46 -> 52 layouts
        // meeting 1.05; swaps had traded sites at a cost instead).
        for &(_, q) in blocked {
            if let Role::Pending(m) = self.role[q]
                && self.fill_early(m, NEAR_FREE_FILL)
            {
                return true;
            }
        }
        // Straight swaps next: one corridor test each, where a detour
        // search that finds nothing costs over a thousand. Swaps take at most
        // one waypoint: the two-waypoint search was most of the scheduler's
        // time at N = 1,000, and without it CMU's push ratio is lower
        // (worst 1.338 -> 1.308; a buffer push or a reroute does better).
        for waypoints in [0, 1] {
            for &(k, q) in blocked {
                let weighed = self.thrifty && (waypoints == 1 || self.careful);
                if self.swap_with(k, q, waypoints, weighed) {
                    return true;
                }
            }
            // Then blockers nearer the site take the move over even when
            // their own way is not free yet: one corridor test each, and a
            // blocker on the way costs nothing in distance. At N = 1,000 this
            // took the order from 0.77 s to 0.06 s and the push ratio from
            // 1.025 to 1.004 (the detour searches it saves were both).
            if waypoints == 0
                && blocked
                    .iter()
                    .any(|&(k, q)| self.swap_nearer(k, q, true, self.careful))
            {
                return true;
            }
        }
        for &(k, q) in blocked {
            if self.detour(k, q) {
                return true;
            }
            if let Role::Pending(m) = self.role[q]
                && self.fill_early(m, DETOUR_FILL)
            {
                return true;
            }
            if !self.thrifty
                && let Role::Pending(m) = self.role[q]
                && self.buffer_pending(m, &self.route_corridors(k))
            {
                return true;
            }
        }
        // The detoured swaps that cost more than a reroute, now that no
        // reroute or early fill was found.
        if self.thrifty && blocked.iter().any(|&(k, q)| self.swap_with(k, q, 1, false)) {
            return true;
        }
        // A careful order's straight trades and capped hand-overs that cost
        // more than a reroute, on the same terms.
        if self.careful
            && blocked.iter().any(|&(k, q)| {
                self.swap_with(k, q, 0, false) || self.swap_nearer(k, q, true, false)
            })
        {
            return true;
        }
        // A thrifty order buffers a particle still to move only when no
        // blocked move could be rerouted or filled early: the buffer push
        // and its way back cost more (CMU: 65 -> 72 of 100 layouts within
        // 1.05 LB_push). The plain repairs buffer in the loop above: at
        // N = 10,000 the extra reroute searches doubled the order (23 ->
        // 44 s) for no gain (push ratio 1.010131 -> 1.010174).
        if self.thrifty {
            for &(k, q) in blocked {
                if let Role::Pending(m) = self.role[q]
                    && self.buffer_pending(m, &self.route_corridors(k))
                {
                    return true;
                }
            }
        }
        for &(k, q) in blocked {
            if self.role[q] == Role::Idle {
                let avoid = self.route_corridors(k);
                if self.clear_way_then_buffer(q, &avoid, Blockers::Buffered) {
                    return true;
                }
            }
        }
        // Last, a nearer blocker takes the move over even past the cap: at
        // N = 10,000 the moves left stuck were 450-1,000 um from their
        // sites with 8 hand-overs spent, and each refusal cost a whole new
        // order (15 s, seven times).
        blocked
            .iter()
            .any(|&(k, q)| self.swap_nearer(k, q, false, false))
    }

    /// Fills move m's site now, before the moves that wait for it (their
    /// routes cross it): when m's own route is free of every particle (or,
    /// beside its site, a route within `fill` of it is) and each of them has
    /// a route that misses the site, within `fill` of its route now. m's
    /// particle is in another move's way, usually beside its site: pushed to
    /// a buffer spot instead, it came back the long way (CMU: mean push
    /// ratio 1.0810 -> 1.0743 with [`DETOUR_FILL`] alone).
    fn fill_early(&mut self, m: usize, fill: EarlyFill) -> bool {
        if !self.thrifty || !self.moves[m].pending {
            return false;
        }
        // m's own way may be blocked only where it stands (often the tip's
        // landing, CMU seed 2: a particle 1.9 um from its site went 27 um by
        // a buffer spot): a route at most `fill` longer, free now, will do.
        let own_route = match self.first_blocker(m) {
            None => None,
            Some(_) => {
                let p = self.moves[m].particle;
                let from = self.occ.pos[p];
                let len = route_length(from, &self.moves[m].route);
                if len > OWN_DETOUR_MAX_RADII * self.radius(p) {
                    return false;
                }
                let cap = len + fill.extra_radii * self.radius(p);
                let key = (m, from.x.to_bits(), from.y.to_bits(), cap.to_bits());
                if self.failed_own_routes.known(&key) {
                    return false;
                }
                let Some(route) = self.route_for(m, p, from, true, fill.waypoints, cap) else {
                    let (lo, hi) = self.search_box_of(p, from, self.obstacles.site(m));
                    self.failed_own_routes.remember(key, lo, hi);
                    return false;
                };
                Some(route)
            }
        };
        let waiters: Vec<usize> = (0..self.moves.len())
            .filter(|&j| self.moves[j].pending && self.moves[j].releases.contains(&m))
            .collect();
        // Marked filled while the waiters' routes are searched, so that
        // `route_for` makes them miss m's site; restored before m goes.
        self.moves[m].pending = false;
        let mut routes = Vec::with_capacity(waiters.len());
        for &j in &waiters {
            let p = self.moves[j].particle;
            let from = self.occ.pos[p];
            let cap = route_length(from, &self.moves[j].route) + fill.extra_radii * self.radius(p);
            let key = (m, j, p, from.x.to_bits(), from.y.to_bits(), cap.to_bits());
            let found = if self.failed_fills.known(&key) {
                None
            } else {
                self.route_for(j, p, from, false, fill.waypoints, cap)
            };
            match found {
                Some(route) => routes.push(route),
                None => {
                    let (lo, hi) = self.search_box_of(p, from, self.obstacles.site(j));
                    self.failed_fills.remember(key, lo, hi);
                    self.moves[m].pending = true;
                    return false;
                }
            }
        }
        self.moves[m].pending = true;
        for (j, route) in waiters.into_iter().zip(routes) {
            self.moves[j].route = route;
            self.compute_conflicts(j);
        }
        if let Some(route) = own_route {
            self.moves[m].route = route;
            self.compute_conflicts(m);
        }
        self.go(m);
        true
    }
}
