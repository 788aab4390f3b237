//! The last push of a particle that ends on no site, pulled in to the
//! nearest spot off the sites that replays clear, or dropped.

use super::MIN_SAVING_M;
use super::bisect;
use super::parking_spots::Parking;
use super::parking_spots::turned_nearer;
use super::push_step;
use super::single_push_check::SinglePushCheck;
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use crate::plan::parking::CLEARING_MARGIN_M;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;
use std::collections::HashMap;

/// `steps` with each push that leaves a particle on no site (its last)
/// shortened to the nearest end found that keeps the parking margin from
/// every site (the site discs with [`CLEARING_MARGIN_M`], as the order's
/// spots) and replays clear: no push at all, a nearer spot off the sites
/// in another direction, or the nearest fraction of the push off the
/// sites, else by bisection towards the full push.
pub(super) fn pull_in_parking(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    // Last first: dropping a push leaves the earlier indices as they are.
    for k in parked_pushes(&steps, parking).into_iter().rev() {
        let Some(end) = nearer_parking_end(&steps, k, layout, index, parking, config) else {
            continue;
        };
        end_push_at(&mut steps, k, end, layout, index, config);
    }
    steps
}

/// Ends the push `k` of `steps` at `end`, or drops it when `end` is where
/// it starts.
pub(super) fn end_push_at(
    steps: &mut Vec<Step>,
    k: usize,
    end: Vector2<f64>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    config: &PlanConfig,
) {
    let (particle, from_m, _) = steps[k].push_move().expect("a push");
    if (end - from_m).norm() < MIN_SAVING_M {
        steps.remove(k);
    } else {
        let r = layout.particles[index[&particle]].radius_m;
        steps[k] = push_step(particle, from_m, end, r, config);
    }
}

/// Indices of the pushes that leave a particle on no site for good (its
/// last push), in order.
pub(super) fn parked_pushes(steps: &[Step], parking: &Parking) -> Vec<usize> {
    let mut last: HashMap<u32, usize> = HashMap::new();
    for (k, step) in steps.iter().enumerate() {
        if let Some((particle, _, _)) = step.push_move() {
            last.insert(particle, k);
        }
    }
    let mut parked: Vec<usize> = last
        .into_values()
        .filter(|&k| {
            !steps[k]
                .push_move()
                .is_some_and(|(_, _, to)| parking.on_site(to))
        })
        .collect();
    parked.sort_unstable();
    parked
}

/// A nearer end for the parked push `k` ([`pull_in_parking`]'s rule), or
/// None when none replays clear.
pub(super) fn nearer_parking_end(
    steps: &[Step],
    k: usize,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Option<Vector2<f64>> {
    let (particle, from_m, to_m) = steps[k].push_move()?;
    let discs = parking.discs_with(CLEARING_MARGIN_M);
    let x = index[&particle];
    let check = SinglePushCheck::new(steps, (x, from_m), k, true, layout, index, config);
    let len = (to_m - from_m).norm();
    let shorter = |spot: Vector2<f64>| (spot - from_m).norm() < len - MIN_SAVING_M;
    let at = |t: f64| from_m + (to_m - from_m) * t;
    let swept = |p: Vector2<f64>| check.swept_later(p);
    let spots = parking.ends(from_m, check.radius, len, &swept);
    let end = spots
        .into_iter()
        .find(|&spot| check.allows(spot))
        .or_else(|| {
            // The nearest fraction (in 32nds) from which the rest of the
            // push stays off the sites.
            let mut t_off = 1.0;
            for n in (0..32).rev() {
                let t = n as f64 / 32.0;
                if discs.covered_by(at(t), check.radius) {
                    break;
                }
                t_off = t;
            }
            if !shorter(at(t_off)) {
                return None;
            }
            if check.allows(at(t_off)) {
                return Some(at(t_off));
            }
            bisect((1.0, t_off), |t| check.allows(at(t))).map(at)
        });
    // The push as it is, or as found, may turn to a nearer spot.
    let turned = turned_nearer(
        parking,
        (from_m, end.unwrap_or(to_m)),
        check.radius,
        &swept,
        |spot| check.allows(spot),
    );
    (end.is_some() || turned != to_m).then_some(turned)
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::*;

    #[test]
    fn a_parked_particle_stops_where_it_is_off_the_sites() {
        // Particle 1 covers the site at (50, 50) (3 um off its centre) and
        // was parked 20 um away; 10.15 um plus the margin is enough.
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (53.0, 50.0)]);
        let steps = vec![
            push(1, (53.0, 50.0), (73.0, 50.0)),
            push(0, (20.0, 50.0), (50.0, 50.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(50.0, 50.0)]);
        assert_eq!(fewer, 0);
        let clearance = PlanConfig::default().clearance_m * 1e6;
        let off = (push_at(&out, 0).2.x - 50.0) - 10.0 - clearance;
        // Within one 32nd of the 20 um push beyond the least distance.
        assert!((0.0..=20.0 / 32.0).contains(&off), "{off}");
    }

    #[test]
    fn a_particle_pushed_off_a_way_no_push_uses_stays_put() {
        // Particle 1 was pushed aside for nothing: particle 0 passes far
        // from it. The push is dropped.
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 150.0)]);
        let steps = vec![
            push(1, (50.0, 150.0), (50.0, 170.0)),
            push(0, (20.0, 50.0), (80.0, 50.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(80.0, 50.0)]);
        assert_eq!(fewer, 1);
        assert_eq!(out.len(), 1);
    }

    #[test]
    fn a_particle_pushed_off_a_way_keeps_clear_of_it() {
        // Particle 1 sits on particle 0's line and is pushed 20 um aside:
        // pulled in, it stops just clear of the corridor (about 10.15 um).
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![
            push(1, (50.0, 50.0), (50.0, 70.0)),
            push(0, (20.0, 50.0), (80.0, 50.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(80.0, 50.0)]);
        let y = push_at(&out, 0).2.y;
        assert!(y > 60.0 && y < 62.0, "{y}");
    }

    #[test]
    fn a_parked_particle_takes_a_nearer_way_off_the_sites() {
        // Particle 1 lies 3 um above the site at (50, 50) and was parked
        // 20 um to the left; straight up, 7.2 um, clears the site.
        let layout = Layout::of_test_centres_um(&[(50.0, 20.0), (50.0, 53.0)]);
        let steps = vec![
            push(1, (50.0, 53.0), (30.0, 53.0)),
            push(0, (50.0, 20.0), (50.0, 50.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(50.0, 50.0)]);
        let (_, from, to) = push_at(&out, 0);
        let len = (to - from).norm();
        // Least: 10.15 um clearance plus the margin, less the 3 um.
        let least = 10.0 + (PlanConfig::default().clearance_m + CLEARING_MARGIN_M) * 1e6 - 3.0;
        assert!(len >= least - 1e-6 && len < least + 0.5, "{len}");
        assert!((to - Vector2::new(50.0, 50.0)).norm() >= least + 3.0 - 1e-6);
    }
}
