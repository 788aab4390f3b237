//! The robust fit of the pixel-to-stage map from pairs of tip positions
//! (pixel, stage). OpenCV calib3d `estimateAffine2D` (RANSAC +
//! Levenberg-Marquardt) fits stage to pixels, so the inlier threshold is
//! in pixels. Then, when asked and the pairs can tell, the lens: its `k1`
//! by a one-dimensional search whose every point is the affine
//! least-squares fit of the pixels undistorted by that `k1` (variable
//! projection: the map is linear once the lens is fixed), the inliers
//! taken again through the new map until they stay the same.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use opencv::core::{Mat, MatTraitConst, Point2d, Vector};

use super::camera_map::{CalibError, CameraCalibration};
use super::lens::{K1_LIMIT, RadialLens};

/// Whether a fit includes the objective's radial distortion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LensModel {
    /// Fit the lens when the pairs can tell it (enough of them, spread
    /// over the frame) and keep it when it fits clearly better than an
    /// affine map; an affine map otherwise.
    Auto,
    /// Fit the lens; refuse pairs that cannot tell it.
    Radial,
    /// An affine map only.
    None,
}

/// Fewest inlier pairs a lens is fitted from: its one parameter on top of
/// the affine map's six, with room to see it.
pub const LENS_MIN_PAIRS: usize = 8;

/// How far out, as a fraction of the frame's half-diagonal, some pair must
/// lie for the lens to show (it grows with the square of the radius).
const LENS_MIN_SPREAD: f64 = 0.3;

/// Rounds of refitting the lens with the inliers taken again.
const LENS_ROUNDS: usize = 5;

/// With a lens, pairs farther off than this many robust standard
/// deviations (or the threshold) are outliers: the lens is a small effect
/// that a tip mislocated by a pixel would bend (on the simulated
/// microscope, a few apexes seen beside a particle are off by 1 px along
/// the probe's axis while the rest are within 0.2 px). 3.7 sigma is the
/// 99.9th percentile of a 2-d Gaussian's length.
const LENS_CLIP_SIGMAS: f64 = 3.7;

/// Smallest clipping radius, pixels: below it, residuals are a locator's
/// finest noise, not outliers.
const LENS_CLIP_FLOOR_PX: f64 = 0.1;

/// How much better than the affine map alone the lens must fit the same
/// pairs for `LensModel::Auto` to keep it: the F statistic of its one
/// parameter (about the 0.1 % tail of F(1, 20)).
const LENS_MIN_F: f64 = 15.0;

/// What a robust fit produced and how well it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFit {
    /// The map.
    pub calibration: CameraCalibration,
    /// Per pair: pixel residual (observed - predicted), and whether the fit kept it.
    pub residuals_px: Vec<(f64, f64, bool)>,
    /// RMS pixel residual of the inliers.
    pub rms_px: f64,
    /// Number of inliers.
    pub inliers: usize,
    /// RMS pixel residual of the affine map alone, on the map's own inliers
    /// (beside `rms_px`, what the lens bought).
    pub affine_rms_px: f64,
    /// Why `LensModel::Auto` fitted no lens, when it did not.
    pub lens_skipped: Option<String>,
}

/// A tip position: (pixel, stage micrometres).
type Pair = ([f64; 2], [f64; 2]);

/// Stage (micrometres) to (undistorted) pixel: `a * stage + t`.
#[derive(Debug, Clone, Copy)]
struct StageToPixel {
    a: Matrix2<f64>,
    t: Vector2<f64>,
}

impl StageToPixel {
    fn predict(&self, s_um: [f64; 2]) -> [f64; 2] {
        let v = self.a * Vector2::new(s_um[0], s_um[1]) + self.t;
        [v[0], v[1]]
    }

    /// The pixel -> stage (metres) map this is the inverse of.
    fn calibration(&self, lens: Option<RadialLens>) -> Result<CameraCalibration, CalibError> {
        let det = self.a.determinant();
        let inv = self
            .a
            .try_inverse()
            .filter(|_| det.abs() > 1e-30)
            .ok_or(CalibError::Singular(det))?;
        Ok(CameraCalibration::affine(inv * 1e-6, -(inv * self.t) * 1e-6).with_lens(lens))
    }
}

