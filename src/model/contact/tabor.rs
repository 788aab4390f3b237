//! The Tabor parameter and the contact regime it selects (spec section 2).

use super::ContactModel;

/// Equilibrium separation z0 used when the scene does not set one (m).
pub const DEFAULT_EQUILIBRIUM_SEPARATION_M: f64 = 0.3e-9;

/// mu_T = (R W^2 / (E*^2 z0^3))^(1/3).
pub fn tabor_parameter(r: f64, e_star: f64, w: f64, z0: f64) -> f64 {
    (r * w * w / (e_star * e_star * z0 * z0 * z0)).cbrt()
}

/// JKR above 5, DMT below 0.1, Maugis-Dugdale (COS) in between; Hertz when
/// there is no adhesion at all.
pub fn regime_for(tabor: f64, w: f64) -> ContactModel {
    if w <= 0.0 {
        ContactModel::Hertz
    } else if tabor > 5.0 {
        ContactModel::Jkr
    } else if tabor < 0.1 {
        ContactModel::Dmt
    } else {
        ContactModel::MaugisDugdale
    }
}
