//! Unassigned particles in the way: which ones cover a site, and how far
//! each must be pushed to clear it (the parking cost the assignment pays).

use super::assignment::with_parking;
use super::grid::Grid;
use nalgebra::Vector2;

/// The sites as discs to keep clear of: their centres (and a grid over
/// them), the radius of the particles that will fill them, and the
/// clearance. One value for the questions below, asked by the assignment's
/// parking costs and by the scheduler.
#[derive(Debug, Clone, Copy)]
pub struct SiteDiscs<'a> {
    /// Grid over `centres`.
    pub grid: &'a Grid,
    /// Site centres.
    pub centres: &'a [Vector2<f64>],
    /// Radius of the particles on the sites.
    pub radius_m: f64,
    /// Least free space kept from a site's particle.
    pub clearance_m: f64,
}

impl SiteDiscs<'_> {
    /// True if a disc at `centre_m` of `radius_m` comes closer than the
    /// clearance to a site's particle.
    pub fn covered_by(&self, centre_m: Vector2<f64>, radius_m: f64) -> bool {
        let reach = radius_m + self.radius_m + self.clearance_m;
        let mut hit = false;
        self.grid.for_each_within(centre_m, reach, |s| {
            if (self.centres[s] - centre_m).norm() < reach {
                hit = true;
            }
        });
        hit
    }
}

/// Candidate spots around `centre` with their distance from it: along the
/// unit `directions`, distances from a quarter to eight pitches (`pitch_m`)
/// in quarter-pitch steps, nearest first.
fn ring(
    centre: Vector2<f64>,
    pitch_m: f64,
    directions: [Vector2<f64>; CLEARING_DIRECTIONS],
) -> impl Iterator<Item = (f64, Vector2<f64>)> {
    (1..=RING_STEPS).flat_map(move |step| {
        let dist = pitch_m * step as f64 / 4.0;
        directions
            .into_iter()
            .map(move |u| (dist, centre + u * dist))
    })
}

/// Quarter-pitch steps of the ring.
const RING_STEPS: usize = 32;

/// Directions of the nearest spots off the sites.
pub const CLEARING_DIRECTIONS: usize = 48;

/// Extra distance, beyond the clearance, a clearing spot keeps from every
/// site (rounding, and a particle pushed there must not graze a site).
pub const CLEARING_MARGIN_M: f64 = 0.05e-6;

/// Candidate spots around `centre` for a disc of `radius_m`: in each of 48
/// directions the nearest point (within two pitches) where it keeps the
/// clearance (plus [`CLEARING_MARGIN_M`]) from every site and `also`
/// does not hold (the scheduler: the corridors the spot must leave free),
/// merged with `ring`, nearest first. Site `own` (the particle's own,
/// when it breaks a covering cycle) may stay covered. The ring's
/// quarter-pitch steps alone (2.75 um for 10 um particles) pushed a
/// particle that covered a site or a
/// corridor by a fraction of a micron 2.75 um off it: on CMU, idle
/// particles pushed off the way were the largest part of the excess above
/// 1.05 LB_push (eleventh pass).
pub fn ring_off_sites(
    centre: Vector2<f64>,
    radius_m: f64,
    sites: &SiteDiscs,
    also: &dyn Fn(Vector2<f64>) -> bool,
    own: Option<usize>,
) -> Vec<Vector2<f64>> {
    // The unit directions once for both: their sines and cosines, taken at
    // every step of the ring, were a tenth of CMU's planning time.
    let directions: [Vector2<f64>; CLEARING_DIRECTIONS] = std::array::from_fn(|a| {
        let ang = std::f64::consts::TAU * a as f64 / CLEARING_DIRECTIONS as f64;
        Vector2::new(ang.cos(), ang.sin())
    });
    let mut along = spots_off_sites_along(centre, directions, radius_m, sites, also, own);
    along.sort_by(|x, y| x.0.total_cmp(&y.0));
    // The ring comes nearest first already: merged, not sorted (sorting
    // its 1,536 spots with the 48 was a tenth of the order's time). On a
    // tie the direction's spot goes first.
    let mut along = along.into_iter().peekable();
    let mut ring = ring(centre, pitch_of(radius_m), directions).peekable();
    let mut spots = Vec::with_capacity(RING_STEPS * CLEARING_DIRECTIONS + CLEARING_DIRECTIONS);
    loop {
        let next = match (along.peek(), ring.peek()) {
            (Some(a), Some(b)) if a.0.total_cmp(&b.0).is_le() => along.next(),
            (_, Some(_)) => ring.next(),
            (Some(_), None) => along.next(),
            (None, None) => break,
        };
        spots.extend(next.map(|s| s.1));
    }
    spots
}

