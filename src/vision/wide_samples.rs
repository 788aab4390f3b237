//! Frames whose samples are not 8- or 16-bit camera counts: 32-bit float or
//! integer, signed 16-bit (ImageJ's "32-bit" TIFFs, background-subtracted or
//! normalised exports).
//!
//! Such a frame is mapped, per frame and affinely, onto 16-bit counts: the
//! range between its [`OUTLIER_FRACTION`] darkest and brightest pixels (of
//! a strided sample of at most [`RANKED_SAMPLES`] pixels) onto
//! [`INLIER_COUNTS`], rounded, and whatever falls beyond 0 or 65535 clipped
//! there. Why a map: every detection threshold is in units of the frame's
//! measured noise, so the scale does not matter, but the pipeline takes 0
//! and the full count as clipped, and its noise floor is a quantisation
//! step of one count: a 0..1 float frame would be all "quantisation noise"
//! and a background-subtracted one half "clipped". Why a robust range: a
//! hot or dead pixel of a scientific camera, 1000 times the frame's range,
//! would squeeze the rest into 65 counts (centres 0.03 px off, about the
//! Cramer-Rao bound); it now clips and reads as clipped, as on the camera
//! itself. Why these counts: a quarter of the counts above keeps a
//! particle's core just brighter than the brightest 0.01 % unclipped, and
//! the dark end sits near zero as a camera's dark level does (the probe's
//! dark-region threshold is a fraction of the way from the darkest pixel to
//! the median: with the dark end at a quarter of the counts, a dead pixel
//! clipped to 0 moved that threshold below the probe, which was then not
//! found). After the map the frame is an ordinary 16-bit frame: written to
//! a recording as PNG and read back equal. The source's own clipping (a
//! level many pixels share at either end, `ClipLevels`) maps onto 0 or the
//! full count, so the pipeline reads those pixels as clipped: the profile
//! fit takes them as censored, not as values.

use super::frame::{Frame, FrameError, check_finite};

/// Counts the frame's robust range is mapped onto: 1/16 of the counts below
/// it, 1/4 above (see the module docs).
pub const INLIER_COUNTS: (f32, f32) = (4096.0, 49151.0);

/// Fraction of the pixels at either end of a wide frame's range left out of
/// its robust range (15 of a 384 x 384 frame, none of one under 10,000
/// pixels): they are mapped too, and clip only beyond the headroom.
pub const OUTLIER_FRACTION: f64 = 1e-4;

/// Bit depth of a mapped frame.
const MAPPED_BITS: u8 = 16;

/// Maps row-major wide samples onto 16-bit counts (see the module docs). A
/// flat frame maps to the dark end. A NaN or infinite sample is
/// refused by its place (ImageJ writes NaN for masked pixels: the frame is
/// then not a camera's).
pub fn frame_from_wide(width: usize, height: usize, samples: &[f32]) -> Result<Frame, FrameError> {
    // Before the map, which would turn a NaN into 0 counts.
    check_finite(samples, width)?;
    let (mut lo, mut hi) = robust_range(samples);
    let (mut floor, mut ceiling) = (f64::from(INLIER_COUNTS.0), f64::from(INLIER_COUNTS.1));
    // The source's own clipping becomes the frame's: its level maps onto 0
    // or the full count, which the pipeline reads as clipped.
    let clipped = ClipLevels::of(samples);
    if let Some(level) = clipped.bright {
        (hi, ceiling) = (f64::from(level), 65535.0);
    }
    if let Some(level) = clipped.dark {
        (lo, floor) = (f64::from(level), 0.0);
    }
    // count = offset + v * scale, the offset folded in f64 so that the f32
    // map never forms v - lo (f32::MAX - f32::MIN overflows).
    let scale = if hi > lo {
        (ceiling - floor) / (hi - lo)
    } else {
        0.0
    };
    let (offset, scale) = ((floor - lo * scale) as f32, scale as f32);
    // Rounded by adding a half and truncating (the value is clamped
    // non-negative first): the loop stays vectorised, where `round` is a call.
    let mut counts: Vec<f32> = samples
        .iter()
        .map(|&v| ((offset + v * scale).clamp(0.0, 65535.0) + 0.5) as u32 as f32)
        .collect();
    // The clip levels exactly at the ends, whatever the map's rounding.
    for (level, count) in [(clipped.dark, 0.0), (clipped.bright, 65535.0)] {
        if let Some(level) = level {
            for (c, &v) in counts.iter_mut().zip(samples) {
                if v == level {
                    *c = count;
                }
            }
        }
    }
    Frame::new(width, height, counts, MAPPED_BITS)
}

/// Fewest pixels that share a level for it to be the source's clipping.
const MIN_CLIPPED_PIXELS: usize = 8;

/// The samples' brightest value when it is a clip level ([`ClipLevels`]):
/// also how a 16-bit file shows its camera's narrower full count
/// (`camera_bits`).
pub(crate) fn bright_clip_level(samples: &[f32]) -> Option<f32> {
    ClipLevels::of(samples).bright
}

