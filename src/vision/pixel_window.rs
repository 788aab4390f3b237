//! A particle's fit window as structure-of-arrays f32 pixels, and the normal
//! equations of the profile models over it, evaluated a whole window at a time.
//!
//! Why: the profile fit is the hot loop of detection (about 100 fits of ~800
//! pixels per frame, a few evaluations each). Evaluated pixel by pixel in f64
//! with libm `exp` and 8x8 rank-one updates it cost ~39 ns per pixel; here each
//! stage is a branch-free loop over plain slices (model and Jacobian columns,
//! then one dot product per normal-matrix entry) that the compiler vectorises.
//! Coordinates are relative to the window's centre pixel, so f32 keeps them
//! exact; dot products run in 8 f32 lanes and are summed in f64, the rss in f64.

use nalgebra::{SMatrix, SVector};

use super::cpu_dispatch::avx2_dispatch;
use super::fast_exp::exp_f32;
use super::frame::Frame;
use super::least_squares::{Evaluation, NormalEquations};

/// The pixels of a square window, coordinates relative to `origin`.
/// Saturated pixels are kept as censored samples: their true value is
/// unknown but at least the camera's full count, so a model brighter there
/// fits them exactly and only a dimmer one is penalised (leaving them out
/// threw away where the core is: on a frame whose particle cores clip, one
/// centre came out 1.2 px off).
#[derive(Debug, Clone)]
pub struct PixelWindow {
    origin: (f64, f64),
    x: Vec<f32>,
    y: Vec<f32>,
    v: Vec<f32>,
    /// The frame's full count: a pixel holding it is saturated (censored).
    full_count: f32,
}

impl PixelWindow {
    /// The pixels of the square window of half-size `half` around (cx, cy),
    /// cut at the frame's edges; saturated ones at the full count, censored.
    pub fn square(frame: &Frame, cx: f64, cy: f64, half: f64) -> Self {
        let (w, h) = (frame.width() as f64, frame.height() as f64);
        let x0 = (cx - half).floor().max(0.0) as usize;
        let x1 = (cx + half).ceil().min(w - 1.0).max(0.0) as usize;
        let y0 = (cy - half).floor().max(0.0) as usize;
        let y1 = (cy + half).ceil().min(h - 1.0).max(0.0) as usize;
        let origin = (cx.round(), cy.round());
        let sat = frame.max_count();
        let n = (x1 + 1).saturating_sub(x0) * (y1 + 1).saturating_sub(y0);
        let mut out = Self {
            origin,
            x: Vec::with_capacity(n),
            y: Vec::with_capacity(n),
            v: Vec::with_capacity(n),
            full_count: sat,
        };
        if n == 0 {
            return out;
        }
        let (w, pixels) = (frame.width(), frame.pixels());
        for y in y0..=y1 {
            let row = &pixels[y * w + x0..=y * w + x1];
            let dy = (y as f64 - origin.1) as f32;
            let dx0 = (x0 as f64 - origin.0) as f32;
            out.x.extend((0..row.len()).map(|k| dx0 + k as f32));
            out.y.extend(std::iter::repeat_n(dy, row.len()));
            if row.iter().all(|&v| v < sat) {
                // No saturated pixel (almost every row): a whole-row copy.
                out.v.extend_from_slice(row);
            } else {
                out.v.extend(row.iter().map(|&v| v.min(sat)));
            }
        }
        out
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.v.len()
    }

    /// True when no pixel is left.
    pub fn is_empty(&self) -> bool {
        self.v.is_empty()
    }

    /// Keeps the pixels whose absolute position satisfies `keep(x, y)`.
    pub fn retain(&mut self, keep: impl Fn(f64, f64) -> bool) {
        let mut j = 0;
        for i in 0..self.v.len() {
            let (x, y) = self.absolute(i);
            if keep(x, y) {
                self.x[j] = self.x[i];
                self.y[j] = self.y[i];
                self.v[j] = self.v[i];
                j += 1;
            }
        }
        self.x.truncate(j);
        self.y.truncate(j);
        self.v.truncate(j);
    }

