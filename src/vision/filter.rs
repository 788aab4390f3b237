//! Separable image filters on row-major f32 buffers: box mean (running sums,
//! O(1) per pixel), square max filter (van Herk / Gil-Werman, 3 comparisons
//! per pixel per axis whatever the window) and small Gaussian. Hand-written
//! because they are a few lines, run on our own buffer type, and avoid a copy
//! into OpenCV per call.

use super::cpu_dispatch::avx2_dispatch;

/// Box mean over a (2r+1)^2 window; the window shrinks at the borders so the
/// mean stays unbiased there.
pub fn box_mean(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; w * h];
    box_mean_into(src, &mut out, w, h, r);
    out
}

/// [`box_mean`] replacing `image` by its box mean (no allocation of a frame).
pub fn box_mean_in_place(image: &mut [f32], w: usize, h: usize, r: usize) {
    box_mean_stream(None, image, w, h, r, Load::Copy);
}

/// [`box_mean`] of `src` written into `out` (every value of `out` is written).
pub fn box_mean_into(src: &[f32], out: &mut [f32], w: usize, h: usize, r: usize) {
    box_mean_stream(Some(src), out, w, h, r, Load::Copy);
}

/// Box mean of the squares of `src` into `out`: the local energy of a
/// band-passed frame without a squared copy of it written and read back.
pub fn box_mean_of_squares_into(src: &[f32], out: &mut [f32], w: usize, h: usize, r: usize) {
    box_mean_stream(Some(src), out, w, h, r, Load::Square);
}

/// Band-pass: box mean of radius `r_small` minus box mean of radius `r_big`,
/// both from one streamed read of `src`, written once into `out`. Equal, to
/// the bit, to the two [`box_mean_into`] frames subtracted; the fused form
/// moves 2 frames of memory instead of 7 (the filters are memory-bound).
pub fn band_pass_into(
    src: &[f32],
    out: &mut [f32],
    w: usize,
    h: usize,
    r_small: usize,
    r_big: usize,
) {
    band_pass_stream(src, out, w, h, r_small, r_big);
}

/// 1 / (pixels in the window cut at the ends) for every position along a line.
fn inverse_counts(n: usize, r: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 1.0 / ((i + r).min(n - 1) + 1 - i.saturating_sub(r)) as f64)
        .collect()
}

/// What a box stream sums: the input values or their squares.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Load {
    Copy,
    Square,
}

/// One box mean streamed down a frame row by row: the horizontal sums of the
/// 2r+2 rows the vertical window needs live in a small ring of rows
/// (cache-resident), and a running row of column sums in f64 (no drift)
/// moves down the frame. Two whole-frame passes through a scratch frame moved
/// three times the memory, and the filters are memory-bound.
///
/// Schedule, for y in 0..h: [`Self::emit`] row y, then [`Self::step`] with
/// input row y + r + 1 (if any). Input row k is read (step k-r-1) before
/// output row k is written (step k), so the output may be the input. The
/// methods are `#[inline(always)]` so they compile into the AVX2 callers.
struct BoxStream {
    r: usize,
    w: usize,
    slots: usize,
    inv_cols: Vec<f32>,
    inv_rows: Vec<f64>,
    ring: Vec<f32>,
    acc: Vec<f64>,
}

impl BoxStream {
    /// A stream of radius `r` over a w x h frame (w, h > 0).
    #[inline(always)]
    fn new(w: usize, h: usize, r: usize) -> Self {
        let slots = 2 * r + 2;
        Self {
            r,
            w,
            slots,
            inv_cols: inverse_counts(w, r).iter().map(|&v| v as f32).collect(),
            inv_rows: inverse_counts(h, r),
            ring: vec![0.0f32; slots * w],
            acc: vec![0.0f64; w],
        }
    }

    fn slot(&self, k: usize) -> std::ops::Range<usize> {
        (k % self.slots) * self.w..(k % self.slots + 1) * self.w
    }

    /// Horizontal sums of input row k (`row`) into its ring slot; `scratch`
    /// holds two work rows of at least w + 2r values.
    #[inline(always)]
    fn load(&mut self, k: usize, row: &[f32], load: Load, scratch: &mut [f32]) {
        let slot = self.slot(k);
        let len = self.w + 2 * self.r;
        let (pow, next) = scratch.split_at_mut(scratch.len() / 2);
        box_row(
            row,
            &mut self.ring[slot],
            self.r,
            &self.inv_cols,
            load,
            &mut pow[..len],
            &mut next[..len],
        );
    }

    /// Input rows 0..=r of the frame `rows`: loads them into the column sums.
    #[inline(always)]
    fn prime(&mut self, rows: &[f32], h: usize, load: Load, scratch: &mut [f32]) {
        let w = self.w;
        for k in 0..(self.r + 1).min(h) {
            self.load(k, &rows[k * w..(k + 1) * w], load, scratch);
            let slot = self.slot(k);
            for (a, &v) in self.acc.iter_mut().zip(&self.ring[slot]) {
                *a += v as f64;
            }
        }
    }

