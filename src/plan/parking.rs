//! Unassigned particles in the way: which ones cover a site, and how far
//! each must be pushed to clear it (the parking cost the assignment pays).

use super::grid::Grid;
use nalgebra::Vector2;

/// True if a disc at `centre_m` of `radius_m` comes closer than `clearance_m`
/// to a site (sites hold particles of `site_radius_m`).
pub fn covers_site(
    centre_m: Vector2<f64>,
    radius_m: f64,
    sites: &Grid,
    site_pts: &[Vector2<f64>],
    site_radius_m: f64,
    clearance_m: f64,
) -> bool {
    let reach = radius_m + site_radius_m + clearance_m;
    let mut hit = false;
    sites.for_each_within(centre_m, reach, |s| {
        if (site_pts[s] - centre_m).norm() < reach {
            hit = true;
        }
    });
    hit
}

/// Candidate spots around `centre`: 48 directions, distances from a quarter
/// to eight pitches (`pitch_m`) in quarter-pitch steps, nearest first.
pub fn ring(centre: Vector2<f64>, pitch_m: f64) -> Vec<Vector2<f64>> {
    let mut spots = Vec::with_capacity(32 * 48);
    for step in 1..=32 {
        let dist = pitch_m * step as f64 / 4.0;
        for a in 0..48 {
            let ang = std::f64::consts::TAU * a as f64 / 48.0;
            spots.push(centre + Vector2::new(ang.cos(), ang.sin()) * dist);
        }
    }
    spots
}

/// Length of the shortest ring move that takes particle `index` (of
/// `particles`, all of `radius_m`) off every site and off every other
/// particle, staying in `[lo, hi]`; `max_m` when none is found.
#[allow(clippy::too_many_arguments)]
pub fn park_cost(
    index: usize,
    particles: &[Vector2<f64>],
    particle_grid: &Grid,
    sites: &Grid,
    site_pts: &[Vector2<f64>],
    radius_m: f64,
    clearance_m: f64,
    lo: Vector2<f64>,
    hi: Vector2<f64>,
    max_m: f64,
) -> f64 {
    let from = particles[index];
    for spot in ring(from, 2.0 * radius_m + 1e-6) {
        if spot.x < lo.x || spot.y < lo.y || spot.x > hi.x || spot.y > hi.y {
            continue;
        }
        if covers_site(spot, radius_m, sites, site_pts, radius_m, clearance_m) {
            continue;
        }
        let mut free = true;
        particle_grid.for_each_within(spot, 2.0 * radius_m + clearance_m, |j| {
            if j != index {
                free = false;
            }
        });
        if free {
            return (spot - from).norm();
        }
    }
    max_m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_particle_on_a_site_pays_the_way_out_and_one_beside_it_pays_nothing() {
        let sites = vec![Vector2::new(50.0, 50.0)];
        let sg = Grid::new(sites.clone(), 10.0);
        assert!(covers_site(
            Vector2::new(55.0, 50.0),
            5.0,
            &sg,
            &sites,
            5.0,
            0.1
        ));
        assert!(!covers_site(
            Vector2::new(61.0, 50.0),
            5.0,
            &sg,
            &sites,
            5.0,
            0.1
        ));
        let parts = vec![Vector2::new(55.0, 50.0)];
        let pg = Grid::new(parts.clone(), 10.0);
        let lo = Vector2::new(0.0, 0.0);
        let hi = Vector2::new(100.0, 100.0);
        let c = park_cost(0, &parts, &pg, &sg, &sites, 5.0, 0.1, lo, hi, 1e9);
        // It must end >= 10.1 from the site: at least 5.1 away, at most one ring step more.
        assert!((5.1..=5.1 + 2.75 + 1e-9).contains(&c), "cost {c}");
    }
}
