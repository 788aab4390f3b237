//! Least-squares fit of a particle's intensity profile around a start centre:
//! the locator that reaches the Cramer-Rao bound. Two models:
//! - ring: background + Gaussian core - Gaussian ring at radius R (bright-field
//!   spheres of either contrast, in or out of focus; the renderer's model);
//! - spot: background + Gaussian (dark spots, fluorescent spots).
//!
//! Saturated pixels are censored samples: their true value is unknown but
//! at least the full count, so they pull only a model that falls short of
//! it there ([`super::pixel_window::PixelWindow`]); a clipped core starts
//! the fit at least as bright as the ring is dark.

use nalgebra::SVector;
use thiserror::Error;

use super::frame::Frame;
use super::least_squares::{FitError, levenberg_marquardt_with, never_give_up};
use super::pixel_window::{PixelWindow, WindowModel};
use crate::median::upper_median;

/// Core and ring must each exceed the residual noise by this factor.
const RING_MIN_CONTRAST_SNR: f64 = 2.0;

/// Iteration cap of the ring fit. From the radial-symmetry start a ring fit
/// converges in 4-9 iterations (bench frame, 100 spheres); the fits that ran
/// to the old cap of 30 were crawling along a flat valley (a core as wide as
/// the window trading off against the background) with the centre fixed, or
/// were not particles at all.
const RING_MAX_ITERATIONS: usize = 12;

/// Iterations after which a ring fit whose current point would be rejected
/// is given up. On the 1024 x 1024 bench frame (100 spheres and the probe),
/// fitted on the square window of before, the fits kept converged in 3-5
/// iterations but two (7 and 12); 15 of the 16 rejected ones ran 6-12
/// iterations to be rejected, about 30 % of the ring fits' iterations. On
/// the disc every fit there ends within 5.
const RING_PATIENCE: usize = 5;

/// Which intensity model a particle is fitted with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProfileModel {
    /// Core + ring (bright-field sphere).
    Ring,
    /// Single Gaussian spot.
    Spot,
}

/// A fitted particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleFit {
    /// Centre x in pixels.
    pub x_px: f64,
    /// Centre y in pixels.
    pub y_px: f64,
    /// Ring radius (ring model) or 1/e^2 radius 2 sigma (spot model), pixels.
    pub r_px: f64,
    /// 1-sigma centre uncertainty per axis, pixels (from the fit covariance).
    pub sigma_px: f64,
    /// Fitted contrast over the residual noise (a detection SNR).
    pub snr: f64,
    /// Model used.
    pub model: ProfileModel,
    /// Fitted centre intensity minus background, counts (sign = polarity).
    pub centre_contrast: f64,
}

