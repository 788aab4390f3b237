//! Collision-free ordering of the moves, minimising tip travel.
//!
//! Unassigned particles that cover a site are first pushed off the sites.
//! Then [`peel`](super::peel) gives every move a fill rank and a route
//! (straight, or through waypoints) that misses every site filled before
//! it; a move waits for the moves whose routes cross its site (always lower
//! ranks, so no cycle). Among the moves that wait for nobody, the one whose
//! first landing point is nearest the tip goes next, provided every leg of
//! its route (particle and tip corridors, parry2d) misses every particle
//! where it is now. Otherwise a repair: an unassigned blocker is pushed to
//! a buffer spot off the sites, the blocked move is rerouted around the
//! particles, or a blocking particle still to move is buffered and
//! rerouted from there. Repairs are bounded; beyond them, or when none
//! applies, the planner refuses and names the blocked move and its
//! blocker.
//!
//! This file holds the scheduler and its loop; the rest, one concern a
//! file: `clearing` (particles off the sites before and during the peel),
//! `repair` (the repairs in the order they are tried, and early fills),
//! `routes` (reroutes and shortcuts), `trades` (sites traded or handed
//! over between a move and its blocker), `buffers` (buffer spots and the
//! pushes there).

mod buffers;
mod clearing;
mod repair;
mod routes;
mod trades;

use super::failed_routes::FailedRoutes;
use super::grid::Grid;
use super::layout::Layout;
use super::occupancy::Occupancy;
use super::pattern::Site;
use super::peel::SiteObstacles;
use super::pushes::{Corridor, approach_point, landing_point, max_push_len, split_long, tip_end};
use super::route::Reach;
use super::shortcuts::take_shortcuts;
use super::{PlanConfig, Step};
use nalgebra::Vector2;
use std::cell::RefCell;

/// An order that spends this share of its search effort
/// ([`PlanConfig::search_effort`]) without completing a move is refused:
/// orders that planned went at most 216 per move and particle between two
/// completed moves (CMU's 120 acceptance layouts: 195; a sweep of 60 other
/// fields, radii 0.5-5 um, uniform, clustered and adversarial: 216), a fifth
/// of the default 5,000 is 1,000; the refused ones had gone thousands
/// without one, 38 of 38 moves often blocked all the way.
pub const STALL_SHARE: u64 = 5;

/// Why no order was found, and which (particle index, site index) moves
/// were stuck: the caller may assign those sites to other particles and try
/// again.
#[derive(Debug, Clone)]
pub struct Refusal {
    /// What blocked what, for the user.
    pub reason: String,
    /// The stuck moves as (particle index, site index).
    pub stuck_pairs: Vec<(usize, usize)>,
}

/// Ordered push steps and how many of them are buffer/detour pushes.
#[derive(Debug, Clone)]
pub struct Ordered {
    /// Push steps in execution order (no tip travel yet).
    pub steps: Vec<Step>,
    /// Pushes that went to a buffer spot or a waypoint.
    pub buffer_pushes: usize,
    /// (particle index, site index) of every site as executed: repairs may
    /// hand a site to another particle than the assignment's.
    pub pairs: Vec<(usize, usize)>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// Not assigned to any site.
    Idle,
    /// Assigned to move `k`, not yet done.
    Pending(usize),
    /// On its final site, or immovable: must not be touched.
    Placed,
}

/// One particle-to-site move.
#[derive(Debug, Clone)]
struct Move {
    particle: usize,
    /// Index of the site in the caller's list.
    site_index: usize,
    /// Waypoints then the site, from the particle's current position.
    route: Vec<Vector2<f64>>,
    rank: usize,
    pending: bool,
    /// Pending moves whose routes cross this move's site.
    wait: usize,
    /// Moves this one's route crosses (they wait for it).
    releases: Vec<usize>,
    /// The last blocker found, with what the test saw; still valid while
    /// none of it changed (a blocked move is re-tested every step otherwise,
    /// which made ordering cubic in the number of moves).
    blocked: Option<BlockedBy>,
}

/// A blocker found for a move: the blocker, and the particle positions and
/// route the corridor test used.
#[derive(Debug, Clone, PartialEq)]
struct BlockedBy {
    blocker: usize,
    blocker_at: Vector2<f64>,
    particle_at: Vector2<f64>,
    route: Vec<Vector2<f64>>,
}

