//! Ring-edge centre of a bright-field particle: the centre of its outline
//! (the dark ring), from the ring's extremum along rays cast from a start
//! centre (a polar resampling, sub-pixel) and a robust circle fit to those
//! edge points.
//!
//! Why it can differ from the profile centre: a sphere in bright field is a
//! ball lens. Its dark ring is where light is refracted past the objective's
//! aperture, so it is drawn by the sphere's outline; its bright core is the
//! light the sphere focuses, and under oblique illumination that focus moves
//! sideways while the outline stays put. The profile fit
//! ([`super::profile_fit`]) models core and ring as concentric, so on such a
//! particle it settles between the two, pulled by the core's many bright
//! pixels: on the real brightfield fixtures (core about 1 px left of the ring)
//! it sits 0.3-0.6 px left of the circle through the ring's minima. The ring's
//! extremum along a ray depends on the outline alone, up to the slope a
//! displaced core's tail adds under the ring (it moves a minimum by about
//! slope x width^2 / depth).
//!
//! On a symmetric particle both estimate the same point and the profile fit
//! is the more precise one (it uses every pixel and reaches the Cramer-Rao
//! bound), so [`recentre_on_ring_edges`] moves a detection only where the two
//! differ significantly (a Hausman-style test of the profile fit's symmetry
//! assumption) and keeps the profile centre otherwise.
//!
//! Written by hand: sampling rays, a three-parameter linear fit and outlier
//! rejection are a few dozen lines over nalgebra; no crate locates ring edges.

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::detect::Detection;
use super::frame::Frame;
use super::noise::MIN_NOISE_COUNTS;
use crate::median::upper_median;

/// Which point of a ring-model particle is reported as its centre.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CentreEstimate {
    /// The profile fit's centre (core and ring concentric): the most precise
    /// centre of a symmetric particle.
    #[default]
    Profile,
    /// The centre of the particle's outline (the ring edge) where it differs
    /// significantly from the profile centre (asymmetric particles under
    /// oblique light), else the profile centre.
    RingEdge,
}

/// Radial sampling step along a ray, pixels (bilinear samples): half a
/// pixel, 5 samples under the vertex parabola (0.25 px measured no better:
/// SNR 8 raw RMS 0.048 vs 0.045 px, at twice the cost).
const RADIAL_STEP_PX: f64 = 0.5;
/// The ring is searched between these fractions of the radius estimate: wide
/// enough for a centre a third of a radius off, narrow enough to stay out of
/// the core and of a touching neighbour's ring.
const SEARCH_INNER_FRACTION: f64 = 0.6;
const SEARCH_OUTER_FRACTION: f64 = 1.4;
/// Half-width of the parabola fitted around a ray's extremum, pixels: a
/// Gaussian dip is parabolic within one width of its extremum, and rings are
/// at least about 1 px wide once sampled by pixels.
const VERTEX_HALF_WIDTH_PX: f64 = 1.0;
/// A ray's extremum must stand out from both sides by this many noise sigmas.
const MIN_PROMINENCE_SIGMA: f64 = 3.0;
/// Edge points farther from the fitted circle than this many robust sigmas
/// (1.4826 MAD) are rejected (a neighbour, the tip, a dust speck).
const OUTLIER_SIGMAS: f64 = 3.5;
/// Floor of the robust residual scale, pixels (a noise-free frame has MAD 0).
const MIN_RESIDUAL_SCALE_PX: f64 = 0.02;
/// Smallest eigenvalue of the per-ray normal matrix of (R, dx, dy): a full
/// circle of rays gives 0.5, a half circle 0.066. Below this the kept rays
/// do not surround the centre.
const MIN_COVERAGE: f64 = 0.1;
/// Fewest edge points a circle is fitted to.
const MIN_RAYS: usize = 8;
/// Rays are recast from the new centre until it moves less than this many
/// of its own sigmas, or less than `CONVERGED_PX`. Each cast removes the
/// offset terms' second-order error (offset^2 / 2R: 0.06 px after a first
/// cast 1 px off, 2e-4 px after the second), but resamples the noise, so
/// the centre wanders at its noise level and a fixed tolerance would only
/// run into `MAX_CASTS`.
const CONVERGED_SIGMAS: f64 = 0.25;
const CONVERGED_PX: f64 = 1e-3;
/// At most this many casts.
const MAX_CASTS: usize = 6;
/// The centre may move at most this fraction of the radius from its start.
const MAX_MOVE_FRACTION: f64 = 0.35;
/// Significance level of the asymmetry test: the profile centre is replaced
/// only when a symmetric particle would show so large a difference with
/// this probability or less.
const ASYMMETRY_P_VALUE: f64 = 1e-3;

