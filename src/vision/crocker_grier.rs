//! Crocker-Grier feature locator (Crocker & Grier 1996, J. Colloid Interface
//! Sci. 179, 298) with the parameter meanings trackpy documents for its
//! `locate`. It is the mode a lab user picks to get results comparable with
//! trackpy on real frames; nanopush's own detector (`detect.rs`) stays the
//! default for the rig (it fits ring profiles and works at the Cramer-Rao
//! bound, which a centroid does not).
//!
//! Steps, for a frame of integer counts (what a camera delivers):
//! 1. optional inversion (`max_count - v`), so dark features become bright;
//! 2. band-pass: a Gaussian blur of sigma `noise_size` (truncated at 4 sigma,
//!    zero outside the frame) minus a boxcar mean of side `smoothing_size`
//!    (edge pixels repeated; each axis pass rounded down to whole counts,
//!    as an integer image keeps its type), values below `threshold` set to 0;
//! 3. the band-pass rescaled to the full range of the frame's bit depth and
//!    truncated to whole levels (the integer image trackpy searches);
//! 4. local maxima: pixels equal to the maximum over the largest square inside
//!    a circle of radius `separation`, above the `percentile` of the non-zero
//!    pixels, and not within the edge margin;
//! 5. refinement: the centroid in a disc of radius `diameter / 2`; while it
//!    is more than 0.6 px off the disc's centre the disc moves by one pixel
//!    (at most `max_iterations` times);
//! 6. of two features closer than `separation`, the one with less mass is
//!    dropped; mass (band-passed, back in frame counts) must exceed `minmass`.
//!
//! Written by hand: no Rust crate implements this locator. It follows the
//! paper and trackpy's documentation; trackpy's source is not copied. Rounding
//! rules (4 sigma truncation, floored boxcar passes, truncated rescale, the
//! even dilation window) were pinned by comparing results black-box with
//! trackpy 0.7 (`scripts/peers/crocker_grier_vs_trackpy.py`).

use thiserror::Error;

use super::detect::Detection;
use super::frame::Frame;
use super::noise::estimate_noise_sigma;

/// Parameters of one `locate` call; names and defaults are trackpy's.
#[derive(Debug, Clone, PartialEq)]
pub struct LocateParams {
    /// Feature extent in pixels, an odd integer larger than the particle
    /// (trackpy's `diameter`): sets the refinement disc and the defaults below.
    pub diameter_px: u32,
    /// Minimum integrated band-passed brightness, in frame counts (trackpy's
    /// `minmass`); 0 keeps every feature with any mass.
    pub minmass: f64,
    /// Minimum centre-to-centre distance in pixels; `None` = `diameter + 1`.
    pub separation_px: Option<f64>,
    /// Sigma of the Gaussian noise blur in pixels (default 1); 0 = no blur.
    pub noise_size_px: f64,
    /// Side of the boxcar background in pixels; `None` = `diameter`.
    pub smoothing_size_px: Option<u32>,
    /// Band-pass values below this (counts) become 0; `None` = 1 count.
    pub threshold: Option<f64>,
    /// Features are darker than the background (dark spots in bright field).
    pub invert: bool,
    /// A peak must be brighter than this percentile of the non-zero
    /// band-passed pixels (default 64); rejects spurious dim peaks.
    pub percentile: f64,
    /// Most disc moves while refining one feature (default 10).
    pub max_iterations: u32,
}

impl LocateParams {
    /// trackpy's defaults for a given `diameter` (odd, px).
    pub fn new(diameter_px: u32) -> Self {
        Self {
            diameter_px,
            minmass: 0.0,
            separation_px: None,
            noise_size_px: 1.0,
            smoothing_size_px: None,
            threshold: None,
            invert: false,
            percentile: 64.0,
            max_iterations: 10,
        }
    }

    /// The separation in force (`diameter + 1` unless set).
    pub fn separation(&self) -> f64 {
        self.separation_px
            .unwrap_or(f64::from(self.diameter_px) + 1.0)
    }

    /// The boxcar side in force (`diameter` unless set).
    pub fn smoothing_size(&self) -> u32 {
        self.smoothing_size_px.unwrap_or(self.diameter_px)
    }

    /// Radius of the refinement disc: `diameter / 2`, rounded down.
    pub fn radius_px(&self) -> usize {
        (self.diameter_px / 2) as usize
    }