/// Why a particle could not be fitted.
#[derive(Debug, Error, PartialEq)]
pub enum ProfileFitError {
    /// The least-squares solver failed.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The fit converged to something that is not a particle near the start.
    #[error("fit is implausible: {0}")]
    Implausible(&'static str),
}

/// Ring model f = b + A exp(-r^2 / 2 s^2) - B exp(-(r - R)^2 / 2 w^2) with
/// parameters (x, y, b, A, s, B, R, w); writes the gradient into `g`.
#[inline]
pub fn ring_model(px: f64, py: f64, p: &SVector<f64, 8>, g: &mut SVector<f64, 8>) -> f64 {
    let (x, y, b, a, s, bb, rr, w) = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
    let dx = px - x;
    let dy = py - y;
    let r2 = dx * dx + dy * dy;
    let r = r2.sqrt().max(1e-9);
    let is2 = 1.0 / (s * s);
    let iw2 = 1.0 / (w * w);
    let e1 = (-0.5 * r2 * is2).exp();
    let dr = r - rr;
    let e2 = (-0.5 * dr * dr * iw2).exp();
    let core_rad = a * e1 * is2; // d/d(r^2) factor
    let ring_rad = bb * e2 * dr * iw2 / r;
    g[0] = core_rad * dx - ring_rad * dx;
    g[1] = core_rad * dy - ring_rad * dy;
    g[2] = 1.0;
    g[3] = e1;
    g[4] = a * e1 * r2 * is2 / s;
    g[5] = -e2;
    g[6] = -bb * e2 * dr * iw2;
    g[7] = -bb * e2 * dr * dr * iw2 / w;
    b + a * e1 - bb * e2
}

/// Spot model f = b + A exp(-r^2 / 2 s^2), parameters (x, y, b, A, s).
#[inline]
pub fn spot_model(px: f64, py: f64, p: &SVector<f64, 5>, g: &mut SVector<f64, 5>) -> f64 {
    let dx = px - p[0];
    let dy = py - p[1];
    let r2 = dx * dx + dy * dy;
    let is2 = 1.0 / (p[4] * p[4]);
    let e = (-0.5 * r2 * is2).exp();
    g[0] = p[3] * e * is2 * dx;
    g[1] = p[3] * e * is2 * dy;
    g[2] = 1.0;
    g[3] = e;
    g[4] = p[3] * e * r2 * is2 / p[4];
    p[2] + p[3] * e
}

/// Fits `model` to the particle near (cx, cy) whose radius is about `radius_px`.
pub fn fit_particle(
    frame: &Frame,
    cx: f64,
    cy: f64,
    radius_px: f64,
    model: ProfileModel,
) -> Result<ParticleFit, ProfileFitError> {
    fit_particle_among(frame, cx, cy, radius_px, model, &[])
}

/// As [`fit_particle`], for a particle with neighbours centred at `neighbours`:
/// pixels nearer a neighbour than (cx, cy) are left out of a ring fit, because
/// a one-sphere model cannot explain a touching sphere's core and ring (touching
/// particles are what an assembled pattern is made of).
pub fn fit_particle_among(
    frame: &Frame,
    cx: f64,
    cy: f64,
    radius_px: f64,
    model: ProfileModel,
    neighbours: &[(f64, f64)],
) -> Result<ParticleFit, ProfileFitError> {
    match model {
        ProfileModel::Ring => fit_ring(frame, cx, cy, radius_px, neighbours),
        ProfileModel::Spot => fit_spot(frame, cx, cy, radius_px),
    }
}

fn fit_ring(
    frame: &Frame,
    cx: f64,
    cy: f64,
    r0: f64,
    neighbours: &[(f64, f64)],
) -> Result<ParticleFit, ProfileFitError> {
    let half = r0 + 5.0;
    // The disc of radius `half`, not the square around it: the corners see
    // only background, which the band from r0 + 3 to `half` already gives
    // (27 % fewer pixels; SNR 8 centre RMS 0.0312 -> 0.0314 px, CRB 0.0322),
    // or worse, the probe's edge, which the fit took for a core (0.57 px off
    // on the bench frame; docs/vision-history.md, twelfth pass).
    let mut win = PixelWindow::square(frame, cx, cy, half);
    win.retain(|x, y| (x - cx).powi(2) + (y - cy).powi(2) <= half * half);
    if !neighbours.is_empty() {
        let d2 = |x: f64, y: f64, p: (f64, f64)| (x - p.0).powi(2) + (y - p.1).powi(2);
        win.retain(|x, y| {
            neighbours
                .iter()
                .all(|&n| d2(x, y, (cx, cy)) <= d2(x, y, n))
        });
    }
    // Each pixel's value, squared distance and distance from the start,
    // computed once for the three uses below.
    let polar: Vec<(f64, f64, f64)> = win
        .pixels()
        .map(|s| {
            let d2 = (s.0 - cx).powi(2) + (s.1 - cy).powi(2);
            (s.2, d2, d2.sqrt())
        })
        .collect();
    // Background from the window's outer band, core from the centre.
    let mut outer: Vec<f64> = polar
        .iter()
        .filter(|s| s.2 > r0 + 3.0)
        .map(|s| s.0)
        .collect();
    let b = upper_median(&mut outer).unwrap_or(0.0);
    let mut inner: Vec<f64> = polar
        .iter()
        .filter(|s| s.1 < (0.25 * r0).max(1.0).powi(2))
        .map(|s| s.0)
        .collect();
    let core = upper_median(&mut inner).unwrap_or(frame.max_count() as f64);
    let a = core - b;
    // Ring: the annulus (0.5 px bins) whose mean departs most from b against the core.
    let nb = (2.0 * r0) as usize + 1;
    let mut sum = vec![0.0; 4 * nb + 4];
    let mut cnt = vec![0usize; 4 * nb + 4];
    for &(v, _, r) in &polar {
        let k = (r * 2.0) as usize;
        if k < sum.len() {
            sum[k] += v - b;
            cnt[k] += 1;
        }
    }
    let sign = if a >= 0.0 { 1.0 } else { -1.0 };
    let (mut best_k, mut best_v) = (0usize, f64::NEG_INFINITY);
    for k in (r0 as usize).max(1)..sum.len() {
        if cnt[k] > 0 && (k as f64 * 0.5) < 1.6 * r0 {
            let v = -sign * sum[k] / cnt[k] as f64;
            if v > best_v {
                best_v = v;
                best_k = k;
            }
        }
    }
    let rr = if best_v.is_finite() {
        (best_k as f64 + 0.5) * 0.5
    } else {
        r0
    };
    let bb = if best_v.is_finite() {
        sign * best_v
    } else {
        0.5 * a
    };
    // A core clipped at the full count is brighter than read, by an unknown
    // amount: on a clipped background too, core - b reads 0 and the fit
    // would start without a core. Start it at least as bright as the ring
    // is dark.
    let clipped_core = core >= frame.max_count() as f64;
    let a = if clipped_core { a.max(bb.abs()) } else { a };
    let init =
        SVector::<f64, 8>::from_column_slice(&[cx, cy, b, a, (0.45 * rr).max(1.0), bb, rr, 1.5]);
    let implausible = |p: &SVector<f64, 8>, noise: f64| ring_implausible(p, (cx, cy), r0, noise);
    let give_up = |iterations: usize, p: &SVector<f64, 8>, variance: f64| {
        (iterations >= RING_PATIENCE)
            .then(|| implausible(p, variance.sqrt().max(1e-12)))
            .flatten()
    };
    let fit = levenberg_marquardt_with(
        win.len(),
        init,
        RING_MAX_ITERATIONS,
        &[0, 1, 6],
        &give_up,
        &mut WindowModel::ring(&win),
    )
    .map_err(|e| match e {
        FitError::GivenUp(reason) => ProfileFitError::Implausible(reason),
        e => e.into(),
    })?;
    let p = fit.params;
    let noise = fit.residual_variance.sqrt().max(1e-12);
    if let Some(reason) = implausible(&p, noise) {
        return Err(ProfileFitError::Implausible(reason));
    }
    Ok(ParticleFit {
        x_px: p[0],
        y_px: p[1],
        r_px: p[6],
        sigma_px: (0.5 * (fit.covariance[(0, 0)] + fit.covariance[(1, 1)])).sqrt(),
        snr: p[3].abs().max(p[5].abs()) / noise,
        model: ProfileModel::Ring,
        centre_contrast: p[3] - p[5] * (-0.5 * (p[6] / p[7]).powi(2)).exp(),
    })
}

/// Why ring parameters `p` fitted from `start` with the size hint `r0` are
/// not a particle, if they are not.
fn ring_implausible(
    p: &SVector<f64, 8>,
    start: (f64, f64),
    r0: f64,
    noise: f64,
) -> Option<&'static str> {
    if ((p[0] - start.0).powi(2) + (p[1] - start.1).powi(2)).sqrt() > (0.75 * r0).max(2.0) {
        return Some("centre moved beyond the particle");
    }
    // Sizes from 0.5x to 1.6x the hint are accepted: several sizes in one frame,
    // but not a "ring" drawn by background texture at twice the hint.
    if !(p[6] > 0.5 * r0
        && p[6] < 1.6 * r0
        && p[7].abs() > 0.2
        && p[7].abs() < 0.4 * p[6]
        && p[4].abs() > 0.2)
    {
        return Some("ring radius or widths out of range");
    }
    // A sphere's signature: core and ring of opposite contrast, both above the noise.
    if p[3] * p[5] <= 0.0 || p[3].abs().min(p[5].abs()) < RING_MIN_CONTRAST_SNR * noise {
        return Some("no core and ring of opposite contrast");
    }
    None
}

