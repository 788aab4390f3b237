//! Bitmap patterns: every dark pixel (luma < 128) of an image is a site, one
//! pixel = one pitch; image rows go down the page. A transparent pixel is
//! paper, not ink: the image is seen over white.

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
    let img = image::open(path).map_err(|e| PatternError::File {
        path: origin.clone(),
        message: e.to_string(),
    })?;
    pattern_from_image(&over_white(&img), pitch_m, &origin)
}

/// The image's luma as seen over white paper: an "L" drawn on a transparent
/// background (pixels 0, 0, 0, 0) had given the whole rectangle as sites.
fn over_white(img: &image::DynamicImage) -> image::GrayImage {
    let with_alpha = img.to_luma_alpha8();
    image::GrayImage::from_fn(with_alpha.width(), with_alpha.height(), |x, y| {
        let [luma, alpha] = with_alpha.get_pixel(x, y).0;
        let a = f32::from(alpha) / 255.0;
        image::Luma([(f32::from(luma) * a + 255.0 * (1.0 - a)).round() as u8])
    })
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
        // Drawn on a transparent background: the ink only.
        let mut clear = image::RgbaImage::from_pixel(4, 3, image::Rgba([0, 0, 0, 0]));
        clear.put_pixel(1, 1, image::Rgba([0, 0, 0, 255]));
        clear.put_pixel(2, 1, image::Rgba([20, 20, 20, 200]));
        clear.put_pixel(3, 1, image::Rgba([0, 0, 0, 40]));
        let seen = over_white(&image::DynamicImage::ImageRgba8(clear));
        let inked = pattern_from_image(&seen, 10e-6, "clear").unwrap();
        assert_eq!(inked.offsets_m.len(), 2, "{:?}", inked.offsets_m);
        let blank = image::GrayImage::from_pixel(2, 2, image::Luma([255]));
        assert!(matches!(
            pattern_from_image(&blank, 10e-6, "b"),
            Err(PatternError::Empty(_))
        ));
    }
}