    /// No feature is reported closer than this to an edge: the disc must fit,
    /// the separation must be explorable, and the boxcar must be valid.
    pub fn margin_px(&self) -> usize {
        let from_separation = ((self.separation() / 2.0).floor() - 1.0).max(0.0) as usize;
        self.radius_px()
            .max(from_separation)
            .max((self.smoothing_size() / 2) as usize)
    }

    fn validate(&self) -> Result<(), LocateError> {
        if self.diameter_px < 3 || self.diameter_px % 2 == 0 {
            return Err(LocateError::Diameter(self.diameter_px));
        }
        if !(self.minmass.is_finite() && self.minmass >= 0.0) {
            return Err(LocateError::Minmass(self.minmass));
        }
        let sep = self.separation();
        if !(sep.is_finite() && sep >= 1.0) {
            return Err(LocateError::Separation(sep));
        }
        let smoothing = self.smoothing_size();
        if !(self.noise_size_px.is_finite()
            && self.noise_size_px >= 0.0
            && self.noise_size_px < f64::from(smoothing))
        {
            return Err(LocateError::BandPass {
                noise_size_px: self.noise_size_px,
                smoothing_size_px: smoothing,
            });
        }
        if let Some(t) = self.threshold
            && !t.is_finite()
        {
            return Err(LocateError::Threshold(t));
        }
        if !(0.0..=100.0).contains(&self.percentile) {
            return Err(LocateError::Percentile(self.percentile));
        }
        Ok(())
    }
}

/// Ways `locate` refuses its parameters.
#[derive(Debug, Error, PartialEq)]
pub enum LocateError {
    /// `diameter` must be an odd integer >= 3.
    #[error("diameter {0} px must be an odd integer >= 3 (when in doubt, round up)")]
    Diameter(u32),
    /// `minmass` must be finite and >= 0.
    #[error("minmass {0} must be finite and >= 0")]
    Minmass(f64),
    /// `separation` must be finite and >= 1 px: below a pixel, the peaks of
    /// one particle are not merged and it is found many times over.
    #[error("separation {0} px must be finite and at least 1 px")]
    Separation(f64),
    /// The noise blur must be finite, >= 0 and smaller than the boxcar.
    #[error(
        "noise size {noise_size_px} px must be finite, >= 0 and smaller than the smoothing size {smoothing_size_px} px"
    )]
    BandPass {
        noise_size_px: f64,
        smoothing_size_px: u32,
    },
    /// The band-pass clip level must be finite.
    #[error("band-pass threshold {0} must be finite")]
    Threshold(f64),
    /// The peak percentile must lie in [0, 100].
    #[error("percentile {0} must lie in [0, 100]")]
    Percentile(f64),
}

/// One located feature, in pixels (centres at integer coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feature {
    /// Centroid x in pixels.
    pub x_px: f64,
    /// Centroid y in pixels.
    pub y_px: f64,
    /// Integrated band-passed brightness in the disc, frame counts (trackpy's `mass`).
    pub mass: f64,
    /// Radius of gyration of the band-passed brightness about the disc centre, px.
    pub size_px: f64,
    /// Brightest band-passed pixel in the disc, frame counts.
    pub signal: f64,
    /// Per-axis centroid uncertainty from the frame's measured noise, px
    /// (white noise through the Gaussian blur; the boxcar's share, the
    /// band-pass clipping and the centroid's bias are ignored, so it runs
    /// about 20 % below the scatter over noise realisations).
    pub sigma_px: f64,
}

/// A feature as the rest of nanopush reports particles: `r_px` is the radius
/// of gyration, `quality` the mass; features sit inside the edge margin, so
/// none is edge-clipped.
impl From<Feature> for Detection {
    fn from(f: Feature) -> Self {
        Detection {
            x_px: f.x_px,
            y_px: f.y_px,
            r_px: f.size_px,
            sigma_px: f.sigma_px,
            quality: f.mass,
            edge_clipped: false,
            fitted: true,
        }
    }
}

