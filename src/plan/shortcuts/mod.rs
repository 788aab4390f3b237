//! Shortcuts through an ordered plan, each kept only when the plan still
//! replays clear (every corridor keeps the clearance, as in the order). One
//! pass a file, run in this order, for up to `ROUNDS` rounds:
//! - `straighten`: a particle the order pushed along a bent path (parked
//!   off a site, then pushed off another move's way again; buffered, then
//!   brought back; routed through a waypoint) is pushed straight from its
//!   start to its end instead, at the time of its first push or of its
//!   last; one that ends on no site, to any nearer spot off the sites;
//! - `bends`: else each bend of its path moves towards the straight line
//!   between its neighbours, then slides along what stops it;
//! - `pull_in`: a particle that ends on no site (parked off the sites, or
//!   pushed off another move's way) has its last push pulled in: it stops
//!   at the nearest spot off every site found clear (in 48 directions,
//!   then on the push's own line, then turned between the directions), or
//!   stays put;
//! - `park_after_blocker`: such a push may wait for the nearby particle
//!   that blocks its nearer way, and end there;
//! - `bend_round_idle`: a particle pushed once off another's way stays put
//!   when the one later push it would block can bend round it for less;
//! - `merge_tiny`: a push shorter than the on-site tolerance joins its
//!   particle's next push or its previous one.
//!
//! `parking_spots` (where a particle on no site may stop) and
//! `single_push_check` (what one push in place of a particle's own must
//! keep clear of) serve several passes.
//!
//! The order decides each push with what it knows at that step; only the
//! finished plan shows that a particle's second push undid half of its
//! first (CMU seed 58 of the 40-60 scenes: a particle parked 0.22 um off a
//! site, later 2.25 um further, 0.16 um more than one push to its end), or
//! that a spot kept clear of a corridor no later push used.

mod bend_round_idle;
mod bends;
mod merge_tiny;
mod park_after_blocker;
mod parking_spots;
mod pull_in;
mod single_push_check;
mod straighten;

use super::layout::Layout;
use super::pushes::{Corridor, approach_point, corridor_reach, segment_distance};
use super::{PlanConfig, Step};
use bend_round_idle::bend_round_idle;
use bends::tighten_bends;
use merge_tiny::merge_tiny;
use nalgebra::Vector2;
use park_after_blocker::park_after_blocker;
use parking_spots::Parking;
use pull_in::pull_in_parking;
use rustc_hash::FxHashMap;
use std::cell::OnceCell;
use straighten::straighten;

/// Least saving a shortcut is tried for: the collinear pieces of a long
/// push save nothing.
const MIN_SAVING_M: f64 = 1e-8;

/// Most pushes of a plan whose shortcuts are tried: each try replays the
/// whole plan, so the cost grows with pushes times bent paths. CMU plans
/// have 30-100 pushes; at N = 1,000 (2,831 pushes) the shortcuts took the
/// push ratio from 1.002560 to 1.002169 and the full plan from 318 to
/// 626 ms, for a target already met.
pub const MAX_PUSHES: usize = 2_000;

/// `steps` (pushes only, in order) after up to `ROUNDS` rounds of
/// straightened paths, tightened bends, parked particles' last pushes
/// pulled in, pushes bent round particles that then stay put and short
/// pushes merged (`site_pts`: every site); and how many pushes fewer it
/// has.
pub fn take_shortcuts(
    steps: Vec<Step>,
    layout: &Layout,
    site_pts: &[Vector2<f64>],
    config: &PlanConfig,
) -> (Vec<Step>, usize) {
    if steps.len() > MAX_PUSHES {
        return (steps, 0);
    }
    let before = steps.len();
    let parking = Parking::new(site_pts, layout, config);
    let index = layout.index_by_id();
    let mut steps = steps;
    for _ in 0..ROUNDS {
        let length = push_length(&steps);
        steps = straighten(steps, layout, &index, &parking, config);
        steps = tighten_bends(steps, layout, &index, config);
        steps = pull_in_parking(steps, layout, &index, &parking, config);
        steps = park_after_blocker(steps, layout, &index, &parking, config);
        steps = bend_round_idle(steps, layout, &index, &parking, config);
        steps = merge_tiny(steps, layout, &index, config);
        if push_length(&steps) > length - MIN_SAVING_M {
            break;
        }
    }
    let fewer = before.saturating_sub(steps.len());
    (steps, fewer)
}

