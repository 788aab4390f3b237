//! Independent geometric replay of a plan.
//!
//! Shares no collision code with the planner: closed-form point-to-segment
//! distances over every particle (brute force), from the plan's own numbers.
//! Reports collisions (a swept particle or tip disc overlapping another
//! particle), pushes that do not start where the particle is, final position
//! errors, unfilled sites, unreachable moves (beyond the nanostage window)
//! and pushes of particles that must not move.

use super::layout::{Layout, may_lie_in_field};
use super::plan_file::PlanGeometry;
use super::{Plan, Step};
use nalgebra::Vector2;
use serde::Serialize;
use std::collections::HashMap;

/// Overlap tolerated before a contact counts as a collision (rounding in files).
pub const COLLISION_TOLERANCE_M: f64 = 1e-9;
/// A push must start within this distance of where the particle is: a
/// file's positions rounded to 0.01 um (1 nm had made 30 pushes of a plan
/// so rounded "start away").
pub const START_TOLERANCE_M: f64 = 1e-8;
/// A push's approach point must lie within this distance of where the tip
/// touches the particle's back on the push line (another tool's rounding),
/// plus what rounding its ends by [`START_TOLERANCE_M`] turns the push line
/// by at that distance: a 0.1 um push rounded to 1 nm had moved its
/// approach point 33 nm.
pub const APPROACH_TOLERANCE_M: f64 = 1e-8;

/// One collision found by the replay.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Collision {
    /// Step index in the plan.
    pub step: usize,
    /// Pushed particle id.
    pub particle: u32,
    /// Particle hit.
    pub other: u32,
    /// "particle" or "tip": which swept disc hit.
    pub by: &'static str,
    /// Overlap depth, um.
    pub depth_um: f64,
}

impl Collision {
    /// "the tip pushing particle 3 hits particle 7 by 0.43 um" (or "particle
    /// 3, pushed, hits ...": "particle 3 particle hits" had read as a typo).
    pub fn describe(&self) -> String {
        let who = match self.by {
            "tip" => format!("the tip pushing particle {}", self.particle),
            _ => format!("particle {}, pushed,", self.particle),
        };
        format!(
            "{who} hits particle {} by {:.3} um",
            self.other, self.depth_um
        )
    }
}

/// What the replay found.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct VerifyReport {
    /// Schema tag.
    pub schema: &'static str,
    /// The tip, standoff and stage range replayed with.
    pub geometry: PlanGeometry,
    /// Push steps replayed.
    pub pushes: usize,
    /// Collisions.
    pub collisions: Vec<Collision>,
    /// Push steps that start away from their particle.
    pub bad_starts: Vec<usize>,
    /// Particles a push or the assignment names that the layout does not
    /// have (their pushes are not replayed; their sites stay unfilled).
    pub unknown_particles: Vec<u32>,
    /// Push steps whose approach point is not where the tip touches the
    /// particle's back on the push line, or up to the standoff behind (a
    /// tip landing beside the particle, or in front of it, pushes nothing
    /// or the wrong way; one wider than the plan's lands on it).
    pub bad_approaches: Vec<usize>,
    /// Push steps whose tip path leaves the current nanostage window: the
    /// window of the last coarse move, or before any, the one window all
    /// the pushes so far share (a plan with its coarse moves left out had
    /// replayed as ok with pushes 280 um apart).
    pub unreachable: Vec<usize>,
    /// Push steps that leave their particle's centre farther beyond the
    /// field than a layout may hold one, two radii (another tool's plan had
    /// pushed one 90 um off it and replayed ok; the planner parks a
    /// particle it does not need partly over the edge).
    pub left_field: Vec<usize>,
    /// Push steps that move a particle the plan must leave where it is (a
    /// frame's edge cut it, so its centre is a guess, or the executor gave
    /// up on it).
    pub moved_immovable: Vec<usize>,
    /// Sites with no particle on them at the end (within tolerance).
    pub unfilled_sites: Vec<u32>,
    /// Unfilled sites another particle than the one assigned lies on at the
    /// end, as (site, particle): the assignment pairs them otherwise (a plan
    /// with swapped labels had read only as two sites left unfilled).
    pub held_by_others: Vec<(u32, u32)>,
    /// Largest distance between an assigned particle and its site at the end, um.
    pub max_final_error_um: f64,
    /// Least free space at the end between a particle the plan assigns no
    /// site and a site's particle (its assigned one, or the layout's
    /// largest), um; None when every particle has a site. Not a fault: a
    /// figure of how clearly the pattern stands out (a stray 0.5 um beside
    /// a letter reads as part of it; the planner keeps
    /// [`PlanConfig::keep_clear_m`](super::PlanConfig::keep_clear_m) where it moves one).
    pub nearest_stray_gap_um: Option<f64>,
    /// True when nothing above is wrong.
    pub ok: bool,
}