/// Locates features in `frame` (see the module doc for the steps). An empty
/// frame, a flat frame or one too small for the margin gives no features.
pub fn locate(frame: &Frame, params: &LocateParams) -> Result<Vec<Feature>, LocateError> {
    params.validate()?;
    let (w, h) = (frame.width(), frame.height());
    let margin = params.margin_px();
    if w <= 2 * margin || h <= 2 * margin {
        return Ok(Vec::new());
    }
    let max_count = f64::from(frame.max_count());
    let image: Vec<f64> = if params.invert {
        frame
            .pixels()
            .iter()
            .map(|&v| max_count - f64::from(v))
            .collect()
    } else {
        frame.pixels().iter().map(|&v| f64::from(v)).collect()
    };
    let kernel = gaussian_kernel(params.noise_size_px);
    let mut band = gaussian_blur(&image, w, h, &kernel);
    let background = floored_boxcar(&image, w, h, params.smoothing_size() as usize);
    let threshold = params.threshold.unwrap_or(1.0);
    let mut peak = 0.0f64;
    for (b, bg) in band.iter_mut().zip(&background) {
        let v = *b - bg;
        *b = if v >= threshold { v } else { 0.0 };
        peak = peak.max(*b);
    }
    if peak <= 0.0 {
        return Ok(Vec::new());
    }
    // The integer image the search runs on: full range of the bit depth.
    let scale = max_count / peak;
    let levels: Vec<u32> = band.iter().map(|&v| (v * scale) as u32).collect();

    let peaks = local_maxima(&levels, w, h, params, margin);
    let radius = params.radius_px();
    let disc = Disc::new(radius);
    let noise_bp = estimate_noise_sigma(frame) * kernel.iter().map(|k| k * k).sum::<f64>();
    let mut features: Vec<Feature> = peaks
        .into_iter()
        .map(|(x, y)| {
            let r = refine(&levels, w, h, &disc, x, y, params.max_iterations);
            Feature {
                x_px: r.x,
                y_px: r.y,
                mass: r.mass / scale,
                size_px: r.size,
                signal: r.signal / scale,
                sigma_px: noise_bp * r.spread(&disc) / (r.mass / scale).max(f64::MIN_POSITIVE),
            }
        })
        .collect();
    drop_close(&mut features, params.separation());
    features.retain(|f| f.mass > params.minmass);
    Ok(features)
}

/// Normalised Gaussian weights for offsets -r..=r, r = round(4 sigma); `[1]` for sigma 0.
fn gaussian_kernel(sigma: f64) -> Vec<f64> {
    if sigma <= 0.0 {
        return vec![1.0];
    }
    let r = (4.0 * sigma + 0.5) as i64;
    let a = -0.5 / (sigma * sigma);
    let mut k: Vec<f64> = (-r..=r).map(|x| (a * (x * x) as f64).exp()).collect();
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    k
}

/// Separable correlation with a symmetric kernel, zero outside the frame;
/// rows (y) first, then columns (x).
fn gaussian_blur(image: &[f64], w: usize, h: usize, kernel: &[f64]) -> Vec<f64> {
    let r = kernel.len() / 2;
    // Vertical pass: whole rows at a time (vectorises).
    let mut vertical = vec![0.0; w * h];
    for y in 0..h {
        let out = &mut vertical[y * w..(y + 1) * w];
        out.iter_mut()
            .zip(&image[y * w..(y + 1) * w])
            .for_each(|(o, &v)| *o = v * kernel[r]);
        for j in 1..=r {
            let wj = kernel[r + j];
            let above = y.checked_sub(j).map(|yy| &image[yy * w..(yy + 1) * w]);
            let below = (y + j < h).then(|| &image[(y + j) * w..(y + j + 1) * w]);
            match (above, below) {
                (Some(a), Some(b)) => out
                    .iter_mut()
                    .zip(a.iter().zip(b))
                    .for_each(|(o, (&p, &q))| *o += (p + q) * wj),
                (Some(a), None) | (None, Some(a)) => {
                    out.iter_mut().zip(a).for_each(|(o, &p)| *o += p * wj)
                }
                (None, None) => {}
            }
        }
    }
    // Horizontal pass through a zero-padded row, one tap pair at a time over
    // the whole row (vectorises; each pixel sums in the same order as above).
    let mut padded = vec![0.0; w + 2 * r];
    for y in 0..h {
        padded[r..r + w].copy_from_slice(&vertical[y * w..(y + 1) * w]);
        let row = &mut vertical[y * w..(y + 1) * w];
        row.iter_mut()
            .zip(&padded[r..r + w])
            .for_each(|(o, &v)| *o = v * kernel[r]);
        for j in 1..=r {
            let wj = kernel[r + j];
            let (left, right) = (&padded[r - j..r - j + w], &padded[r + j..r + j + w]);
            row.iter_mut()
                .zip(left.iter().zip(right))
                .for_each(|(o, (&p, &q))| *o += (p + q) * wj);
        }
    }
    vertical
}