/// A ring-edge circle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingEdgeFit {
    /// Centre x of the outline, pixels.
    pub x_px: f64,
    /// Centre y of the outline, pixels.
    pub y_px: f64,
    /// Radius of the ring's extremum, pixels.
    pub r_px: f64,
    /// 1-sigma centre uncertainty per axis, pixels (residual scatter of the
    /// edge points, inflated for their correlation along the ring).
    pub sigma_px: f64,
    /// Edge points the circle was fitted to.
    pub rays_used: usize,
    /// Rays cast.
    pub rays_cast: usize,
}

/// Why no ring-edge centre was found.
#[derive(Debug, Clone, Copy, Error, PartialEq)]
pub enum RingEdgeError {
    /// The start centre or radius cannot seed a search.
    #[error("ring-edge search cannot start: {0}")]
    BadStart(&'static str),
    /// Too few rays show a significant ring extremum inside the search band.
    #[error("ring not found: {found} of {cast} rays show a ring edge (need {needed})")]
    NoRing {
        found: usize,
        cast: usize,
        needed: usize,
    },
    /// The rays that show the ring lie on one side of the centre (frame
    /// edge, neighbours all round).
    #[error("ring-edge points cover too little of the circle (coverage {coverage:.3}, need 0.1)")]
    OneSided { coverage: f64 },
    /// The circle's centre ran away from the start.
    #[error("ring-edge centre moved {moved_px:.2} px from its start (limit {limit_px:.2} px)")]
    Moved { moved_px: f64, limit_px: f64 },
}

/// What [`recentre_on_ring_edges`] did with one detection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RingEdgeOutcome {
    /// Moved to the ring-edge centre: the difference was significant.
    Recentred {
        /// Distance moved, pixels.
        shift_px: f64,
        /// Squared difference over its variance (chi-square, 2 degrees of freedom).
        statistic: f64,
    },
    /// Kept: the ring-edge centre agrees with the profile centre within noise.
    Consistent { shift_px: f64, statistic: f64 },
    /// Kept: no ring-edge centre (the reason).
    Failed(RingEdgeError),
}

/// Dark ring (look for minima) or bright ring (maxima).
#[derive(Debug, Clone, Copy, PartialEq)]
enum RingSign {
    Dark,
    Bright,
}

impl RingSign {
    /// Factor that turns the ring's extremum into a minimum.
    fn factor(self) -> f64 {
        match self {
            RingSign::Dark => 1.0,
            RingSign::Bright => -1.0,
        }
    }
}

/// The search around one start: frame, neighbours, noise and ray directions.
struct RaySearch<'a> {
    frame: &'a Frame,
    radius_px: f64,
    neighbours: &'a [(f64, f64)],
    noise_sigma: f64,
    /// (cos, sin) of every ray.
    directions: Vec<(f64, f64)>,
}

