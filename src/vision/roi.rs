//! Region-of-interest mask: particles whose centre falls outside are ignored
//! (e.g. a scratched corner, the label of a grid, a second probe).

use super::frame::Frame;

/// Which pixels detection may report particles in.
#[derive(Debug, Clone, PartialEq)]
pub struct RoiMask {
    width: usize,
    height: usize,
    inside: Vec<bool>,
}

impl RoiMask {
    /// A rectangle [x0, x1) x [y0, y1) of a width x height frame.
    pub fn rectangle(
        width: usize,
        height: usize,
        x0: usize,
        y0: usize,
        x1: usize,
        y1: usize,
    ) -> Self {
        let inside = (0..width * height)
            .map(|i| {
                let (x, y) = (i % width, i / width);
                x >= x0 && x < x1 && y >= y0 && y < y1
            })
            .collect();
        Self {
            width,
            height,
            inside,
        }
    }

    /// A mask image: non-zero pixels are inside.
    pub fn from_frame(mask: &Frame) -> Self {
        Self {
            width: mask.width(),
            height: mask.height(),
            inside: mask.pixels().iter().map(|&v| v > 0.0).collect(),
        }
    }

    /// True when (x, y) is inside; points off the mask are outside.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let (xi, yi) = (x.round(), y.round());
        if xi < 0.0 || yi < 0.0 || xi >= self.width as f64 || yi >= self.height as f64 {
            return false;
        }
        self.inside[yi as usize * self.width + xi as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_contains() {
        let m = RoiMask::rectangle(10, 10, 2, 2, 5, 5);
        assert!(m.contains(3.2, 4.4));
        assert!(!m.contains(5.6, 3.0));
        assert!(!m.contains(-1.0, 3.0));
    }
}
