//! Particles the tip cannot push in any direction from where they lie.
//!
//! In a dense cluster the gaps can be narrower than the tip: no push
//! direction has room for the tip to land behind a particle and for the
//! particle to move ahead. The planner then refuses, and its reason names a
//! blocked move; saying how many particles are locked, and which, tells the
//! user that the cluster itself is the obstacle (clear it by other means,
//! or use a finer tip), not the pattern or its placement.

use super::PlanConfig;
use super::grid::Grid;
use super::layout::Layout;
use super::pushes::Corridor;
use nalgebra::Vector2;

/// Push directions tried per particle (every 5 degrees).
const DIRECTIONS: usize = 72;
/// Length of the probing push: short, so that "locked" means boxed in where
/// the particle lies, not a path blocked further on.
const PROBE_M: f64 = 1e-6;

/// Indices of the movable particles with no free push of `PROBE_M` in any
/// of `DIRECTIONS` directions (the corridor test of the planner: tip
/// landing, tip and particle paths clear of every other particle by the
/// clearance). A particle no plan may push (`PlanConfig::immovable`: cut by
/// the frame's edge, beside the probe, given up on) is an obstacle here,
/// never counted as locked.
pub fn locked_particles(layout: &Layout, config: &PlanConfig) -> Vec<usize> {
    let particles = &layout.particles;
    let max_radius = layout.max_radius_m();
    let grid = Grid::new(particles.iter().map(|p| p.centre_m), 2.0 * max_radius);
    let reach = max_radius + config.clearance_m;
    (0..particles.len())
        .filter(|&i| !config.immovable.contains(&particles[i].id))
        .filter(|&i| {
            let p = &particles[i];
            !(0..DIRECTIONS).any(|k| {
                let angle = k as f64 * std::f64::consts::TAU / DIRECTIONS as f64;
                let to = p.centre_m + Vector2::new(angle.cos(), angle.sin()) * PROBE_M;
                let corridor = Corridor::new(p.centre_m, to, p.radius_m, config);
                let (a, b, r) = corridor.spine_m;
                grid.for_each_near_segment(a, b, r + reach, |j| {
                    let q = &particles[j];
                    j == i || !corridor.hits(q.centre_m, q.radius_m, config.clearance_m)
                })
            })
        })
        .collect()
}

/// A sentence for a refusal: how many of the movable particles are locked
/// and the first few ids; empty when none is.
pub fn locked_note(layout: &Layout, config: &PlanConfig) -> String {
    let locked = locked_particles(layout, config);
    if locked.is_empty() {
        return String::new();
    }
    let ids: Vec<String> = locked
        .iter()
        .take(8)
        .map(|&i| layout.particles[i].id.to_string())
        .collect();
    let more = if locked.len() > ids.len() {
        ", ..."
    } else {
        ""
    };
    let movable = layout
        .particles
        .iter()
        .filter(|p| !config.immovable.contains(&p.id))
        .count();
    format!(
        "; {} of the {movable} movable particles cannot be pushed even {:.0} um in any direction from where they lie (boxed in, or no room for the {:.1} um tip behind them; ids {}{more})",
        locked.len(),
        PROBE_M * 1e6,
        2.0 * config.tip_radius_m * 1e6,
        ids.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hexagonal block at 1 um gaps: the tip (2 um across) fits behind
    /// none of the inner particles; a lone particle and a wide lattice are free.
    #[test]
    fn a_dense_cluster_is_locked_and_a_sparse_one_is_not() {
        let config = PlanConfig::default();
        let hex = |pitch: f64| -> Vec<(f64, f64)> {
            (0..5)
                .flat_map(|row| {
                    (0..5).map(move |col| {
                        let shift = if row % 2 == 1 { pitch / 2.0 } else { 0.0 };
                        (
                            50.0 + col as f64 * pitch + shift,
                            50.0 + row as f64 * pitch * 3f64.sqrt() / 2.0,
                        )
                    })
                })
                .collect()
        };
        let dense = Layout::of_test_centres_um(&hex(11.0));
        let locked = locked_particles(&dense, &config);
        // The 9 inner particles (rows and columns 1-3) have six neighbours.
        for row in 1..4 {
            for col in 1..4 {
                assert!(locked.contains(&(row * 5 + col)), "{row},{col}: {locked:?}");
            }
        }
        assert!(locked.len() < 25, "a corner has room behind it");
        let note = locked_note(&dense, &config);
        assert!(
            note.contains(&format!("{} of the 25 movable particles", locked.len())),
            "{note}"
        );
        // Particles no plan may push are obstacles, neither counted nor
        // named: the centre (id 12) and a corner (id 0).
        let held = PlanConfig {
            immovable: vec![0, 12],
            ..PlanConfig::default()
        };
        let locked_held = locked_particles(&dense, &held);
        assert!(!locked_held.contains(&12) && !locked_held.contains(&0));
        assert_eq!(locked_held.len(), locked.len() - 1, "{locked_held:?}");
        let note = locked_note(&dense, &held);
        assert!(
            note.contains(&format!("{} of the 23 movable particles", locked.len() - 1)),
            "{note}"
        );
        assert!(locked_particles(&Layout::of_test_centres_um(&hex(14.0)), &config).is_empty());
        assert!(locked_note(&Layout::of_test_centres_um(&[(100.0, 100.0)]), &config).is_empty());
    }
}
