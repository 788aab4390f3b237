//! Collision-free ordering of the moves, minimising tip travel.
//!
//! Unassigned particles that cover a site are first pushed off the sites.
//! Then [`peel`] gives every move a fill rank and a route (straight, or
//! through waypoints) that misses every site filled before it; a move waits
//! for the moves whose routes cross its site (always lower ranks, so no
//! cycle). Among the moves that wait for nobody, the one whose first landing
//! point is nearest the tip goes next, provided every leg of its route
//! (particle and tip corridors, parry2d) misses every particle where it is
//! now. Otherwise a repair: an unassigned blocker is pushed to a buffer spot
//! off the sites, the blocked move is rerouted around the particles, or a
//! blocking particle still to move is buffered and rerouted from there.
//! Repairs are bounded; beyond them, or when none applies, the planner
//! refuses and names the blocked move and its blocker.

use super::failed_routes::{FailedRoutes, search_box};
use super::grid::Grid;
use super::layout::Layout;
use super::occupancy::Occupancy;
use super::pattern::Site;
use super::peel::{FillOrder, SiteObstacles, peel};
use super::pushes::{Corridor, approach_point, landing_point, max_push_len, split_long, tip_end};
use super::route::{Reach, find_route_within, route_length};
use super::shortcuts::take_shortcuts;
use super::{PlanConfig, Step};
use nalgebra::Vector2;
use std::cell::RefCell;

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
    // Sites are held at the largest radius: moves may trade particles.
    let site_radii = vec![r; moves.len()];
    let site_pts: Vec<Vector2<f64>> = sites.iter().map(|s| s.centre_m).collect();
    let n_moves = moves.len();
    let mut sch = Scheduler {
        config,
        layout,
        occ: Occupancy::new(layout),
        role,
        moves,
        obstacles: SiteObstacles::new(move_sites, site_radii, fixed, config),
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
    sch.clear_sites();
    let order = sch.peel_with_clearing(&radii)?;
    for (k, m) in sch.moves.iter_mut().enumerate() {
        m.rank = order.rank[k];
        m.route = order.route[k].clone();
    }
    for k in 0..sch.moves.len() {
        sch.compute_conflicts(k);
    }
    sch.run()?;
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

/// Hand-overs to a nearer blocker per move. At N = 10,000 a move crosses
/// 600 um of crowd on average (15 particles in its corridor at 10 %
/// coverage); with 8, over 2,000 blockers on spent moves were buffered out
/// and back (a third of the excess push distance), and the order took 20 s.
const MAX_NEARER_SWAPS: u8 = 32;

/// Least length a shortcut must save, metres (less is rounding).
const SHORTCUT_GAIN_M: f64 = 1e-9;

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

/// A thrifty order's swap whose routes need a waypoint is left until the
/// reroutes and early fills have failed when it adds more than so many
/// particle radii beyond what rerouting the blocked move adds (CMU seed 84:
/// a swap took a particle 26 um round to its new site). CMU: 79 -> 88 of
/// 100 layouts within 1.05 LB_push; N = 1,000 1.003011 -> 1.002560. With
/// no slack CMU had 88 but N = 1,000 1.003304, with 2 radii 86 and
/// 1.002943.
const SWAP_OVER_REROUTE_RADII: f64 = 1.0;

/// How short of its site a particle breaking a covering cycle stops at
/// most, metres: 0.5 um still covered the neighbouring sites (pitch 10.5 um,
/// covered within 10.35 um) and gave nothing on CMU; 0.1 um gave 88 -> 91
/// of 100 layouts within 1.05 LB_push.
const TOWARD_SITE_GAP_M: f64 = 0.1e-6;

/// Buffer spots weighed for a particle still to move.
const BUFFER_CANDIDATES: usize = 24;

/// Buffer pushes allowed to break covering cycles before the peel gives up.
const MAX_CYCLE_BREAKS: usize = 8;

impl Scheduler<'_> {
    /// Peels the sites; when it is stuck because particles cover each
    /// other's sites (a cycle), pushes one of them to a spot where it covers
    /// no site but its own, the one whose spot adds least to its path
    /// ([`Self::cycle_break_spot`]), and peels again.
    fn peel_with_clearing(&mut self, radii: &[f64]) -> Result<FillOrder, Refusal> {
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
                continue;
            }
            repairs += 1;
            let stuck: Vec<usize> = blocked.iter().map(|&(k, _)| k).collect();
            if repairs > max_repairs {
                let remaining = self.moves.iter().filter(|m| m.pending).count();
                let reason = format!(
                    "{remaining} of {total} moves still blocked after {max_repairs} buffer moves and detours; {}",
                    self.blocked_reason(&blocked)
                );
                return Err(self.refusal(reason, &stuck));
            }
            if !self.repair(&blocked) {
                return Err(self.refusal(self.blocked_reason(&blocked), &stuck));
            }
        }
    }

    /// Tries one repair for the blocked ready moves; true on success.
    fn repair(&mut self, blocked: &[(usize, usize)]) -> bool {
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
                if self.clear_way_then_buffer(q, &avoid) {
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

    /// Route for move k's site with `particle` starting at `from`, missing
    /// the sites filled before it (by rank) or already filled, and, when
    /// `dynamic`, every other particle where it is now, with at most
    /// `waypoints` waypoints, shorter than `shorter_than_m` (infinite: any
    /// length). A detour search that found nothing is remembered until
    /// something changes where it looked (one cut short by the length is not).
    fn route_for(
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
    fn search_box_of(
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
    fn straight_or_along(&self, k: usize, particle: usize) -> Option<Vec<Vector2<f64>>> {
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
    fn shortcut(&self, k: usize) -> Option<Vec<Vector2<f64>>> {
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
    fn reroute_added(&self, k: usize) -> f64 {
        let p = self.moves[k].particle;
        let from = self.occ.pos[p];
        self.route_for(k, p, from, true, 2, f64::INFINITY)
            .map_or(f64::INFINITY, |route| {
                route_length(from, &route) - route_length(from, &self.moves[k].route)
            })
    }

    /// Blocked move k's detour: its blocker q buffered when idle, else k
    /// rerouted around the particles; true on success.
    fn detour(&mut self, k: usize, q: usize) -> bool {
        let avoid = self.route_corridors(k);
        (self.role[q] == Role::Idle && self.buffer_idle(q, &avoid)) || self.reroute(k)
    }

    /// Reroutes move k around the particles where they are now (and the
    /// sites filled before it); true when its route changed.
    fn reroute(&mut self, k: usize) -> bool {
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

    /// Hands move k to particle q, which is in the way of k's particle:
    /// an idle q takes over (k's particle becomes idle), a pending q trades
    /// sites with it; true when q has a route free of every particle now
    /// (so the swap makes progress) and the other changed move has a route
    /// (with at most `waypoints` waypoints). When `weighed`, not when the
    /// swap adds more to the two moves' paths than rerouting move k would,
    /// plus [`SWAP_OVER_REROUTE_RADII`].
    fn swap_with(&mut self, k: usize, q: usize, waypoints: usize, weighed: bool) -> bool {
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
    fn swap_nearer(&mut self, k: usize, q: usize, capped: bool, weighed: bool) -> bool {
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

    /// Pushes idle particle q to a buffer spot clear of `avoid`; true on success.
    fn buffer_idle(&mut self, q: usize, avoid: &[Corridor]) -> bool {
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
    fn buffer_pending(&mut self, m: usize, avoid: &[Corridor]) -> bool {
        let q = self.moves[m].particle;
        let from = self.occ.pos[q];
        let site = self.obstacles.site(m);
        let r = self.radius(q);
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
                    !self.off_sites(s, r),
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
    fn buffer_spots<'s>(
        &'s self,
        q: usize,
        avoid: &'s [Corridor],
    ) -> impl Iterator<Item = Vector2<f64>> + 's {
        let from = self.occ.pos[q];
        let r = self.radius(q);
        let usable = move |spot: &Vector2<f64>| self.spot_usable(q, *spot, avoid);
        let nearest_out = if self.role[q] == Role::Idle {
            avoid
        } else {
            &[]
        };
        let spots = self.ring(from, r, nearest_out, None);
        let on = spots.clone();
        let off = spots.into_iter().filter(move |s| self.off_sites(*s, r));
        let on = on.into_iter().filter(move |s| !self.off_sites(*s, r));
        off.chain(on).filter(usable)
    }

    /// True when particle q can be pushed from where it is to `spot` now
    /// (free way, and [`Self::spot_free`]).
    fn spot_usable(&self, q: usize, spot: Vector2<f64>, avoid: &[Corridor]) -> bool {
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
        let r = self.radius(q);
        let cl = self.config.clearance_m;
        self.reach.contains(spot)
            && self.occ.disc_free(spot, r, q, cl)
            && avoid.iter().all(|c| !c.hits(spot, r, cl))
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
        let mut ring =
            super::parking::ring_off_sites(from, r, &self.peel_site_discs(), &|_| false, own);
        ring.sort_by(|a, b| added(a).total_cmp(&added(b)));
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

    /// Pushes every idle particle that covers a site to a spot off the sites
    /// before the moves start; one with no free parking push now is left to
    /// the repairs.
    fn clear_sites(&mut self) {
        let mut covering: Vec<usize> = (0..self.occ.pos.len())
            .filter(|&q| {
                self.role[q] == Role::Idle && !self.off_sites(self.occ.pos[q], self.radius(q))
            })
            .collect();
        for _round in 0..3 {
            let before = covering.len();
            covering.retain(|&q| {
                let spot = self
                    .buffer_spots(q, &[])
                    .find(|s| self.off_sites(*s, self.radius(q)));
                match spot {
                    Some(spot) => {
                        self.push(q, spot, true);
                        false
                    }
                    None => true,
                }
            });
            if covering.is_empty() || covering.len() == before {
                break;
            }
        }
    }

    /// True when a disc of radius r at `spot` keeps clearance from every site.
    fn off_sites(&self, spot: Vector2<f64>, r: f64) -> bool {
        !self.site_discs().covered_by(spot, r)
    }

    /// The sites as discs of the largest radius, for the parking questions.
    fn site_discs(&self) -> super::parking::SiteDiscs<'_> {
        super::parking::SiteDiscs {
            grid: &self.site_grid,
            centres: &self.site_pts,
            radius_m: self.occ.max_radius_m,
            clearance_m: self.config.clearance_m,
        }
    }

    /// The sites as the peel sees them ([`SiteObstacles::covered_by`]): a filled
    /// site's particle may lie anywhere within the on-site tolerance, so a
    /// spot off the sites keeps that too. A cycle break's spots kept only
    /// the clearance (10.15 um from a site for 10 um particles, the peel
    /// asks 10.35): the nearest spot off the other sites still covered
    /// them, and the break fell back to quarter-pitch ring spots or none
    /// (CMU seed 82 of the 40-60 scenes: 1.1716 -> 1.0403).
    fn peel_site_discs(&self) -> super::parking::SiteDiscs<'_> {
        let mut discs = self.site_discs();
        discs.clearance_m += self.config.on_site_tolerance_m;
        discs
    }

    /// Candidate spots around `centre` for a disc of radius r, with the
    /// nearest ones off the sites and clear of `avoid` (see
    /// [`super::parking::ring_off_sites`]).
    fn ring(
        &self,
        centre: Vector2<f64>,
        r: f64,
        avoid: &[Corridor],
        own: Option<usize>,
    ) -> Vec<Vector2<f64>> {
        let cl = self.config.clearance_m;
        let discs = if self.wide_spots {
            self.peel_site_discs()
        } else {
            self.site_discs()
        };
        super::parking::ring_off_sites(
            centre,
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
    fn clear_way_then_buffer(&mut self, q: usize, avoid: &[Corridor]) -> bool {
        let from = self.occ.pos[q];
        let r = self.radius(q);
        let cl = self.config.clearance_m;
        for spot in self.ring(from, r, avoid, None) {
            if !self.off_sites(spot, r) || !self.spot_free(q, spot, avoid) {
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
                let spot = self.buffer_spots(h, &keep_clear).next();
                match spot {
                    Some(t) => {
                        self.push(h, t, true);
                        moved = true;
                    }
                    None => break,
                }
            }
            if moved {
                if self.occ.first_hit(&way, q, cl).is_none() && self.occ.disc_free(spot, r, q, cl) {
                    self.push(q, spot, true);
                }
                return true;
            }
        }
        false
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