/// Most rounds of the passes: one can free room for another.
const ROUNDS: usize = 3;

/// Total length of the pushes of `steps`.
fn push_length(steps: &[Step]) -> f64 {
    steps
        .iter()
        .filter_map(Step::push_move)
        .map(|(_, from_m, to_m)| (to_m - from_m).norm())
        .sum()
}

/// Bisection steps when pulling a bend or a parked particle's push in.
const PULL_IN_STEPS: usize = 7;

/// A push step of `particle` from `from` to `to`, its approach behind it.
fn push_step(
    particle: u32,
    from: Vector2<f64>,
    to: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
) -> Step {
    Step::Push {
        particle,
        from_m: from,
        to_m: to,
        approach_m: approach_point(from, to, radius_m, config),
        contact_angle_rad: config.contact_angle_rad,
    }
}

/// [`PULL_IN_STEPS`] bisections between the fractions `valid` (`ok`) and
/// `invalid`: the fraction nearest `invalid` found `ok`; None when only
/// `valid` is.
fn bisect((mut valid, mut invalid): (f64, f64), ok: impl Fn(f64) -> bool) -> Option<f64> {
    let mut best = None;
    for _ in 0..PULL_IN_STEPS {
        let mid = 0.5 * (valid + invalid);
        if ok(mid) {
            valid = mid;
            best = Some(mid);
        } else {
            invalid = mid;
        }
    }
    best
}

/// One push whose corridor many discs are tested against: a box and a
/// distance test first (most discs a shortcut checks lie far from the
/// push), and the corridor built once, when a disc first comes near.
struct SweptPush<'a> {
    a: Vector2<f64>,
    b: Vector2<f64>,
    radius: f64,
    config: &'a PlanConfig,
    /// How far from the segment a-b the corridor reaches.
    reach: f64,
    corridor: OnceCell<Corridor>,
}

impl<'a> SweptPush<'a> {
    /// Pushing a particle of `radius` from `a` to `b`.
    fn new((a, b, radius): (Vector2<f64>, Vector2<f64>, f64), config: &'a PlanConfig) -> Self {
        SweptPush {
            a,
            b,
            radius,
            config,
            reach: corridor_reach(radius, config),
            corridor: OnceCell::new(),
        }
    }

    /// True when the corridor comes within the clearance of a disc of
    /// `radius` at `centre`.
    fn hits(&self, centre: Vector2<f64>, radius: f64) -> bool {
        let clearance = self.config.clearance_m;
        let near = self.reach + clearance + radius;
        let (a, b) = (self.a, self.b);
        let in_box = centre.x >= a.x.min(b.x) - near
            && centre.x <= a.x.max(b.x) + near
            && centre.y >= a.y.min(b.y) - near
            && centre.y <= a.y.max(b.y) + near;
        in_box
            && segment_distance(centre, a, b) < near
            && self
                .corridor
                .get_or_init(|| Corridor::new(a, b, self.radius, self.config))
                .hits(centre, radius, clearance)
    }
}

/// True when the corridor of pushing a particle of radius `r` from `a` to
/// `b` comes within the clearance of a disc of `radius` at `centre`.
fn corridor_hits(
    push: (Vector2<f64>, Vector2<f64>, f64),
    centre: Vector2<f64>,
    radius: f64,
    config: &PlanConfig,
) -> bool {
    SweptPush::new(push, config).hits(centre, radius)
}

