//! Bright-field image of a sphere: a bright core inside a dark ring at the
//! sphere's edge (or the reverse contrast), blurred by the optics.
//!
//! The profile is a sum of two Gaussians (core, ring); the point-spread
//! function and the pixel's box sampling are folded in analytically (Gaussian
//! widths add in quadrature), so sub-pixel positions are exact and rendering
//! needs no convolution. The same profile is the detector's fit model.

/// Relative modulation of the background by one sphere, ready to evaluate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereProfile {
    /// Centre x in pixels.
    pub x_px: f64,
    /// Centre y in pixels.
    pub y_px: f64,
    /// Radius of the dark ring (the sphere's apparent edge) in pixels.
    pub ring_radius_px: f64,
    /// Peak relative brightening of the core (negative: dark core).
    pub core_amplitude: f64,
    /// Gaussian width of the core in pixels (blur included).
    pub core_sigma_px: f64,
    /// Peak relative darkening of the ring (negative: bright ring).
    pub ring_amplitude: f64,
    /// Gaussian width of the ring in pixels (blur included).
    pub ring_sigma_px: f64,
}

/// Optical parameters of how spheres look, shared by all spheres in a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereOptics {
    /// Core brightening relative to background, in focus.
    pub core_contrast: f64,
    /// Ring darkening relative to background, in focus.
    pub ring_contrast: f64,
    /// Core width as a fraction of the radius.
    pub core_width_fraction: f64,
    /// Intrinsic ring width in pixels, in focus.
    pub ring_width_px: f64,
    /// Defocus blur in pixels: widens the ring and spreads its contrast.
    pub defocus_px: f64,
    /// Flip the contrast (dark core, bright ring), as on the other side of focus.
    pub inverted: bool,
}

impl Default for SphereOptics {
    fn default() -> Self {
        Self {
            core_contrast: 0.4,
            ring_contrast: 0.5,
            core_width_fraction: 0.45,
            ring_width_px: 1.2,
            defocus_px: 0.0,
            inverted: false,
        }
    }
}

/// Pixel sampling variance (a unit box has variance 1/12 px^2).
const PIXEL_BOX_VARIANCE: f64 = 1.0 / 12.0;

impl SphereProfile {
    /// The profile of a sphere of apparent radius `radius_px` seen through
    /// `optics` and a Gaussian PSF of width `blur_sigma_px`.
    pub fn new(
        x_px: f64,
        y_px: f64,
        radius_px: f64,
        optics: &SphereOptics,
        blur_sigma_px: f64,
    ) -> Self {
        let extra = blur_sigma_px.powi(2) + optics.defocus_px.powi(2) + PIXEL_BOX_VARIANCE;
        let core0 = (optics.core_width_fraction * radius_px).max(0.3);
        let core_sigma = (core0.powi(2) + extra).sqrt();
        let ring0 = optics.ring_width_px.max(0.3);
        let ring_sigma = (ring0.powi(2) + extra).sqrt();
        let sign = if optics.inverted { -1.0 } else { 1.0 };
        Self {
            x_px,
            y_px,
            ring_radius_px: radius_px,
            // Blurring a 2-D Gaussian keeps its volume; a ring keeps its line integral.
            core_amplitude: sign * optics.core_contrast * (core0 / core_sigma).powi(2),
            core_sigma_px: core_sigma,
            ring_amplitude: sign * optics.ring_contrast * (ring0 / ring_sigma),
            ring_sigma_px: ring_sigma,
        }
    }

    /// Distance beyond which the modulation is negligible (< 1e-4).
    pub fn support_px(&self) -> f64 {
        (self.ring_radius_px + 4.5 * self.ring_sigma_px).max(4.5 * self.core_sigma_px)
    }

    /// Relative modulation at (x, y): 0 far away, +core at the centre.
    #[inline]
    pub fn modulation(&self, x: f64, y: f64) -> f64 {
        let dx = x - self.x_px;
        let dy = y - self.y_px;
        let r2 = dx * dx + dy * dy;
        let r = r2.sqrt();
        let core = self.core_amplitude * (-0.5 * r2 / self.core_sigma_px.powi(2)).exp();
        let dr = r - self.ring_radius_px;
        let ring = self.ring_amplitude * (-0.5 * dr * dr / self.ring_sigma_px.powi(2)).exp();
        core - ring
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bright_core_dark_ring_and_inverted() {
        let o = SphereOptics::default();
        let p = SphereProfile::new(10.0, 10.0, 8.0, &o, 0.8);
        assert!(p.modulation(10.0, 10.0) > 0.2);
        assert!(p.modulation(18.0, 10.0) < -0.2);
        assert!(p.modulation(40.0, 10.0).abs() < 1e-4);
        let inv = SphereProfile::new(
            10.0,
            10.0,
            8.0,
            &SphereOptics {
                inverted: true,
                ..o
            },
            0.8,
        );
        assert!(inv.modulation(10.0, 10.0) < -0.2);
        assert!(inv.modulation(10.0, 18.0) > 0.2);
    }

    #[test]
    fn defocus_spreads_the_ring() {
        let o = SphereOptics::default();
        let sharp = SphereProfile::new(0.0, 0.0, 8.0, &o, 0.8);
        let blurred = SphereProfile::new(
            0.0,
            0.0,
            8.0,
            &SphereOptics {
                defocus_px: 2.0,
                ..o
            },
            0.8,
        );
        assert!(blurred.ring_sigma_px > sharp.ring_sigma_px + 1.0);
        assert!(blurred.ring_amplitude < sharp.ring_amplitude);
    }
}
