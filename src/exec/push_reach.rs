//! How far one push may carry a particle on a stage that moves at most so
//! far at once (a rig file's `max_step_um`). The stage cuts a longer stroke
//! into pieces and stops between them; the particle sticks again at every
//! stop and ends short (about 0.6 um a stop with the E-727 templates' 10 um
//! step), to be pushed again. Planning pushes whose whole stroke fits one
//! move avoids that.

use crate::model::Scene;
use crate::model::advice::advise_push;

/// Share of the largest step a stroke may use: the stage cuts moves past
/// 99 % of it (`gcs_line_stage::pieces`), and the charge build-up over a
/// run lengthens the cantilever's lag a little.
pub const STROKE_SHARE_OF_STEP: f64 = 0.95;

/// Shortest push worth planning: below it the stage's step, not the
/// particles, sets the pace (a 50 um move would take over 50 pushes).
pub const SHORTEST_USEFUL_PUSH_M: f64 = 1e-6;

/// What a stroke adds to the push beyond the particle's own travel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeAllowance {
    /// Gap the tip closes before it touches the particle.
    pub clearance_m: f64,
    /// Farthest a kept plan's push may start from where it was planned
    /// (the executor moves a plan in hand onto the particles as seen).
    pub kept_plan_shift_m: f64,
}

/// The longest push whose stroke (clearance, the particle's travel and the
/// cantilever's lag behind the stage, as the pushing model predicts it)
/// fits [`STROKE_SHARE_OF_STEP`] of `max_step_m`. Err says why no useful
/// push fits, for the user.
pub fn longest_push_m(
    max_step_m: f64,
    scene: &Scene,
    allowance: StrokeAllowance,
) -> Result<f64, String> {
    let speed = scene.push.speed_m_per_s;
    // Stage travel after contact is linear in the distance (the particle
    // follows the stage, lagging it by F/k): two distances give its line.
    let travel = |d_m: f64| {
        advise_push(scene, d_m)
            .map(|a| a.duration_s * speed)
            .map_err(|e| format!("the pushing model: {e}"))
    };
    let (near, far) = (1e-6, 10e-6);
    let (t_near, t_far) = (travel(near)?, travel(far)?);
    let per_m = (t_far - t_near) / (far - near);
    let lag_m = t_near - per_m * near;
    let lag_m = lag_m.max(0.0);
    let extra_m = allowance.clearance_m + allowance.kept_plan_shift_m + lag_m;
    let longest = (STROKE_SHARE_OF_STEP * max_step_m - extra_m) / per_m;
    if longest.is_finite() && longest >= SHORTEST_USEFUL_PUSH_M {
        return Ok(longest);
    }
    let needed_um = (SHORTEST_USEFUL_PUSH_M * per_m + extra_m) / STROKE_SHARE_OF_STEP * 1e6;
    Err(format!(
        "a push must fit one stage move of at most {:.3} um (the rig file's max_step_um), \
         but its stroke adds {:.3} um to the particle's travel (the tip's {:.3} um clearance, \
         {:.3} um for a kept plan, the cantilever's {:.3} um lag): raise max_step_um to \
         at least {:.1} um",
        max_step_m * 1e6,
        extra_m * 1e6,
        allowance.clearance_m * 1e6,
        allowance.kept_plan_shift_m * 1e6,
        lag_m * 1e6,
        (needed_um * 10.0).ceil() / 10.0
    ))
}

/// Said once when the step, not what the planner would otherwise allow
/// (`uncapped_m`, from the nanostage's range), bounds the pushes: a short
/// step makes many more pushes (CMU: 207 at a 3 um step, 36 at 150 um),
/// and nothing had said why. None when the step does not bind.
pub fn step_cap_note(longest_m: f64, uncapped_m: f64, max_step_m: f64) -> Option<String> {
    (longest_m < uncapped_m).then(|| {
        format!(
            "pushes at most {:.1} um (max_step_um {:.1} um in the rig file): a larger step makes fewer pushes",
            longest_m * 1e6,
            max_step_m * 1e6
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scene::built_in_scene_paths;
    use std::path::Path;

    fn scenes() -> Vec<Scene> {
        built_in_scene_paths()
            .map(|p| Scene::load(Path::new(p)).unwrap())
            .collect()
    }

    fn allowance() -> StrokeAllowance {
        StrokeAllowance {
            clearance_m: 0.5e-6,
            kept_plan_shift_m: 0.5e-6,
        }
    }

    fn stroke_m(scene: &Scene, d_m: f64) -> f64 {
        let a = advise_push(scene, d_m).unwrap();
        allowance().clearance_m
            + allowance().kept_plan_shift_m
            + a.duration_s * scene.push.speed_m_per_s
    }

    #[test]
    fn the_longest_push_fills_the_step_and_no_more() {
        for (scene, step_um) in scenes()
            .iter()
            .flat_map(|s| [5.0, 10.0, 20.0].map(|step| (s, step)))
        {
            let step = step_um * 1e-6;
            let d = longest_push_m(step, scene, allowance()).unwrap();
            let used = stroke_m(scene, d) / step;
            assert!(
                (used - STROKE_SHARE_OF_STEP).abs() < 0.01,
                "step {step_um} um: a {:.3} um push's stroke uses {used:.4} of it",
                d * 1e6
            );
        }
    }

    #[test]
    fn a_step_too_short_for_a_useful_push_is_refused_with_what_it_needs() {
        let scene = Scene::load(Path::new(crate::model::scene::DEFAULT_SCENE_PATH)).unwrap();
        let why = longest_push_m(1.5e-6, &scene, allowance()).unwrap_err();
        eprintln!("{why}");
        assert!(why.contains("raise max_step_um to at least"), "{why}");
        let needed: f64 = why
            .rsplit("at least ")
            .next()
            .and_then(|s| s.trim_end_matches(" um").parse().ok())
            .unwrap();
        let fits = longest_push_m(needed * 1e-6 + 1e-9, &scene, allowance()).unwrap();
        assert!(
            (fits - SHORTEST_USEFUL_PUSH_M).abs() < 0.1e-6,
            "the step it asks for gives a {:.3} um push",
            fits * 1e6
        );
    }
}
