//! A push shorter than the on-site tolerance joins its particle's next
//! push (or, for its last, its previous one): on the rig every push is a
//! whole cycle of approach, stroke, frame and check (about 2 s), and one
//! this short moves the particle by less than a site's own tolerance.
//! CMU seed 5 of the closed-loop study: a 2.3 nm push of a particle
//! between two longer ones, made as a 0.1 um push.

use super::clear_for;
use super::push_step;
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use crate::plan::pushes::max_push_len;
use rustc_hash::FxHashMap;

/// `steps` with each push shorter than the on-site tolerance merged into
/// its particle's next push (which then starts where the short one did)
/// or, when that does not replay clear or there is none, its previous
/// push (which then ends where the short one did); left as it is when
/// neither replays clear or it is the particle's only push.
pub(super) fn merge_tiny(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    config: &PlanConfig,
) -> Vec<Step> {
    let mut k = 0;
    while k < steps.len() {
        match merged(&steps, k, layout, index, config) {
            Some(shorter) => steps = shorter,
            None => k += 1,
        }
    }
    steps
}

/// `steps` with push `k` merged away, when it is a short push and a merge
/// replays clear.
fn merged(
    steps: &[Step],
    k: usize,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    config: &PlanConfig,
) -> Option<Vec<Step>> {
    let (particle, from, to) = steps[k].push_move()?;
    if (to - from).norm() >= config.on_site_tolerance_m {
        return None;
    }
    let x = *index.get(&particle)?;
    let radius = layout.particles[x].radius_m;
    let own = |j: &usize| steps[*j].push_move().is_some_and(|(id, ..)| id == particle);
    let next = (k + 1..steps.len()).find(own);
    let previous = (0..k).rev().find(own);
    // The next push from the short one's start, or the previous to its end.
    let tries = [
        next.and_then(|j| {
            let (_, _, end) = steps[j].push_move()?;
            Some((j, from, end))
        }),
        previous.and_then(|j| {
            let (_, start, _) = steps[j].push_move()?;
            Some((j, start, to))
        }),
    ];
    tries.into_iter().flatten().find_map(|(j, start, end)| {
        if (end - start).norm() > max_push_len(radius, config) {
            return None;
        }
        let out = without_push(steps, k, j, push_step(particle, start, end, radius, config));
        clear_for(&out, layout, index, config, x).then_some(out)
    })
}

/// `steps` without step `k`, step `j` replaced by `push`.
fn without_push(steps: &[Step], k: usize, j: usize, push: Step) -> Vec<Step> {
    let mut out: Vec<Step> = steps.to_vec();
    out[j] = push;
    out.remove(k);
    out
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::*;
    use nalgebra::Vector2;

    /// `steps` after [`merge_tiny`] with the default config, checked to
    /// replay clear.
    fn merge(layout: &Layout, steps: Vec<Step>) -> Vec<Step> {
        let index = layout.index_by_id();
        let out = merge_tiny(steps, layout, &index, &PlanConfig::default());
        assert!(
            replays_clear(&out, layout),
            "the merged plan does not replay clear"
        );
        out
    }

    fn um(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    #[test]
    fn a_push_of_a_few_nanometres_joins_the_next_push() {
        let layout = Layout::of_test_centres_um(&[(20.0, 20.0), (80.0, 80.0)]);
        let steps = vec![
            push(0, (20.0, 20.0), (30.0, 20.0)),
            push(1, (80.0, 80.0), (80.0, 70.0)),
            push(0, (30.0, 20.0), (30.002, 20.001)),
            push(0, (30.002, 20.001), (30.0, 40.0)),
        ];
        let out = merge(&layout, steps);
        assert_eq!(out.len(), 3);
        let (particle, from, to) = push_at(&out, 2);
        assert_eq!(particle, 0);
        assert!((from - um(30.0, 20.0)).norm() < 1e-9, "{from:?}");
        assert!((to - um(30.0, 40.0)).norm() < 1e-9, "{to:?}");
    }

    #[test]
    fn a_last_short_push_joins_the_previous_one() {
        // The last 0.1 um to the site, as a cycle break leaves it.
        let layout = Layout::of_test_centres_um(&[(20.0, 20.0), (80.0, 80.0)]);
        let steps = vec![
            push(0, (20.0, 20.0), (39.9, 20.0)),
            push(1, (80.0, 80.0), (80.0, 70.0)),
            push(0, (39.9, 20.0), (40.0, 20.0)),
        ];
        let out = merge(&layout, steps);
        assert_eq!(out.len(), 2);
        let (particle, from, to) = push_at(&out, 0);
        assert_eq!(particle, 0);
        assert!((from - um(20.0, 20.0)).norm() < 1e-9);
        assert!((to - um(40.0, 20.0)).norm() < 1e-9);
    }

    #[test]
    fn a_push_whose_merge_would_not_keep_the_clearance_stays() {
        // Particle 1 passes 10.05 um below particle 0's start (within the
        // 0.1 um clearance of two 5 um discs) and 10.25 um below where the
        // short push leaves it: 0 must make that push first.
        let layout = Layout::of_test_centres_um(&[(40.0, 40.0), (15.0, 29.95)]);
        let steps = vec![
            push(0, (40.0, 40.0), (40.0, 40.2)),
            push(1, (15.0, 29.95), (65.0, 29.95)),
            push(0, (40.0, 40.2), (40.0, 60.0)),
        ];
        assert_eq!(merge(&layout, steps).len(), 3);
    }

    #[test]
    fn a_particles_only_push_stays_however_short() {
        let layout = Layout::of_test_centres_um(&[(20.0, 20.0), (80.0, 80.0)]);
        let lone = vec![push(0, (20.0, 20.0), (20.1, 20.0))];
        assert_eq!(merge(&layout, lone).len(), 1);
    }
}
