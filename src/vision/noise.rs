//! Measuring a frame's noise, so detection thresholds are in units of noise
//! and do not depend on bit depth, gain or exposure.

use super::frame::Frame;

/// Noise floor: below it the frame is taken as quantisation-limited (1/sqrt(12) counts).
pub const MIN_NOISE_COUNTS: f64 = 0.2887;

/// Robust per-pixel noise standard deviation in counts: the median absolute
/// difference of horizontal neighbours (scaled for a Gaussian), on a sample of
/// rows. Structure (particles, the tip) occupies few pixel pairs, so the
/// median sees noise only. Saturated pairs are skipped.
pub fn estimate_noise_sigma(frame: &Frame) -> f64 {
    let (w, h) = (frame.width(), frame.height());
    if w < 2 {
        return MIN_NOISE_COUNTS;
    }
    let sat = frame.max_count();
    let step = (h / 256).max(1);
    let px = frame.pixels();
    // Every pair's difference, or +inf for a pair with a saturated, zero or
    // non-finite pixel: no branch and no compaction, so the loop
    // vectorises (half the time of pushing the kept pairs). The
    // infinities rank above every kept difference, so the median of the
    // kept ones is the value of rank kept / 2 among all.
    let mut diffs: Vec<f32> = Vec::with_capacity((h / step + 1) * (w - 1));
    for y in (0..h).step_by(step) {
        let row = &px[y * w..(y + 1) * w];
        diffs.extend(row[..w - 1].iter().zip(&row[1..]).map(|(&a, &b)| {
            let kept = (a < sat) & (b < sat) & (a > 0.0) & (b > 0.0);
            if kept { (b - a).abs() } else { f32::INFINITY }
        }));
    }
    let kept = diffs.iter().filter(|d| d.is_finite()).count();
    if kept == 0 {
        return MIN_NOISE_COUNTS;
    }
    let med = select_non_negative(&diffs, kept / 2);
    // |a-b| of two N(0, s^2) samples has median 0.6745 * sqrt(2) * s.
    let sigma = med as f64 / (0.674_49 * std::f64::consts::SQRT_2);
    sigma.max(MIN_NOISE_COUNTS)
}

/// The value of rank `rank` (0-based) among non-negative `values` (+inf included),
/// as `select_nth_unstable` would place it, by a two-pass radix select on the
/// bit patterns (for non-negative floats their order is the order of the
/// values): two histogram passes instead of quickselect's data-dependent
/// partitions, a third of the noise estimate's time on a 1024x1024 frame.
pub(crate) fn select_non_negative(values: &[f32], rank: usize) -> f32 {
    let mut hist = vec![0u32; 1 << 16];
    for v in values {
        hist[(v.to_bits() >> 16) as usize] += 1;
    }
    let (high, rank) = bin_of_rank(&hist, rank);
    hist.fill(0);
    for v in values {
        let b = v.to_bits();
        if b >> 16 == high {
            hist[(b & 0xffff) as usize] += 1;
        }
    }
    let (low, _) = bin_of_rank(&hist, rank);
    f32::from_bits((high << 16) | low)
}

/// The histogram bin holding rank `rank`, and the rank within that bin.
fn bin_of_rank(hist: &[u32], mut rank: usize) -> (u32, usize) {
    for (bin, &n) in hist.iter().enumerate() {
        if rank < n as usize {
            return (bin as u32, rank);
        }
        rank -= n as usize;
    }
    (hist.len() as u32 - 1, 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn radix_select_equals_quickselect() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = Normal::new(0.0f64, 30.0).unwrap();
        for len in [1usize, 2, 7, 1000, 4097] {
            // Rounded values repeat (as integer counts do), plus exact zeros.
            let v: Vec<f32> = (0..len)
                .map(|i| {
                    if i % 9 == 0 {
                        0.0
                    } else {
                        (n.sample(&mut rng) as f32).abs().round() / 4.0
                    }
                })
                .collect();
            for rank in [0, len / 2, len - 1] {
                let mut sorted = v.clone();
                let want = *sorted.select_nth_unstable_by(rank, |a, b| a.total_cmp(b)).1;
                assert_eq!(select_non_negative(&v, rank), want, "len {len} rank {rank}");
            }
        }
    }

    /// Pairs with a saturated, zero or non-finite pixel are left out: the
    /// estimate is the median of the other pairs' differences, as a plain
    /// filter and sort gives it.
    #[test]
    fn saturated_and_zero_pairs_are_left_out_of_the_median() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let n = Normal::new(3000.0f64, 40.0).unwrap();
        let (w, h) = (300, 40);
        let mut px: Vec<f32> = (0..w * h)
            .map(|_| n.sample(&mut rng).round() as f32)
            .collect();
        // A saturated blob, dead pixels and a bright streak of small steps
        // (which would pull the median down were they counted).
        for (i, p) in px.iter_mut().enumerate() {
            match i % 7 {
                0 => *p = 65535.0,
                3 if i % 2 == 0 => *p = 0.0,
                _ => {}
            }
        }
        let f = Frame::new(w, h, px.clone(), 16).unwrap();
        let mut kept: Vec<f32> = px
            .chunks(w)
            .flat_map(|row| row.windows(2))
            .filter(|p| p.iter().all(|&v| v > 0.0 && v < 65535.0))
            .map(|p| (p[1] - p[0]).abs())
            .collect();
        let rank = kept.len() / 2;
        let median = *kept.select_nth_unstable_by(rank, |a, b| a.total_cmp(b)).1;
        let want = (median as f64 / (0.674_49 * std::f64::consts::SQRT_2)).max(MIN_NOISE_COUNTS);
        assert_eq!(estimate_noise_sigma(&f), want);
        assert!((want / 40.0 - 1.0).abs() < 0.1, "sigma {want}");
    }

    #[test]
    fn recovers_gaussian_sigma_and_floors_flat_frames() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = Normal::new(1000.0f64, 12.0).unwrap();
        let px: Vec<f32> = (0..200 * 150).map(|_| n.sample(&mut rng) as f32).collect();
        let f = Frame::new(200, 150, px, 16).unwrap();
        let s = estimate_noise_sigma(&f);
        assert!((s / 12.0 - 1.0).abs() < 0.05, "sigma {s}");
        let flat = Frame::new(10, 10, vec![0.0; 100], 8).unwrap();
        assert_eq!(estimate_noise_sigma(&flat), MIN_NOISE_COUNTS);
    }
}
