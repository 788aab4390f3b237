//! The next push: the tracks the planner is told about, the plan made
//! (or the one in hand, moved onto the particles as they lie now), and
//! the particles and layouts the planner is given.

use super::{Assembly, ExecError, PlannedPush, PushIntent};
use crate::exec::events::RunEvent;
use crate::exec::particle_sizes::ParticleSizes;
use crate::exec::tracker::{Track, Tracker};
use crate::plan::layout::{Layout, Particle, UM_PER_M, beyond_field_m, may_lie_in_field};
use crate::plan::rebase::rebase_plan;
use crate::plan::touching::settle_overlaps;
use crate::plan::verify::pushable_later;
use crate::plan::{Plan, Step, plan_assembly, verify_plan};
use crate::vision::log_on_change::changed;
use crate::wording::counted;
use nalgebra::Vector2;

impl Assembly<'_> {
    /// The particles the planner must not push: those given up on.
    pub(super) fn immovable(&self) -> Vec<u32> {
        self.given_up.iter().map(|&id| id as u32).collect()
    }

    /// The tracks the planner is told about. The first plan takes every track
    /// (the run's first looks find every particle) and they stay; a track new
    /// after it must be seen twice: a one-frame false detection between
    /// particles had become an obstacle that blocked the plan in hand and
    /// every fresh plan. (A first-plan track seen once, then out of view, had
    /// vanished from the next plan, which pushed a particle through it.)
    pub(super) fn confirmed_tracks(&self) -> Vec<Track> {
        let first = self.first_plan_ids.unwrap_or(usize::MAX);
        self.tracker
            .tracks()
            .iter()
            .filter(|t| t.hits >= 2 || t.id < first)
            .cloned()
            .collect()
    }

    /// The next push: from the plan in hand if, moved onto the particles as
    /// seen now, it still verifies; otherwise from a fresh plan. Returns why
    /// there is none when the planner refuses.
    pub(super) fn next_push(&mut self) -> Result<Result<PushIntent, String>, ExecError> {
        let confirmed = self.confirmed_tracks();
        // The particles' measured sizes, for the plan and for the push.
        // Not the scene's: a batch 2 % off its nominal size (4.9 um
        // particles in a 5 um scene) put the tip's contact 0.15 um off
        // along the push at a 70 deg contact angle, and every push, re-push
        // included, fell 0.35 um short (or, 2 % over, overshot 0.3 um, back
        // and forth 400 times): CMU stopped at 0 of 31.
        let sizes = ParticleSizes::of(&confirmed, self.scene.particle_radius_m);
        let layout = Layout {
            field_m: self.settings.field_m,
            particles: planning_particles(&confirmed, &sizes, self.settings.field_m),
        };
        let mut config = self.plan_config.clone();
        config.immovable = self.immovable();
        let repushed = self.repush_next.map(|id| id as u32);
        // The plan in hand, moved onto the particles, when it no longer
        // verifies: kept in case no fresh plan is found.
        let mut faulty_later = None;
        let kept = self.plan_in_hand.take().map(|p| {
            let p = rebase_plan(&p, &layout, self.settings.keep_plan_shift_m, repushed)
                .map_err(|e| e.to_string())?;
            let report = verify_plan(&p, &layout, &config);
            if report.ok {
                Ok(p)
            } else {
                faulty_later = Some(p);
                Err(format!("it no longer verifies: {}", report.summary()))
            }
        });
        let unmoved = self.unmoved.take();
        if let (Some(Err(_)), Some(particle)) = (&kept, unmoved) {
            // A fresh plan would ask for the push that did nothing again.
            self.fail(particle)?;
            config.immovable = self.immovable();
            faulty_later = None;
        }
        let plan = match kept {
            Some(Ok(plan)) => plan,
            dropped => {
                config.tip_start_m = self
                    .tip_hint_m
                    .take()
                    .or_else(|| self.last_sighting.as_ref().and_then(|s| s.tip_m))
                    .map(|t| Vector2::new(t[0], t[1]));
                let because = dropped.and_then(Result::err);
                let mut planned =
                    plan_assembly(&layout, &self.open_sites(), &config).map_err(|e| e.to_string());
                if let Err(first) = &planned
                    && let left @ 1.. = self.leave_near_particles_short()?
                {
                    // Boxed in a hair from its site (one 0.21 um off, between
                    // three filled sites, had stopped the run): plan without it.
                    config.immovable = self.immovable();
                    // When that fails too, the first refusal is the layout's
                    // own: the second named a particle "immovable" that only
                    // the loop had left where it lay (a dense 1 um field).
                    let left = counted(left, "particle");
                    planned = plan_assembly(&layout, &self.open_sites(), &config).map_err(|again| {
                        format!("{first} (nor with {left} left short where they lie near a site: {again})")
                    });
                }
                match planned {
                    Ok(plan) => {
                        self.journal_plan(&plan, because)?;
                        plan
                    }
                    Err(e) => match faulty_later.and_then(|p| {
                        pushable_later(p, &layout, &config, self.settings.clearance_m)
                    }) {
                        // No plan now, but the next push of the one in hand is
                        // clear: make it and plan again after it, as after
                        // every push. In a dense core the particles as
                        // measured had put a later step (the plan's 15th, its
                        // 79th) 0.06-0.17 um into a particle, no order was
                        // found at the fixed sites, and the run stopped where
                        // pushing on cleared the way.
                        Some(plan) => {
                            tracing::warn!(
                                "no new plan ({e}); the plan in hand fails only later ({}): its next push is clear, so it is made, and the plan made again after it",
                                because.unwrap_or_default()
                            );
                            plan
                        }
                        None => {
                            let kept = because
                                .map(|b| format!(" (the plan in hand was dropped: {b})"))
                                .unwrap_or_default();
                            return Ok(Err(format!("planner: {e}{kept}")));
                        }
                    },
                }
            }
        };
        self.plan = plan
            .steps
            .iter()
            .filter_map(|step| match step {
                Step::Push { from_m, to_m, .. } => Some(PlannedPush {
                    from: [from_m.x, from_m.y],
                    to: [to_m.x, to_m.y],
                }),
                _ => None,
            })
            .collect();
        let first = plan.steps.iter().find_map(|step| match step {
            Step::Push {
                particle,
                from_m,
                to_m,
                ..
            } => Some((*particle as usize, *from_m, *to_m)),
            _ => None,
        });
        // Its first push leaves the plan when the camera shows it placed (`check`).
        self.plan_in_hand = Some(plan);
        self.first_plan_ids.get_or_insert(self.tracker.ids_issued());
        Ok(first
            .ok_or_else(|| "the plan has no push left".to_owned())
            .map(|(particle, from, to)| PushIntent {
                particle,
                from: [from.x, from.y],
                to: [to.x, to.y],
                radius_m: sizes.radius_of(&confirmed, particle),
            }))
    }

    /// Where the plan in hand lands the tip for the push after the one
    /// being made (its second push), when it has one.
    pub(super) fn next_landing_in_hand(&self) -> Option<[f64; 2]> {
        let plan = self.plan_in_hand.as_ref()?;
        let mut landings = plan.steps.iter().filter_map(|step| match step {
            Step::Push { approach_m, .. } => Some([approach_m.x, approach_m.y]),
            _ => None,
        });
        landings.nth(1)
    }

    pub(super) fn journal_plan(
        &mut self,
        plan: &Plan,
        replaced_because: Option<String>,
    ) -> Result<(), ExecError> {
        let s = &plan.summary;
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Plan {
                pushes: s.pushes,
                push_distance_um: s.push_distance_m * 1e6,
                tip_travel_um: s.tip_travel_m * 1e6,
                lb_push_um: s.lb_push_m * 1e6,
                lb_tip_um: s.lb_tip_m * 1e6,
                planning_ms: s.planning_time_s * 1e3,
                replaced_because,
            },
        )?;
        Ok(())
    }
}

