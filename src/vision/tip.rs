//! Probe tip detection: the cantilever's silhouette from above, its apex, axis
//! angle and a match score.
//!
//! 1. The darkest large connected region (the opaque cantilever) gives a rough
//!    apex (its point farthest from where it enters the frame) and axis.
//! 2. A blurred-silhouette model (tapered cantilever, same shape family as the
//!    renderer's probe, width, taper, blur and contrast all free) is fitted to
//!    the pixels near its edges around the apex, with Huber weights so a
//!    particle under or beside the tip does not pull the fit; free blur keeps
//!    it valid through focus changes.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use super::cpu_dispatch::avx2_dispatch;
use super::frame::Frame;
use super::least_squares::{Sample, levenberg_marquardt};
use super::noise::select_non_negative;
use crate::median::upper_median;
use crate::render::probe::{PlacedSilhouette, ProbeShape, ProbeSilhouette, normal_cdf};

/// Tip detection parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipSettings {
    /// A pixel is "probe" when darker than black + this fraction of (median - black).
    pub dark_fraction: f64,
    /// Smallest dark region, pixels, taken for the probe; it must also
    /// touch the frame's edge (the cantilever comes from beyond the view),
    /// which keeps particles out. 100 px: with its apex 20-30 px inside,
    /// a probe shows 100-400 px of itself (the limit was 400 px anywhere,
    /// and large dark particles of 30 px radius were taken for the probe).
    pub min_area_px: usize,
    /// Smallest score to report a tip.
    pub min_score: f64,
}

impl Default for TipSettings {
    fn default() -> Self {
        Self {
            dark_fraction: 0.45,
            min_area_px: 100,
            min_score: 0.5,
        }
    }
}

/// The detected probe tip.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TipDetection {
    /// Apex x in pixels.
    pub x_px: f64,
    /// Apex y in pixels.
    pub y_px: f64,
    /// Direction from the cantilever body to the apex, radians in (-pi, pi].
    pub angle_rad: f64,
    /// Fraction of the intensity variance near the tip the model explains (0..1).
    pub score: f64,
    /// Fitted cantilever width in pixels.
    pub width_px: f64,
    /// Fitted taper length in pixels.
    pub taper_length_px: f64,
}

impl TipDetection {
    /// Signed distance from (x, y) to the fitted silhouette (negative inside).
    pub fn signed_distance(&self, x: f64, y: f64) -> f64 {
        self.silhouette().signed_distance(x, y)
    }

    fn silhouette(&self) -> ProbeSilhouette {
        ProbeSilhouette {
            apex_x_px: self.x_px,
            apex_y_px: self.y_px,
            angle_rad: self.angle_rad,
            shape: ProbeShape {
                width_px: self.width_px,
                taper_length_px: self.taper_length_px,
                opacity: 1.0,
            },
        }
    }
}

