//! Camera noise: photon shot noise (Poisson), read noise (Gaussian), gain,
//! offset and quantisation to the camera's bit depth.

use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Poisson};

/// How the camera turns photo-electrons into counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraNoise {
    /// Read noise, electrons RMS.
    pub read_noise_e: f64,
    /// Counts per electron.
    pub gain_counts_per_e: f64,
    /// Dark offset in counts, keeps read noise from clipping at zero.
    pub offset_counts: f64,
    /// Bits per sample (8 or 16); counts saturate at 2^bits - 1.
    pub bit_depth: u8,
}

impl CameraNoise {
    /// Largest count the camera outputs.
    pub fn max_count(&self) -> f64 {
        ((1u32 << self.bit_depth.clamp(1, 16)) - 1) as f64
    }

    /// One noisy, quantised reading of a pixel whose mean is `mean_e` electrons.
    pub fn sample(&self, mean_e: f64, rng: &mut ChaCha8Rng) -> f32 {
        let shot = if mean_e > 0.0 {
            Poisson::new(mean_e).map(|p| p.sample(rng)).unwrap_or(0.0)
        } else {
            0.0
        };
        let read = if self.read_noise_e > 0.0 {
            Normal::new(0.0, self.read_noise_e)
                .map(|n| n.sample(rng))
                .unwrap_or(0.0)
        } else {
            0.0
        };
        let counts = self.offset_counts + self.gain_counts_per_e * (shot + read);
        counts.round().clamp(0.0, self.max_count()) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn mean_and_variance_follow_poisson_plus_read() {
        let cam = CameraNoise {
            read_noise_e: 3.0,
            gain_counts_per_e: 1.0,
            offset_counts: 100.0,
            bit_depth: 16,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let n = 20000;
        let xs: Vec<f64> = (0..n).map(|_| cam.sample(400.0, &mut rng) as f64).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        assert!((mean - 500.0).abs() < 0.5, "mean {mean}");
        // 400 shot + 9 read + 1/12 quantisation; 3 % tolerance ~ 3 standard errors.
        assert!((var / 409.08 - 1.0).abs() < 0.03, "var {var}");
    }
}
