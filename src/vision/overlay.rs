//! Overlay image: what detection found, drawn over the frame (particles as
//! circles, the tip as a cross with its axis). Hand-drawn with `image` pixels
//! because no drawing crate is a dependency and circles and lines are a few lines.

use image::{Rgb, RgbImage};

use super::detect::Detection;
use super::frame::Frame;
use super::tip::TipDetection;

fn put(img: &mut RgbImage, x: f64, y: f64, c: Rgb<u8>) {
    let (xi, yi) = (x.round(), y.round());
    if xi >= 0.0 && yi >= 0.0 && xi < img.width() as f64 && yi < img.height() as f64 {
        img.put_pixel(xi as u32, yi as u32, c);
    }
}

fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).clamp(1, 10000);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        put(img, a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1), c);
    }
}

/// The frame, contrast-stretched to 8-bit grey, with detections drawn on it.
pub fn draw_overlay(
    frame: &Frame,
    particles: &[Detection],
    tip: Option<&TipDetection>,
) -> RgbImage {
    let (w, h) = (frame.width() as u32, frame.height() as u32);
    let (lo, hi) = frame
        .pixels()
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, u), &v| {
            (l.min(v), u.max(v))
        });
    let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
    let mut img = RgbImage::from_fn(w, h, |x, y| {
        let v = ((frame.at(x as usize, y as usize) - lo) * scale) as u8;
        Rgb([v, v, v])
    });
    for d in particles {
        let colour = if d.edge_clipped {
            Rgb([255, 160, 0])
        } else {
            Rgb([0, 220, 0])
        };
        let n = ((2.0 * std::f64::consts::PI * d.r_px).ceil() as usize).clamp(16, 2000);
        for k in 0..n {
            let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            put(
                &mut img,
                d.x_px + d.r_px * a.cos(),
                d.y_px + d.r_px * a.sin(),
                colour,
            );
        }
        put(&mut img, d.x_px, d.y_px, Rgb([255, 0, 0]));
    }
    if let Some(t) = tip {
        let red = Rgb([255, 0, 0]);
        line(
            &mut img,
            (t.x_px - 6.0, t.y_px),
            (t.x_px + 6.0, t.y_px),
            red,
        );
        line(
            &mut img,
            (t.x_px, t.y_px - 6.0),
            (t.x_px, t.y_px + 6.0),
            red,
        );
        let back = (
            t.x_px - 60.0 * t.angle_rad.cos(),
            t.y_px - 60.0 * t.angle_rad.sin(),
        );
        line(&mut img, (t.x_px, t.y_px), back, Rgb([0, 160, 255]));
    }
    img
}
