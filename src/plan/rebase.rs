//! Keeping a plan after a push: the steps still to come, moved onto where the
//! particles are now seen.
//!
//! A plan made from an earlier frame stays good while the particles are
//! close to where it expects them. Re-planning from every frame instead makes
//! the run depend on every mid-run state being plannable, and a crowded
//! mid-run state can refuse (a site walled in) although the plan in hand
//! still works. The executor keeps the remaining steps, shifts each
//! particle's first push to its seen centre, and replays the result with
//! [`super::verify`]; only when that fails does it plan afresh.

use super::layout::Layout;
use super::{Plan, Step};
use nalgebra::Vector2;
use std::collections::HashSet;

/// Why the remaining steps cannot be kept.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RebaseRefusal {
    /// No push is left.
    #[error("no push left")]
    Finished,
    /// A particle the plan pushes is not in the layout.
    #[error("particle {0} is not seen")]
    Unseen(u32),
    /// A particle is farther from where the plan expects it than allowed.
    #[error("particle {particle} is {off_um:.2} um from where the plan expects it")]
    Moved {
        /// Particle id.
        particle: u32,
        /// Distance, um.
        off_um: f64,
    },
}

/// The plan without its first push (and the travel leading to it): what is
/// left once that push has been made.
pub fn without_first_push(plan: &Plan) -> Plan {
    let mut rest = plan.clone();
    if let Some(k) = rest
        .steps
        .iter()
        .position(|s| matches!(s, Step::Push { .. }))
    {
        // Keep a coarse move before the push: later pushes need its window.
        let mut kept: Vec<Step> = rest.steps[..k]
            .iter()
            .filter(|s| matches!(s, Step::CoarseMove { .. }))
            .cloned()
            .collect();
        kept.extend_from_slice(&rest.steps[k + 1..]);
        rest.steps = kept;
    }
    rest
}

