//! DMT contact (stiff, weakly adhesive, low Tabor parameter):
//! a^3 = (R/K)(P + 2 pi W R), delta = a^2/R, pull-off P_c = -2 pi W R.

use std::f64::consts::PI;

/// Pull-off force (negative).
pub fn pull_off(r: f64, w: f64) -> f64 {
    -2.0 * PI * w * r
}

/// Contact radius under load `p`; `None` below pull-off.
pub fn contact_radius(r: f64, k: f64, w: f64, p: f64) -> Option<f64> {
    let x = p + 2.0 * PI * w * r;
    (x >= 0.0).then(|| (r / k * x).cbrt())
}

/// Indentation for contact radius `a` (Hertzian profile).
pub fn indentation(r: f64, a: f64) -> f64 {
    a * a / r
}
