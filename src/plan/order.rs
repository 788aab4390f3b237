//! Collision-free ordering of pushes, minimising tip travel.
//!
//! Moves wait for each other when one's corridor crosses the other's site
//! (the site must still be empty when the corridor is swept). Among the moves
//! that wait for nobody, the one whose landing point is nearest the tip is
//! taken, provided its corridor (checked with parry2d) hits no particle where
//! it is at that moment. When nothing can go: a blocking idle or waiting
//! particle is pushed to a buffer spot, or the blocked move is rerouted
//! through a waypoint next to its site whose last leg crosses nothing
//! (a detour; this also breaks wait cycles). A bounded number of such repairs
//! is allowed; beyond it the planner refuses with the reason.

use super::grid::Grid;
use super::layout::Layout;
use super::pattern::Site;
use super::pushes::{Corridor, approach_point, landing_point, max_push_len, split_long, tip_end};
use super::{PlanConfig, PlanError, Step};
use nalgebra::Vector2;
use std::collections::HashMap;

/// Ordered push steps and how many of them are buffer/detour pushes.
#[derive(Debug, Clone)]
pub struct Ordered {
    /// Push steps in execution order (no tip travel yet).
    pub steps: Vec<Step>,
    /// Pushes that went to a buffer spot or a waypoint.
    pub buffer_pushes: usize,
}

/// Particle positions that change as pushes are executed, bucketed for queries.
struct Occupancy {
    pos: Vec<Vector2<f64>>,
    radius: Vec<f64>,
    cell_m: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
    max_radius_m: f64,
}

impl Occupancy {
    fn new(layout: &Layout) -> Self {
        let max_radius_m = layout.max_radius_m();
        let mut o = Occupancy {
            pos: layout.particles.iter().map(|p| p.centre_m).collect(),
            radius: layout.particles.iter().map(|p| p.radius_m).collect(),
            cell_m: (4.0 * max_radius_m).max(1e-9),
            cells: HashMap::new(),
            max_radius_m,
        };
        for i in 0..o.pos.len() {
            let k = o.key(o.pos[i]);
            o.cells.entry(k).or_default().push(i);
        }
        o
    }
    fn key(&self, p: Vector2<f64>) -> (i64, i64) {
        (
            (p.x / self.cell_m).floor() as i64,
            (p.y / self.cell_m).floor() as i64,
        )
    }
    fn set(&mut self, i: usize, p: Vector2<f64>) {
        let old = self.key(self.pos[i]);
        if let Some(v) = self.cells.get_mut(&old) {
            v.retain(|&x| x != i);
        }
        self.pos[i] = p;
        let k = self.key(p);
        self.cells.entry(k).or_default().push(i);
    }
    fn for_each_near(&self, c: Vector2<f64>, r: f64, mut f: impl FnMut(usize) -> bool) {
        let (x0, y0) = self.key(c - Vector2::new(r, r));
        let (x1, y1) = self.key(c + Vector2::new(r, r));
        for x in x0..=x1 {
            for y in y0..=y1 {
                if let Some(v) = self.cells.get(&(x, y)) {
                    for &i in v {
                        if !f(i) {
                            return;
                        }
                    }
                }
            }
        }
    }
    /// First particle other than `except` that the corridor hits.
    fn first_hit(&self, c: &Corridor, except: usize, clearance: f64) -> Option<usize> {
        let mut hit = None;
        self.for_each_near(
            c.bound_centre_m,
            c.bound_radius_m + self.max_radius_m + clearance,
            |i| {
                if i != except && c.hits(self.pos[i], self.radius[i], clearance) {
                    hit = Some(i);
                    return false;
                }
                true
            },
        );
        hit
    }
    /// Every particle other than `except` that the corridor hits.
    fn all_hits(&self, c: &Corridor, except: usize, clearance: f64) -> Vec<usize> {
        let mut hits = Vec::new();
        self.for_each_near(
            c.bound_centre_m,
            c.bound_radius_m + self.max_radius_m + clearance,
            |i| {
                if i != except && c.hits(self.pos[i], self.radius[i], clearance) {
                    hits.push(i);
                }
                true
            },
        );
        hits
    }
    fn disc_free(&self, p: Vector2<f64>, r: f64, except: usize, clearance: f64) -> bool {
        let mut free = true;
        self.for_each_near(p, r + self.max_radius_m + clearance, |i| {
            if i != except && (self.pos[i] - p).norm() < r + self.radius[i] + clearance {
                free = false;
                return false;
            }
            true
        });
        free
    }
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

struct Scheduler<'a> {
    config: &'a PlanConfig,
    layout: &'a Layout,
    occ: Occupancy,
    role: Vec<Role>,
    moves: Vec<(usize, Vector2<f64>)>,
    pending: Vec<bool>,
    wait: Vec<usize>,
    releases: Vec<Vec<usize>>,
    site_grid: Grid,
    site_pts: Vec<Vector2<f64>>,
    site_move: Vec<Option<usize>>,
    reach_lo: Vector2<f64>,
    reach_hi: Vector2<f64>,
    steps: Vec<Step>,
    buffer_pushes: usize,
    tip: Option<Vector2<f64>>,
    releases_ready: Vec<usize>,
}

