//! Frames whose samples are not 8- or 16-bit camera counts: 32-bit float or
//! integer, signed 16-bit (ImageJ's "32-bit" TIFFs, background-subtracted or
//! normalised exports).
//!
//! Such a frame is mapped, per frame and affinely, onto 16-bit counts: its
//! darkest pixel to [`WIDE_FLOOR`], its brightest to 65535 - [`WIDE_FLOOR`],
//! rounded. Why: every detection threshold is in units of the frame's
//! measured noise, so the scale does not matter, but the pipeline takes 0 and
//! the full count as clipped, and its noise floor is a quantisation step of
//! one count; a 0..1 float frame would be all "quantisation noise" and a
//! background-subtracted one half "clipped". After the map the frame is an
//! ordinary 16-bit frame: written to a recording as PNG and read back equal.
//! The source's own saturation, if it had one, is not known and not flagged.

use super::frame::{Frame, FrameError};

/// Counts kept free at both ends of the 16-bit range, so no mapped pixel
/// reads as clipped (0) or saturated (65535).
pub const WIDE_FLOOR: f32 = 64.0;

/// Bit depth of a mapped frame.
const MAPPED_BITS: u8 = 16;

/// Maps row-major wide samples onto 16-bit counts (see the module docs). A
/// flat frame maps to the floor. A NaN or infinite sample is refused by its
/// index (ImageJ writes NaN for masked pixels: the frame is then not a
/// camera's).
pub fn frame_from_wide(width: usize, height: usize, samples: &[f32]) -> Result<Frame, FrameError> {
    if let Some(index) = samples.iter().position(|v| !v.is_finite()) {
        return Err(FrameError::NotFinite { index });
    }
    let lo = samples.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = samples.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    // In f64: a span of f32::MAX minus f32::MIN overflows f32.
    let span = f64::from(hi) - f64::from(lo);
    let scale = if span > 0.0 {
        (65535.0 - 2.0 * f64::from(WIDE_FLOOR)) / span
    } else {
        0.0
    };
    let counts = samples
        .iter()
        .map(|&v| (f64::from(WIDE_FLOOR) + (f64::from(v) - f64::from(lo)) * scale).round() as f32)
        .collect();
    Frame::new(width, height, counts, MAPPED_BITS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn darkest_and_brightest_land_inside_the_16_bit_range_in_order() {
        let samples = [-0.5f32, 0.0, 0.25, 1.5];
        let f = frame_from_wide(2, 2, &samples).unwrap();
        assert_eq!(f.bit_depth(), 16);
        assert_eq!(f.at(0, 0), WIDE_FLOOR);
        assert_eq!(f.at(1, 1), 65535.0 - WIDE_FLOOR);
        // Affine: 0.0 is a quarter of the way from -0.5 to 1.5.
        let quarter = WIDE_FLOOR + 0.25 * (65535.0 - 2.0 * WIDE_FLOOR);
        assert!((f.at(1, 0) - quarter).abs() <= 0.5, "{}", f.at(1, 0));
        assert!(f.at(1, 0) < f.at(0, 1));
    }

    #[test]
    fn extreme_and_flat_frames_map_without_overflow() {
        let f = frame_from_wide(2, 1, &[f32::MIN, f32::MAX]).unwrap();
        assert_eq!(f.pixels(), &[WIDE_FLOOR, 65535.0 - WIDE_FLOOR]);
        let flat = frame_from_wide(3, 1, &[7.5; 3]).unwrap();
        assert_eq!(flat.pixels(), &[WIDE_FLOOR; 3]);
    }

    #[test]
    fn a_nan_sample_is_refused_by_its_index() {
        assert_eq!(
            frame_from_wide(2, 1, &[0.0, f32::NAN]),
            Err(FrameError::NotFinite { index: 1 })
        );
    }
}
