//! One picture of the run animation: a camera frame with what the loop knows
//! drawn over it: target sites, tracked particles, the plan's pushes still to
//! come, the tip, the push whose result the frame shows, and a caption.
//! Drawn with plotters on an RGB buffer (no extra drawing crate).

use super::key::{KeyEntry, Swatch};
use crate::vision::frame::Frame;
use image::RgbImage;
use plotters::prelude::*;

/// What to draw over a frame, in the frame's pixels.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunOverlay {
    /// Target sites (drawn as thin circles of the particle radius).
    pub sites_px: Vec<[f64; 2]>,
    /// Radius of a site circle, pixels.
    pub site_radius_px: f64,
    /// Tracked particles: x, y, radius.
    pub particles_px: Vec<[f64; 3]>,
    /// Pushes of the current plan still to come: from, to.
    pub plan_px: Vec<[[f64; 2]; 2]>,
    /// The push whose result this frame shows: from, to.
    pub push_px: Option<[[f64; 2]; 2]>,
    /// Tip apex, when seen.
    pub tip_px: Option<[f64; 2]>,
    /// One line of text at the top left.
    pub caption: String,
}

const SITE: RGBColor = RGBColor(0, 200, 255);
const PARTICLE: RGBColor = RGBColor(40, 220, 40);
const PLAN: RGBColor = RGBColor(255, 160, 0);
const PUSH: RGBColor = RGBColor(255, 0, 200);
const TIP: RGBColor = RGBColor(255, 40, 40);