struct Scheduler<'a> {
    config: &'a PlanConfig,
    layout: &'a Layout,
    occ: Occupancy,
    role: Vec<Role>,
    moves: Vec<Move>,
    /// Sites of the moves (index = move) and fixed particles.
    obstacles: SiteObstacles,
    /// The largest radius a site takes ([`PlanConfig::site_radius_for`]),
    /// looked up once: buffer and trade queries ask it on every call.
    site_radius_m: f64,
    /// Every site (buffer spots stay off all of them).
    site_grid: Grid,
    site_pts: Vec<Vector2<f64>>,
    reach: Reach,
    steps: Vec<Step>,
    buffer_pushes: usize,
    tip: Option<Vector2<f64>>,
    /// Route searches that found nothing, until a change where they looked.
    failed_routes: RefCell<FailedRoutes>,
    /// Early fills refused because a waiting move had no route short
    /// enough: (filled move, waiting move, its particle, start x, start y,
    /// length cap bits), until a site is filled where the search looked.
    failed_fills: FailedRoutes<(usize, usize, usize, u64, u64, u64)>,
    /// Early fills refused because the filled move's own way had no short
    /// route free now: (move, start x, start y, length cap bits), until a
    /// push or a filled site touches where the search looked.
    failed_own_routes: FailedRoutes<(usize, u64, u64, u64)>,
    /// (particle, site) pairs no swap may make.
    banned: &'a [(usize, usize)],
    /// [`Scheduler::swap_nearer`] hand-overs per move, capped so that two
    /// moves cannot hand a site back and forth for ever.
    nearer_swaps: Vec<u8>,
    /// Early fills and buffer spots by added path are tried (see [`order_moves`]).
    thrifty: bool,
    /// Every trade of sites is weighed against rerouting the blocked move
    /// (see [`CAREFUL_MAX_MOVES`]).
    careful: bool,
    /// A blocked move is rerouted (or its idle blocker buffered) before any
    /// early fill or trade of sites (see [`Repairs::DetourFirst`]).
    detour_first: bool,
    /// Every spot off the sites keeps the peel's margin
    /// ([`Scheduler::peel_site_discs`]), not only a cycle break's: the last
    /// try of [`order_moves`].
    wide_spots: bool,
}

/// Which repairs an order may make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Repairs {
    /// The thrifty repairs (early fills, buffer spots by added path) up to
    /// `THRIFTY_MAX_MOVES` moves; the plain ones after a refusal or above.
    Thrifty,
    /// The plain repairs only.
    Plain,
    /// The thrifty repairs, but a blocked move is first rerouted around the
    /// particles (or its idle blocker buffered) before any early fill or
    /// trade of sites: trades that each look cheap can add up (CMU seed 46:
    /// +6.3 um of traded sites, 1.0737 LB_push thrifty, 1.0433 refined
    /// with these). A second opinion only (see `plan::second_opinion`).
    DetourFirst,
}

/// Orders the moves `pairs` (particle index, site index) into collision-free
/// pushes; particles in `on_site` (and immovable ones) are never pushed, and
/// no repair hands a site to a particle it is `banned` from (pairs that got
/// stuck in an earlier try).
pub fn order_moves(
    layout: &Layout,
    sites: &[Site],
    pairs: &[(usize, usize)],
    on_site: &[usize],
    banned: &[(usize, usize)],
    config: &PlanConfig,
    repairs: Repairs,
) -> Result<Ordered, Refusal> {
    // The repairs that save push distance can leave a move boxed in where
    // the plain repairs did not, so a refused thrifty order is ordered
    // again without them. Parking spots that keep only the clearance from
    // the sites can crowd a later move's way; a refused order is tried last
    // with every spot keeping the peel's margin (CMU seed 66 of the 40-60
    // scenes: refused, then planned at 1.0477 LB_push; as the only spots
    // they made the other plans longer, mean 1.0247 -> 1.0278).
    let detour_first = repairs == Repairs::DetourFirst;
    let order = |thrifty, wide_spots| {
        let repairs = (thrifty, detour_first, wide_spots);
        order_once(layout, sites, pairs, on_site, banned, config, repairs)
    };
    if repairs == Repairs::Plain || pairs.len() > THRIFTY_MAX_MOVES {
        return order(false, false).or_else(|_| order(false, true));
    }
    order(true, false)
        .or_else(|_| order(false, false))
        .or_else(|_| order(true, true))
}

