//! A 16-bit image file often holds a 10-, 12- or 14-bit camera's counts,
//! either as they are (the top value 4095 for 12 bits) or shifted up to the
//! file's top bits (every count a multiple of 16). The camera's full count
//! is then below the file's 65535, and pixels clipped there were neither
//! censored by the fits nor warned of: a 12-bit frame of the bench scene
//! with 73 % of its pixels at 4095 gave no warning and 11 of 30 particles,
//! where the same frame in 16 bits warned and gave 30.

use super::frame::Frame;
use super::wide_samples::bright_clip_level;

/// Camera bit depths a 16-bit file may carry, narrowest first.
const CAMERA_BITS: [u8; 3] = [10, 12, 14];

/// `frame` at its camera's bit depth: a 16-bit frame whose counts are all
/// multiples of 4 or 16 is shifted down by 2 or 4 bits (14 or 12 bits);
/// one whose top value is a clip level (as a wide frame's source clipping
/// is told, `wide_samples`) at 2^b - 1 (b = 10, 12, 14) is b bits.
/// Anything else, and frames of another depth, as they are.
pub fn at_camera_bits(frame: Frame) -> Frame {
    if frame.bit_depth() != 16 {
        return frame;
    }
    let px = frame.pixels();
    let top = px.iter().copied().fold(0.0f32, f32::max);
    if top <= 0.0 {
        return frame;
    }
    let shifted = [4u8, 2].into_iter().find(|&s| {
        let step = (1u32 << s) as f32;
        px.iter().all(|&v| v % step == 0.0)
    });
    let (pixels, bits) = match shifted {
        Some(s) => {
            let step = (1u32 << s) as f32;
            (px.iter().map(|&v| v / step).collect(), 16 - s)
        }
        None => match CAMERA_BITS
            .into_iter()
            .find(|&b| top == ((1u32 << b) - 1) as f32 && bright_clip_level(px) == Some(top))
        {
            Some(b) => (px.to_vec(), b),
            None => return frame,
        },
    };
    Frame::new(frame.width(), frame.height(), pixels, bits).unwrap_or(frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp of 12-bit counts, the top `clipped` pixels at 4095.
    fn twelve_bit(clipped: usize) -> Vec<f32> {
        (0..4000)
            .map(|i| {
                if i < clipped {
                    4095.0
                } else {
                    (i % 4000) as f32
                }
            })
            .collect()
    }

    #[test]
    fn a_clipped_twelve_bit_frame_is_twelve_bits_as_counts_or_shifted_up() {
        let lsb = Frame::new(100, 40, twelve_bit(500), 16).unwrap();
        let f = at_camera_bits(lsb.clone());
        assert_eq!((f.bit_depth(), f.max_count()), (12, 4095.0));
        assert_eq!(f.pixels(), lsb.pixels());
        let msb: Vec<f32> = twelve_bit(500).iter().map(|v| v * 16.0).collect();
        let f = at_camera_bits(Frame::new(100, 40, msb, 16).unwrap());
        assert_eq!((f.bit_depth(), f.max_count()), (12, 4095.0));
        assert_eq!(f.pixels(), lsb.pixels());
    }

    #[test]
    fn a_sixteen_bit_frame_or_an_unclipped_top_stays_as_it_is() {
        // A top value held by a few pixels is a tail, not a clip level.
        let few = Frame::new(100, 40, twelve_bit(3), 16).unwrap();
        assert_eq!(at_camera_bits(few).bit_depth(), 16);
        // Odd counts up to 65535: a 16-bit camera's.
        let wide: Vec<f32> = (0..4000).map(|i| (i * 16 + 1) as f32).collect();
        assert_eq!(
            at_camera_bits(Frame::new(100, 40, wide, 16).unwrap()).bit_depth(),
            16
        );
        // Dark and 8-bit frames are left alone.
        let dark = Frame::new(10, 10, vec![0.0; 100], 16).unwrap();
        assert_eq!(at_camera_bits(dark).bit_depth(), 16);
        let eight = Frame::new(10, 10, vec![255.0; 100], 8).unwrap();
        assert_eq!(at_camera_bits(eight).bit_depth(), 8);
    }
}
