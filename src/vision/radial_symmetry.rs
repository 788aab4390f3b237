//! Radial-symmetry centre (Parthasarathy, Nature Methods 9, 724, 2012): the
//! point closest, in a weighted least-squares sense, to every line along the
//! local intensity gradient. Works for spots and rings of either contrast,
//! needs no model and no iteration; the profile fit starts from it.

use super::cpu_dispatch::avx2_dispatch;
use super::frame::Frame;

/// Centre of radial symmetry of the square window of half-size `half` around
/// (cx, cy), or `None` when the window holds no gradient (flat) or leaves the frame.
pub fn radial_symmetry_centre(frame: &Frame, cx: f64, cy: f64, half: usize) -> Option<(f64, f64)> {
    let (w, h) = (frame.width() as isize, frame.height() as isize);
    let x0 = (cx.round() as isize - half as isize).max(0);
    let y0 = (cy.round() as isize - half as isize).max(0);
    let x1 = (cx.round() as isize + half as isize).min(w - 1);
    let y1 = (cy.round() as isize + half as isize).min(h - 1);
    if x1 - x0 < 2 || y1 - y0 < 2 {
        return None;
    }
    let (x0, y0) = (x0 as usize, y0 as usize);
    let (bw, bh) = (x1 as usize - x0, y1 as usize - y0);
    let (cx, cy) = window_centre(frame, x0, y0, bw, bh)?;
    Some((x0 as f64 + cx, y0 as f64 + cy))
}

/// Lanes of the weighted sums: each lane sums every 8th block, so the loops
/// run as vectors (8 f32 with AVX2, two SSE registers without); the lanes
/// are added in f64 at the end.
const LANES: usize = 8;

avx2_dispatch!(
    /// The centre, relative to (x0, y0), from the gradients of the `bw` x
    /// `bh` blocks of 2x2 pixels whose top-left corners start at (x0, y0).
    fn window_centre(frame: &Frame, x0: usize, y0: usize, bw: usize, bh: usize)
        -> Option<(f64, f64)> => window_centre_lanes
);

/// Lane sums (see [`LANES`]) of K terms per block: `term(chunk, l)` gives
/// the terms of block l of the chunk of blocks starting at `chunk`; `n` is a
/// whole number of lanes. The chunk's values are taken as fixed-size arrays
/// by the callers, so each lane loop compiles to vector instructions.
#[inline(always)]
fn lane_sums<const K: usize>(n: usize, term: impl Fn(usize, usize) -> [f32; K]) -> [f64; K] {
    let mut acc = [[0.0f32; LANES]; K];
    for c in (0..n).step_by(LANES) {
        let terms: [[f32; K]; LANES] = std::array::from_fn(|l| term(c, l));
        for (k, acc_k) in acc.iter_mut().enumerate() {
            for (a, t) in acc_k.iter_mut().zip(&terms) {
                *a += t[k];
            }
        }
    }
    acc.map(|lanes| lanes.iter().map(|&v| v as f64).sum())
}

/// Block values `c..c + LANES` of `v` as an array.
#[inline(always)]
fn chunk(v: &[f32], c: usize) -> &[f32; LANES] {
    v[c..c + LANES].try_into().expect("whole lanes")
}

