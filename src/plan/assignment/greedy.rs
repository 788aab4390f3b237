//! Greedy assignment: every (site, particle) pair in order of distance, taken
//! when both are still free. A baseline for the study, not optimal.

use super::dist;
use nalgebra::Vector2;

/// Greedy nearest-pair assignment over the k nearest particles of each site
/// (k grows until every site is served).
pub fn solve(sites: &[Vector2<f64>], particles: &[Vector2<f64>]) -> Vec<usize> {
    let grid = crate::plan::grid::Grid::new(particles.iter().copied(), 0.0);
    let mut k = 16;
    loop {
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (s, site) in sites.iter().enumerate() {
            for (d, p) in grid.nearest(*site, k) {
                pairs.push((d, s, p));
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut s2p = vec![usize::MAX; sites.len()];
        let mut taken = vec![false; particles.len()];
        for (_, s, p) in pairs {
            if s2p[s] == usize::MAX && !taken[p] {
                s2p[s] = p;
                taken[p] = true;
            }
        }
        if s2p.iter().all(|&p| p != usize::MAX) || k >= particles.len() {
            // Any site still unserved takes the nearest free particle.
            for s in 0..sites.len() {
                if s2p[s] == usize::MAX {
                    let best = (0..particles.len())
                        .filter(|&p| !taken[p])
                        .min_by(|&a, &b| {
                            dist(&sites[s], &particles[a])
                                .total_cmp(&dist(&sites[s], &particles[b]))
                        });
                    if let Some(p) = best {
                        s2p[s] = p;
                        taken[p] = true;
                    }
                }
            }
            return s2p;
        }
        k *= 4;
    }
}
