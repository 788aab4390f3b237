//! Cantilever springs of a rectangular beam with a tip of height H
//! (spec section 2, eq. 1), and the twist of the tip in a reduced form.

use super::units::Radians;

/// A rectangular cantilever with its tip; all SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cantilever {
    /// Beam length L.
    pub length_m: f64,
    /// Beam width w.
    pub width_m: f64,
    /// Beam thickness t.
    pub thickness_m: f64,
    /// Young's modulus of the beam.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio of the beam.
    pub poisson_ratio: f64,
    /// Tip height H (lever arm of torsion).
    pub tip_height_m: f64,
}

/// The three springs the push sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Springs {
    /// K_z = E w t^3 / (4 L^3): normal bending stiffness.
    pub normal_n_per_m: f64,
    /// K_theta = E w t^3 / (6 L (1 + nu)): torsional stiffness.
    pub torsional_nm_per_rad: f64,
    /// k_y = K_theta / H^2: lateral stiffness at the tip apex.
    pub lateral_n_per_m: f64,
}

impl Cantilever {
    /// Springs of eq. (1); inputs are validated positive by the scene.
    pub fn springs(&self) -> Springs {
        let ewt3 = self.youngs_modulus_pa * self.width_m * self.thickness_m.powi(3);
        let k_z = ewt3 / (4.0 * self.length_m.powi(3));
        let k_theta = ewt3 / (6.0 * self.length_m * (1.0 + self.poisson_ratio));
        Springs {
            normal_n_per_m: k_z,
            torsional_nm_per_rad: k_theta,
            lateral_n_per_m: k_theta / (self.tip_height_m * self.tip_height_m),
        }
    }
}

/// Lateral force at the apex for a twist `theta`: F_y = K_theta theta / (H cos theta).
///
/// This is the reduced form of the source's eq. (4), which divides the moment
/// by sin(theta) and is 0/0 at theta = 0 (spec case 1); written with theta
/// itself it is finite there and tends to k_y H theta. Returns `None` at or
/// beyond 90 deg, where the tip has slipped (spec case 2).
pub fn lateral_force_from_twist(
    springs: &Springs,
    tip_height_m: f64,
    theta: Radians,
) -> Option<f64> {
    let c = theta.0.cos();
    if !theta.0.is_finite() || c <= 1e-12 {
        return None;
    }
    Some(springs.torsional_nm_per_rad * theta.0 / (tip_height_m * c))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> Cantilever {
        Cantilever {
            length_m: 225e-6,
            width_m: 48e-6,
            thickness_m: 1e-6,
            youngs_modulus_pa: 169e9,
            poisson_ratio: 0.27,
            tip_height_m: 12e-6,
        }
    }

    #[test]
    fn springs_match_the_spec_figures() {
        let s = paper().springs();
        assert!(
            (s.normal_n_per_m - 0.178).abs() < 0.001,
            "{}",
            s.normal_n_per_m
        );
        assert!((s.torsional_nm_per_rad - 4.73e-9).abs() < 0.01e-9);
        assert!((s.lateral_n_per_m - 32.9).abs() < 0.1);
    }

    #[test]
    fn twist_force_is_finite_at_zero_and_tends_to_linear() {
        let c = paper();
        let s = c.springs();
        assert_eq!(
            lateral_force_from_twist(&s, c.tip_height_m, Radians(0.0)),
            Some(0.0)
        );
        let th = 1e-6;
        let f = lateral_force_from_twist(&s, c.tip_height_m, Radians(th)).unwrap();
        assert!((f / (s.lateral_n_per_m * c.tip_height_m * th) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn twist_at_ninety_degrees_is_refused() {
        let c = paper();
        let s = c.springs();
        let r = lateral_force_from_twist(&s, c.tip_height_m, Radians(std::f64::consts::FRAC_PI_2));
        assert_eq!(r, None);
    }
}
