//! Short routes of straight pushes for one particle around obstacles.
//!
//! A route is the straight push when its corridor is free, else one
//! waypoint, else two, taken from rays cast from both ends (32 directions,
//! distances in steps of the particle radius), shortest total length first.
//! What counts as an obstacle is the caller's `free` test on each leg's
//! [`Corridor`] (particle and tip), so the same search serves the static
//! fill order (sites filled earlier) and the scheduler (particles where
//! they are now). Written by hand: a visibility-graph crate would need the
//! corridors as polygons and would not know the tip that lands behind every
//! leg; rays keep the search bounded (a few hundred corridor tests).

use super::PlanConfig;
use super::pushes::Corridor;
use nalgebra::Vector2;

/// Ray directions cast from each end.
const DIRECTIONS: usize = 32;
/// Steps along a ray, each one particle radius long.
const STEPS: usize = 16;
/// Most leg tests spent on one-waypoint candidates before trying two.
const MAX_ONE_WAYPOINT_TESTS: usize = 600;
/// Most middle-leg tests spent on two-waypoint candidates.
const MAX_TWO_WAYPOINT_TESTS: usize = 1000;

/// Where a particle centre may go: the field shrunk by the particle radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// Lower corner, metres.
    pub lo: Vector2<f64>,
    /// Upper corner, metres.
    pub hi: Vector2<f64>,
}

impl Reach {
    /// True when `p` lies inside.
    pub fn contains(&self, p: Vector2<f64>) -> bool {
        p.x >= self.lo.x && p.y >= self.lo.y && p.x <= self.hi.x && p.y <= self.hi.y
    }
}

/// The points a particle at `from` passes through to reach `to` (waypoints,
/// then `to`), each leg free by `free`; None when no route of at most two
/// waypoints is found.
pub fn find_route(
    from: Vector2<f64>,
    to: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
    reach: Reach,
    free: &dyn Fn(&Corridor) -> bool,
) -> Option<Vec<Vector2<f64>>> {
    let leg_free = |a: Vector2<f64>, b: Vector2<f64>| free(&Corridor::new(a, b, radius_m, config));
    if leg_free(from, to) {
        return Some(vec![to]);
    }
    // Points on rays from `to` whose last leg into `to` is free, and points on
    // rays from `from` whose first leg is free. Along a ray the corridor only
    // grows, so each ray stops at its first blocked step.
    let last_ok = free_ray_points(to, radius_m, reach, |w| leg_free(w, to));
    let first_ok = free_ray_points(from, radius_m, reach, |w| leg_free(from, w));
    let len = |w: &Vector2<f64>| (w - from).norm() + (to - w).norm();
    // One waypoint: a free last leg needing a free first leg, or the reverse.
    let mut one: Vec<(f64, Vector2<f64>, bool)> = last_ok
        .iter()
        .map(|w| (len(w), *w, true))
        .chain(first_ok.iter().map(|w| (len(w), *w, false)))
        .collect();
    one.sort_by(|a, b| a.0.total_cmp(&b.0));
    for &(_, w, last_is_free) in one.iter().take(MAX_ONE_WAYPOINT_TESTS) {
        let other_free = if last_is_free {
            leg_free(from, w)
        } else {
            leg_free(w, to)
        };
        if other_free {
            return Some(vec![w, to]);
        }
    }
    // Two waypoints: free first leg to w1, free last leg from w2, test the middle.
    let mut two: Vec<(f64, usize, usize)> = Vec::with_capacity(first_ok.len() * last_ok.len());
    for (i, w1) in first_ok.iter().enumerate() {
        for (j, w2) in last_ok.iter().enumerate() {
            two.push((
                (w1 - from).norm() + (w2 - w1).norm() + (to - w2).norm(),
                i,
                j,
            ));
        }
    }
    let keep = MAX_TWO_WAYPOINT_TESTS.min(two.len());
    if keep < two.len() {
        two.select_nth_unstable_by(keep, |a, b| a.0.total_cmp(&b.0));
        two.truncate(keep);
    }
    two.sort_by(|a, b| a.0.total_cmp(&b.0));
    two.into_iter()
        .find(|&(_, i, j)| leg_free(first_ok[i], last_ok[j]))
        .map(|(_, i, j)| vec![first_ok[i], last_ok[j], to])
}

/// Points along rays from `centre` (inside `reach`) for which `ok` holds,
/// each ray walked outwards until `ok` first fails.
fn free_ray_points(
    centre: Vector2<f64>,
    step_m: f64,
    reach: Reach,
    ok: impl Fn(Vector2<f64>) -> bool,
) -> Vec<Vector2<f64>> {
    let mut out = Vec::new();
    for a in 0..DIRECTIONS {
        let ang = std::f64::consts::TAU * a as f64 / DIRECTIONS as f64;
        let dir = Vector2::new(ang.cos(), ang.sin());
        for k in 1..=STEPS {
            let w = centre + dir * (step_m * k as f64);
            if !reach.contains(w) || !ok(w) {
                break;
            }
            out.push(w);
        }
    }
    out
}

/// Total length of the route from `from` through `points`.
pub fn route_length(from: Vector2<f64>, points: &[Vector2<f64>]) -> f64 {
    let mut at = from;
    let mut total = 0.0;
    for p in points {
        total += (p - at).norm();
        at = *p;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reach() -> Reach {
        Reach {
            lo: Vector2::new(5e-6, 5e-6),
            hi: Vector2::new(195e-6, 195e-6),
        }
    }

    #[test]
    fn a_wall_in_the_way_gives_a_detour_whose_legs_avoid_it() {
        let cfg = PlanConfig::default();
        let r = 5e-6;
        // A vertical wall of discs between from and to, open above y = 83 um.
        let wall: Vec<Vector2<f64>> = (0..6)
            .map(|i| Vector2::new(100e-6, 20e-6 + 10.5e-6 * i as f64))
            .collect();
        let free = |c: &Corridor| wall.iter().all(|w| !c.hits(*w, r, cfg.clearance_m));
        let from = Vector2::new(60e-6, 60e-6);
        let to = Vector2::new(140e-6, 60e-6);
        let route = find_route(from, to, r, &cfg, reach(), &free).expect("a route around");
        assert!(route.len() >= 2, "straight through the wall: {route:?}");
        assert_eq!(*route.last().unwrap(), to);
        let mut at = from;
        for p in &route {
            assert!(free(&Corridor::new(at, *p, r, &cfg)), "leg {at:?} -> {p:?}");
            at = *p;
        }
        assert!(route_length(from, &route) > (to - from).norm());
        // Straight when nothing is in the way.
        let open = |_: &Corridor| true;
        assert_eq!(
            find_route(from, to, r, &cfg, reach(), &open),
            Some(vec![to])
        );
        // Enclosed target: no route.
        let ring: Vec<Vector2<f64>> = (0..8)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 8.0;
                to + Vector2::new(a.cos(), a.sin()) * 10.5e-6
            })
            .collect();
        let enclosed = |c: &Corridor| ring.iter().all(|w| !c.hits(*w, r, cfg.clearance_m));
        assert_eq!(find_route(from, to, r, &cfg, reach(), &enclosed), None);
    }
}
