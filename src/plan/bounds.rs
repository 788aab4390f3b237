//! Lower bounds a plan is measured against.
//!
//! LB_push: the optimal assignment's total straight-line distance (computed
//! in `plan_assembly`). LB_tip: every push's landing point must be reached
//! from somewhere, either the tip's start or the end of another push; the
//! minimum-cost assignment of landing points to {start, push ends} is a
//! relaxation of the tip's tour (self pairs are allowed, which only lowers
//! it), plus the standoff approach every push needs.

use super::assignment::{AssignmentMethod, assign};
use super::pushes::{landing_point, tip_end};
use super::{PlanConfig, Step};
use nalgebra::Vector2;

/// LB_tip of the pushes in `steps`, tip starting at `start` (None: free start).
pub fn lb_tip(steps: &[Step], start: Option<Vector2<f64>>, config: &PlanConfig) -> f64 {
    let mut landings = Vec::new();
    let mut ends = Vec::new();
    for s in steps {
        if let Step::Push {
            from_m,
            to_m,
            approach_m,
            ..
        } = s
        {
            landings.push(landing_point(*from_m, *to_m, *approach_m, config));
            ends.push(tip_end(*from_m, *to_m, *approach_m));
        }
    }
    if landings.is_empty() {
        return 0.0;
    }
    let standoffs = landings.len() as f64 * config.standoff_m;
    match start {
        Some(s) => ends.push(s),
        None => {
            // A free start: the first landing costs nothing; drop the largest-cost row
            // is not cheap to find exactly, so use the start at the first landing.
            ends.push(landings[0]);
        }
    }
    assign(&landings, &ends, AssignmentMethod::Exact)
        .map(|a| a.cost_m)
        .unwrap_or(0.0)
        + standoffs
}
