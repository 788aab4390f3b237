//! How near the plan leaves the particles it puts on no site to the
//! pattern's: a stray beside a letter reads as part of it, so the
//! placement prefers a centre whose plan keeps
//! [`PlanConfig::keep_clear_m`](super::PlanConfig::keep_clear_m).
//! (`verify.rs` measures the same by its own replay, for the report.)

use super::{Layout, Plan};
use nalgebra::Vector2;
use rustc_hash::FxHashMap;

/// Least free space, metres, between a particle on no site, where its
/// last push leaves it, and a site's particle; None when every particle
/// is on a site.
pub fn nearest_stray_gap_m(plan: &Plan, layout: &Layout) -> Option<f64> {
    let mut ends: FxHashMap<u32, Vector2<f64>> = FxHashMap::default();
    for (id, _, to) in plan.steps.iter().filter_map(|s| s.push_move()) {
        ends.insert(id, to);
    }
    let radius: FxHashMap<u32, f64> = layout
        .particles
        .iter()
        .map(|p| (p.id, p.radius_m))
        .collect();
    let filled: Vec<(Vector2<f64>, f64)> = plan
        .assignment
        .iter()
        .filter_map(|&(p, s)| {
            let site = plan.sites.iter().find(|site| site.id == s)?;
            Some((site.centre_m, *radius.get(&p)?))
        })
        .collect();
    let on_site: std::collections::HashSet<u32> = plan.assignment.iter().map(|a| a.0).collect();
    layout
        .particles
        .iter()
        .filter(|p| !on_site.contains(&p.id))
        .flat_map(|p| {
            let at = ends.get(&p.id).copied().unwrap_or(p.centre_m);
            filled
                .iter()
                .map(move |(centre, r)| (at - centre).norm() - p.radius_m - r)
        })
        .min_by(f64::total_cmp)
}