/// Median of a sample of about 65 536 of the frame's pixels: the background
/// level (the probe and particles cover a minority of the frame). Counts are
/// non-negative, so the exact median comes from the radix select of the noise
/// estimate (two histogram passes, a third of quickselect's time); a frame
/// with a negative (or -0) value takes quickselect.
fn background_median(frame: &Frame) -> f32 {
    let px = frame.pixels();
    let step = (px.len() / 65536).max(1);
    let mut sample: Vec<f32> = px.iter().step_by(step).copied().collect();
    let mid = sample.len() / 2;
    if sample.iter().all(|v| v.is_sign_positive()) {
        return select_non_negative(&sample, mid);
    }
    *sample.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// Lanes for the whole-frame scans below: fixed-width chunks whose
/// per-lane minimum and "any below" compile to vector instructions, where a
/// per-pixel fold or an early-exit test runs one pixel per cycle or worse.
const SCAN_LANES: usize = 16;

/// The darkest level two neighbouring pixels share: the least, over every
/// pixel and the next in the buffer, of the brighter of the two. A camera's
/// dead pixel (0 counts) next to normal ones is not the frame's dark level:
/// taken as it, it moved the dark-region threshold below a low-contrast
/// probe, which was then not found. The probe is hundreds of pixels wide.
/// (NaN-free frames; a NaN would be skipped.)
#[inline(always)]
fn darkest(px: &[f32]) -> f32 {
    if px.len() < 2 {
        return px.first().copied().unwrap_or(f32::INFINITY);
    }
    let (here, next) = (&px[..px.len() - 1], &px[1..]);
    let mut lanes = [f32::INFINITY; SCAN_LANES];
    let pairs = here
        .chunks_exact(SCAN_LANES)
        .zip(next.chunks_exact(SCAN_LANES));
    let tail = here.len() - here.len() % SCAN_LANES;
    for (a, b) in here[tail..].iter().zip(&next[tail..]) {
        let v = if a > b { *a } else { *b };
        lanes[0] = if v < lanes[0] { v } else { lanes[0] };
    }
    for (a, b) in pairs {
        for ((m, &a), &b) in lanes.iter_mut().zip(a).zip(b) {
            let v = if a > b { a } else { b };
            *m = if v < *m { v } else { *m };
        }
    }
    lanes.into_iter().fold(f32::INFINITY, f32::min)
}

avx2_dispatch!(
    /// The largest dark connected region, as pixel (x, y); its two
    /// whole-frame scans (dark level, dark chunks) run 8 lanes with AVX2.
    fn dark_region(
        frame: &Frame,
        settings: &TipSettings,
        median: f32,
    ) -> Option<Vec<(usize, usize)>> => dark_region_lanes
);

/// Positions travel as coordinates, not indices: splitting an index into x
/// and y is an integer division per pixel, which cost more than the flood
/// fill itself.
#[inline(always)]
fn dark_region_lanes(
    frame: &Frame,
    settings: &TipSettings,
    median: f32,
) -> Option<Vec<(usize, usize)>> {
    let (w, h) = (frame.width(), frame.height());
    let px = frame.pixels();
    let black = darkest(px);
    if median - black <= 0.0 {
        return None;
    }
    let t = black + settings.dark_fraction as f32 * (median - black);
    let mut label = vec![false; w * h];
    let mut best: Option<Vec<(usize, usize)>> = None;
    let mut stack = Vec::new();
    for y0 in 0..h {
        let row = &px[y0 * w..(y0 + 1) * w];
        // Skip whole chunks with no dark pixel (most of the frame) at once.
        for (chunk_no, chunk) in row.chunks(SCAN_LANES).enumerate() {
            if chunk.iter().fold(true, |all, &v| all & (v >= t)) {
                continue;
            }
            for x0 in chunk_no * SCAN_LANES..chunk_no * SCAN_LANES + chunk.len() {
                let start = y0 * w + x0;
                if label[start] || px[start] >= t {
                    continue;
                }
                let mut region = Vec::new();
                label[start] = true;
                stack.push((x0, y0));
                while let Some((x, y)) = stack.pop() {
                    region.push((x, y));
                    let mut visit = |x: usize, y: usize| {
                        let j = y * w + x;
                        if !label[j] && px[j] < t {
                            label[j] = true;
                            stack.push((x, y));
                        }
                    };
                    if x > 0 {
                        visit(x - 1, y);
                    }
                    if x + 1 < w {
                        visit(x + 1, y);
                    }
                    if y > 0 {
                        visit(x, y - 1);
                    }
                    if y + 1 < h {
                        visit(x, y + 1);
                    }
                }
                // The probe enters the frame from its edge.
                let on_edge =
                    || (region.iter()).any(|&(x, y)| x == 0 || y == 0 || x + 1 == w || y + 1 == h);
                let larger = region.len() >= settings.min_area_px
                    && best.as_ref().is_none_or(|b| region.len() > b.len());
                if larger && on_edge() {
                    best = Some(region);
                }
            }
        }
    }
    best
}

/// Rough apex, angle, width and taper from the dark region, and its length
/// from where it meets the frame's edge to its far point (the apex).
fn initial_guess(region: &[(usize, usize)], w: usize, h: usize) -> (f64, f64, f64, f64, f64, f64) {
    let xy = |&(x, y): &(usize, usize)| (x as f64, y as f64);
    let on_border: Vec<(f64, f64)> = region
        .iter()
        .map(xy)
        .filter(|&(x, y)| x == 0.0 || y == 0.0 || x == (w - 1) as f64 || y == (h - 1) as f64)
        .collect();
    let mean = |pts: &[(f64, f64)]| {
        let n = pts.len().max(1) as f64;
        (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        )
    };
    let base = if on_border.is_empty() {
        let all: Vec<(f64, f64)> = region.iter().map(xy).collect();
        mean(&all)
    } else {
        mean(&on_border)
    };
    let far = region
        .iter()
        .map(xy)
        .max_by(|a, b| {
            let da = (a.0 - base.0).powi(2) + (a.1 - base.1).powi(2);
            let db = (b.0 - base.0).powi(2) + (b.1 - base.1).powi(2);
            da.total_cmp(&db)
        })
        .unwrap_or(base);
    let angle = (far.1 - base.1).atan2(far.0 - base.0);
    let (s, c) = angle.sin_cos();
    // Width profile along the axis: pixels per unit length behind the apex.
    // Each pixel is shared between the two bins beside it: counted whole
    // into one, an axis along a pixel diagonal puts one diagonal line of
    // pixels in some bins and two in others, and the median width came out
    // 1/sqrt(2) of the probe's, a start the fit never recovered from.
    let len = ((far.0 - base.0).powi(2) + (far.1 - base.1).powi(2))
        .sqrt()
        .max(1.0);
    let nbins = len.ceil() as usize + 2;
    let mut counts = vec![0.0f64; nbins + 1];
    for p in region {
        let (x, y) = xy(p);
        let u = -((x - far.0) * c + (y - far.1) * s);
        if u >= 0.0 && (u as usize) < nbins {
            let (bin, frac) = (u as usize, u.fract());
            counts[bin] += 1.0 - frac;
            counts[bin + 1] += frac;
        }
    }
    counts.truncate(nbins);
    let lo = (0.5 * len) as usize;
    let hi = ((0.9 * len) as usize).max(lo + 1).min(nbins);
    let mut body: Vec<f64> = counts[lo..hi].to_vec();
    body.sort_unstable_by(f64::total_cmp);
    let width = body
        .get(body.len() / 2)
        .copied()
        .unwrap_or(10.0)
        .round()
        .max(3.0);
    let taper = counts
        .iter()
        .position(|&n| n >= 0.9 * width)
        .unwrap_or(width as usize) as f64;
    (far.0, far.1, angle, width, taper.max(2.0), len)
}

fn silhouette_of(p: &SVector<f64, 8>) -> ProbeSilhouette {
    ProbeSilhouette {
        apex_x_px: p[0],
        apex_y_px: p[1],
        angle_rad: p[2],
        shape: ProbeShape {
            width_px: p[3],
            taper_length_px: p[4],
            opacity: p[6],
        },
    }
}

fn edge_sigma(p: &SVector<f64, 8>) -> f64 {
    p[7].abs().max(0.05)
}

/// The tip model at parameters p, placed once: f(x, y) = level * (1 -
/// opacity * Phi(-d / blur)), d the signed distance to the silhouette, seen
/// through the camera: the mean of a noisy value clipped at the full count
/// ([`TipModel::clipped`]). Where the background clips (an over-exposed
/// frame) the model clips with it, so saturated pixels pull nothing;
/// without the clip the fit bent the edge to meet the flat clipped level
/// (apex 0.67 px off at three times the gain), and without the noise the
/// pixels of a background at the clip level, saturated or not, read low
/// (0.58 px at 2.7x; tests/vision_tip.rs).
struct TipModel {
    placed: PlacedSilhouette,
    full_count: f64,
    /// Per-pixel noise sigma, counts (0: clip without noise, the first
    /// round, before the residuals give it).
    noise: f64,
    level: f64,
    opacity: f64,
    sigma: f64,
    blur_sign: f64,
}

impl TipModel {
    fn at(p: &SVector<f64, 8>, full_count: f64, noise: f64) -> Self {
        Self {
            placed: silhouette_of(p).placed(),
            full_count,
            noise,
            level: p[5],
            opacity: p[6],
            sigma: edge_sigma(p),
            // The blur enters as |p7| floored at 0.05: no gradient on the floor.
            blur_sign: if p[7].abs() > 0.05 {
                p[7].signum()
            } else {
                0.0
            },
        }
    }

    fn value(&self, x: f64, y: f64) -> f64 {
        let d = self.placed.signed_distance(x, y);
        self.clipped(self.level * (1.0 - self.opacity * normal_cdf(-d / self.sigma)))
            .0
    }

    /// What the camera shows on average of a true value f with Gaussian
    /// noise, clipped at the full count c, and its derivative in f:
    /// E[min(X, c)] = f - (f - c) Phi(b) - noise phi(b) with
    /// b = (f - c) / noise, derivative Phi(-b); min(f, c) without noise.
    fn clipped(&self, f: f64) -> (f64, f64) {
        let c = self.full_count;
        if self.noise <= 0.0 || !c.is_finite() {
            return if f > c { (c, 0.0) } else { (f, 1.0) };
        }
        let b = (f - c) / self.noise;
        if b < -8.0 {
            return (f, 1.0);
        }
        let density = (-0.5 * b * b).exp() / (2.0 * std::f64::consts::PI).sqrt();
        (
            f - (f - c) * normal_cdf(b) - self.noise * density,
            normal_cdf(-b),
        )
    }

    /// Value and analytic gradient (the geometry through the signed
    /// distance's gradient, see `PlacedSilhouette::signed_distance_grad`).
    fn value_grad(&self, x: f64, y: f64, g: &mut SVector<f64, 8>) -> f64 {
        let (d, dd) = self.placed.signed_distance_grad(x, y);
        let z = -d / self.sigma;
        let covered = normal_cdf(z);
        let density = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
        // df/dd = level * opacity * phi(z) / sigma.
        let df_dd = self.level * self.opacity * density / self.sigma;
        for (gi, ddi) in g.iter_mut().zip(dd) {
            *gi = df_dd * ddi;
        }
        g[5] = 1.0 - self.opacity * covered;
        g[6] = -self.level * covered;
        g[7] = -df_dd * (d / self.sigma) * self.blur_sign;
        let (value, slope) = self.clipped(self.level * (1.0 - self.opacity * covered));
        *g *= slope;
        value
    }
}

/// Side of the pixel blocks [`edge_band`] tests as a whole.
const BAND_BLOCK: usize = 4;

/// The pixels of the box [x0, x1] x [y0, y1] (inclusive) within the circle
/// (cx, cy, radius) whose signed distance to `sil` is at most `band` in
/// magnitude, in raster order. The signed distance is 1-Lipschitz (the
/// distance to the silhouette's edge, signed by side; its far end is 1e5 px
/// away), so a block whose centre lies farther than `band` + half its
/// diagonal from the edge holds no such pixel and is skipped whole: the edge
/// band is a few percent of the box, and a distance costs two segment
/// projections and a square root.
fn edge_band(
    sil: &PlacedSilhouette,
    (x0, x1): (usize, usize),
    (y0, y1): (usize, usize),
    (cx, cy, radius): (f64, f64, f64),
    band: f64,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    if x1 < x0 || y1 < y0 {
        return out;
    }
    let blocks = (x1 - x0) / BAND_BLOCK + 1;
    let mut live = vec![false; blocks];
    for by in (y0..=y1).step_by(BAND_BLOCK) {
        let ey = (by + BAND_BLOCK - 1).min(y1);
        for (b, l) in live.iter_mut().enumerate() {
            let bx = x0 + b * BAND_BLOCK;
            let ex = (bx + BAND_BLOCK - 1).min(x1);
            let (mx, my) = (0.5 * (bx + ex) as f64, 0.5 * (by + ey) as f64);
            // Half the diagonal, and a margin for the rounding of distances.
            let reach = 0.5 * ((ex - bx) as f64).hypot((ey - by) as f64) + 1e-6;
            *l = (mx - cx).hypot(my - cy) <= radius + reach
                && sil.signed_distance(mx, my).abs() <= band + reach;
        }
        for y in by..=ey {
            for (b, _) in live.iter().enumerate().filter(|&(_, &l)| l) {
                let bx = x0 + b * BAND_BLOCK;
                for x in bx..=(bx + BAND_BLOCK - 1).min(x1) {
                    let (xf, yf) = (x as f64, y as f64);
                    if (xf - cx).powi(2) + (yf - cy).powi(2) <= radius * radius
                        && sil.signed_distance(xf, yf).abs() <= band
                    {
                        out.push((x, y));
                    }
                }
            }
        }
    }
    out
}

/// The largest fitted blur, as a fraction of the apex's length (the taper
/// length or the dark region's length from where it meets the frame's edge
/// to its far point, whichever is shorter), of a fit taken for a probe: a
/// probe's apex is sharper than the blur, while dark dirt cut by the frame's
/// edge, or a shaded corner, is a soft shape the fit can only match with a
/// blur of about its own size. Measured (2026-11-30, the frames of
/// `scripts/tip_false_study.py`, blurred at sigma 0-6 px): true tips 0.017
/// to 0.15, 0.28 for an apex 20 px inside the frame's edge at sigma 3; the
/// probe-free frames' false tips 0.45 and more, but for those of shading
/// (opacity 0.00-0.10, see `MIN_OPACITY`) and one fit that left its dark
/// region (0.22, see `MAX_APEX_SHIFT_PER_APEX_LENGTH`). An apex 20-30 px
/// inside the edge at sigma 6 (0.42-0.78) is lost with them: 12-20 px of a
/// probe under a 6 px blur is not told from a dirt blob.
const MAX_BLUR_PER_APEX_LENGTH: f64 = 0.35;

/// The least fitted opacity of a probe (the fraction of the light its body
/// takes away): the renderer's probe fits 0.85, one of half its contrast
/// 0.43, while the false tips of shading (vignetted corners of frames out
/// of focus, synthetic and real, at sigma 3-6 px) fitted 0.00-0.10; of the
/// false tips with a blur under `MAX_BLUR_PER_APEX_LENGTH`, only one
/// fitted more (0.48), and its apex had left its dark region.
const MIN_OPACITY: f64 = 0.3;

/// The largest fitted opacity: more than all of the light (past noise)
/// is no occluder. False tips on dirt, shaded or not, fitted 1.26-1.29.
const MAX_OPACITY: f64 = 1.05;

/// How far the fit may move the apex from the dark region's far point, as a
/// fraction of the apex's length (as in `MAX_BLUR_PER_APEX_LENGTH`): the
/// fit refines the apex of the region it started from. True tips moved
/// 0.03-0.34 of it (the most at sigma 6 px); a false tip on two touching dirt
/// blobs, 1.5, its apex 97 px out in the bright background.
const MAX_APEX_SHIFT_PER_APEX_LENGTH: f64 = 1.0;

/// Whether the fitted silhouette `p` is a probe's, not a soft dark shape's
/// (dirt cut by the frame's edge, a shaded corner): an apex sharper than
/// the blur, an occluder's opacity, and the apex where the dark region ends
/// (`len`: the region's length from its edge base to `far`, its far point).
/// No score cut does this: a half-contrast probe scores 0.975 and dirt up to
/// 0.973.
fn probe_like(p: &SVector<f64, 8>, len: f64, far: (f64, f64)) -> bool {
    let apex_length = p[4].min(len);
    let shift = (p[0] - far.0).hypot(p[1] - far.1);
    p[7].abs() <= MAX_BLUR_PER_APEX_LENGTH * apex_length
        && (MIN_OPACITY..=MAX_OPACITY).contains(&p[6])
        && shift <= MAX_APEX_SHIFT_PER_APEX_LENGTH * apex_length
}

/// Finds the probe tip, or `None` when no probe silhouette is in view.
pub fn detect_tip(frame: &Frame, settings: &TipSettings) -> Option<TipDetection> {
    let (w, h) = (frame.width(), frame.height());
    let full = f64::from(frame.max_count());
    let median = background_median(frame);
    let region = dark_region(frame, settings, median)?;
    let (ax, ay, angle, width, taper, len) = initial_guess(&region, w, h);
    let inside: Vec<f64> = region.iter().map(|&(x, y)| frame.at(x, y) as f64).collect();
    let dark = inside.iter().sum::<f64>() / inside.len() as f64;
    let bg = median as f64;
    let opacity = (1.0 - dark / bg.max(1e-9)).clamp(0.05, 1.0);
    let mut p =
        SVector::<f64, 8>::from_column_slice(&[ax, ay, angle, width, taper, bg, opacity, 1.0]);
    let radius = (taper + width).clamp(20.0, 150.0);
    let mut weights_from: Option<(SVector<f64, 8>, f64)> = None;
    let mut score = 0.0;
    for round in 0..3 {
        let sil = silhouette_of(&p).placed();
        let noise = weights_from.map_or(0.0, |(_, s)| s);
        let weighting = weights_from.map(|(q, s)| (TipModel::at(&q, full, noise), s));
        let band = 3.0 * p[7].abs() + 3.0;
        let (x0, x1) = (
            (p[0] - radius).max(0.0) as usize,
            ((p[0] + radius) as usize).min(w - 1),
        );
        let (y0, y1) = (
            (p[1] - radius).max(0.0) as usize,
            ((p[1] + radius) as usize).min(h - 1),
        );
        let mut samples: Vec<Sample> = Vec::new();
        for (x, y) in edge_band(&sil, (x0, x1), (y0, y1), (p[0], p[1], radius), band) {
            let (xf, yf) = (x as f64, y as f64);
            let v = frame.at(x, y) as f64;
            let wgt = match &weighting {
                Some((q, s)) => {
                    let r = (v - q.value(xf, yf)).abs();
                    if r <= 2.5 * *s { 1.0 } else { 2.5 * *s / r }
                }
                None => 1.0,
            };
            samples.push((xf, yf, v, wgt));
        }
        let fit = levenberg_marquardt(&samples, p, 40, |q| {
            let model = TipModel::at(q, full, noise);
            move |x, y, g: &mut SVector<f64, 8>| model.value_grad(x, y, g)
        });
        // A reweighted round may fail where the first held: a probe whose
        // body is out of the frame shows only its taper, so its width and
        // taper length are one unknown between them. The last round's fit
        // stands then (its apex was within 0.1 px on the frames that did
        // this); before, the whole tip was dropped.
        let fit = match fit {
            Ok(fit) => fit,
            Err(_) if round > 0 => break,
            Err(_) => return None,
        };
        p = fit.params;
        // Robust noise scale for the next round's weights.
        let model = TipModel::at(&p, full, noise);
        let mut abs_res: Vec<f64> = samples
            .iter()
            .map(|s| (s.2 - model.value(s.0, s.1)).abs())
            .collect();
        let mad = upper_median(&mut abs_res).unwrap_or(0.0);
        weights_from = Some((p, (1.4826 * mad).max(1e-9)));
        let mean = samples.iter().map(|s| s.2 * s.3).sum::<f64>()
            / samples.iter().map(|s| s.3).sum::<f64>();
        let tss: f64 = samples.iter().map(|s| s.3 * (s.2 - mean).powi(2)).sum();
        score = if tss > 0.0 {
            (1.0 - fit.rss / tss).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    // The apex must be in view: a cantilever crossing the frame with its
    // apex beyond it fits a silhouette too, extrapolated to nowhere.
    let in_frame = (0.0..=(w - 1) as f64).contains(&p[0]) && (0.0..=(h - 1) as f64).contains(&p[1]);
    if !(p.iter().all(|v| v.is_finite()) && p[3] > 1.0 && p[4] > 0.0 && in_frame)
        || score < settings.min_score
        || !probe_like(&p, len, (ax, ay))
    {
        return None;
    }
    let angle = (p[2].sin()).atan2(p[2].cos());
    Some(TipDetection {
        x_px: p[0],
        y_px: p[1],
        angle_rad: angle,
        score,
        width_px: p[3],
        taper_length_px: p[4],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn background_median_equals_quickselect_for_either_sign() {
        for offset in [0.0f32, -300.0] {
            let px: Vec<f32> = (0..300 * 301)
                .map(|i| ((i * 7919) % 1009) as f32 * 0.75 + offset)
                .collect();
            let frame = Frame::new(300, 301, px.clone(), 16).unwrap();
            let step = (px.len() / 65536).max(1);
            let mut sorted: Vec<f32> = px.iter().step_by(step).copied().collect();
            sorted.sort_by(f32::total_cmp);
            assert_eq!(background_median(&frame), sorted[sorted.len() / 2]);
        }
    }

    #[test]
    fn edge_band_equals_the_pixel_by_pixel_selection() {
        let mut selected = 0;
        for (angle, taper, band) in [(0.4, 47.0, 6.0), (-2.9, 10.0, 3.05), (1.57, 0.5, 9.7)] {
            let sil = silhouette_of(&SVector::<f64, 8>::from_column_slice(&[
                100.3, 80.6, angle, 38.0, taper, 900.0, 0.8, 1.0,
            ]))
            .placed();
            for (bx, by, radius) in [((31, 170), (0, 161), 80.0), ((95, 97), (3, 200), 90.0)] {
                let mut want = Vec::new();
                for y in by.0..=by.1 {
                    for x in bx.0..=bx.1 {
                        let (xf, yf) = (x as f64, y as f64);
                        if (xf - 100.3).powi(2) + (yf - 80.6).powi(2) <= radius * radius
                            && sil.signed_distance(xf, yf).abs() <= band
                        {
                            want.push((x, y));
                        }
                    }
                }
                selected += want.len();
                assert_eq!(edge_band(&sil, bx, by, (100.3, 80.6, radius), band), want);
            }
        }
        assert!(selected > 1000, "the cases select edge pixels: {selected}");
    }

    #[test]
    fn tip_model_gradient_matches_central_differences() {
        let p =
            SVector::<f64, 8>::from_column_slice(&[100.3, 80.6, 0.4, 38.0, 47.0, 900.0, 0.8, 1.7]);
        let mut g = SVector::<f64, 8>::zeros();
        // Unclipped; clipped below the background (850 counts) with noise,
        // and without.
        for (full, noise) in [(f64::INFINITY, 0.0), (850.0, 30.0), (850.0, 0.0)] {
            let value = |q: &SVector<f64, 8>, x, y| TipModel::at(q, full, noise).value(x, y);
            // Pixels near the taper edges, the side edges and the apex.
            for &(x, y) in &[(98.0, 83.0), (70.0, 85.0), (60.0, 40.0), (101.0, 81.0)] {
                let v = TipModel::at(&p, full, noise).value_grad(x, y, &mut g);
                assert_eq!(v, value(&p, x, y));
                for i in 0..8 {
                    let h = [1e-3, 1e-3, 1e-5, 1e-3, 1e-3, 1e-3, 1e-5, 1e-4][i];
                    let (mut a, mut b) = (p, p);
                    a[i] += h;
                    b[i] -= h;
                    let fd = (value(&a, x, y) - value(&b, x, y)) / (2.0 * h);
                    assert!(
                        (fd - g[i]).abs() < 1e-3 * (1.0 + fd.abs()),
                        "full {full}, noise {noise}: ({x}, {y}) param {i}: {fd} vs {}",
                        g[i]
                    );
                }
            }
        }
    }

    /// The clipped mean: the value itself far below the clip, the clip far
    /// above it, and at the clip level the mean of min(X, c) by brute force.
    #[test]
    fn a_clipped_noisy_value_averages_as_sampled() {
        let model = TipModel::at(
            &SVector::<f64, 8>::from_column_slice(&[0.0, 0.0, 0.0, 10.0, 10.0, 1.0, 0.5, 1.0]),
            1000.0,
            50.0,
        );
        assert_eq!(model.clipped(100.0), (100.0, 1.0));
        let (far_above, slope) = model.clipped(2000.0);
        assert!((far_above - 1000.0).abs() < 1e-9 && slope < 1e-9);
        for f in [950.0, 1000.0, 1040.0] {
            // Midpoint quadrature of E[min(X, 1000)], X ~ N(f, 50^2).
            let n = 20_000;
            let mean: f64 = (0..n)
                .map(|k| {
                    let z = -8.0 + 16.0 * (k as f64 + 0.5) / n as f64;
                    let weight = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
                    (f + 50.0 * z).min(1000.0) * weight * 16.0 / n as f64
                })
                .sum();
            let (value, _) = model.clipped(f);
            assert!((value - mean).abs() < 1e-3, "f {f}: {value} vs {mean}");
        }
    }
}