    /// Output row y into `dst`.
    #[inline(always)]
    fn emit(&self, y: usize, dst: &mut [f32]) {
        let inv = self.inv_rows[y];
        for (d, a) in dst.iter_mut().zip(&self.acc) {
            *d = (a * inv) as f32;
        }
    }

    /// Output row y subtracted from `dst`.
    #[inline(always)]
    fn emit_subtract(&self, y: usize, dst: &mut [f32]) {
        let inv = self.inv_rows[y];
        for (d, a) in dst.iter_mut().zip(&self.acc) {
            *d -= (a * inv) as f32;
        }
    }

    /// Moves the window from row y to y + 1: `entering` is input row y + r + 1
    /// (None past the bottom).
    #[inline(always)]
    fn step(&mut self, y: usize, entering: Option<&[f32]>, load: Load, scratch: &mut [f32]) {
        let r = self.r;
        if let Some(row) = entering {
            self.load(y + r + 1, row, load, scratch);
        }
        let (add, sub) = (entering.is_some(), y >= r);
        let (p, m) = (self.slot(y + r + 1), self.slot(y.wrapping_sub(r)));
        match (add, sub) {
            (true, true) => {
                let (p, m) = (&self.ring[p], &self.ring[m]);
                for ((a, &p), &m) in self.acc.iter_mut().zip(p).zip(m) {
                    *a += p as f64 - m as f64;
                }
            }
            (true, false) => {
                for (a, &p) in self.acc.iter_mut().zip(&self.ring[p]) {
                    *a += p as f64;
                }
            }
            (false, true) => {
                for (a, &m) in self.acc.iter_mut().zip(&self.ring[m]) {
                    *a -= m as f64;
                }
            }
            (false, false) => {}
        }
    }
}

avx2_dispatch!(
    /// Box mean of `src` (or of `out` itself when `src` is `None`) into
    /// `out`, see [`BoxStream`].
    fn box_mean_stream(
        src: Option<&[f32]>,
        out: &mut [f32],
        w: usize,
        h: usize,
        r: usize,
        load: Load,
    ) => box_mean_stream_lanes
);

#[inline(always)]
fn box_mean_stream_lanes(
    src: Option<&[f32]>,
    out: &mut [f32],
    w: usize,
    h: usize,
    r: usize,
    load: Load,
) {
    if w == 0 || h == 0 {
        return;
    }
    let mut stream = BoxStream::new(w, h, r);
    let mut scratch = vec![0.0f32; 2 * (w + 2 * r)];
    stream.prime(src.unwrap_or(&*out), h, load, &mut scratch);
    for y in 0..h {
        stream.emit(y, &mut out[y * w..(y + 1) * w]);
        let k = y + r + 1;
        // In place, row k of `out` still holds the input: it is written at step k > y.
        let input = src.unwrap_or(&*out);
        stream.step(
            y,
            (k < h).then(|| &input[k * w..(k + 1) * w]),
            load,
            &mut scratch,
        );
    }
}

avx2_dispatch!(
    /// [`band_pass_into`], see [`BoxStream`].
    fn band_pass_stream(
        src: &[f32],
        out: &mut [f32],
        w: usize,
        h: usize,
        r_small: usize,
        r_big: usize,
    ) => band_pass_lanes
);

#[inline(always)]
fn band_pass_lanes(src: &[f32], out: &mut [f32], w: usize, h: usize, r_small: usize, r_big: usize) {
    if w == 0 || h == 0 {
        return;
    }
    let mut scratch = vec![0.0f32; 2 * (w + 2 * r_small.max(r_big))];
    let mut small = BoxStream::new(w, h, r_small);
    let mut big = BoxStream::new(w, h, r_big);
    small.prime(src, h, Load::Copy, &mut scratch);
    big.prime(src, h, Load::Copy, &mut scratch);
    let row = |k: usize| (k < h).then(|| &src[k * w..(k + 1) * w]);
    for y in 0..h {
        let dst = &mut out[y * w..(y + 1) * w];
        small.emit(y, dst);
        big.emit_subtract(y, dst);
        small.step(y, row(y + r_small + 1), Load::Copy, &mut scratch);
        big.step(y, row(y + r_big + 1), Load::Copy, &mut scratch);
    }
}