/// Orders the moves `pairs` (particle index, site index) into collision-free pushes.
pub fn order_moves(
    layout: &Layout,
    sites: &[Site],
    pairs: &[(usize, usize)],
    on_site: &[usize],
    config: &PlanConfig,
) -> Result<Ordered, PlanError> {
    // Immovable particles are obstacles like placed ones: never pushed.
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
    let mut moves = Vec::new();
    let mut site_move = vec![None; sites.len()];
    for &(p, s) in pairs {
        let target = sites[s].centre_m;
        if on_site.contains(&p) || (layout.particles[p].centre_m - target).norm() <= 1e-12 {
            role[p] = Role::Placed;
        } else {
            role[p] = Role::Pending(moves.len());
            site_move[s] = Some(moves.len());
            moves.push((p, target));
        }
    }
    let r = layout.max_radius_m();
    let site_pts: Vec<Vector2<f64>> = sites.iter().map(|s| s.centre_m).collect();
    let mut sch = Scheduler {
        config,
        layout,
        occ: Occupancy::new(layout),
        role,
        pending: vec![true; moves.len()],
        wait: vec![0; moves.len()],
        releases: vec![Vec::new(); moves.len()],
        site_grid: Grid::new(site_pts.iter().copied(), 2.0 * r),
        site_pts,
        site_move,
        moves,
        reach_lo: Vector2::new(r, r),
        reach_hi: Vector2::new(layout.field_m[0] - r, layout.field_m[1] - r),
        steps: Vec::new(),
        buffer_pushes: 0,
        tip: config.tip_start_m,
        releases_ready: Vec::new(),
    };
    for k in 0..sch.moves.len() {
        sch.compute_conflicts(k);
    }
    sch.clear_sites();
    sch.run()?;
    Ok(Ordered {
        steps: sch.steps,
        buffer_pushes: sch.buffer_pushes,
    })
}