/// Finds the centre of the ring around (x_px, y_px) whose radius is about
/// `radius_px`. Rays are cut where they come nearer a neighbour centre than
/// the start (so a touching sphere's ring is not taken for this one's), and
/// at the frame edge. `noise_sigma` is the frame's per-pixel noise in counts
/// ([`super::noise::estimate_noise_sigma`]).
pub fn ring_edge_centre(
    frame: &Frame,
    x_px: f64,
    y_px: f64,
    radius_px: f64,
    neighbours: &[(f64, f64)],
    noise_sigma: f64,
) -> Result<RingEdgeFit, RingEdgeError> {
    if !(x_px.is_finite() && y_px.is_finite()) {
        return Err(RingEdgeError::BadStart("centre is not finite"));
    }
    if !(radius_px.is_finite() && radius_px >= 2.0) {
        return Err(RingEdgeError::BadStart(
            "radius must be finite and at least 2 px",
        ));
    }
    let (w, h) = (frame.width() as f64, frame.height() as f64);
    if w < 2.0 || h < 2.0 || x_px < 0.0 || y_px < 0.0 || x_px > w - 1.0 || y_px > h - 1.0 {
        return Err(RingEdgeError::BadStart("centre is outside the frame"));
    }
    let n_rays = (std::f64::consts::TAU * radius_px)
        .ceil()
        .clamp(16.0, 720.0) as usize;
    let search = RaySearch {
        frame,
        radius_px,
        neighbours,
        noise_sigma: if noise_sigma.is_finite() && noise_sigma > 0.0 {
            noise_sigma
        } else {
            MIN_NOISE_COUNTS
        },
        // One ray per pixel of circumference: neighbouring rays share few pixels.
        directions: (0..n_rays)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / n_rays as f64;
                (t.cos(), t.sin())
            })
            .collect(),
    };
    let mut cast = search.cast(x_px, y_px);
    let sign = search.ring_sign(&cast);
    let limit_px = MAX_MOVE_FRACTION * radius_px;
    let (mut cx, mut cy) = (x_px, y_px);
    let mut last = None;
    for i in 0..MAX_CASTS {
        if i > 0 {
            cast = search.cast(cx, cy);
        }
        let edges: Vec<Option<f64>> = (0..search.directions.len())
            .map(|i| search.ray_edge(cast.ray(i), sign))
            .collect();
        let circle = robust_circle(&search.directions, &edges)?;
        cx += circle.dx;
        cy += circle.dy;
        let moved_px = (cx - x_px).hypot(cy - y_px);
        if moved_px > limit_px {
            return Err(RingEdgeError::Moved { moved_px, limit_px });
        }
        let step = circle.dx.hypot(circle.dy);
        let settled = step < CONVERGED_PX.max(CONVERGED_SIGMAS * circle.sigma_px);
        last = Some(circle);
        if settled {
            break;
        }
    }
    // MAX_CASTS >= 1, so a circle was fitted (or an error returned above).
    let circle = last.ok_or(RingEdgeError::BadStart("no rays cast"))?;
    Ok(RingEdgeFit {
        x_px: cx,
        y_px: cy,
        r_px: circle.radius_px,
        sigma_px: circle.sigma_px,
        rays_used: circle.used,
        rays_cast: n_rays,
    })
}

impl RaySearch<'_> {
    /// Inner and outer radius of the search band.
    fn band(&self) -> (f64, f64) {
        (
            SEARCH_INNER_FRACTION * self.radius_px,
            SEARCH_OUTER_FRACTION * self.radius_px,
        )
    }

    /// Samples of every ray from (cx, cy) across the search band, each until
    /// the frame edge or a neighbour's half-plane.
    fn cast(&self, cx: f64, cy: f64) -> Cast {
        let (r_lo, r_hi) = self.band();
        let stride = ((r_hi - r_lo) / RADIAL_STEP_PX).floor() as usize + 1;
        let mut cast = Cast {
            samples: vec![(0.0, false); stride * self.directions.len()],
            lengths: Vec::with_capacity(self.directions.len()),
            stride,
        };
        for (ray, d) in cast.samples.chunks_exact_mut(stride).zip(&self.directions) {
            let mut len = 0;
            for (k, slot) in ray.iter_mut().enumerate() {
                let r = r_lo + k as f64 * RADIAL_STEP_PX;
                let (x, y) = (cx + r * d.0, cy + r * d.1);
                if self
                    .neighbours
                    .iter()
                    .any(|&(nx, ny)| (x - nx).powi(2) + (y - ny).powi(2) < r * r)
                {
                    break;
                }
                match bilinear(self.frame, x, y) {
                    Some(v) => *slot = v,
                    None => break,
                }
                len += 1;
            }
            cast.lengths.push(len);
        }
        cast
    }

    /// Dark or bright ring: which extremum of the azimuthal mean profile over
    /// the outer part of the band departs more from its outer end (the inner
    /// part is left out: a bright core's tail would pass for a bright ring).
    fn ring_sign(&self, cast: &Cast) -> RingSign {
        let r_lo = self.band().0;
        let first = ((0.75 * self.radius_px - r_lo) / RADIAL_STEP_PX)
            .ceil()
            .max(0.0) as usize;
        let mut sum = vec![0.0; cast.stride];
        let mut count = vec![0usize; cast.stride];
        for i in 0..self.directions.len() {
            for (k, (v, _)) in cast.ray(i).iter().enumerate() {
                sum[k] += v;
                count[k] += 1;
            }
        }
        let mean: Vec<f64> = sum
            .iter()
            .zip(&count)
            .skip(first)
            .filter(|(_, c)| **c > 0)
            .map(|(s, c)| s / *c as f64)
            .collect();
        let Some(&outer) = mean.last() else {
            return RingSign::Dark;
        };
        let lo = mean.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = mean.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if outer - lo >= hi - outer {
            RingSign::Dark
        } else {
            RingSign::Bright
        }
    }

    /// Sub-pixel radius of the ring's extremum along one ray, or `None` when
    /// the ray shows no significant interior extremum (cut short, flat, at the
    /// band's end, or clipped at the camera's range).
    fn ray_edge(&self, samples: &[(f64, bool)], sign: RingSign) -> Option<f64> {
        let half = (VERTEX_HALF_WIDTH_PX / RADIAL_STEP_PX).round() as usize;
        if samples.len() < 2 * half + 1 {
            return None;
        }
        let v: Vec<f64> = samples.iter().map(|s| sign.factor() * s.0).collect();
        let (k, &v_min) = v.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
        if k < half || k + half >= v.len() {
            return None;
        }
        let left = v[..k].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let right = v[k + 1..].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if left.min(right) - v_min < MIN_PROMINENCE_SIGMA * self.noise_sigma {
            return None;
        }
        let window = k - half..=k + half;
        if samples[window.clone()].iter().any(|s| s.1) {
            return None;
        }
        // Least-squares parabola v = a + b t + c t^2 over t symmetric about 0
        // (so the odd moments vanish).
        let (mut n, mut s2, mut s4, mut sv, mut stv, mut st2v) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for j in window {
            let t = (j as f64 - k as f64) * RADIAL_STEP_PX;
            n += 1.0;
            s2 += t * t;
            s4 += t.powi(4);
            sv += v[j];
            stv += t * v[j];
            st2v += t * t * v[j];
        }
        let b = stv / s2;
        let c = (n * st2v - s2 * sv) / (n * s4 - s2 * s2);
        if c.is_nan() || c <= 0.0 {
            return None;
        }
        let vertex = -b / (2.0 * c);
        if vertex.is_nan() || vertex.abs() > VERTEX_HALF_WIDTH_PX {
            return None;
        }
        Some(self.band().0 + k as f64 * RADIAL_STEP_PX + vertex)
    }
}

