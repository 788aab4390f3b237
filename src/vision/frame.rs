//! A grey microscope frame in camera counts, the one image type every stage shares.
//!
//! Pixels are stored as `f32` counts (not rescaled), so thresholds derived from
//! the measured noise work the same for 8- and 16-bit cameras.

use thiserror::Error;

/// Ways a frame can be invalid.
#[derive(Debug, Error, PartialEq)]
pub enum FrameError {
    /// Width or height is zero.
    #[error("frame has zero size ({width}x{height})")]
    ZeroSize { width: usize, height: usize },
    /// The pixel buffer does not match width x height.
    #[error("frame buffer holds {got} pixels, {width}x{height} needs {expected}")]
    BufferSize {
        width: usize,
        height: usize,
        expected: usize,
        got: usize,
    },
    /// A pixel is NaN or infinite (image x right, y down).
    #[error("pixel ({x}, {y}) is not a finite value (NaN or infinite: a masked pixel?)")]
    NotFinite { x: usize, y: usize },
}

/// Fails on the first NaN or infinite sample of a row-major buffer `width`
/// wide, naming its place.
pub fn check_finite(samples: &[f32], width: usize) -> Result<(), FrameError> {
    match samples.iter().position(|p| !p.is_finite()) {
        None => Ok(()),
        Some(index) => Err(FrameError::NotFinite {
            x: index % width.max(1),
            y: index / width.max(1),
        }),
    }
}

/// A grey frame: row-major counts, pixel centres at integer coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    width: usize,
    height: usize,
    pixels: Vec<f32>,
    bit_depth: u8,
}

impl Frame {
    /// Wraps a row-major buffer; checks size and finiteness so later stages need not.
    pub fn new(
        width: usize,
        height: usize,
        pixels: Vec<f32>,
        bit_depth: u8,
    ) -> Result<Self, FrameError> {
        if width == 0 || height == 0 {
            return Err(FrameError::ZeroSize { width, height });
        }
        let expected = width * height;
        if pixels.len() != expected {
            return Err(FrameError::BufferSize {
                width,
                height,
                expected,
                got: pixels.len(),
            });
        }
        check_finite(&pixels, width)?;
        Ok(Self {
            width,
            height,
            pixels,
            bit_depth,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Bits per sample of the source (8 or 16, or the 10, 12 or 14 of a
    /// camera whose counts a 16-bit file holds, `camera_bits`); sets the
    /// saturation level.
    pub fn bit_depth(&self) -> u8 {
        self.bit_depth
    }

    /// Largest count the source can hold (255, 65535, or 4095 for a
    /// 12-bit camera's).
    pub fn max_count(&self) -> f32 {
        ((1u32 << self.bit_depth.min(31)) - 1) as f32
    }

    /// Row-major pixel counts.
    pub fn pixels(&self) -> &[f32] {
        &self.pixels
    }

    /// Count at integer pixel (x, y); the caller keeps it inside the frame.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.pixels[y * self.width + x]
    }
}

/// Fails, naming the first odd frame and the first one, unless every size
/// in `sizes` (width, height) is the first's: one camera, one pixel grid
/// (a recording's frames; a calibration's, where a crop's tip position
/// would bend the map). `name` gives frame k's name, asked only on failure.
pub fn check_one_size(
    sizes: &[(usize, usize)],
    name: impl Fn(usize) -> String,
) -> Result<(), String> {
    let Some(&first) = sizes.first() else {
        return Ok(());
    };
    match sizes.iter().position(|&s| s != first) {
        None => Ok(()),
        Some(i) => Err(not_one_size(&name(i), sizes[i], &name(0), first)),
    }
}

/// What is said of frame `name`, of `size`, in a recording whose first frame
/// `first_name` is `first_size` (width, height in pixels).
pub fn not_one_size(
    name: &str,
    size: (usize, usize),
    first_name: &str,
    first_size: (usize, usize),
) -> String {
    format!(
        "{name} is {}x{} px but {first_name} is {}x{} px: every frame of a recording must be one size",
        size.0, size.1, first_size.0, first_size.1
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_zero_size_wrong_buffer_and_nan() {
        assert!(matches!(
            Frame::new(0, 3, vec![], 8),
            Err(FrameError::ZeroSize { .. })
        ));
        assert!(matches!(
            Frame::new(2, 2, vec![0.0; 3], 8),
            Err(FrameError::BufferSize { got: 3, .. })
        ));
        assert_eq!(
            Frame::new(1, 2, vec![0.0, f32::NAN], 8),
            Err(FrameError::NotFinite { x: 0, y: 1 })
        );
        let f = Frame::new(2, 1, vec![1.0, 2.0], 16).unwrap();
        assert_eq!(f.at(1, 0), 2.0);
        assert_eq!(f.max_count(), 65535.0);
    }
}
