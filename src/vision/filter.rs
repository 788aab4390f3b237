//! Separable image filters on row-major f32 buffers: box mean (running sums,
//! O(1) per pixel), square max filter (van Herk / Gil-Werman, 3 comparisons
//! per pixel per axis whatever the window) and small Gaussian. Hand-written
//! because they are a few lines, run on our own buffer type, and avoid a copy
//! into OpenCV per call.

use super::cpu_dispatch::avx2_dispatch;
use super::frame::Frame;

/// Box mean over a (2r+1)^2 window; the window shrinks at the borders so the
/// mean stays unbiased there.
pub fn box_mean(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; w * h];
    box_mean_into(src, &mut out, w, h, r);
    out
}

/// [`box_mean`] replacing `image` by its box mean (no allocation of a frame).
pub fn box_mean_in_place(image: &mut [f32], w: usize, h: usize, r: usize) {
    box_mean_stream(None, image, w, h, r);
}

/// [`box_mean`] of `src` written into `out` (every value of `out` is written).
pub fn box_mean_into(src: &[f32], out: &mut [f32], w: usize, h: usize, r: usize) {
    box_mean_stream(Some(src), out, w, h, r);
}

/// 1 / (pixels in the window cut at the ends) for every position along a line.
fn inverse_counts(n: usize, r: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 1.0 / ((i + r).min(n - 1) + 1 - i.saturating_sub(r)) as f64)
        .collect()
}

avx2_dispatch!(
    /// Box mean of `src` (or of `out` itself when `src` is `None`) into
    /// `out`, see [`box_mean_stream_lanes`].
    fn box_mean_stream(src: Option<&[f32]>, out: &mut [f32], w: usize, h: usize, r: usize)
        => box_mean_stream_lanes
);

/// Rows between exact re-sums of the running f32 column sums in
/// [`box_mean_stream_lanes`]: each step adds at most two roundings (2^-24
/// relative each) of the sums it passes through, so the error stays below
/// 64 * 2^-24 = 4e-6 of the largest column sum of the last 32 rows (0.1
/// count on a 16-bit background), and a bright stretch that has left the
/// window leaves no error behind.
const RESUM_ROWS: usize = 32;

/// Both passes streamed row by row: the horizontal sums of the 2r+2 rows the
/// vertical window needs live in a small ring of rows (cache-resident), and
/// a running row of column sums moves down the frame. Two whole-frame passes
/// through a scratch frame moved three times the memory. The column sums run
/// in f32 (8 lanes, no conversions; in f64 the vertical pass was half the
/// filter's time) and are re-summed exactly from the ring every
/// [`RESUM_ROWS`] rows, so rounding cannot drift. Row k of the input is read
/// (step k-r-1) before row k of the output is written (step k), so `out` may
/// be the input.
#[inline(always)]
fn box_mean_stream_lanes(src: Option<&[f32]>, out: &mut [f32], w: usize, h: usize, r: usize) {
    if w == 0 || h == 0 {
        return;
    }
    let inv_cols: Vec<f32> = inverse_counts(w, r).iter().map(|&v| v as f32).collect();
    let inv_rows: Vec<f32> = inverse_counts(h, r).iter().map(|&v| v as f32).collect();
    let slots = 2 * r + 2;
    let mut ring = vec![0.0f32; slots * w];
    let mut pow = vec![0.0f32; w + 2 * r];
    let mut next = vec![0.0f32; w + 2 * r];
    let mut acc = vec![0.0f32; w];
    let mut exact = vec![0.0f64; w];
    // Horizontal sums of input row k into its ring slot. (A macro, not a
    // closure: a closure is compiled as its own function, without AVX2.)
    macro_rules! load {
        ($k:expr) => {{
            let k = $k;
            let row = match src {
                Some(s) => &s[k * w..(k + 1) * w],
                None => &out[k * w..(k + 1) * w],
            };
            let slot = &mut ring[(k % slots) * w..(k % slots + 1) * w];
            box_row(row, slot, r, &inv_cols, &mut pow, &mut next);
        }};
    }
    let slot_of = |k: usize| (k % slots) * w..(k % slots + 1) * w;
    for k in 0..(r + 1).min(h) {
        load!(k);
    }
    for y in 0..h {
        // The window of output row y: input rows y - r ..= y + r, cut.
        let (lo, hi) = (y.saturating_sub(r), (y + r).min(h - 1));
        if y % RESUM_ROWS == 0 {
            exact.fill(0.0);
            for k in lo..=hi {
                for (e, &v) in exact.iter_mut().zip(&ring[slot_of(k)]) {
                    *e += v as f64;
                }
            }
            for (a, &e) in acc.iter_mut().zip(&exact) {
                *a = e as f32;
            }
        }
        let inv = inv_rows[y];
        for (d, &a) in out[y * w..(y + 1) * w].iter_mut().zip(&acc) {
            *d = a * inv;
        }
        let (add, sub) = (y + r + 1 < h, y >= r);
        if add {
            load!(y + r + 1);
        }
        match (add, sub) {
            (true, true) => {
                let (p, m) = (&ring[slot_of(y + r + 1)], &ring[slot_of(y - r)]);
                for ((a, &p), &m) in acc.iter_mut().zip(p).zip(m) {
                    *a += p - m;
                }
            }
            (true, false) => {
                for (a, &p) in acc.iter_mut().zip(&ring[slot_of(y + r + 1)]) {
                    *a += p;
                }
            }
            (false, true) => {
                for (a, &m) in acc.iter_mut().zip(&ring[slot_of(y - r)]) {
                    *a -= m;
                }
            }
            (false, false) => {}
        }
    }
}

