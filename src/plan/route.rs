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
use super::layout::Layout;
use super::pushes::Corridor;
use nalgebra::Vector2;

/// Ray directions cast from each end.
const DIRECTIONS: usize = 32;
/// Distances of the points along a ray, in particle radii: finer near the
/// ends, where a short move blocked only behind its tip needs a small bend.
const RAY_RADII: [f64; 19] = [
    0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 14.0,
    16.0,
];
/// Points along a ray.
const STEPS: usize = RAY_RADII.len();
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
    /// The layout's field shrunk by its largest particle radius.
    pub fn of_layout(layout: &Layout) -> Self {
        let r = layout.max_radius_m();
        Reach {
            lo: Vector2::new(r, r),
            hi: Vector2::new(layout.field_m[0] - r, layout.field_m[1] - r),
        }
    }

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
    find_route_within(from, to, radius_m, config, reach, 2, f64::INFINITY, free)
}

/// [`find_route`] with at most `waypoints` (0, 1 or 2) waypoints and a
/// total length below `shorter_than_m` (infinite: any length).
#[allow(clippy::too_many_arguments)]
pub fn find_route_within(
    from: Vector2<f64>,
    to: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
    reach: Reach,
    waypoints: usize,
    shorter_than_m: f64,
    free: &dyn Fn(&Corridor) -> bool,
) -> Option<Vec<Vector2<f64>>> {
    let leg_free = |a: Vector2<f64>, b: Vector2<f64>| free(&Corridor::new(a, b, radius_m, config));
    if (to - from).norm() >= shorter_than_m {
        return None;
    }
    if leg_free(from, to) {
        return Some(vec![to]);
    }
    if waypoints == 0 {
        return None;
    }
    // Waypoints on rays from both ends. A waypoint on a ray from `to` needs a
    // free last leg into `to`, one on a ray from `from` a free first leg: its
    // ray leg. Along a ray the corridor only grows, so a ray is closed beyond
    // its first blocked step. Ray legs are tested lazily, shortest route
    // first: most searches end after a few tests, not after all 1,024.
    let mut last_rays = Rays::new(to, radius_m, reach);
    let mut first_rays = Rays::new(from, radius_m, reach);
    let len = |w: &Vector2<f64>| (w - from).norm() + (to - w).norm();
    let one: Vec<(f64, bool, usize)> = last_rays
        .points()
        .map(|(i, w)| (len(&w), true, i))
        .chain(first_rays.points().map(|(i, w)| (len(&w), false, i)))
        .filter(|c| c.0 < shorter_than_m)
        .collect();
    let mut tests = 0;
    for (on_last_ray, i) in shortest_first(&one) {
        if tests == MAX_ONE_WAYPOINT_TESTS {
            break;
        }
        let ray_leg_free = if on_last_ray {
            last_rays.open(i, |w| leg_free(w, to))
        } else {
            first_rays.open(i, |w| leg_free(from, w))
        };
        if !ray_leg_free {
            continue;
        }
        tests += 1;
        let other_free = if on_last_ray {
            leg_free(from, last_rays.point(i))
        } else {
            leg_free(first_rays.point(i), to)
        };
        if other_free {
            let w = if on_last_ray {
                last_rays.point(i)
            } else {
                first_rays.point(i)
            };
            return Some(vec![w, to]);
        }
    }
    if waypoints == 1 {
        return None;
    }
    // Two waypoints: free first leg to w1, free last leg from w2, test the middle.
    // Along a ray from either end, |from - w| + |w - to| never decreases,
    // so a ray is walked only while a route through it can be short enough.
    let short = |w: Vector2<f64>| len(&w) < shorter_than_m;
    let first_ok = first_rays.open_points(short, |w| leg_free(from, w));
    let last_ok = last_rays.open_points(short, |w| leg_free(w, to));
    let mut two: Vec<(f64, usize, usize)> = Vec::with_capacity(first_ok.len() * last_ok.len());
    for (i, w1) in first_ok.iter().enumerate() {
        for (j, w2) in last_ok.iter().enumerate() {
            let len = (w1 - from).norm() + (w2 - w1).norm() + (to - w2).norm();
            if len < shorter_than_m {
                two.push((len, i, j));
            }
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

/// The candidates' (on the last ray, point index) by length, ties in their
/// order: a heap popped lazily, since most searches end after a few of the
/// up to 1,216 (a full sort of them took a tenth of the route search).
fn shortest_first(candidates: &[(f64, bool, usize)]) -> impl Iterator<Item = (bool, usize)> + '_ {
    struct Shortest(f64, usize);
    impl PartialEq for Shortest {
        fn eq(&self, other: &Self) -> bool {
            self.cmp(other).is_eq()
        }
    }
    impl Eq for Shortest {}
    impl PartialOrd for Shortest {
        fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(other))
        }
    }
    impl Ord for Shortest {
        // Reversed: the max-heap pops the shortest, then the earliest.
        fn cmp(&self, other: &Self) -> std::cmp::Ordering {
            other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
        }
    }
    let mut heap: std::collections::BinaryHeap<Shortest> = candidates
        .iter()
        .enumerate()
        .map(|(k, c)| Shortest(c.0, k))
        .collect();
    std::iter::from_fn(move || heap.pop()).map(|Shortest(_, k)| (candidates[k].1, candidates[k].2))
}

