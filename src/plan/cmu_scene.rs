//! The CMU acceptance scenes of issue 4: a seeded layout of 40-60 particles
//! (10 um, gaps >= 1 um, 120 x 100 um) with the "CMU" sites placed where
//! the plan pushes least (as `nanopush plan` places them without `--at`).
//! The acceptance tests and the benchmark take them from here, so both
//! measure the same 100 layouts.

use super::PlanConfig;
use super::Site;
use super::layout::Layout;
use super::pattern::transform::Reachable;
use super::pattern::{Pattern, PatternError};
use super::placement::{PlacementGoal, place_by_plan};
use super::synth_layout::{LayoutKind, SynthError, SynthParams, synth_layout};

/// Particle radius of the scenes, metres.
const RADIUS_M: f64 = 5e-6;
/// Site pitch: a particle diameter plus 0.5 um (the default gap).
const PITCH_M: f64 = 10.5e-6;

/// Why a scene could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The layout generator failed.
    #[error(transparent)]
    Synth(#[from] SynthError),
    /// The pattern could not be placed.
    #[error(transparent)]
    Pattern(#[from] PatternError),
}

/// Particles in the scene of `seed`: 40 to 60, spread over the seeds.
pub fn particle_count(seed: u64) -> usize {
    40 + (seed as usize * 13) % 21
}

/// The layout of `kind` and `seed` and its CMU sites.
pub fn cmu_scene(kind: LayoutKind, seed: u64) -> Result<(Layout, Vec<Site>), SceneError> {
    let pattern = Pattern::from_text("CMU", PITCH_M)?;
    let layout = synth_layout(&SynthParams::cmu_field(particle_count(seed), kind, seed))?;
    let area = Reachable::for_field(layout.field_m, RADIUS_M);
    let config = PlanConfig::default();
    let sites = place_by_plan(&pattern, &area, &layout, &config, PlacementGoal::LeastPush)?;
    Ok((layout, sites))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The seeds span 40 to 60 particles, and a scene has one particle
    /// count, field and 31 sites inside it.
    #[test]
    fn scenes_span_40_to_60_particles_and_hold_the_31_sites() {
        let counts: Vec<usize> = (0..100).map(particle_count).collect();
        assert_eq!(counts.iter().min(), Some(&40));
        assert_eq!(counts.iter().max(), Some(&60));
        let (layout, sites) = cmu_scene(LayoutKind::Uniform, 7).unwrap();
        assert_eq!(layout.particles.len(), particle_count(7));
        assert_eq!(sites.len(), 31);
        // Within 1 pm: a site placed against the edge is the centre plus its
        // offset, rounded (the tolerance `place_at` also allows).
        let inside = |v: f64, hi: f64| v >= RADIUS_M - 1e-12 && v <= hi - RADIUS_M + 1e-12;
        for s in &sites {
            assert!(inside(s.centre_m.x, layout.field_m[0]), "{:?}", s.centre_m);
            assert!(inside(s.centre_m.y, layout.field_m[1]), "{:?}", s.centre_m);
        }
    }
}
