//! Assignment capability: the large-N fast path (auction) reaches the same
//! optimum as the dense reference on the benchmark blocks, `Exact` switches
//! to it above the threshold, and bad input is a typed error.

use nalgebra::Vector2;
use nanopush::plan::assignment::{
    AssignmentError, AssignmentMethod, EXACT_SPARSE_MAX_PAIRS, assign, auction, block_instance,
    dense_jv,
};

fn block(n: usize, seed: u64) -> (Vec<Vector2<f64>>, Vec<Vector2<f64>>) {
    let (sites, layout) = block_instance(n, seed);
    (sites, layout.particles.iter().map(|p| p.centre_m).collect())
}

#[test]
fn auction_equals_the_dense_optimum_on_benchmark_blocks() {
    for (n, seed) in [(120, 1), (300, 7)] {
        let (sites, parts) = block(n, seed);
        let fast = assign(&sites, &parts, AssignmentMethod::Auction).unwrap();
        let dense = assign(&sites, &parts, AssignmentMethod::Dense).unwrap();
        let greedy = assign(&sites, &parts, AssignmentMethod::Greedy).unwrap();
        // Rounding each distance to diag / 1e9 bounds the excess by n * diag / 1e9.
        assert!(
            fast.cost_m <= dense.cost_m * (1.0 + 1e-9),
            "n {n}: auction {} dense {}",
            fast.cost_m,
            dense.cost_m
        );
        assert!(fast.cost_m >= dense.cost_m * (1.0 - 1e-12));
        assert!(greedy.cost_m > fast.cost_m, "greedy is not optimal here");
        let mut used = fast.site_to_particle.clone();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), n);
    }
}

#[test]
fn exact_uses_the_fast_path_above_the_threshold_and_agrees_with_it() {
    let (sites, parts) = block(150, 2);
    assert!(sites.len() * parts.len() > EXACT_SPARSE_MAX_PAIRS);
    let exact = assign(&sites, &parts, AssignmentMethod::Exact).unwrap();
    assert_eq!(exact.site_to_particle, auction::solve(&sites, &parts));
    let dense = dense_jv::solve(&sites, &parts, |s, p| (sites[s] - parts[p]).norm());
    let dense_cost: f64 = dense
        .iter()
        .enumerate()
        .map(|(s, &p)| (sites[s] - parts[p]).norm())
        .sum();
    assert!((exact.cost_m - dense_cost).abs() <= 1e-9 * dense_cost);
}

#[test]
fn bad_input_is_a_typed_error() {
    let sites = [Vector2::new(0.0, 0.0), Vector2::new(f64::NAN, 1.0)];
    let parts = [
        Vector2::new(0.0, 0.0),
        Vector2::new(1.0, 1.0),
        Vector2::new(2.0, 2.0),
    ];
    for method in [
        AssignmentMethod::Exact,
        AssignmentMethod::Auction,
        AssignmentMethod::Greedy,
    ] {
        assert_eq!(
            assign(&sites, &parts, method),
            Err(AssignmentError::NotFinite {
                what: "site",
                index: 1
            })
        );
        assert!(matches!(
            assign(&parts, &sites[..1], method),
            Err(AssignmentError::TooFewParticles {
                sites: 3,
                particles: 1
            })
        ));
    }
    let inf = [Vector2::new(0.0, f64::INFINITY)];
    assert_eq!(
        assign(&sites[..1], &inf, AssignmentMethod::Auction),
        Err(AssignmentError::NotFinite {
            what: "particle",
            index: 0
        })
    );
}