/// How far, as a share of the two radii, a particle seen now must overlap
/// a missed track for the track to be taken as stale: touching neighbours
/// are measured up to 0.1-0.2 um into each other. In a dense core (5 um
/// adversarial seed 6 '42') a particle placed 0.14 um off, 0.02 um into
/// its neighbour's disc while the neighbour went undetected, had the
/// neighbour dropped, and the next plan pushed a particle through it.
const STALE_OVERLAP_SHARE: f64 = 0.05;

/// The particles the planner is told about. A track the camera has missed
/// for a few frames is dropped; one missed more recently is kept unless a
/// particle seen in this frame overlaps it by more than
/// `STALE_OVERLAP_SHARE` of their radii (then the stale one is wrong: a
/// particle pushed out from under the probe, say, under a new id).
/// Each particle has its size from `sizes`. Radii are capped so
/// that no two discs overlap: touching spheres cannot, so a few nanometres
/// of apparent overlap must not make the layout invalid. A particle
/// farther outside `field_m` than a push may start is said once (when
/// their number changes): the planner holds it as an obstacle
/// (`Layout::beyond_field_ids`). Left out, it had been in the way of a
/// tip landing behind a particle at the field's edge.
pub fn planning_particles(
    tracks: &[Track],
    sizes: &ParticleSizes,
    field_m: [f64; 2],
) -> Vec<Particle> {
    let overlaps = |a: &Track, b: &Track| {
        let reach = (1.0 - STALE_OVERLAP_SHARE) * (a.last.radius_m + b.last.radius_m);
        (a.last.x_m - b.last.x_m).hypot(a.last.y_m - b.last.y_m) < reach
    };
    let seen: Vec<_> = tracks
        .iter()
        .filter(|t| t.missed_frames < 3)
        .filter(|t| {
            t.missed_frames == 0
                || !tracks
                    .iter()
                    .any(|u| u.id != t.id && u.missed_frames == 0 && overlaps(t, u))
        })
        .map(|t| (t.id, [t.last.x_m, t.last.y_m], sizes.radius_m(t)))
        .collect();
    let beyond: Vec<_> = (seen.iter())
        .filter(|&&(_, c, r)| !may_lie_in_field(field_m, Vector2::from(c), r))
        .collect();
    warn_of_particles_beyond(&beyond, field_m);
    particles_seen(&seen)
}

