//! Bracketed scalar root finding (Illinois-modified regula falsi).
//!
//! Written by hand because the crate's dependency set has no 1-D root finder
//! and this one is 40 lines: it never leaves its bracket, so the onset of
//! motion and the implicit critical forces are found to a stated tolerance
//! and can never be stepped over (spec section 5, case 7).

/// Finds `x` in `[lo, hi]` with `f(x) = 0`, given `f(lo) <= 0 < f(hi)` or the
/// reverse. Stops when the bracket is narrower than `x_tol` or after 200
/// iterations. Returns the end of the final bracket where `f >= 0`
/// (the first point at which the event has happened), or `None` when the
/// ends do not bracket a sign change.
pub fn find_root<F: FnMut(f64) -> f64>(mut f: F, lo: f64, hi: f64, x_tol: f64) -> Option<f64> {
    let (mut a, mut b) = (lo, hi);
    let (mut fa, mut fb) = (f(a), f(b));
    if !(fa.is_finite() && fb.is_finite()) {
        return None;
    }
    if fa >= 0.0 && fb >= 0.0 || fa < 0.0 && fb < 0.0 {
        return None;
    }
    let mut side = 0i8;
    for _ in 0..200 {
        if (b - a).abs() <= x_tol {
            break;
        }
        let mut c = (a * fb - b * fa) / (fb - fa);
        if !c.is_finite() || c <= a.min(b) || c >= a.max(b) {
            c = 0.5 * (a + b);
        }
        let fc = f(c);
        if !fc.is_finite() {
            return None;
        }
        if (fc >= 0.0) == (fb >= 0.0) {
            b = c;
            fb = fc;
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            a = c;
            fa = fc;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
    }
    // Return the end on the "event happened" side (f >= 0).
    Some(if fb >= 0.0 { b } else { a })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_cube_root_within_tolerance() {
        let r = find_root(|x| x * x * x - 2.0, 0.0, 2.0, 1e-12).unwrap();
        assert!((r - 2f64.cbrt()).abs() < 1e-11);
    }

    #[test]
    fn refuses_a_non_bracket() {
        assert!(find_root(|x| x * x + 1.0, -1.0, 1.0, 1e-9).is_none());
    }

    #[test]
    fn returns_the_side_where_the_event_happened() {
        let r = find_root(|x| x - 0.5, 0.0, 1.0, 1e-3).unwrap();
        assert!(r >= 0.5 && r - 0.5 <= 1e-3);
    }
}
