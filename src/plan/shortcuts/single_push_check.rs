//! Whether one push of a particle, in place of all its own, keeps the
//! clearance: the test several passes try their candidate ends with.

use super::MIN_SAVING_M;
use super::{SweptPush, corridor_hits};
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;

/// What a particle's one push, put where step `at` is in place of all its
/// own pushes, must keep clear of: the other particles where they are at
/// `at`, and their later pushes' corridors (it then lies at its end for
/// good). When its earlier pushes are dropped, it also stays at its start
/// until `at`: the other particles' pushes before `at` must miss it there.
pub(super) struct SinglePushCheck<'a> {
    from: Vector2<f64>,
    pub(super) radius: f64,
    /// The pushes before `at` miss the particle at its start.
    clear_before: bool,
    /// Centres and radii of the other particles at the push.
    others: Vec<(Vector2<f64>, f64)>,
    /// The other particles' later pushes: start, end, radius.
    later: Vec<SweptPush<'a>>,
    config: &'a PlanConfig,
}

impl<'a> SinglePushCheck<'a> {
    /// For particle `particle` (index in `layout`) leaving `from` where
    /// step `at` is; `unchanged_before`: its pushes before `at` stay, so
    /// nothing before `at` changes.
    pub(super) fn new(
        steps: &[Step],
        (particle, from): (usize, Vector2<f64>),
        at: usize,
        unchanged_before: bool,
        layout: &Layout,
        index: &FxHashMap<u32, usize>,
        config: &'a PlanConfig,
    ) -> Self {
        let radius_of = |i: usize| layout.particles[i].radius_m;
        let radius = radius_of(particle);
        let others_push = |step: &Step| {
            let (id, from_m, to_m) = step.push_move()?;
            let i = *index.get(&id).filter(|&&i| i != particle)?;
            Some((from_m, to_m, radius_of(i), i))
        };
        let mut pos: Vec<Vector2<f64>> = layout.particles.iter().map(|p| p.centre_m).collect();
        let mut clear_before = true;
        for (a, b, r, i) in steps[..at].iter().filter_map(others_push) {
            clear_before = clear_before
                && (unchanged_before || !corridor_hits((a, b, r), from, radius, config));
            pos[i] = b;
        }
        SinglePushCheck {
            from,
            radius,
            clear_before,
            others: (0..pos.len())
                .filter(|&i| i != particle)
                .map(|i| (pos[i], radius_of(i)))
                .collect(),
            later: steps[at..]
                .iter()
                .filter_map(others_push)
                .map(|(a, b, r, _)| SweptPush::new((a, b, r), config))
                .collect(),
            config,
        }
    }

    /// True when a later push of another particle sweeps over `end`.
    pub(super) fn swept_later(&self, end: Vector2<f64>) -> bool {
        self.later.iter().any(|push| push.hits(end, self.radius))
    }

    /// True when pushing the particle to `end` (not at all, at its start)
    /// keeps the clearance from every particle at every push.
    pub(super) fn allows(&self, end: Vector2<f64>) -> bool {
        if !self.clear_before || self.swept_later(end) {
            return false;
        }
        let own = SweptPush::new((self.from, end, self.radius), self.config);
        (end - self.from).norm() < MIN_SAVING_M || self.others.iter().all(|&(c, r)| !own.hits(c, r))
    }
}
