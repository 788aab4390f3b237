//! Contact mechanics of one interface (sphere on sphere or on flat): contact
//! radius, indentation and pull-off under the Hertz, DMT, JKR and
//! Maugis-Dugdale (COS) models. One model per file; this file holds the
//! interface description and dispatch.

pub mod dmt;
pub mod hertz;
pub mod jkr;
pub mod maugis;
pub mod tabor;

use super::error::ContactError;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Which contact law an interface obeys.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ContactModel {
    /// Non-adhesive elastic contact.
    Hertz,
    /// Derjaguin-Muller-Toporov: adhesion outside the contact (low Tabor).
    Dmt,
    /// Johnson-Kendall-Roberts: adhesion inside the contact (high Tabor).
    Jkr,
    /// Maugis-Dugdale transition via the COS interpolation.
    MaugisDugdale,
}

impl ContactModel {
    /// Parses the scene spelling (`hertz`, `dmt`, `jkr`, `maugis-dugdale`).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "hertz" => Some(Self::Hertz),
            "dmt" => Some(Self::Dmt),
            "jkr" => Some(Self::Jkr),
            "maugis-dugdale" | "maugis" => Some(Self::MaugisDugdale),
            _ => None,
        }
    }

    /// The scene spelling.
    pub fn name(self) -> &'static str {
        match self {
            Self::Hertz => "hertz",
            Self::Dmt => "dmt",
            Self::Jkr => "jkr",
            Self::MaugisDugdale => "maugis-dugdale",
        }
    }
}

/// One elastic adhesive interface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interface {
    /// Equivalent radius R = R1 R2 / (R1 + R2) (flat: R = R_sphere).
    pub radius_m: f64,
    /// Reduced modulus E*.
    pub reduced_modulus_pa: f64,
    /// Work of adhesion W.
    pub work_of_adhesion_j_m2: f64,
    /// Tabor parameter (decides the regime unless pinned).
    pub tabor: f64,
    /// Contact law in use.
    pub model: ContactModel,
    /// Largest physical contact radius (the smaller body's radius): a sharp
    /// tip under uN loads would exceed it (spec case 6); `a` is capped there.
    pub max_radius_m: f64,
}

/// The contact at a given load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// Contact radius a.
    pub radius_m: f64,
    /// Indentation delta.
    pub indentation_m: f64,
    /// True when `a` hit `max_radius_m` and was capped.
    pub capped: bool,
}

impl Interface {
    /// K = (4/3) E*.
    pub fn k(&self) -> f64 {
        4.0 / 3.0 * self.reduced_modulus_pa
    }

    /// Pull-off force of the law in use (negative; 0 for Hertz).
    pub fn pull_off_n(&self) -> f64 {
        let (r, w) = (self.radius_m, self.work_of_adhesion_j_m2);
        match self.model {
            ContactModel::Hertz => 0.0,
            ContactModel::Dmt => dmt::pull_off(r, w),
            ContactModel::Jkr => jkr::pull_off(r, w),
            ContactModel::MaugisDugdale => maugis::pull_off(r, w, self.tabor),
        }
    }

    /// Contact radius and indentation under `load_n` (compressive positive).
    pub fn contact(&self, load_n: f64) -> Result<ContactState, ContactError> {
        if !load_n.is_finite() {
            return Err(ContactError::NonFinite {
                what: "load_n",
                value: load_n,
            });
        }
        let (r, k, w) = (self.radius_m, self.k(), self.work_of_adhesion_j_m2);
        let a = match self.model {
            ContactModel::Hertz => hertz::contact_radius(r, k, load_n.max(0.0)),
            ContactModel::Dmt => dmt::contact_radius(r, k, w, load_n),
            ContactModel::Jkr => jkr::contact_radius(r, k, w, load_n),
            ContactModel::MaugisDugdale => maugis::contact_radius(r, k, w, self.tabor, load_n),
        }
        .ok_or(ContactError::Detached {
            load_n,
            pull_off_n: self.pull_off_n(),
        })?;
        let capped = a > self.max_radius_m;
        let a = a.min(self.max_radius_m);
        let delta = match self.model {
            ContactModel::Hertz => hertz::indentation(r, a),
            ContactModel::Dmt => dmt::indentation(r, a),
            ContactModel::Jkr => jkr::indentation(r, k, w, a),
            ContactModel::MaugisDugdale => maugis::indentation(r, k, w, self.tabor, a),
        };
        Ok(ContactState {
            radius_m: a,
            indentation_m: delta,
            capped,
        })
    }

