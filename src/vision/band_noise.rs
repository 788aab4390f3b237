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

/// Which part of the differences' distribution the noise is read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reading {
    /// The median: robust to half the pairs being structure.
    Median,
    /// The 95th percentile, for a frame without pixel noise (its white
    /// estimate at the quantisation floor): a heavily quantised JPEG
    /// (quality 45 and below) flattens whole blocks, so most differences
    /// are zero and the median reads a tenth of the clean frame's noise
    /// (quality 20), while the blocks' steps, the noise that makes
    /// phantoms, are the tail. It stands only while under 5 % of the pairs
    /// are structure: a probe not left out (`detect_particles` without its
    /// silhouette) read the loop's simulated frames 3 to 6 times too noisy
    /// and lost particles, so it is kept to frames that need it.
    Tail,
}

impl Reading {
    /// The quantile, and the standard normal quantile that scales it to a
    /// standard deviation (|d| of a Gaussian exceeds it that often).
    fn quantile(self) -> (f64, f64) {
        match self {
            Reading::Median => (0.5, 0.674_49),
            Reading::Tail => (0.95, 1.959_96),
        }
    }
}

/// Fewest background pixel pairs a measurement stands on.
const MIN_PAIRS: usize = 1000;

/// A disc to leave out of the background: centre x, y and radius, pixels.
pub type Disc = (f64, f64, f64);

