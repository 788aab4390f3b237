//! The tip's footprint and landing, scaled to the particles.
//!
//! [`PlanConfig`]'s defaults (a 1 um tip disc landing 1 um behind the
//! contact point, nearer down to 0.25 um) are drawn for 10 um spheres. Kept
//! for 1 um spheres, the disc was as wide as the particles: a field of them
//! 0.2 um apart left it no room behind most, and `plan` refused after 75-184 s
//! of placements what a 0.2 um disc planned in 0.4-8.5 s. A conical tip's
//! cross-section at the particles' height shrinks with that height, so the
//! same geometry scaled to the particle is what a lab would draw; the landing
//! never comes nearer than the corridor's clearance (the free space every
//! corridor keeps anyway).

use super::PlanConfig;

/// Particle radius the defaults are drawn for (10 um spheres); larger
/// particles keep them.
pub const DEFAULT_GEOMETRY_RADIUS_M: f64 = 5e-6;

impl PlanConfig {
    /// This config with the tip disc, standoff and nearest standoff of the
    /// defaults scaled by `particle_radius_m / 5 um` where that is below 1
    /// (the standoffs not below the clearance). A radius that is not finite
    /// and positive leaves the config as it is (the layout check refuses it).
    pub fn with_tip_scaled_to(self, particle_radius_m: f64) -> Self {
        let scale = particle_radius_m / DEFAULT_GEOMETRY_RADIUS_M;
        // 5 um read from a file in um is 4.999999999999999e-6 m: no scaling.
        if !(scale.is_finite() && scale > 0.0) || scale > 1.0 - 1e-9 {
            return self;
        }
        let base = PlanConfig::default();
        let standoff_m = (base.standoff_m * scale).max(self.clearance_m);
        PlanConfig {
            tip_radius_m: base.tip_radius_m * scale,
            standoff_m,
            min_standoff_m: (base.min_standoff_m * scale)
                .max(self.clearance_m)
                .min(standoff_m),
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ten_micron_spheres_and_larger_keep_the_defaults() {
        let base = PlanConfig::default();
        assert_eq!(base.clone().with_tip_scaled_to(5e-6), base);
        assert_eq!(base.clone().with_tip_scaled_to(5.0 * 1e-6), base);
        assert_eq!(base.clone().with_tip_scaled_to(4.999999999999999e-6), base);
        assert_eq!(base.clone().with_tip_scaled_to(50e-6), base);
        assert_eq!(base.clone().with_tip_scaled_to(f64::NAN), base);
        assert_eq!(base.clone().with_tip_scaled_to(0.0), base);
    }

    #[test]
    fn small_particles_get_a_tip_scaled_with_them_landing_no_nearer_than_the_clearance() {
        let one_micron = PlanConfig::default().with_tip_scaled_to(1e-6);
        assert!((one_micron.tip_radius_m - 0.2e-6).abs() < 1e-15);
        assert!((one_micron.standoff_m - 0.2e-6).abs() < 1e-15);
        assert!((one_micron.min_standoff_m - 0.1e-6).abs() < 1e-15);
        let tiny = PlanConfig::default().with_tip_scaled_to(0.1e-6);
        assert!((tiny.tip_radius_m - 0.02e-6).abs() < 1e-15);
        assert_eq!(tiny.standoff_m, tiny.clearance_m);
        assert_eq!(tiny.min_standoff_m, tiny.clearance_m);
        assert!(tiny.validate().is_ok());
    }
}
