//! Critical pushing forces for rolling, sliding, spinning and detachment.
//!
//! The contact areas depend on the loads, which depend on F, so each critical
//! force is the root of its margin (friction::criteria) in F, found by a
//! bracketed search (root.rs), not taken at zero load (which is off by up to
//! 50 %, spec section 2). A non-positive drive means the mode is locked:
//! `Critical::Locked`, never a division by ~0 (spec case 3).

use super::contact::Interface;
use super::error::{ContactError, ModelError};
use super::friction::criteria::{self, FrictionParams, PushGeometry};
use super::root::find_root;
use serde::Serialize;

/// How contact areas are evaluated (a study setting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AreaFidelity {
    /// Areas at zero load: closed form, cheap, biased low.
    ZeroLoad,
    /// Areas at the actual loads: implicit, solved by bracketed root.
    LoadDependent,
}

/// A critical force, or the statement that the mode cannot start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "kind", content = "force_n")]
pub enum Critical {
    /// The mode starts when the pushing force reaches this value (N).
    Force(f64),
    /// The drive of this mode never exceeds its resistance (F* = +inf).
    Locked,
}

impl Critical {
    /// The force, or +inf for a locked mode (for comparisons and plots only).
    pub fn or_inf(self) -> f64 {
        match self {
            Critical::Force(f) => f,
            Critical::Locked => f64::INFINITY,
        }
    }

    /// The force if the mode can start.
    pub fn force(self) -> Option<f64> {
        match self {
            Critical::Force(f) => Some(f),
            Critical::Locked => None,
        }
    }
}

/// Everything the critical forces depend on.
#[derive(Debug, Clone, Copy)]
pub struct CriticalSetup {
    /// Particle-substrate interface.
    pub substrate: Interface,
    /// Tip-particle interface.
    pub tip: Interface,
    /// Friction laws.
    pub friction: FrictionParams,
    /// Angles and lengths.
    pub geometry: PushGeometry,
    /// Extra compressive substrate load (capillary meniscus) (N).
    pub extra_substrate_load_n: f64,
    /// Area fidelity.
    pub fidelity: AreaFidelity,
    /// Relative tolerance of the force roots.
    pub relative_tolerance: f64,
}

/// The four critical forces of one configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CriticalForces {
    /// F_r*.
    pub rolling: Critical,
    /// F_s*.
    pub sliding: Critical,
    /// Spinning (off-axis push).
    pub spinning: Critical,
    /// Force at which the substrate load falls below pull-off (psi > 90 deg).
    pub detach: Critical,
    /// True when the tip contact radius was capped at the tip radius.
    pub tip_contact_capped: bool,
}

impl CriticalSetup {
    fn areas(&self, force_n: f64) -> Result<(f64, f64, f64, bool), ContactError> {
        let (ps, pt) = match self.fidelity {
            AreaFidelity::ZeroLoad => (0.0, 0.0),
            AreaFidelity::LoadDependent => {
                let l = self.geometry.loads(force_n, self.extra_substrate_load_n);
                (l.substrate_normal_n, l.tip_normal_n)
            }
        };
        let s = self.substrate.contact(ps)?;
        // The tip contact may not hold tension beyond its own pull-off; then
        // it carries no area (the tip is about to lose the particle).
        let t = self.tip.contact(pt).ok();
        let pi = std::f64::consts::PI;
        let a_t = t.map_or(0.0, |t| t.radius_m);
        Ok((
            pi * s.radius_m * s.radius_m,
            pi * a_t * a_t,
            s.radius_m,
            t.is_some_and(|t| t.capped),
        ))
    }

    /// The force at which the substrate contact detaches, if psi > 90 deg.
    fn detach_force(&self) -> Critical {
        let c = self.geometry.psi_rad.cos();
        if c >= -1e-12 {
            return Critical::Locked;
        }
        Critical::Force((self.substrate.pull_off_n() - self.extra_substrate_load_n) / c)
    }

    /// Root of `margin` in F, up to `f_max` (beyond which the particle has detached).
    fn solve(
        &self,
        what: &'static str,
        f_max: f64,
        margin: impl Fn(f64) -> Result<f64, ContactError>,
    ) -> Result<Critical, ModelError> {
        let m = |f: f64| margin(f).unwrap_or(f64::NAN);
        // Just inside detachment: at `f_max` itself the substrate load sits
        // exactly at pull-off, where rounding can leave no contact at all
        // (seen: R 0.74 um, W 1 mJ/m2, E* 0.1 GPa, phi 78 deg, in the
        // Maugis-Dugdale regime).
        let f_max = f_max * (1.0 - 1e-9);
        // Upper bracket: double from a small scale until the margin is positive.
        let mut hi: f64 = 1e-12;
        loop {
            let v = m(hi.min(f_max));
            if v.is_nan() {
                return Err(ModelError::RootNotFound {
                    what,
                    why: format!("contact failed at F = {hi:.3e} N"),
                });
            }
            if v >= 0.0 {
                hi = hi.min(f_max);
                break;
            }
            if hi >= f_max || hi > 1e3 {
                return Ok(Critical::Locked);
            }
            hi *= 4.0;
        }
        let mut lo = hi / 4.0;
        let mut shrink = 0;
        while m(lo) >= 0.0 {
            lo /= 4.0;
            shrink += 1;
            if shrink > 40 {
                return Ok(Critical::Force(lo));
            }
        }
        let tol = (hi * self.relative_tolerance).max(1e-30);
        find_root(m, lo, hi, tol)
            .map(Critical::Force)
            .ok_or(ModelError::RootNotFound {
                what,
                why: "no sign change in bracket".into(),
            })
    }

    /// All four critical forces.
    pub fn critical_forces(&self) -> Result<CriticalForces, ModelError> {
        let g = self.geometry;
        let f = self.friction;
        let extra = self.extra_substrate_load_n;
        let detach = self.detach_force();
        let f_max = detach.or_inf();
        let rolling = if g.rolling_drive_per_newton(&f) <= 1e-9 * g.particle_radius_m {
            Critical::Locked
        } else {
            self.solve("critical rolling force", f_max, |x| {
                let (a_s, a_t, _, _) = self.areas(x)?;
                Ok(criteria::rolling_margin(&g, &f, x, extra, a_s, a_t))
            })?
        };
        let sliding = if g.sliding_drive_per_newton(&f) <= 1e-12 {
            Critical::Locked
        } else {
            self.solve("critical sliding force", f_max, |x| {
                let (a_s, _, _, _) = self.areas(x)?;
                Ok(criteria::sliding_margin(&g, &f, x, extra, a_s))
            })?
        };
        let spinning = if g.offset_m == 0.0 || g.psi_rad.sin() <= 1e-12 {
            Critical::Locked
        } else {
            self.solve("critical spinning force", f_max, |x| {
                let (_, _, r_s, _) = self.areas(x)?;
                Ok(criteria::spinning_margin(&g, &f, x, extra, r_s))
            })?
        };
        let at = rolling
            .force()
            .or(sliding.force())
            .unwrap_or(0.0)
            .min(f_max);
        let tip_contact_capped = self.areas(at).map(|a| a.3).unwrap_or(false);
        Ok(CriticalForces {
            rolling,
            sliding,
            spinning,
            detach,
            tip_contact_capped,
        })
    }
}