/// The source's own clip levels: the frame's brightest (darkest) value when
/// more pixels share it than the [`OUTLIER_FRACTION`] (so it bounds the
/// robust range itself), at least [`MIN_CLIPPED_PIXELS`], and more than
/// twice as many as the next value in. A camera's full count or black level
/// in a float or 32-bit export piles up so; a tail of noise thins out
/// towards its end, and a few hot pixels at one value stay outliers.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct ClipLevels {
    dark: Option<f32>,
    bright: Option<f32>,
}

impl ClipLevels {
    fn of(samples: &[f32]) -> Self {
        let none = Self::default();
        let ends = Ends::of(samples);
        if ends.min >= ends.max {
            return none;
        }
        let least = ((samples.len() as f64 * OUTLIER_FRACTION) as usize).max(MIN_CLIPPED_PIXELS);
        // Almost every frame ends here: neither end is shared widely.
        if (ends.at_min as usize) < least && (ends.at_max as usize) < least {
            return none;
        }
        // The next values in from either end, and how many pixels hold them.
        let inner: Vec<f32> = samples
            .iter()
            .copied()
            .filter(|&v| v > ends.min && v < ends.max)
            .collect();
        // Two levels and nothing between is a mask, not a clipped frame.
        if inner.is_empty() {
            return none;
        }
        let next = Ends::of(&inner);
        let plateau = |at_end: u32, next_in: u32| at_end as usize >= least && at_end > 2 * next_in;
        Self {
            dark: plateau(ends.at_min, next.at_min).then_some(ends.min),
            bright: plateau(ends.at_max, next.at_max).then_some(ends.max),
        }
    }
}

/// The smallest and largest sample and how many pixels hold each, found in
/// one pass of eight independent lanes (the loop vectorises: the map of a
/// 1024 x 1024 frame reads 4 MB a pass).
#[derive(Debug, Clone, Copy)]
struct Ends {
    min: f32,
    at_min: u32,
    max: f32,
    at_max: u32,
}

impl Ends {
    const EMPTY: Self = Self {
        min: f32::INFINITY,
        at_min: 0,
        max: f32::NEG_INFINITY,
        at_max: 0,
    };

    fn of(samples: &[f32]) -> Self {
        // Lanes as separate arrays (not eight structs), so each update is
        // one vector instruction over the eight.
        let (mut min, mut at_min) = ([f32::INFINITY; 8], [0u32; 8]);
        let (mut max, mut at_max) = ([f32::NEG_INFINITY; 8], [0u32; 8]);
        let chunks = samples.chunks_exact(8);
        let tail = chunks.remainder();
        for chunk in chunks {
            for l in 0..8 {
                let v = chunk[l];
                at_min[l] = if v < min[l] {
                    1
                } else {
                    at_min[l] + u32::from(v == min[l])
                };
                min[l] = if v < min[l] { v } else { min[l] };
                at_max[l] = if v > max[l] {
                    1
                } else {
                    at_max[l] + u32::from(v == max[l])
                };
                max[l] = if v > max[l] { v } else { max[l] };
            }
        }
        let mut out = Self::EMPTY;
        for &v in tail {
            out = out.merge(&Self {
                min: v,
                at_min: 1,
                max: v,
                at_max: 1,
            });
        }
        (0..8).fold(out, |a, l| {
            a.merge(&Self {
                min: min[l],
                at_min: at_min[l],
                max: max[l],
                at_max: at_max[l],
            })
        })
    }

    fn merge(self, other: &Self) -> Self {
        let join = |a: f32, na: u32, b: f32, nb: u32, first: bool| match (a == b, first) {
            (true, _) => (a, na + nb),
            (false, true) => (a, na),
            (false, false) => (b, nb),
        };
        let (min, at_min) = join(
            self.min,
            self.at_min,
            other.min,
            other.at_min,
            self.min < other.min,
        );
        let (max, at_max) = join(
            self.max,
            self.at_max,
            other.max,
            other.at_max,
            self.max > other.max,
        );
        Self {
            min,
            at_min,
            max,
            at_max,
        }
    }
}

/// Most samples the robust range is ranked from: a larger frame is sampled
/// with a fixed stride (ranking all of a 1024 x 1024 frame took 7.0 ms, as
/// long as detecting its particles; the range only sets a scale with a
/// quarter of the counts as headroom, so a sample's estimate does).
pub const RANKED_SAMPLES: usize = 1 << 16;