    /// Indices of the saturated (censored) pixels, ascending: those at the
    /// full count.
    pub fn censored(&self) -> Vec<u32> {
        let at = self
            .v
            .iter()
            .enumerate()
            .filter(|(_, v)| **v >= self.full_count);
        at.map(|(i, _)| i as u32).collect()
    }

    fn absolute(&self, i: usize) -> (f64, f64) {
        (
            self.origin.0 + self.x[i] as f64,
            self.origin.1 + self.y[i] as f64,
        )
    }

    /// Pixels as (x, y, value), absolute coordinates.
    pub fn pixels(&self) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        (0..self.len()).map(|i| {
            let (x, y) = self.absolute(i);
            (x, y, self.v[i] as f64)
        })
    }
}

/// Residuals and Jacobian columns of one evaluation (reused between evaluations).
#[derive(Debug, Clone)]
struct Columns<const N: usize> {
    residual: Vec<f32>,
    jacobian: [Vec<f32>; N],
    /// r^T r of the evaluation, in f64.
    rss: f64,
    /// Pixels that carry information (all but the censored ones reached).
    observations: usize,
}

impl<const N: usize> Columns<N> {
    /// Room for a window of `n` pixels.
    fn new(n: usize) -> Self {
        Self {
            residual: vec![0.0; n],
            jacobian: std::array::from_fn(|_| vec![0.0; n]),
            rss: 0.0,
            observations: n,
        }
    }

    /// A saturated pixel the model reaches (residual full count - model <= 0)
    /// is fitted exactly: no residual and no gradient; one the model falls
    /// short of keeps its residual like any pixel. A few pixels a window,
    /// after the vector loop, which stays as it is.
    fn censor(&mut self, censored: &[u32]) {
        let mut reached = 0;
        for &i in censored {
            let i = i as usize;
            if self.residual[i] <= 0.0 {
                reached += 1;
                self.residual[i] = 0.0;
                for column in &mut self.jacobian {
                    column[i] = 0.0;
                }
            }
        }
        self.observations = self.residual.len() - reached;
        if reached > 0 {
            self.rss = sum_of_squares_f64(&self.residual);
        }
    }

    /// J^T J, J^T r and r^T r (unit weights) of the evaluation the columns hold.
    ///
    /// The entries are the dot products of the pairs (J_i, J_j), j <= i, and
    /// (J_i, r), row by row, taken four pairs per pass over the window: every
    /// pass has the same shape, so it compiles to the same vector loop. (Rows
    /// passed one at a time left passes of one to three dots, which the
    /// compiler vectorised across the dots instead of across pixels: 2-4
    /// lanes, and a third of an evaluation's time.)
    #[inline(always)]
    fn normal_equations(&self) -> NormalEquations<N> {
        const { assert!(N < 16, "up to 15 parameters") };
        // (row, column) of each entry; column N is the residual.
        let mut pairs = [(0usize, 0usize); 16 * 17 / 2];
        let mut n_pairs = 0;
        for i in 0..N {
            for j in (0..=i).chain([N]) {
                pairs[n_pairs] = (i, j);
                n_pairs += 1;
            }
        }
        let column = |k: usize| {
            if k < N {
                self.jacobian[k].as_slice()
            } else {
                self.residual.as_slice()
            }
        };
        let mut jtj = SMatrix::<f64, N, N>::zeros();
        let mut jtr = SVector::<f64, N>::zeros();
        for group in pairs[..n_pairs].chunks(4) {
            // A short last group repeats its last pair (computed, not stored).
            let pair = |k: usize| group[k.min(group.len() - 1)];
            let sums = dots(
                std::array::from_fn(|k| column(pair(k).0)),
                std::array::from_fn(|k| column(pair(k).1)),
            );
            for (&(i, j), sum) in group.iter().zip(sums) {
                if j == N {
                    jtr[i] = sum;
                } else {
                    jtj[(i, j)] = sum;
                    jtj[(j, i)] = sum;
                }
            }
        }
        NormalEquations {
            jtj,
            jtr,
            rss: self.rss,
            observations: self.observations,
        }
    }
}

