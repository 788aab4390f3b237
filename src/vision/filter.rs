//! Separable image filters on row-major f32 buffers: box mean (running sums,
//! O(1) per pixel), square max filter (van Herk / Gil-Werman, 3 comparisons
//! per pixel per axis whatever the window) and small Gaussian. Hand-written
//! because they are a few lines, run on our own buffer type, and avoid a copy
//! into OpenCV per call.

/// Box mean over a (2r+1)^2 window; the window shrinks at the borders so the
/// mean stays unbiased there.
pub fn box_mean(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let tmp = box_rows(src, w, h, r);
    box_columns(&tmp, w, h, r)
}

fn box_rows(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        let dst = &mut out[y * w..(y + 1) * w];
        let mut acc: f64 = row[..(r + 1).min(w)].iter().map(|&v| v as f64).sum();
        let mut n = (r + 1).min(w);
        for (x, d) in dst.iter_mut().enumerate() {
            *d = (acc / n as f64) as f32;
            if x + r + 1 < w {
                acc += row[x + r + 1] as f64;
                n += 1;
            }
            if x >= r {
                acc -= row[x - r] as f64;
                n -= 1;
            }
        }
    }
    out
}

/// Vertical pass with a running row of column sums (cache-friendly).
fn box_columns(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; w * h];
    let mut acc = vec![0.0f64; w];
    let mut n = 0usize;
    for y in 0..(r + 1).min(h) {
        for (a, &v) in acc.iter_mut().zip(&src[y * w..(y + 1) * w]) {
            *a += v as f64;
        }
        n += 1;
    }
    for y in 0..h {
        let inv = 1.0 / n as f64;
        for (d, a) in out[y * w..(y + 1) * w].iter_mut().zip(&acc) {
            *d = (a * inv) as f32;
        }
        if y + r + 1 < h {
            let add = &src[(y + r + 1) * w..(y + r + 2) * w];
            for (a, &v) in acc.iter_mut().zip(add) {
                *a += v as f64;
            }
            n += 1;
        }
        if y >= r {
            let sub = &src[(y - r) * w..(y - r + 1) * w];
            for (a, &v) in acc.iter_mut().zip(sub) {
                *a -= v as f64;
            }
            n -= 1;
        }
    }
    out
}

/// Maximum over the (2r+1)^2 window around every pixel; the window is cut at
/// the borders (pixels outside the frame do not exist, they are not zero).
/// Local maxima of an image are where it equals its max filter.
pub fn max_filter(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut rows = vec![0.0f32; w * h];
    let mut scratch = RunningMax::new(w, r);
    for y in 0..h {
        scratch.run(&src[y * w..(y + 1) * w], &mut rows[y * w..(y + 1) * w]);
    }
    // Columns: the same recurrence with whole rows as the elements, so the
    // inner loops run along memory and vectorise.
    max_columns(&rows, w, h, r)
}

/// Per-row buffers for the van Herk / Gil-Werman running max.
struct RunningMax {
    k: usize,
    r: usize,
    prefix: Vec<f32>,
    suffix: Vec<f32>,
}

impl RunningMax {
    fn new(n: usize, r: usize) -> Self {
        let padded = n + 2 * r;
        Self {
            k: 2 * r + 1,
            r,
            prefix: vec![f32::NEG_INFINITY; padded],
            suffix: vec![f32::NEG_INFINITY; padded],
        }
    }

    /// out[i] = max(src[i - r ..= i + r]) (cut at the ends).
    fn run(&mut self, src: &[f32], out: &mut [f32]) {
        let (k, r, n) = (self.k, self.r, src.len());
        let padded = n + 2 * r;
        let at = |i: usize| {
            if i >= r && i - r < n {
                src[i - r]
            } else {
                f32::NEG_INFINITY
            }
        };
        for i in 0..padded {
            let v = at(i);
            self.prefix[i] = if i % k == 0 {
                v
            } else {
                self.prefix[i - 1].max(v)
            };
        }
        for i in (0..padded).rev() {
            let v = at(i);
            self.suffix[i] = if i % k == k - 1 || i + 1 == padded {
                v
            } else {
                self.suffix[i + 1].max(v)
            };
        }
        // Window [i, i + k - 1] in padded indices is centred on src[i].
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.suffix[i].max(self.prefix[i + k - 1]);
        }
    }
}

fn max_columns(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let k = 2 * r + 1;
    let padded = h + 2 * r;
    let row = |i: usize| -> Option<&[f32]> {
        (i >= r && i - r < h).then(|| &src[(i - r) * w..(i - r + 1) * w])
    };
    let mut prefix = vec![f32::NEG_INFINITY; padded * w];
    let mut suffix = vec![f32::NEG_INFINITY; padded * w];
    for i in 0..padded {
        let (done, rest) = prefix.split_at_mut(i * w);
        let dst = &mut rest[..w];
        match (row(i), i % k == 0) {
            (Some(s), true) => dst.copy_from_slice(s),
            (None, true) => dst.fill(f32::NEG_INFINITY),
            (Some(s), false) => {
                let prev = &done[(i - 1) * w..];
                for ((d, &p), &v) in dst.iter_mut().zip(prev).zip(s) {
                    *d = p.max(v);
                }
            }
            (None, false) => dst.copy_from_slice(&done[(i - 1) * w..]),
        }
    }
    for i in (0..padded).rev() {
        let (head, next) = suffix.split_at_mut((i + 1) * w);
        let dst = &mut head[i * w..];
        let restart = i % k == k - 1 || i + 1 == padded;
        match (row(i), restart) {
            (Some(s), true) => dst.copy_from_slice(s),
            (None, true) => dst.fill(f32::NEG_INFINITY),
            (Some(s), false) => {
                for ((d, &p), &v) in dst.iter_mut().zip(&next[..w]).zip(s) {
                    *d = p.max(v);
                }
            }
            (None, false) => dst.copy_from_slice(&next[..w]),
        }
    }
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        let a = &suffix[y * w..(y + 1) * w];
        let b = &prefix[(y + k - 1) * w..(y + k) * w];
        for ((o, &p), &q) in out[y * w..(y + 1) * w].iter_mut().zip(a).zip(b) {
            *o = p.max(q);
        }
    }
    out
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
    fn max_filter_equals_the_brute_force_window_max() {
        let (w, h) = (23, 17);
        // A deterministic, irregular image (no ties to hide errors).
        let src: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 1009) as f32 - 500.0)
            .collect();
        for r in [0usize, 1, 2, 5, 12] {
            let fast = max_filter(&src, w, h, r);
            for y in 0..h {
                for x in 0..w {
                    let mut m = f32::NEG_INFINITY;
                    for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                        for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                            m = m.max(src[yy * w + xx]);
                        }
                    }
                    assert_eq!(fast[y * w + x], m, "r {r} at ({x}, {y})");
                }
            }
        }
    }
}
