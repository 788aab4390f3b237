//! Bends of a particle's path moved towards the straight line between
//! their neighbours, then slid along what stops them; the room a bent push
//! keeps for the closed loop's placement errors.

use super::MIN_SAVING_M;
use super::bisect;
use super::clear_for;
use super::push_step;
use super::straighten::bent_paths;
use crate::plan::PlanConfig;
use crate::plan::Step;
use crate::plan::layout::Layout;
use crate::plan::pushes::max_push_len;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;

/// `steps` with the pushes `i` and `j` of `particle` (of `radius_m`),
/// from `p` to `n`, meeting at `bend` instead.
pub(super) fn with_bend(
    steps: &[Step],
    (i, j): (usize, usize),
    (particle, p, n): (u32, Vector2<f64>, Vector2<f64>),
    bend: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
) -> Vec<Step> {
    let mut out = steps.to_vec();
    out[i] = push_step(particle, p, bend, radius_m, config);
    out[j] = push_step(particle, bend, n, radius_m, config);
    out
}

/// `steps` with each bend of a particle's path (where one of its pushes
/// ends and its next begins: a waypoint, a buffer spot) moved towards the
/// straight line between the bend's neighbours, as far as the plan still
/// replays clear: the route search picks waypoints from a coarse set.
pub(super) fn tighten_bends(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &FxHashMap<u32, usize>,
    config: &PlanConfig,
) -> Vec<Step> {
    let wide = with_room(config);
    for (particle, _) in bent_paths(&steps) {
        let x = index[&particle];
        let radius = layout.particles[x].radius_m;
        let own: Vec<usize> = (0..steps.len())
            .filter(|&k| matches!(steps[k], Step::Push { particle: id, .. } if id == particle))
            .collect();
        for pair in own.windows(2) {
            let (i, j) = (pair[0], pair[1]);
            let (Some((_, p, v)), Some((_, _, n))) = (steps[i].push_move(), steps[j].push_move())
            else {
                continue;
            };
            if (v - p).norm() + (n - v).norm() - (n - p).norm() < MIN_SAVING_M {
                continue;
            }
            let pn = n - p;
            let along = if pn.norm_squared() > 0.0 {
                ((v - p).dot(&pn) / pn.norm_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let straight = p + pn * along;
            let candidate = |t: f64| {
                let bend = v + (straight - v) * t;
                with_bend(&steps, (i, j), (particle, p, n), bend, radius, config)
            };
            let full = candidate(1.0);
            if clear_for(&full, layout, index, config, x) {
                steps = full;
            } else if let Some(t) = bisect((0.0, 1.0), |t| {
                clear_for(&candidate(t), layout, index, config, x)
            }) {
                steps = candidate(t);
            }
            let clear = |s: &[Step]| clear_for(s, layout, index, &wide, x);
            steps = slide_bend(steps, (i, j), radius, clear, config);
        }
    }
    steps
}

/// Room beyond the clearance that a slid bend, or a push bent round a
/// particle left in place, keeps from every particle: they end where the
/// room runs out, and the closed loop re-plans from where the particles
/// are seen after each push, tens of nanometres off the plan (CMU seed 33
/// of `nanopush study assemble`: with bent pushes at the bare clearance,
/// the plan in hand stopped verifying mid-run and the re-plan from there
/// was refused).
const EXECUTION_ROOM_M: f64 = 0.05e-6;

/// `config` with [`EXECUTION_ROOM_M`] added to its clearance.
pub(super) fn with_room(config: &PlanConfig) -> PlanConfig {
    PlanConfig {
        clearance_m: config.clearance_m + EXECUTION_ROOM_M,
        ..config.clone()
    }
}

/// Step sizes of [`slide_bend`]'s pattern search, metres.
const SLIDE_STEPS_M: [f64; 6] = [0.5e-6, 0.25e-6, 0.12e-6, 0.06e-6, 0.03e-6, 0.015e-6];

/// Least a slide must shorten a path, metres: a bend that follows the
/// edge of a particle's corridor gains little per step.
const SLIDE_GAIN_M: f64 = 1e-12;

/// Most moves of a bend per step size.
const SLIDE_MOVES: usize = 16;

/// `steps` with the bend between the pushes `i` and `j` of one particle
/// (of `radius_m`) slid in 8 directions and along either push's line, by
/// shrinking steps (a pattern search), while the two pushes get shorter
/// and `clear` holds. Pulled towards its neighbours' line, a bend stops
/// where a leg touches a particle; slid along that particle, the path
/// still gets shorter (CMU seed 8 of the 40-60 scenes: a path round a
/// filled site 1.8 um above its straight line, where a smooth way round
/// is 0.8 um above it).
pub(super) fn slide_bend(
    mut steps: Vec<Step>,
    (i, j): (usize, usize),
    radius_m: f64,
    clear: impl Fn(&[Step]) -> bool,
    config: &PlanConfig,
) -> Vec<Step> {
    let (Some((particle, p, _)), Some((_, _, n))) = (steps[i].push_move(), steps[j].push_move())
    else {
        return steps;
    };
    let length = |b: Vector2<f64>| (b - p).norm() + (n - b).norm();
    // A push stays within the nanostage's reach, as the order's pieces.
    let longest = max_push_len(radius_m, config);
    let compass: Vec<Vector2<f64>> = (0..4)
        .map(|a| {
            let angle = std::f64::consts::TAU * f64::from(a) / 8.0;
            Vector2::new(angle.cos(), angle.sin())
        })
        .collect();
    for h in SLIDE_STEPS_M {
        for _ in 0..SLIDE_MOVES {
            let Some((_, _, v)) = steps[i].push_move() else {
                return steps;
            };
            // Along either leg too: a leg that touches a particle keeps
            // its line, so the bend follows that edge of the free space.
            let legs = [v - p, n - v].map(|leg| leg.try_normalize(0.0));
            let mut tries: Vec<(f64, Vector2<f64>)> = compass
                .iter()
                .chain(legs.iter().flatten())
                .flat_map(|&u| [v + u * h, v - u * h])
                .filter(|&b| (b - p).norm().max((n - b).norm()) <= longest)
                .map(|b| (length(b), b))
                .filter(|&(len, _)| len < length(v) - SLIDE_GAIN_M)
                .collect();
            tries.sort_by(|a, b| a.0.total_cmp(&b.0));
            let moved = tries.into_iter().find_map(|(_, b)| {
                let out = with_bend(&steps, (i, j), (particle, p, n), b, radius_m, config);
                clear(&out).then_some(out)
            });
            match moved {
                Some(out) => steps = out,
                None => break,
            }
        }
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::*;

    #[test]
    fn a_detour_around_a_particle_stays_bent_but_tighter() {
        // Particle 1 sits on the straight line from (20, 50) to (80, 50).
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![
            push(0, (20.0, 50.0), (50.0, 65.0)),
            push(0, (50.0, 65.0), (80.0, 50.0)),
        ];
        let (out, fewer) = shortened(&layout, steps.clone(), &[(80.0, 50.0)]);
        assert_eq!(fewer, 0);
        // The bend moves towards the line, not onto it: the two particles
        // need 10 um between centres plus the clearance.
        let y = push_at(&out, 0).2.y;
        assert!(y > 60.0 && y < 62.0, "{y}");
        assert!(push_length(&out) < push_length(&steps));
    }

    #[test]
    fn a_bend_off_centre_slides_round_the_particle_to_the_shortest_way() {
        // Particle 1 sits on the straight line from (20, 50) to (80, 50);
        // the bend starts off centre, at (30, 75). Pulled towards the line
        // alone it stops where its second leg touches particle 1; slid, it
        // ends where both legs touch: the shortest one-bend way round,
        // 2 sqrt(30^2 + h^2) with h = 30 rho / sqrt(30^2 - rho^2), rho the
        // 10 um between centres plus the clearance and the execution room.
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![
            push(0, (20.0, 50.0), (30.0, 75.0)),
            push(0, (30.0, 75.0), (80.0, 50.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(80.0, 50.0)]);
        let rho = 10.0 + (PlanConfig::default().clearance_m + EXECUTION_ROOM_M) * 1e6;
        let h = 30.0 * rho / (900.0 - rho * rho).sqrt();
        let shortest = 2.0 * (900.0 + h * h).sqrt();
        let len = push_length(&out) * 1e6;
        assert!(
            len > shortest - 1e-6 && len < shortest + 0.05,
            "{len} {shortest}"
        );
    }
}