/// Largest whole number <= `v` (`f64::floor` without a libm call on the
/// x86_64 baseline, which has no rounding instruction).
#[inline]
fn floor_fast(v: f64) -> f64 {
    if v.abs() < 4.5e15 {
        let t = v as i64 as f64;
        if t > v { t - 1.0 } else { t }
    } else {
        v.floor()
    }
}

/// Boxcar mean of side `size` with edge pixels repeated; the vertical pass,
/// then the horizontal one, each rounded down to whole counts (an integer
/// image keeps its type). Window offsets -size/2 ..= size - 1 - size/2.
fn floored_boxcar(image: &[f64], w: usize, h: usize, size: usize) -> Vec<f64> {
    let (lo, hi) = (size / 2, size - 1 - size / 2);
    let n = size as f64;
    let mut vertical = vec![0.0; w * h];
    let mut sums = vec![0.0; w];
    let row = |y: isize| {
        let yy = y.clamp(0, h as isize - 1) as usize;
        &image[yy * w..(yy + 1) * w]
    };
    for dy in -(lo as isize)..=hi as isize {
        sums.iter_mut().zip(row(dy)).for_each(|(s, &v)| *s += v);
    }
    for y in 0..h {
        vertical[y * w..(y + 1) * w]
            .iter_mut()
            .zip(&sums)
            .for_each(|(o, &s)| *o = floor_fast(s / n));
        let (leaving, entering) = (
            row(y as isize - lo as isize),
            row(y as isize + hi as isize + 1),
        );
        sums.iter_mut()
            .zip(leaving.iter().zip(entering))
            .for_each(|(s, (&a, &b))| *s += b - a);
    }
    // Horizontal pass in place, from a copy of the row with its edge pixels
    // repeated lo to the left and hi + 1 to the right.
    let mut padded = vec![0.0; w + size + 1];
    for y in 0..h {
        let row = &mut vertical[y * w..(y + 1) * w];
        padded[lo..lo + w].copy_from_slice(row);
        let (first, last) = (row[0], row[w - 1]);
        padded[..lo].fill(first);
        padded[lo + w..].fill(last);
        let mut s: f64 = padded[..size].iter().sum();
        for (x, o) in row.iter_mut().enumerate() {
            *o = floor_fast(s / n);
            s += padded[x + size] - padded[x];
        }
    }
    vertical
}

/// Pixels equal to the maximum of their dilation window, brighter than the
/// percentile of the non-zero levels, outside the margin; raster order.
fn local_maxima(
    levels: &[u32],
    w: usize,
    h: usize,
    params: &LocateParams,
    margin: usize,
) -> Vec<(usize, usize)> {
    let mut nonzero: Vec<u32> = levels.iter().copied().filter(|&v| v > 0).collect();
    let Some(threshold) = percentile(&mut nonzero, params.percentile) else {
        return Vec::new();
    };
    // Largest square inside the circle of radius `separation`.
    let side = ((2.0 * params.separation() / std::f64::consts::SQRT_2) as usize).max(1);
    let dilated = dilate(levels, w, h, side);
    let mut peaks = Vec::new();
    for y in margin..h - margin {
        for x in margin..w - margin {
            let v = levels[y * w + x];
            if f64::from(v) > threshold && v == dilated[y * w + x] {
                peaks.push((x, y));
            }
        }
    }
    peaks
}

/// The `p`-th percentile with linear interpolation between order statistics
/// (rank p/100 (n-1)); `None` when there are no values.
fn percentile(values: &mut [u32], p: f64) -> Option<f64> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let rank = p / 100.0 * (n - 1) as f64;
    let lo = (rank.floor() as usize).min(n - 1);
    let (_, &mut a, rest) = values.select_nth_unstable(lo);
    let frac = rank - lo as f64;
    if frac == 0.0 || rest.is_empty() {
        return Some(f64::from(a));
    }
    let b = *rest.iter().min().unwrap_or(&a);
    Some(f64::from(a) + (f64::from(b) - f64::from(a)) * frac)
}