impl Scheduler<'_> {
    fn radius(&self, p: usize) -> f64 {
        self.layout.particles[p].radius_m
    }

    fn corridor(&self, p: usize, from: Vector2<f64>, to: Vector2<f64>) -> Corridor {
        Corridor::new(from, to, self.radius(p), self.config)
    }

    /// Pending moves whose site lies on move k's corridor (they wait for k).
    fn site_conflicts(&self, k: usize, from: Vector2<f64>) -> Vec<usize> {
        let (p, to) = self.moves[k];
        let c = self.corridor(p, from, to);
        let r = self.occ.max_radius_m;
        let mut out = Vec::new();
        self.site_grid.for_each_within(
            c.bound_centre_m,
            c.bound_radius_m + r + self.config.clearance_m,
            |s| {
                if let Some(b) = self.site_move[s]
                    && b != k
                    && self.pending[b]
                    && c.hits(
                        self.site_pts[s],
                        self.radius(self.moves[b].0),
                        self.config.clearance_m,
                    )
                {
                    out.push(b);
                }
            },
        );
        out
    }

    fn compute_conflicts(&mut self, k: usize) {
        for b in std::mem::take(&mut self.releases[k]) {
            self.wait[b] -= 1;
        }
        let from = self.occ.pos[self.moves[k].0];
        let list = self.site_conflicts(k, from);
        for &b in &list {
            self.wait[b] += 1;
        }
        self.releases[k] = list;
    }

    fn landing(&self, k: usize) -> Vector2<f64> {
        let (p, to) = self.moves[k];
        let from = self.occ.pos[p];
        landing_point(
            from,
            to,
            approach_point(from, to, self.radius(p), self.config),
            self.config,
        )
    }

    /// Appends the push steps of particle p going straight to `to` and updates positions.
    fn push(&mut self, p: usize, to: Vector2<f64>, buffer: bool) {
        let from = self.occ.pos[p];
        let r = self.radius(p);
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

    fn run(&mut self) -> Result<(), PlanError> {
        let total = self.moves.len();
        let mut remaining = total;
        let mut repairs = 0usize;
        let max_repairs = 3 * total + 20;
        let mut ready: Vec<usize> = (0..total).filter(|&k| self.wait[k] == 0).collect();
        while remaining > 0 {
            ready.retain(|&k| self.pending[k]);
            let mut chosen = None;
            let mut blocked: Vec<(usize, usize)> = Vec::new();
            let tip = self.tip;
            let mut order: Vec<(f64, usize)> = ready
                .iter()
                .map(|&k| (tip.map(|t| (self.landing(k) - t).norm()).unwrap_or(0.0), k))
                .collect();
            // Check the nearest first; partial selection keeps this linear in practice.
            while !order.is_empty() {
                let (best_i, _) = order
                    .iter()
                    .enumerate()
                    .min_by(|a, b| a.1.0.total_cmp(&b.1.0).then(a.1.1.cmp(&b.1.1)))
                    .expect("non-empty");
                let (_, k) = order.swap_remove(best_i);
                let (p, to) = self.moves[k];
                let c = self.corridor(p, self.occ.pos[p], to);
                match self.occ.first_hit(&c, p, self.config.clearance_m) {
                    None => {
                        chosen = Some(k);
                        break;
                    }
                    Some(q) => blocked.push((k, q)),
                }
            }
            if let Some(k) = chosen {
                self.complete(k);
                remaining -= 1;
                ready.append(&mut self.releases_ready);
                continue;
            }
            repairs += 1;
            if repairs > max_repairs {
                return Err(PlanError::Blocked(format!(
                    "{remaining} of {total} moves still blocked after {max_repairs} buffer moves and detours"
                )));
            }
            let repaired = self.repair(&blocked);
            remaining = self.pending.iter().filter(|&&p| p).count();
            if remaining == 0 {
                break;
            }
            if !repaired {
                return Err(PlanError::Blocked(self.blocked_reason(&blocked)));
            }
            ready = (0..total)
                .filter(|&k| self.pending[k] && self.wait[k] == 0)
                .collect();
        }
        Ok(())
    }

    /// Pushes every idle particle that covers a site to a parking spot off
    /// the sites before the moves start, outermost first (nearest the
    /// pattern's edge has the freest corridor); a particle with no free
    /// parking move now is left to the repairs of the main loop.
    fn clear_sites(&mut self) {
        let r = self.occ.max_radius_m;
        let mut covering: Vec<usize> = (0..self.occ.pos.len())
            .filter(|&q| {
                self.role[q] == Role::Idle
                    && super::parking::covers_site(
                        self.occ.pos[q],
                        self.radius(q),
                        &self.site_grid,
                        &self.site_pts,
                        r,
                        self.config.clearance_m,
                    )
            })
            .collect();
        for _round in 0..3 {
            let before = covering.len();
            covering.retain(|&q| match self.buffer_spot_off_sites(q) {
                Some(spot) => {
                    self.push(q, spot, true);
                    false
                }
                None => true,
            });
            if covering.is_empty() || covering.len() == before {
                break;
            }
        }
        for k in 0..self.moves.len() {
            self.compute_conflicts(k);
        }
    }

    /// A free spot off every site, reachable from q's place now, nearest first.
    fn buffer_spot_off_sites(&self, q: usize) -> Option<Vector2<f64>> {
        let from = self.occ.pos[q];
        let r = self.radius(q);
        let cl = self.config.clearance_m;
        self.ring(from, r).into_iter().find(|spot| {
            self.spot_free(q, *spot, None)
                && self
                    .occ
                    .first_hit(&self.corridor(q, from, *spot), q, cl)
                    .is_none()
        })
    }

    /// Executes move k (its corridor is free) and releases the moves waiting for it.
    fn complete(&mut self, k: usize) {
        let (p, to) = self.moves[k];
        self.push(p, to, false);
        self.pending[k] = false;
        self.role[p] = Role::Placed;
        for b in std::mem::take(&mut self.releases[k]) {
            self.wait[b] -= 1;
            if self.wait[b] == 0 && self.pending[b] {
                self.releases_ready.push(b);
            }
        }
    }

    /// Tries one repair: move a blocker out of the way or reroute a move. True on success.
    fn repair(&mut self, blocked: &[(usize, usize)]) -> bool {
        // 1. A blocked ready move whose blocker can be moved aside.
        for &(k, q) in blocked {
            let (p, to) = self.moves[k];
            let c = self.corridor(p, self.occ.pos[p], to);
            match self.role[q] {
                Role::Idle => {
                    if let Some(spot) = self.buffer_spot(q, Some(&c)) {
                        self.push(q, spot, true);
                        return true;
                    }
                    if self.clear_way_then_buffer(q, &c) {
                        return true;
                    }
                }
                Role::Pending(m) => {
                    if self.reroute(m, Some(&c)) {
                        return true;
                    }
                    if let Some(spot) = self.buffer_spot(q, Some(&c)) {
                        self.push(q, spot, true);
                        self.compute_conflicts(m);
                        return true;
                    }
                }
                Role::Placed => {}
            }
        }
        // 2. Reroute a blocked move itself (detour), e.g. past placed particles.
        for &(k, _) in blocked {
            if self.reroute(k, None) {
                return true;
            }
        }
        // 3. Force the nearest waiting move whose corridor is free now; the
        //    moves that waited for its site get detours later if they need them.
        let tip = self.tip;
        let mut waiting: Vec<(f64, usize)> = (0..self.moves.len())
            .filter(|&k| self.pending[k] && self.wait[k] > 0)
            .map(|k| (tip.map(|t| (self.landing(k) - t).norm()).unwrap_or(0.0), k))
            .collect();
        waiting.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (_, k) in waiting {
            let (p, to) = self.moves[k];
            let c = self.corridor(p, self.occ.pos[p], to);
            if self.occ.first_hit(&c, p, self.config.clearance_m).is_none() {
                self.complete(k);
                return true;
            }
        }
        // 4. Wait cycle (no move is ready): reroute the move that waits for the fewest others.
        if !blocked.is_empty() {
            return false;
        }
        let mut cands: Vec<usize> = (0..self.moves.len()).filter(|&k| self.pending[k]).collect();
        cands.sort_by_key(|&k| (self.wait[k], k));
        for k in cands.into_iter().take(32) {
            if self.reroute(k, None) {
                return true;
            }
        }
        false
    }

    fn in_reach(&self, p: Vector2<f64>) -> bool {
        p.x >= self.reach_lo.x
            && p.y >= self.reach_lo.y
            && p.x <= self.reach_hi.x
            && p.y <= self.reach_hi.y
    }

    /// Spot is free of particles (except `p`) and of every site (except `own_site`).
    fn spot_free(&self, p: usize, spot: Vector2<f64>, own_site: Option<Vector2<f64>>) -> bool {
        let r = self.radius(p);
        let cl = self.config.clearance_m;
        if !self.in_reach(spot) || !self.occ.disc_free(spot, r, p, cl) {
            return false;
        }
        let mut free = true;
        self.site_grid
            .for_each_within(spot, 2.0 * self.occ.max_radius_m + cl, |s| {
                let sp = self.site_pts[s];
                if own_site.is_none_or(|o| (o - sp).norm() > 1e-12)
                    && (sp - spot).norm() < r + self.occ.max_radius_m + cl
                {
                    free = false;
                }
            });
        free
    }

    /// Candidate spots around `centre`: 48 directions, distances from half a
    /// pitch to eight pitches in quarter-pitch steps.
    fn ring(&self, centre: Vector2<f64>, r: f64) -> Vec<Vector2<f64>> {
        super::parking::ring(centre, 2.0 * r + 1e-6)
    }

    /// A free spot near particle q, reachable now, outside corridor `avoid`:
    /// off every site if possible, else off-site-agnostic (a temporary parking
    /// spot; whoever it blocks later gets repaired in turn).
    fn buffer_spot(&self, q: usize, avoid: Option<&Corridor>) -> Option<Vector2<f64>> {
        let from = self.occ.pos[q];
        let r = self.radius(q);
        let cl = self.config.clearance_m;
        let mut spots = self.ring(from, r);
        spots.sort_by(|a, b| (a - from).norm().total_cmp(&(b - from).norm()));
        let usable = |spot: &Vector2<f64>, off_sites: bool| {
            let free = if off_sites {
                self.spot_free(q, *spot, None)
            } else {
                self.in_reach(*spot) && self.occ.disc_free(*spot, r, q, cl)
            };
            free && avoid.is_none_or(|c| !c.hits(*spot, r, cl))
                && self
                    .occ
                    .first_hit(&self.corridor(q, from, *spot), q, cl)
                    .is_none()
        };
        spots
            .iter()
            .find(|s| usable(s, true))
            .or_else(|| spots.iter().find(|s| usable(s, false)))
            .copied()
    }

    /// Two-level buffer move: idle particle q has no free way to a spot off
    /// `avoid`, but some spot's way is blocked only by idle particles that
    /// can each be buffered directly (off `avoid` and off q's way); those go
    /// first, then q. True when at least the first of them moved.
    fn clear_way_then_buffer(&mut self, q: usize, avoid: &Corridor) -> bool {
        let from = self.occ.pos[q];
        let r = self.radius(q);
        let cl = self.config.clearance_m;
        for spot in self.ring(from, r) {
            if !self.spot_free(q, spot, None) || avoid.hits(spot, r, cl) {
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
                let target = self
                    .buffer_spot(h, Some(avoid))
                    .filter(|t| !way.hits(*t, self.radius(h), cl));
                match target {
                    Some(t) => {
                        self.push(h, t, true);
                        moved = true;
                    }
                    None => break,
                }
            }
            if moved {
                if self.occ.first_hit(&way, q, cl).is_none() && self.spot_free(q, spot, None) {
                    self.push(q, spot, true);
                }
                return true;
            }
        }
        false
    }

    /// Why nothing could move: the first blocked moves and what blocks them.
    fn blocked_reason(&self, blocked: &[(usize, usize)]) -> String {
        if blocked.is_empty() {
            return "every remaining move waits for another (a cycle no detour breaks)".into();
        }
        blocked
            .iter()
            .take(3)
            .map(|&(k, q)| {
                let (p, to) = self.moves[k];
                let what = match self.role[q] {
                    Role::Idle => "an unassigned particle with no free buffer spot",
                    Role::Pending(_) => "a particle still to move",
                    Role::Placed => "a placed or immovable particle, and no detour",
                };
                format!(
                    "particle {} to ({:.2}, {:.2}) um blocked by particle {} ({what})",
                    self.layout.particles[p].id,
                    to.x * 1e6,
                    to.y * 1e6,
                    self.layout.particles[q].id
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    /// Moves pending move k's particle to a waypoint near its site whose last
    /// leg crosses no particle and no pending site; true on success.
    fn reroute(&mut self, k: usize, avoid: Option<&Corridor>) -> bool {
        let (p, to) = self.moves[k];
        let from = self.occ.pos[p];
        let r = self.radius(p);
        let cl = self.config.clearance_m;
        // Waypoints around the site and around the middle of the straight path.
        let mut spots = self.ring(to, r);
        spots.extend(self.ring((from + to) / 2.0, r));
        spots.sort_by(|a, b| {
            ((a - from).norm() + (a - to).norm()).total_cmp(&((b - from).norm() + (b - to).norm()))
        });
        for spot in spots {
            if (spot - from).norm() < 1e-9
                || !self.spot_free(p, spot, None)
                || avoid.is_some_and(|c| c.hits(spot, r, cl))
            {
                continue;
            }
            if self
                .occ
                .first_hit(&self.corridor(p, from, spot), p, cl)
                .is_some()
            {
                continue;
            }
            // Last leg: no particle other than p (ignoring p's current place) and no pending site.
            let last = self.corridor(p, spot, to);
            if !self.occ.all_hits(&last, p, cl).is_empty()
                || !self.site_conflicts(k, spot).is_empty()
            {
                continue;
            }
            self.push(p, spot, true);
            self.compute_conflicts(k);
            return true;
        }
        false
    }
}
