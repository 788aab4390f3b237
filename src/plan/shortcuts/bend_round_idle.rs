//! A particle pushed once off another's way stays put, and the one later
//! push its stay would block bends round it, when that costs less.

use super::MIN_SAVING_M;
use super::bends::slide_bend;
use super::bends::with_bend;
use super::bends::with_room;
use super::clear_for;
use super::corridor_hits;
use super::parking_spots::Parking;
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use crate::plan::pushes::max_push_len;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;
use std::collections::HashMap;

/// Where a bend is first tried on a push it replaces: fractions of the
/// way along it, and distances aside (either side), metres.
const BEND_ALONG: [f64; 5] = [0.2, 0.35, 0.5, 0.65, 0.8];

const BEND_ASIDE_M: [f64; 6] = [0.5e-6, 1e-6, 2e-6, 3e-6, 4e-6, 6e-6];

/// `steps` where a particle pushed once, from a spot off the sites to no
/// site (off another's way), stays put instead, and the one later push its
/// stay would block bends round it (a bend from a coarse set, then slid),
/// when the bent push is shorter than the two. The order moves an idle
/// blocker before it reroutes (CMU seed 50 of the 40-60 scenes: p54
/// pushed 2.33 um out of the tip's landing behind p3, where p3's push
/// bent by about 30 degrees lands its tip clear for about 1 um more).
pub(super) fn bend_round_idle(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    let radius = |i: usize| layout.particles[i].radius_m;
    let wide = with_room(config);
    let mut pushes_of: HashMap<u32, usize> = HashMap::new();
    for (id, _, _) in steps.iter().filter_map(Step::push_move) {
        *pushes_of.entry(id).or_insert(0) += 1;
    }
    let mut once: Vec<u32> = pushes_of
        .into_iter()
        .filter(|&(_, n)| n == 1)
        .map(|(id, _)| id)
        .collect();
    once.sort_unstable();
    for id in once {
        let Some(k) = steps
            .iter()
            .position(|s| s.push_move().is_some_and(|(p, _, _)| p == id))
        else {
            continue;
        };
        let (_, start, end) = steps[k].push_move().expect("a push");
        let q = index[&id];
        if parking.on_site(end) || parking.discs().covered_by(start, radius(q)) {
            continue;
        }
        let mut without = steps.clone();
        without.remove(k);
        let blocked: Vec<usize> = (k..without.len())
            .filter(|&j| {
                without[j].push_move().is_some_and(|(p, a, b)| {
                    corridor_hits((a, b, radius(index[&p])), start, radius(q), config)
                })
            })
            .collect();
        let [j] = blocked[..] else {
            continue;
        };
        let (pid, a, b) = without[j].push_move().expect("a push");
        let x = index[&pid];
        let rx = radius(x);
        let budget = (b - a).norm() + (end - start).norm() - MIN_SAVING_M;
        let longest = max_push_len(rx, config);
        let ab = b - a;
        if ab.norm() < MIN_SAVING_M {
            continue;
        }
        let aside = Vector2::new(-ab.y, ab.x).normalize();
        let mut bends: Vec<(f64, Vector2<f64>)> = BEND_ALONG
            .iter()
            .flat_map(|&t| {
                BEND_ASIDE_M
                    .iter()
                    .flat_map(move |&h| [a + ab * t + aside * h, a + ab * t - aside * h])
            })
            .filter(|&w| (w - a).norm().max((b - w).norm()) <= longest)
            .map(|w| ((w - a).norm() + (b - w).norm(), w))
            .filter(|&(len, _)| len < budget)
            .collect();
        bends.sort_by(|u, v| u.0.total_cmp(&v.0));
        let clear = |s: &[Step]| {
            clear_for(s, layout, index, &wide, x) && clear_for(s, layout, index, &wide, q)
        };
        // Push j in two pieces, then bent where they meet.
        let mut split = without;
        split.insert(j + 1, split[j].clone());
        let found = bends.into_iter().find_map(|(_, w)| {
            let bent = with_bend(&split, (j, j + 1), (pid, a, b), w, rx, config);
            clear(&bent).then_some(bent)
        });
        if let Some(bent) = found {
            steps = slide_bend(bent, (j, j + 1), rx, clear, config);
        }
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::*;

    #[test]
    fn a_particle_pushed_out_of_a_tip_landing_stays_and_the_push_bends_round_it() {
        // Particle 1 lies 4 um from where the tip lands behind particle 0's
        // push up to the site at (50, 40); the order pushed it 14.5 um
        // aside. Pushed straight away from the landing, its own tip would
        // land on particle 0; bending particle 0's push round it costs
        // under 1.5 um, and particle 1 stays.
        let layout = Layout::of_test_centres_um(&[(50.0, 20.0), (50.5, 9.0)]);
        let steps = vec![
            push(1, (50.5, 9.0), (65.0, 9.0)),
            push(0, (50.0, 20.0), (50.0, 40.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(50.0, 40.0)]);
        assert!(out.iter().all(|s| s.push_move().is_some_and(|m| m.0 == 0)));
        let len = push_length(&out) * 1e6;
        assert!(len > 20.0 && len < 21.5, "{len}");
    }
}
