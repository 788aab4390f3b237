//! Assignment of particles to sites minimising total straight-line push distance.
//!
//! Methods (see `nanopush study plan` for what each costs):
//! - [`sparse_ssp`]: exact shortest augmenting paths that look at a site's
//!   particles lazily, nearest first; what `Exact` runs on small instances
//!   (up to [`EXACT_SPARSE_MAX_PAIRS`] site-particle pairs).
//! - [`auction`]: the large-N fast path, an epsilon-scaling forward/reverse
//!   auction on integer costs (distances rounded to diag / 1e9), exact for
//!   the rounded costs; what `Exact` runs above the threshold.
//! - [`dense_jv`]: the textbook dense shortest-augmenting-path method
//!   (Jonker-Volgenant / Crouse, what scipy runs); the reference for tests.
//! - [`greedy`]: nearest free particle, site by site; a baseline.
//! - [`with_parking`]: adds the cost of clearing unassigned particles off
//!   the sites (what the planner uses when a site is covered).
//! - [`lp`]: a linear program solved with clarabel for side constraints
//!   (forbidden pairs, size classes) and the bottleneck (min-max) variant.
//!
//! Written by hand: no maintained Rust crate solves rectangular real-valued
//! assignment sparsely; the LP goes through clarabel.

pub mod auction;
pub(crate) mod buckets;
pub mod dense_jv;
pub mod dual_bound;
pub mod greedy;
pub mod instance;
pub mod lp;
pub mod sparse_ssp;
pub(crate) mod weighted_nearest;
pub mod with_parking;

use nalgebra::Vector2;

pub use instance::{block_instance, instance_json, read_instance_json};

/// Which assignment method to run.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum AssignmentMethod {
    /// Exact: sparse shortest augmenting paths up to 5,000 site x particle
    /// pairs, the epsilon-scaling auction above.
    Exact,
    /// Epsilon-scaling auction at any size (exact for distances rounded to diag / 1e9).
    Auction,
    /// The large-N fast path (the planner's default): exact up to 5,000
    /// pairs; above, the auction stopped at a proven gap of 0.01 %, with
    /// its dual bound as the lower bound.
    Fast,
    /// Exact, dense Jonker-Volgenant style; O(n^2 m), reference only.
    Dense,
    /// Greedy nearest particle; a fast assignment, not optimal (a plan
    /// from it pushes further, and its crossings take longer to order).
    Greedy,
    /// Linear program through clarabel (side constraints); small N only.
    Lp,
}

/// Result of an assignment: for every site, the index of its particle.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    /// `site_to_particle(s)` is the particle index assigned to site `s`.
    pub site_to_particle: Vec<usize>,
    /// Sum of straight-line distances, metres.
    pub cost_m: f64,
    /// A proven lower bound of the optimal cost, metres: the cost itself for
    /// exact methods, the dual bound for `Fast`; None for greedy.
    pub lower_bound_m: Option<f64>,
}

/// Refuses `sites` sites for `particles` particles with the assignment's
/// own words, for a command that can count both before any work (`demo`
/// and `study assemble` had run, or simulated a push, before the run
/// found it).
pub fn enough_particles(sites: usize, particles: usize) -> Result<(), AssignmentError> {
    if sites > particles {
        return Err(AssignmentError::TooFewParticles { sites, particles });
    }
    Ok(())
}

/// Ways an assignment can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AssignmentError {
    /// More sites than particles.
    #[error("{} but only {}: cannot fill the pattern", crate::wording::counted(*sites, "site"), crate::wording::counted(*particles, "particle"))]
    TooFewParticles {
        /// Number of sites.
        sites: usize,
        /// Number of particles.
        particles: usize,
    },
    /// Side constraints leave some site with no admissible particle set.
    #[error("no assignment satisfies the constraints ({0})")]
    Infeasible(String),
    /// A coordinate is NaN or infinite.
    #[error("{what} {index} has a non-finite coordinate")]
    NotFinite {
        /// "site" or "particle".
        what: &'static str,
        /// Index of the point.
        index: usize,
    },
    /// The LP solver did not converge.
    #[error("LP solver failed: {0}")]
    Solver(String),
}

/// Euclidean distance between two points.
pub(crate) fn dist(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    (a - b).norm()
}

/// Total cost of a site->particle assignment. Folded from +0.0: `sum`
/// starts at -0.0, and a plan with nothing to push printed "LB_push -0.0 um".
pub fn assignment_cost(sites: &[Vector2<f64>], particles: &[Vector2<f64>], s2p: &[usize]) -> f64 {
    s2p.iter()
        .enumerate()
        .fold(0.0, |total, (s, &p)| total + dist(&sites[s], &particles[p]))
}

/// Largest sites x particles instance `Exact` solves with [`sparse_ssp`]; above
/// it the auction is faster (measured in `nanopush study plan`).
pub const EXACT_SPARSE_MAX_PAIRS: usize = 5_000;

/// Proven relative gap at which `Fast` stops the auction: 0.01 %, far below
/// what detours add to a plan.
pub const FAST_REL_GAP: f64 = 1e-4;

