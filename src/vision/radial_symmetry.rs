//! Radial-symmetry centre (Parthasarathy, Nature Methods 9, 724, 2012): the
//! point closest, in a weighted least-squares sense, to every line along the
//! local intensity gradient. Works for spots and rings of either contrast,
//! needs no model and no iteration; the profile fit starts from it.

use super::frame::Frame;

/// Centre of radial symmetry of the square window of half-size `half` around
/// (cx, cy), or `None` when the window holds no gradient (flat) or leaves the frame.
pub fn radial_symmetry_centre(frame: &Frame, cx: f64, cy: f64, half: usize) -> Option<(f64, f64)> {
    let (w, h) = (frame.width() as isize, frame.height() as isize);
    let x0 = (cx.round() as isize - half as isize).max(0);
    let y0 = (cy.round() as isize - half as isize).max(0);
    let x1 = (cx.round() as isize + half as isize).min(w - 1);
    let y1 = (cy.round() as isize + half as isize).min(h - 1);
    if x1 - x0 < 2 || y1 - y0 < 2 {
        return None;
    }
    // Gradients at the centres of 2x2 blocks (Roberts cross, rotated to x/y).
    let mut pts: Vec<(f64, f64, f64, f64, f64)> = Vec::new(); // px, py, nx, ny, g2
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for y in y0..y1 {
        for x in x0..x1 {
            let (xu, yu) = (x as usize, y as usize);
            let a = frame.at(xu, yu) as f64;
            let b = frame.at(xu + 1, yu) as f64;
            let c = frame.at(xu, yu + 1) as f64;
            let d = frame.at(xu + 1, yu + 1) as f64;
            let gx = 0.5 * ((b - a) + (d - c));
            let gy = 0.5 * ((c - a) + (d - b));
            let g2 = gx * gx + gy * gy;
            if g2 <= 0.0 {
                continue;
            }
            let g = g2.sqrt();
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            pts.push((px, py, -gy / g, gx / g, g2));
            sx += g2 * px;
            sy += g2 * py;
            sw += g2;
        }
    }
    if sw <= 0.0 {
        return None;
    }
    let mut centre = (sx / sw, sy / sw);
    // Two passes: weights |g|^2 / distance to the current centre estimate.
    for _ in 0..2 {
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(px, py, nx, ny, g2) in &pts {
            let dist = ((px - centre.0).powi(2) + (py - centre.1).powi(2))
                .sqrt()
                .max(0.5);
            let wt = g2 / dist;
            let pn = px * nx + py * ny;
            a11 += wt * nx * nx;
            a12 += wt * nx * ny;
            a22 += wt * ny * ny;
            b1 += wt * nx * pn;
            b2 += wt * ny * pn;
        }
        let det = a11 * a22 - a12 * a12;
        if det.abs() <= 1e-12 * (a11 * a22).abs().max(1e-300) {
            return None;
        }
        let c = ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
        if !(c.0.is_finite() && c.1.is_finite()) {
            return None;
        }
        centre = c;
    }
    Some(centre)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_subpixel_centre_of_a_noise_free_gaussian() {
        let (w, h) = (31, 31);
        let (tx, ty) = (15.3, 14.6);
        let px: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                (100.0 + 500.0 * (-((x - tx).powi(2) + (y - ty).powi(2)) / 8.0).exp()) as f32
            })
            .collect();
        let f = Frame::new(w, h, px, 16).unwrap();
        let (x, y) = radial_symmetry_centre(&f, 15.0, 15.0, 8).unwrap();
        assert!((x - tx).abs() < 0.05 && (y - ty).abs() < 0.05, "{x} {y}");
        let flat = Frame::new(w, h, vec![5.0; w * h], 8).unwrap();
        assert_eq!(radial_symmetry_centre(&flat, 15.0, 15.0, 8), None);
    }
}