/// Lanes of the dot products: lane k sums the products of elements k, k + 8,
/// k + 16, ... in f32 (one AVX register, or two SSE ones), then the lanes are
/// summed in f64.
const LANES: usize = 8;

/// The four dot products a[k] . b[k] in one pass: each chunk of each slice
/// is loaded once per pass and the four accumulators are independent, so the
/// adds do not wait on each other (one dot per pass waited on its own
/// accumulator's latency, and was half the time of a ring-model evaluation).
#[inline(always)]
fn dots(a: [&[f32]; 4], b: [&[f32]; 4]) -> [f64; 4] {
    let n = a.iter().chain(&b).fold(usize::MAX, |n, s| n.min(s.len()));
    let whole = n / LANES * LANES;
    let mut acc = [[0.0f32; LANES]; 4];
    for c in (0..whole).step_by(LANES) {
        for ((acc_k, a_k), b_k) in acc.iter_mut().zip(&a).zip(&b) {
            let x: &[f32; LANES] = a_k[c..c + LANES].try_into().expect("chunk of LANES");
            let y: &[f32; LANES] = b_k[c..c + LANES].try_into().expect("chunk of LANES");
            for l in 0..LANES {
                acc_k[l] += x[l] * y[l];
            }
        }
    }
    let mut out = [0.0f64; 4];
    for (((o, acc_k), a_k), b_k) in out.iter_mut().zip(&acc).zip(&a).zip(&b) {
        let mut s: f64 = acc_k.iter().map(|&v| v as f64).sum();
        for (x, y) in a_k[whole..n].iter().zip(&b_k[whole..n]) {
            s += (x * y) as f64;
        }
        *o = s;
    }
    out
}

/// Lanes of the f64 sum of squares: independent partial sums, so the adds
/// run as vectors instead of one chain of dependent scalar adds (which cost
/// as much as a quarter of the dot products).
const F64_LANES: usize = 4;