/// The samples of one cast: `stride` slots per ray, the first `lengths[i]`
/// of ray i filled (a ray stops at the frame edge or a neighbour).
struct Cast {
    samples: Vec<(f64, bool)>,
    lengths: Vec<usize>,
    stride: usize,
}

impl Cast {
    /// (value, clipped) along ray `i`, inner end first.
    fn ray(&self, i: usize) -> &[(f64, bool)] {
        &self.samples[i * self.stride..i * self.stride + self.lengths[i]]
    }
}

/// Bilinear sample at (x, y): value, and whether any of its pixels is at
/// the camera's range (0 or saturated, value unknown). `None` off the frame.
fn bilinear(frame: &Frame, x: f64, y: f64) -> Option<(f64, bool)> {
    let (w, h) = (frame.width(), frame.height());
    if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64) {
        return None;
    }
    // x, y >= 0 here, so truncation is the floor (and needs no libm call).
    let x0 = (x as usize).min(w - 2);
    let y0 = (y as usize).min(h - 2);
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let p = [
        frame.at(x0, y0),
        frame.at(x0 + 1, y0),
        frame.at(x0, y0 + 1),
        frame.at(x0 + 1, y0 + 1),
    ];
    let sat = frame.max_count();
    let clipped = p.iter().any(|&v| v <= 0.0 || v >= sat);
    let [a, b, c, d] = p.map(f64::from);
    let top = a + fx * (b - a);
    let bottom = c + fx * (d - c);
    Some((top + fy * (bottom - top), clipped))
}

/// One circle fit to the edge points of one cast.
struct CircleStep {
    /// Centre correction from the cast's centre, pixels.
    dx: f64,
    dy: f64,
    radius_px: f64,
    sigma_px: f64,
    used: usize,
}

/// Terms of the outline's radius function rho(t) fitted per cast: R, the
/// centre offset (dx cos t + dy sin t) and an elliptical part (cos 2t,
/// sin 2t). Real outlines are slightly elliptical (the brightfield fixtures'
/// edge points show a clear second harmonic, up to 0.3 px); an ellipse's
/// centre has no first harmonic, so the term leaves the centre where it is
/// and keeps the shape out of the centre's uncertainty.
const SHAPE_TERMS: usize = 5;

/// The basis of rho(t) for direction (cos t, sin t).
fn shape_basis(c: f64, s: f64) -> SVector<f64, SHAPE_TERMS> {
    SVector::<f64, SHAPE_TERMS>::from_column_slice(&[1.0, c, s, c * c - s * s, 2.0 * c * s])
}