/// How far from either end of a route the corridors its search tests can
/// reach, metres: the last ray step, a particle radius, and the tip landing
/// behind it.
pub fn search_extent_m(radius_m: f64, config: &PlanConfig) -> f64 {
    (RAY_RADII[STEPS - 1] + 1.0) * radius_m + config.tip_radius_m + config.standoff_m
}

/// Points on rays cast from one end of a route (inside `reach`), with the
/// outcome of each ray leg's test remembered: a ray is closed from its
/// first blocked step outwards.
struct Rays {
    centre: Vector2<f64>,
    step_m: f64,
    /// Unit vector of each ray (computed once: every point asked for one).
    directions: [Vector2<f64>; DIRECTIONS],
    /// Per ray and step (index `ray * STEPS + step - 1`): tested free or blocked.
    tested: Vec<Option<bool>>,
    /// Per ray: the first step known blocked (or out of reach).
    closed_from: [usize; DIRECTIONS],
}

impl Rays {
    fn new(centre: Vector2<f64>, step_m: f64, reach: Reach) -> Self {
        let mut rays = Rays {
            centre,
            step_m,
            directions: std::array::from_fn(|a| {
                let ang = std::f64::consts::TAU * a as f64 / DIRECTIONS as f64;
                Vector2::new(ang.cos(), ang.sin())
            }),
            tested: vec![None; DIRECTIONS * STEPS],
            closed_from: [STEPS + 1; DIRECTIONS],
        };
        for a in 0..DIRECTIONS {
            if let Some(k) = (1..=STEPS).find(|&k| !reach.contains(rays.at(a, k))) {
                rays.closed_from[a] = k;
            }
        }
        rays
    }

    fn at(&self, ray: usize, step: usize) -> Vector2<f64> {
        self.centre + self.directions[ray] * (self.step_m * RAY_RADII[step - 1])
    }

    /// The point of index `i` (`ray * STEPS + step - 1`).
    fn point(&self, i: usize) -> Vector2<f64> {
        self.at(i / STEPS, i % STEPS + 1)
    }

    /// Every point inside the reach, with its index.
    fn points(&self) -> impl Iterator<Item = (usize, Vector2<f64>)> + '_ {
        (0..DIRECTIONS).flat_map(move |a| {
            (1..self.closed_from[a]).map(move |k| (a * STEPS + k - 1, self.at(a, k)))
        })
    }

    /// True when point i's ray leg is free (`leg_free`, tested once) and its
    /// ray is not closed before it.
    fn open(&mut self, i: usize, leg_free: impl Fn(Vector2<f64>) -> bool) -> bool {
        let (ray, step) = (i / STEPS, i % STEPS + 1);
        if step >= self.closed_from[ray] {
            return false;
        }
        let w = self.at(ray, step);
        let free = *self.tested[i].get_or_insert_with(|| leg_free(w));
        if !free {
            self.closed_from[ray] = step;
        }
        free
    }

    /// The points whose ray legs are free, each ray walked outwards until
    /// its first blocked step or its first point that `keep` rejects.
    fn open_points(
        &mut self,
        keep: impl Fn(Vector2<f64>) -> bool,
        leg_free: impl Fn(Vector2<f64>) -> bool,
    ) -> Vec<Vector2<f64>> {
        let mut out = Vec::new();
        for a in 0..DIRECTIONS {
            for k in 1..=STEPS {
                let i = a * STEPS + k - 1;
                if !keep(self.at(a, k)) || !self.open(i, &leg_free) {
                    break;
                }
                out.push(self.at(a, k));
            }
        }
        out
    }
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
