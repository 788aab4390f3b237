//! Radial lens distortion, the first term of the Brown-Conrady model. A
//! microscope objective bends the view a little towards or away from its
//! axis, more the farther out: an affine map alone can be off by a few
//! pixels in the corners, which at 0.3 um/px is more than a site's
//! tolerance. The lens is centred where the calibration put it (the
//! frame's centre); `k1` is the fraction by which a point at `radius_px`
//! from the centre (the frame's half-diagonal) is moved outward
//! (negative: inward, barrel distortion).

use serde::{Deserialize, Serialize};

/// Largest |k1| a lens may have: 10 % at the frame's corner is far beyond
/// a microscope objective, and keeps the model one-to-one (below).
pub const K1_LIMIT: f64 = 0.1;

/// Beyond this many radii from the centre (well outside any frame) the
/// model goes on in a straight line, so every stage point has one pixel.
const REACH_RADII: f64 = 1.5;

/// A radial lens: undistorted = centre + (pixel - centre)(1 + k1 (r / radius)^2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadialLens {
    /// The lens axis in the frame, pixels.
    pub centre_px: [f64; 2],
    /// The radius `k1` is stated at, pixels (the half-diagonal of the
    /// frame the lens was fitted on).
    pub radius_px: f64,
    /// Fractional outward shift at `radius_px` (negative: inward).
    pub k1: f64,
}

impl RadialLens {
    /// A lens on the centre of a `width` x `height` frame, `k1` stated at
    /// its half-diagonal.
    pub fn centred_on(width: usize, height: usize, k1: f64) -> Self {
        let (w, h) = (width as f64, height as f64);
        Self {
            centre_px: [0.5 * (w - 1.0), 0.5 * (h - 1.0)],
            radius_px: 0.5 * w.hypot(h),
            k1,
        }
    }

    /// Why this lens cannot be used, if it cannot.
    pub fn check(&self) -> Result<(), String> {
        if !(self.centre_px.iter().all(|v| v.is_finite())
            && self.radius_px.is_finite()
            && self.radius_px > 0.0
            && self.k1.is_finite())
        {
            return Err(format!(
                "lens centre {:?} px, radius {} px, k1 {}: every value must be a finite number, the radius positive",
                self.centre_px, self.radius_px, self.k1
            ));
        }
        if self.k1.abs() > K1_LIMIT {
            return Err(format!(
                "lens k1 {} is beyond +/-{K1_LIMIT} (a shift of {:.0} % at the frame's corner): not a microscope objective",
                self.k1,
                100.0 * self.k1.abs()
            ));
        }
        Ok(())
    }

    /// Where the camera's pixel `p` would lie without the lens.
    pub fn undistort(&self, p: [f64; 2]) -> [f64; 2] {
        self.along_ray(p, |r| self.radial(r))
    }

    /// The camera pixel that shows the undistorted point `u` (the inverse
    /// of [`Self::undistort`]).
    pub fn distort(&self, u: [f64; 2]) -> [f64; 2] {
        self.along_ray(u, |r| self.inverse_radial(r))
    }

    /// `p` moved along its ray from the centre to the radius `to` gives
    /// its radius.
    fn along_ray(&self, p: [f64; 2], to: impl Fn(f64) -> f64) -> [f64; 2] {
        let (dx, dy) = (p[0] - self.centre_px[0], p[1] - self.centre_px[1]);
        let r = dx.hypot(dy);
        if r == 0.0 {
            return p;
        }
        let gain = to(r) / r;
        [self.centre_px[0] + dx * gain, self.centre_px[1] + dy * gain]
    }

    /// The pixel radius whose undistorted radius is `target`: Newton's
    /// method on the cubic, the straight line beyond the reach.
    fn inverse_radial(&self, target: f64) -> f64 {
        let reach = REACH_RADII * self.radius_px;
        if target >= self.radial(reach) {
            return reach + (target - self.radial(reach)) / self.slope(reach);
        }
        let mut r = target.min(reach);
        for _ in 0..50 {
            let step = (self.radial(r) - target) / self.slope(r);
            r = (r - step).clamp(0.0, reach);
            if step.abs() < 1e-12 * self.radius_px {
                break;
            }
        }
        r
    }

    /// How far the lens moves the farthest pixel of a `width` x `height`
    /// frame, pixels.
    pub fn largest_shift_px(&self, width: usize, height: usize) -> f64 {
        let (w, h) = (width.max(1) as f64 - 1.0, height.max(1) as f64 - 1.0);
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(x, y)| {
                let u = self.undistort([x, y]);
                (u[0] - x).hypot(u[1] - y)
            })
            .fold(0.0, f64::max)
    }

    /// Undistorted radius of a pixel `r` from the centre: a cubic out to
    /// the reach, a straight line beyond it.
    fn radial(&self, r: f64) -> f64 {
        let reach = REACH_RADII * self.radius_px;
        if r <= reach {
            r * (1.0 + self.k1 * (r / self.radius_px).powi(2))
        } else {
            self.radial(reach) + self.slope(reach) * (r - reach)
        }
    }

    /// d radial / d r, positive for |k1| <= K1_LIMIT (one-to-one).
    fn slope(&self, r: f64) -> f64 {
        let s = r.min(REACH_RADII * self.radius_px) / self.radius_px;
        1.0 + 3.0 * self.k1 * s * s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distort_undoes_undistort_in_the_frame_and_far_outside_it() {
        for k1 in [-K1_LIMIT, -0.01, 0.0, 0.004, K1_LIMIT] {
            let lens = RadialLens::centred_on(640, 480, k1);
            for p in [
                [0.0, 0.0],
                [639.0, 479.0],
                [319.5, 239.5],
                [100.0, 400.0],
                [-2000.0, 5000.0],
            ] {
                let back = lens.distort(lens.undistort(p));
                let err = (back[0] - p[0]).hypot(back[1] - p[1]);
                assert!(err < 1e-6, "k1 {k1} at {p:?}: {back:?}");
            }
        }
    }

    #[test]
    fn k1_is_the_fractional_shift_at_the_half_diagonal() {
        let lens = RadialLens::centred_on(101, 101, -0.02);
        // The corner (0, 0) is radius_px from the centre (50, 50) within
        // half a pixel's diagonal; it moves inward by about 2 % of that.
        let corner = lens.undistort([0.0, 0.0]);
        let (r0, r1) = (50f64.hypot(50.0), 50.0 - corner[0]);
        let expected = r0 * (1.0 - 0.02 * (r0 / lens.radius_px).powi(2));
        assert!((r1 * 2f64.sqrt() - expected).abs() < 1e-9);
        assert!((lens.largest_shift_px(101, 101) - (r0 - expected)).abs() < 1e-9);
        assert_eq!(lens.undistort(lens.centre_px), lens.centre_px);
    }

    #[test]
    fn an_impossible_lens_is_refused_by_name() {
        let strong = RadialLens::centred_on(100, 100, 0.5);
        assert!(strong.check().unwrap_err().contains("k1 0.5"));
        let bad = RadialLens {
            radius_px: 0.0,
            ..RadialLens::centred_on(100, 100, 0.0)
        };
        assert!(bad.check().unwrap_err().contains("radius"));
        assert!(RadialLens::centred_on(100, 100, -0.05).check().is_ok());
    }
}
