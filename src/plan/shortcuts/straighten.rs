//! A particle pushed along a bent path is pushed straight from its start to
//! its end instead (or, when it ends on no site, to a nearer spot off the
//! sites), at the time of its first push or its last.

use super::MIN_SAVING_M;
use super::parking_spots::Parking;
use super::parking_spots::turned_nearer;
use super::push_step;
use super::single_push_check::SinglePushCheck;
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use crate::plan::pushes::max_push_len;
use crate::plan::pushes::split_long;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;
use std::collections::HashMap;

/// `steps` with every bent path that can be straightened so (at its first
/// push or its last), largest saving first; a particle that ends on no
/// site may end at any spot off the sites nearer than its path's length
/// (CMU seed 3 of the 40-60 scenes: a particle pushed off a site, then
/// later off a corridor, 2.5 um where 0.25 um leaves the site).
pub(super) fn straighten(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    for (particle, excess) in bent_paths(&steps) {
        let Some(path) = PathOf::find(&steps, particle) else {
            continue;
        };
        let x = index[&particle];
        let length = (path.end - path.start).norm() + excess;
        let parked = !parking.on_site(path.end);
        let checks = [path.first, path.last].map(|at| {
            let unchanged_before = at == path.first;
            let c = SinglePushCheck::new(
                &steps,
                (x, path.start),
                at,
                unchanged_before,
                layout,
                index,
                config,
            );
            (at, c)
        });
        // (length, which check, end), shortest first: the path's own end,
        // then for a parked particle any spot off the sites.
        let mut tries: Vec<(f64, usize, Vector2<f64>)> = Vec::new();
        for (which, (_, check)) in checks.iter().enumerate() {
            tries.push((length - excess, which, path.end));
            if parked {
                let swept = |p: Vector2<f64>| check.swept_later(p);
                for end in parking.ends(path.start, check.radius, length, &swept) {
                    tries.push(((end - path.start).norm(), which, end));
                }
            }
        }
        tries.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let found = tries
            .into_iter()
            .find(|&(_, which, end)| checks[which].1.allows(end));
        if let Some((_, which, end)) = found {
            let (at, check) = &checks[which];
            let end = if parked {
                let swept = |p: Vector2<f64>| check.swept_later(p);
                turned_nearer(parking, (path.start, end), check.radius, &swept, |spot| {
                    check.allows(spot)
                })
            } else {
                end
            };
            steps = path.straightened(&steps, *at, end, check.radius, config);
        }
    }
    steps
}

/// Particle ids whose pushes add up to more than their straight line,
/// largest excess first.
pub(super) fn bent_paths(steps: &[Step]) -> Vec<(u32, f64)> {
    let mut path: HashMap<u32, (Vector2<f64>, Vector2<f64>, f64)> = HashMap::new();
    for step in steps {
        if let Some((particle, from_m, to_m)) = step.push_move() {
            let e = path.entry(particle).or_insert((from_m, from_m, 0.0));
            e.1 = to_m;
            e.2 += (to_m - from_m).norm();
        }
    }
    let mut bent: Vec<(u32, f64)> = path
        .into_iter()
        .map(|(id, (start, end, len))| (id, len - (end - start).norm()))
        .filter(|&(_, saving)| saving > MIN_SAVING_M)
        .collect();
    bent.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    bent
}

/// One particle's pushes in a plan: where they start and end, and the
/// indices of its first and last.
struct PathOf {
    particle: u32,
    start: Vector2<f64>,
    end: Vector2<f64>,
    first: usize,
    last: usize,
}

impl PathOf {
    fn find(steps: &[Step], particle: u32) -> Option<Self> {
        let mut found: Option<PathOf> = None;
        for (k, step) in steps.iter().enumerate() {
            if let Some((id, from_m, to_m)) = step.push_move()
                && id == particle
            {
                let p = found.get_or_insert(PathOf {
                    particle,
                    start: from_m,
                    end: to_m,
                    first: k,
                    last: k,
                });
                p.end = to_m;
                p.last = k;
            }
        }
        found
    }

    /// `steps` without this particle's pushes (radius `r`), and its
    /// straight push to `end` (split to fit the nanostage; none when `end`
    /// is its start) where step `at` was.
    fn straightened(
        &self,
        steps: &[Step],
        at: usize,
        end: Vector2<f64>,
        r: f64,
        config: &PlanConfig,
    ) -> Vec<Step> {
        let pieces = if (end - self.start).norm() < MIN_SAVING_M {
            Vec::new()
        } else {
            split_long(self.start, end, max_push_len(r, config))
        };
        let straight = pieces
            .into_iter()
            .map(|(a, b)| push_step(self.particle, a, b, r, config));
        let mut out = Vec::with_capacity(steps.len());
        let mut straight = Some(straight);
        for (k, step) in steps.iter().enumerate() {
            if k == at {
                out.extend(straight.take().into_iter().flatten());
            }
            match step {
                Step::Push { particle, .. } if *particle == self.particle => {}
                other => out.push(other.clone()),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::*;

    #[test]
    fn a_bent_path_in_open_space_goes_straight() {
        let layout = Layout::of_test_centres_um(&[(50.0, 50.0), (150.0, 150.0)]);
        let steps = vec![
            push(0, (50.0, 50.0), (60.0, 50.0)),
            push(1, (150.0, 150.0), (150.0, 140.0)),
            push(0, (60.0, 50.0), (60.0, 60.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(60.0, 60.0), (150.0, 140.0)]);
        assert_eq!(fewer, 1);
        let expected = 200f64.sqrt() + 10.0;
        assert!((push_length(&out) * 1e6 - expected).abs() < 1e-9);
        let (particle, _, to) = push_at(&out, 0);
        assert_eq!(particle, 0);
        assert!((to - Vector2::new(60.0, 60.0)).norm() < 1e-9);
    }

    #[test]
    fn a_buffered_particle_waits_where_it_is_when_that_is_clear() {
        // Particle 0 steps aside and back while particle 1 passes well clear
        // of it: staying put until the last push is clear too, and shorter.
        let layout = Layout::of_test_centres_um(&[(20.0, 20.0), (100.0, 100.0)]);
        let steps = vec![
            push(0, (20.0, 20.0), (20.0, 40.0)),
            push(1, (100.0, 100.0), (100.0, 150.0)),
            push(0, (20.0, 40.0), (20.0, 20.5)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(20.0, 20.5), (100.0, 150.0)]);
        assert_eq!(fewer, 1);
        assert!((push_length(&out) * 1e6 - 50.5).abs() < 1e-9);
    }

    #[test]
    fn a_particle_pushed_off_a_site_then_off_a_way_goes_once_where_neither_needs_it() {
        // Particle 1 covers the site at (50, 50); the order pushed it just
        // off, then up and right off particle 0's later way (y = 62):
        // 19.4 um. One push at the start, off the site and below the way,
        // is about 11.8 um.
        let layout = Layout::of_test_centres_um(&[(20.0, 62.0), (50.0, 58.0)]);
        let steps = vec![
            push(1, (50.0, 58.0), (50.0, 60.3)),
            push(1, (50.0, 60.3), (62.0, 72.5)),
            push(0, (20.0, 62.0), (80.0, 62.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(50.0, 50.0), (80.0, 62.0)]);
        assert_eq!(fewer, 1);
        let (particle, from, to) = push_at(&out, 0);
        assert_eq!(particle, 1);
        let len = (to - from).norm();
        assert!(len < 13.0, "{len}");
    }
}
