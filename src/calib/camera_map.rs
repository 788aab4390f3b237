//! The map from image pixels to stage coordinates: an affine part (scale,
//! rotation, shear, offset) after the objective's radial distortion, when
//! that was measured ([`RadialLens`]), and its TOML file. The fit is in
//! `camera_fit`.

use std::path::Path;

use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::lens::RadialLens;

/// Schema tag of calibration files without a lens (what older nanopush
/// reads).
pub const CALIBRATION_SCHEMA: &str = "nanopush.calibration/1";

/// Schema tag of calibration files with a lens: a reader that knows only
/// `/1` refuses them rather than ignore the lens.
pub const CALIBRATION_SCHEMA_LENS: &str = "nanopush.calibration/2";

/// A calibration, said for a person given another file for one.
const CALIBRATION_WANTED: &str = "a calibration (nanopush.calibration/1 or /2: pixel_to_stage_um, as `nanopush calibrate` and `nanopush rig calibrate` write it)";

/// Stage (metres) = linear * undistorted pixel + offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraCalibration {
    /// Metres per pixel, with rotation and shear.
    pub linear: Matrix2<f64>,
    /// Stage position of (undistorted) pixel (0, 0), metres.
    pub offset_m: Vector2<f64>,
    /// The objective's radial distortion, when it was measured.
    pub lens: Option<RadialLens>,
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
    /// The file is another nanopush kind (a scene, a rig file) given as a
    /// calibration.
    #[error("{path}: {kind}")]
    AnotherKind {
        path: String,
        kind: crate::file_schema::AnotherKind,
    },
    /// The map cannot be inverted (all pixels map to a line).
    #[error("calibration is singular (determinant {0:e}); pixels would collapse onto a line")]
    Singular(f64),
    /// Too few point pairs, or the robust fit found no consistent map.
    #[error("calibration fit failed: {0}")]
    Fit(String),
}

/// The file as written; an unknown key is refused (a misspelt `[lens]`
/// would otherwise drop the lens without a word).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CalibrationFile {
    schema: String,
    /// Rows of the 2x3 matrix [a b c; d e f]: stage_um = [a b; d e] px + [c; f],
    /// px undistorted by the lens when there is one.
    pixel_to_stage_um: [[f64; 3]; 2],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    residual_rms_px: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    inliers: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lens: Option<RadialLens>,
}

/// Most a calibration's two pixel axes may differ in length, as a ratio:
/// camera pixels are square ([`CameraCalibration::check_square_pixels`]).
const MAX_AXIS_RATIO: f64 = 1.1;
/// Plausible pixel sizes on the sample, um: an electron microscope's
/// nanometre to a low-power objective's tens of micrometres. A map outside
/// is in other units (metres, millimetres) or mistyped.
pub const PLAUSIBLE_UM_PER_PX: std::ops::RangeInclusive<f64> = 1e-3..=100.0;
/// Most the pixel axes may be off perpendicular on the sample, degrees.
const MAX_SHEAR_DEG: f64 = 5.0;

impl CameraCalibration {
    /// An affine map (no lens).
    pub fn affine(linear: Matrix2<f64>, offset_m: Vector2<f64>) -> Self {
        Self {
            linear,
            offset_m,
            lens: None,
        }
    }

    /// A map with isotropic scale, rotation and offset.
    pub fn from_scale_rotation(m_per_px: f64, angle_rad: f64, offset_m: [f64; 2]) -> Self {
        let (s, c) = angle_rad.sin_cos();
        Self::affine(
            Matrix2::new(c, -s, s, c) * m_per_px,
            Vector2::new(offset_m[0], offset_m[1]),
        )
    }

    /// This map seen through `lens`.
    pub fn with_lens(self, lens: Option<RadialLens>) -> Self {
        Self { lens, ..self }
    }

    /// Stage position (metres) of pixel (x, y).
    pub fn pixel_to_stage_m(&self, x_px: f64, y_px: f64) -> [f64; 2] {
        let [x, y] = self
            .lens
            .map_or([x_px, y_px], |l| l.undistort([x_px, y_px]));
        let v = self.linear * Vector2::new(x, y) + self.offset_m;
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
        Ok(self.lens.map_or([v[0], v[1]], |l| l.distort([v[0], v[1]])))
    }

