//! Motion criteria for sliding, rolling and spinning (spec section 2) in
//! margin form: each returns `drive - resistance` for a pushing force F, so
//! "moves" is `margin >= 0` and no division by a vanishing denominator ever
//! happens (spec case 3). The critical forces are the roots of these margins.

/// Friction laws of the particle-substrate (and tip-particle) contacts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionParams {
    /// mu: sliding friction coefficient.
    pub sliding_coefficient: f64,
    /// tau: interfacial shear strength (Pa).
    pub shear_strength_pa: f64,
    /// mu_r: rolling friction coefficient (m).
    pub rolling_coefficient_m: f64,
    /// tau_r: rolling shear strength [N/m].
    pub rolling_shear_n_per_m: f64,
}

/// Angles and lengths of the push.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushGeometry {
    /// psi: pushing-force angle from the substrate normal (rad).
    pub psi_rad: f64,
    /// phi: tip-particle contact-normal angle (rad).
    pub phi_rad: f64,
    /// R_p: particle radius.
    pub particle_radius_m: f64,
    /// Distance of the push line from the particle centre (spinning arm).
    pub offset_m: f64,
}

/// Force components on the particle for a pushing force F (spec section 2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Loads {
    /// f_s = F sin psi: lateral drive at the substrate.
    pub substrate_lateral_n: f64,
    /// F_s = F cos psi (+ extra normal load such as capillarity).
    pub substrate_normal_n: f64,
    /// f_t = F cos zeta = F sin(psi - phi): tip-particle friction.
    pub tip_friction_n: f64,
    /// F_t = -F sin zeta = F cos(psi - phi): tip normal load.
    pub tip_normal_n: f64,
}

impl PushGeometry {
    /// Resolves F into the four loads; zeta = psi - phi - 90 deg is expanded
    /// analytically so that no cancellation happens at zeta = -90 deg.
    pub fn loads(&self, force_n: f64, extra_substrate_load_n: f64) -> Loads {
        let (sp, cp) = self.psi_rad.sin_cos();
        let (sd, cd) = (self.psi_rad - self.phi_rad).sin_cos();
        Loads {
            substrate_lateral_n: force_n * sp,
            substrate_normal_n: force_n * cp + extra_substrate_load_n,
            tip_friction_n: force_n * sd,
            tip_normal_n: force_n * cd,
        }
    }

    /// Rolling denominator R_p (sin psi + cos zeta) + mu_r (sin zeta - cos psi):
    /// the rolling drive per newton of pushing force.
    pub fn rolling_drive_per_newton(&self, f: &FrictionParams) -> f64 {
        let (sp, cp) = self.psi_rad.sin_cos();
        let (sd, cd) = (self.psi_rad - self.phi_rad).sin_cos();
        // cos zeta = sin(psi - phi), sin zeta = -cos(psi - phi)
        self.particle_radius_m * (sp + sd) + f.rolling_coefficient_m * (-cd - cp)
    }

    /// Sliding denominator sin psi - mu cos psi.
    pub fn sliding_drive_per_newton(&self, f: &FrictionParams) -> f64 {
        let (sp, cp) = self.psi_rad.sin_cos();
        sp - f.sliding_coefficient * cp
    }
}

/// Rolling margin: (f_s + f_t) R_p - (M_s + M_t), M = mu_r F_n + tau_r A.
pub fn rolling_margin(
    g: &PushGeometry,
    f: &FrictionParams,
    force_n: f64,
    extra_load_n: f64,
    area_s: f64,
    area_t: f64,
) -> f64 {
    force_n * g.rolling_drive_per_newton(f)
        - f.rolling_coefficient_m * extra_load_n
        - f.rolling_shear_n_per_m * (area_s + area_t)
}

/// Sliding margin: f_s - (mu F_s + tau A_s).
pub fn sliding_margin(
    g: &PushGeometry,
    f: &FrictionParams,
    force_n: f64,
    extra_load_n: f64,
    area_s: f64,
) -> f64 {
    force_n * g.sliding_drive_per_newton(f)
        - f.sliding_coefficient * extra_load_n
        - f.shear_strength_pa * area_s
}

/// Spinning margin: f_s e - (2/3) a_s (mu F_s + tau A_s), the friction moment
/// of a uniformly loaded circular contact (a simple model: the real pressure
/// distribution shifts the 2/3 factor by at most ~20 %).
pub fn spinning_margin(
    g: &PushGeometry,
    f: &FrictionParams,
    force_n: f64,
    extra_load_n: f64,
    radius_s: f64,
) -> f64 {
    let l = g.loads(force_n, extra_load_n);
    let area = std::f64::consts::PI * radius_s * radius_s;
    l.substrate_lateral_n * g.offset_m.abs()
        - 2.0 / 3.0
            * radius_s
            * (f.sliding_coefficient * l.substrate_normal_n.max(0.0) + f.shear_strength_pa * area)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> (PushGeometry, FrictionParams) {
        (
            PushGeometry {
                psi_rad: 45f64.to_radians(),
                phi_rad: 45f64.to_radians(),
                particle_radius_m: 5e-6,
                offset_m: 0.0,
            },
            FrictionParams {
                sliding_coefficient: 0.8,
                shear_strength_pa: 28e6,
                rolling_coefficient_m: 80e-9,
                rolling_shear_n_per_m: 28.0,
            },
        )
    }

    #[test]
    fn sliding_is_impossible_below_the_friction_angle() {
        let (mut g, f) = paper();
        g.psi_rad = 0.8f64.atan() - 1e-3;
        assert!(g.sliding_drive_per_newton(&f) < 0.0);
        assert!(
            sliding_margin(&g, &f, 1.0, 0.0, 1e-13) < 0.0,
            "even 1 N cannot slide it"
        );
    }

    #[test]
    fn rolling_drive_matches_the_spec_formula() {
        let (g, f) = paper();
        let zeta = g.psi_rad - g.phi_rad - std::f64::consts::FRAC_PI_2;
        let spec = g.particle_radius_m * (g.psi_rad.sin() + zeta.cos())
            + f.rolling_coefficient_m * (zeta.sin() - g.psi_rad.cos());
        assert!((g.rolling_drive_per_newton(&f) - spec).abs() < 1e-18);
    }
}