/// Horizontal box mean of one row (`inv`: 1 / window length per position).
/// A running sum along a row is one long dependency chain; instead the
/// window sum is built from power-of-two partial sums (binary decomposition
/// of 2r+1), each a whole-row element-wise add that vectorises. No running
/// subtraction, so no drift in f32. `pow` and `next` are work rows of length
/// w + 2r.
#[inline(always)]
fn box_row<'a>(
    src: &[f32],
    dst: &mut [f32],
    r: usize,
    inv: &[f32],
    load: Load,
    mut pow: &'a mut [f32],
    mut next: &'a mut [f32],
) {
    let w = src.len();
    let len = w + 2 * r;
    // pow = the row with r zeros either side: window [x, x + 2r] of pow
    // is the window [x - r, x + r] of the row, cut at the ends.
    pow[..r].fill(0.0);
    match load {
        Load::Copy => pow[r..r + w].copy_from_slice(src),
        Load::Square => {
            for (p, &v) in pow[r..r + w].iter_mut().zip(src) {
                *p = v * v;
            }
        }
    }
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
        std::mem::swap(&mut pow, &mut next);
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

/// Flags of the pixels in a row that pass the threshold and the left/right
/// test (raster-order tie rule: an equal pixel to the left wins), for maxima
/// and minima: a branch-free pass over the row that vectorises. Per pixel,
/// with branches, the tests mispredicted on noisy maps and cost a third of
/// candidate finding. Maps are finite, so `l < v` is `!(l >= v)`.
#[inline(always)]
fn row_flags(row: &[f32], threshold: f32, check_sides: bool, flags: &mut [u8]) {
    let w = row.len();
    let flag = |v: f32, left: Option<f32>, right: Option<f32>| {
        let side = |sign: f32| {
            !check_sides
                || (left.is_none_or(|l| sign * l < sign * v)
                    && right.is_none_or(|rt| sign * rt <= sign * v))
        };
        (u8::from(v > threshold && side(1.0)) * MAX_FLAG)
            | (u8::from(-v > threshold && side(-1.0)) * MIN_FLAG)
    };
    if w <= 2 {
        for x in 0..w {
            let left = (x > 0).then(|| row[x - 1]);
            let right = (x + 1 < w).then(|| row[x + 1]);
            flags[x] = flag(row[x], left, right);
        }
        return;
    }
    flags[0] = flag(row[0], None, Some(row[1]));
    flags[w - 1] = flag(row[w - 1], Some(row[w - 2]), None);
    let interior = &mut flags[1..w - 1];
    let (left, mid, right) = (&row[..w - 2], &row[1..w - 1], &row[2..]);
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
        row_flags(&src[row..row + w], threshold, r >= 1, &mut flags);
        for (chunk_no, chunk) in flags.chunks(32).enumerate() {
            if chunk.iter().fold(0u8, |any, &f| any | f) == 0 {
                continue;
            }
            for (k, &f) in chunk.iter().enumerate().filter(|&(_, &f)| f != 0) {
                let x = chunk_no * 32 + k;
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
                    let (mut sum, mut n) = (0.0f64, 0usize);
                    for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                        for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                            sum += src[yy * w + xx] as f64;
                            n += 1;
                        }
                    }
                    let want = sum / n as f64;
                    assert!(
                        (fast[y * w + x] as f64 - want).abs() < 1e-4 * (1.0 + want.abs()),
                        "r {r} at ({x}, {y}): {} vs {want}",
                        fast[y * w + x]
                    );
                }
            }
        }
    }

    #[test]
    fn fused_band_pass_and_energy_equal_the_separate_filters_to_the_bit() {
        for (w, h) in [(37usize, 23usize), (5, 40), (1, 1)] {
            let src: Vec<f32> = (0..w * h)
                .map(|i| ((i * 7919) % 1009) as f32 * 0.37 - 150.0)
                .collect();
            for (small, big) in [(1usize, 17usize), (1, 3), (0, 40), (2, 2)] {
                let mut want = box_mean(&src, w, h, small);
                for (v, b) in want.iter_mut().zip(box_mean(&src, w, h, big)) {
                    *v -= b;
                }
                let mut got = vec![f32::NAN; w * h];
                band_pass_into(&src, &mut got, w, h, small, big);
                assert_eq!(got, want, "{w}x{h} radii {small} {big}");
            }
            for r in [0usize, 1, 5, 30] {
                let squares: Vec<f32> = src.iter().map(|v| v * v).collect();
                let mut got = vec![f32::NAN; w * h];
                box_mean_of_squares_into(&src, &mut got, w, h, r);
                assert_eq!(got, box_mean(&squares, w, h, r), "{w}x{h} r {r}");
            }
        }
    }

    #[test]
    fn local_maxima_equal_the_brute_force_window_maxima() {
        let (w, h) = (23, 17);
        // An irregular image with a plateau (ties resolved in raster order).
        let mut src: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 1009) as f32 - 500.0)
            .collect();
        for i in [5 * w + 5, 5 * w + 6, 6 * w + 5] {
            src[i] = 600.0;
        }
        for r in [0usize, 1, 2, 5, 12] {
            for threshold in [-1000.0f32, 100.0] {
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
