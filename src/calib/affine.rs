//! Affine map from image pixels to stage coordinates (scale, rotation, shear,
//! offset), its TOML file, and the robust fit from pairs of tip positions.
//!
//! The fit uses OpenCV calib3d `estimateAffine2D` (RANSAC + Levenberg-Marquardt
//! refinement) from stage to pixels, so the inlier threshold is in pixels, and
//! inverts the result. Lens distortion is not modelled.

use std::path::Path;

use nalgebra::{Matrix2, Vector2};
use opencv::core::{Mat, MatTraitConst, Point2d, Vector};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Schema tag of calibration files.
pub const CALIBRATION_SCHEMA: &str = "nanopush.calibration/1";

/// Stage (metres) = linear * pixel + offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AffineCalibration {
    /// Metres per pixel, with rotation and shear.
    pub linear: Matrix2<f64>,
    /// Stage position of pixel (0, 0), metres.
    pub offset_m: Vector2<f64>,
}

/// Ways calibration can fail.
#[derive(Debug, Error)]
pub enum CalibError {
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    /// The TOML is malformed or has the wrong schema.
    #[error("{path}: {reason}")]
    Format { path: String, reason: String },
    /// The map cannot be inverted (all pixels map to a line).
    #[error("calibration is singular (determinant {0:e}); pixels would collapse onto a line")]
    Singular(f64),
    /// Too few point pairs, or the robust fit found no consistent map.
    #[error("calibration fit failed: {0}")]
    Fit(String),
}

#[derive(Serialize, Deserialize)]
struct CalibrationFile {
    schema: String,
    /// Rows of the 2x3 matrix [a b c; d e f]: stage_um = [a b; d e] px + [c; f].
    pixel_to_stage_um: [[f64; 3]; 2],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    residual_rms_px: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    inliers: Option<usize>,
}

/// What a robust fit produced and how well it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFit {
    /// The map.
    pub calibration: AffineCalibration,
    /// Per pair: pixel residual (observed - predicted), and whether RANSAC kept it.
    pub residuals_px: Vec<(f64, f64, bool)>,
    /// RMS pixel residual of the inliers.
    pub rms_px: f64,
    /// Number of inliers.
    pub inliers: usize,
}

impl AffineCalibration {
    /// A map with isotropic scale, rotation and offset.
    pub fn from_scale_rotation(m_per_px: f64, angle_rad: f64, offset_m: [f64; 2]) -> Self {
        let (s, c) = angle_rad.sin_cos();
        Self {
            linear: Matrix2::new(c, -s, s, c) * m_per_px,
            offset_m: Vector2::new(offset_m[0], offset_m[1]),
        }
    }

    /// Stage position (metres) of pixel (x, y).
    pub fn pixel_to_stage_m(&self, x_px: f64, y_px: f64) -> [f64; 2] {
        let v = self.linear * Vector2::new(x_px, y_px) + self.offset_m;
        [v[0], v[1]]
    }

    /// Pixel of stage position (metres).
    pub fn stage_to_pixel(&self, x_m: f64, y_m: f64) -> Result<[f64; 2], CalibError> {
        let det = self.linear.determinant();
        let inv = self
            .linear
            .try_inverse()
            .filter(|_| det.abs() > 1e-30)
            .ok_or(CalibError::Singular(det))?;
        let v = inv * (Vector2::new(x_m, y_m) - self.offset_m);
        Ok([v[0], v[1]])
    }

    /// Mean scale in metres per pixel (square root of the determinant).
    pub fn m_per_px(&self) -> f64 {
        self.linear.determinant().abs().sqrt()
    }