/// Fits rho_i = R + dx cos t_i + dy sin t_i + a cos 2t_i + b sin 2t_i to the
/// edge radii (linear; the offset terms are exact to second order in the
/// offset, which recasting removes), rejecting points beyond
/// `OUTLIER_SIGMAS` robust sigmas until the kept set is stable.
fn robust_circle(
    directions: &[(f64, f64)],
    edges: &[Option<f64>],
) -> Result<CircleStep, RingEdgeError> {
    let rows: Vec<(SVector<f64, SHAPE_TERMS>, f64)> = directions
        .iter()
        .zip(edges)
        .filter_map(|(&(c, s), e)| e.map(|rho| (shape_basis(c, s), rho)))
        .collect();
    let no_ring = |found| RingEdgeError::NoRing {
        found,
        cast: directions.len(),
        needed: MIN_RAYS,
    };
    if rows.len() < MIN_RAYS {
        return Err(no_ring(rows.len()));
    }
    let mut keep = vec![true; rows.len()];
    let mut passes = 0;
    loop {
        passes += 1;
        let kept: Vec<(SVector<f64, SHAPE_TERMS>, f64)> = rows
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(r, _)| *r)
            .collect();
        if kept.len() < MIN_RAYS {
            return Err(no_ring(kept.len()));
        }
        let (p, inverse) = solve_shape(&kept)?;
        let residual = |(a, rho): &(SVector<f64, SHAPE_TERMS>, f64)| rho - a.dot(&p);
        let kept_res: Vec<f64> = kept.iter().map(residual).collect();
        let scale = (1.4826
            * upper_median(&mut kept_res.iter().map(|x| x.abs()).collect::<Vec<_>>())
                .unwrap_or(0.0))
        .max(MIN_RESIDUAL_SCALE_PX);
        let next: Vec<bool> = rows
            .iter()
            .map(|r| residual(r).abs() <= OUTLIER_SIGMAS * scale)
            .collect();
        if next == keep || passes >= 5 {
            let dof = (kept.len() - SHAPE_TERMS) as f64;
            let variance = kept_res.iter().map(|e| e * e).sum::<f64>() / dof;
            let cov = inverse * (variance * correlation_inflation(&kept_res));
            return Ok(CircleStep {
                dx: p[1],
                dy: p[2],
                radius_px: p[0],
                sigma_px: (0.5 * (cov[(1, 1)] + cov[(2, 2)])).max(0.0).sqrt(),
                used: kept.len(),
            });
        }
        keep = next;
    }
}

/// Least-squares shape terms and the inverse normal matrix; `OneSided` when
/// the rays do not surround the centre.
#[allow(clippy::type_complexity)]
fn solve_shape(
    rows: &[(SVector<f64, SHAPE_TERMS>, f64)],
) -> Result<
    (
        SVector<f64, SHAPE_TERMS>,
        SMatrix<f64, SHAPE_TERMS, SHAPE_TERMS>,
    ),
    RingEdgeError,
> {
    let mut ata = SMatrix::<f64, SHAPE_TERMS, SHAPE_TERMS>::zeros();
    let mut atb = SVector::<f64, SHAPE_TERMS>::zeros();
    for (a, rho) in rows {
        ata += a * a.transpose();
        atb += a * *rho;
    }
    let coverage = (ata / rows.len() as f64).symmetric_eigenvalues().min();
    if coverage.is_nan() || coverage < MIN_COVERAGE {
        return Err(RingEdgeError::OneSided {
            coverage: if coverage.is_finite() { coverage } else { 0.0 },
        });
    }
    let inverse = ata
        .try_inverse()
        .ok_or(RingEdgeError::OneSided { coverage })?;
    Ok((inverse * atb, inverse))
}

/// Variance inflation for residuals correlated from ray to ray (they share
/// pixels, and a real ring's shape varies smoothly): (1 + rho) / (1 - rho)
/// for the lag-1 autocorrelation rho around the ring (AR(1) long-run
/// variance); 1 when rho <= 0.
fn correlation_inflation(residuals: &[f64]) -> f64 {
    let n = residuals.len();
    let ss: f64 = residuals.iter().map(|e| e * e).sum();
    if n < 3 || ss <= 0.0 {
        return 1.0;
    }
    let lag1: f64 = (0..n).map(|i| residuals[i] * residuals[(i + 1) % n]).sum();
    let rho = (lag1 / ss).clamp(0.0, 0.9);
    (1.0 + rho) / (1.0 - rho)
}

/// Chi-square (2 degrees of freedom) quantile at `ASYMMETRY_P_VALUE`.
fn asymmetry_threshold() -> f64 {
    -2.0 * ASYMMETRY_P_VALUE.ln()
}