/// Draws `overlay` on `frame` (contrast-stretched grey) scaled by `scale`
/// (0.5 halves the size); errors are the drawing backend's, as text.
pub fn draw_run_frame(frame: &Frame, overlay: &RunOverlay, scale: f64) -> Result<RgbImage, String> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(format!("overlay scale must be positive, got {scale}"));
    }
    let w = ((frame.width() as f64 * scale).round() as u32).max(1);
    let h = ((frame.height() as f64 * scale).round() as u32).max(1);
    let (lo, hi) = frame
        .pixels()
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, u), &v| {
            (l.min(v), u.max(v))
        });
    let stretch = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
    let mut buf = vec![0u8; (w * h * 3) as usize];
    for y in 0..h {
        let sy = ((y as f64 + 0.5) / scale)
            .floor()
            .min(frame.height() as f64 - 1.0) as usize;
        for x in 0..w {
            let sx = ((x as f64 + 0.5) / scale)
                .floor()
                .min(frame.width() as f64 - 1.0) as usize;
            let v = ((frame.at(sx, sy) - lo) * stretch).clamp(0.0, 255.0) as u8;
            let i = ((y * w + x) * 3) as usize;
            buf[i..i + 3].copy_from_slice(&[v, v, v]);
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let px = |p: [f64; 2]| ((p[0] * scale).round() as i32, (p[1] * scale).round() as i32);
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        let r_site = ((overlay.site_radius_px * scale).round() as i32).max(2);
        for s in &overlay.sites_px {
            root.draw(&Circle::new(px(*s), r_site, SITE.stroke_width(1)))
                .map_err(e)?;
        }
        for p in &overlay.particles_px {
            let r = ((p[2] * scale).round() as i32).max(2);
            root.draw(&Circle::new(px([p[0], p[1]]), r, PARTICLE.stroke_width(1)))
                .map_err(e)?;
        }
        for [a, b] in &overlay.plan_px {
            draw_arrow(&root, px(*a), px(*b), PLAN, 1)?;
        }
        if let Some([a, b]) = overlay.push_px {
            draw_arrow(&root, px(a), px(b), PUSH, 2)?;
        }
        if let Some(t) = overlay.tip_px {
            draw_cross(&root, px(t), TIP)?;
        }
        let style = ("sans-serif", 14).into_font().color(&YELLOW);
        let fits = |line: &str| {
            root.estimate_text_size(line, &style)
                .is_ok_and(|(tw, _)| tw + 8 <= w)
        };
        for (i, line) in caption_lines(&overlay.caption, fits).iter().enumerate() {
            let y = 4 + 16 * i as i32;
            root.draw(&Text::new(line.clone(), (4, y), style.clone()))
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    RgbImage::from_raw(w, h, buf).ok_or_else(|| "overlay buffer size".to_owned())
}

/// The caption's parts (separated by three spaces) gathered into lines
/// that `fits` takes: a half-size run animation had cut "checking push of
/// particle 12" off at its right edge. A part too long alone is a line of
/// its own.
fn caption_lines(caption: &str, fits: impl Fn(&str) -> bool) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for part in caption.split("   ").filter(|p| !p.is_empty()) {
        match lines.last_mut() {
            Some(line) if fits(&format!("{line}   {part}")) => {
                line.push_str("   ");
                line.push_str(part);
            }
            _ => lines.push(part.to_owned()),
        }
    }
    lines
}

/// The key of `overlay`'s marks, those it draws ([`super::key`]).
pub fn key(overlay: &RunOverlay) -> Vec<KeyEntry> {
    let mut entries = vec![
        KeyEntry {
            swatch: Swatch::Ring(SITE),
            label: "site of the pattern",
        },
        KeyEntry {
            swatch: Swatch::Ring(PARTICLE),
            label: "particle seen (ring: its size)",
        },
        KeyEntry {
            swatch: Swatch::Arrow(PLAN, 1),
            label: "push to come (head: where it ends)",
        },
    ];
    if overlay.push_px.is_some() {
        entries.push(KeyEntry {
            swatch: Swatch::Arrow(PUSH, 2),
            label: "push whose result is shown",
        });
    }
    if overlay.tip_px.is_some() {
        entries.push(KeyEntry {
            swatch: Swatch::Cross(TIP),
            label: "the tip's apex",
        });
    }
    entries
}

/// A cross of 12 px centred on `at`: the tip's apex.
pub(super) fn draw_cross<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    (x, y): (i32, i32),
    colour: RGBColor,
) -> Result<(), String> {
    for seg in [[(x - 6, y), (x + 6, y)], [(x, y - 6), (x, y + 6)]] {
        root.draw(&PathElement::new(seg.to_vec(), colour.stroke_width(2)))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// A line from `a` to `b` with a head at `b`.
pub(super) fn draw_arrow<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    a: (i32, i32),
    b: (i32, i32),
    colour: RGBColor,
    width: u32,
) -> Result<(), String> {
    let style = colour.stroke_width(width);
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.draw(&PathElement::new(vec![a, b], style)).map_err(e)?;
    let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
    let len = dx.hypot(dy);
    if len < 1.0 {
        return Ok(());
    }
    let (ux, uy) = (dx / len, dy / len);
    let head = 6.0_f64.min(len / 2.0);
    for side in [-1.0, 1.0] {
        let hx = b.0 as f64 - head * (ux + side * 0.5 * uy);
        let hy = b.1 as f64 - head * (uy - side * 0.5 * ux);
        root.draw(&PathElement::new(
            vec![b, (hx.round() as i32, hy.round() as i32)],
            style,
        ))
        .map_err(e)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: usize, h: usize) -> Frame {
        let mut px = vec![100.0f32; w * h];
        px[0] = 0.0;
        Frame::new(w, h, px, 8).unwrap()
    }

    #[test]
    fn overlay_marks_show_in_their_colours_at_the_scaled_places() {
        let overlay = RunOverlay {
            sites_px: vec![[40.0, 40.0]],
            site_radius_px: 10.0,
            particles_px: vec![[120.0, 40.0, 10.0]],
            push_px: Some([[20.0, 150.0], [180.0, 150.0]]),
            tip_px: Some([100.0, 100.0]),
            ..RunOverlay::default()
        };
        let img = draw_run_frame(&flat(200, 200), &overlay, 0.5).unwrap();
        assert_eq!((img.width(), img.height()), (100, 100));
        let has = |c: RGBColor, x0: u32, x1: u32, y0: u32, y1: u32| {
            (x0..x1).any(|x| (y0..y1).any(|y| img.get_pixel(x, y).0 == [c.0, c.1, c.2]))
        };
        assert!(has(SITE, 14, 26, 14, 26), "site circle around (20, 20)");
        assert!(
            has(PARTICLE, 54, 66, 14, 26),
            "particle circle around (60, 20)"
        );
        assert!(has(PUSH, 30, 70, 74, 76), "push line along y = 75");
        assert!(has(TIP, 47, 53, 47, 53), "tip cross at (50, 50)");
        assert!(!has(PLAN, 0, 100, 0, 100), "no plan was given");
    }

    /// A caption wider than the frame goes on in lines below, each part
    /// whole; in one line at 280 px, "checking push of particle 12" was cut.
    #[test]
    fn a_long_caption_is_wrapped_not_cut() {
        let caption = "t 12.5 s   particles 48   sites filled 15/31   checking push of particle 12";
        let lines = caption_lines(caption, |l| l.len() <= 40);
        assert_eq!(
            lines,
            [
                "t 12.5 s   particles 48",
                "sites filled 15/31",
                "checking push of particle 12"
            ]
        );
        assert_eq!(caption_lines("a   b", |_| true), ["a   b"]);
        assert_eq!(caption_lines("a long part", |_| false), ["a long part"]);
        let overlay = RunOverlay {
            caption: caption.to_owned(),
            ..RunOverlay::default()
        };
        // Black: one bright pixel in a corner sets the stretch.
        let mut px = vec![0.0f32; 560 * 560];
        px[560 * 560 - 1] = 100.0;
        let dark = Frame::new(560, 560, px, 8).unwrap();
        let img = draw_run_frame(&dark, &overlay, 0.5).unwrap();
        let yellow_in_rows = |y0: u32, y1: u32| {
            (0..img.width()).any(|x| {
                (y0..y1).any(|y| {
                    let [r, g, b] = img.get_pixel(x, y).0;
                    r > 150 && g > 150 && b < 60
                })
            })
        };
        assert!(yellow_in_rows(4, 18), "first line");
        assert!(yellow_in_rows(20, 34), "second line");
    }

    #[test]
    fn a_bad_scale_is_an_error_not_a_panic() {
        assert!(draw_run_frame(&flat(10, 10), &RunOverlay::default(), 0.0).is_err());
        assert!(draw_run_frame(&flat(10, 10), &RunOverlay::default(), f64::NAN).is_err());
    }
}
