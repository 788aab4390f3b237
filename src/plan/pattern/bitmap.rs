//! Bitmap patterns: every dark pixel (luma < 128) of an image is a site, one
//! pixel = one pitch; image rows go down the page.

use super::{Pattern, PatternError};
use crate::plan::value_sign::Sign;
use nalgebra::Vector2;
use std::path::Path;

/// Sites of a luma image at `pitch_m`.
pub fn pattern_from_image(
    img: &image::GrayImage,
    pitch_m: f64,
    origin: &str,
) -> Result<Pattern, PatternError> {
    super::check_value("pitch_um", pitch_m * 1e6, Sign::Positive)?;
    let offsets = img
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0[0] < 128)
        .map(|(x, y, _)| Vector2::new(x as f64 * pitch_m, -(y as f64) * pitch_m))
        .collect();
    Pattern::from_offsets(offsets, &format!("{origin} has no dark pixel"))
}

/// Reads an image file as a bitmap pattern.
pub fn read_bitmap(path: &Path, pitch_m: f64) -> Result<Pattern, PatternError> {
    let origin = path.display().to_string();
    let img = image::open(path)
        .map_err(|e| PatternError::File {
            path: origin.clone(),
            message: e.to_string(),
        })?
        .to_luma8();
    pattern_from_image(&img, pitch_m, &origin)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dark_pixels_become_sites() {
        let mut img = image::GrayImage::from_pixel(4, 3, image::Luma([255]));
        img.put_pixel(0, 0, image::Luma([0]));
        img.put_pixel(3, 2, image::Luma([10]));
        let p = pattern_from_image(&img, 10e-6, "mem").unwrap();
        assert_eq!(p.offsets_m.len(), 2);
        assert!((p.extent_m() - Vector2::new(30e-6, 20e-6)).norm() < 1e-15);
        let blank = image::GrayImage::from_pixel(2, 2, image::Luma([255]));
        assert!(matches!(
            pattern_from_image(&blank, 10e-6, "b"),
            Err(PatternError::Empty(_))
        ));
    }
}