/// Says how many particles lie beyond the field, when that number
/// changes, naming the one nearest its edge.
fn warn_of_particles_beyond(beyond: &[&(usize, [f64; 2], f64)], field_m: [f64; 2]) {
    let topic = format!("beyond the field {field_m:?}");
    if !changed(topic, beyond.len().to_string()) || beyond.is_empty() {
        return;
    }
    let distance = |c: &[f64; 2]| beyond_field_m(field_m, Vector2::from(*c));
    let nearest = beyond
        .iter()
        .min_by(|a, b| distance(&a.1).total_cmp(&distance(&b.1)));
    if let Some((id, c, _)) = nearest {
        let verb = if beyond.len() == 1 { "lies" } else { "lie" };
        tracing::warn!(
            "{} {verb} beyond the {:.1} x {:.1} um field, where no push reaches: the plans keep clear of them; the nearest is particle {id} at ({:.1}, {:.1}) um",
            counted(beyond.len(), "particle"),
            field_m[0] * UM_PER_M,
            field_m[1] * UM_PER_M,
            c[0] * UM_PER_M,
            c[1] * UM_PER_M
        );
    }
}

/// The first frame's particles as a layout of `field_m` (ids by order
/// seen), each with the size the loop will plan it with
/// ([`ParticleSizes`]; `nominal_m` is the scene's radius), for placing the
/// pattern on a rig: placed with the nominal radius for all, a spread
/// batch's sites could count on particles the loop then finds too wide.
pub fn layout_measured(
    field_m: [f64; 2],
    seen: &[crate::exec::tracker::Observation],
    nominal_m: f64,
) -> Layout {
    let mut tracker = Tracker::new(f64::INFINITY);
    tracker.update(seen, &[], &|_, _| true);
    layout_of_tracks(field_m, tracker.tracks(), nominal_m)
}