/// Robust fit from pairs (pixel, stage metres) of a frame `frame_px`
/// (width, height) wide; pairs whose pixel residual exceeds `threshold_px`
/// are outliers.
pub fn fit_camera_map(
    pixels: &[[f64; 2]],
    stage_m: &[[f64; 2]],
    threshold_px: f64,
    lens: LensModel,
    frame_px: (usize, usize),
) -> Result<CalibrationFit, CalibError> {
    if pixels.len() != stage_m.len() || pixels.len() < 3 {
        return Err(CalibError::Fit(format!(
            "need at least 3 matching pairs, got {} and {}",
            crate::wording::counted(pixels.len(), "pixel"),
            crate::wording::counted(stage_m.len(), "stage position")
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
    let stage_um: Vec<[f64; 2]> = stage_m.iter().map(|s| [s[0] * 1e6, s[1] * 1e6]).collect();
    let (affine, ransac_inliers) = ransac_affine(pixels, &stage_um, threshold_px)?;
    let affine_residuals = residuals(&affine, None, pixels, &stage_um);
    let axis = RadialLens::centred_on(frame_px.0, frame_px.1, 0.0);
    // The lens when it is asked for and the pairs can tell it; else why not.
    let lens_fit = lens_wanted(lens, pixels, &ransac_inliers, &axis).and_then(|asked| {
        asked
            .then(|| {
                fit_with_lens(
                    pixels,
                    &stage_um,
                    ransac_inliers.clone(),
                    axis,
                    threshold_px,
                )
            })
            .transpose()
            .map_err(|e| e.to_string())
    });
    let (map, lens, inliers, lens_skipped) = match lens_fit {
        Ok(None) => (affine, None, ransac_inliers, None),
        Ok(Some(fit)) if lens == LensModel::Auto && fit.f_statistic < LENS_MIN_F => {
            let why = format!(
                "k1 {:+.5} fits the tip positions hardly better than an affine map (F {:.1} < {LENS_MIN_F})",
                fit.lens.k1, fit.f_statistic
            );
            (affine, None, ransac_inliers, Some(why))
        }
        Ok(Some(fit)) => (fit.map, Some(fit.lens), fit.inliers, None),
        Err(reason) if lens == LensModel::Auto => (affine, None, ransac_inliers, Some(reason)),
        Err(reason) => return Err(CalibError::Fit(reason)),
    };
    let kept = inliers.iter().filter(|&&k| k).count();
    if kept < 3 {
        return Err(CalibError::Fit(format!(
            "only {}",
            crate::wording::counted(kept, "inlier")
        )));
    }
    let r = residuals(&map, lens, pixels, &stage_um);
    // Over the same inliers as the map's RMS: over RANSAC's, which the lens
    // fit may thin, "an affine map alone left 0.221 px" set beside the
    // lens's 0.069 px credited the lens with the 3 frames it dropped.
    let affine_rms_px = rms(&affine_residuals, &inliers);
    Ok(CalibrationFit {
        calibration: map.calibration(lens)?,
        rms_px: rms(&r, &inliers),
        residuals_px: r
            .iter()
            .zip(&inliers)
            .map(|(d, &k)| (d[0], d[1], k))
            .collect(),
        inliers: kept,
        affine_rms_px,
        lens_skipped,
    })
}

/// RANSAC affine stage -> pixel map and its inliers (OpenCV calib3d).
fn ransac_affine(
    pixels: &[[f64; 2]],
    stage_um: &[[f64; 2]],
    threshold_px: f64,
) -> Result<(StageToPixel, Vec<bool>), CalibError> {
    let from: Vector<Point2d> = stage_um.iter().map(|s| Point2d::new(s[0], s[1])).collect();
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
    let map = StageToPixel {
        a: Matrix2::new(at(0, 0)?, at(0, 1)?, at(1, 0)?, at(1, 1)?),
        t: Vector2::new(at(0, 2)?, at(1, 2)?),
    };
    let inliers = (0..pixels.len())
        .map(|i| inlier_mask.at::<u8>(i as i32).is_ok_and(|v| *v != 0))
        .collect();
    Ok((map, inliers))
}

/// Whether a lens is to be fitted (`Ok(false)`: not asked for), or why
/// these pairs cannot tell one.
fn lens_wanted(
    model: LensModel,
    pixels: &[[f64; 2]],
    inliers: &[bool],
    axis: &RadialLens,
) -> Result<bool, String> {
    if model == LensModel::None {
        return Ok(false);
    }
    axis.check()
        .map_err(|why| format!("no frame size to centre a lens on ({why})"))?;
    let kept: Vec<&[f64; 2]> = pixels
        .iter()
        .zip(inliers)
        .filter(|p| *p.1)
        .map(|p| p.0)
        .collect();
    if kept.len() < LENS_MIN_PAIRS {
        return Err(format!(
            "a lens needs at least {LENS_MIN_PAIRS} tip positions that fit, got {}",
            kept.len()
        ));
    }
    let reach = kept
        .iter()
        .map(|p| (p[0] - axis.centre_px[0]).hypot(p[1] - axis.centre_px[1]))
        .fold(0.0, f64::max)
        / axis.radius_px;
    if reach < LENS_MIN_SPREAD {
        return Err(format!(
            "a lens needs tip positions out to {:.0} % of the way from the frame's centre to its corner; the farthest is at {:.0} %",
            100.0 * LENS_MIN_SPREAD,
            100.0 * reach
        ));
    }
    Ok(true)
}

/// A lens fitted with its affine map, on its inliers.
struct LensFit {
    map: StageToPixel,
    lens: RadialLens,
    inliers: Vec<bool>,
    /// How much the lens lowers the residual against an affine map alone
    /// on the same inliers, in units of the residual variance left.
    f_statistic: f64,
}

/// The lens's `k1` and the affine map after it, with the inliers taken
/// again through each new map (clipped at a few robust standard
/// deviations, at most `threshold_px`).
fn fit_with_lens(
    pixels: &[[f64; 2]],
    stage_um: &[[f64; 2]],
    mut inliers: Vec<bool>,
    axis: RadialLens,
    threshold_px: f64,
) -> Result<LensFit, CalibError> {
    let kept = |inliers: &[bool]| -> Vec<Pair> {
        (0..pixels.len())
            .filter(|&i| inliers[i])
            .map(|i| (pixels[i], stage_um[i]))
            .collect()
    };
    let mut fitted = None;
    for _ in 0..LENS_ROUNDS {
        let (k1, map, rss) = best_k1(&kept(&inliers), axis)?;
        let lens = RadialLens { k1, ..axis };
        let lengths: Vec<f64> = residuals(&map, Some(lens), pixels, stage_um)
            .iter()
            .map(|d| d[0].hypot(d[1]))
            .collect();
        let clip = clip_radius(&lengths, &inliers).min(threshold_px);
        let again: Vec<bool> = lengths.iter().map(|&r| r <= clip).collect();
        let settled = again == inliers;
        fitted = Some((map, lens, rss));
        if settled || again.iter().filter(|&&k| k).count() < LENS_MIN_PAIRS {
            break;
        }
        inliers = again;
    }
    let (map, lens, rss) = fitted.ok_or_else(|| CalibError::Fit("no lens round ran".into()))?;
    if lens.k1.abs() > 0.999 * K1_LIMIT {
        return Err(CalibError::Fit(format!(
            "the lens fit ran to its limit (k1 {:.4}): the tip positions do not follow a lens; fit with --lens none and look at the residuals",
            lens.k1
        )));
    }
    let pairs = kept(&inliers);
    let affine_rss = least_squares_affine(&pairs).map_or(f64::INFINITY, |f| f.1);
    let dof = (2 * pairs.len()).saturating_sub(7).max(1) as f64;
    let f_statistic = (affine_rss - rss) / (rss / dof).max(1e-300);
    Ok(LensFit {
        map,
        lens,
        inliers,
        f_statistic,
    })
}

/// The residual length beyond which a pair is an outlier:
/// `LENS_CLIP_SIGMAS` robust standard deviations of the inliers' residuals
/// (from their median length, a 2-d Gaussian's being 1.1774 sigma), at
/// least `LENS_CLIP_FLOOR_PX`.
fn clip_radius(lengths: &[f64], inliers: &[bool]) -> f64 {
    let mut kept: Vec<f64> = lengths
        .iter()
        .zip(inliers)
        .filter(|r| *r.1)
        .map(|r| *r.0)
        .collect();
    kept.sort_by(f64::total_cmp);
    let median = kept.get(kept.len() / 2).copied().unwrap_or(0.0);
    (LENS_CLIP_SIGMAS * median / 1.1774).max(LENS_CLIP_FLOOR_PX)
}

/// The `k1` whose undistorted pixels an affine map fits best (golden
/// section over +/- K1_LIMIT: the residual is smooth and has one minimum
/// there for any lens an objective has), that map and its sum of squared
/// residuals.
fn best_k1(pairs: &[Pair], axis: RadialLens) -> Result<(f64, StageToPixel, f64), CalibError> {
    let fit = |k1: f64| {
        let lens = RadialLens { k1, ..axis };
        let undistorted: Vec<Pair> = pairs
            .iter()
            .map(|(p, s)| (lens.undistort(*p), *s))
            .collect();
        least_squares_affine(&undistorted)
    };
    let cost = |k1: f64| fit(k1).map_or(f64::INFINITY, |f| f.1);
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (-K1_LIMIT, K1_LIMIT);
    let (mut x1, mut x2) = (hi - ratio * (hi - lo), lo + ratio * (hi - lo));
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    for _ in 0..80 {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - ratio * (hi - lo);
            f1 = cost(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + ratio * (hi - lo);
            f2 = cost(x2);
        }
    }
    let k1 = 0.5 * (lo + hi);
    let (map, rss) = fit(k1).ok_or_else(|| {
        CalibError::Fit("the tip positions lie on a line: no map fits them".into())
    })?;
    Ok((k1, map, rss))
}

/// Least-squares stage (um) -> pixel affine map of `pairs` (pixel, stage)
/// and its sum of squared pixel residuals; `None` when the stage positions
/// lie on a line. Centred on the means, for a well-conditioned solve.
fn least_squares_affine(pairs: &[Pair]) -> Option<(StageToPixel, f64)> {
    let n = pairs.len() as f64;
    let mean = |f: &dyn Fn(&Pair) -> f64| pairs.iter().map(f).sum::<f64>() / n;
    let (px, py) = (mean(&|q| q.0[0]), mean(&|q| q.0[1]));
    let (sx, sy) = (mean(&|q| q.1[0]), mean(&|q| q.1[1]));
    let mut normal = Matrix3::zeros();
    let (mut rhs_x, mut rhs_y) = (Vector3::zeros(), Vector3::zeros());
    for (p, s) in pairs {
        let row = Vector3::new(s[0] - sx, s[1] - sy, 1.0);
        normal += row * row.transpose();
        rhs_x += row * (p[0] - px);
        rhs_y += row * (p[1] - py);
    }
    let lu = normal.lu();
    let (cx, cy) = (lu.solve(&rhs_x)?, lu.solve(&rhs_y)?);
    if !(cx.iter().chain(cy.iter()).all(|v| v.is_finite()))
        || (cx[0] * cy[1] - cx[1] * cy[0]).abs() < 1e-12
    {
        return None;
    }
    let a = Matrix2::new(cx[0], cx[1], cy[0], cy[1]);
    let t = Vector2::new(px + cx[2], py + cy[2]) - a * Vector2::new(sx, sy);
    let map = StageToPixel { a, t };
    let rss = pairs
        .iter()
        .map(|(p, s)| {
            let q = map.predict(*s);
            (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
        })
        .sum();
    Some((map, rss))
}

/// Observed minus predicted pixel of every pair, through `lens` if any.
fn residuals(
    map: &StageToPixel,
    lens: Option<RadialLens>,
    pixels: &[[f64; 2]],
    stage_um: &[[f64; 2]],
) -> Vec<[f64; 2]> {
    pixels
        .iter()
        .zip(stage_um)
        .map(|(p, s)| {
            let u = map.predict(*s);
            let q = lens.map_or(u, |l| l.distort(u));
            [p[0] - q[0], p[1] - q[1]]
        })
        .collect()
}

/// RMS length of the residuals kept.
fn rms(residuals: &[[f64; 2]], kept: &[bool]) -> f64 {
    let (ss, n) = residuals
        .iter()
        .zip(kept)
        .filter(|r| *r.1)
        .fold((0.0, 0usize), |(ss, n), (d, _)| {
            (ss + d[0] * d[0] + d[1] * d[1], n + 1)
        });
    (ss / n.max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5 x 5 grid of tip positions over a 640 x 480 frame, mapped to the
    /// stage through `truth`.
    fn grid(truth: &CameraCalibration) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let mut px = Vec::new();
        let mut st = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                let p = [20.0 + 150.0 * i as f64, 15.0 + 112.0 * j as f64];
                px.push(p);
                st.push(truth.pixel_to_stage_m(p[0], p[1]));
            }
        }
        (px, st)
    }

    /// Too few pairs are counted in words that fit one of each ("got 1
    /// pixels and 1 stage positions" had been said).
    #[test]
    fn one_pair_is_said_in_the_singular() {
        let refusal = |pixels: usize| {
            fit_camera_map(
                &vec![[1.0, 2.0]; pixels],
                &[[0.0, 0.0]],
                1.0,
                LensModel::None,
                (640, 480),
            )
            .unwrap_err()
            .to_string()
        };
        let err = refusal(1);
        assert!(err.contains("got 1 pixel and 1 stage position"), "{err}");
        let err = refusal(2);
        assert!(err.contains("got 2 pixels and 1 stage position"), "{err}");
    }

    #[test]
    fn ransac_recovers_map_despite_an_outlier() {
        let truth = CameraCalibration::from_scale_rotation(0.2e-6, -0.05, [10e-6, 20e-6]);
        let (mut px, st) = grid(&truth);
        px[7][0] += 30.0;
        let fit = fit_camera_map(&px, &st, 1.0, LensModel::None, (640, 480)).unwrap();
        assert_eq!(fit.inliers, 24);
        assert!(!fit.residuals_px[7].2);
        assert!(fit.rms_px < 1e-3, "{}", fit.rms_px);
        assert!((fit.calibration.linear - truth.linear).norm() < 1e-6 * truth.m_per_px());
        assert_eq!(fit.calibration.lens, None);
    }

    #[test]
    fn the_lens_is_found_and_the_map_holds_to_the_corners() {
        // Barrel distortion moving the corners 0.8 % inward (about 3 px):
        // an affine map alone is off by most of a pixel at the corners.
        let lens = RadialLens::centred_on(640, 480, -0.008);
        let truth = CameraCalibration::from_scale_rotation(0.3e-6, 0.2, [5e-6, -8e-6])
            .with_lens(Some(lens));
        let (mut px, st) = grid(&truth);
        // One tip lost (25 px off) and one mislocated by a pixel: within
        // RANSAC's 2 px, but far outside the others' spread.
        px[3][1] += 25.0;
        px[17][0] += 1.0;
        let fit = fit_camera_map(&px, &st, 2.0, LensModel::Auto, (640, 480)).unwrap();
        let found = fit.calibration.lens.expect("a lens");
        assert!((found.k1 - lens.k1).abs() < 1e-6, "{}", found.k1);
        assert_eq!(fit.inliers, 23);
        assert!(!fit.residuals_px[3].2 && !fit.residuals_px[17].2);
        assert!(fit.rms_px < 1e-4, "{}", fit.rms_px);
        assert!(fit.affine_rms_px > 0.3, "{}", fit.affine_rms_px);
        let off = fit.calibration.largest_difference_m(&truth, 640, 480);
        assert!(off < 1e-10, "{off}");
        let affine = fit_camera_map(&px, &st, 2.0, LensModel::None, (640, 480)).unwrap();
        let affine_off = affine.calibration.largest_difference_m(&truth, 640, 480);
        println!("affine alone: {:.3} um off at worst", affine_off * 1e6);
        assert!(affine_off > 0.2e-6, "{affine_off}");
    }

    #[test]
    fn without_a_lens_auto_keeps_the_affine_map_and_says_why() {
        let truth = CameraCalibration::from_scale_rotation(0.3e-6, 0.2, [5e-6, -8e-6]);
        let (mut px, st) = grid(&truth);
        // Detection noise of up to 0.05 px.
        for (k, p) in px.iter_mut().enumerate() {
            p[0] += 0.05 * ((k * 7 % 11) as f64 / 5.0 - 1.0);
            p[1] += 0.05 * ((k * 5 % 13) as f64 / 6.0 - 1.0);
        }
        let fit = fit_camera_map(&px, &st, 2.0, LensModel::Auto, (640, 480)).unwrap();
        assert_eq!(fit.calibration.lens, None);
        let why = fit.lens_skipped.expect("a reason");
        assert!(why.contains("hardly better"), "{why}");
        assert_eq!(fit.rms_px, fit.affine_rms_px);
        // Asked for, the lens is fitted anyway, and is near nothing.
        let radial = fit_camera_map(&px, &st, 2.0, LensModel::Radial, (640, 480)).unwrap();
        let k1 = radial.calibration.lens.expect("fitted").k1;
        assert!(k1.abs() < 1e-3, "{k1}");
        let off = radial.calibration.largest_difference_m(&truth, 640, 480);
        assert!(off < 0.1 * 0.3e-6, "{off}");
    }

    /// The affine map's RMS is told on the lens fit's own inliers: a tip
    /// mislocated by a pixel (inside RANSAC's 2 px) that the lens fit drops
    /// made "an affine map alone left 0.2 px" of a map as good as the lens's.
    #[test]
    fn the_affine_rms_beside_a_lens_is_over_the_same_inliers() {
        let truth = CameraCalibration::from_scale_rotation(0.3e-6, 0.2, [5e-6, -8e-6]);
        let (mut px, st) = grid(&truth);
        px[17][0] += 1.0;
        let fit = fit_camera_map(&px, &st, 2.0, LensModel::Radial, (640, 480)).unwrap();
        assert!(
            !fit.residuals_px[17].2,
            "the lens fit keeps the mislocated tip"
        );
        assert!(fit.rms_px < 1e-3, "{}", fit.rms_px);
        // No lens in the truth: on the same inliers the affine map is as good.
        assert!(fit.affine_rms_px < 0.05, "{}", fit.affine_rms_px);
    }

    #[test]
    fn pairs_that_cannot_tell_a_lens_fit_none_or_are_refused() {
        let truth = CameraCalibration::from_scale_rotation(0.3e-6, 0.0, [0.0, 0.0]);
        // Five pairs (not on one line): too few for a lens.
        let (px, st) = grid(&truth);
        let five = [0, 1, 5, 6, 12];
        let (px, st): (Vec<_>, Vec<_>) = five.iter().map(|&k| (px[k], st[k])).unzip();
        let auto = fit_camera_map(&px, &st, 2.0, LensModel::Auto, (640, 480)).unwrap();
        assert_eq!(auto.calibration.lens, None);
        assert!(auto.lens_skipped.unwrap().contains("at least 8"));
        assert!(auto.rms_px < 1e-3, "{}", auto.rms_px);
        let err = fit_camera_map(&px, &st, 2.0, LensModel::Radial, (640, 480))
            .unwrap_err()
            .to_string();
        assert!(err.contains("at least 8"), "{err}");
        // Nine pairs all near the centre: the lens cannot show.
        let (near_px, near_st): (Vec<_>, Vec<_>) = (0..9)
            .map(|k| {
                let p = [300.0 + 10.0 * (k % 3) as f64, 230.0 + 10.0 * (k / 3) as f64];
                (p, truth.pixel_to_stage_m(p[0], p[1]))
            })
            .unzip();
        let err = fit_camera_map(&near_px, &near_st, 2.0, LensModel::Radial, (640, 480))
            .unwrap_err()
            .to_string();
        assert!(err.contains("of the way from the frame's centre"), "{err}");
        // No frame size: no lens, and no NaN.
        let (px, st) = grid(&truth);
        let err = fit_camera_map(&px, &st, 2.0, LensModel::Radial, (0, 0))
            .unwrap_err()
            .to_string();
        assert!(err.contains("no frame size"), "{err}");
        let auto = fit_camera_map(&px, &st, 2.0, LensModel::Auto, (0, 0)).unwrap();
        assert!(auto.calibration.lens.is_none() && auto.rms_px.is_finite());
    }
}
