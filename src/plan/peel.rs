//! Fill order of the sites by peeling, with each move's route.
//!
//! Sites nearly touch (pitch = diameter + 0.5 um), so a site whose
//! neighbours are filled first can be walled in. Peeling works backwards:
//! among the remaining sites, one whose particle has a route (straight, or
//! through one or two waypoints) that misses every other remaining site is
//! filled LAST among them, and removed. Removing a site only frees routes,
//! so a site that has a route keeps it, and the straight routes are peeled
//! first (most moves stay straight); when no straight route is left the
//! shortest detour goes. The result: a rank per move (0 = filled first)
//! and its route, which misses every site of lower rank; a move must wait
//! for the moves whose routes cross its site, which always have a lower
//! rank, so the waits never form a cycle. A particle that starts on other
//! sites must leave them before they are filled: its move is ranked before
//! theirs.

use super::PlanConfig;
use super::failed_routes::{FailedRoutes, search_box};
use super::grid::Grid;
use super::pushes::Corridor;
use super::route::{Reach, find_route, route_length};
use nalgebra::Vector2;

/// What stands still while the moves are made: the sites (held by the
/// particles that will fill them, ranked by fill order) and particles that
/// are never pushed (already on a site, or immovable).
#[derive(Debug, Clone)]
pub struct SiteObstacles {
    site_pts: Vec<Vector2<f64>>,
    site_radius: Vec<f64>,
    site_grid: Grid,
    fixed: Vec<(Vector2<f64>, f64)>,
    fixed_grid: Grid,
    max_radius_m: f64,
    /// Clearance kept from sites: the config's clearance plus the on-site
    /// tolerance (a particle lands anywhere within it).
    site_clearance_m: f64,
    /// Clearance kept from fixed particles (where they are is known).
    fixed_clearance_m: f64,
}

impl SiteObstacles {
    /// Sites with the radius of the particle each receives, and fixed particles.
    pub fn new(
        site_pts: Vec<Vector2<f64>>,
        site_radius: Vec<f64>,
        fixed: Vec<(Vector2<f64>, f64)>,
        config: &PlanConfig,
    ) -> Self {
        let max_radius_m = site_radius
            .iter()
            .chain(fixed.iter().map(|f| &f.1))
            .copied()
            .fold(0.0, f64::max);
        let cell = (2.0 * max_radius_m).max(1e-9);
        SiteObstacles {
            site_grid: Grid::new(site_pts.iter().copied(), cell),
            fixed_grid: Grid::new(fixed.iter().map(|f| f.0), cell),
            site_pts,
            site_radius,
            fixed,
            max_radius_m,
            site_clearance_m: config.clearance_m + config.on_site_tolerance_m,
            fixed_clearance_m: config.clearance_m,
        }
    }

    /// Site `k`'s centre.
    pub fn site(&self, k: usize) -> Vector2<f64> {
        self.site_pts[k]
    }

    /// Sites the corridor hits (every site, whatever its rank).
    pub fn sites_hit(&self, c: &Corridor) -> Vec<usize> {
        let mut out = Vec::new();
        let (a, b, r) = c.spine_m;
        let reach = r + self.max_radius_m + self.site_clearance_m;
        self.site_grid.for_each_near_segment(a, b, reach, |s| {
            if c.hits(self.site_pts[s], self.site_radius[s], self.site_clearance_m) {
                out.push(s);
            }
            true
        });
        out
    }

    /// Sites that a disc at `centre_m` of `radius_m` covers now: a particle
    /// starting there leaves them on its way, so its route may cross them.
    pub fn covered_by(&self, centre_m: Vector2<f64>, radius_m: f64) -> Vec<usize> {
        let reach = radius_m + self.max_radius_m + self.site_clearance_m;
        let mut out = Vec::new();
        self.site_grid.for_each_within(centre_m, reach, |s| {
            if (self.site_pts[s] - centre_m).norm()
                < radius_m + self.site_radius[s] + self.site_clearance_m
            {
                out.push(s);
            }
        });
        out
    }

    /// True when the corridor misses every fixed particle and every site
    /// for which `filled(site)` holds.
    pub fn misses(&self, c: &Corridor, filled: impl Fn(usize) -> bool) -> bool {
        let (a, b, r) = c.spine_m;
        let reach = r + self.max_radius_m + self.site_clearance_m;
        self.site_grid.for_each_near_segment(a, b, reach, |s| {
            !(filled(s) && c.hits(self.site_pts[s], self.site_radius[s], self.site_clearance_m))
        }) && self.fixed_grid.for_each_near_segment(a, b, reach, |f| {
            !c.hits(self.fixed[f].0, self.fixed[f].1, self.fixed_clearance_m)
        })
    }
}