    /// Mean scale in metres per pixel at the lens axis (square root of the
    /// determinant).
    pub fn m_per_px(&self) -> f64 {
        self.linear.determinant().abs().sqrt()
    }

    /// Refuses a map whose pixels are not square on the sample, near
    /// enough: detection and the loop take one scale ([`Self::m_per_px`])
    /// for both axes, so a sheared or stretched map puts the particles
    /// where they are not and sizes them wrong.
    pub fn check_square_pixels(&self) -> Result<(), String> {
        let (a, b) = (self.linear.column(0), self.linear.column(1));
        let (la, lb) = (a.norm(), b.norm());
        let ratio = la.max(lb) / la.min(lb);
        let shear_deg = (a.dot(&b) / (la * lb))
            .clamp(-1.0, 1.0)
            .asin()
            .abs()
            .to_degrees();
        // The map is not singular (checked on load): both axes have a length.
        if ratio > MAX_AXIS_RATIO || shear_deg > MAX_SHEAR_DEG {
            return Err(format!(
                "pixel_to_stage_um has pixel axes {:.4} and {:.4} um long, {shear_deg:.1} deg off \
                 perpendicular (at most {MAX_AXIS_RATIO}x and {MAX_SHEAR_DEG} deg: camera pixels are square)",
                la * 1e6,
                lb * 1e6
            ));
        }
        Ok(())
    }

    /// Farthest apart, metres, that this map and `other` put a pixel of a
    /// `width` x `height` frame, over a 17 x 17 grid that takes in the
    /// corners (where two affine maps differ most; with lenses the
    /// difference is smooth, so the grid finds its largest within a hair).
    pub fn largest_difference_m(&self, other: &Self, width: usize, height: usize) -> f64 {
        const STEPS: usize = 16;
        let (w, h) = (width.max(1) as f64 - 1.0, height.max(1) as f64 - 1.0);
        let along = |extent: f64, k: usize| extent * k as f64 / STEPS as f64;
        (0..=STEPS)
            .flat_map(|i| (0..=STEPS).map(move |j| (i, j)))
            .map(|(i, j)| {
                let (x, y) = (along(w, i), along(h, j));
                let (p, q) = (self.pixel_to_stage_m(x, y), other.pixel_to_stage_m(x, y));
                (p[0] - q[0]).hypot(p[1] - q[1])
            })
            .fold(0.0, f64::max)
    }

    /// TOML text of this map (lab units: micrometres).
    pub fn to_toml(&self, fit: Option<(f64, usize)>) -> String {
        let l = self.linear * 1e6;
        let o = self.offset_m * 1e6;
        let schema = match self.lens {
            Some(_) => CALIBRATION_SCHEMA_LENS,
            None => CALIBRATION_SCHEMA,
        };
        let file = CalibrationFile {
            schema: schema.into(),
            pixel_to_stage_um: [[l[(0, 0)], l[(0, 1)], o[0]], [l[(1, 0)], l[(1, 1)], o[1]]],
            residual_rms_px: fit.map(|f| f.0),
            inliers: fit.map(|f| f.1),
            lens: self.lens,
        };
        toml::to_string(&file).unwrap_or_default()
    }