/// Centre-to-centre distance of neighbouring spots for particles of
/// `radius_m`: a diameter and a micron.
fn pitch_of(radius_m: f64) -> f64 {
    2.0 * radius_m + 1e-6
}

/// Along each unit direction of `directions` from `centre` (within two
/// pitches), the nearest spot where a disc of `radius_m` keeps the
/// clearance (plus [`CLEARING_MARGIN_M`]) from every site except `own` and
/// `also` does not hold, with its distance; directions with none are left
/// out. [`ring_off_sites`]'s rule, also for callers that turn a direction
/// finer than its 48.
pub fn spots_off_sites_along(
    centre: Vector2<f64>,
    directions: impl IntoIterator<Item = Vector2<f64>>,
    radius_m: f64,
    sites: &SiteDiscs,
    also: &dyn Fn(Vector2<f64>) -> bool,
    own: Option<usize>,
) -> Vec<(f64, Vector2<f64>)> {
    let pitch = pitch_of(radius_m);
    let max_m = 2.0 * pitch;
    let reach = radius_m + sites.radius_m + sites.clearance_m + CLEARING_MARGIN_M;
    let near = sites.grid.within(centre, max_m + reach);
    let along = |u: Vector2<f64>| {
        // Along the ray, each site is covered on an interval of distances.
        let mut covered: Vec<(f64, f64)> = near
            .iter()
            .filter(|&&s| Some(s) != own)
            .filter_map(|&s| {
                let d = sites.centres[s] - centre;
                let b = d.dot(&u);
                let disc = b * b - (d.norm_squared() - reach * reach);
                (disc > 0.0).then(|| (b - disc.sqrt(), b + disc.sqrt()))
            })
            .filter(|&(_, hi)| hi > 0.0)
            .collect();
        covered.sort_by(|x, y| x.0.total_cmp(&y.0));
        let off_sites_from = |mut t: f64| {
            for &(lo, hi) in &covered {
                if lo > t {
                    break;
                }
                t = t.max(hi);
            }
            t
        };
        // Off the sites, then out of `also` (marching, then bisecting its
        // edge), until both hold at once.
        let mut t = off_sites_from(0.0);
        for _ in 0..4 {
            if t > max_m || !also(centre + u * t) {
                break;
            }
            t = match exit_along(centre, u, t, pitch / 8.0, max_m, also) {
                Some(out) => off_sites_from(out + CLEARING_MARGIN_M),
                None => f64::INFINITY,
            };
        }
        (t > 0.0 && t <= max_m && !also(centre + u * t)).then(|| (t, centre + u * t))
    };
    directions.into_iter().filter_map(along).collect()
}

/// The first distance beyond `t` along `u` from `centre` (up to `max_m`)
/// where `covered` fails: marched in steps of `step_m`, then its edge
/// bisected to a nanometre.
fn exit_along(
    centre: Vector2<f64>,
    u: Vector2<f64>,
    mut t: f64,
    step_m: f64,
    max_m: f64,
    covered: &dyn Fn(Vector2<f64>) -> bool,
) -> Option<f64> {
    let mut out = t;
    while covered(centre + u * out) {
        t = out;
        out += step_m;
        if out > max_m {
            return None;
        }
    }
    while out - t > 1e-9 {
        let mid = 0.5 * (t + out);
        if covered(centre + u * mid) {
            t = mid;
        } else {
            out = mid;
        }
    }
    Some(out)
}

