//! Tip kinematics before onset: how stage travel becomes pushing force.
//!
//! The source's kinematics (tip pinned on the particle, eq.-1 springs) give
//! onset in milliseconds and break at t = H/V (spec section 4). Here the tip
//! is held on the particle only along the contact normal m (no penetration)
//! and slides along the tangent t with Coulomb friction `mu_tip`: it rides up
//! the sphere, so lateral stage travel is coupled into the soft normal spring
//! K_z. For a stage travel d (lateral vector D = (d, 0)), with K = diag(k_y, K_z):
//!
//! ```text
//! force on particle  F = N g,   g = m + mu_tip t,  m = (sin phi, -cos phi),  t = (cos phi, sin phi)
//! N = (m . D) / (m . K^-1 g)          (linear in d: a constant ramp)
//! tip slip along t   c = t . D - N t . K^-1 g
//! ```
//!
//! The tip self-locks when the force of the springs with the tip held still,
//! K D (horizontal), lies inside the friction cone about m: cos phi <=
//! mu_tip sin phi, i.e. phi >= atan(1 / mu_tip). Then the force is the full
//! spring K D (psi = 90 deg). The slip formula gives the same boundary
//! (c (m . K^-1 g) = K_z^-1 (cos phi - mu_tip sin phi)), but past it the slip
//! comes out negative, the tip sliding down against the friction assumed
//! for sliding up: a force above the lateral spring itself (106 N/m on a
//! 32.9 N/m spring at 89 deg) until 2026-11-29, when only `m . K^-1 g <= 0`
//! (a subset: phi >= 83 deg at mu_tip 0.23 was missed from 77 deg) locked. The model is linearised about the initial contact: the
//! contact angle phi is held (as in the source); whether the tip then climbs
//! over the top is the separate "tip riding over" effect.

use super::cantilever::Springs;
use super::units::Radians;

/// The load path per metre of stage travel (all quantities are linear in d).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadPath {
    /// dF_T/dd: pushing-force ramp [N/m].
    pub force_per_travel: f64,
    /// psi: angle of the pushing force from the (downward) substrate normal.
    pub force_angle: Radians,
    /// Tip slip along the particle surface per metre of travel [m/m].
    pub tip_slip_per_travel: f64,
    /// Lateral deflection of the apex relative to the stage per metre of travel.
    pub lateral_deflection_per_travel: f64,
    /// True when friction locks the tip on the particle (no slip).
    pub tip_locked: bool,
}

/// Load path for contact angle `phi` and tip-particle friction `mu_tip`.
pub fn load_path(springs: &Springs, phi: Radians, mu_tip: f64) -> LoadPath {
    let (s, c) = phi.0.sin_cos();
    let cy = 1.0 / springs.lateral_n_per_m;
    let cz = 1.0 / springs.normal_n_per_m;
    // m.K^-1 g and t.K^-1 g, expanded to avoid forming vectors.
    let m_k_m = s * s * cy + c * c * cz;
    let m_k_t = s * c * (cy - cz);
    let t_k_t = c * c * cy + s * s * cz;
    let den = m_k_m + mu_tip * m_k_t;
    // Locked: the stuck force lies in the friction cone (then also every
    // den <= 0). Sliding, den >= sin phi cy (sin phi + mu cos phi) > 0.
    if c <= mu_tip * s {
        return LoadPath {
            force_per_travel: springs.lateral_n_per_m,
            force_angle: Radians(std::f64::consts::FRAC_PI_2),
            tip_slip_per_travel: 0.0,
            lateral_deflection_per_travel: 1.0,
            tip_locked: true,
        };
    }
    let n_per_d = s / den;
    let g_norm = (1.0 + mu_tip * mu_tip).sqrt();
    let slip = c - n_per_d * (m_k_t + mu_tip * t_k_t);
    // Lateral force component of F = N g: g_y = sin phi + mu cos phi.
    let f_y = n_per_d * (s + mu_tip * c);
    LoadPath {
        force_per_travel: n_per_d * g_norm,
        force_angle: Radians(phi.0 + mu_tip.atan()),
        tip_slip_per_travel: slip,
        lateral_deflection_per_travel: f_y * cy,
        tip_locked: false,
    }
}

/// The source's literal kinematics: the tip pinned on the particle twists by
/// theta with H sin(theta) = stage travel. Returns `None` once the travel
/// reaches H (theta = 90 deg, t = H/V): the tip has slipped (spec case 2).
pub fn literal_twist(travel_m: f64, tip_height_m: f64) -> Option<Radians> {
    let x = travel_m / tip_height_m;
    if !x.is_finite() || x.abs() >= 1.0 {
        return None;
    }
    Some(Radians(x.asin()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper_springs() -> Springs {
        Springs {
            normal_n_per_m: 0.178,
            torsional_nm_per_rad: 4.73e-9,
            lateral_n_per_m: 32.9,
        }
    }

    #[test]
    fn frictionless_tip_pushes_along_the_normal_with_series_stiffness() {
        let phi = Radians(45f64.to_radians());
        let lp = load_path(&paper_springs(), phi, 0.0);
        let k_n = 1.0 / (0.5 / 32.9 + 0.5 / 0.178);
        assert!((lp.force_per_travel - k_n * phi.0.sin()).abs() < 1e-12);
        assert!((lp.force_angle.0 - phi.0).abs() < 1e-15);
        assert!(lp.tip_slip_per_travel > 0.0, "tip rides up the sphere");
    }

    #[test]
    fn smaller_contact_angle_gives_a_slower_ramp() {
        let s = paper_springs();
        let a = load_path(&s, Radians(30f64.to_radians()), 0.23).force_per_travel;
        let b = load_path(&s, Radians(45f64.to_radians()), 0.23).force_per_travel;
        assert!(a < b);
    }

    /// The tip locks exactly where the stuck (horizontal) spring force enters
    /// the friction cone, phi >= atan(1 / mu_tip); sliding, it slides up
    /// (slip >= 0) and the force never exceeds the lateral spring's.
    #[test]
    fn the_tip_locks_exactly_inside_the_friction_cone() {
        let springs = paper_springs();
        for mu in [0.05f64, 0.23, 0.5, 1.0, 2.0] {
            let lock_from = (1.0 / mu).atan();
            for tenth in 1..900 {
                let phi = (tenth as f64 / 10.0).to_radians();
                let lp = load_path(&springs, Radians(phi), mu);
                if (phi - lock_from).abs() > 1e-9 {
                    assert_eq!(lp.tip_locked, phi > lock_from, "mu {mu} phi {phi}");
                }
                assert!(lp.tip_slip_per_travel >= 0.0, "mu {mu} phi {phi}: {lp:?}");
                assert!(
                    lp.force_per_travel <= springs.lateral_n_per_m * (1.0 + 1e-12),
                    "mu {mu} phi {phi}: {lp:?}"
                );
                assert!(lp.force_angle.0 <= std::f64::consts::FRAC_PI_2 + 1e-12);
            }
        }
    }

    #[test]
    fn high_tip_friction_locks_the_tip() {
        let lp = load_path(&paper_springs(), Radians(45f64.to_radians()), 2.0);
        assert!(lp.tip_locked);
        assert!(lp.force_per_travel.is_finite());
    }

    #[test]
    fn literal_kinematics_break_at_h() {
        assert!(literal_twist(11.9e-6, 12e-6).is_some());
        assert!(literal_twist(12e-6, 12e-6).is_none());
        assert_eq!(literal_twist(0.0, 12e-6), Some(Radians(0.0)));
    }
}
