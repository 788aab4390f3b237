//! The AFM probe seen from above: an opaque cantilever whose end narrows to a
//! triangle; the apex is the point the planner steers.
//!
//! The silhouette is a convex pentagon; its blurred edge is the normal CDF of
//! the signed distance to the polygon, exact for straight edges under a
//! Gaussian PSF. Hand-written because it is a few lines and must be fast.

/// Shape of the probe silhouette in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeShape {
    /// Cantilever width in pixels.
    pub width_px: f64,
    /// Length of the triangular end, apex to where the full width starts.
    pub taper_length_px: f64,
    /// Fraction of light the cantilever blocks (1 = fully opaque).
    pub opacity: f64,
}

impl Default for ProbeShape {
    fn default() -> Self {
        Self {
            width_px: 40.0,
            taper_length_px: 50.0,
            opacity: 0.85,
        }
    }
}

/// A probe placed in the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeSilhouette {
    /// Apex x in pixels.
    pub apex_x_px: f64,
    /// Apex y in pixels.
    pub apex_y_px: f64,
    /// Direction from the cantilever body towards the apex (image axes, y down).
    pub angle_rad: f64,
    /// Shape.
    pub shape: ProbeShape,
}

/// Cantilever length drawn behind the taper; longer than any frame.
const BODY_LENGTH_PX: f64 = 1.0e5;

impl ProbeSilhouette {
    /// Polygon corners in image coordinates, counter-clockwise in (u, v).
    pub fn corners(&self) -> [(f64, f64); 5] {
        let (s, c) = self.angle_rad.sin_cos();
        let h = 0.5 * self.shape.width_px;
        let t = self.shape.taper_length_px;
        let local = [
            (0.0, 0.0),
            (-t, h),
            (-BODY_LENGTH_PX, h),
            (-BODY_LENGTH_PX, -h),
            (-t, -h),
        ];
        local.map(|(u, v)| {
            (
                self.apex_x_px + u * c - v * s,
                self.apex_y_px + u * s + v * c,
            )
        })
    }

    /// Signed distance from (x, y) to the silhouette edge: negative inside.
    pub fn signed_distance(&self, x: f64, y: f64) -> f64 {
        // Work in the probe's frame: u along the axis (apex at 0), v across.
        let (s, c) = self.angle_rad.sin_cos();
        let dx = x - self.apex_x_px;
        let dy = y - self.apex_y_px;
        let u = dx * c + dy * s;
        let v = (-dx * s + dy * c).abs();
        let h = 0.5 * self.shape.width_px;
        let t = self.shape.taper_length_px.max(1e-9);
        // Symmetric in v: the half-shape is the apex edge (0,0)->(-t,h), the side
        // edge (-t,h)->(-L,h), and the far end (never in view).
        let seg = |ax: f64, ay: f64, bx: f64, by: f64| {
            let (ex, ey) = (bx - ax, by - ay);
            let k = (((u - ax) * ex + (v - ay) * ey) / (ex * ex + ey * ey)).clamp(0.0, 1.0);
            ((u - ax - k * ex).powi(2) + (v - ay - k * ey).powi(2)).sqrt()
        };
        let d_edge = seg(0.0, 0.0, -t, h).min(seg(-t, h, -BODY_LENGTH_PX, h));
        let inside_taper = u <= 0.0 && u >= -t && v <= -u * h / t;
        let inside_body = u < -t && u > -BODY_LENGTH_PX && v <= h;
        if inside_taper || inside_body {
            -d_edge
        } else {
            d_edge
        }
    }

    /// Fraction of light transmitted at (x, y) given the blur width.
    #[inline]
    pub fn transmission(&self, x: f64, y: f64, edge_sigma_px: f64) -> f64 {
        let d = self.signed_distance(x, y);
        let covered = normal_cdf(-d / edge_sigma_px.max(1e-6));
        1.0 - self.shape.opacity * covered
    }
}

/// Standard normal CDF, via the complementary error function (Abramowitz-Stegun
/// 7.1.26, |error| < 1.5e-7, ample for 16-bit images).
pub fn normal_cdf(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erfc_abs = poly * (-x * x).exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc_abs
    } else {
        0.5 * erfc_abs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_outside_and_apex() {
        let p = ProbeSilhouette {
            apex_x_px: 100.0,
            apex_y_px: 50.0,
            angle_rad: 0.0,
            shape: ProbeShape::default(),
        };
        assert!(p.signed_distance(90.0, 50.0) < 0.0);
        assert!(p.signed_distance(110.0, 50.0) > 9.9);
        assert!(p.signed_distance(0.0, 50.0) < -19.9);
        assert!((p.signed_distance(103.0, 50.0) - 3.0).abs() < 1e-9);
        assert!(p.transmission(0.0, 50.0, 1.0) < 0.2);
        assert!(p.transmission(150.0, 50.0, 1.0) > 0.999);
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.0) - 0.841_344_7).abs() < 1e-6);
    }
}