/// The darkest and brightest samples once the [`OUTLIER_FRACTION`] at
/// either end is set aside (of a strided sample of large frames).
fn robust_range(samples: &[f32]) -> (f64, f64) {
    if samples.is_empty() {
        return (0.0, 0.0);
    }
    let stride = samples.len().div_ceil(RANKED_SAMPLES);
    let mut ranked: Vec<f32> = samples.iter().step_by(stride).copied().collect();
    let n = ranked.len();
    let k = (n as f64 * OUTLIER_FRACTION) as usize;
    let lo = *ranked.select_nth_unstable_by(k, f32::total_cmp).1;
    let hi = *ranked.select_nth_unstable_by(n - 1 - k, f32::total_cmp).1;
    (f64::from(lo), f64::from(hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_frame_spans_the_inlier_counts_in_order() {
        let samples = [-0.5f32, 0.0, 0.25, 1.5];
        let f = frame_from_wide(2, 2, &samples).unwrap();
        assert_eq!(f.bit_depth(), 16);
        let (floor, ceiling) = INLIER_COUNTS;
        assert_eq!((f.at(0, 0), f.at(1, 1)), (floor, ceiling));
        // Affine: 0.0 is a quarter of the way from -0.5 to 1.5.
        let quarter = floor + 0.25 * (ceiling - floor);
        assert!((f.at(1, 0) - quarter).abs() <= 0.5, "{}", f.at(1, 0));
        assert!(f.at(1, 0) < f.at(0, 1));
    }

    #[test]
    fn extreme_and_flat_frames_map_without_overflow() {
        let f = frame_from_wide(2, 1, &[f32::MIN, f32::MAX]).unwrap();
        assert_eq!(f.pixels(), &[INLIER_COUNTS.0, INLIER_COUNTS.1]);
        let flat = frame_from_wide(3, 1, &[7.5; 3]).unwrap();
        assert_eq!(flat.pixels(), &[INLIER_COUNTS.0; 3]);
    }

    #[test]
    fn hot_and_dead_pixels_clip_and_the_rest_keeps_its_range() {
        // 20,000 pixels: the 2 most extreme at either end fall outside the
        // robust range; a slightly bright one keeps its headroom.
        let mut samples: Vec<f32> = (0..20_000).map(|i| (i % 100) as f32 * 0.01).collect();
        samples[5] = 1e4;
        samples[6] = -1e4;
        samples[7] = 1.2;
        let f = frame_from_wide(200, 100, &samples).unwrap();
        assert_eq!((f.pixels()[5], f.pixels()[6]), (65535.0, 0.0));
        let (floor, ceiling) = INLIER_COUNTS;
        let per_unit = (ceiling - floor) / 0.99;
        assert!((f.pixels()[7] - (floor + 1.2 * per_unit)).abs() <= 0.5);
        let inliers = f.pixels().iter().filter(|&&v| v > 0.0 && v < 65535.0);
        let (lo, hi) = inliers.fold((f32::INFINITY, 0.0f32), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
        assert_eq!((lo, hi), (floor, f.pixels()[7]));
    }

    /// A level many pixels share at an end is the source's clipping; the
    /// thinning tail of integer noise and a few hot pixels at one value are
    /// not.
    #[test]
    fn clip_levels_are_plateaus_at_the_ends_not_tails_or_hot_pixels() {
        // Integer counts, a triangular histogram: 1 pixel at 0 and at 200,
        // 100 at 100.
        let tail: Vec<f32> = (0..=200i32)
            .flat_map(|v| std::iter::repeat_n(v as f32, (100 - (v - 100).abs()).max(1) as usize))
            .collect();
        let none = ClipLevels::default();
        assert_eq!(ClipLevels::of(&tail), none);
        // The same clipped at 150 (the 50 values above piled up there) and
        // at 20 below.
        let clipped: Vec<f32> = tail.iter().map(|v| v.clamp(20.0, 150.0)).collect();
        let levels = ClipLevels::of(&clipped);
        assert_eq!(
            levels,
            ClipLevels {
                dark: Some(20.0),
                bright: Some(150.0)
            }
        );
        // Mapped: the clipped pixels at the ends, the rest strictly inside.
        let f = frame_from_wide(clipped.len(), 1, &clipped).unwrap();
        for (&v, &c) in clipped.iter().zip(f.pixels()) {
            match v {
                150.0 => assert_eq!(c, 65535.0),
                20.0 => assert_eq!(c, 0.0),
                _ => assert!(c > 0.0 && c < 65535.0, "{v} -> {c}"),
            }
        }
        // Nine hot pixels at one value, under the outlier fraction's 10 of
        // 100,000 pixels, stay outliers.
        let mut hot: Vec<f32> = (0..100_000).map(|i| (i % 1000) as f32 * 1e-3).collect();
        for v in hot.iter_mut().step_by(12_000) {
            *v = 500.0;
        }
        assert_eq!(ClipLevels::of(&hot).bright, None);
        // A flat frame has no ends, and a two-level mask no clipping.
        assert_eq!(ClipLevels::of(&[3.0; 50]), none);
        let mask: Vec<f32> = (0..100)
            .map(|i| if i % 3 == 0 { 1.0 } else { 0.0 })
            .collect();
        assert_eq!(ClipLevels::of(&mask), none);
    }

    #[test]
    fn a_nan_sample_is_refused_by_its_index() {
        assert_eq!(
            frame_from_wide(2, 1, &[0.0, f32::NAN]),
            Err(FrameError::NotFinite { x: 1, y: 0 })
        );
    }
}
