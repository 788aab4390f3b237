//! How near the plan leaves the particles it puts on no site to the
//! pattern's: a stray beside a letter reads as part of it, so the
//! placement prefers a centre whose plan keeps
//! [`PlanConfig::keep_clear_m`](super::PlanConfig::keep_clear_m).
//! (`verify.rs` measures the same on its own replay, for its report, and
//! a run's report on where the particles end: all by [`least_gap_m`].)

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
    let strays = (layout.particles.iter())
        .filter(|p| !on_site.contains(&p.id))
        .map(|p| (ends.get(&p.id).copied().unwrap_or(p.centre_m), p.radius_m));
    least_gap_m(strays, &filled)
}

/// Least free space, metres, between any of `strays` and any of
/// `pattern` (discs: centre, radius); None when either is empty. The one
/// measure the planner, `verify-plan` and a run's report share.
pub fn least_gap_m(
    strays: impl IntoIterator<Item = (Vector2<f64>, f64)>,
    pattern: &[(Vector2<f64>, f64)],
) -> Option<f64> {
    strays
        .into_iter()
        .flat_map(|(at, r)| pattern.iter().map(move |(c, rc)| (at - c).norm() - r - rc))
        .min_by(f64::total_cmp)
}

/// The same where a run ends, from where the particles are seen (or are,
/// on the simulated rig): a site's particle is the one nearest it, when
/// within its own radius of the site; every other particle is a stray.
/// None when no site is filled or nothing else is there.
pub fn seen_stray_gap_m(sites: &[Vector2<f64>], particles: &[(Vector2<f64>, f64)]) -> Option<f64> {
    let nearest = |site: &Vector2<f64>| {
        (0..particles.len())
            .min_by(|&a, &b| {
                let d = |i: usize| (particles[i].0 - site).norm();
                d(a).total_cmp(&d(b))
            })
            .filter(|&i| (particles[i].0 - site).norm() <= particles[i].1)
    };
    let on_site: std::collections::BTreeSet<usize> = sites.iter().filter_map(nearest).collect();
    let pattern: Vec<(Vector2<f64>, f64)> = on_site.iter().map(|&i| particles[i]).collect();
    let strays = (0..particles.len())
        .filter(|i| !on_site.contains(i))
        .map(|i| particles[i]);
    least_gap_m(strays, &pattern)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(x_um: f64, y_um: f64, r_um: f64) -> (Vector2<f64>, f64) {
        (Vector2::new(x_um, y_um) * 1e-6, r_um * 1e-6)
    }

    /// A site's particle is the nearest one within its radius; the rest are
    /// strays, measured edge to edge from the site's particle, not the site.
    #[test]
    fn the_seen_gap_is_from_the_particles_on_sites_to_the_rest() {
        let sites = [Vector2::new(10e-6, 10e-6), Vector2::new(20e-6, 10e-6)];
        let on_first = disc(10.3, 10.0, 5.0);
        let on_second = disc(20.0, 10.0, 5.0);
        // 2 um right of the second's edge, and one 4 um above the first.
        let stray = disc(32.0, 10.0, 5.0);
        let high = disc(10.3, 24.0, 5.0);
        let gap = seen_stray_gap_m(&sites, &[on_first, stray, on_second, high]).unwrap();
        assert!((gap - 2e-6).abs() < 1e-12, "{gap}");
        // A site nobody is on leaves its nearest particle a stray: no
        // pattern, no gap.
        let off = [disc(20.0, 26.0, 5.0), disc(40.0, 10.0, 5.0)];
        assert_eq!(seen_stray_gap_m(&sites[1..], &off), None);
        assert_eq!(seen_stray_gap_m(&sites, &[on_first, on_second]), None);
        assert_eq!(seen_stray_gap_m(&sites, &[stray]), None);
    }
}