/// Length of the shortest ring move that takes particle `index` (of
/// `particles`, all of the sites' radius) off every site and off every other
/// particle, staying in `[lo, hi]`; `max_m` when none is found.
pub fn park_cost(
    index: usize,
    particles: &[Vector2<f64>],
    particle_grid: &Grid,
    sites: &SiteDiscs,
    lo: Vector2<f64>,
    hi: Vector2<f64>,
    max_m: f64,
) -> f64 {
    let (from, radius_m, clearance_m) = (particles[index], sites.radius_m, sites.clearance_m);
    let nothing_else = |_: Vector2<f64>| false;
    for spot in ring_off_sites(from, radius_m, sites, &nothing_else, None) {
        if spot.x < lo.x || spot.y < lo.y || spot.x > hi.x || spot.y > hi.y {
            continue;
        }
        if sites.covered_by(spot, radius_m) {
            continue;
        }
        let mut free = true;
        particle_grid.for_each_within(spot, 2.0 * radius_m + clearance_m, |j| {
            if j != index {
                free = false;
            }
        });
        if free {
            return (spot - from).norm();
        }
    }
    max_m
}

/// Least distance from `from` to a point at least `reach` from every centre
/// in `centres` (0 when `from` is such a point): how far a particle must at
/// least be pushed to end clear of the sites, whatever its path. Exact: the
/// nearest such point lies on the boundary of the union of the discs, at
/// the radial exit of one disc or where two circles cross.
pub fn clearing_lower_bound(from: Vector2<f64>, centres: &[Vector2<f64>], reach: f64) -> f64 {
    let clear = |p: Vector2<f64>| {
        centres
            .iter()
            .all(|c| (p - c).norm() >= reach * (1.0 - 1e-12))
    };
    if clear(from) {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    let mut consider = |p: Vector2<f64>| {
        let d = (p - from).norm();
        if d < best && clear(p) {
            best = d;
        }
    };
    for (i, a) in centres.iter().enumerate() {
        let out = from - a;
        let dir = if out.norm() > 0.0 {
            out / out.norm()
        } else {
            Vector2::new(1.0, 0.0)
        };
        consider(a + dir * reach);
        for b in &centres[i + 1..] {
            let ab = b - a;
            let d = ab.norm();
            if d <= 0.0 || d >= 2.0 * reach {
                continue;
            }
            let mid = a + ab * 0.5;
            let h = (reach * reach - d * d / 4.0).sqrt();
            let normal = Vector2::new(-ab.y, ab.x) / d;
            consider(mid + normal * h);
            consider(mid - normal * h);
        }
    }
    best
}

/// A lower bound on the push distance of every plan that fills `sites`
/// from `particles` (centres): the optimal assignment in which each
/// particle left without a site pays its [`clearing_lower_bound`]
/// (`reach_m[p]`: its radius plus the sites' particles'). Tighter than the
/// plain assignment (LB_push) when particles start on the sites' discs.
/// Particles within `on_site_tolerance_m` of a site stay there, as in the
/// planner ([`pin_on_sites`]), so the bound is never below its LB_push.
/// Dense: O(n^3), for small instances.
pub fn clearing_bound(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    reach_m: &[f64],
    on_site_tolerance_m: f64,
) -> f64 {
    let park: Vec<f64> = particles
        .iter()
        .zip(reach_m)
        .map(|(&p, &reach)| clearing_lower_bound(p, sites, reach))
        .collect();
    let grid = Grid::new(
        particles.iter().copied(),
        reach_m.iter().fold(1e-9, |a, &b| a.max(b)),
    );
    let (pinned, free_sites) = pin_on_sites(sites, &grid, on_site_tolerance_m, |_| true);
    let mut free = vec![true; particles.len()];
    let mut total = 0.0;
    for &(p, s) in &pinned {
        free[p] = false;
        total += (sites[s] - particles[p]).norm();
    }
    let free_particles: Vec<usize> = (0..particles.len()).filter(|&p| free[p]).collect();
    let site_pts: Vec<_> = free_sites.iter().map(|&s| sites[s]).collect();
    let part_pts: Vec<_> = free_particles.iter().map(|&p| particles[p]).collect();
    let free_park: Vec<f64> = free_particles.iter().map(|&p| park[p]).collect();
    let chosen = with_parking::solve(&site_pts, &part_pts, &free_park, &[], &Default::default());
    total += free_park.iter().sum::<f64>();
    for (s, &p) in chosen.iter().enumerate() {
        total += (site_pts[s] - part_pts[p]).norm() - free_park[p];
    }
    total
}

/// The particles already on a site, which stay there (issue 4): each
/// site's nearest particle when it lies within `tolerance_m` and is
/// `movable` and not pinned to an earlier site. Returns the (particle,
/// site) pairs pinned and the sites left free, in order.
pub fn pin_on_sites(
    sites: &[Vector2<f64>],
    particles: &Grid,
    tolerance_m: f64,
    movable: impl Fn(usize) -> bool,
) -> (Vec<(usize, usize)>, Vec<usize>) {
    let mut taken = std::collections::HashSet::new();
    let (mut pinned, mut free) = (Vec::new(), Vec::new());
    for (si, &s) in sites.iter().enumerate() {
        match particles.nearest(s, 1).first() {
            Some(&(d, p)) if d <= tolerance_m && movable(p) && taken.insert(p) => {
                pinned.push((p, si));
            }
            _ => free.push(si),
        }
    }
    (pinned, free)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_particle_on_a_site_pays_the_way_out_and_one_beside_it_pays_nothing() {
        let sites = vec![Vector2::new(50.0, 50.0)];
        let sg = Grid::new(sites.clone(), 10.0);
        let discs = SiteDiscs {
            grid: &sg,
            centres: &sites,
            radius_m: 5.0,
            clearance_m: 0.1,
        };
        assert!(discs.covered_by(Vector2::new(55.0, 50.0), 5.0));
        assert!(!discs.covered_by(Vector2::new(61.0, 50.0), 5.0));
        let parts = vec![Vector2::new(55.0, 50.0)];
        let pg = Grid::new(parts.clone(), 10.0);
        let lo = Vector2::new(0.0, 0.0);
        let hi = Vector2::new(100.0, 100.0);
        let c = park_cost(0, &parts, &pg, &discs, lo, hi, 1e9);
        // It must end >= 10.1 from the site: at least 5.1 away, at most one ring step more.
        assert!((5.1..=5.1 + 2.75 + 1e-9).contains(&c), "cost {c}");
    }

    #[test]
    fn the_nearest_spots_leave_a_site_or_a_band_by_the_margin_only() {
        let (r, cl) = (5e-6, 0.1e-6);
        let sites = vec![Vector2::new(50e-6, 50e-6)];
        let sg = Grid::new(sites.clone(), 10e-6);
        let discs = SiteDiscs {
            grid: &sg,
            centres: &sites,
            radius_m: r,
            clearance_m: cl,
        };
        // 9.5 um from the site: 0.6 um (plus the margin) from clearing it.
        let from = Vector2::new(59.5e-6, 50e-6);
        let none = |_: Vector2<f64>| false;
        let spots = ring_off_sites(from, r, &discs, &none, None);
        let first = spots[0];
        let need = 10.1e-6 - 9.5e-6 + CLEARING_MARGIN_M;
        assert!(((first - from).norm() - need).abs() < 1e-9, "{first:?}");
        assert!(!discs.covered_by(first, r));
        // Nearest first, and the ring is still there.
        assert!(
            spots
                .windows(2)
                .all(|w| (w[0] - from).norm() <= (w[1] - from).norm() + 1e-12)
        );
        assert!(spots.len() >= 32 * 48);
        // Also out of a band below y = 51.5 um: the spot leaves both.
        let band = |p: Vector2<f64>| p.y < 51.5e-6;
        let first = ring_off_sites(from, r, &discs, &band, None)[0];
        assert!(!band(first) && !discs.covered_by(first, r));
        assert!((first - from).norm() < 2.0e-6, "{first:?}");
    }

    /// One disc: the radial exit. Two overlapping discs with the point
    /// between them: out through a crossing of the circles, not a radial
    /// exit (which lands inside the other disc). Outside: 0.
    #[test]
    fn the_clearing_bound_leaves_the_union_of_the_site_discs() {
        let one = [Vector2::new(0.0, 0.0)];
        let d = clearing_lower_bound(Vector2::new(3.0, 0.0), &one, 10.0);
        assert!((d - 7.0).abs() < 1e-12, "{d}");
        assert_eq!(
            clearing_lower_bound(Vector2::new(12.0, 0.0), &one, 10.0),
            0.0
        );
        let two = [Vector2::new(-6.0, 0.0), Vector2::new(6.0, 0.0)];
        let d = clearing_lower_bound(Vector2::new(0.0, 0.0), &two, 10.0);
        // The circles cross at (0, +-8).
        assert!((d - 8.0).abs() < 1e-9, "{d}");
    }
}