/// The layout the loop's first plan sees after its first `looks` at the
/// field (in order), tracked with `gate_m` as the loop tracks them (a
/// particle a look does not show, out of view or under the probe, is not
/// missed): the simulated rig places the pattern on it. One look's radii
/// and two looks' differ by nanometres, and a crowded place planned on the
/// parked look alone had no order on the loop's two (5 um adversarial
/// seed 2 'CMU').
pub fn layout_after_looks<'a>(
    field_m: [f64; 2],
    looks: impl IntoIterator<Item = &'a crate::exec::observe::Sighting>,
    nominal_m: f64,
    gate_m: f64,
) -> Layout {
    let mut tracker = Tracker::new(gate_m);
    for look in looks {
        tracker.update(&look.particles, &[], &|x, y| look.shows(x, y));
    }
    layout_of_tracks(field_m, tracker.tracks(), nominal_m)
}

/// Why the particles of `layout` in its field cannot fill a pattern of
/// `sites` sites (those beyond it are never pushed), said after what
/// `shown_by` ("the first frame shows"); None when they can. The dry-run
/// and the hardware rig refuse such a pattern before the loop starts: on
/// a rig the placement had gone on, and the run with it.
pub fn too_few_in_field(layout: &Layout, sites: usize, shown_by: &str) -> Option<String> {
    let beyond_field = layout.beyond_field_ids().len();
    let held = layout.particles.len() - beyond_field;
    if sites <= held {
        return None;
    }
    let beyond = match beyond_field {
        0 => String::new(),
        n => format!(" ({n} more beyond it)"),
    };
    Some(format!(
        "the pattern has {} but {shown_by} {} in the field{beyond}",
        counted(sites, "site"),
        counted(held, "particle"),
    ))
}

/// The layout of `tracks`, each particle with the size the loop plans it
/// with.
fn layout_of_tracks(field_m: [f64; 2], tracks: &[Track], nominal_m: f64) -> Layout {
    let sizes = ParticleSizes::of(tracks, nominal_m);
    Layout {
        field_m,
        particles: planning_particles(tracks, &sizes, field_m),
    }
}

