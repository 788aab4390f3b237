//! Buffer spots off the sites and out of the blocked moves' ways, and the
//! pushes that take a blocker there.

use super::Role;
use super::Scheduler;
use crate::plan::pushes::Corridor;
use crate::plan::route::route_length;
use nalgebra::Vector2;

/// Buffer spots weighed for a particle still to move.
const BUFFER_CANDIDATES: usize = 24;

/// Which idle particles a two-level buffer move
/// ([`Scheduler::clear_way_then_buffer`]) takes out of the way, and where to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Blockers {
    /// Those on the way (not on the spot), to any buffer spot: while the
    /// moves run.
    Buffered,
    /// Those on the way or the spot, to spots off the sites with the gap:
    /// once the pattern is whole.
    Parked,
}

impl Scheduler<'_> {
    /// Pushes idle particle q to a buffer spot clear of `avoid`; true on success.
    pub(super) fn buffer_idle(&mut self, q: usize, avoid: &[Corridor]) -> bool {
        let spot = self.buffer_spots(q, avoid).next();
        match spot {
            Some(spot) => {
                self.push(q, spot, true);
                true
            }
            None => false,
        }
    }

    /// Pushes move m's particle (in someone's way) to a buffer spot clear of
    /// `avoid` from which m still has a route, the spot that adds least to
    /// m's path (push there plus route on, against the straight move);
    /// true on success. Nearest spot first cost CMU's worst layouts a
    /// particle pushed away from beside its site and back.
    pub(super) fn buffer_pending(&mut self, m: usize, avoid: &[Corridor]) -> bool {
        let q = self.moves[m].particle;
        let from = self.occ.pos[q];
        let site = self.obstacles.site(m);
        let spots: Vec<Vector2<f64>> = self
            .buffer_spots(q, avoid)
            .take(BUFFER_CANDIDATES)
            .collect();
        // Spots off the sites first (the order of `buffer_spots`), each
        // group by the least length a route through it can have.
        let mut by_bound: Vec<(bool, f64, Vector2<f64>)> = spots
            .into_iter()
            .map(|s| {
                (
                    !self.off_sites(q, s),
                    (s - from).norm() + (site - s).norm(),
                    s,
                )
            })
            .collect();
        if self.thrifty {
            by_bound.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        }
        let mut best: Option<(f64, Vector2<f64>, Vec<Vector2<f64>>)> = None;
        for (on_site, bound, spot) in by_bound {
            if let Some(b) = &best
                && (on_site || bound >= b.0 || !self.thrifty)
            {
                break;
            }
            let push = (spot - from).norm();
            let cap = best.as_ref().map_or(f64::INFINITY, |b| b.0 - push);
            if let Some(route) = self.route_for(m, q, spot, false, 2, cap) {
                let total = push + route_length(spot, &route);
                best = Some((total, spot, route));
            }
        }
        let Some((_, spot, route)) = best else {
            return false;
        };
        self.push(q, spot, true);
        self.moves[m].route = route;
        self.compute_conflicts(m);
        true
    }

    /// Free spots near particle q, reachable now in one push and clear of
    /// `avoid`: off every site first, nearest first; then spots on sites.
    /// Lazy: callers take the first few, and each spot costs a corridor test.
    pub(super) fn buffer_spots<'s>(
        &'s self,
        q: usize,
        avoid: &'s [Corridor],
    ) -> impl Iterator<Item = Vector2<f64>> + 's {
        let usable = move |spot: &Vector2<f64>| self.spot_usable(q, *spot, avoid);
        let nearest_out = if self.role[q] == Role::Idle {
            avoid
        } else {
            &[]
        };
        let spots = self.ring(q, nearest_out, None);
        let on = spots.clone();
        let off = spots.into_iter().filter(move |s| self.off_sites(q, *s));
        let on = on.into_iter().filter(move |s| !self.off_sites(q, *s));
        off.chain(on).filter(usable)
    }

    /// True when particle q can be pushed from where it is to `spot` now
    /// (free way, and [`Self::spot_free`]).
    pub(super) fn spot_usable(&self, q: usize, spot: Vector2<f64>, avoid: &[Corridor]) -> bool {
        self.spot_free(q, spot, avoid)
            && self
                .occ
                .first_hit(
                    &self.corridor(q, self.occ.pos[q], spot),
                    q,
                    self.config.clearance_m,
                )
                .is_none()
    }

    /// True when `spot` is inside the field, free of other particles for
    /// particle q, and clear of `avoid` (whatever lies on the way there).
    fn spot_free(&self, q: usize, spot: Vector2<f64>, avoid: &[Corridor]) -> bool {
        let cl = self.config.clearance_m;
        self.spot_clear_of(q, spot, avoid) && self.occ.disc_free(spot, self.radius(q), Some(q), cl)
    }

    /// True when `spot` is inside the field and particle q there would be
    /// clear of `avoid` (other particles not asked).
    fn spot_clear_of(&self, q: usize, spot: Vector2<f64>, avoid: &[Corridor]) -> bool {
        let (r, cl) = (self.radius(q), self.config.clearance_m);
        self.reach.contains(spot) && avoid.iter().all(|c| !c.hits(spot, r, cl))
    }

    /// True when particle q at `spot` keeps its clearance from every site
    /// ([`Self::site_discs`]).
    pub(super) fn off_sites(&self, q: usize, spot: Vector2<f64>) -> bool {
        !self.site_discs(q).covered_by(spot, self.radius(q))
    }

    /// The sites as discs of the radius they take, for the parking
    /// questions of particle q: an idle particle ends where it is left, so
    /// it keeps the keep-clear gap too ([`PlanConfig::stray_clearance_m`](crate::plan::PlanConfig::stray_clearance_m));
    /// one still to move keeps the clearance only.
    fn site_discs(&self, q: usize) -> crate::plan::parking::SiteDiscs<'_> {
        let clearance_m = if self.role[q] == Role::Idle {
            self.config.stray_clearance_m()
        } else {
            self.config.clearance_m
        };
        crate::plan::parking::SiteDiscs {
            grid: &self.site_grid,
            centres: &self.site_pts,
            radius_m: self.site_radius_m,
            clearance_m,
        }
    }

    /// The sites as the peel sees them
    /// ([`SiteObstacles::covered_by`](crate::plan::peel::SiteObstacles::covered_by)):
    /// a filled site's particle may lie anywhere within the on-site tolerance, so a
    /// spot off the sites keeps that too. A cycle break's spots kept only
    /// the clearance (10.15 um from a site for 10 um particles, the peel
    /// asks 10.35): the nearest spot off the other sites still covered
    /// them, and the break fell back to quarter-pitch ring spots or none
    /// (CMU seed 82 of the 40-60 scenes: 1.1716 -> 1.0403).
    pub(super) fn peel_site_discs(&self, q: usize) -> crate::plan::parking::SiteDiscs<'_> {
        let mut discs = self.site_discs(q);
        discs.clearance_m += self.config.on_site_tolerance_m;
        discs
    }

    /// Candidate spots around particle q, with the nearest ones off the
    /// sites and clear of `avoid` (see
    /// [`crate::plan::parking::ring_off_sites`]).
    pub(super) fn ring(
        &self,
        q: usize,
        avoid: &[Corridor],
        own: Option<usize>,
    ) -> Vec<Vector2<f64>> {
        let cl = self.config.clearance_m;
        let r = self.radius(q);
        let discs = if self.wide_spots {
            self.peel_site_discs(q)
        } else {
            self.site_discs(q)
        };
        crate::plan::parking::ring_off_sites(
            self.occ.pos[q],
            r,
            &discs,
            &|spot| avoid.iter().any(|c| c.hits(spot, r, cl)),
            own,
        )
    }

    /// Two-level buffer move: idle particle q has no free push to a spot
    /// clear of `avoid`, but some spot's way is blocked only by idle
    /// particles that can each be buffered directly; those go first, then q.
    /// True when at least the first of them moved.
    ///
    /// `Blockers::Parked` (the pattern is whole): the idle particles in the
    /// way may also sit on q's spot, and they too go only to spots that
    /// keep the gap, so that clearing q leaves no other stray.
    pub(super) fn clear_way_then_buffer(
        &mut self,
        q: usize,
        avoid: &[Corridor],
        blockers: Blockers,
    ) -> bool {
        let from = self.occ.pos[q];
        let r = self.radius(q);
        let cl = self.config.clearance_m;
        let parked = blockers == Blockers::Parked;
        for spot in self.ring(q, avoid, None) {
            let open = if parked {
                self.spot_clear_of(q, spot, avoid)
            } else {
                self.spot_free(q, spot, avoid)
            };
            if !self.off_sites(q, spot) || !open {
                continue;
            }
            let way = self.corridor(q, from, spot);
            let hits = self.occ.all_hits(&way, q, cl);
            if hits.is_empty() || hits.len() > 2 || hits.iter().any(|&h| self.role[h] != Role::Idle)
            {
                continue;
            }
            let mut moved = false;
            for &h in &hits {
                let mut keep_clear = avoid.to_vec();
                keep_clear.push(way.clone());
                let spot =
                    (self.buffer_spots(h, &keep_clear)).find(|t| !parked || self.off_sites(h, *t));
                match spot {
                    Some(t) => {
                        self.push(h, t, true);
                        moved = true;
                    }
                    None => break,
                }
            }
            if moved {
                if self.occ.first_hit(&way, q, cl).is_none()
                    && self.occ.disc_free(spot, r, Some(q), cl)
                {
                    self.push(q, spot, true);
                }
                return true;
            }
        }
        false
    }
}
