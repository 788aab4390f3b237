//! Detours forced by the particles that never move.
//!
//! A particle already on its site (or one the executor gave up on) stays
//! where it is for the whole plan, so a pair whose straight push runs into
//! it can only be made by a detour. The plain assignment prices that pair
//! at its straight line; the order then pays the detour or trades the site
//! away (CMU seed 76: particle 11's straight way ran through the particle
//! sitting on the site below its own, and the trades the order made
//! instead added 24 um). Priced up front, the assignment weighs the detour
//! against the other pairs.

use super::PlanConfig;
use super::layout::Layout;
use super::peel::SiteObstacles;
use super::pushes::Corridor;
use super::route::{Reach, find_route, route_length};
use nalgebra::Vector2;
use rustc_hash::FxHashMap;

/// What each (free particle, free site) pair pays beyond its straight line
/// to get around the `fixed` particles (layout indices), keyed by the
/// indices into `free_particles` and `sites`; pairs with a free straight
/// way are left out, and so are pairs longer than `longest_m` (the plain
/// assignment's longest pair: the longer ones hardly ever enter an optimum,
/// and searching their routes took 99 % of the time, up to 24 ms on a CMU
/// layout, for the same plans). A pair with no route of at most two
/// waypoints pays the field's width plus height (taken only when nothing
/// else fills the site).
pub fn fixed_detours(
    layout: &Layout,
    fixed: &[usize],
    free_particles: &[usize],
    sites: &[Vector2<f64>],
    longest_m: f64,
    config: &PlanConfig,
) -> FxHashMap<(usize, usize), f64> {
    let mut out = FxHashMap::default();
    if fixed.is_empty() {
        return out;
    }
    let particles = &layout.particles;
    let discs = fixed
        .iter()
        .map(|&f| (particles[f].centre_m, particles[f].radius_m));
    let obstacles = SiteObstacles::new(Vec::new(), Vec::new(), discs.collect(), config);
    let free = |c: &Corridor| obstacles.misses(c, |_| false);
    let reach = Reach::of_layout(layout);
    let no_route_m = layout.field_m[0] + layout.field_m[1];
    for (j, &p) in free_particles.iter().enumerate() {
        let (from, radius) = (particles[p].centre_m, particles[p].radius_m);
        for (k, &to) in sites.iter().enumerate() {
            if (to - from).norm() > longest_m || free(&Corridor::new(from, to, radius, config)) {
                continue;
            }
            let extra = find_route(from, to, radius, config, reach, &free)
                .map_or(no_route_m, |route| {
                    route_length(from, &route) - (to - from).norm()
                });
            out.insert((j, k), extra);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Particle;

    fn particle(id: u32, x_um: f64, y_um: f64) -> Particle {
        Particle {
            id,
            centre_m: Vector2::new(x_um, y_um) * 1e-6,
            radius_m: 5e-6,
        }
    }

    /// A fixed particle at (50, 50) sits on the straight way of particle 0
    /// (x = 20) to a site at x = 80: that pair pays a detour, more than
    /// nothing and less than going round the field; the other three pairs
    /// (particle 0 up to (20, 65), particle 1 from y = 80 to either site)
    /// pass clear of it and pay nothing. Without fixed particles, or with
    /// the blocked pair longer than the longest one priced, nothing is.
    #[test]
    fn only_pairs_through_a_fixed_particle_pay_their_detour() {
        let layout = Layout {
            field_m: [100e-6, 100e-6],
            particles: vec![
                particle(0, 20.0, 50.0),
                particle(1, 20.0, 80.0),
                particle(2, 50.0, 50.0),
            ],
        };
        let sites = [Vector2::new(80e-6, 50e-6), Vector2::new(20e-6, 65e-6)];
        let config = PlanConfig::default();
        let detours = fixed_detours(&layout, &[2], &[0, 1], &sites, f64::INFINITY, &config);
        assert_eq!(detours.len(), 1, "{detours:?}");
        let extra = detours[&(0, 0)];
        assert!(extra > 1e-6 && extra < 60e-6, "detour {extra}");
        assert!(fixed_detours(&layout, &[], &[0, 1], &sites, f64::INFINITY, &config).is_empty());
        // The 60 um pair is longer than a 50 um longest pair: not priced.
        assert!(fixed_detours(&layout, &[2], &[0, 1], &sites, 50e-6, &config).is_empty());
    }
}
