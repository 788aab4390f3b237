//! A parked push waits for the nearby particle that blocks its nearer way
//! and moves only after it.

use super::clear_for;
use super::parking_spots::Parking;
use super::pull_in::end_push_at;
use super::pull_in::nearer_parking_end;
use super::pull_in::parked_pushes;
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use crate::plan::pushes::corridor_reach;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;
use std::collections::HashMap;

/// Least a parked push must shorten for [`park_after_blocker`] to reorder
/// the plan: the tour re-sequences the pushes after the shortcuts anyway,
/// but a reordered plan is harder to follow for little.
const REORDER_GAIN_M: f64 = 0.1e-6;

/// `steps` where a parked particle's push, whose nearer spots are blocked
/// by a particle that only moves later (another's tip landing, or its
/// disc, in the way), waits until that particle has moved: the other's
/// pushes go first, when they replay clear there, and the parked push
/// ends at the nearer spot then found ([`nearer_parking_end`]). CMU seed
/// 95 of the 40-60 scenes: p32, pushed 3.88 um off site 15 between p53
/// (on the tip's landing of the radial way out) and p3 (on the spot of a
/// way 30 degrees round), where 2.9 um would do once p3 is on its site.
pub(super) fn park_after_blocker(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    for k in parked_pushes(&steps, parking).into_iter().rev() {
        let Some((particle, from, to)) = steps[k].push_move() else {
            continue;
        };
        let x = index[&particle];
        let len = (to - from).norm();
        let reach = len + corridor_reach(layout.particles[x].radius_m, config) + config.clearance_m;
        // Particles that first move after push k, near enough to bound it.
        let mut first_start: HashMap<u32, (usize, Vector2<f64>)> = HashMap::new();
        for (j, step) in steps.iter().enumerate() {
            if let Some((id, start, _)) = step.push_move() {
                first_start.entry(id).or_insert((j, start));
            }
        }
        let mut blockers: Vec<u32> = first_start
            .into_iter()
            .filter(|&(id, (j, start))| {
                j > k && (start - from).norm() < reach + layout.particles[index[&id]].radius_m
            })
            .map(|(id, _)| id)
            .collect();
        blockers.sort_unstable();
        let found = blockers.into_iter().find_map(|id| {
            // Their pushes all come after k: they go just before it.
            let theirs = |s: &&Step| s.push_move().is_some_and(|(p, _, _)| p == id);
            let mut hoisted: Vec<Step> = steps[..k].to_vec();
            hoisted.extend(steps[k..].iter().filter(theirs).cloned());
            let moved = hoisted.len() - k;
            hoisted.extend(steps[k..].iter().filter(|s| !theirs(s)).cloned());
            if !clear_for(&hoisted, layout, index, config, index[&id]) {
                return None;
            }
            let at = k + moved;
            let end = nearer_parking_end(&hoisted, at, layout, index, parking, config)?;
            if (end - from).norm() > len - REORDER_GAIN_M {
                return None;
            }
            end_push_at(&mut hoisted, at, end, layout, index, config);
            clear_for(&hoisted, layout, index, config, x).then_some(hoisted)
        });
        if let Some(shorter) = found {
            steps = shorter;
        }
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::*;

    #[test]
    fn a_parked_push_waits_for_the_particle_that_blocks_its_nearer_way() {
        // Particle 0 lies 2 um from the site at (52, 50); particle 1, at
        // (34, 50), leaves for its site at (34, 30) only after particle 0
        // was pushed up, 9.95 um at least. With particle 1 gone, the way
        // out to the left is 8.15 um: particle 1 goes first, then particle
        // 0 is pushed left.
        let layout = Layout::of_test_centres_um(&[(50.0, 50.0), (34.0, 50.0)]);
        let steps = vec![
            push(0, (50.0, 50.0), (50.0, 61.0)),
            push(1, (34.0, 50.0), (34.0, 30.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(52.0, 50.0), (34.0, 30.0)]);
        let k = |id: u32| {
            out.iter()
                .position(|s| s.push_move().is_some_and(|m| m.0 == id))
        };
        assert!(k(1) < k(0), "particle 1 still moves after particle 0");
        let (_, from, to) = push_at(&out, k(0).unwrap());
        let len = (to - from).norm();
        assert!(len > 8.1 && len < 8.3 && to.x < 50.0, "{len} to {to:?}");
    }
}