impl VerifyReport {
    /// The first step something is wrong at, when every fault is a step's (a
    /// collision, a start away from the particle, a bad approach, a push out
    /// of reach or of the field, or of a particle to leave alone) and the
    /// plan otherwise ends whole (every site filled, every particle known):
    /// the steps before it replay clean. None when the plan is ok or a fault
    /// is the whole plan's.
    pub fn first_faulty_step(&self) -> Option<usize> {
        if self.ok || !self.unknown_particles.is_empty() || !self.unfilled_sites.is_empty() {
            return None;
        }
        self.collisions
            .iter()
            .map(|c| c.step)
            .chain(self.bad_starts.iter().copied())
            .chain(self.bad_approaches.iter().copied())
            .chain(self.unreachable.iter().copied())
            .chain(self.left_field.iter().copied())
            .chain(self.moved_immovable.iter().copied())
            .min()
    }

    /// One line on what is wrong (or "ok").
    pub fn summary(&self) -> String {
        if self.ok {
            return "ok".to_owned();
        }
        let mut parts = Vec::new();
        if let Some(c) = self.collisions.first() {
            parts.push(format!(
                "{} (first: step {}, {})",
                crate::wording::counted(self.collisions.len(), "collision"),
                c.step,
                c.describe()
            ));
        }
        if let Some(first) = self.bad_starts.first() {
            parts.push(format!(
                "{} start away from their particle (first: step {first})",
                crate::wording::counted(self.bad_starts.len(), "push")
            ));
        }
        if !self.unknown_particles.is_empty() {
            parts.push(format!(
                "the plan names particles {:?} the layout does not have",
                self.unknown_particles
            ));
        }
        if let Some(first) = self.bad_approaches.first() {
            parts.push(format!(
                "{} approach away from their particle's back (first: step {first})",
                crate::wording::counted(self.bad_approaches.len(), "push")
            ));
        }
        if let Some(first) = self.unreachable.first() {
            parts.push(format!(
                "{} leave the nanostage window, no coarse move bringing them into it (first: step {first})",
                crate::wording::counted(self.unreachable.len(), "push")
            ));
        }
        if let Some(first) = self.left_field.first() {
            parts.push(format!(
                "{} leave their particle more than two radii beyond the field (first: step {first})",
                crate::wording::counted(self.left_field.len(), "push")
            ));
        }
        if let Some(first) = self.moved_immovable.first() {
            parts.push(format!(
                "{} move a particle that must not move (first: step {first})",
                crate::wording::counted(self.moved_immovable.len(), "push")
            ));
        }
        if !self.unfilled_sites.is_empty() {
            let held: Vec<String> = (self.held_by_others.iter())
                .map(|(site, particle)| format!("site {site} has particle {particle} on it"))
                .collect();
            parts.push(format!(
                "sites {:?} left unfilled{}",
                self.unfilled_sites,
                if held.is_empty() {
                    String::new()
                } else {
                    format!(
                        " ({}, which the assignment pairs otherwise)",
                        held.join(", ")
                    )
                }
            ));
        }
        parts.join("; ")
    }
}

/// Distance from `p` to the segment a-b. `pushes::segment_distance` again,
/// on purpose: the replay shares no code with the planner's checks, so that
/// a bug there cannot hide here.
fn seg_dist(p: Vector2<f64>, a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).norm()
}

/// Where the nanostage can reach: around the last coarse move's centre, or
/// before any, wherever the user put the stage, which need only hold the
/// pushes so far (the box they span).
enum Window {
    Unplaced(Option<(Vector2<f64>, Vector2<f64>)>),
    Centred(Vector2<f64>),
}