/// One try of [`order_moves`], with the thrifty repairs or without,
/// detours first or not, and wide spots or not (`(thrifty, detour_first,
/// wide_spots)`).
fn order_once(
    layout: &Layout,
    sites: &[Site],
    pairs: &[(usize, usize)],
    on_site: &[usize],
    banned: &[(usize, usize)],
    config: &PlanConfig,
    (thrifty, detour_first, wide_spots): (bool, bool, bool),
) -> Result<Ordered, Refusal> {
    let mut role: Vec<Role> = layout
        .particles
        .iter()
        .map(|q| {
            if config.immovable.contains(&q.id) {
                Role::Placed
            } else {
                Role::Idle
            }
        })
        .collect();
    let mut move_sites = Vec::new();
    let mut moves = Vec::new();
    let mut placed_pairs = Vec::new();
    for &(p, s) in pairs {
        let target = sites[s].centre_m;
        if on_site.contains(&p) || (layout.particles[p].centre_m - target).norm() <= 1e-12 {
            role[p] = Role::Placed;
            placed_pairs.push((p, s));
        } else {
            role[p] = Role::Pending(moves.len());
            move_sites.push(target);
            moves.push(Move {
                particle: p,
                site_index: s,
                route: vec![target],
                rank: 0,
                pending: true,
                wait: 0,
                releases: Vec::new(),
                blocked: None,
            });
        }
    }
    let fixed: Vec<(Vector2<f64>, f64)> = (0..layout.particles.len())
        .filter(|&q| role[q] == Role::Placed)
        .map(|q| (layout.particles[q].centre_m, layout.particles[q].radius_m))
        .collect();
    let radii: Vec<f64> = moves
        .iter()
        .map(|m| layout.particles[m.particle].radius_m)
        .collect();
    let r = layout.max_radius_m();
    // Sites are held at the largest radius a site takes: moves may trade particles.
    let site_radius_m = config.site_radius_for(layout);
    let site_radii = vec![site_radius_m; moves.len()];
    let site_pts: Vec<Vector2<f64>> = sites.iter().map(|s| s.centre_m).collect();
    let n_moves = moves.len();
    let mut sch = Scheduler {
        config,
        layout,
        occ: Occupancy::new(layout),
        role,
        moves,
        obstacles: SiteObstacles::new(move_sites, site_radii, fixed, config),
        site_radius_m,
        site_grid: Grid::new(site_pts.iter().copied(), 2.0 * r),
        site_pts,
        reach: Reach::of_layout(layout),
        steps: Vec::new(),
        buffer_pushes: 0,
        tip: config.tip_start_m,
        failed_routes: Default::default(),
        failed_fills: Default::default(),
        failed_own_routes: Default::default(),
        banned,
        nearer_swaps: vec![0; n_moves],
        thrifty,
        careful: thrifty && n_moves <= CAREFUL_MAX_MOVES,
        detour_first,
        wide_spots,
    };
    sch.clear_sites(false);
    let order = sch.peel_with_clearing(&radii)?;
    for (k, m) in sch.moves.iter_mut().enumerate() {
        m.rank = order.rank[k];
        m.route = order.route[k].clone();
    }
    for k in 0..sch.moves.len() {
        sch.compute_conflicts(k);
    }
    sch.run()?;
    // A particle whose site a repair handed to another is idle where it
    // stopped, perhaps within the keep-clear gap (CMU seed 1: 1.6 um
    // inside the C); the pattern is whole now, so only its own way counts.
    sch.clear_sites(true);
    let (steps, fewer) = take_shortcuts(sch.steps, layout, &sch.site_pts, config);
    Ok(Ordered {
        pairs: placed_pairs
            .into_iter()
            .chain(sch.moves.iter().map(|m| (m.particle, m.site_index)))
            .collect(),
        steps,
        // The pushes a shortcut removed were buffer or waypoint pushes.
        buffer_pushes: sch.buffer_pushes.saturating_sub(fewer),
    })
}

/// Most moves for which a thrifty order also weighs its straight trades
/// and capped hand-overs against rerouting the blocked move, as it weighs
/// the detoured trades, and makes them unweighed only when no reroute or
/// early fill is found. A trade runs straight, but it may lengthen the two
/// moves more than a detour of one would: CMU seed 69 traded +9.2 um where
/// its reroute cost less (1.058 -> 1.037 LB_push; 95 -> 96 of 100 layouts
/// within 1.05). At N = 100 and 300 it changed no plan but made the order
/// 1.8x and 3.3x slower, and at N = 1,000 it made the push ratio worse
/// (1.002560 -> 1.003970) and the plan 3x slower.
const CAREFUL_MAX_MOVES: usize = 64;

