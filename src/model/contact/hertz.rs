//! Hertz contact (no adhesion): a^3 = R P / K, delta = a^2 / R.

/// Contact radius under load `p` (compressive >= 0); `None` for tension.
pub fn contact_radius(r: f64, k: f64, p: f64) -> Option<f64> {
    (p >= 0.0).then(|| (r * p / k).cbrt())
}

/// Indentation for contact radius `a`.
pub fn indentation(r: f64, a: f64) -> f64 {
    a * a / r
}