    /// Parses calibration TOML; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, CalibError> {
        if let Some(kind) =
            crate::file_schema::other_toml_kind(text, CALIBRATION_SCHEMA, CALIBRATION_WANTED)
        {
            return Err(CalibError::AnotherKind {
                path: origin.into(),
                kind,
            });
        }
        let f: CalibrationFile = toml::from_str(text).map_err(|e| CalibError::Format {
            path: origin.into(),
            reason: e.to_string(),
        })?;
        if f.schema != CALIBRATION_SCHEMA && f.schema != CALIBRATION_SCHEMA_LENS {
            return Err(CalibError::Format {
                path: origin.into(),
                reason: format!(
                    "schema is {:?}, expected {CALIBRATION_SCHEMA:?} or {CALIBRATION_SCHEMA_LENS:?}",
                    f.schema
                ),
            });
        }
        // The schema says whether there is a lens: a reader of `/1` would
        // not know one, and `/2` exists so that a lens is never lost.
        match (f.schema == CALIBRATION_SCHEMA_LENS, &f.lens) {
            (true, None) => {
                return Err(CalibError::Format {
                    path: origin.into(),
                    reason: format!("schema {CALIBRATION_SCHEMA_LENS:?} needs a [lens] table"),
                });
            }
            (false, Some(_)) => {
                return Err(CalibError::Format {
                    path: origin.into(),
                    reason: format!(
                        "a [lens] table needs schema {CALIBRATION_SCHEMA_LENS:?}, not {:?}",
                        f.schema
                    ),
                });
            }
            (_, Some(lens)) => lens.check().map_err(|reason| CalibError::Format {
                path: origin.into(),
                reason,
            })?,
            (false, None) => {}
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
            lens: f.lens,
        };
        let det = cal.linear.determinant();
        if det.abs() < 1e-30 {
            return Err(CalibError::Singular(det));
        }
        let um_per_px = cal.m_per_px() * 1e6;
        if !PLAUSIBLE_UM_PER_PX.contains(&um_per_px) {
            return Err(CalibError::Format {
                path: origin.into(),
                reason: format!(
                    "pixel_to_stage_um gives {um_per_px:.3e} um/px, outside {}-{} um/px: are its numbers in micrometres?",
                    PLAUSIBLE_UM_PER_PX.start(),
                    PLAUSIBLE_UM_PER_PX.end()
                ),
            });
        }
        // Every reader takes one scale for both axes, so a stretched map is
        // refused here, once, not by each command that loads one.
        cal.check_square_pixels()
            .map_err(|reason| CalibError::Format {
                path: origin.into(),
                reason,
            })?;
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
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map in metres or nanometres (a millionth or a thousand times the
    /// scale) is refused on reading, naming its scale; one at either end
    /// of the plausible range reads. Before, a map of 1e9 um/px read, and
    /// `detect --calib` put particles at 2.5e11 um with exit 0.
    #[test]
    fn a_file_of_implausible_scale_is_refused_on_reading() {
        let file = |um: f64| {
            format!(
                "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[{um}, 0.0, 0.0], [0.0, {um}, 0.0]]\n"
            )
        };
        for um in [0.001, 0.588, 100.0] {
            let cal = CameraCalibration::from_toml(&file(um), "cal.toml").unwrap();
            assert!((cal.m_per_px() * 1e6 - um).abs() < 1e-9 * um);
        }
        for (um, says) in [
            (1e9, "1.000e9 um/px"),
            (5.88e-7, "5.880e-7 um/px"),
            (250.0, "2.500e2 um/px"),
        ] {
            let err = CameraCalibration::from_toml(&file(um), "cal.toml").unwrap_err();
            let text = err.to_string();
            assert!(text.contains("cal.toml") && text.contains(says), "{text}");
        }
    }

    #[test]
    fn a_file_of_stretched_or_sheared_pixels_is_refused_on_reading() {
        let square = CameraCalibration::from_scale_rotation(0.25e-6, 0.3, [1e-6, 2e-6]);
        let text = square.to_toml(None);
        assert!(CameraCalibration::from_toml(&text, "cal.toml").is_ok());
        for (bad, says) in [
            (
                "[[0.25, 0.0, 1.0], [0.0, 0.3, 2.0]]",
                "0.2500 and 0.3000 um long",
            ),
            (
                "[[0.25, 0.05, 1.0], [0.0, 0.25, 2.0]]",
                "11.3 deg off perpendicular",
            ),
        ] {
            let stretched =
                format!("schema = \"nanopush.calibration/1\"\npixel_to_stage_um = {bad}\n");
            let err = CameraCalibration::from_toml(&stretched, "cal.toml").unwrap_err();
            assert!(
                matches!(err, CalibError::Format { .. }) && err.to_string().contains(says),
                "{err}"
            );
        }
    }

    #[test]
    fn the_largest_difference_of_two_maps_is_at_a_corner_of_the_frame() {
        let a = CameraCalibration::from_scale_rotation(0.5e-6, 0.0, [0.0, 0.0]);
        let shifted = CameraCalibration::from_scale_rotation(0.5e-6, 0.0, [3e-6, 4e-6]);
        assert!((a.largest_difference_m(&shifted, 100, 100) - 5e-6).abs() < 1e-15);
        // Turned by 0.01 rad about pixel (0, 0): the far corner, 99 sqrt(2)
        // px out, moves by about 0.01 of its 70 um.
        let turned = CameraCalibration::from_scale_rotation(0.5e-6, 0.01, [0.0, 0.0]);
        let far = 0.5e-6 * 99.0 * 2f64.sqrt();
        let d = a.largest_difference_m(&turned, 100, 100);
        assert!((d - 2.0 * far * (0.005f64).sin()).abs() < 1e-12, "{d}");
    }

    #[test]
    fn toml_round_trip_and_inverse() {
        let c = CameraCalibration::from_scale_rotation(0.15e-6, 0.1, [5e-6, -3e-6]);
        let back = CameraCalibration::from_toml(&c.to_toml(Some((0.1, 9))), "mem").unwrap();
        assert!((back.linear - c.linear).norm() < 1e-15);
        assert!((back.offset_m - c.offset_m).norm() < 1e-15);
        let s = c.pixel_to_stage_m(100.0, 50.0);
        let p = c.stage_to_pixel(s[0], s[1]).unwrap();
        assert!((p[0] - 100.0).abs() < 1e-9 && (p[1] - 50.0).abs() < 1e-9);
        assert!(
            CameraCalibration::from_toml(
                "schema = \"x\"\npixel_to_stage_um = [[1,0,0],[0,1,0]]",
                "m"
            )
            .is_err()
        );
        assert!(matches!(
            CameraCalibration::from_toml(
                "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[1,2,0],[2,4,0]]",
                "m"
            ),
            Err(CalibError::Singular(_))
        ));
    }

    #[test]
    fn a_lens_reads_back_under_its_own_schema_and_a_bad_one_is_refused() {
        let lens = RadialLens::centred_on(1024, 768, -0.006);
        let c = CameraCalibration::from_scale_rotation(0.3e-6, 0.1, [5e-6, -3e-6])
            .with_lens(Some(lens));
        let text = c.to_toml(Some((0.04, 19)));
        assert!(text.contains(CALIBRATION_SCHEMA_LENS), "{text}");
        let back = CameraCalibration::from_toml(&text, "mem").unwrap();
        assert_eq!(back.lens, Some(lens));
        assert!(back.largest_difference_m(&c, 1024, 768) < 1e-15);
        // Through the lens and back, in a corner and outside the frame.
        for p in [[0.0, 0.0], [1023.0, 767.0], [-300.0, 900.0]] {
            let s = c.pixel_to_stage_m(p[0], p[1]);
            let q = c.stage_to_pixel(s[0], s[1]).unwrap();
            assert!(
                (q[0] - p[0]).abs() < 1e-6 && (q[1] - p[1]).abs() < 1e-6,
                "{q:?}"
            );
        }
        // Without the lens the corner lies elsewhere: the lens is used.
        let affine = c.with_lens(None);
        assert!(affine.largest_difference_m(&c, 1024, 768) > 0.5e-6);
        let strong = text.replace("k1 = -0.006", "k1 = 0.5");
        assert_ne!(strong, text);
        let err = CameraCalibration::from_toml(&strong, "cal.toml").unwrap_err();
        assert!(err.to_string().contains("k1 0.5"), "{err}");
        // A file without a lens is what it was before lenses.
        assert!(c.with_lens(None).to_toml(None).contains(CALIBRATION_SCHEMA));
        // A misspelt table, a `/2` without its lens, a lens under `/1`:
        // refused, not read as a map without a lens.
        let misspelt = text.replace("[lens]", "[lense]");
        let err = CameraCalibration::from_toml(&misspelt, "cal.toml").unwrap_err();
        assert!(err.to_string().contains("lense"), "{err}");
        let lens_at = text.find("[lens]").unwrap();
        let err = CameraCalibration::from_toml(&text[..lens_at], "cal.toml").unwrap_err();
        assert!(err.to_string().contains("needs a [lens] table"), "{err}");
        let old = text.replace(CALIBRATION_SCHEMA_LENS, CALIBRATION_SCHEMA);
        let err = CameraCalibration::from_toml(&old, "cal.toml").unwrap_err();
        assert!(err.to_string().contains("needs schema"), "{err}");
    }
}