/// Horizontal box mean of one row (`inv`: 1 / window length per position).
/// A running sum along a row is one long dependency chain; instead the
/// window sum is built from power-of-two partial sums (binary decomposition
/// of 2r+1), each a whole-row element-wise add that vectorises. No running
/// subtraction, so no drift in f32. `pow` and `next` are work rows of length
/// w + 2r.
#[inline(always)]
fn box_row(
    src: &[f32],
    dst: &mut [f32],
    r: usize,
    inv: &[f32],
    pow: &mut Vec<f32>,
    next: &mut Vec<f32>,
) {
    let w = src.len();
    let len = w + 2 * r;
    // pow = the row with r zeros either side: window [x, x + 2r] of pow
    // is the window [x - r, x + r] of the row, cut at the ends.
    pow[..r].fill(0.0);
    pow[r..r + w].copy_from_slice(src);
    pow[r + w..].fill(0.0);
    let (mut rem, mut width, mut offset, mut first) = (2 * r + 1, 1usize, 0usize, true);
    loop {
        if rem & 1 == 1 {
            // The first partial sum is stored, the others added.
            if first {
                dst.copy_from_slice(&pow[offset..offset + w]);
                first = false;
            } else {
                for (d, &p) in dst.iter_mut().zip(&pow[offset..offset + w]) {
                    *d += p;
                }
            }
            offset += width;
        }
        rem >>= 1;
        if rem == 0 {
            break;
        }
        // next[i]: the sum of 2 * width elements from i (the last `width`
        // entries would read past the end; they are never used).
        let used = len - width;
        for ((n, &a), &b) in next[..used].iter_mut().zip(&pow[..used]).zip(&pow[width..]) {
            *n = a + b;
        }
        next[used..].fill(0.0);
        std::mem::swap(pow, next);
        width *= 2;
    }
    for (d, &k) in dst.iter_mut().zip(inv) {
        *d *= k;
    }
}

/// Pixels above `threshold` that equal the maximum of the (2r+1)^2 window
/// around them (cut at the borders), in raster order; on a plateau only its
/// first pixel in raster order counts. Row-major indices.
///
/// The left and right neighbours are checked first, then the 8 neighbours:
/// on a smooth map almost every pixel above the threshold has a larger
/// neighbour and is rejected there, so the full window is scanned only at the
/// few true peaks.
pub fn local_maxima(src: &[f32], w: usize, h: usize, r: usize, threshold: f32) -> Vec<usize> {
    let [maxima, _] = local_extrema_both(src, w, h, r, threshold);
    maxima
}

/// [`local_maxima`] of `sign * src` (sign -1: local minima below -threshold),
/// without a negated copy of the frame.
pub fn local_extrema(
    src: &[f32],
    w: usize,
    h: usize,
    r: usize,
    threshold: f32,
    sign: f32,
) -> Vec<usize> {
    let [maxima, minima] = local_extrema_both(src, w, h, r, threshold);
    if sign >= 0.0 { maxima } else { minima }
}

avx2_dispatch!(
    /// [`local_maxima`] of `src` and of `-src` in one pass over the map:
    /// `[maxima above threshold, minima below -threshold]`.
    pub fn local_extrema_both(
        src: &[f32],
        w: usize,
        h: usize,
        r: usize,
        threshold: f32,
    ) -> [Vec<usize>; 2] => local_extrema_lanes
);

/// Flag bit of a maximum candidate; a minimum candidate has bit 2.
const MAX_FLAG: u8 = 1;
const MIN_FLAG: u8 = 2;