/// Grey dilation (maximum filter) over a `side` x `side` square, zero outside
/// the frame; window offsets -(side-1)/2 ..= side - 1 - (side-1)/2 (an even
/// side reaches one pixel further right/down, as a reflected structuring
/// element does). Each axis by window doubling: maxima over 1, 2, 4, ..
/// pixels, then two overlapping power-of-two windows cover `side`; about
/// log2(side) + 1 whole-row passes per axis instead of `side`.
fn dilate(levels: &[u32], w: usize, h: usize, side: usize) -> Vec<u32> {
    let lo = (side - 1) / 2;
    let span = largest_power_of_two_at_most(side);
    // Horizontal: each row zero-padded by lo on the left and side - 1 - lo on
    // the right.
    let mut horizontal = vec![0u32; w * h];
    let mut padded = vec![0u32; w + side - 1];
    let mut doubled = vec![0u32; w + side - 1];
    for y in 0..h {
        padded.fill(0);
        padded[lo..lo + w].copy_from_slice(&levels[y * w..(y + 1) * w]);
        let mut len = 1;
        while len < span {
            let n = padded.len() - len;
            doubled[..n]
                .iter_mut()
                .zip(padded[..n].iter().zip(&padded[len..]))
                .for_each(|(o, (&p, &q))| *o = p.max(q));
            std::mem::swap(&mut padded, &mut doubled);
            len *= 2;
        }
        let out = &mut horizontal[y * w..(y + 1) * w];
        let (a, b) = (&padded[..w], &padded[side - span..side - span + w]);
        out.iter_mut()
            .zip(a.iter().zip(b))
            .for_each(|(o, (&p, &q))| *o = p.max(q));
    }
    // Vertical: the same on whole rows, zero rows padding top and bottom.
    let rows = h + side - 1;
    let mut stack = vec![0u32; rows * w];
    stack[lo * w..(lo + h) * w].copy_from_slice(&horizontal);
    let mut len = 1;
    while len < span {
        for r in 0..rows - len {
            let (top, rest) = stack[r * w..].split_at_mut(len * w);
            top[..w]
                .iter_mut()
                .zip(&rest[..w])
                .for_each(|(o, &s)| *o = (*o).max(s));
        }
        len *= 2;
    }
    let mut out = horizontal;
    for y in 0..h {
        let a = &stack[y * w..(y + 1) * w];
        let b = &stack[(y + side - span) * w..(y + side - span + 1) * w];
        out[y * w..(y + 1) * w]
            .iter_mut()
            .zip(a.iter().zip(b))
            .for_each(|(o, (&p, &q))| *o = p.max(q));
    }
    out
}

/// Largest power of two <= `n` (n >= 1).
fn largest_power_of_two_at_most(n: usize) -> usize {
    1 << (usize::BITS - 1 - n.leading_zeros())
}

/// The refinement disc: offsets (dx, dy) with dx^2 + dy^2 <= r^2.
struct Disc {
    radius: usize,
    offsets: Vec<(isize, isize)>,
}

impl Disc {
    fn new(radius: usize) -> Self {
        let r = radius as isize;
        let offsets = (-r..=r)
            .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
            .filter(|&(dx, dy)| dx * dx + dy * dy <= r * r)
            .collect();
        Self { radius, offsets }
    }
}

/// A refined feature in the rescaled levels.
struct Refined {
    /// Centroid offset from the disc centre, px.
    off_x: f64,
    off_y: f64,
    x: f64,
    y: f64,
    mass: f64,
    size: f64,
    signal: f64,
}

impl Refined {
    /// sqrt(sum over the disc of (x_i - x_centroid)^2), px: turns pixel noise
    /// into centroid noise.
    fn spread(&self, disc: &Disc) -> f64 {
        disc.offsets
            .iter()
            .map(|&(dx, _)| (dx as f64 - self.off_x).powi(2))
            .sum::<f64>()
            .sqrt()
    }
}

/// Centroid in the disc, moving the disc by one pixel per axis while the
/// centroid is more than 0.6 px off its centre; the last centroid computed
/// is the position (the disc stays inside the frame).
fn refine(
    levels: &[u32],
    w: usize,
    h: usize,
    disc: &Disc,
    x0: usize,
    y0: usize,
    max_iterations: u32,
) -> Refined {
    const SHIFT_PX: f64 = 0.6;
    let r = disc.radius;
    let (mut cx, mut cy) = (x0, y0);
    let mut computed = 0;
    loop {
        let result = centroid(levels, w, disc, cx, cy);
        computed += 1;
        let (ox, oy) = (result.off_x, result.off_y);
        if (ox.abs() < SHIFT_PX && oy.abs() < SHIFT_PX) || computed >= max_iterations.max(1) {
            return result;
        }
        let step = |c: usize, off: f64, n: usize| {
            let moved = if off > SHIFT_PX {
                c + 1
            } else if off < -SHIFT_PX {
                c.saturating_sub(1)
            } else {
                c
            };
            moved.clamp(r, n - 1 - r)
        };
        cx = step(cx, ox, w);
        cy = step(cy, oy, h);
    }
}

