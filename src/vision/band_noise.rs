//! The band-pass's noise measured on the background between the particles
//! found, for noise the white estimate misses.
//!
//! Detection thresholds are in units of noise, and the white estimate
//! ([`super::noise::estimate_noise_sigma`], from neighbouring pixels) takes
//! the noise as independent from pixel to pixel. A lossy codec (JPEG, MJPG,
//! mp4) smooths that pixel noise away and leaves blocks a few pixels
//! across; a real background has out-of-focus texture. Both pass the
//! band-pass at a particle's scale, and in units of the white estimate
//! they were particles: the real bright-field frame saved as a JPEG of
//! quality 50 gave 35 for its 5, a synthetic frame of 40 gave 60-65.

use super::noise::select_non_negative;

/// Band-pass noise on the background above this many times the white
/// estimate's (in standard deviations) is correlated noise, and detection
/// runs again at its level. Synthetic frames of white noise measure
/// 1.00-1.31 (16- and 8-bit, SNR 4-20), so they are searched once; a field
/// crowded as the CMU scenes (60 particles of 10 um in 120 x 100 um) has too
/// little background to measure, and is searched once too.
pub const CORRELATED_NOISE_RATIO: f64 = 1.5;

/// Fewest background pixel pairs a measurement stands on.
const MIN_PAIRS: usize = 1000;

/// A disc to leave out of the background: centre x, y and radius, pixels.
pub type Disc = (f64, f64, f64);

/// Robust variance of the band-passed frame `values` (`w` x `h`) outside
/// `discs`, or `None` when fewer than 1,000 pairs are clear (`MIN_PAIRS`).
///
/// It is measured on differences of values `lag` pixels apart along a row
/// (median absolute difference, scaled for a Gaussian, halved for the
/// difference of two): a difference cancels the band-pass's local offset
/// between crowded particles (their light in its background mean), and a
/// lag of a particle's diameter sees noise correlated over that scale. A
/// sample of rows, as the white estimate reads.
pub fn background_band_var(
    values: &[f32],
    (w, h): (usize, usize),
    discs: &[Disc],
    lag: usize,
) -> Option<f64> {
    if lag == 0 || w <= lag {
        return None;
    }
    let step = (h / 256).max(1);
    let mut clear = vec![true; w];
    let mut diffs: Vec<f32> = Vec::with_capacity((h / step + 1) * (w - lag));
    for y in (0..h).step_by(step) {
        clear.fill(true);
        for &(cx, cy, r) in discs {
            let dy = y as f64 - cy;
            if dy.abs() >= r {
                continue;
            }
            let half = (r * r - dy * dy).sqrt();
            let from = (cx - half).floor().max(0.0) as usize;
            let to = ((cx + half).ceil().max(0.0) as usize).min(w - 1);
            if from <= to {
                clear[from..=to].fill(false);
            }
        }
        let row = &values[y * w..(y + 1) * w];
        diffs.extend(
            (0..w - lag)
                .filter(|&x| clear[x] && clear[x + lag])
                .map(|x| (row[x + lag] - row[x]).abs())
                .filter(|d| d.is_finite()),
        );
    }
    if diffs.len() < MIN_PAIRS {
        return None;
    }
    let rank = diffs.len() / 2;
    let sd = select_non_negative(&diffs, rank) as f64 / (0.674_49 * std::f64::consts::SQRT_2);
    Some(sd * sd)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn white(w: usize, h: usize, sd: f64, seed: u64) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = Normal::new(0.0, sd).unwrap();
        (0..w * h).map(|_| n.sample(&mut rng) as f32).collect()
    }

    #[test]
    fn white_noise_measures_its_own_variance() {
        let v = white(400, 300, 2.0, 1);
        let var = background_band_var(&v, (400, 300), &[], 5).unwrap();
        assert!((var.sqrt() / 2.0 - 1.0).abs() < 0.03, "{}", var.sqrt());
    }

    #[test]
    fn particles_discs_are_left_out_and_an_offset_cancels() {
        // Bright discs of 40 times the noise, 10 px in radius every 25 px
        // (half the frame), on a ramp of offsets: left out, the noise is
        // measured as if neither were there.
        let (w, h) = (400, 300);
        let discs: Vec<Disc> = (0..16)
            .flat_map(|i| (0..12).map(move |j| (12.5 + 25.0 * i as f64, 12.5 + 25.0 * j as f64)))
            .map(|(x, y)| (x, y, 11.0))
            .collect();
        let mut v = white(w, h, 1.0, 2);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                v[i] += 0.01 * x as f32;
                if discs
                    .iter()
                    .any(|d| (x as f64 - d.0).hypot(y as f64 - d.1) < 10.0)
                {
                    v[i] += 40.0;
                }
            }
        }
        let var = background_band_var(&v, (w, h), &discs, 5).unwrap();
        assert!((var.sqrt() - 1.0).abs() < 0.05, "{}", var.sqrt());
        let seen = background_band_var(&v, (w, h), &[], 5).unwrap();
        assert!(
            seen.sqrt() > 1.3,
            "the discs count when not left out: {}",
            seen.sqrt()
        );
    }

    #[test]
    fn noise_correlated_over_blocks_measures_above_the_pixel_noise() {
        // Blocks of 8 pixels of one value each: neighbours differ within a
        // block by nothing, but values half a particle apart do.
        let (w, h): (usize, usize) = (400, 300);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let blocks: Vec<f32> = (0..(w / 8) * h.div_ceil(8))
            .map(|_| rng.random_range(-2.0..2.0))
            .collect();
        let v: Vec<f32> = (0..w * h)
            .map(|i| blocks[(i / w / 8) * (w / 8) + (i % w) / 8])
            .collect();
        let near = background_band_var(&v, (w, h), &[], 1).unwrap();
        let half = background_band_var(&v, (w, h), &[], 8).unwrap();
        assert!(near < 0.1 * half, "lag 1 {near}, lag 8 {half}");
    }

    #[test]
    fn too_few_clear_pixels_measure_nothing() {
        let v = white(100, 100, 1.0, 4);
        assert!(background_band_var(&v, (100, 100), &[(50.0, 50.0, 80.0)], 5).is_none());
        assert!(background_band_var(&v, (4, 100), &[], 5).is_none());
    }
}
