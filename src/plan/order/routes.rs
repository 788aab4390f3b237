//! Routes for a move: straight or through waypoints, around the sites
//! filled before it and, when rerouting, around the particles where they
//! are now.

use super::Role;
use super::Scheduler;
use crate::plan::failed_routes::search_box;
use crate::plan::pushes::Corridor;
use crate::plan::route::find_route_within;
use crate::plan::route::route_length;
use nalgebra::Vector2;

/// Least length a shortcut must save, metres (less is rounding).
const SHORTCUT_GAIN_M: f64 = 1e-9;

impl Scheduler<'_> {
    /// Route for move k's site with `particle` starting at `from`, missing
    /// the sites filled before it (by rank) or already filled, and, when
    /// `dynamic`, every other particle where it is now, with at most
    /// `waypoints` waypoints, shorter than `shorter_than_m` (infinite: any
    /// length). A detour search that found nothing is remembered until
    /// something changes where it looked (one cut short by the length is not).
    pub(super) fn route_for(
        &self,
        k: usize,
        particle: usize,
        from: Vector2<f64>,
        dynamic: bool,
        waypoints: usize,
        shorter_than_m: f64,
    ) -> Option<Vec<Vector2<f64>>> {
        let r = self.radius(particle);
        let free = |c: &Corridor| self.leg_free(k, particle, c, dynamic);
        let to = self.obstacles.site(k);
        if waypoints == 0 {
            return ((to - from).norm() < shorter_than_m
                && free(&Corridor::new(from, to, r, self.config)))
            .then(|| vec![to]);
        }
        let key = (
            k,
            particle,
            from.x.to_bits(),
            from.y.to_bits(),
            dynamic,
            waypoints,
        );
        if self.failed_routes.borrow().known(&key) {
            return None;
        }
        let res = find_route_within(
            from,
            to,
            r,
            self.config,
            self.reach,
            waypoints,
            shorter_than_m,
            &free,
        );
        if res.is_none() && shorter_than_m == f64::INFINITY {
            let (lo, hi) = self.search_box_of(particle, from, to);
            self.failed_routes.borrow_mut().remember(key, lo, hi);
        }
        res
    }

    /// The box a route search for `particle` from `from` to `to` looks in
    /// (what must change there before a failed search is worth repeating).
    pub(super) fn search_box_of(
        &self,
        particle: usize,
        from: Vector2<f64>,
        to: Vector2<f64>,
    ) -> (Vector2<f64>, Vector2<f64>) {
        search_box(
            from,
            to,
            self.radius(particle),
            self.occ.max_radius_m,
            self.config,
        )
    }

    /// True when corridor `c` of `particle` on move k's route misses the
    /// sites filled before k (by rank) or already filled, and, when
    /// `dynamic`, every other particle where it is now.
    fn leg_free(&self, k: usize, particle: usize, c: &Corridor, dynamic: bool) -> bool {
        let rank = self.moves[k].rank;
        // Particles first: at large N they reject most corridors, and
        // more cheaply than the sites.
        (!dynamic
            || self
                .occ
                .first_hit(c, particle, self.config.clearance_m)
                .is_none())
            && self.obstacles.misses(c, |s| {
                s != k && (self.moves[s].rank < rank || !self.moves[s].pending)
            })
    }

    /// Route for move k with `particle` from where it is now, missing the
    /// sites as [`Self::route_for`] does: straight, else through the
    /// waypoints of k's route now. A particle in the way of k's first leg
    /// follows the rest of that route; the route's waypoints were chosen to
    /// pass the sites filled before k, so a straight push usually hits them.
    pub(super) fn straight_or_along(&self, k: usize, particle: usize) -> Option<Vec<Vector2<f64>>> {
        let from = self.occ.pos[particle];
        if let Some(route) = self.route_for(k, particle, from, false, 0, f64::INFINITY) {
            return Some(route);
        }
        let route = &self.moves[k].route;
        let mut at = from;
        let along = route.len() > 1
            && route.iter().all(|&b| {
                let c = self.corridor(particle, at, b);
                at = b;
                self.leg_free(k, particle, &c, false)
            });
        along.then(|| route.clone())
    }

    /// A shorter route for move k, which goes now: free of every particle
    /// where it is now, it need not miss the sites still empty. The route
    /// was chosen to miss the sites ranked before k (the peel) or the
    /// particles as they were (a reroute); a site still empty now is filled
    /// after k, so passing it costs nothing, and what blocked a detour may
    /// have moved since.
    pub(super) fn shortcut(&self, k: usize) -> Option<Vec<Vector2<f64>>> {
        let m = &self.moves[k];
        if m.route.len() < 2 {
            return None;
        }
        let p = m.particle;
        let from = self.occ.pos[p];
        let free = |c: &Corridor| {
            self.occ.first_hit(c, p, self.config.clearance_m).is_none()
                && self
                    .obstacles
                    .misses(c, |s| s != k && !self.moves[s].pending)
        };
        find_route_within(
            from,
            self.obstacles.site(k),
            self.radius(p),
            self.config,
            self.reach,
            m.route.len() - 1,
            route_length(from, &m.route) - SHORTCUT_GAIN_M,
            &free,
        )
    }

    /// What [`Self::reroute`] would add to move k's planned path (infinite
    /// when it finds no route).
    pub(super) fn reroute_added(&self, k: usize) -> f64 {
        let p = self.moves[k].particle;
        let from = self.occ.pos[p];
        self.route_for(k, p, from, true, 2, f64::INFINITY)
            .map_or(f64::INFINITY, |route| {
                route_length(from, &route) - route_length(from, &self.moves[k].route)
            })
    }

    /// Blocked move k's detour: its blocker q buffered when idle, else k
    /// rerouted around the particles; true on success.
    pub(super) fn detour(&mut self, k: usize, q: usize) -> bool {
        let avoid = self.route_corridors(k);
        (self.role[q] == Role::Idle && self.buffer_idle(q, &avoid)) || self.reroute(k)
    }

    /// Reroutes move k around the particles where they are now (and the
    /// sites filled before it); true when its route changed.
    pub(super) fn reroute(&mut self, k: usize) -> bool {
        let p = self.moves[k].particle;
        match self.route_for(k, p, self.occ.pos[p], true, 2, f64::INFINITY) {
            Some(route) if route != self.moves[k].route => {
                self.moves[k].route = route;
                self.compute_conflicts(k);
                true
            }
            _ => false,
        }
    }
}