/// Centroid, mass, radius of gyration and peak of the levels in the disc at (cx, cy).
fn centroid(levels: &[u32], w: usize, disc: &Disc, cx: usize, cy: usize) -> Refined {
    // Moments in disc-corner coordinates (0..=2r): the sums are exact
    // integers, and the offset from the disc centre is (sum / mass) - r, the
    // order of rounding that decides a 0.6 px tie the way trackpy does.
    let r = disc.radius as isize;
    let (mut m, mut sx, mut sy, mut sr2, mut peak) = (0.0, 0.0, 0.0, 0.0, 0u32);
    for &(dx, dy) in &disc.offsets {
        let v = levels[(cy as isize + dy) as usize * w + (cx as isize + dx) as usize];
        let f = f64::from(v);
        m += f;
        sx += f * (dx + r) as f64;
        sy += f * (dy + r) as f64;
        sr2 += f * (dx * dx + dy * dy) as f64;
        peak = peak.max(v);
    }
    let (off_x, off_y, size) = if m > 0.0 {
        (sx / m - r as f64, sy / m - r as f64, (sr2 / m).sqrt())
    } else {
        (0.0, 0.0, 0.0)
    };
    Refined {
        off_x,
        off_y,
        x: off_x + cx as f64,
        y: off_y + cy as f64,
        mass: m,
        size,
        signal: f64::from(peak),
    }
}