/// Most moves for which the thrifty repairs are tried: at N = 3,000 they
/// doubled the order's time (0.44 -> 0.9 s) for a push ratio 1.00393 ->
/// 1.00391, and at N = 10,000 they boxed a move in (refused after 30 s).
const THRIFTY_MAX_MOVES: usize = 1_000;

impl Scheduler<'_> {
    fn radius(&self, p: usize) -> f64 {
        self.layout.particles[p].radius_m
    }

    fn corridor(&self, p: usize, from: Vector2<f64>, to: Vector2<f64>) -> Corridor {
        Corridor::new(from, to, self.radius(p), self.config)
    }

    /// Corridors of move k's route from its particle's current position.
    fn route_corridors(&self, k: usize) -> Vec<Corridor> {
        let p = self.moves[k].particle;
        let mut at = self.occ.pos[p];
        self.moves[k]
            .route
            .iter()
            .map(|&b| {
                let c = self.corridor(p, at, b);
                at = b;
                c
            })
            .collect()
    }

    /// Recomputes which pending moves wait for move k (their site is on its route).
    fn compute_conflicts(&mut self, k: usize) {
        for b in std::mem::take(&mut self.moves[k].releases) {
            self.moves[b].wait -= 1;
        }
        let mut list: Vec<usize> = self
            .route_corridors(k)
            .iter()
            .flat_map(|c| self.obstacles.sites_hit(c))
            .filter(|&b| b != k && self.moves[b].pending && self.moves[b].rank > self.moves[k].rank)
            .collect();
        list.sort_unstable();
        list.dedup();
        for &b in &list {
            self.moves[b].wait += 1;
        }
        self.moves[k].releases = list;
    }

    /// Where the tip lands for move k's first leg.
    fn landing(&self, k: usize) -> Vector2<f64> {
        let p = self.moves[k].particle;
        let from = self.occ.pos[p];
        let to = self.moves[k].route[0];
        landing_point(
            from,
            to,
            approach_point(from, to, self.radius(p), self.config),
            self.config,
        )
    }

    /// [`Self::first_blocker`], reusing the last answer while the blocker,
    /// the move's particle and its route are where they were: a blocker that
    /// has not moved still blocks.
    fn cached_blocker(&mut self, k: usize) -> Option<usize> {
        let m = &self.moves[k];
        if let Some(b) = &m.blocked
            && self.occ.pos[b.blocker] == b.blocker_at
            && self.occ.pos[m.particle] == b.particle_at
            && b.route == m.route
        {
            return Some(b.blocker);
        }
        let found = self.first_blocker(k);
        let m = &self.moves[k];
        let blocked = found.map(|q| BlockedBy {
            blocker: q,
            blocker_at: self.occ.pos[q],
            particle_at: self.occ.pos[m.particle],
            route: m.route.clone(),
        });
        self.moves[k].blocked = blocked;
        found
    }

    /// First particle that a leg of move k's route hits now.
    fn first_blocker(&self, k: usize) -> Option<usize> {
        let p = self.moves[k].particle;
        self.route_corridors(k)
            .iter()
            .find_map(|c| self.occ.first_hit(c, p, self.config.clearance_m))
    }

    /// Appends the push steps of particle p going straight to `to` and updates positions.
    fn push(&mut self, p: usize, to: Vector2<f64>, buffer: bool) {
        let from = self.occ.pos[p];
        let r = self.radius(p);
        let reach = Vector2::repeat(r + self.config.clearance_m);
        let (lo, hi) = (from.inf(&to) - reach, from.sup(&to) + reach);
        self.failed_routes.get_mut().forget_near(lo, hi);
        self.failed_own_routes.forget_near(lo, hi);
        for (a, b) in split_long(from, to, max_push_len(r, self.config)) {
            let approach = approach_point(a, b, r, self.config);
            self.steps.push(Step::Push {
                particle: self.layout.particles[p].id,
                from_m: a,
                to_m: b,
                approach_m: approach,
                contact_angle_rad: self.config.contact_angle_rad,
            });
            self.tip = Some(tip_end(a, b, approach));
            if buffer {
                self.buffer_pushes += 1;
            }
        }
        self.occ.set(p, to);
    }

    /// Executes move k (its route is free) and releases the moves waiting for it.
    fn complete(&mut self, k: usize) {
        let p = self.moves[k].particle;
        let route = self.moves[k].route.clone();
        let last = route.len() - 1;
        for (i, b) in route.into_iter().enumerate() {
            self.push(p, b, i < last);
        }
        self.moves[k].pending = false;
        let site = self.obstacles.site(k);
        let reach = Vector2::repeat(self.occ.max_radius_m + self.config.clearance_m);
        self.failed_routes
            .get_mut()
            .forget_near(site - reach, site + reach);
        self.failed_fills.forget_near(site - reach, site + reach);
        self.failed_own_routes
            .forget_near(site - reach, site + reach);
        self.role[p] = Role::Placed;
        for b in std::mem::take(&mut self.moves[k].releases) {
            self.moves[b].wait -= 1;
        }
    }

    /// Executes move k (its route is free) by the shortest route free now.
    fn go(&mut self, k: usize) {
        if let Some(route) = self.shortcut(k) {
            self.moves[k].route = route;
        }
        self.complete(k);
    }

    /// A refusal naming the stuck moves.
    fn refusal(&self, reason: String, stuck: &[usize]) -> Refusal {
        Refusal {
            reason,
            stuck_pairs: stuck
                .iter()
                .map(|&k| (self.moves[k].particle, self.moves[k].site_index))
                .collect(),
        }
    }

    fn run(&mut self) -> Result<(), Refusal> {
        let total = self.moves.len();
        let mut repairs = 0usize;
        let max_repairs = 4 * total + 20;
        // Work of the collision queries (`Occupancy::work`, most of a long
        // search's time) this order may spend.
        let moves_and_particles = (total as u64).saturating_mul(self.layout.particles.len() as u64);
        let max_work = self
            .config
            .search_effort
            .saturating_mul(moves_and_particles);
        let max_stall = max_work / STALL_SHARE;
        // The work done when the last move was completed.
        let mut progress_at = 0u64;
        loop {
            let tip = self.tip;
            let mut ready: Vec<(f64, usize)> = (0..total)
                .filter(|&k| self.moves[k].pending && self.moves[k].wait == 0)
                .map(|k| (tip.map(|t| (self.landing(k) - t).norm()).unwrap_or(0.0), k))
                .collect();
            if ready.is_empty() {
                if self.moves.iter().any(|m| m.pending) {
                    // Cannot happen: the lowest pending rank waits for nobody.
                    return Err(self.refusal("every remaining move waits for another".into(), &[]));
                }
                return Ok(());
            }
            ready.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut blocked = Vec::new();
            let mut chosen = None;
            for &(_, k) in &ready {
                match self.cached_blocker(k) {
                    None => {
                        chosen = Some(k);
                        break;
                    }
                    Some(q) => blocked.push((k, q)),
                }
            }
            if let Some(k) = chosen {
                self.go(k);
                progress_at = self.occ.work();
                continue;
            }
            repairs += 1;
            let stuck: Vec<usize> = blocked.iter().map(|&(k, _)| k).collect();
            let ran_out = if repairs > max_repairs {
                Some(format!("after {max_repairs} buffer moves and detours"))
            } else if self.occ.work() > max_work {
                Some(format!(
                    "when the search effort ran out ({} tests of buffer moves and detours)",
                    self.occ.work()
                ))
            } else if let stalled = self.occ.work() - progress_at
                && stalled > max_stall
            {
                Some(format!(
                    "after {stalled} tests of buffer moves and detours made way for none"
                ))
            } else {
                None
            };
            if let Some(when) = ran_out {
                let remaining = self.moves.iter().filter(|m| m.pending).count();
                let reason = format!(
                    "{remaining} of {total} moves still blocked {when}; {}",
                    self.blocked_reason(&blocked)
                );
                return Err(self.refusal(reason, &stuck));
            }
            if !self.repair(&blocked) {
                return Err(self.refusal(self.blocked_reason(&blocked), &stuck));
            }
        }
    }

    /// Why nothing could move: the first blocked moves and what blocks them.
    fn blocked_reason(&self, blocked: &[(usize, usize)]) -> String {
        blocked
            .iter()
            .take(3)
            .map(|&(k, q)| {
                let p = self.moves[k].particle;
                let to = self.obstacles.site(k);
                let what = match self.role[q] {
                    Role::Idle => "an unassigned particle with no free buffer spot",
                    Role::Pending(_) => "a particle still to move, with no buffer spot",
                    Role::Placed => "a placed or immovable particle",
                };
                format!(
                    "particle {} to ({:.2}, {:.2}) um blocked by particle {} ({what}) and no detour of two waypoints",
                    self.layout.particles[p].id,
                    to.x * 1e6,
                    to.y * 1e6,
                    self.layout.particles[q].id
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    }
}
