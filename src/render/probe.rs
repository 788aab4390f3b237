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
        self.placed().signed_distance(x, y)
    }

    /// The silhouette with its axis' sine and cosine computed once, for
    /// callers that evaluate many pixels (the tip fit: one `sin_cos` per
    /// evaluation instead of one per pixel).
    pub fn placed(&self) -> PlacedSilhouette {
        let (s, c) = self.angle_rad.sin_cos();
        PlacedSilhouette {
            apex_x_px: self.apex_x_px,
            apex_y_px: self.apex_y_px,
            sin: s,
            cos: c,
            half_width_px: 0.5 * self.shape.width_px,
            taper_px: self.shape.taper_length_px.max(1e-9),
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

/// A [`ProbeSilhouette`] with its trigonometry done: the signed distance and
/// its gradient with respect to the geometry, per pixel, without `sin_cos`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedSilhouette {
    apex_x_px: f64,
    apex_y_px: f64,
    sin: f64,
    cos: f64,
    half_width_px: f64,
    taper_px: f64,
}

/// Gradient of the signed distance with respect to apex x, apex y, axis
/// angle, width and taper length (the order of the tip fit's parameters).
pub type DistanceGradient = [f64; 5];

/// The nearest point of one silhouette edge segment (in the probe's u, v
/// frame) to a point.
struct Nearest {
    /// Distance to the segment.
    distance: f64,
    /// Position of the nearest point along the segment, 0..1.
    k: f64,
    /// Point minus nearest point.
    du: f64,
    dv: f64,
}

fn nearest_on_segment(u: f64, v: f64, ax: f64, ay: f64, bx: f64, by: f64) -> Nearest {
    let (ex, ey) = (bx - ax, by - ay);
    let k = (((u - ax) * ex + (v - ay) * ey) / (ex * ex + ey * ey)).clamp(0.0, 1.0);
    let (du, dv) = (u - ax - k * ex, v - ay - k * ey);
    Nearest {
        distance: (du.powi(2) + dv.powi(2)).sqrt(),
        k,
        du,
        dv,
    }
}

impl PlacedSilhouette {
    /// The point in the probe's frame: u along the axis (apex at 0), v across
    /// (signed), and the distance parts shared by the value and the gradient.
    #[inline]
    fn locate(&self, x: f64, y: f64) -> (f64, f64, Nearest, bool, bool) {
        let (s, c) = (self.sin, self.cos);
        let dx = x - self.apex_x_px;
        let dy = y - self.apex_y_px;
        let u = dx * c + dy * s;
        let v_signed = -dx * s + dy * c;
        let v = v_signed.abs();
        let h = self.half_width_px;
        let t = self.taper_px;
        // Symmetric in v: the half-shape is the apex edge (0,0)->(-t,h), the side
        // edge (-t,h)->(-L,h), and the far end (never in view).
        let apex_edge = nearest_on_segment(u, v, 0.0, 0.0, -t, h);
        let side_edge = nearest_on_segment(u, v, -t, h, -BODY_LENGTH_PX, h);
        let on_side = side_edge.distance < apex_edge.distance;
        let nearest = if on_side { side_edge } else { apex_edge };
        let inside_taper = u <= 0.0 && u >= -t && v <= -u * h / t;
        let inside_body = u < -t && u > -BODY_LENGTH_PX && v <= h;
        (u, v_signed, nearest, on_side, inside_taper || inside_body)
    }

    /// Signed distance from (x, y) to the silhouette edge: negative inside.
    #[inline]
    pub fn signed_distance(&self, x: f64, y: f64) -> f64 {
        let (_, _, nearest, _, inside) = self.locate(x, y);
        if inside {
            -nearest.distance
        } else {
            nearest.distance
        }
    }

    /// Signed distance and its analytic gradient with respect to (apex x,
    /// apex y, angle, width, taper). The gradient of a signed distance is the
    /// outward normal at the nearest edge point; moving a segment end moves
    /// that point in proportion to where it lies along the segment. On the
    /// edge itself (distance 0) the edge's own outward normal is used.
    pub fn signed_distance_grad(&self, x: f64, y: f64) -> (f64, DistanceGradient) {
        let (u, v_signed, nearest, on_side, inside) = self.locate(x, y);
        let (h, t) = (self.half_width_px, self.taper_px);
        // Outward normal in (u, |v|).
        let (nu, nv) = if nearest.distance > 1e-12 {
            let sign = if inside { -1.0 } else { 1.0 };
            (
                sign * nearest.du / nearest.distance,
                sign * nearest.dv / nearest.distance,
            )
        } else if on_side {
            (0.0, 1.0)
        } else {
            let len = h.hypot(t);
            (h / len, t / len)
        };
        let d = if inside {
            -nearest.distance
        } else {
            nearest.distance
        };
        // |v| folds the lower half onto the upper one.
        let fold = if v_signed < 0.0 { -1.0 } else { 1.0 };
        let (s, c) = (self.sin, self.cos);
        // d u / d(apex x, apex y, angle) = (-c, -s, v); d v / d(...) = (s, -c, -u).
        let d_ax = nu * -c + nv * fold * s;
        let d_ay = nu * -s + nv * fold * -c;
        let d_angle = nu * v_signed + nv * fold * -u;
        // The segment end (-t, h) moves the nearest point by its weight along
        // the segment: k on the apex edge (0,0)->(-t,h), 1-k on the side edge
        // (-t,h)->(-L,h), whose far end is at v = h too.
        let (d_h, d_t) = if on_side {
            (-nv, (1.0 - nearest.k) * nu)
        } else {
            (-nearest.k * nv, nearest.k * nu)
        };
        let d_t = if self.taper_px > 1e-9 { d_t } else { 0.0 };
        (d, [d_ax, d_ay, d_angle, 0.5 * d_h, d_t])
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

    #[test]
    fn distance_gradient_matches_central_differences() {
        let base = [100.3, 80.6, 0.4, 38.0, 47.0];
        let at = |q: [f64; 5]| ProbeSilhouette {
            apex_x_px: q[0],
            apex_y_px: q[1],
            angle_rad: q[2],
            shape: ProbeShape {
                width_px: q[3],
                taper_length_px: q[4],
                opacity: 1.0,
            },
        };
        let steps = [1e-5, 1e-5, 1e-7, 1e-5, 1e-5];
        let mut checked = 0;
        // A grid around the apex: in front, beside the taper, inside, over the body.
        for iy in 0..25 {
            for ix in 0..25 {
                let (x, y) = (20.0 + 4.3 * ix as f64, 20.0 + 4.1 * iy as f64);
                let (d, g) = at(base).placed().signed_distance_grad(x, y);
                assert_eq!(d, at(base).signed_distance(x, y));
                for i in 0..5 {
                    let (mut a, mut b) = (base, base);
                    a[i] += steps[i];
                    b[i] -= steps[i];
                    let fd = (at(a).signed_distance(x, y) - at(b).signed_distance(x, y))
                        / (2.0 * steps[i]);
                    // Skip the medial axis, where the nearest edge switches.
                    let one_sided = (at(a).signed_distance(x, y) - d) / steps[i];
                    if (one_sided - fd).abs() > 1e-3 * (1.0 + fd.abs()) {
                        continue;
                    }
                    assert!(
                        (fd - g[i]).abs() < 1e-4 * (1.0 + fd.abs()),
                        "({x}, {y}) param {i}: {fd} vs {}",
                        g[i]
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 2500, "only {checked} checks");
    }
}