    /// Farthest apart, metres, that this map and `other` put a pixel of a
    /// `width` x `height` frame. Their difference is affine, so its length
    /// is largest at a corner.
    pub fn largest_difference_m(&self, other: &Self, width: usize, height: usize) -> f64 {
        let (w, h) = (width.max(1) as f64 - 1.0, height.max(1) as f64 - 1.0);
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(x, y)| {
                let (p, q) = (self.pixel_to_stage_m(x, y), other.pixel_to_stage_m(x, y));
                (p[0] - q[0]).hypot(p[1] - q[1])
            })
            .fold(0.0, f64::max)
    }

    /// TOML text of this map (lab units: micrometres).
    pub fn to_toml(&self, fit: Option<(f64, usize)>) -> String {
        let l = self.linear * 1e6;
        let o = self.offset_m * 1e6;
        let file = CalibrationFile {
            schema: CALIBRATION_SCHEMA.into(),
            pixel_to_stage_um: [[l[(0, 0)], l[(0, 1)], o[0]], [l[(1, 0)], l[(1, 1)], o[1]]],
            residual_rms_px: fit.map(|f| f.0),
            inliers: fit.map(|f| f.1),
        };
        toml::to_string(&file).unwrap_or_default()
    }

    /// Parses calibration TOML; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, CalibError> {
        let f: CalibrationFile = toml::from_str(text).map_err(|e| CalibError::Format {
            path: origin.into(),
            reason: e.to_string(),
        })?;
        if f.schema != CALIBRATION_SCHEMA {
            return Err(CalibError::Format {
                path: origin.into(),
                reason: format!("schema is {:?}, expected {CALIBRATION_SCHEMA:?}", f.schema),
            });
        }
        let m = f.pixel_to_stage_um;
        if m.iter().flatten().any(|v| !v.is_finite()) {
            return Err(CalibError::Format {
                path: origin.into(),
                reason: "pixel_to_stage_um holds a non-finite number".into(),
            });
        }
        let cal = Self {
            linear: Matrix2::new(m[0][0], m[0][1], m[1][0], m[1][1]) * 1e-6,
            offset_m: Vector2::new(m[0][2], m[1][2]) * 1e-6,
        };
        let det = cal.linear.determinant();
        if det.abs() < 1e-30 {
            return Err(CalibError::Singular(det));
        }
        Ok(cal)
    }

    /// Reads a calibration TOML file.
    pub fn load(path: &Path) -> Result<Self, CalibError> {
        let text = std::fs::read_to_string(path).map_err(|source| CalibError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Robust fit from pairs (pixel, stage metres); pairs whose pixel residual
    /// exceeds `threshold_px` are outliers.
    pub fn fit_ransac(
        pixels: &[[f64; 2]],
        stage_m: &[[f64; 2]],
        threshold_px: f64,
    ) -> Result<CalibrationFit, CalibError> {
        if pixels.len() != stage_m.len() || pixels.len() < 3 {
            return Err(CalibError::Fit(format!(
                "need at least 3 matching pairs, got {} pixels and {} stage positions",
                pixels.len(),
                stage_m.len()
            )));
        }
        if !(threshold_px.is_finite() && threshold_px > 0.0)
            || pixels
                .iter()
                .chain(stage_m)
                .flatten()
                .any(|v| !v.is_finite())
        {
            return Err(CalibError::Fit("non-finite input or threshold".into()));
        }
        // Fit stage (um) -> pixel so that RANSAC's threshold is in pixels.
        let from: Vector<Point2d> = stage_m
            .iter()
            .map(|s| Point2d::new(s[0] * 1e6, s[1] * 1e6))
            .collect();
        let to: Vector<Point2d> = pixels.iter().map(|p| Point2d::new(p[0], p[1])).collect();
        let mut inlier_mask = Mat::default();
        let m = opencv::calib3d::estimate_affine_2d(
            &from,
            &to,
            &mut inlier_mask,
            opencv::calib3d::RANSAC,
            threshold_px,
            2000,
            0.999,
            10,
        )
        .map_err(|e| CalibError::Fit(e.to_string()))?;
        if m.empty() || m.rows() != 2 || m.cols() != 3 {
            return Err(CalibError::Fit(
                "RANSAC found no consistent affine map".into(),
            ));
        }
        let at = |r: i32, c: i32| {
            m.at_2d::<f64>(r, c)
                .copied()
                .map_err(|e| CalibError::Fit(e.to_string()))
        };
        let a = Matrix2::new(at(0, 0)?, at(0, 1)?, at(1, 0)?, at(1, 1)?); // px per um
        let t = Vector2::new(at(0, 2)?, at(1, 2)?);
        let det = a.determinant();
        let inv = a
            .try_inverse()
            .filter(|_| det.abs() > 1e-30)
            .ok_or(CalibError::Singular(det))?;
        let calibration = Self {
            linear: inv * 1e-6,
            offset_m: -(inv * t) * 1e-6,
        };
        let mut residuals_px = Vec::with_capacity(pixels.len());
        let (mut ss, mut n) = (0.0, 0usize);
        for (i, (p, s)) in pixels.iter().zip(stage_m).enumerate() {
            let pred = a * Vector2::new(s[0] * 1e6, s[1] * 1e6) + t;
            let (dx, dy) = (p[0] - pred[0], p[1] - pred[1]);
            let inlier = inlier_mask
                .at::<u8>(i as i32)
                .map(|v| *v != 0)
                .unwrap_or(false);
            if inlier {
                ss += dx * dx + dy * dy;
                n += 1;
            }
            residuals_px.push((dx, dy, inlier));
        }
        if n < 3 {
            return Err(CalibError::Fit(format!("only {n} inliers")));
        }
        Ok(CalibrationFit {
            calibration,
            residuals_px,
            rms_px: (ss / n as f64).sqrt(),
            inliers: n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_difference_of_two_maps_is_at_a_corner_of_the_frame() {
        let a = AffineCalibration::from_scale_rotation(0.5e-6, 0.0, [0.0, 0.0]);
        let shifted = AffineCalibration::from_scale_rotation(0.5e-6, 0.0, [3e-6, 4e-6]);
        assert!((a.largest_difference_m(&shifted, 100, 100) - 5e-6).abs() < 1e-15);
        // Turned by 0.01 rad about pixel (0, 0): the far corner, 99 sqrt(2)
        // px out, moves by about 0.01 of its 70 um.
        let turned = AffineCalibration::from_scale_rotation(0.5e-6, 0.01, [0.0, 0.0]);
        let far = 0.5e-6 * 99.0 * 2f64.sqrt();
        let d = a.largest_difference_m(&turned, 100, 100);
        assert!((d - 2.0 * far * (0.005f64).sin()).abs() < 1e-12, "{d}");
    }

    #[test]
    fn toml_round_trip_and_inverse() {
        let c = AffineCalibration::from_scale_rotation(0.15e-6, 0.1, [5e-6, -3e-6]);
        let back = AffineCalibration::from_toml(&c.to_toml(Some((0.1, 9))), "mem").unwrap();
        assert!((back.linear - c.linear).norm() < 1e-15);
        assert!((back.offset_m - c.offset_m).norm() < 1e-15);
        let s = c.pixel_to_stage_m(100.0, 50.0);
        let p = c.stage_to_pixel(s[0], s[1]).unwrap();
        assert!((p[0] - 100.0).abs() < 1e-9 && (p[1] - 50.0).abs() < 1e-9);
        assert!(
            AffineCalibration::from_toml(
                "schema = \"x\"\npixel_to_stage_um = [[1,0,0],[0,1,0]]",
                "m"
            )
            .is_err()
        );
        assert!(matches!(
            AffineCalibration::from_toml(
                "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[1,2,0],[2,4,0]]",
                "m"
            ),
            Err(CalibError::Singular(_))
        ));
    }

    #[test]
    fn ransac_recovers_map_despite_an_outlier() {
        let truth = AffineCalibration::from_scale_rotation(0.2e-6, -0.05, [10e-6, 20e-6]);
        let mut px = Vec::new();
        let mut st = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                let p = [50.0 + 100.0 * i as f64, 40.0 + 90.0 * j as f64];
                px.push(p);
                st.push(truth.pixel_to_stage_m(p[0], p[1]));
            }
        }
        px[7][0] += 30.0;
        let fit = AffineCalibration::fit_ransac(&px, &st, 1.0).unwrap();
        assert_eq!(fit.inliers, 24);
        assert!(!fit.residuals_px[7].2);
        println!(
            "rms {} linear err {}",
            fit.rms_px,
            (fit.calibration.linear - truth.linear).norm()
        );
        assert!(fit.rms_px < 1e-3);
        assert!((fit.calibration.linear - truth.linear).norm() < 1e-6 * truth.m_per_px());
    }
}