/// True when the pushes of `steps` that involve particle `x` (its index in
/// `layout`: its own pushes, and every other push while it lies where it
/// does then) start where their particle is and keep the clearance: the
/// whole replay's answer for a plan that replayed clear before only `x`'s
/// pushes changed, since the positions of every other pair at every push
/// are the same. Linear in the pushes, plus the particles for each push of
/// `x`.
fn clear_for(
    steps: &[Step],
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    config: &PlanConfig,
    x: usize,
) -> bool {
    let mut pos: Vec<Vector2<f64>> = layout.particles.iter().map(|p| p.centre_m).collect();
    let radius = |j: usize| layout.particles[j].radius_m;
    steps.iter().all(|step| {
        let Some((id, from_m, to_m)) = step.push_move() else {
            return true;
        };
        let Some(&i) = index.get(&id) else {
            return false;
        };
        let push = SweptPush::new((from_m, to_m, radius(i)), config);
        let clear = if i == x {
            (pos[x] - from_m).norm() <= 1e-12
                && (0..pos.len()).all(|j| j == x || !push.hits(pos[j], radius(j)))
        } else {
            !push.hits(pos[x], radius(x))
        };
        pos[i] = to_m;
        clear
    })
}

/// What the passes' tests share: plans written in micrometres, and the
/// check that the shortcuts keep them replaying clear.
#[cfg(test)]
mod test_support {
    pub(super) use super::push_length;
    use super::*;
    use crate::plan::occupancy::Occupancy;

    /// True when every push of `steps`, replayed from `layout`, starts where
    /// its particle is and its corridor (particle and tip) keeps the clearance
    /// from every other particle where it is then: the order's own test.
    pub(super) fn replays_clear(steps: &[Step], layout: &Layout) -> bool {
        let config = PlanConfig::default();
        let index = layout.index_by_id();
        let mut occ = Occupancy::new(layout);
        steps.iter().all(|step| {
            step.push_move().is_none_or(|(particle, from_m, to_m)| {
                index
                    .get(&particle)
                    .is_some_and(|&i| occ.replay_push(i, (from_m, to_m), &config))
            })
        })
    }

    /// A push of `particle` of 5 um radius from `from` to `to` (um).
    pub(super) fn push(particle: u32, from: (f64, f64), to: (f64, f64)) -> Step {
        let (a, b) = (
            Vector2::new(from.0, from.1) * 1e-6,
            Vector2::new(to.0, to.1) * 1e-6,
        );
        push_step(particle, a, b, 5e-6, &PlanConfig::default())
    }

    /// `steps` (which must replay clear) after the shortcuts, with the
    /// sites at `sites` (um), checked to replay clear; and how many pushes
    /// fewer they have.
    pub(super) fn shortened(
        layout: &Layout,
        steps: Vec<Step>,
        sites: &[(f64, f64)],
    ) -> (Vec<Step>, usize) {
        assert!(
            replays_clear(&steps, layout),
            "the plan given does not replay clear"
        );
        let sites: Vec<Vector2<f64>> = sites
            .iter()
            .map(|&(x, y)| Vector2::new(x, y) * 1e-6)
            .collect();
        let (out, fewer) = take_shortcuts(steps, layout, &sites, &PlanConfig::default());
        assert!(replays_clear(&out, layout), "the shortened plan does not");
        (out, fewer)
    }

    /// Particle, start and end (um) of the push at `k`.
    pub(super) fn push_at(steps: &[Step], k: usize) -> (u32, Vector2<f64>, Vector2<f64>) {
        let (particle, from_m, to_m) = steps[k].push_move().expect("a push");
        (particle, from_m * 1e6, to_m * 1e6)
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;

    #[test]
    fn a_replay_that_hits_a_particle_is_not_clear() {
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![push(0, (20.0, 50.0), (80.0, 50.0))];
        assert!(!replays_clear(&steps, &layout));
        let wrong_start = vec![push(0, (21.0, 50.0), (20.0, 80.0))];
        assert!(!replays_clear(&wrong_start, &layout));
    }
}