/// Particles `(id, centre, radius)`, each radius capped at its share of
/// the distance to every neighbour it would overlap (see
/// [`planning_particles`] and [`settle_overlaps`]).
pub fn particles_seen(seen: &[(usize, [f64; 2], f64)]) -> Vec<Particle> {
    let mut particles: Vec<Particle> = seen
        .iter()
        .map(|&(id, c, r)| Particle {
            id: id as u32,
            centre_m: Vector2::new(c[0], c[1]),
            radius_m: r,
        })
        .collect();
    settle_overlaps(&mut particles);
    particles
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::tracker::Observation;

    /// A first frame of a spread batch (4.6-5.4 um) places the pattern
    /// with each particle's measured size; two 0.1 um apart keep most of
    /// their sightings' offsets from the batch's median (the median for
    /// both had let a plan push a wide one into its neighbour), and do not
    /// overlap.
    #[test]
    fn the_first_frames_layout_has_the_sizes_the_loop_plans_with() {
        let at = |x_um: f64, r_um: f64| Observation {
            x_m: x_um * 1e-6,
            y_m: 20e-6,
            radius_m: r_um * 1e-6,
        };
        let seen = [
            at(10.0, 4.6),
            at(30.0, 5.0),
            at(50.0, 5.4),
            at(70.0, 4.8),
            at(79.9, 5.0),
        ];
        let layout = layout_measured([100e-6, 40e-6], &seen, 5e-6);
        let r: Vec<f64> = layout.particles.iter().map(|p| p.radius_m * 1e6).collect();
        for (got, want) in r.iter().zip([4.6, 5.0, 5.4]) {
            assert!((got - want).abs() < 0.01, "{r:?}");
        }
        // The last two, 0.1 um apart: 4.8 um shrunk a little towards the
        // median (5 um), 5 um kept; together within their 9.9 um distance.
        assert!(r[3] > 4.8 && r[3] < 4.86, "{r:?}");
        assert!((r[4] - 5.0).abs() < 0.01, "{r:?}");
        assert!(r[3] + r[4] <= 9.9, "{r:?}");
    }

    /// Every particle seen lies in the planner's layout, those beyond the
    /// field too (its obstacles, `Layout::beyond_field_ids`); one missed
    /// for three frames is left out.
    #[test]
    fn particles_beyond_the_field_stay_as_obstacles() {
        let at = |x_um: f64, y_um: f64| Observation {
            x_m: x_um * 1e-6,
            y_m: y_um * 1e-6,
            radius_m: 5e-6,
        };
        let mut tracker = Tracker::new(4e-6);
        let seen = [
            at(50.0, 50.0),
            at(-9.0, 50.0),
            at(-11.0, 70.0),
            at(50.0, 113.0),
            at(30.0, 30.0),
        ];
        tracker.update(&seen, &[], &|_, _| true);
        for _ in 0..3 {
            tracker.update(&seen[..4], &[], &|_, _| true);
        }
        let sizes = ParticleSizes::of(tracker.tracks(), 5e-6);
        let layout = Layout {
            field_m: [100e-6, 100e-6],
            particles: planning_particles(tracker.tracks(), &sizes, [100e-6, 100e-6]),
        };
        let held: Vec<u32> = layout.particles.iter().map(|p| p.id).collect();
        assert_eq!(held, [0, 1, 2, 3]);
        assert_eq!(layout.beyond_field_ids(), [2, 3]);
    }

    /// A missed track that a particle seen now lies 0.02 um into (touching
    /// neighbours are measured so) stays an obstacle; one a particle seen
    /// now covers by 1 um is a stale place, and goes.
    #[test]
    fn a_missed_neighbour_touching_a_seen_particle_stays_and_a_stale_place_goes() {
        let at = |x_um: f64| Observation {
            x_m: x_um * 1e-6,
            y_m: 20e-6,
            radius_m: 5e-6,
        };
        let mut tracker = Tracker::new(4e-6);
        tracker.update(&[at(20.0), at(30.5), at(60.0)], &[], &|_, _| true);
        // 0 moved 0.52 um towards 1, which is missed; 3 is new, 9 um from 2.
        tracker.update(&[at(20.52), at(69.0)], &[], &|_, _| true);
        let sizes = ParticleSizes::of(tracker.tracks(), 5e-6);
        let held: Vec<u32> = planning_particles(tracker.tracks(), &sizes, [100e-6, 40e-6])
            .iter()
            .map(|p| p.id)
            .collect();
        assert_eq!(held, [0, 1, 3]);
    }

    /// Particles of their own sizes, 5.2 and 4.8 um, seen 9.99 um apart
    /// share the 10 nm of apparent overlap by size; a lone one keeps its own.
    #[test]
    fn touching_particles_of_two_sizes_share_the_overlap_by_size() {
        let particles = particles_seen(&[
            (3, [10e-6, 20e-6], 5.2e-6),
            (8, [19.99e-6, 20e-6], 4.8e-6),
            (9, [60e-6, 20e-6], 4.5e-6),
        ]);
        let ids: Vec<u32> = particles.iter().map(|p| p.id).collect();
        assert_eq!(ids, [3, 8, 9]);
        let near = |a: f64, b: f64| (a - b).abs() < 1e-11;
        assert!(near(particles[0].radius_m, 5.2e-6 * 0.999), "{particles:?}");
        assert!(near(particles[1].radius_m, 4.8e-6 * 0.999), "{particles:?}");
        assert_eq!(particles[2].radius_m, 4.5e-6);
        let gap = 9.99e-6 - particles[0].radius_m - particles[1].radius_m;
        assert!(gap > 0.0, "overlap {gap}");
    }
}
