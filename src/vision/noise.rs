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
    let mut diffs: Vec<f32> = Vec::with_capacity((h / step + 1) * w);
    let px = frame.pixels();
    for y in (0..h).step_by(step) {
        let row = &px[y * w..(y + 1) * w];
        for pair in row.windows(2) {
            if pair[0] < sat && pair[1] < sat && pair[0] > 0.0 && pair[1] > 0.0 {
                diffs.push((pair[1] - pair[0]).abs());
            }
        }
    }
    if diffs.is_empty() {
        return MIN_NOISE_COUNTS;
    }
    let med = select_non_negative(&diffs, diffs.len() / 2);
    // |a-b| of two N(0, s^2) samples has median 0.6745 * sqrt(2) * s.
    let sigma = med as f64 / (0.674_49 * std::f64::consts::SQRT_2);
    sigma.max(MIN_NOISE_COUNTS)
}

/// The value of rank `rank` (0-based) among non-negative finite `values`,
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