/// sum r^2 in f64 (the rss decides whether a trial step is accepted, so it
/// is not summed in f32 lanes like the normal equations).
#[inline(always)]
fn sum_of_squares_f64(r: &[f32]) -> f64 {
    let chunks = r.chunks_exact(F64_LANES);
    let mut acc = [0.0f64; F64_LANES];
    let tail: f64 = chunks
        .remainder()
        .iter()
        .map(|&v| v as f64 * v as f64)
        .sum();
    for chunk in chunks {
        for (a, &v) in acc.iter_mut().zip(chunk) {
            *a += v as f64 * v as f64;
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// A profile model fitted over a window, evaluated in the two parts
/// [`Evaluation`] asks for: the model's residuals and Jacobian columns with
/// their rss, then, only for a point the fit keeps, the dot products of the
/// normal equations (most of an evaluation's time; about a quarter of the
/// trial points are rejected).
pub struct WindowModel<'a, const N: usize> {
    win: &'a PixelWindow,
    /// The window's saturated pixels, found once for the fit.
    censored: Vec<u32>,
    cols: Columns<N>,
    columns: fn(&PixelWindow, &SVector<f64, N>, &mut Columns<N>),
    normal: fn(&Columns<N>) -> NormalEquations<N>,
}

impl<'a> WindowModel<'a, 8> {
    /// The ring model (`profile_fit::ring_model`, parameters x, y, b, A, s,
    /// B, R, w) over the window.
    pub fn ring(win: &'a PixelWindow) -> Self {
        Self::over(win, ring_columns, normal_equations_8)
    }
}

impl<'a> WindowModel<'a, 5> {
    /// The spot model (`profile_fit::spot_model`, parameters x, y, b, A, s)
    /// over the window.
    pub fn spot(win: &'a PixelWindow) -> Self {
        Self::over(win, spot_columns, normal_equations_5)
    }
}

impl<'a, const N: usize> WindowModel<'a, N> {
    fn over(
        win: &'a PixelWindow,
        columns: fn(&PixelWindow, &SVector<f64, N>, &mut Columns<N>),
        normal: fn(&Columns<N>) -> NormalEquations<N>,
    ) -> Self {
        Self {
            win,
            censored: win.censored(),
            cols: Columns::new(win.len()),
            columns,
            normal,
        }
    }
}

impl<const N: usize> Evaluation<N> for WindowModel<'_, N> {
    fn rss(&mut self, p: &SVector<f64, N>) -> f64 {
        (self.columns)(self.win, p, &mut self.cols);
        self.cols.censor(&self.censored);
        self.cols.rss
    }

    fn normal_equations(&mut self) -> NormalEquations<N> {
        (self.normal)(&self.cols)
    }
}

avx2_dispatch!(
    fn normal_equations_8(cols: &Columns<8>) -> NormalEquations<8> => Columns::<8>::normal_equations
);

avx2_dispatch!(
    fn normal_equations_5(cols: &Columns<5>) -> NormalEquations<5> => Columns::<5>::normal_equations
);

avx2_dispatch!(
    /// Residuals, Jacobian columns and rss of the ring model over the window.
    fn ring_columns(
        win: &PixelWindow,
        p: &SVector<f64, 8>,
        cols: &mut Columns<8>,
    ) => ring_columns_lanes
);

#[inline(always)]
fn ring_columns_lanes(win: &PixelWindow, p: &SVector<f64, 8>, cols: &mut Columns<8>) {
    let n = win.len();
    let (xs, ys, vs) = (&win.x[..n], &win.y[..n], &win.v[..n]);
    let cx = (p[0] - win.origin.0) as f32;
    let cy = (p[1] - win.origin.1) as f32;
    let (b, a, s, bb, rr, w) = (
        p[2] as f32,
        p[3] as f32,
        p[4] as f32,
        p[5] as f32,
        p[6] as f32,
        p[7] as f32,
    );
    let is2 = 1.0 / (s * s);
    let iw2 = 1.0 / (w * w);
    let (inv_s, inv_w) = (1.0 / s, 1.0 / w);
    let res = &mut cols.residual[..n];
    let [j0, j1, j2, j3, j4, j5, j6, j7] = &mut cols.jacobian;
    let (j0, j1, j2, j3) = (&mut j0[..n], &mut j1[..n], &mut j2[..n], &mut j3[..n]);
    let (j4, j5, j6, j7) = (&mut j4[..n], &mut j5[..n], &mut j6[..n], &mut j7[..n]);
    for i in 0..n {
        let dx = xs[i] - cx;
        let dy = ys[i] - cy;
        let r2 = dx * dx + dy * dy;
        let r = r2.sqrt().max(1e-6);
        let e1 = exp_f32(-0.5 * r2 * is2);
        let dr = r - rr;
        let e2 = exp_f32(-0.5 * dr * dr * iw2);
        let core = a * e1;
        let ring = bb * e2;
        let radial = core * is2 - ring * dr * iw2 / r;
        j0[i] = radial * dx;
        j1[i] = radial * dy;
        j2[i] = 1.0;
        j3[i] = e1;
        j4[i] = core * r2 * is2 * inv_s;
        j5[i] = -e2;
        j6[i] = -ring * dr * iw2;
        j7[i] = -ring * dr * dr * iw2 * inv_w;
        res[i] = (vs[i] - b) - (core - ring);
    }
    cols.rss = sum_of_squares_f64(res);
}

avx2_dispatch!(
    /// Residuals, Jacobian columns and rss of the spot model over the window.
    fn spot_columns(
        win: &PixelWindow,
        p: &SVector<f64, 5>,
        cols: &mut Columns<5>,
    ) => spot_columns_lanes
);

#[inline(always)]
fn spot_columns_lanes(win: &PixelWindow, p: &SVector<f64, 5>, cols: &mut Columns<5>) {
    let n = win.len();
    let (xs, ys, vs) = (&win.x[..n], &win.y[..n], &win.v[..n]);
    let cx = (p[0] - win.origin.0) as f32;
    let cy = (p[1] - win.origin.1) as f32;
    let (b, a, s) = (p[2] as f32, p[3] as f32, p[4] as f32);
    let is2 = 1.0 / (s * s);
    let inv_s = 1.0 / s;
    let res = &mut cols.residual[..n];
    let [j0, j1, j2, j3, j4] = &mut cols.jacobian;
    let (j0, j1, j2, j3, j4) = (
        &mut j0[..n],
        &mut j1[..n],
        &mut j2[..n],
        &mut j3[..n],
        &mut j4[..n],
    );
    for i in 0..n {
        let dx = xs[i] - cx;
        let dy = ys[i] - cy;
        let r2 = dx * dx + dy * dy;
        let e = exp_f32(-0.5 * r2 * is2);
        let core = a * e;
        j0[i] = core * is2 * dx;
        j1[i] = core * is2 * dy;
        j2[i] = 1.0;
        j3[i] = e;
        j4[i] = core * r2 * is2 * inv_s;
        res[i] = (vs[i] - b) - core;
    }
    cols.rss = sum_of_squares_f64(res);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::profile_fit::{ring_model, spot_model};

    /// A 31x31 frame with a ring-like texture and one saturated pixel.
    fn frame() -> Frame {
        let (w, h) = (31, 31);
        let mut px: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64 - 15.3, (i / w) as f64 - 14.8);
                let r = x.hypot(y);
                (1000.0 + 400.0 * (-r * r / 8.0).exp() - 300.0 * (-(r - 7.0).powi(2) / 3.0).exp()
                    + ((i * 7919) % 13) as f64) as f32
            })
            .collect();
        px[3 * w + 4] = 65535.0;
        Frame::new(w, h, px, 16).unwrap()
    }

    /// The batch normal equations equal the per-pixel f64 ones to f32
    /// precision, a saturated pixel the model reaches left out.
    fn compare<const N: usize>(
        batch: NormalEquations<N>,
        win: &PixelWindow,
        p: &SVector<f64, N>,
        model: impl Fn(f64, f64, &SVector<f64, N>, &mut SVector<f64, N>) -> f64,
    ) {
        let mut g = SVector::<f64, N>::zeros();
        let mut jtj = SMatrix::<f64, N, N>::zeros();
        let mut jtr = SVector::<f64, N>::zeros();
        let mut rss = 0.0;
        let censored = win.censored();
        for (i, (x, y, v)) in win.pixels().enumerate() {
            let r = v - model(x, y, p, &mut g);
            if censored.contains(&(i as u32)) && r <= 0.0 {
                continue;
            }
            rss += r * r;
            jtr += g * r;
            jtj += g * g.transpose();
        }
        assert!(
            (batch.rss / rss - 1.0).abs() < 1e-4,
            "{} vs {rss}",
            batch.rss
        );
        for i in 0..N {
            let scale = jtj[(i, i)].sqrt() * (rss.sqrt() + 1.0);
            assert!((batch.jtr[i] - jtr[i]).abs() < 1e-4 * scale, "jtr {i}");
            for j in 0..N {
                let scale = (jtj[(i, i)] * jtj[(j, j)]).sqrt();
                assert!(
                    (batch.jtj[(i, j)] - jtj[(i, j)]).abs() < 1e-4 * scale,
                    "jtj {i} {j}: {} vs {}",
                    batch.jtj[(i, j)],
                    jtj[(i, j)]
                );
            }
        }
    }

    #[test]
    fn ring_and_spot_normal_equations_match_the_per_pixel_models() {
        let f = frame();
        let win = PixelWindow::square(&f, 15.0, 15.0, 12.0);
        assert_eq!(win.len(), 25 * 25);
        assert_eq!(win.censored().len(), 1, "the saturated pixel is censored");
        let p = SVector::<f64, 8>::from_column_slice(&[
            15.2, 14.9, 1005.0, 380.0, 2.1, 290.0, 6.8, 1.3,
        ]);
        let mut ring = WindowModel::ring(&win);
        let rss = ring.rss(&p);
        let at_p = ring.normal_equations();
        assert_eq!(rss, at_p.rss);
        compare(at_p, &win, &p, ring_model);
        let q = SVector::<f64, 5>::from_column_slice(&[15.4, 14.7, 990.0, 300.0, 2.4]);
        let mut spot = WindowModel::spot(&win);
        spot.rss(&q);
        compare(spot.normal_equations(), &win, &q, spot_model);
    }

    /// A saturated pixel tells only that the true value is at least the
    /// full count: a model above it there fits it exactly (no residual, no
    /// gradient), a model below it is pulled up like by any pixel.
    #[test]
    fn a_saturated_pixel_counts_only_where_the_model_falls_short_of_it() {
        // A bright core clipped at 255 counts (8-bit) on a background of 50.
        let (w, h) = (21, 21);
        let px: Vec<f32> = (0..w * h)
            .map(|i| {
                let r2 = ((i % w) as f64 - 10.2).powi(2) + ((i / w) as f64 - 9.9).powi(2);
                let texture = ((i * 7919) % 7) as f64;
                (50.0 + texture + 400.0 * (-r2 / 6.0).exp()).min(255.0) as f32
            })
            .collect();
        let f = Frame::new(w, h, px, 8).unwrap();
        let win = PixelWindow::square(&f, 10.0, 10.0, 7.0);
        let censored = win.censored();
        let clipped = censored.len();
        assert!(clipped >= 5, "{clipped} clipped pixels");
        // Spot models whose peak is above the full count (the clipped
        // pixels reached: no residual at most of them) and below it (every
        // one pulls).
        for (amplitude, expect_reached) in [(400.0, true), (150.0, false)] {
            let q =
                SVector::<f64, 5>::from_column_slice(&[10.2, 9.9, 50.0, amplitude, 3.0f64.sqrt()]);
            let mut spot = WindowModel::spot(&win);
            spot.rss(&q);
            let reached = (0..win.len())
                .filter(|&i| censored.contains(&(i as u32)) && spot.cols.residual[i] == 0.0)
                .count();
            assert_eq!(
                reached > 0,
                expect_reached,
                "amplitude {amplitude}: {reached}"
            );
            let at_q = spot.normal_equations();
            // A pixel fitted exactly adds no degree of freedom to the noise.
            assert_eq!(at_q.observations, win.len() - reached);
            compare(at_q, &win, &q, spot_model);
        }
    }

    #[test]
    fn square_lists_every_pixel_in_raster_order_the_saturated_censored() {
        let f = frame();
        // Around the saturated pixel (4, 3), cut by the frame's top-left edge.
        for (cx, cy, half) in [(4.4, 3.0, 6.0), (15.0, 15.0, 12.0), (29.6, 30.2, 2.5)] {
            let win = PixelWindow::square(&f, cx, cy, half);
            let mut want = Vec::new();
            let mut saturated = Vec::new();
            let lo = |c: f64| (c - half).floor().max(0.0) as usize;
            let hi = |c: f64| ((c + half).ceil() as usize).min(30);
            for y in lo(cy)..=hi(cy) {
                for x in lo(cx)..=hi(cx) {
                    if f.at(x, y) >= f.max_count() {
                        saturated.push(want.len() as u32);
                    }
                    want.push((x as f64, y as f64, f.at(x, y).min(f.max_count()) as f64));
                }
            }
            assert_eq!(win.pixels().collect::<Vec<_>>(), want, "({cx}, {cy})");
            assert_eq!(win.censored(), saturated, "({cx}, {cy})");
        }
    }

    #[test]
    fn retain_keeps_absolute_positions() {
        let f = frame();
        let mut win = PixelWindow::square(&f, 15.0, 15.0, 3.0);
        win.retain(|x, _| x >= 15.0);
        assert_eq!(win.len(), 4 * 7);
        assert!(
            win.pixels()
                .all(|(x, y, v)| x >= 15.0 && f.at(x as usize, y as usize) as f64 == v)
        );
        // The saturated pixel (4, 3) keeps its mark when pixels before it go.
        let mut win = PixelWindow::square(&f, 4.0, 3.0, 3.0);
        win.retain(|x, y| x >= 3.0 && y >= 2.0);
        let marked: Vec<(f64, f64, f64)> = win
            .censored()
            .iter()
            .map(|&i| win.pixels().nth(i as usize).unwrap())
            .collect();
        assert_eq!(marked, vec![(4.0, 3.0, f.max_count() as f64)]);
    }
}
