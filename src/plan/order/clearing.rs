//! Particles off the sites before and while the peel orders the moves:
//! idle particles that cover a site are pushed off first, and a covering
//! cycle is broken by pushing one of its particles aside.

use super::Refusal;
use super::Role;
use super::Scheduler;
use super::buffers::Blockers;
use crate::plan::peel::FillOrder;
use crate::plan::peel::peel;
use crate::plan::pushes::Corridor;
use nalgebra::Vector2;

/// Buffer pushes allowed to break covering cycles before the peel gives up.
const MAX_CYCLE_BREAKS: usize = 8;

/// How short of its site a particle breaking a covering cycle stops at
/// most, metres: 0.5 um still covered the neighbouring sites (pitch 10.5 um,
/// covered within 10.35 um) and gave nothing on CMU; 0.1 um gave 88 -> 91
/// of 100 layouts within 1.05 LB_push.
const TOWARD_SITE_GAP_M: f64 = 0.1e-6;

impl Scheduler<'_> {
    /// Pushes every idle particle that covers a site (or lies within the
    /// keep-clear gap) to a spot off the sites: before the moves start, and
    /// once more after them (`pattern_whole`); one with no free parking
    /// push now is left to the repairs, or after the moves, where it is.
    /// After them, a particle whose spots are all taken or walled in by
    /// other idle particles has those parked first
    /// ([`Blockers::Parked`]): the closed-loop study's seed 5 had left one
    /// 0.28 um from the M, the spots up between the M and the U taken by
    /// idle particle 4 or behind it.
    pub(super) fn clear_sites(&mut self, pattern_whole: bool) {
        let mut covering: Vec<usize> = (0..self.occ.pos.len())
            .filter(|&q| self.role[q] == Role::Idle && !self.off_sites(q, self.occ.pos[q]))
            .collect();
        for _round in 0..3 {
            let before = covering.len();
            covering.retain(|&q| {
                let parked = self.push_off_sites(q, &[])
                    || (pattern_whole
                        && self.clear_way_then_buffer(q, &[], Blockers::Parked)
                        && self.off_sites(q, self.occ.pos[q]));
                !parked
            });
            if covering.is_empty() || covering.len() == before {
                break;
            }
        }
    }

    /// Pushes idle particle q to the nearest free spot off the sites (with
    /// the keep-clear gap) out of `avoid`; true when it moved.
    pub(super) fn push_off_sites(&mut self, q: usize, avoid: &[Corridor]) -> bool {
        let spot = self.buffer_spots(q, avoid).find(|s| self.off_sites(q, *s));
        if let Some(spot) = spot {
            self.push(q, spot, true);
        }
        spot.is_some()
    }

    /// Particle p, idle now that move k went to another, is pushed out of
    /// the keep-clear gap at once (out of k's way) when it lies in it:
    /// after the moves, the letters filled round it may wall it in (CMU
    /// seed 3: 0.9 um beside the U, no free push left). Nothing when the
    /// plan keeps no gap beyond the clearance.
    pub(super) fn leave_clear(&mut self, p: usize, k: usize) {
        let pos = self.occ.pos[p];
        if self.config.keep_clear_m <= 0.0 || self.off_sites(p, pos) {
            return;
        }
        let way = self.route_corridors(k);
        self.push_off_sites(p, &way);
    }

    /// Peels the sites; when it is stuck because particles cover each
    /// other's sites (a cycle), pushes one of them to a spot where it covers
    /// no site but its own, the one whose spot adds least to its path
    /// ([`Self::cycle_break_spot`]), and peels again.
    pub(super) fn peel_with_clearing(&mut self, radii: &[f64]) -> Result<FillOrder, Refusal> {
        let mut breaks = 0;
        loop {
            let starts: Vec<Vector2<f64>> = self
                .moves
                .iter()
                .map(|m| self.occ.pos[m.particle])
                .collect();
            let walled = match peel(&self.obstacles, &starts, radii, self.config, self.reach) {
                Ok(order) => return Ok(order),
                Err(w) => w,
            };
            // Of the particles that cover other sites, the one whose spot
            // adds least to its path moves (the first one with a spot did
            // before: often the one whose own site the other covers, so its
            // way there was not free).
            let best = walled
                .stuck
                .iter()
                .filter(|&&k| {
                    let p = self.moves[k].particle;
                    self.obstacles
                        .covered_by(self.occ.pos[p], self.radius(p))
                        .iter()
                        .any(|&s| s != k)
                })
                .filter_map(|&k| Some((k, self.cycle_break_spot(k)?)))
                .min_by(|a, b| a.1.0.total_cmp(&b.1.0));
            let Some((k, (_, spot))) = best.filter(|_| breaks < MAX_CYCLE_BREAKS) else {
                return Err(self.refusal(walled.to_string(), &walled.stuck));
            };
            self.push(self.moves[k].particle, spot, true);
            breaks += 1;
        }
    }

    /// Where move k's particle goes to break a covering cycle: a spot where
    /// it covers no site but its own, free to push to now, that adds least
    /// to its path; on its straight way to its site ([`Self::toward_site`])
    /// first, else the ring's spots by added path (the nearest spot off
    /// the other sites came first before, CMU seed 46: 6 um out and back).
    /// Returns the path it adds and the spot.
    fn cycle_break_spot(&self, k: usize) -> Option<(f64, Vector2<f64>)> {
        let p = self.moves[k].particle;
        let (from, site, r) = (self.occ.pos[p], self.obstacles.site(k), self.radius(p));
        let added = |s: &Vector2<f64>| (s - from).norm() + (site - s).norm() - (site - from).norm();
        let own = Some(self.moves[k].site_index);
        // The ring is found only when no spot on the way does.
        let ring = std::iter::once_with(|| {
            let ring = crate::plan::parking::ring_off_sites(
                from,
                r,
                &self.peel_site_discs(p),
                &|_| false,
                own,
            );
            let mut by_added: Vec<(f64, Vector2<f64>)> =
                ring.into_iter().map(|s| (added(&s), s)).collect();
            by_added.sort_by(|a, b| a.0.total_cmp(&b.0));
            by_added
        })
        .flatten()
        .map(|(_, s)| s);
        self.toward_site(k)
            .chain(ring)
            .find(|s| {
                self.obstacles.covered_by(*s, r).iter().all(|&c| c == k)
                    && self.spot_usable(p, *s, &[])
            })
            .map(|s| (added(&s), s))
    }

    /// Spots on the straight way of move k's particle to its site, nearest
    /// the site first (the last within [`TOWARD_SITE_GAP_M`] of it): a push
    /// there adds nothing to the move's path. A particle covering other
    /// sites than its own (a covering cycle) was pushed to a ring spot
    /// instead, CMU seed 76 10 um out and back (eleventh pass).
    fn toward_site(&self, k: usize) -> impl Iterator<Item = Vector2<f64>> + '_ {
        let from = self.occ.pos[self.moves[k].particle];
        let site = self.obstacles.site(k);
        let len = (site - from).norm();
        let near = (1.0 - TOWARD_SITE_GAP_M / len.max(1e-12)).max(0.0);
        [near, 0.75, 0.5, 0.25]
            .into_iter()
            .filter(move |&t| t <= near)
            .map(move |t| from + (site - from) * t)
    }
}
