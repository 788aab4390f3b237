//! Whether a fitted calibration can be trusted: enough frames agreeing on
//! it to check it, residuals a detected apex allows, and tip positions
//! spread over the frame. Why: `calibrate` had written, with exit 0, an
//! exact fit through 3 frames ("RMS residual 0.000 px"), a map 7 of 19
//! frames agreed on, and one from half the view of an interrupted run; and
//! `rig calibrate` makes what it writes the rig's calibration.

use super::camera_fit::CalibrationFit;

/// Fewest frames the map must fit: an affine map takes 3 exactly, so 3 more
/// are what checks it.
pub const MIN_INLIERS: usize = 6;

/// Whether `frames` tip positions are enough for a map [`judge`] accepts
/// (at least [`MIN_INLIERS`]): the one rule, for a command that advises a
/// fit of frames it saved as well as for the fit itself.
pub fn enough_to_fit(frames: usize) -> bool {
    frames >= MIN_INLIERS
}

/// Smallest share of the frames with a tip that must agree on the map; below,
/// the stage log and the frames do not belong together (order, units, a
/// wrong file) or the tip was found elsewhere.
pub const MIN_INLIER_SHARE: f64 = 0.5;

/// RMS residual above which the map is written with a warning: the apex is
/// located to ~0.2 px on a focused frame (the simulated rig's fit: 0.22 px).
pub const WARN_RMS_PX: f64 = 0.5;

/// Share of the frame's width and height the agreeing apexes should span;
/// beyond them the map is extrapolated.
pub const WARN_SPAN_SHARE: f64 = 0.5;

/// A fit's verdict: why it must not be written, and what to say if it is.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FitVerdict {
    /// Set when the map must not be used.
    pub refusal: Option<String>,
    /// Doubts worth a warning.
    pub warnings: Vec<String>,
}

/// Judges `fit` of the apexes `pixels` in frames `frame_px` (width, height) wide.
pub fn judge(fit: &CalibrationFit, pixels: &[[f64; 2]], frame_px: (usize, usize)) -> FitVerdict {
    let mut verdict = FitVerdict::default();
    let n = pixels.len();
    if !enough_to_fit(fit.inliers) {
        verdict.refusal = Some(format!(
            "only {} fit the map (of {n} with a tip): an affine map takes 3 exactly, and at least {MIN_INLIERS} are needed to check it; record more (nanopush rig calibrate --grid 3 or more)",
            crate::wording::counted(fit.inliers, "frame")
        ));
    } else if (fit.inliers as f64) < MIN_INLIER_SHARE * n as f64 {
        verdict.refusal = Some(format!(
            "only {} of {n} frames fit one map: do stage.csv's rows belong to these frames (order, unit), and is the tip found where it is? The table names the frames off the map",
            fit.inliers
        ));
    }
    if fit.rms_px > WARN_RMS_PX {
        verdict.warnings.push(format!(
            "RMS residual {:.2} px (a focused apex fits to ~0.2 px): every position the camera gives is that uncertain; check focus and the frames marked off",
            fit.rms_px
        ));
    }
    let kept: Vec<[f64; 2]> = pixels
        .iter()
        .zip(&fit.residuals_px)
        .filter(|(_, r)| r.2)
        .map(|(p, _)| *p)
        .collect();
    let span = |axis: usize| {
        let (lo, hi) = kept
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[axis]), hi.max(p[axis]))
            });
        (hi - lo).max(0.0)
    };
    let (w, h) = (frame_px.0.max(1) as f64, frame_px.1.max(1) as f64);
    let (sx, sy) = (span(0) / w, span(1) / h);
    if !kept.is_empty() && (sx < WARN_SPAN_SHARE || sy < WARN_SPAN_SHARE) {
        verdict.warnings.push(format!(
            "the tip was seen over {:.0} % of the frame's width and {:.0} % of its height: beyond, the map is extrapolated; a grid across the view fits it better",
            100.0 * sx,
            100.0 * sy
        ));
    }
    verdict
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::camera_map::CameraCalibration;

    fn fit(inliers: usize, of: usize, rms_px: f64) -> CalibrationFit {
        CalibrationFit {
            calibration: CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [0.0, 0.0]),
            residuals_px: (0..of).map(|k| (0.0, 0.0, k < inliers)).collect(),
            rms_px,
            inliers,
            affine_rms_px: rms_px,
            lens_skipped: None,
        }
    }

    fn grid(n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|k| {
                [
                    20.0 + 200.0 * (k % 4) as f64 / 3.0,
                    20.0 + 60.0 * (k / 4) as f64,
                ]
            })
            .collect()
    }

    #[test]
    fn too_few_or_too_few_agreeing_frames_are_refused() {
        let refused = |inliers, of| judge(&fit(inliers, of, 0.1), &grid(of), (256, 256)).refusal;
        let why = refused(3, 3).expect("an exact fit through 3 frames");
        assert!(why.contains("at least 6"), "{why}");
        let why = refused(7, 19).expect("7 of 19 frames agreeing");
        assert!(why.contains("7 of 19"), "{why}");
        assert_eq!(refused(16, 19), None);
        assert_eq!(refused(6, 12), None);
    }

    #[test]
    fn loose_or_narrow_fits_are_warned_of() {
        let wide = judge(&fit(16, 16, 0.2), &grid(16), (256, 256));
        assert_eq!(wide, FitVerdict::default());
        let loose = judge(&fit(16, 16, 1.02), &grid(16), (256, 256));
        assert!(
            loose.warnings.iter().any(|w| w.contains("1.02 px")),
            "{loose:?}"
        );
        // Half the view's tip positions, as an interrupted run leaves them.
        let narrow: Vec<[f64; 2]> = grid(16).iter().map(|p| [p[0] * 0.4, p[1]]).collect();
        let half = judge(&fit(16, 16, 0.2), &narrow, (256, 256));
        assert!(
            half.warnings
                .iter()
                .any(|w| w.contains("of the frame's width")),
            "{half:?}"
        );
    }
}