/// Pixels per chunk of a row that [`local_extrema_both`] skips at once when
/// no value in it passes the threshold.
const EXTREMA_CHUNK: usize = 32;

/// Largest |v| of a chunk, in lanes that compile to vector max instructions.
#[inline(always)]
fn chunk_abs_max(chunk: &[f32]) -> f32 {
    let mut lanes = [0.0f32; 8];
    let whole = chunk.chunks_exact(8);
    let rest = whole.remainder();
    for part in whole {
        for (m, &v) in lanes.iter_mut().zip(part) {
            let a = v.abs();
            *m = if a > *m { a } else { *m };
        }
    }
    for &v in rest {
        let a = v.abs();
        lanes[0] = if a > lanes[0] { a } else { lanes[0] };
    }
    lanes
        .into_iter()
        .fold(0.0, |m, a| if a > m { a } else { m })
}

/// Flags of the pixels `row[x0..x0 + flags.len()]` that pass the threshold
/// and the left/right test (raster-order tie rule: an equal pixel to the left
/// wins), for maxima and minima: a branch-free pass that vectorises. Per
/// pixel, with branches, the tests mispredicted on noisy maps and cost a
/// third of candidate finding. Maps are finite, so `l < v` is `!(l >= v)`.
#[inline(always)]
fn row_flags_in(row: &[f32], x0: usize, threshold: f32, check_sides: bool, flags: &mut [u8]) {
    let w = row.len();
    let n = flags.len();
    let flag = |x: usize| {
        let v = row[x];
        let left = (x > 0).then(|| row[x - 1]);
        let right = (x + 1 < w).then(|| row[x + 1]);
        let side = |sign: f32| {
            !check_sides
                || (left.is_none_or(|l| sign * l < sign * v)
                    && right.is_none_or(|rt| sign * rt <= sign * v))
        };
        (u8::from(v > threshold && side(1.0)) * MAX_FLAG)
            | (u8::from(-v > threshold && side(-1.0)) * MIN_FLAG)
    };
    if n <= 2 {
        for (k, f) in flags.iter_mut().enumerate() {
            *f = flag(x0 + k);
        }
        return;
    }
    flags[0] = flag(x0);
    flags[n - 1] = flag(x0 + n - 1);
    let interior = &mut flags[1..n - 1];
    let (left, mid, right) = (
        &row[x0..x0 + n - 2],
        &row[x0 + 1..x0 + n - 1],
        &row[x0 + 2..x0 + n],
    );
    for (((f, &l), &v), &rt) in interior.iter_mut().zip(left).zip(mid).zip(right) {
        let max_ok = (v > threshold) & (((l < v) & (rt <= v)) | !check_sides);
        let min_ok = (-v > threshold) & (((-l < -v) & (-rt <= -v)) | !check_sides);
        *f = (u8::from(max_ok) * MAX_FLAG) | (u8::from(min_ok) * MIN_FLAG);
    }
}

#[inline(always)]
fn local_extrema_lanes(
    src: &[f32],
    w: usize,
    h: usize,
    r: usize,
    threshold: f32,
) -> [Vec<usize>; 2] {
    let mut out = [Vec::new(), Vec::new()];
    let mut flags = vec![0u8; w];
    for y in 0..h {
        let row = y * w;
        let values = &src[row..row + w];
        for (chunk_no, chunk) in values.chunks(EXTREMA_CHUNK).enumerate() {
            // A chunk whose largest |v| is at most the threshold holds
            // neither a maximum above it nor a minimum below -threshold
            // (most of a frame: the band-pass is noise away from particles).
            if chunk_abs_max(chunk) <= threshold {
                continue;
            }
            let x0 = chunk_no * EXTREMA_CHUNK;
            let x1 = x0 + chunk.len();
            let flags = &mut flags[x0..x1];
            row_flags_in(values, x0, threshold, r >= 1, flags);
            for (k, &f) in flags.iter().enumerate().filter(|&(_, &f)| f != 0) {
                let x = x0 + k;
                for (bit, sign, found) in [(MAX_FLAG, 1.0f32, 0), (MIN_FLAG, -1.0, 1)] {
                    if f & bit == 0 {
                        continue;
                    }
                    let at = |i: usize| sign * src[i];
                    let v = at(row + x);
                    if wins_window(&at, w, h, x, y, 1.min(r), v)
                        && (r <= 1 || wins_window(&at, w, h, x, y, r, v))
                    {
                        out[found].push(row + x);
                    }
                }
            }
        }
    }
    out
}