fn fit_spot(frame: &Frame, cx: f64, cy: f64, r0: f64) -> Result<ParticleFit, ProfileFitError> {
    let half = (1.5 * r0).max(3.0);
    let win = PixelWindow::square(frame, cx, cy, half);
    let mut border: Vec<f64> = win
        .pixels()
        .filter(|s| (s.0 - cx).abs().max((s.1 - cy).abs()) > half - 1.5)
        .map(|s| s.2)
        .collect();
    let b = upper_median(&mut border).unwrap_or(0.0);
    let core = win
        .pixels()
        .min_by(|p, q| {
            let dp = (p.0 - cx).powi(2) + (p.1 - cy).powi(2);
            let dq = (q.0 - cx).powi(2) + (q.1 - cy).powi(2);
            dp.total_cmp(&dq)
        })
        .map_or(b, |s| s.2);
    let init = SVector::<f64, 5>::from_column_slice(&[cx, cy, b, core - b, (0.5 * r0).max(0.8)]);
    let fit = levenberg_marquardt_with(
        win.len(),
        init,
        30,
        &[0, 1, 4],
        &never_give_up,
        &mut WindowModel::spot(&win),
    )?;
    let p = fit.params;
    let noise = fit.residual_variance.sqrt().max(1e-12);
    if ((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt() > r0.max(2.0) {
        return Err(ProfileFitError::Implausible(
            "centre moved beyond the particle",
        ));
    }
    let s = p[4].abs();
    if !(s > 0.3 && s < 0.8 * r0.max(1.0)) {
        return Err(ProfileFitError::Implausible("spot width out of range"));
    }
    Ok(ParticleFit {
        x_px: p[0],
        y_px: p[1],
        r_px: 2.0 * s,
        sigma_px: (0.5 * (fit.covariance[(0, 0)] + fit.covariance[(1, 1)])).sqrt(),
        snr: p[3].abs() / noise,
        model: ProfileModel::Spot,
        centre_contrast: p[3],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_model_gradient_matches_finite_differences() {
        let p =
            SVector::<f64, 8>::from_column_slice(&[10.2, 9.7, 100.0, 40.0, 3.5, 50.0, 8.0, 1.6]);
        let mut g = SVector::<f64, 8>::zeros();
        let mut g2 = SVector::<f64, 8>::zeros();
        for &(x, y) in &[(12.0, 8.0), (17.0, 14.0), (10.0, 10.0)] {
            ring_model(x, y, &p, &mut g);
            for i in 0..8 {
                let mut q = p;
                q[i] += 1e-6;
                let fd = (ring_model(x, y, &q, &mut g2) - ring_model(x, y, &p, &mut g2)) / 1e-6;
                assert!(
                    (fd - g[i]).abs() < 1e-3 * (1.0 + fd.abs()),
                    "param {i}: {fd} vs {}",
                    g[i]
                );
            }
        }
    }
}