/// Robust variance of the band-passed frame `values` (`w` x `h`) outside
/// `discs` and where `excluded` does not hold (the probe's silhouette and
/// shadow, whose edges are the largest steps of a frame: on the loop's
/// simulated frames they alone read the noise 3 to 6 times too high), or
/// `None` when fewer than 1,000 pairs are clear (`MIN_PAIRS`).
///
/// It is measured on differences of values `lag` pixels apart along a row
/// (their median or 95th percentile, `reading`, scaled for a Gaussian,
/// halved for the difference of two): a difference cancels the band-pass's local offset
/// between crowded particles (their light in its background mean), and a
/// lag of a particle's diameter sees noise correlated over that scale. A
/// sample of rows, as the white estimate reads.
pub fn background_band_var(
    values: &[f32],
    (w, h): (usize, usize),
    discs: &[Disc],
    excluded: &dyn Fn(f64, f64) -> bool,
    lag: usize,
    reading: Reading,
) -> Option<f64> {
    if lag == 0 || w <= lag {
        return None;
    }
    let step = (h / 256).max(1);
    let left_out = ExcludedCells::of(excluded, (w, h));
    let mut clear = vec![true; w];
    let mut diffs: Vec<f32> = Vec::with_capacity((h / step + 1) * (w - lag));
    for y in (0..h).step_by(step) {
        clear.fill(true);
        left_out.mark_row(y, &mut clear);
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
    let (quantile, z) = reading.quantile();
    let rank = ((diffs.len() as f64 * quantile) as usize).min(diffs.len() - 1);
    let sd = select_non_negative(&diffs, rank) as f64 / (z * std::f64::consts::SQRT_2);
    Some(sd * sd)
}

/// Side of the cells `excluded` is asked about, pixels: the probe's
/// silhouette and shadow are tens of pixels wide.
const EXCLUDED_CELL_PX: usize = 8;

/// Where a caller's `excluded` holds (the probe and its shadow), on a grid
/// of [`EXCLUDED_CELL_PX`] cells asked at their centres, each marked cell
/// grown by one cell all round (a thin part between centres is not missed).
struct ExcludedCells {
    columns: usize,
    rows: usize,
    marked: Vec<bool>,
}

impl ExcludedCells {
    fn of(excluded: &dyn Fn(f64, f64) -> bool, (w, h): (usize, usize)) -> Self {
        let (columns, rows) = (w.div_ceil(EXCLUDED_CELL_PX), h.div_ceil(EXCLUDED_CELL_PX));
        let centre = |k: usize| (k * EXCLUDED_CELL_PX) as f64 + 0.5 * EXCLUDED_CELL_PX as f64;
        let hit: Vec<bool> = (0..rows * columns)
            .map(|k| excluded(centre(k % columns), centre(k / columns)))
            .collect();
        let mut marked = vec![false; rows * columns];
        for (k, _) in hit.iter().enumerate().filter(|(_, h)| **h) {
            let (i, j) = (k % columns, k / columns);
            for jj in j.saturating_sub(1)..(j + 2).min(rows) {
                for ii in i.saturating_sub(1)..(i + 2).min(columns) {
                    marked[jj * columns + ii] = true;
                }
            }
        }
        Self {
            columns,
            rows,
            marked,
        }
    }

    /// Marks row `y`'s excluded pixels not clear.
    fn mark_row(&self, y: usize, clear: &mut [bool]) {
        let j = (y / EXCLUDED_CELL_PX).min(self.rows - 1);
        for i in 0..self.columns {
            if self.marked[j * self.columns + i] {
                let from = i * EXCLUDED_CELL_PX;
                let to = (from + EXCLUDED_CELL_PX).min(clear.len());
                clear[from..to].fill(false);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A `w` x `h` frame of 8 x 8 blocks, each of one value from `value`
    /// (drawn row of blocks by row of blocks).
    fn blocks_of_8(w: usize, h: usize, mut value: impl FnMut() -> f32) -> Vec<f32> {
        let blocks: Vec<f32> = (0..(w / 8) * h.div_ceil(8)).map(|_| value()).collect();
        (0..w * h)
            .map(|i| blocks[(i / w / 8) * (w / 8) + (i % w) / 8])
            .collect()
    }

    fn white(w: usize, h: usize, sd: f64, seed: u64) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = Normal::new(0.0, sd).unwrap();
        (0..w * h).map(|_| n.sample(&mut rng) as f32).collect()
    }

    #[test]
    fn white_noise_measures_its_own_variance() {
        let v = white(400, 300, 2.0, 1);
        let var =
            background_band_var(&v, (400, 300), &[], &|_, _| false, 5, Reading::Median).unwrap();
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
        let var =
            background_band_var(&v, (w, h), &discs, &|_, _| false, 5, Reading::Median).unwrap();
        assert!((var.sqrt() - 1.0).abs() < 0.05, "{}", var.sqrt());
        let seen = background_band_var(&v, (w, h), &[], &|_, _| false, 5, Reading::Median).unwrap();
        assert!(
            seen.sqrt() > 1.3,
            "the discs count when not left out: {}",
            seen.sqrt()
        );
    }

    #[test]
    fn noise_correlated_over_blocks_measures_above_the_pixel_noise() {
        // Blocks of 8 pixels of one value each (uniform in -2..2, sd 1.155):
        // neighbours differ only across a block's edge, values 8 apart
        // always, and read the blocks' own spread (3 % under, for the
        // difference of two uniforms is not a Gaussian).
        let (w, h): (usize, usize) = (400, 300);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let v = blocks_of_8(w, h, || rng.random_range(-2.0..2.0));
        let near = background_band_var(&v, (w, h), &[], &|_, _| false, 1, Reading::Median)
            .unwrap()
            .sqrt();
        let apart = background_band_var(&v, (w, h), &[], &|_, _| false, 8, Reading::Median)
            .unwrap()
            .sqrt();
        assert!((apart / 1.155 - 1.0).abs() < 0.1, "lag 8: {apart}");
        assert!(near < 0.6 * apart, "lag 1 {near}, lag 8 {apart}");
    }

    #[test]
    fn blocks_mostly_flat_are_measured_by_their_steps() {
        // Four blocks in five flat at 0, the fifth at +-3: most differences
        // are zero (their median would read no noise at all), the steps
        // are what a threshold must stand above.
        let (w, h): (usize, usize) = (400, 304);
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let v = blocks_of_8(w, h, || match rng.random_range(0..10) {
            0 => 3.0,
            1 => -3.0,
            _ => 0.0,
        });
        let read = |reading| {
            background_band_var(&v, (w, h), &[], &|_, _| false, 8, reading)
                .unwrap()
                .sqrt()
        };
        let (tail, median) = (read(Reading::Tail), read(Reading::Median));
        assert!(tail > 1.0 && median < 0.1, "tail {tail}, median {median}");
    }

    #[test]
    fn an_excluded_region_is_left_out() {
        // Five dark bars of 100 times the noise, 20 px wide every 80 px, as
        // a probe's silhouette: excluded with 10 px to spare, the noise
        // reads as if they were not there.
        let (w, h) = (400, 300);
        let bar_at = |x: f64, margin: f64| {
            (0..5).any(|k| {
                let left = 40.0 + 80.0 * k as f64;
                x >= left - margin && x < left + 20.0 + margin
            })
        };
        let mut v = white(w, h, 1.0, 7);
        for y in 20..280 {
            for x in 0..w {
                if bar_at(x as f64, 0.0) {
                    v[y * w + x] -= 100.0;
                }
            }
        }
        let bars = |x: f64, y: f64| (10.0..290.0).contains(&y) && bar_at(x, 10.0);
        let var = background_band_var(&v, (w, h), &[], &bars, 5, Reading::Tail).unwrap();
        assert!((var.sqrt() - 1.0).abs() < 0.05, "{}", var.sqrt());
        let seen = background_band_var(&v, (w, h), &[], &|_, _| false, 5, Reading::Tail).unwrap();
        assert!(
            seen.sqrt() > 1.5,
            "the bars count when not left out: {}",
            seen.sqrt()
        );
    }

    #[test]
    fn too_few_clear_pixels_measure_nothing() {
        let v = white(100, 100, 1.0, 4);
        assert!(
            background_band_var(
                &v,
                (100, 100),
                &[(50.0, 50.0, 80.0)],
                &|_, _| false,
                5,
                Reading::Median
            )
            .is_none()
        );
        assert!(
            background_band_var(&v, (4, 100), &[], &|_, _| false, 5, Reading::Median).is_none()
        );
    }
}
