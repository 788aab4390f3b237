//! Cramer-Rao lower bound on the centre error of a bright-field sphere, for the
//! synthetic microscope's image model (Poisson shot noise + Gaussian read noise,
//! all profile parameters unknown). The yardstick the study and tests quote.

use nalgebra::{SMatrix, SVector};

use super::profile_fit::ring_model;
use crate::render::microscope::RenderSettings;
use crate::render::sphere::SphereProfile;

/// Widest image half-side, pixels, the bound is summed over: its cost
/// grows with the image's area (about 1 s at this size), and a sphere
/// wider than this is beyond any frame the vision works on.
pub const MAX_SUPPORT_PX: f64 = 1024.0;

/// Per-axis 1-sigma bound on the centre, in pixels, for a sphere of radius
/// `radius_px` at unit illumination, or `None` if the Fisher matrix is
/// singular or the radius is not positive or its image is wider than
/// [`MAX_SUPPORT_PX`] (so a mistyped radius cannot hang the caller).
pub fn centre_crb_px(radius_px: f64, settings: &RenderSettings) -> Option<f64> {
    let prof = SphereProfile::new(
        0.0,
        0.0,
        radius_px,
        &settings.optics,
        settings.blur_sigma_px,
    );
    let b = settings.background_e;
    // The renderer's image is b (1 + modulation): the fit model with these parameters.
    let (cx, cy) = (0.31, 0.62);
    let p = SVector::<f64, 8>::from_column_slice(&[
        cx,
        cy,
        b,
        b * prof.core_amplitude,
        prof.core_sigma_px,
        b * prof.ring_amplitude,
        prof.ring_radius_px,
        prof.ring_sigma_px,
    ]);
    let support = prof.support_px();
    if !(radius_px > 0.0 && support.is_finite() && support <= MAX_SUPPORT_PX) {
        return None;
    }
    let half = (support + 2.0).ceil() as i64;
    let read2 = settings.camera.read_noise_e.powi(2);
    let mut fisher = SMatrix::<f64, 8, 8>::zeros();
    let mut g = SVector::<f64, 8>::zeros();
    for y in -half..=half {
        for x in -half..=half {
            let mu = ring_model(x as f64, y as f64, &p, &mut g).max(0.0);
            fisher.syger(1.0 / (mu + read2 + 1e-12), &g, &g, 1.0);
        }
    }
    let inv = fisher.try_inverse()?;
    let v = 0.5 * (inv[(0, 0)] + inv[(1, 1)]);
    (v.is_finite() && v > 0.0).then(|| v.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bound_scales_inversely_with_snr() {
        let lo = centre_crb_px(8.0, &RenderSettings::with_snr(5.0, 16)).unwrap();
        let hi = centre_crb_px(8.0, &RenderSettings::with_snr(20.0, 16)).unwrap();
        assert!(lo > hi && lo < 0.5, "{lo} {hi}");
        // Shot-noise dominated: four times the SNR, about a quarter of the error.
        assert!((lo / hi - 4.0).abs() < 0.6, "{}", lo / hi);
    }

    #[test]
    fn an_absurd_radius_gives_no_bound_at_once() {
        // Without the support cap a radius of 1e4 px gives Some after about
        // a hundred seconds and 1e300 never returns: no clock needed.
        let s = RenderSettings::with_snr(8.0, 16);
        for r in [1e4, 1e300, f64::INFINITY, f64::NAN, 0.0, -8.0] {
            assert_eq!(centre_crb_px(r, &s), None, "radius {r}");
        }
    }
}
