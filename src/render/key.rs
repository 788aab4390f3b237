//! The key of a drawing: one line a mark, the mark as the drawing draws it,
//! then its label, under the picture so it hides nothing. Shared by the
//! plan drawn over its layout and over a camera frame, so the two read
//! alike (a lab user handed either had nothing to read the marks by).

use super::run_overlay::{draw_arrow, draw_cross};
use image::RgbImage;
use plotters::coord::Shift;
use plotters::prelude::*;

/// How a mark looks, drawn in the key as in the picture.
#[derive(Clone, Copy)]
pub enum Swatch {
    /// A filled disc.
    Disc(RGBColor),
    /// A thin ring.
    Ring(RGBColor),
    /// A line ending in a dot (a push of the layout's drawing).
    LineToDot(RGBColor),
    /// A plain line.
    Line(ShapeStyle),
    /// An arrow of this width.
    Arrow(RGBColor, u32),
    /// A cross (the tip's apex).
    Cross(RGBColor),
}

/// One line of a key.
#[derive(Clone, Copy)]
pub struct KeyEntry {
    pub swatch: Swatch,
    pub label: &'static str,
}

/// Height of one line of the key, pixels.
const LINE_PX: i32 = 16;
/// Where a label starts, pixels from the key's left.
const LABEL_X_PX: i32 = 44;

fn font() -> FontDesc<'static> {
    ("sans-serif", 15).into_font()
}

/// Height of the key of `entries`, pixels (a line each and a margin).
pub fn key_height_px(entries: &[KeyEntry]) -> u32 {
    (LINE_PX * (entries.len() as i32 + 1)) as u32
}

/// Width the key's longest line needs, pixels (measured in its font; 8 px a
/// character should the font not measure).
pub fn key_width_px(entries: &[KeyEntry]) -> u32 {
    let widest = entries
        .iter()
        .map(|e| {
            font()
                .box_size(e.label)
                .map_or(8 * e.label.len() as u32, |(w, _)| w)
        })
        .max()
        .unwrap_or(0);
    LABEL_X_PX as u32 + widest + 10
}

/// Draws the key of `entries` into `key`: a faint rule along its top, then
/// one line a mark. Errors are the drawing backend's, as text.
pub fn draw_key<DB: DrawingBackend>(
    key: &DrawingArea<DB, Shift>,
    entries: &[KeyEntry],
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    key.draw(&PathElement::new(
        vec![(0, 0), (key.dim_in_pixel().0 as i32, 0)],
        BLACK.mix(0.3).stroke_width(1),
    ))
    .map_err(e)?;
    let font = font().color(&BLACK);
    for (i, entry) in entries.iter().enumerate() {
        let y = LINE_PX * (i as i32 + 1);
        let (left, right) = ((10, y), (34, y));
        match entry.swatch {
            Swatch::Disc(c) => key.draw(&Circle::new((22, y), 6, c.filled())).map_err(e)?,
            Swatch::Ring(c) => key
                .draw(&Circle::new((22, y), 6, c.stroke_width(1)))
                .map_err(e)?,
            Swatch::LineToDot(c) => {
                key.draw(&PathElement::new(vec![left, right], c.stroke_width(2)))
                    .map_err(e)?;
                key.draw(&Circle::new(right, 3, c.filled())).map_err(e)?;
            }
            Swatch::Line(style) => key
                .draw(&PathElement::new(vec![left, right], style))
                .map_err(e)?,
            Swatch::Arrow(c, width) => draw_arrow(key, left, right, c, width)?,
            Swatch::Cross(c) => draw_cross(key, (22, y), c)?,
        }
        key.draw(&Text::new(entry.label, (LABEL_X_PX, y - 7), font.clone()))
            .map_err(e)?;
    }
    Ok(())
}

/// `picture` with the key of `entries` under it on white, the picture at
/// the top left and the whole as wide as the key's longest line needs.
pub fn with_key_below(picture: &RgbImage, entries: &[KeyEntry]) -> Result<RgbImage, String> {
    let (pw, ph) = picture.dimensions();
    let (w, h) = (pw.max(key_width_px(entries)), ph + key_height_px(entries));
    let mut buf = vec![255u8; (w * h * 3) as usize];
    for (y, row) in picture.rows().enumerate() {
        for (x, p) in row.enumerate() {
            let i = (y * w as usize + x) * 3;
            buf[i..i + 3].copy_from_slice(&p.0);
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let (_, key) = root.split_vertically(ph);
        draw_key(&key, entries)?;
        root.present().map_err(|e| e.to_string())?;
    }
    RgbImage::from_raw(w, h, buf).ok_or_else(|| "key buffer size".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The picture is kept as it was at the top left; the key below it is
    /// as wide as its line needs, with the swatch's colour and dark text.
    #[test]
    fn the_key_goes_under_the_picture_and_widens_a_narrow_one() {
        let picture = RgbImage::from_pixel(40, 30, image::Rgb([10, 20, 30]));
        let entries = [KeyEntry {
            swatch: Swatch::Ring(RGBColor(0, 200, 255)),
            label: "site of the pattern",
        }];
        let drawn = with_key_below(&picture, &entries).unwrap();
        assert_eq!(drawn.height(), 30 + key_height_px(&entries));
        assert!(drawn.width() > 40 + 100, "{}", drawn.width());
        assert!((0..40).all(|x| (0..30).all(|y| drawn.get_pixel(x, y).0 == [10, 20, 30])));
        let in_key = |x0: u32, x1: u32, hit: &dyn Fn([u8; 3]) -> bool| {
            (x0..x1).any(|x| (30..drawn.height()).any(|y| hit(drawn.get_pixel(x, y).0)))
        };
        assert!(in_key(10, 35, &|p| p == [0, 200, 255]), "the ring");
        assert!(
            in_key(44, drawn.width(), &|p| p.iter().all(|&c| c < 100)),
            "the label's text"
        );
    }
}
