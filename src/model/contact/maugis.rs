//! Maugis-Dugdale regime through the Carpick-Ogletree-Salmeron (COS)
//! interpolation with the Pietrement-Troyon coefficients
//! (Carpick et al., J. Colloid Interface Sci. 211 (1999) 395; Pietrement &
//! Troyon, J. Colloid Interface Sci. 226 (2000) 166). Used because the exact
//! Maugis solution is implicit in two variables while the interpolation is
//! closed form and within ~1 % of it in a(P) over the whole transition.
//!
//! a(P) = a0(lambda) [(alpha + sqrt(1 - P/P_c(lambda))) / (1 + alpha)]^(2/3),
//! lambda = 1.157 mu_T (Maugis parameter), alpha = (1 - exp(-lambda/0.924))/1.02.
//! Limits: alpha -> 0 gives DMT, alpha -> 1 gives JKR. The indentation has
//! no closed form: delta ~ a^2/R - alpha (2/3) sqrt(6 pi W a / K) (the JKR
//! neck term scaled by alpha), an approximation we document, not a solution.

use std::f64::consts::PI;

/// COS transition parameter alpha from the Tabor parameter.
pub fn alpha(tabor: f64) -> f64 {
    let lambda = 1.157 * tabor;
    ((1.0 - (-lambda / 0.924).exp()) / 1.02).clamp(0.0, 1.0)
}

/// Pull-off force (negative), Pietrement-Troyon fit between -2 and -1.5 pi W R.
pub fn pull_off(r: f64, w: f64, tabor: f64) -> f64 {
    let l = (1.157 * tabor).max(0.0).powf(0.25) * 4.04;
    -(1.75 - 0.25 * (l - 1.0) / (l + 1.0)) * PI * w * r
}

/// Zero-load contact radius, Pietrement-Troyon fit between DMT and JKR.
fn zero_load_radius(r: f64, k: f64, w: f64, tabor: f64) -> f64 {
    let l = 2.28 * (1.157 * tabor).max(0.0).powf(1.3);
    (1.54 + 0.279 * (l - 1.0) / (l + 1.0)) * (PI * w * r * r / k).cbrt()
}

/// Contact radius under load `p`; `None` below pull-off.
pub fn contact_radius(r: f64, k: f64, w: f64, tabor: f64, p: f64) -> Option<f64> {
    let pc = pull_off(r, w, tabor);
    let x = 1.0 - p / pc;
    if x < 0.0 {
        return None;
    }
    let al = alpha(tabor);
    let a0 = zero_load_radius(r, k, w, tabor);
    Some(a0 * ((al + x.sqrt()) / (1.0 + al)).powf(2.0 / 3.0))
}

/// Approximate indentation for contact radius `a` (see module doc).
pub fn indentation(r: f64, k: f64, w: f64, tabor: f64, a: f64) -> f64 {
    a * a / r - alpha(tabor) * (2.0 / 3.0) * (6.0 * PI * w * a / k).sqrt()
}