/// True when no pixel of the window around (x, y) exceeds `v`, and none equal
/// to it comes earlier in raster order.
#[inline]
fn wins_window(
    at: &impl Fn(usize) -> f32,
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    r: usize,
    v: f32,
) -> bool {
    let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1));
    for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
        for xx in x0..=x1 {
            let u = at(yy * w + xx);
            let earlier = yy < y || (yy == y && xx < x);
            if u > v || (u == v && earlier) {
                return false;
            }
        }
    }
    true
}

/// 2x2 binning: each output pixel is the mean of a 2x2 block (of the pixels
/// there are, at an odd width or height), so the output is
/// ceil(w / 2) x ceil(h / 2). Returns the binned pixels and their width and
/// height.
pub fn bin_2x2(src: &[f32], w: usize, h: usize) -> (Vec<f32>, usize, usize) {
    let (bw, bh) = (w.div_ceil(2), h.div_ceil(2));
    let mut out = vec![0.0f32; bw * bh];
    for (by, dst) in out.chunks_exact_mut(bw.max(1)).enumerate() {
        let top = &src[2 * by * w..(2 * by + 1) * w];
        let bottom = if 2 * by + 1 < h {
            &src[(2 * by + 1) * w..(2 * by + 2) * w]
        } else {
            top
        };
        // Whole pairs of columns: a branch-free loop that vectorises.
        let pairs = w / 2;
        let blocks = dst[..pairs]
            .iter_mut()
            .zip(top.chunks_exact(2))
            .zip(bottom.chunks_exact(2));
        for ((d, t), b) in blocks {
            *d = 0.25 * ((t[0] + t[1]) + (b[0] + b[1]));
        }
        if w % 2 == 1 {
            dst[pairs] = 0.5 * (top[w - 1] + bottom[w - 1]);
        }
    }
    (out, bw, bh)
}

/// [`bin_2x2`] of a frame, as a frame of the same bit depth (a binned pixel
/// reaches the saturation count only when its whole block does). The tip's
/// dark-region search and the particles' candidate search share it.
pub fn bin_frame(frame: &Frame) -> Frame {
    let (px, w, h) = bin_2x2(frame.pixels(), frame.width(), frame.height());
    match Frame::new(w, h, px, frame.bit_depth()) {
        Ok(f) => f,
        // Means of finite pixels are finite, and the size is at least 1x1.
        Err(e) => unreachable!("a binned frame is a valid frame: {e}"),
    }
}

/// Normalised 1-D Gaussian kernel of width `sigma`, radius ceil(3 sigma).
pub fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as isize;
    let k: Vec<f64> = (-r..=r)
        .map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter().map(|v| (v / s) as f32).collect()
}