/// Moves every detection whose ring-edge centre differs significantly from
/// its centre (|d|^2 / (sigma_ring^2 + sigma_profile^2) above the chi-square
/// quantile at p = 0.001; the variance sum assumes independent estimates,
/// which over-states the difference's variance and so errs towards keeping
/// the profile centre). Neighbours are the other detections. Returns what was
/// done with each detection, in order.
pub fn recentre_on_ring_edges(
    frame: &Frame,
    found: &mut [Detection],
    noise_sigma: f64,
) -> Vec<RingEdgeOutcome> {
    let centres: Vec<(f64, f64)> = found.iter().map(|d| (d.x_px, d.y_px)).collect();
    let threshold = asymmetry_threshold();
    found
        .iter_mut()
        .enumerate()
        .map(|(i, d)| {
            // Beyond twice the band's outer radius a neighbour's half-plane
            // does not reach the band.
            let reach = 2.0 * SEARCH_OUTER_FRACTION * d.r_px;
            let neighbours = super::detect::neighbours_within(&centres, i, reach);
            match ring_edge_centre(frame, d.x_px, d.y_px, d.r_px, &neighbours, noise_sigma) {
                Err(e) => RingEdgeOutcome::Failed(e),
                Ok(f) => {
                    let shift_px = (f.x_px - d.x_px).hypot(f.y_px - d.y_px);
                    let variance = f.sigma_px.powi(2) + d.sigma_px.powi(2);
                    let statistic = if variance > 0.0 {
                        shift_px * shift_px / variance
                    } else {
                        f64::INFINITY
                    };
                    if statistic > threshold {
                        d.x_px = f.x_px;
                        d.y_px = f.y_px;
                        d.r_px = f.r_px;
                        d.sigma_px = f.sigma_px;
                        RingEdgeOutcome::Recentred {
                            shift_px,
                            statistic,
                        }
                    } else {
                        RingEdgeOutcome::Consistent {
                            shift_px,
                            statistic,
                        }
                    }
                }
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::profile_fit::{ProfileModel, fit_particle};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    const BACKGROUND: f64 = 1000.0;

    /// A 16-bit frame of `f(x, y)` plus Gaussian noise of `noise` counts (seeded).
    fn frame_of(size: usize, noise: f64, seed: u64, f: impl Fn(f64, f64) -> f64) -> Frame {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, noise.max(1e-12)).unwrap();
        let pixels = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f64, (i / size) as f64);
                let n = if noise > 0.0 {
                    normal.sample(&mut rng)
                } else {
                    0.0
                };
                (f(x, y) + n).clamp(0.0, 65535.0) as f32
            })
            .collect();
        Frame::new(size, size, pixels, 16).unwrap()
    }

    /// A bright-field sphere whose outline (dark ring, radius 8.5 px) is
    /// centred at (cx, cy) and whose bright core sits `core_dx` px to the
    /// side; the ring is broader on the side away from the core, as on the
    /// real fixtures (oblique light). `sign` -1 flips the contrast.
    fn asymmetric_sphere(cx: f64, cy: f64, core_dx: f64, sign: f64) -> impl Fn(f64, f64) -> f64 {
        move |x, y| {
            let (dx, dy) = (x - cx, y - cy);
            let r = dx.hypot(dy);
            let cos_t = if r > 0.0 { dx / r } else { 0.0 };
            let away = if core_dx == 0.0 {
                0.0
            } else {
                -cos_t * core_dx.signum()
            };
            let width = 1.2 + 0.8 * away.max(0.0);
            let ring = 400.0 * (-0.5 * ((r - 8.5) / width).powi(2)).exp();
            let core_r2 = (x - cx - core_dx).powi(2) + dy * dy;
            let core = 600.0 * (-0.5 * core_r2 / 3.8f64.powi(2)).exp();
            BACKGROUND + sign * (core - ring)
        }
    }

    #[test]
    fn symmetric_noise_free_rings_give_their_centre() {
        for (cx, cy) in [(40.0, 40.0), (40.3, 39.8), (39.55, 40.45)] {
            let frame = frame_of(80, 0.0, 1, asymmetric_sphere(cx, cy, 0.0, 1.0));
            let f = ring_edge_centre(&frame, cx + 0.7, cy - 0.6, 8.0, &[], 1.0).unwrap();
            let err = (f.x_px - cx).hypot(f.y_px - cy);
            assert!(err < 0.03, "({cx}, {cy}): error {err} px");
            // The profile's minimum, which the core's tail puts a little
            // outside the ring's 8.5 px (dense 1-D search).
            let sphere = asymmetric_sphere(cx, cy, 0.0, 1.0);
            let r_min = (6000..11000)
                .map(|i| i as f64 * 1e-3)
                .min_by(|a, b| sphere(cx + a, cy).total_cmp(&sphere(cx + b, cy)))
                .unwrap();
            assert!(r_min > 8.55, "core tail moves the minimum out: {r_min}");
            assert!(
                (f.r_px - r_min).abs() < 0.05,
                "radius {} vs {r_min}",
                f.r_px
            );
            assert_eq!(f.rays_used, f.rays_cast);
        }
    }

    /// The failure mode this module exists for: the core 1 px off the outline
    /// pulls the profile fit; the ring edge stays on the outline.
    #[test]
    fn asymmetric_sphere_outline_centre_where_the_profile_fit_is_pulled_to_the_core() {
        let (cx, cy) = (50.2, 49.7);
        for seed in 1..=4 {
            let frame = frame_of(100, 10.0, seed, asymmetric_sphere(cx, cy, -1.0, 1.0));
            let p = fit_particle(&frame, cx, cy, 8.5, ProfileModel::Ring).unwrap();
            let f = ring_edge_centre(&frame, p.x_px, p.y_px, p.r_px, &[], 10.0).unwrap();
            let profile_err = (p.x_px - cx).hypot(p.y_px - cy);
            let ring_err = (f.x_px - cx).hypot(f.y_px - cy);
            println!(
                "seed {seed}: profile error {profile_err:.3} px, ring-edge error {ring_err:.3} px"
            );
            assert!(
                profile_err > 0.2,
                "seed {seed}: profile error {profile_err}"
            );
            assert!(ring_err < 0.1, "seed {seed}: ring-edge error {ring_err}");
            assert!(f.sigma_px > 0.0 && f.sigma_px < 0.1, "sigma {}", f.sigma_px);
        }
    }

    #[test]
    fn bright_ring_of_the_inverted_contrast_is_found() {
        let (cx, cy) = (40.4, 40.1);
        let frame = frame_of(80, 5.0, 7, asymmetric_sphere(cx, cy, 0.0, -1.0));
        let f = ring_edge_centre(&frame, cx - 0.5, cy + 0.5, 8.5, &[], 5.0).unwrap();
        assert!((f.x_px - cx).hypot(f.y_px - cy) < 0.1, "{f:?}");
        assert!((f.r_px - 8.5).abs() < 0.2, "{f:?}");
    }

    /// A dark bar (the probe's cantilever) across the ring's right side: its
    /// rays are rejected as outliers, the centre stays on the outline.
    #[test]
    fn a_dark_bar_across_the_ring_is_rejected() {
        let (cx, cy) = (40.0, 40.0);
        let sphere = asymmetric_sphere(cx, cy, 0.0, 1.0);
        let frame = frame_of(80, 5.0, 3, |x, y| {
            let bar = if (y - 41.0).abs() < 1.5 && x > 44.0 {
                -700.0
            } else {
                0.0
            };
            sphere(x, y) + bar
        });
        let f = ring_edge_centre(&frame, cx + 0.4, cy, 8.5, &[], 5.0).unwrap();
        assert!((f.x_px - cx).hypot(f.y_px - cy) < 0.1, "{f:?}");
        assert!(f.rays_used < f.rays_cast);
    }

    /// A touching neighbour's ring is not taken for this one's: rays are cut
    /// at the bisector.
    #[test]
    fn touching_neighbour_is_cut_at_the_bisector() {
        let a = asymmetric_sphere(30.0, 40.0, 0.0, 1.0);
        let b = asymmetric_sphere(47.0, 40.3, 0.0, 1.0);
        let frame = frame_of(80, 5.0, 5, |x, y| a(x, y) + b(x, y) - BACKGROUND);
        let f = ring_edge_centre(&frame, 30.3, 40.2, 8.5, &[(47.0, 40.3)], 5.0).unwrap();
        assert!((f.x_px - 30.0).hypot(f.y_px - 40.0) < 0.15, "{f:?}");
    }

    #[test]
    fn no_ring_gives_a_typed_outcome_never_nan() {
        // Flat noise, a Gaussian spot without a ring, a uniform frame.
        let flat = frame_of(64, 5.0, 2, |_, _| BACKGROUND);
        let spot = frame_of(64, 5.0, 2, |x, y| {
            BACKGROUND + 800.0 * (-0.5 * ((x - 32.0).powi(2) + (y - 32.0).powi(2)) / 9.0).exp()
        });
        let uniform = frame_of(64, 0.0, 2, |_, _| BACKGROUND);
        for (name, frame) in [("flat", &flat), ("spot", &spot), ("uniform", &uniform)] {
            match ring_edge_centre(frame, 32.0, 32.0, 8.5, &[], 5.0) {
                Err(RingEdgeError::NoRing { found, cast, .. }) => {
                    assert!(found < MIN_RAYS && cast > 0, "{name}")
                }
                other => panic!("{name}: {other:?}"),
            }
        }
    }

    #[test]
    fn bad_starts_and_one_sided_rings_are_refused() {
        let frame = frame_of(80, 5.0, 4, asymmetric_sphere(40.0, 40.0, 0.0, 1.0));
        for (x, y, r) in [
            (f64::NAN, 40.0, 8.5),
            (40.0, f64::INFINITY, 8.5),
            (40.0, 40.0, 1.0),
            (40.0, 40.0, f64::NAN),
            (-3.0, 40.0, 8.5),
            (40.0, 95.0, 8.5),
        ] {
            assert!(
                matches!(
                    ring_edge_centre(&frame, x, y, r, &[], 5.0),
                    Err(RingEdgeError::BadStart(_))
                ),
                "({x}, {y}, {r})"
            );
        }
        // A sphere cut by the frame's corner: most rays leave the frame.
        let corner = frame_of(60, 5.0, 4, asymmetric_sphere(2.0, 2.0, 0.0, 1.0));
        let outcome = ring_edge_centre(&corner, 2.0, 2.0, 8.5, &[], 5.0);
        assert!(
            matches!(
                outcome,
                Err(RingEdgeError::OneSided { .. } | RingEdgeError::NoRing { .. })
            ),
            "{outcome:?}"
        );
        // Neighbours all round leave no ray.
        let around: Vec<(f64, f64)> = (0..6)
            .map(|k| {
                let t = k as f64 * std::f64::consts::FRAC_PI_3;
                (40.0 + 12.0 * t.cos(), 40.0 + 12.0 * t.sin())
            })
            .collect();
        assert!(ring_edge_centre(&frame, 40.0, 40.0, 8.5, &around, 5.0).is_err());
        // A tiny frame, and a non-finite noise figure (falls back to the floor).
        let tiny = Frame::new(1, 1, vec![5.0], 8).unwrap();
        assert!(ring_edge_centre(&tiny, 0.0, 0.0, 8.5, &[], 1.0).is_err());
        let f = ring_edge_centre(&frame, 40.2, 40.0, 8.5, &[], f64::NAN).unwrap();
        assert!(f.x_px.is_finite() && f.sigma_px.is_finite());
    }

    #[test]
    fn recentring_moves_only_significantly_asymmetric_particles() {
        let det = |x_px, y_px, sigma_px| Detection {
            x_px,
            y_px,
            r_px: 8.5,
            sigma_px,
            quality: 30.0,
            edge_clipped: false,
            fitted: true,
        };
        let a = asymmetric_sphere(30.0, 30.0, -1.0, 1.0);
        let s = asymmetric_sphere(90.0, 90.0, 0.0, 1.0);
        let frame = frame_of(120, 10.0, 9, |x, y| a(x, y) + s(x, y) - BACKGROUND);
        // The asymmetric one as the profile fit would report it (0.4 px
        // towards the core), the symmetric one at its truth.
        let mut found = vec![det(29.6, 30.0, 0.02), det(90.0, 90.0, 0.02)];
        let outcomes = recentre_on_ring_edges(&frame, &mut found, 10.0);
        assert!(
            matches!(outcomes[0], RingEdgeOutcome::Recentred { shift_px, .. } if shift_px > 0.3),
            "{outcomes:?}"
        );
        assert!(
            matches!(outcomes[1], RingEdgeOutcome::Consistent { .. }),
            "{outcomes:?}"
        );
        assert!((found[0].x_px - 30.0).hypot(found[0].y_px - 30.0) < 0.1);
        assert_eq!((found[1].x_px, found[1].y_px), (90.0, 90.0));
    }

    #[test]
    fn correlation_inflation_grows_with_smooth_residuals() {
        let alternating: Vec<f64> = (0..40)
            .map(|i| if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        assert_eq!(correlation_inflation(&alternating), 1.0);
        let smooth: Vec<f64> = (0..40).map(|i| (i as f64 * 0.3).sin()).collect();
        assert!(correlation_inflation(&smooth) > 5.0);
        assert_eq!(correlation_inflation(&[0.0; 10]), 1.0);
    }
}