/// Fill order and routes of the moves.
#[derive(Debug, Clone)]
pub struct FillOrder {
    /// `rank[k]`: move k is the rank-th to be filled (0 first).
    pub rank: Vec<usize>,
    /// `route[k]`: waypoints then the site, from the particle's start.
    pub route: Vec<Vec<Vector2<f64>>>,
}

/// "1 site is" or "3 sites are".
fn sites_are(n: &usize) -> String {
    match n {
        1 => "1 site is".to_owned(),
        _ => format!("{n} sites are"),
    }
}

/// Why no fill order exists.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{} walled in: no route of at most two waypoints reaches a site so walled past the fixed particles and the other sites, or the particles cover each other's sites (first: site at ({x_um:.2}, {y_um:.2}) um)",
    sites_are(.walled)
)]
pub struct Walled {
    /// Moves left without a rank.
    pub stuck: Vec<usize>,
    /// Sites left without a route.
    pub walled: usize,
    /// First of them, um.
    pub x_um: f64,
    /// First of them, um.
    pub y_um: f64,
}

/// Moves searched for a detour first when no straight move is left.
const DETOUR_CANDIDATES: usize = 32;

/// Peels the sites of `obstacles`; `starts[k]` and `radius[k]` are move k's
/// particle position and radius.
///
/// Cost: each move's straight corridor is tested once; a site's removal
/// updates the counts of the moves it blocked or covered (inverse lists),
/// so a step costs a scan of the candidates, not a corridor test each.
pub fn peel(
    obstacles: &SiteObstacles,
    starts: &[Vector2<f64>],
    radius: &[f64],
    config: &PlanConfig,
    reach: Reach,
) -> Result<FillOrder, Walled> {
    let m = starts.len();
    let mut rank: Vec<Option<usize>> = vec![None; m];
    let mut route: Vec<Option<Vec<Vector2<f64>>>> = vec![None; m];
    // `covering[k]`: other remaining sites move k's particle covers now (it
    // cannot be the last of them). `blocking[k]`: remaining sites its
    // straight push hits; `fixed_free[k]`: that push misses every fixed particle.
    let mut covering = vec![0usize; m];
    let mut blocking = vec![0usize; m];
    let mut covered_by_site: Vec<Vec<usize>> = vec![Vec::new(); m];
    let mut blocked_by_site: Vec<Vec<usize>> = vec![Vec::new(); m];
    let mut fixed_free = vec![false; m];
    for k in 0..m {
        for s in obstacles.covered_by(starts[k], radius[k]) {
            if s != k {
                covering[k] += 1;
                covered_by_site[s].push(k);
            }
        }
        let c = Corridor::new(starts[k], obstacles.site(k), radius[k], config);
        fixed_free[k] = obstacles.misses(&c, |_| false);
        for s in obstacles.sites_hit(&c) {
            if s != k {
                blocking[k] += 1;
                blocked_by_site[s].push(k);
            }
        }
    }
    // Detour searches that found nothing, with the box they looked in: a
    // search is repeated only once a site inside its box has been removed
    // (at N = 10,000 the same failing searches were most of the time).
    let mut failed: FailedRoutes<usize> = FailedRoutes::default();
    let mut remaining: Vec<usize> = (0..m).collect();
    let mut site_sum: Vector2<f64> = (0..m).map(|k| obstacles.site(k)).sum();
    for step in (0..m).rev() {
        // Remaining sites are the ones without a rank (all filled before `step`).
        let filled = |s: usize| rank[s].is_none();
        let centroid = site_sum / remaining.len() as f64;
        // A move whose particle still covers another remaining site cannot be
        // the last of them: that site is filled after the particle has left.
        let eligible = remaining.iter().copied().filter(|&k| covering[k] == 0);
        // The shortest detour among `group`'s moves; routes found are kept.
        let mut shortest_detour = |group: &[usize]| {
            let mut best: Option<(f64, usize, Vec<Vector2<f64>>)> = None;
            for &k in group {
                if route[k].is_none() && failed.known(&k) {
                    continue;
                }
                let free = |c: &Corridor| obstacles.misses(c, |s| s != k && filled(s));
                let found = route[k].clone().or_else(|| {
                    find_route(
                        starts[k],
                        obstacles.site(k),
                        radius[k],
                        config,
                        reach,
                        &free,
                    )
                });
                if found.is_none() {
                    let (lo, hi) = search_box(
                        starts[k],
                        obstacles.site(k),
                        radius[k],
                        obstacles.max_radius_m,
                        config,
                    );
                    failed.remember(k, lo, hi);
                }
                if let Some(r) = found {
                    let extra =
                        route_length(starts[k], &r) - (obstacles.site(k) - starts[k]).norm();
                    if best.as_ref().is_none_or(|b| extra < b.0) {
                        best = Some((extra, k, r.clone()));
                    }
                    route[k] = Some(r);
                }
            }
            best.map(|(_, k, r)| (k, r))
        };
        // Outermost straight move first; else the shortest detour.
        let pick = eligible
            .clone()
            .filter(|&k| fixed_free[k] && blocking[k] == 0)
            .max_by(|&a, &b| {
                let da = (obstacles.site(a) - centroid).norm();
                let db = (obstacles.site(b) - centroid).norm();
                da.total_cmp(&db).then(b.cmp(&a))
            })
            .map(|k| (k, vec![obstacles.site(k)]));
        let pick = pick.or_else(|| {
            // The moves blocked by the fewest sites are searched first (a
            // detour past one or two sites is the likely find); the rest
            // only when none of them has one. At N = 10,000 searching every
            // eligible move at every such step was most of the time.
            let mut by_blocking: Vec<usize> = eligible.collect();
            by_blocking.sort_by_key(|&k| (!fixed_free[k], blocking[k], k));
            let (first, rest) = by_blocking.split_at(by_blocking.len().min(DETOUR_CANDIDATES));
            [first, rest].into_iter().find_map(&mut shortest_detour)
        });
        let Some((k, r)) = pick else {
            let first = obstacles.site(remaining[0]);
            return Err(Walled {
                stuck: remaining.clone(),
                walled: remaining.len(),
                x_um: first.x * 1e6,
                y_um: first.y * 1e6,
            });
        };
        rank[k] = Some(step);
        route[k] = Some(r);
        let at = remaining
            .iter()
            .position(|&q| q == k)
            .expect("picked from remaining");
        remaining.remove(at);
        site_sum -= obstacles.site(k);
        for &q in &covered_by_site[k] {
            covering[q] -= 1;
        }
        for &q in &blocked_by_site[k] {
            blocking[q] -= 1;
        }
        failed.forget_near(obstacles.site(k), obstacles.site(k));
    }
    Ok(FillOrder {
        rank: rank
            .into_iter()
            .map(|r| r.expect("every step ranks one"))
            .collect(),
        route: route
            .into_iter()
            .map(|r| r.expect("ranked moves have routes"))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_filled_from_one_side_is_filled_far_end_first() {
        let cfg = PlanConfig::default();
        let r = 5e-6;
        // Row of 4 touching-ish sites along x; particles waiting to the left.
        let sites: Vec<Vector2<f64>> = (0..4)
            .map(|i| Vector2::new(60e-6 + 10.5e-6 * i as f64, 50e-6))
            .collect();
        let starts: Vec<Vector2<f64>> = (0..4)
            .map(|i| Vector2::new(10e-6, 50e-6 + 0.01e-6 * i as f64))
            .collect();
        let obs = SiteObstacles::new(sites.clone(), vec![r; 4], Vec::new(), &cfg);
        let reach = Reach {
            lo: Vector2::new(5e-6, 5e-6),
            hi: Vector2::new(195e-6, 95e-6),
        };
        let order = peel(&obs, &starts, &[r; 4], &cfg, reach).unwrap();
        // Every route misses the sites filled before it.
        for (k, start) in starts.iter().enumerate() {
            let mut at = *start;
            for p in &order.route[k] {
                let c = Corridor::new(at, *p, r, &cfg);
                assert!(
                    obs.misses(&c, |s| order.rank[s] < order.rank[k]),
                    "move {k}"
                );
                at = *p;
            }
        }
        // The far end of the row (site 3) cannot be last with a straight push
        // through the others, and the near end (site 0) can.
        let mut ranks = order.rank.clone();
        ranks.sort();
        assert_eq!(ranks, vec![0, 1, 2, 3]);
        assert_eq!(
            (order.rank[0], order.rank[3]),
            (3, 0),
            "near end last, far end first"
        );
        assert_eq!(
            order.route[0].len(),
            1,
            "near end straight: {:?}",
            order.route[0]
        );
        // A site enclosed by fixed particles is refused.
        let ring: Vec<(Vector2<f64>, f64)> = (0..8)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 8.0;
                (sites[3] + Vector2::new(a.cos(), a.sin()) * 10.5e-6, r)
            })
            .collect();
        let walled = SiteObstacles::new(vec![sites[3]], vec![r], ring, &cfg);
        assert!(peel(&walled, &starts[..1], &[r], &cfg, reach).is_err());
    }
}
