//! Greedy assignment: (site, particle) pairs in order of distance, taken
//! when both are still free. A baseline for the study, not optimal.

use nalgebra::Vector2;

/// Greedy nearest-pair assignment in rounds: every unserved site offers its
/// `k` nearest particles, the pairs are taken in order of distance when both
/// are free, and the sites left unserved go to the next round with `4k`.
/// (Within a round this is the global greedy on those pairs; the rounds keep
/// it near-linear instead of sorting all n x m pairs.)
pub fn solve(sites: &[Vector2<f64>], particles: &[Vector2<f64>]) -> Vec<usize> {
    let grid = crate::plan::grid::Grid::new(particles.iter().copied(), 0.0);
    let mut s2p = vec![usize::MAX; sites.len()];
    let mut taken = vec![false; particles.len()];
    let mut unserved: Vec<usize> = (0..sites.len()).collect();
    let mut k = 16;
    while !unserved.is_empty() {
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for &s in &unserved {
            pairs.extend(
                grid.nearest(sites[s], k)
                    .into_iter()
                    .filter(|&(_, p)| !taken[p])
                    .map(|(d, p)| (d, s, p)),
            );
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, s, p) in pairs {
            if s2p[s] == usize::MAX && !taken[p] {
                s2p[s] = p;
                taken[p] = true;
            }
        }
        unserved.retain(|&s| s2p[s] == usize::MAX);
        if k >= particles.len() {
            // Every particle was offered: fewer particles than sites (caller's error).
            break;
        }
        k = (k * 4).min(particles.len());
    }
    s2p
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::*;

    #[test]
    fn every_site_gets_a_distinct_particle_and_the_closest_pair_is_taken() {
        let sites = random_points(200, 100.0, 1);
        let parts = random_points(220, 100.0, 2);
        let s2p = solve(&sites, &parts);
        let mut used = s2p.clone();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), 200);
        assert!(used.iter().all(|&p| p < 220));
        let (d, s, p) = (0..200)
            .flat_map(|s| (0..220).map(move |p| (s, p)))
            .map(|(s, p)| ((sites[s] - parts[p]).norm(), s, p))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        assert_eq!(s2p[s], p, "closest pair ({d}) taken");
    }
}
