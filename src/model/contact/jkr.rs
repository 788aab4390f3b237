//! JKR contact (compliant, strongly adhesive, high Tabor parameter).
//!
//! a^3 = (R/K)[P + 3 pi W R + sqrt(6 pi W R P + (3 pi W R)^2)],
//! delta = a^2/R - (2/3) sqrt(6 pi W a / K) (the source prints 3 pi: wrong),
//! pull-off P_c = -(3/2) pi W R (load-controlled).
//! Near pull-off da/dP is infinite, so [`load_from_radius`] gives the
//! a-parametrised form P = K a^3/R - sqrt(6 pi W K a^3) (spec case 4).

use std::f64::consts::PI;

/// Pull-off force (negative).
pub fn pull_off(r: f64, w: f64) -> f64 {
    -1.5 * PI * w * r
}

/// Contact radius under load `p`; `None` below pull-off (the square root's
/// argument is negative: detached).
pub fn contact_radius(r: f64, k: f64, w: f64, p: f64) -> Option<f64> {
    let b = 3.0 * PI * w * r;
    // 6 pi W R P + b^2 = 6 pi W R (P - P_c), written so it is exactly 0 at P_c.
    let disc = 6.0 * PI * w * r * (p - pull_off(r, w));
    if disc < 0.0 {
        return None;
    }
    Some((r / k * (p + b + disc.sqrt())).max(0.0).cbrt())
}

/// Load for contact radius `a` (finite slope through pull-off).
pub fn load_from_radius(r: f64, k: f64, w: f64, a: f64) -> f64 {
    let a3 = a * a * a;
    k * a3 / r - (6.0 * PI * w * k * a3).sqrt()
}

/// Indentation for contact radius `a`.
pub fn indentation(r: f64, k: f64, w: f64, a: f64) -> f64 {
    a * a / r - (2.0 / 3.0) * (6.0 * PI * w * a / k).sqrt()
}