/// Gaussian blur with border clamping.
pub fn gaussian(src: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    let k = gaussian_kernel(sigma);
    let r = (k.len() / 2) as isize;
    let mut tmp = vec![0.0f32; w * h];
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        for x in 0..w {
            let mut acc = 0.0f32;
            for (j, kv) in k.iter().enumerate() {
                let xx = (x as isize + j as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kv * row[xx];
            }
            tmp[y * w + x] = acc;
        }
    }
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        for (j, kv) in k.iter().enumerate() {
            let yy = (y as isize + j as isize - r).clamp(0, h as isize - 1) as usize;
            let src_row = &tmp[yy * w..(yy + 1) * w];
            let dst = &mut out[y * w..(y + 1) * w];
            for (d, s) in dst.iter_mut().zip(src_row) {
                *d += kv * s;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bin_2x2_averages_blocks_and_the_cut_blocks_at_odd_edges() {
        // 5x3: blocks of 4, 2 (right column) and 2 (bottom row), 1 (corner).
        let src: Vec<f32> = (0..15).map(|i| i as f32).collect();
        let (out, bw, bh) = bin_2x2(&src, 5, 3);
        assert_eq!((bw, bh), (3, 2));
        assert_eq!(
            out,
            vec![3.0, 5.0, 6.5, 10.5, 12.5, 14.0],
            "means of 0 1 5 6 | 2 3 7 8 | 4 9 | 10 11 | 12 13 | 14"
        );
    }

    #[test]
    fn box_and_gaussian_keep_constants_and_smooth_impulses() {
        let (w, h) = (9, 7);
        let c = vec![3.0f32; w * h];
        assert!(box_mean(&c, w, h, 2).iter().all(|v| (v - 3.0).abs() < 1e-5));
        assert!(
            gaussian(&c, w, h, 1.0)
                .iter()
                .all(|v| (v - 3.0).abs() < 1e-5)
        );
        let mut imp = vec![0.0f32; w * h];
        imp[3 * w + 4] = 25.0;
        let b = box_mean(&imp, w, h, 2);
        assert!((b[3 * w + 4] - 1.0).abs() < 1e-6);
        assert!((b[3 * w + 2] - 1.0).abs() < 1e-6);
        assert_eq!(b[3 * w + 1], 0.0);
        let g = gaussian(&imp, w, h, 1.0);
        let total: f32 = g.iter().sum();
        assert!((total - 25.0).abs() < 1e-3);
    }

    #[test]
    fn box_mean_equals_the_brute_force_window_mean() {
        let (w, h) = (37, 23);
        let src: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 1009) as f32 - 500.0)
            .collect();
        for r in [0usize, 1, 2, 5, 17, 40] {
            let fast = box_mean(&src, w, h, r);
            let mut in_place = src.clone();
            box_mean_in_place(&mut in_place, w, h, r);
            assert_eq!(in_place, fast, "in place, r {r}");
            for y in 0..h {
                for x in 0..w {
                    let want = brute_box_mean(&src, w, h, r, x, y);
                    assert!(
                        (fast[y * w + x] as f64 - want).abs() < 1e-4 * (1.0 + want.abs()),
                        "r {r} at ({x}, {y}): {} vs {want}",
                        fast[y * w + x]
                    );
                }
            }
        }
    }

    /// The mean of the (2r+1)^2 box around (x, y) clipped to the frame, in f64.
    fn brute_box_mean(src: &[f32], w: usize, h: usize, r: usize, x: usize, y: usize) -> f64 {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                sum += src[yy * w + xx] as f64;
                n += 1;
            }
        }
        sum / n as f64
    }

    #[test]
    fn box_mean_column_sums_do_not_drift_down_a_tall_frame() {
        // 40 bright rows (1e6 counts) above 260 dim ones (1-2 counts): a
        // running f32 column sum keeps the rounding of the bright rows
        // (~ulp(3.5e7) = 4 counts) after they leave the window, swamping the
        // dim means; re-summed every RESUM_ROWS rows it is exact again.
        let (w, h, bright) = (11, 300, 40);
        let src: Vec<f32> = (0..w * h)
            .map(|i| {
                let texture = ((i * 7919) % 1009) as f32 / 1009.0;
                if i / w < bright {
                    1e6 + 777.0 * texture
                } else {
                    1.0 + texture
                }
            })
            .collect();
        const { assert!(RESUM_ROWS <= 32, "the check below starts 32 rows on") };
        for r in [3usize, 17] {
            let fast = box_mean(&src, w, h, r);
            for y in bright + r + 32..h {
                for x in 0..w {
                    let want = brute_box_mean(&src, w, h, r, x, y);
                    let got = fast[y * w + x] as f64;
                    assert!(
                        (got - want).abs() < 1e-5 * want,
                        "r {r} at ({x}, {y}): {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn local_maxima_equal_the_brute_force_window_maxima() {
        // 23 wide: one chunk per row; 75 wide: chunks of 32 cut the rows, and
        // the threshold 480 leaves whole chunks below it (skipped unread).
        for (w, h) in [(23, 17), (75, 13)] {
            brute_force_maxima_case(w, h);
        }
    }

    fn brute_force_maxima_case(w: usize, h: usize) {
        // An irregular image with a plateau (ties resolved in raster order).
        let mut src: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 1009) as f32 - 500.0)
            .collect();
        for i in [5 * w + 5, 5 * w + 6, 6 * w + 5] {
            src[i] = 600.0;
        }
        for r in [0usize, 1, 2, 5, 12] {
            for threshold in [-1000.0f32, 100.0, 480.0] {
                let mut want = Vec::new();
                for y in 0..h {
                    for x in 0..w {
                        let v = src[y * w + x];
                        let mut best = true;
                        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                                let u = src[yy * w + xx];
                                let earlier = (yy, xx) < (y, x);
                                best &= u < v || (u == v && !earlier);
                            }
                        }
                        if v > threshold && best {
                            want.push(y * w + x);
                        }
                    }
                }
                assert_eq!(local_maxima(&src, w, h, r, threshold), want, "r {r}");
                let negated: Vec<f32> = src.iter().map(|v| -v).collect();
                assert_eq!(
                    local_extrema(&negated, w, h, r, threshold, -1.0),
                    want,
                    "r {r}"
                );
                if r >= 1 {
                    assert!(want.contains(&(5 * w + 5)) && !want.contains(&(5 * w + 6)));
                }
            }
        }
    }
}