    /// Contact area pi a^2 under `load_n`.
    pub fn area_m2(&self, load_n: f64) -> Result<f64, ContactError> {
        let a = self.contact(load_n)?.radius_m;
        Ok(PI * a * a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iface(model: ContactModel) -> Interface {
        Interface {
            radius_m: 5e-6,
            reduced_modulus_pa: 5.48e9 * 0.75,
            work_of_adhesion_j_m2: 0.1,
            tabor: tabor::tabor_parameter(5e-6, 5.48e9 * 0.75, 0.1, 0.3e-9),
            model,
            max_radius_m: 5e-6,
        }
    }

    #[test]
    fn paper_zero_load_radius_matches_spec() {
        let a = iface(ContactModel::Jkr).contact(0.0).unwrap().radius_m;
        assert!((a - 205e-9).abs() < 2e-9, "{a}");
        assert!((-iface(ContactModel::Jkr).pull_off_n() - 2.36e-6).abs() < 0.01e-6);
    }

    #[test]
    fn jkr_closed_forms_hold() {
        let i = iface(ContactModel::Jkr);
        let (r, k, w) = (i.radius_m, i.k(), i.work_of_adhesion_j_m2);
        for p in [0.0, 1e-7, 1e-6, 1e-5] {
            let s = i.contact(p).unwrap();
            let a = s.radius_m;
            // a(P) inverts P(a) and delta follows the corrected formula.
            assert!((jkr::load_from_radius(r, k, w, a) - p).abs() < 1e-9 * (1e-6 + p.abs()));
            let d = a * a / r - (2.0 / 3.0) * (6.0 * PI * w * a / k).sqrt();
            assert!((s.indentation_m - d).abs() <= 1e-12 * d.abs().max(1e-12));
        }
        // At pull-off the contact still exists (a > 0), just below it detaches.
        let pc = i.pull_off_n();
        assert!((pc + 1.5 * PI * w * r).abs() < 1e-18);
        let a_c = i.contact(pc).unwrap().radius_m;
        assert!(a_c > 0.0);
        assert!((a_c.powi(3) - r * 1.5 * PI * w * r / k).abs() < 1e-6 * a_c.powi(3));
        assert!(matches!(
            i.contact(pc * 1.0001),
            Err(ContactError::Detached { .. })
        ));
    }

    #[test]
    fn dmt_and_hertz_closed_forms_hold() {
        let d = iface(ContactModel::Dmt);
        let h = iface(ContactModel::Hertz);
        let (r, k, w) = (d.radius_m, d.k(), d.work_of_adhesion_j_m2);
        let p = 2e-6;
        let a_d = d.contact(p).unwrap();
        assert!(
            (a_d.radius_m.powi(3) - r / k * (p + 2.0 * PI * w * r)).abs()
                < 1e-9 * a_d.radius_m.powi(3)
        );
        assert!((a_d.indentation_m - a_d.radius_m.powi(2) / r).abs() < 1e-20);
        assert!((d.pull_off_n() + 2.0 * PI * w * r).abs() < 1e-18);
        let a_h = h.contact(p).unwrap();
        assert!((a_h.radius_m.powi(3) - r * p / k).abs() < 1e-9 * a_h.radius_m.powi(3));
        assert_eq!(h.pull_off_n(), 0.0);
    }

    #[test]
    fn maugis_interpolates_between_dmt_and_jkr() {
        let mut m = iface(ContactModel::MaugisDugdale);
        m.tabor = 1e4;
        let j = iface(ContactModel::Jkr).contact(1e-6).unwrap().radius_m;
        let mj = m.contact(1e-6).unwrap().radius_m;
        assert!((mj / j - 1.0).abs() < 0.03, "{mj} vs {j}");
        m.tabor = 1e-4;
        let d = iface(ContactModel::Dmt).contact(1e-6).unwrap().radius_m;
        let md = m.contact(1e-6).unwrap().radius_m;
        assert!((md / d - 1.0).abs() < 0.03, "{md} vs {d}");
    }

    #[test]
    fn sharp_tip_contact_is_capped_and_says_so() {
        let mut i = iface(ContactModel::Jkr);
        i.radius_m = 20e-9;
        i.max_radius_m = 20e-9;
        let s = i.contact(3e-6).unwrap();
        assert!(s.capped);
        assert_eq!(s.radius_m, 20e-9);
    }

    #[test]
    fn regime_follows_tabor() {
        assert_eq!(tabor::regime_for(10.0, 0.1), ContactModel::Jkr);
        assert_eq!(tabor::regime_for(0.01, 0.1), ContactModel::Dmt);
        assert_eq!(tabor::regime_for(1.0, 0.1), ContactModel::MaugisDugdale);
        assert_eq!(tabor::regime_for(1.0, 0.0), ContactModel::Hertz);
    }
}