/// The least-squares point nearest to the lines through the block centres
/// along their gradients, each line weighted by |g|^2 / (distance to
/// `centre`): with unit normals n = (-gy, gx) / |g| the weights' |g|^2
/// cancels the normalisation, so every term is a product of gradient
/// components over the distance (no square root or division per line for
/// the normal, one of each for the distance).
#[inline(always)]
fn refine(
    px: &[f32],
    py: &[f32],
    gx: &[f32],
    gy: &[f32],
    centre: (f64, f64),
) -> Option<(f64, f64)> {
    let (cx, cy) = (centre.0 as f32, centre.1 as f32);
    let [a11, a12, a22, b1, b2] = lane_sums(px.len(), |c, l| {
        let (x, y, gx, gy) = (
            chunk(px, c)[l],
            chunk(py, c)[l],
            chunk(gx, c)[l],
            chunk(gy, c)[l],
        );
        let dist = ((x - cx) * (x - cx) + (y - cy) * (y - cy)).sqrt();
        let inv = 1.0 / if dist > 0.5 { dist } else { 0.5 };
        // Line i: n . p = n . (x, y), n = (-gy, gx) / |g|.
        let pn = gx * y - gy * x;
        [
            gy * gy * inv,
            -gx * gy * inv,
            gx * gx * inv,
            -gy * pn * inv,
            gx * pn * inv,
        ]
    });
    let det = a11 * a22 - a12 * a12;
    if det.abs() <= 1e-12 * (a11 * a22).abs().max(1e-300) {
        return None;
    }
    let c = ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
    (c.0.is_finite() && c.1.is_finite()).then_some(c)
}

#[inline(always)]
fn window_centre_lanes(
    frame: &Frame,
    x0: usize,
    y0: usize,
    bw: usize,
    bh: usize,
) -> Option<(f64, f64)> {
    // Gradients at the centres of 2x2 blocks (Roberts cross, rotated to x/y),
    // in structure-of-arrays f32 with coordinates relative to (x0, y0), so
    // they are exact. Padded to whole lanes with flat blocks (g = 0), which
    // add nothing to any sum.
    let n = (bw * bh).div_ceil(LANES) * LANES;
    let (mut px, mut py) = (vec![0.0f32; n], vec![0.0f32; n]);
    let (mut gxs, mut gys) = (vec![0.0f32; n], vec![0.0f32; n]);
    let w = frame.width();
    let pixels = frame.pixels();
    for by in 0..bh {
        let top = &pixels[(y0 + by) * w + x0..][..bw + 1];
        let bottom = &pixels[(y0 + by + 1) * w + x0..][..bw + 1];
        let row = by * bw..(by + 1) * bw;
        let out = px[row.clone()]
            .iter_mut()
            .zip(&mut py[row.clone()])
            .zip(&mut gxs[row.clone()])
            .zip(&mut gys[row]);
        for (bx, (((px, py), gx), gy)) in out.enumerate() {
            let (a, b, c, d) = (top[bx], top[bx + 1], bottom[bx], bottom[bx + 1]);
            *gx = 0.5 * ((b - a) + (d - c));
            *gy = 0.5 * ((c - a) + (d - b));
            *px = bx as f32 + 0.5;
            *py = by as f32 + 0.5;
        }
    }
    // Start: the centroid of the block centres weighted by |g|^2.
    let [sx, sy, sw] = lane_sums(n, |c, l| {
        let (gx, gy) = (chunk(&gxs, c)[l], chunk(&gys, c)[l]);
        let g2 = gx * gx + gy * gy;
        [g2 * chunk(&px, c)[l], g2 * chunk(&py, c)[l], g2]
    });
    if sw <= 0.0 {
        return None;
    }
    // Two passes: weights |g|^2 / distance to the current centre estimate.
    let centre = refine(&px, &py, &gxs, &gys, (sx / sw, sy / sw))?;
    refine(&px, &py, &gxs, &gys, centre)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_subpixel_centre_of_a_noise_free_gaussian() {
        let (w, h) = (31, 31);
        let (tx, ty) = (15.3, 14.6);
        let px: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                (100.0 + 500.0 * (-((x - tx).powi(2) + (y - ty).powi(2)) / 8.0).exp()) as f32
            })
            .collect();
        let f = Frame::new(w, h, px, 16).unwrap();
        let (x, y) = radial_symmetry_centre(&f, 15.0, 15.0, 8).unwrap();
        assert!((x - tx).abs() < 0.05 && (y - ty).abs() < 0.05, "{x} {y}");
        let flat = Frame::new(w, h, vec![5.0; w * h], 8).unwrap();
        assert_eq!(radial_symmetry_centre(&flat, 15.0, 15.0, 8), None);
    }
}