impl Window {
    /// True when a window of `range` holds `points` (and, unplaced, the
    /// pushes before: then it grows to take them).
    fn reaches(&mut self, points: &[Vector2<f64>], range: f64) -> bool {
        let slack = range + 1e-12;
        match self {
            Window::Centred(c) => points
                .iter()
                .all(|p| 2.0 * (p.x - c.x).abs() <= slack && 2.0 * (p.y - c.y).abs() <= slack),
            Window::Unplaced(span) => {
                let (mut lo, mut hi) = span.unwrap_or((points[0], points[0]));
                for p in points {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                let fits = hi.x - lo.x <= slack && hi.y - lo.y <= slack;
                if fits {
                    *span = Some((lo, hi));
                }
                fits
            }
        }
    }
}

/// Replays `plan` on `layout`, whose particles in `immovable` must not be
/// pushed; `final_tolerance_m` is the allowed final error.
pub fn verify_plan_with(
    plan: &Plan,
    layout: &Layout,
    immovable: &[u32],
    geometry: &PlanGeometry,
    final_tolerance_m: f64,
) -> VerifyReport {
    let tip_r = geometry.tip_radius_um * 1e-6;
    let standoff = geometry.standoff_um * 1e-6;
    let range = geometry.nanostage_range_um * 1e-6;
    let mut pos: Vec<Vector2<f64>> = layout.particles.iter().map(|p| p.centre_m).collect();
    let index = layout.index_by_id();
    let mut rep = VerifyReport {
        schema: "nanopush.verify/1",
        geometry: *geometry,
        ..Default::default()
    };
    let mut window = Window::Unplaced(None);
    for (k, step) in plan.steps.iter().enumerate() {
        match *step {
            Step::CoarseMove { centre_m } => window = Window::Centred(centre_m),
            Step::TipTravel { .. } => {}
            Step::Push {
                particle,
                from_m,
                to_m,
                approach_m,
                ..
            } => {
                rep.pushes += 1;
                let Some(&i) = index.get(&particle) else {
                    rep.unknown_particles.push(particle);
                    continue;
                };
                if (pos[i] - from_m).norm() > START_TOLERANCE_M {
                    rep.bad_starts.push(k);
                }
                if immovable.contains(&particle) {
                    rep.moved_immovable.push(k);
                }
                let r = layout.particles[i].radius_m;
                let len = (to_m - from_m).norm();
                let dir = if len > 0.0 {
                    (to_m - from_m) / len
                } else {
                    Vector2::new(1.0, 0.0)
                };
                // The tip touches the particle's back: its disc and the
                // particle's, centres R + r_tip apart, behind on the push
                // line. It may end its approach up to the standoff farther
                // back (a plan for a wider tip, replayed with a narrower
                // one: it touches a little later), never nearer (a wider
                // tip would land on the particle).
                let back = from_m - approach_m;
                let along = back.dot(&dir);
                let beside = (back - dir * along).norm();
                let turned = (r + tip_r) * 2.0 * START_TOLERANCE_M / len.max(START_TOLERANCE_M);
                let slack = APPROACH_TOLERANCE_M + turned;
                let touch = r + tip_r;
                if beside > slack || along < touch - slack || along > touch + standoff + slack {
                    rep.bad_approaches.push(k);
                }
                let land = approach_m - dir * standoff;
                let tip_end = approach_m + (to_m - from_m);
                if !window.reaches(&[land, tip_end], range) {
                    rep.unreachable.push(k);
                }
                if !may_lie_in_field(layout.field_m, to_m, r) {
                    rep.left_field.push(k);
                }
                for (j, q) in pos.iter().enumerate() {
                    if j == i {
                        continue;
                    }
                    let rq = layout.particles[j].radius_m;
                    let dp = r + rq - seg_dist(*q, from_m, to_m);
                    let dt = tip_r + rq - seg_dist(*q, land, tip_end);
                    for (depth, by) in [(dp, "particle"), (dt, "tip")] {
                        if depth > COLLISION_TOLERANCE_M {
                            rep.collisions.push(Collision {
                                step: k,
                                particle,
                                other: layout.particles[j].id,
                                by,
                                depth_um: depth * 1e6,
                            });
                        }
                    }
                }
                pos[i] = to_m;
            }
        }
    }
    let sites: HashMap<u32, Vector2<f64>> = plan.sites.iter().map(|s| (s.id, s.centre_m)).collect();
    let mut filled = std::collections::HashSet::new();
    for &(p, s) in &plan.assignment {
        if !index.contains_key(&p) {
            rep.unknown_particles.push(p);
        }
        if let (Some(&i), Some(&c)) = (index.get(&p), sites.get(&s)) {
            let e = (pos[i] - c).norm();
            rep.max_final_error_um = rep.max_final_error_um.max(e * 1e6);
            if e <= final_tolerance_m {
                filled.insert(s);
            }
        }
    }
    rep.unfilled_sites = plan
        .sites
        .iter()
        .map(|s| s.id)
        .filter(|id| !filled.contains(id))
        .collect();
    rep.unknown_particles.sort_unstable();
    rep.unknown_particles.dedup();
    let assigned: HashMap<u32, u32> = plan.assignment.iter().map(|&(p, s)| (s, p)).collect();
    for &site in &rep.unfilled_sites {
        let c = sites[&site];
        let on_it = (layout.particles.iter().zip(&pos)).find(|(p, q)| {
            (*q - c).norm() <= final_tolerance_m && assigned.get(&site) != Some(&p.id)
        });
        if let Some((p, _)) = on_it {
            rep.held_by_others.push((site, p.id));
        }
    }
    rep.nearest_stray_gap_um = nearest_stray_gap_m(plan, layout, &pos, &index).map(|g| g * 1e6);
    rep.ok = rep.collisions.is_empty()
        && rep.bad_starts.is_empty()
        && rep.unknown_particles.is_empty()
        && rep.bad_approaches.is_empty()
        && rep.unreachable.is_empty()
        && rep.left_field.is_empty()
        && rep.moved_immovable.is_empty()
        && rep.unfilled_sites.is_empty();
    rep
}

/// Whether `plan`, replayed as `report` says, fails only after its first
/// push, which replays clean ([`VerifyReport::first_faulty_step`]).
fn fails_only_after_its_first_push(plan: &Plan, report: &VerifyReport) -> bool {
    let first_push = plan
        .steps
        .iter()
        .position(|step| matches!(step, Step::Push { .. }));
    let first_fault = report.first_faulty_step();
    matches!((first_push, first_fault), (Some(push), Some(fault)) if push < fault)
}

/// A plan in hand that no longer verifies, when the loop (and the
/// dry-run) may push on with it for want of a fresh plan: its first push
/// clear and only a later one failing ([`VerifyReport::first_faulty_step`]),
/// at its own standoff or at the nearest one that still covers where the
/// push lowers the tip (`lowered_m` behind the particle, within the tip
/// disc; at least `min_standoff_m`). 10 um spheres' plans check 2 um where
/// the loop lowers the tip 0.5 um behind, and a plan in hand failing only
/// at a landing 0.09 um on a neighbour at 1 um of standoff had stopped a
/// dense core's run (adversarial seed 6, CMU: stopped at 22 of 31, now
/// done).
pub fn pushable_later(
    plan: Plan,
    layout: &Layout,
    config: &super::PlanConfig,
    lowered_m: f64,
) -> Option<Plan> {
    // One replay a standoff.
    let pushable = |p: &Plan| {
        let report = verify_plan(p, layout, config);
        report.ok || fails_only_after_its_first_push(p, &report)
    };
    if pushable(&plan) {
        return Some(plan);
    }
    let nearest_m = (lowered_m - config.tip_radius_m).max(config.min_standoff_m);
    if plan.standoff_m <= nearest_m {
        return None;
    }
    let nearer = Plan {
        standoff_m: nearest_m,
        ..plan
    };
    pushable(&nearer).then_some(nearer)
}

/// Least free space between a particle on no site (final positions `pos`)
/// and a site's particle: see [`VerifyReport::nearest_stray_gap_um`].
fn nearest_stray_gap_m(
    plan: &Plan,
    layout: &Layout,
    pos: &[Vector2<f64>],
    index: &rustc_hash::FxHashMap<u32, usize>,
) -> Option<f64> {
    let site_radius: HashMap<u32, f64> = (plan.assignment.iter())
        .filter_map(|&(p, s)| Some((s, layout.particles[*index.get(&p)?].radius_m)))
        .collect();
    let assigned: std::collections::HashSet<u32> =
        plan.assignment.iter().map(|&(p, _)| p).collect();
    let largest = layout.max_radius_m();
    let pattern: Vec<(Vector2<f64>, f64)> = (plan.sites.iter())
        .map(|s| {
            (
                s.centre_m,
                site_radius.get(&s.id).copied().unwrap_or(largest),
            )
        })
        .collect();
    let strays = (layout.particles.iter().zip(pos))
        .filter(|(p, _)| !assigned.contains(&p.id))
        .map(|(p, at)| (*at, p.radius_m));
    super::stray_gap::least_gap_m(strays, &pattern)
}

/// Replays a plan made with `config` (the executor's entry point), its tip
/// landing where the plan says (`Plan::standoff_m`), its `immovable`
/// particles held.
pub fn verify_plan(plan: &Plan, layout: &Layout, config: &super::PlanConfig) -> VerifyReport {
    verify_plan_with(
        plan,
        layout,
        &config.immovable,
        &super::plan_file::geometry_of(plan, config),
        config.on_site_tolerance_m.max(1e-9),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Particle, PlanConfig, Site, plan_assembly};

    /// The plan (and its config) that pushes `layout`'s particle at
    /// (30, 50) um to a site at (60, 50) um; it verifies as planned.
    fn plan_to_one_site(layout: &Layout) -> (Plan, PlanConfig) {
        let sites = [Site {
            id: 0,
            centre_m: Vector2::new(60e-6, 50e-6),
        }];
        let config = PlanConfig::default();
        let plan = plan_assembly(layout, &sites, &config).unwrap();
        assert!(verify_plan(&plan, layout, &config).ok);
        (plan, config)
    }

    /// A plan in hand whose first push lands the tip on a particle at its
    /// own 1 um standoff is pushed on with at the nearest standoff that
    /// covers where the loop lowers the tip (0.5 um behind: the 0.25 um
    /// least), which clears it; not when the tip is lowered farther back.
    #[test]
    fn a_plan_failing_only_at_its_landing_is_pushed_on_with_a_nearer_one() {
        let (plan, config) = plan_to_one_site(&Layout::of_test_centres_um(&[(30.0, 50.0)]));
        assert_eq!(plan.standoff_m, config.standoff_m);
        // Its edge at 22.4 um: 0.4 um into the tip's disc landed 1 um
        // behind the contact point (22-24 um), 0.35 um clear of it landed
        // 0.25 um behind.
        let behind = Layout::of_test_centres_um(&[(30.0, 50.0), (17.4, 50.0)]);
        assert!(!verify_plan(&plan, &behind, &config).ok);
        let nearer = pushable_later(plan.clone(), &behind, &config, 0.5e-6).unwrap();
        assert_eq!(nearer.standoff_m, config.min_standoff_m);
        assert!(verify_plan(&nearer, &behind, &config).ok);
        assert!(pushable_later(plan, &behind, &config, 2.5e-6).is_none());
    }

    /// A plan that collides only at a later step says which step (the
    /// steps before replay clean); one that leaves a site unfilled is
    /// wrong as a whole and names none.
    #[test]
    fn the_first_faulty_step_is_named_only_when_the_rest_is_whole() {
        let start = [(20.0, 50.0), (20.0, 150.0)];
        let planned_on = Layout::of_test_centres_um(&start);
        let sites = [(0, 60.0, 50.0), (1, 60.0, 150.0)].map(|(id, x, y)| Site {
            id,
            centre_m: Vector2::new(x, y) * 1e-6,
        });
        let config = PlanConfig::default();
        let plan = plan_assembly(&planned_on, &sites, &config).unwrap();
        let report = verify_plan(&plan, &planned_on, &config);
        assert!(report.ok && report.first_faulty_step().is_none());
        let pushes_of = |id: u32| -> Vec<usize> {
            (plan.steps.iter().enumerate())
                .filter(|(_, s)| matches!(s, Step::Push { particle, .. } if *particle == id))
                .map(|(k, _)| k)
                .collect()
        };
        // A third particle on particle 1's way, none on particle 0's.
        let blocked = Layout::of_test_centres_um(&[start[0], start[1], (40.0, 150.0)]);
        let report = verify_plan(&plan, &blocked, &config);
        assert!(!report.ok);
        assert_eq!(report.first_faulty_step(), pushes_of(1).first().copied());
        assert!(
            pushes_of(0)
                .iter()
                .all(|&k| k < report.first_faulty_step().unwrap())
        );
        // Without particle 0's pushes site 0 stays empty: though particle
        // 1's still collide, no step is named.
        let mut partial = plan.clone();
        partial
            .steps
            .retain(|s| !matches!(s, Step::Push { particle: 0, .. }));
        let report = verify_plan(&partial, &blocked, &config);
        assert!(!report.collisions.is_empty(), "{report:?}");
        assert_eq!(report.unfilled_sites, vec![0]);
        assert_eq!(report.first_faulty_step(), None);
    }

    /// A push of a particle the plan must not move (a frame's edge cut
    /// it) is reported, by step: such plans replayed as ok, though the
    /// particle's centre was never measured.
    #[test]
    fn a_push_of_an_immovable_particle_is_reported() {
        let layout = Layout::of_test_centres_um(&[(30.0, 50.0), (30.0, 150.0)]);
        let (plan, config) = plan_to_one_site(&layout);
        let pushes: Vec<usize> = (plan.steps.iter().enumerate())
            .filter(|(_, s)| matches!(s, Step::Push { particle: 0, .. }))
            .map(|(k, _)| k)
            .collect();
        assert!(!pushes.is_empty());
        let held = PlanConfig {
            immovable: vec![0],
            ..config.clone()
        };
        let report = verify_plan(&plan, &layout, &held);
        assert_eq!(report.moved_immovable, pushes);
        assert!(!report.ok, "{report:?}");
        assert!(
            report
                .summary()
                .contains("move a particle that must not move"),
            "{}",
            report.summary()
        );
        // Holding the particle it does not push changes nothing.
        let other = PlanConfig {
            immovable: vec![1],
            ..config
        };
        assert!(verify_plan(&plan, &layout, &other).ok);
    }

    /// Pushes no one nanostage window holds need the planner's coarse
    /// moves: a plan with them verifies, the same plan without them is
    /// reported by step (it had replayed as ok with pushes 280 um apart),
    /// and so is it with a window too small for its one push.
    #[test]
    fn pushes_beyond_one_window_without_a_coarse_move_are_unreachable() {
        let layout = Layout {
            field_m: [300e-6, 300e-6],
            ..Layout::of_test_centres_um(&[(20.0, 20.0), (280.0, 280.0)])
        };
        let sites = [(0, 20.0, 40.0), (1, 280.0, 260.0)].map(|(id, x, y)| Site {
            id,
            centre_m: Vector2::new(x, y) * 1e-6,
        });
        let config = PlanConfig::default();
        let plan = plan_assembly(&layout, &sites, &config).unwrap();
        assert!(plan.summary.coarse_moves > 0);
        assert!(verify_plan(&plan, &layout, &config).ok);
        let mut bare = plan.clone();
        bare.steps.retain(|s| !matches!(s, Step::CoarseMove { .. }));
        let report = verify_plan(&bare, &layout, &config);
        let second_push = (bare.steps.iter().enumerate())
            .filter(|(_, s)| matches!(s, Step::Push { .. }))
            .map(|(k, _)| k)
            .nth(1)
            .unwrap();
        assert_eq!(report.unreachable, [second_push]);
        assert!(
            report.summary().contains("no coarse move"),
            "{}",
            report.summary()
        );
        // In a 10 um window, not even one 20 um push (with its approach).
        let narrow = PlanGeometry {
            nanostage_range_um: 10.0,
            ..super::super::plan_file::geometry_of(&plan, &config)
        };
        let report = verify_plan_with(&bare, &layout, &[], &narrow, 1e-9);
        assert_eq!(report.unreachable.len(), 2);
    }

    /// A push whose approach point is not at the particle's back (beside
    /// it, or in front) is reported: such plans replayed as ok, though the
    /// tip would push nothing, or push the particle the other way.
    #[test]
    fn a_push_approached_from_beside_or_in_front_is_reported() {
        let layout = Layout {
            field_m: [100e-6, 100e-6],
            particles: vec![Particle {
                id: 7,
                centre_m: Vector2::new(30e-6, 50e-6),
                radius_m: 5e-6,
            }],
        };
        let (plan, config) = plan_to_one_site(&layout);
        let k = plan
            .steps
            .iter()
            .position(|s| matches!(s, Step::Push { .. }))
            .unwrap();
        for shift in [
            Vector2::new(0.0, 40e-6),
            Vector2::new(2.0 * (5e-6 + 1e-6), 0.0),
        ] {
            let mut moved = plan.clone();
            if let Step::Push { approach_m, .. } = &mut moved.steps[k] {
                *approach_m += shift;
            }
            let report = verify_plan(&moved, &layout, &config);
            assert_eq!(report.bad_approaches, [k], "{shift:?}");
            assert!(!report.ok && report.summary().contains("approach"));
        }
    }

    /// A push that leaves its particle outside the field is reported by
    /// step: another tool's plan pushing one 90 um off the field had
    /// replayed as ok. A push of a particle the layout does not have is
    /// named as such.
    #[test]
    fn a_push_off_the_field_or_of_no_particle_is_reported() {
        let layout = Layout {
            field_m: [100e-6, 100e-6],
            ..Layout::of_test_centres_um(&[(30.0, 50.0)])
        };
        let (plan, config) = plan_to_one_site(&layout);
        assert!(verify_plan(&plan, &layout, &config).left_field.is_empty());
        let k = plan
            .steps
            .iter()
            .position(|s| matches!(s, Step::Push { .. }))
            .unwrap();
        let mut off = plan.clone();
        if let Step::Push { to_m, .. } = &mut off.steps[k] {
            *to_m = Vector2::new(-60e-6, 50e-6);
        }
        let report = verify_plan(&off, &layout, &config);
        assert_eq!(report.left_field, [k]);
        assert!(
            report.summary().contains("beyond the field"),
            "{}",
            report.summary()
        );
        let mut nobody = plan.clone();
        if let Step::Push { particle, .. } = &mut nobody.steps[k] {
            *particle = 999;
        }
        let report = verify_plan(&nobody, &layout, &config);
        assert_eq!(report.unknown_particles, [999]);
        assert!(report.bad_starts.is_empty());
        assert!(
            report
                .summary()
                .contains("the plan names particles [999] the layout does not have"),
            "{}",
            report.summary()
        );
    }

    /// A plan whose particles end on each other's sites (its assignment's
    /// labels swapped) says which particle lies on each unfilled site; one
    /// rounded to 0.01 um (another tool's file) still verifies.
    #[test]
    fn swapped_labels_and_rounded_numbers_are_told_apart() {
        let layout = Layout::of_test_centres_um(&[(30.123456, 50.004321), (30.0, 150.0)]);
        let sites = [(0, 60.0, 50.0), (1, 60.0, 150.0)].map(|(id, x, y)| Site {
            id,
            centre_m: Vector2::new(x, y) * 1e-6,
        });
        let config = PlanConfig::default();
        let plan = plan_assembly(&layout, &sites, &config).unwrap();
        assert!(verify_plan(&plan, &layout, &config).ok);
        let mut swapped = plan.clone();
        for pair in &mut swapped.assignment {
            pair.1 = 1 - pair.1;
        }
        let report = verify_plan(&swapped, &layout, &config);
        assert_eq!(report.unfilled_sites, [0, 1]);
        assert_eq!(report.held_by_others, [(0, 0), (1, 1)]);
        assert!(
            report.summary().contains("site 0 has particle 0 on it"),
            "{}",
            report.summary()
        );
        let mut rounded = plan.clone();
        let round = |v: &mut Vector2<f64>| *v = v.map(|c| (c * 1e8).round() / 1e8);
        for step in &mut rounded.steps {
            if let Step::Push {
                from_m,
                to_m,
                approach_m,
                ..
            } = step
            {
                round(from_m);
                round(to_m);
                round(approach_m);
            }
        }
        let report = verify_plan(&rounded, &layout, &config);
        assert!(report.ok, "{report:?}");
    }
}
