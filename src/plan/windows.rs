//! Coarse-stage windows: the nanostage reaches +-range/2 around the coarse
//! stage's position. Pushes are kept in their order; whenever the next push's
//! tip path leaves the current window, a coarse move recentres the window on
//! that push (inserted before the tip travel that leads to it).

use super::pushes::{landing_point, tip_end};
use super::{PlanConfig, Step};
use nalgebra::Vector2;

/// True if both points lie within the window of `range_m` centred at `centre`.
pub fn fits(centre: Vector2<f64>, points: &[Vector2<f64>], range_m: f64) -> bool {
    points.iter().all(|p| {
        (p.x - centre.x).abs() <= range_m / 2.0 + 1e-12
            && (p.y - centre.y).abs() <= range_m / 2.0 + 1e-12
    })
}

/// Inserts coarse moves where needed; returns how many (0 when one window holds every push).
pub fn insert_coarse_moves(steps: &mut Vec<Step>, config: &PlanConfig) -> usize {
    let mut pts_all = Vec::new();
    for s in steps.iter() {
        if let Step::Push {
            from_m,
            to_m,
            approach_m,
            ..
        } = s
        {
            pts_all.push(landing_point(*from_m, *to_m, *approach_m, config));
            pts_all.push(tip_end(*from_m, *to_m, *approach_m));
        }
    }
    if pts_all.is_empty() {
        return 0;
    }
    let (lo, hi) = super::pattern::bbox(&pts_all);
    if fits((lo + hi) / 2.0, &pts_all, config.nanostage_range_m) {
        return 0;
    }
    let mut out = Vec::with_capacity(steps.len() + 16);
    let mut centre: Option<Vector2<f64>> = None;
    let mut count = 0;
    let mut pending_travel: Option<Step> = None;
    for s in steps.drain(..) {
        match &s {
            Step::TipTravel { .. } => pending_travel = Some(s),
            Step::Push {
                from_m,
                to_m,
                approach_m,
                ..
            } => {
                let pts = [
                    landing_point(*from_m, *to_m, *approach_m, config),
                    tip_end(*from_m, *to_m, *approach_m),
                ];
                if centre.is_none_or(|c| !fits(c, &pts, config.nanostage_range_m)) {
                    let c = (pts[0] + pts[1]) / 2.0;
                    out.push(Step::CoarseMove { centre_m: c });
                    centre = Some(c);
                    count += 1;
                }
                out.extend(pending_travel.take());
                out.push(s);
            }
            Step::CoarseMove { .. } => out.push(s),
        }
    }
    out.extend(pending_travel);
    *steps = out;
    count
}