/// Drops every feature that has a neighbour closer than `separation` with
/// more mass (with equal mass, the one nearer the top-left corner goes).
/// Pairs are judged all at once, as a set of close pairs.
fn drop_close(features: &mut Vec<Feature>, separation: f64) {
    if separation <= 0.0 || features.len() < 2 {
        return;
    }
    // Closer than separation, with trackpy's relative tolerance on the edge.
    let limit = separation * (1.0 - 1e-7);
    let mut order: Vec<usize> = (0..features.len()).collect();
    order.sort_by(|&a, &b| features[a].x_px.total_cmp(&features[b].x_px));
    let mut dropped = vec![false; features.len()];
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            let (a, b) = (&features[i], &features[j]);
            if b.x_px - a.x_px > limit {
                break;
            }
            if (b.x_px - a.x_px).hypot(b.y_px - a.y_px) > limit {
                continue;
            }
            let loser = if a.mass != b.mass {
                if a.mass < b.mass { i } else { j }
            } else if a.x_px + a.y_px > b.x_px + b.y_px {
                j
            } else {
                i
            };
            dropped[loser] = true;
        }
    }
    let mut k = 0;
    features.retain(|_| {
        k += 1;
        !dropped[k - 1]
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gaussian spots of peak `amp` and sigma `s` on a background `bg`, integer counts.
    fn spots(w: usize, h: usize, bg: f64, centres: &[(f64, f64, f64)], s: f64) -> Frame {
        let mut px = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let v: f64 = centres
                    .iter()
                    .map(|&(cx, cy, amp)| {
                        amp * (-((x as f64 - cx).powi(2) + (y as f64 - cy).powi(2)) / (2.0 * s * s))
                            .exp()
                    })
                    .sum();
                px[y * w + x] = (bg + v).round() as f32;
            }
        }
        Frame::new(w, h, px, 8).unwrap()
    }

    #[test]
    fn floored_boxcar_matches_brute_force() {
        let (w, h) = (13, 9);
        let image: Vec<f64> = (0..w * h).map(|i| ((i * 37) % 23) as f64).collect();
        for size in [1usize, 3, 4, 5, 11, 20] {
            let got = floored_boxcar(&image, w, h, size);
            let (lo, hi) = (size as isize / 2, size as isize - 1 - size as isize / 2);
            let at = |x: isize, y: isize| {
                image[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
            };
            for y in 0..h as isize {
                for x in 0..w as isize {
                    let col = |xx: isize| {
                        ((-lo..=hi).map(|d| at(xx, y + d)).sum::<f64>() / size as f64).floor()
                    };
                    let want = ((-lo..=hi).map(|d| col(x + d)).sum::<f64>() / size as f64).floor();
                    assert_eq!(
                        got[y as usize * w + x as usize],
                        want,
                        "size {size} at {x},{y}"
                    );
                }
            }
        }
    }

    #[test]
    fn dilation_window_matches_brute_force_for_odd_and_even_sides() {
        let (w, h) = (17, 12);
        let levels: Vec<u32> = (0..w * h).map(|i| ((i * 7919) % 101) as u32).collect();
        for side in [1usize, 2, 5, 14, 16, 30] {
            let got = dilate(&levels, w, h, side);
            let lo = (side as isize - 1) / 2;
            let hi = side as isize - 1 - lo;
            for y in 0..h as isize {
                for x in 0..w as isize {
                    let mut m = 0;
                    for yy in (y - lo).max(0)..=(y + hi).min(h as isize - 1) {
                        for xx in (x - lo).max(0)..=(x + hi).min(w as isize - 1) {
                            m = m.max(levels[yy as usize * w + xx as usize]);
                        }
                    }
                    assert_eq!(
                        got[y as usize * w + x as usize],
                        m,
                        "side {side} at {x},{y}"
                    );
                }
            }
        }
    }

    #[test]
    fn floor_fast_agrees_with_floor() {
        for v in [
            0.0,
            -0.0,
            2.0,
            2.5,
            -2.5,
            -3.0,
            1e-300,
            -1e-300,
            4.4e15,
            -4.4e15,
            1e17,
            33.0 / 11.0,
        ] {
            assert_eq!(floor_fast(v), v.floor(), "{v}");
        }
    }

    #[test]
    fn percentile_interpolates_between_order_statistics() {
        let mut v = vec![4, 1, 3, 2];
        assert_eq!(percentile(&mut v, 50.0), Some(2.5));
        assert_eq!(percentile(&mut v, 100.0), Some(4.0));
        assert_eq!(percentile(&mut v, 0.0), Some(1.0));
        assert_eq!(percentile(&mut [], 64.0), None);
    }

    #[test]
    fn locates_isolated_spots_to_a_tenth_of_a_pixel() {
        let truth = [
            (20.3, 25.7, 120.0),
            (50.6, 30.2, 90.0),
            (35.0, 55.45, 150.0),
        ];
        let frame = spots(80, 80, 20.0, &truth, 1.6);
        let found = locate(&frame, &LocateParams::new(9)).unwrap();
        assert_eq!(found.len(), 3, "{found:?}");
        for &(tx, ty, _) in &truth {
            let f = found
                .iter()
                .min_by(|a, b| {
                    let da = (a.x_px - tx).hypot(a.y_px - ty);
                    let db = (b.x_px - tx).hypot(b.y_px - ty);
                    da.total_cmp(&db)
                })
                .unwrap();
            let err = (f.x_px - tx).hypot(f.y_px - ty);
            assert!(
                err < 0.1,
                "({tx}, {ty}): found ({}, {}), error {err}",
                f.x_px,
                f.y_px
            );
            assert!(f.sigma_px > 0.0 && f.sigma_px < 0.5, "sigma {}", f.sigma_px);
        }
    }

    /// `sigma_px` is the right scale for the centroid's scatter over noise
    /// realisations: within 1.5x either way (measured: scatter / sigma = 1.27
    /// at noise 2 counts, 1.19 at 5; the estimate leaves out the boxcar's
    /// noise and the clipping of the band-pass).
    #[test]
    fn reported_sigma_matches_the_scatter_over_noise_realisations() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let (w, h, cx, cy) = (48usize, 48usize, 24.3, 23.8);
        for noise in [2.0, 5.0] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
            let normal = Normal::new(0.0, noise).unwrap();
            let (mut xs, mut sigmas) = (Vec::new(), Vec::new());
            for _ in 0..300 {
                let mut px = vec![0f32; w * h];
                for y in 0..h {
                    for x in 0..w {
                        let r2 = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2);
                        let v = 100.0 + 80.0 * (-r2 / (2.0 * 1.8 * 1.8)).exp();
                        px[y * w + x] = (v + normal.sample(&mut rng)).round() as f32;
                    }
                }
                let frame = Frame::new(w, h, px, 16).unwrap();
                let params = LocateParams {
                    minmass: 100.0,
                    ..LocateParams::new(11)
                };
                let found = locate(&frame, &params).unwrap();
                let near: Vec<_> = found
                    .iter()
                    .filter(|f| (f.x_px - cx).hypot(f.y_px - cy) < 2.0)
                    .collect();
                assert_eq!(near.len(), 1, "noise {noise}: {found:?}");
                xs.push(near[0].x_px);
                sigmas.push(near[0].sigma_px);
            }
            let n = xs.len() as f64;
            let mean = xs.iter().sum::<f64>() / n;
            let scatter = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            let sigma = sigmas.iter().sum::<f64>() / n;
            let ratio = scatter / sigma;
            assert!(
                (1.0 / 1.5..=1.5).contains(&ratio),
                "noise {noise}: scatter {scatter}, mean sigma {sigma}"
            );
        }
    }

    #[test]
    fn inverts_dark_spots_and_applies_minmass() {
        let truth = [(20.0, 20.0, -100.0), (45.0, 40.0, -40.0)];
        let frame = spots(64, 64, 200.0, &truth, 1.5);
        let bright = locate(&frame, &LocateParams::new(9)).unwrap();
        assert!(
            bright
                .iter()
                .all(|f| (f.x_px - 20.0).hypot(f.y_px - 20.0) > 3.0),
            "dark spot found without invert: {bright:?}"
        );
        let mut params = LocateParams {
            invert: true,
            ..LocateParams::new(9)
        };
        let all = locate(&frame, &params).unwrap();
        assert_eq!(all.len(), 2, "{all:?}");
        let (strong, weak) = if all[0].mass > all[1].mass {
            (all[0], all[1])
        } else {
            (all[1], all[0])
        };
        assert!((strong.x_px - 20.0).abs() < 0.2 && (weak.x_px - 45.0).abs() < 0.2);
        params.minmass = 0.5 * (strong.mass + weak.mass);
        let kept = locate(&frame, &params).unwrap();
        assert_eq!(kept.len(), 1);
        assert_eq!(kept[0], strong);
    }

    #[test]
    fn of_two_spots_closer_than_separation_the_heavier_stays() {
        let frame = spots(
            64,
            64,
            10.0,
            &[(28.0, 30.0, 150.0), (35.0, 30.0, 80.0)],
            1.2,
        );
        let close = locate(&frame, &LocateParams::new(9)).unwrap();
        assert_eq!(close.len(), 1, "{close:?}");
        assert!((close[0].x_px - 28.0).abs() < 0.6, "{close:?}");
        let apart = locate(
            &frame,
            &LocateParams {
                separation_px: Some(5.0),
                ..LocateParams::new(9)
            },
        )
        .unwrap();
        assert_eq!(apart.len(), 2, "{apart:?}");
    }

    #[test]
    fn flat_tiny_and_edge_frames_give_nothing() {
        let flat = Frame::new(40, 40, vec![77.0; 1600], 8).unwrap();
        assert!(locate(&flat, &LocateParams::new(9)).unwrap().is_empty());
        let tiny = Frame::new(6, 6, vec![1.0; 36], 8).unwrap();
        assert!(locate(&tiny, &LocateParams::new(9)).unwrap().is_empty());
        let edge = spots(40, 40, 10.0, &[(1.0, 20.0, 200.0)], 1.5);
        assert!(locate(&edge, &LocateParams::new(9)).unwrap().is_empty());
    }

    #[test]
    fn bad_parameters_are_typed_errors() {
        let f = Frame::new(40, 40, vec![0.0; 1600], 8).unwrap();
        let bad = |p: LocateParams| locate(&f, &p).unwrap_err();
        assert_eq!(bad(LocateParams::new(8)), LocateError::Diameter(8));
        assert_eq!(bad(LocateParams::new(1)), LocateError::Diameter(1));
        assert!(matches!(
            bad(LocateParams {
                minmass: f64::NAN,
                ..LocateParams::new(9)
            }),
            LocateError::Minmass(_)
        ));
        assert!(matches!(
            bad(LocateParams {
                separation_px: Some(-1.0),
                ..LocateParams::new(9)
            }),
            LocateError::Separation(_)
        ));
        assert!(matches!(
            bad(LocateParams {
                separation_px: Some(0.0),
                ..LocateParams::new(9)
            }),
            LocateError::Separation(_)
        ));
        assert!(matches!(
            bad(LocateParams {
                noise_size_px: 9.0,
                ..LocateParams::new(9)
            }),
            LocateError::BandPass { .. }
        ));
        assert!(matches!(
            bad(LocateParams {
                percentile: 101.0,
                ..LocateParams::new(9)
            }),
            LocateError::Percentile(_)
        ));
        assert!(matches!(
            bad(LocateParams {
                threshold: Some(f64::INFINITY),
                ..LocateParams::new(9)
            }),
            LocateError::Threshold(_)
        ));
    }
}