/// Assigns particles to sites with `method`, minimising total distance.
pub fn assign(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    method: AssignmentMethod,
) -> Result<Assignment, AssignmentError> {
    enough_particles(sites.len(), particles.len())?;
    for (what, points) in [("site", sites), ("particle", particles)] {
        if let Some(index) = points
            .iter()
            .position(|p| !(p.x.is_finite() && p.y.is_finite()))
        {
            return Err(AssignmentError::NotFinite { what, index });
        }
    }
    let small = sites.len() * particles.len() <= EXACT_SPARSE_MAX_PAIRS;
    let mut lower_bound_m = None;
    let s2p = match method {
        AssignmentMethod::Exact | AssignmentMethod::Fast if small => {
            sparse_ssp::solve(sites, particles)
        }
        AssignmentMethod::Fast => {
            let within = auction::solve_within(sites, particles, FAST_REL_GAP);
            lower_bound_m = Some(within.lower_bound_m);
            within.site_to_particle
        }
        AssignmentMethod::Exact | AssignmentMethod::Auction => auction::solve(sites, particles),
        AssignmentMethod::Dense => {
            dense_jv::solve(sites, particles, |s, p| dist(&sites[s], &particles[p]))
        }
        AssignmentMethod::Greedy => greedy::solve(sites, particles),
        AssignmentMethod::Lp => lp::solve(sites, particles, &lp::SideConstraints::default())?,
    };
    let cost_m = assignment_cost(sites, particles, &s2p);
    if method != AssignmentMethod::Greedy {
        lower_bound_m = lower_bound_m.or(Some(cost_m));
    }
    Ok(Assignment {
        site_to_particle: s2p,
        cost_m,
        lower_bound_m,
    })
}

#[cfg(test)]
pub(crate) mod test_support {
    use nalgebra::Vector2;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random points in a square, seeded.
    pub fn random_points(n: usize, side: f64, seed: u64) -> Vec<Vector2<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| Vector2::new(rng.random::<f64>() * side, rng.random::<f64>() * side))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::random_points;
    use super::*;

    /// Nothing to assign costs +0: a plan with no push had printed
    /// "LB_push -0.0 um" (an empty `sum` of f64 is -0.0).
    #[test]
    fn an_empty_assignment_costs_plus_zero() {
        let parts = random_points(3, 100.0, 1);
        let a = assign(&[], &parts, AssignmentMethod::Exact).unwrap();
        assert!(
            a.cost_m == 0.0 && a.cost_m.is_sign_positive(),
            "{}",
            a.cost_m
        );
        let lb = a.lower_bound_m.unwrap();
        assert!(lb.is_sign_positive(), "{lb}");
    }

    #[test]
    fn exact_methods_agree_and_greedy_is_not_better() {
        for seed in 0..20 {
            let sites = random_points(25, 100.0, seed);
            let parts = random_points(40, 100.0, seed + 1000);
            let a = assign(&sites, &parts, AssignmentMethod::Exact).unwrap();
            let b = assign(&sites, &parts, AssignmentMethod::Dense).unwrap();
            let g = assign(&sites, &parts, AssignmentMethod::Greedy).unwrap();
            assert!(
                (a.cost_m - b.cost_m).abs() < 1e-9 * b.cost_m,
                "seed {seed}: {} vs {}",
                a.cost_m,
                b.cost_m
            );
            assert!(g.cost_m >= b.cost_m - 1e-9);
            let mut used = a.site_to_particle.clone();
            used.sort();
            used.dedup();
            assert_eq!(used.len(), sites.len(), "each particle used at most once");
        }
    }

    #[test]
    fn fast_is_within_its_gap_and_its_bound_is_below_the_optimum() {
        for seed in 0..6 {
            // 120 x 200 = 24,000 pairs: above the sparse threshold, so the
            // auction stops at its gap.
            let sites = random_points(120, 1000.0, seed);
            let parts = random_points(200, 1000.0, seed + 100);
            let opt = assign(&sites, &parts, AssignmentMethod::Dense)
                .unwrap()
                .cost_m;
            let fast = assign(&sites, &parts, AssignmentMethod::Fast).unwrap();
            let lb = fast.lower_bound_m.unwrap();
            // The auction's rounding: n costs of diag / 1e9 each.
            let rounding = 120.0 * 1000.0 * 2f64.sqrt() * 1e-9;
            assert!(
                lb <= opt + 1e-9 * opt,
                "seed {seed}: bound {lb} above {opt}"
            );
            assert!(fast.cost_m >= opt - 1e-9 * opt, "seed {seed}");
            assert!(
                fast.cost_m <= opt * (1.0 + FAST_REL_GAP) + rounding,
                "seed {seed}: {} against the optimum {opt}",
                fast.cost_m
            );
            assert!(
                fast.cost_m * (1.0 - FAST_REL_GAP) <= lb + rounding,
                "seed {seed}: the bound {lb} is not within the gap of {}",
                fast.cost_m
            );
            let mut used = fast.site_to_particle.clone();
            used.sort();
            used.dedup();
            assert_eq!(used.len(), sites.len(), "each particle used at most once");
        }
    }

    #[test]
    fn too_few_particles_is_an_error() {
        let sites = random_points(5, 10.0, 1);
        let parts = random_points(4, 10.0, 2);
        assert!(matches!(
            assign(&sites, &parts, AssignmentMethod::Exact),
            Err(AssignmentError::TooFewParticles { .. })
        ));
    }
}