/// Moves each particle's first remaining push to start where `layout` sees it
/// (the approach keeps its distance behind the particle, on the new push
/// line); later pushes of that particle start where the plan put it. Refuses
/// if a pushed particle is missing or more than `max_shift_m` from where the
/// plan expected it, except `repushed`: the particle whose push just failed,
/// which is expected elsewhere and is pushed again from where it is.
pub fn rebase_plan(
    plan: &Plan,
    layout: &Layout,
    max_shift_m: f64,
    repushed: Option<u32>,
) -> Result<Plan, RebaseRefusal> {
    if !plan.steps.iter().any(|s| matches!(s, Step::Push { .. })) {
        return Err(RebaseRefusal::Finished);
    }
    let mut seen: HashSet<u32> = HashSet::new();
    let mut out = plan.clone();
    for step in &mut out.steps {
        let Step::Push {
            particle,
            from_m,
            to_m,
            approach_m,
            ..
        } = step
        else {
            continue;
        };
        if !seen.insert(*particle) {
            continue;
        }
        let now = layout
            .particles
            .iter()
            .find(|p| p.id == *particle)
            .ok_or(RebaseRefusal::Unseen(*particle))?
            .centre_m;
        let shift: Vector2<f64> = now - *from_m;
        if shift.norm() > max_shift_m && repushed != Some(*particle) {
            return Err(RebaseRefusal::Moved {
                particle: *particle,
                off_um: shift.norm() * 1e6,
            });
        }
        let behind = (*from_m - *approach_m).norm();
        let line = *to_m - now;
        let old_line = *from_m - *approach_m;
        let dir = if line.norm() > 1e-9 {
            line.normalize()
        } else if old_line.norm() > 0.0 {
            old_line.normalize()
        } else {
            Vector2::new(1.0, 0.0)
        };
        *from_m = now;
        *approach_m = now - dir * behind;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::layout::Particle;
    use crate::plan::pattern::Site;
    use crate::plan::{PlanConfig, plan_assembly, verify_plan};

    fn layout(points: &[(u32, f64, f64)]) -> Layout {
        Layout {
            field_m: [100e-6, 100e-6],
            particles: points
                .iter()
                .map(|&(id, x, y)| Particle {
                    id,
                    centre_m: Vector2::new(x * 1e-6, y * 1e-6),
                    radius_m: 5e-6,
                })
                .collect(),
        }
    }

    fn sites(points: &[(f64, f64)]) -> Vec<Site> {
        points
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| Site {
                id: i as u32,
                centre_m: Vector2::new(x * 1e-6, y * 1e-6),
            })
            .collect()
    }

    fn two_push_plan() -> (Layout, Plan, PlanConfig) {
        let start = layout(&[(0, 20.0, 20.0), (1, 20.0, 70.0)]);
        let config = PlanConfig::default();
        let plan = plan_assembly(&start, &sites(&[(60.0, 40.0), (71.0, 40.0)]), &config).unwrap();
        assert_eq!(plan.summary.pushes, 2, "{:?}", plan.steps);
        (start, plan, config)
    }

    /// The plan's first push step.
    fn first_push(plan: &Plan) -> Step {
        plan.steps
            .iter()
            .find(|s| matches!(s, Step::Push { .. }))
            .cloned()
            .expect("a push")
    }

    /// The layout after the plan's first push, as the camera would see it:
    /// the pushed particle `miss_um` short of its target.
    fn after_first_push(start: &Layout, plan: &Plan, miss_um: f64) -> Layout {
        let (particle, from_m, to_m) = first_push(plan).push_move().unwrap();
        let dir = (to_m - from_m).normalize();
        let mut now = start.clone();
        for p in &mut now.particles {
            if p.id == particle {
                p.centre_m = to_m - dir * miss_um * 1e-6;
            }
        }
        now
    }

    #[test]
    fn remaining_steps_after_a_clean_push_verify_on_the_new_layout() {
        let (start, plan, config) = two_push_plan();
        let now = after_first_push(&start, &plan, 0.05);
        let rest = rebase_plan(&without_first_push(&plan), &now, 0.5e-6, None).unwrap();
        assert_eq!(
            rest.steps
                .iter()
                .filter(|s| matches!(s, Step::Push { .. }))
                .count(),
            1
        );
        assert!(verify_plan(&rest, &now, &config).ok);
    }

    #[test]
    fn a_push_that_fell_short_leaves_a_plan_that_does_not_verify() {
        let (start, plan, config) = two_push_plan();
        // 3 um short: the site is unfilled and the remaining plan does not push it again.
        let now = after_first_push(&start, &plan, 3.0);
        let rest = rebase_plan(&without_first_push(&plan), &now, 0.5e-6, None).unwrap();
        let report = verify_plan(&rest, &now, &config);
        assert!(!report.ok);
        assert_eq!(report.unfilled_sites.len(), 1);
    }

    #[test]
    fn a_particle_moved_beyond_the_limit_is_refused_and_one_within_it_is_followed() {
        let (start, plan, _) = two_push_plan();
        let Step::Push {
            particle,
            from_m,
            approach_m,
            ..
        } = first_push(&plan)
        else {
            unreachable!()
        };
        let mut nudged = start.clone();
        for p in &mut nudged.particles {
            if p.id == particle {
                p.centre_m.x += 0.3e-6;
            }
        }
        assert!(matches!(
            rebase_plan(&plan, &nudged, 0.2e-6, None),
            Err(RebaseRefusal::Moved { particle: q, .. }) if q == particle
        ));
        let moved = rebase_plan(&plan, &nudged, 0.5e-6, None).unwrap();
        let Step::Push {
            from_m: f2,
            approach_m: a2,
            ..
        } = first_push(&moved)
        else {
            unreachable!()
        };
        assert!(((f2 - from_m).x - 0.3e-6).abs() < 1e-12);
        // The tip lands as far behind the particle as before.
        assert!(((f2 - a2).norm() - (from_m - approach_m).norm()).abs() < 1e-12);
    }

    #[test]
    fn a_push_that_fell_short_is_pushed_again_from_where_the_particle_stopped() {
        let (start, plan, config) = two_push_plan();
        let now = after_first_push(&start, &plan, 3.0);
        let Step::Push { particle, to_m, .. } = first_push(&plan) else {
            unreachable!()
        };
        assert!(matches!(
            rebase_plan(&plan, &now, 0.5e-6, None),
            Err(RebaseRefusal::Moved { .. })
        ));
        let again = rebase_plan(&plan, &now, 0.5e-6, Some(particle)).unwrap();
        let Step::Push {
            from_m, approach_m, ..
        } = first_push(&again)
        else {
            unreachable!()
        };
        assert!(
            (from_m
                - now
                    .particles
                    .iter()
                    .find(|p| p.id == particle)
                    .unwrap()
                    .centre_m)
                .norm()
                < 1e-12
        );
        // The approach stays behind the particle on the line to the target.
        let along = (from_m - approach_m)
            .normalize()
            .dot(&(to_m - from_m).normalize());
        assert!((along - 1.0).abs() < 1e-9, "{along}");
        assert!(verify_plan(&again, &now, &config).ok);
    }

    #[test]
    fn an_unseen_particle_and_an_empty_plan_are_refused() {
        let (start, plan, _) = two_push_plan();
        let ids: Vec<u32> = plan
            .steps
            .iter()
            .filter_map(|s| match s {
                Step::Push { particle, .. } => Some(*particle),
                _ => None,
            })
            .collect();
        let mut fewer = start.clone();
        fewer.particles.retain(|p| p.id != ids[0]);
        assert_eq!(
            rebase_plan(&plan, &fewer, 1e-6, None),
            Err(RebaseRefusal::Unseen(ids[0]))
        );
        let done = without_first_push(&without_first_push(&plan));
        assert_eq!(
            rebase_plan(&done, &start, 1e-6, None),
            Err(RebaseRefusal::Finished)
        );
    }
}
