//! A uniform bucket grid over points: the neighbour queries the planner needs
//! (within a radius, nearest k) in near-constant time.
//!
//! Written by hand because the queries are tiny and tied to our own indices;
//! a general k-d tree crate would add a dependency for no gain here.

use nalgebra::Vector2;
use std::ops::RangeInclusive;

/// Uniform grid of point indices.
#[derive(Debug, Clone)]
pub struct Grid {
    origin: Vector2<f64>,
    cell_m: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<usize>>,
    points: Vec<Vector2<f64>>,
}

impl Grid {
    /// Builds a grid with square cells of `cell_m` (clamped so the grid stays
    /// small; 0 or non-finite: sized for about two points per cell).
    pub fn new(points: impl IntoIterator<Item = Vector2<f64>>, cell_m: f64) -> Self {
        let points: Vec<Vector2<f64>> = points.into_iter().collect();
        let (mut lo, mut hi) = (Vector2::new(0.0, 0.0), Vector2::new(0.0, 0.0));
        if let Some(first) = points.first() {
            lo = *first;
            hi = *first;
        }
        for p in &points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let span = (hi - lo).max().max(1e-12);
        // Keep at most ~4 cells per point and at least one cell.
        let min_cell = span / ((4 * points.len().max(1)) as f64).sqrt().max(1.0);
        let cell_m = if cell_m.is_finite() && cell_m > 0.0 {
            cell_m.max(min_cell)
        } else {
            // Unspecified: about two points per cell over the bounding box.
            let (w, h) = (
                (hi.x - lo.x).max(span * 1e-3),
                (hi.y - lo.y).max(span * 1e-3),
            );
            (2.0 * w * h / points.len().max(1) as f64)
                .sqrt()
                .max(min_cell)
        };
        let nx = (((hi.x - lo.x) / cell_m) as usize + 1).max(1);
        let ny = (((hi.y - lo.y) / cell_m) as usize + 1).max(1);
        let mut cells = vec![Vec::new(); nx * ny];
        let mut grid = Grid {
            origin: lo,
            cell_m,
            nx,
            ny,
            cells: Vec::new(),
            points,
        };
        for (i, p) in grid.points.iter().enumerate() {
            let (cx, cy) = grid.cell_of(*p);
            cells[cy * nx + cx].push(i);
        }
        grid.cells = cells;
        grid
    }

    fn cell_of(&self, p: Vector2<f64>) -> (usize, usize) {
        // Truncation is the floor here: negatives are clamped to cell 0.
        let cx = (p.x - self.origin.x) / self.cell_m;
        let cy = (p.y - self.origin.y) / self.cell_m;
        (
            (cx.max(0.0) as usize).min(self.nx - 1),
            (cy.max(0.0) as usize).min(self.ny - 1),
        )
    }

    /// Indices of points within `radius_m` of `centre` (inclusive).
    pub fn within(&self, centre: Vector2<f64>, radius_m: f64) -> Vec<usize> {
        let mut out = Vec::new();
        self.for_each_within(centre, radius_m, |i| out.push(i));
        out
    }

    /// Calls `f` on every point index within `radius_m` of `centre`.
    pub fn for_each_within(&self, centre: Vector2<f64>, radius_m: f64, mut f: impl FnMut(usize)) {
        if self.points.is_empty() || !radius_m.is_finite() {
            return;
        }
        let (x0, y0) = self.cell_of(centre - Vector2::new(radius_m, radius_m));
        let (x1, y1) = self.cell_of(centre + Vector2::new(radius_m, radius_m));
        let r2 = radius_m * radius_m;
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                for &i in &self.cells[cy * self.nx + cx] {
                    if (self.points[i] - centre).norm_squared() <= r2 {
                        f(i);
                    }
                }
            }
        }
    }

    /// Calls `f` on every point index in the cells within `reach_m` of the
    /// segment a-b (a superset of the points within `reach_m`: `f` makes the
    /// exact test) until `f` returns false; false when it stopped early.
    pub fn for_each_near_segment(
        &self,
        a: Vector2<f64>,
        b: Vector2<f64>,
        reach_m: f64,
        mut f: impl FnMut(usize) -> bool,
    ) -> bool {
        if self.points.is_empty() {
            return true;
        }
        let within = [0..=self.nx as i64 - 1, 0..=self.ny as i64 - 1];
        for_each_cell_near_segment(self.origin, self.cell_m, a, b, reach_m, within, |cx, cy| {
            self.cells[cy as usize * self.nx + cx as usize]
                .iter()
                .all(|&i| f(i))
        })
    }

    /// The `k` nearest points to `centre`, sorted by distance (fewer if the grid has fewer).
    pub fn nearest(&self, centre: Vector2<f64>, k: usize) -> Vec<(f64, usize)> {
        let k = k.min(self.points.len());
        if k == 0 {
            return Vec::new();
        }
        let mut radius = self.cell_m;
        loop {
            let mut found: Vec<(f64, usize)> = Vec::new();
            self.for_each_within(centre, radius, |i| {
                found.push(((self.points[i] - centre).norm(), i))
            });
            let covers_all = radius >= self.farthest_corner_m(centre);
            if found.len() >= k || covers_all {
                found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                found.truncate(k);
                return found;
            }
            radius *= 2.0;
        }
    }

    /// Distance from `centre` to the grid's farthest corner: a search of
    /// that radius has seen every point. (Sized by the grid's own extent
    /// instead, a search from far outside a small grid, such as one point
    /// 30 um away, gave up empty after a few picometres.)
    fn farthest_corner_m(&self, centre: Vector2<f64>) -> f64 {
        let span = Vector2::new(self.nx as f64, self.ny as f64) * self.cell_m;
        let far = |lo: f64, hi: f64, c: f64| (c - lo).abs().max((hi - c).abs());
        Vector2::new(
            far(self.origin.x, self.origin.x + span.x, centre.x),
            far(self.origin.y, self.origin.y + span.y, centre.y),
        )
        .norm()
    }

    /// Number of points in the grid.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the grid holds no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// `v.floor() as i64` without the floor call (software on the baseline
/// x86-64 target, a seventieth of CMU's planning): the same for every
/// finite `v`, saturating alike beyond the i64 range, 0 for NaN.
pub fn floor_to_i64(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// Calls `f(cx, cy)` on the cells (of side `cell_m` from `origin`) that
/// come within `reach_m` of the segment a-b, column by column, until `f`
/// returns false; false when it stopped early. A long segment's bounding
/// square holds many cells far from it; this visits about three per column.
/// Only cells with `cx` in `within[0]` and `cy` in `within[1]` are
/// visited: a grid of tiny cells (one point has no spread to size them by)
/// would otherwise walk millions of empty cells along a long segment.
pub fn for_each_cell_near_segment(
    origin: Vector2<f64>,
    cell_m: f64,
    a: Vector2<f64>,
    b: Vector2<f64>,
    reach_m: f64,
    within: [RangeInclusive<i64>; 2],
    mut f: impl FnMut(i64, i64) -> bool,
) -> bool {
    if !(reach_m.is_finite() && a.iter().chain(b.iter()).all(|v| v.is_finite())) {
        return true;
    }
    // Widened a little: callers' exact tests run in f32 micrometres.
    let reach_m = reach_m + cell_m * 1e-3;
    let cell = |v: f64, o: f64| floor_to_i64((v - o) / cell_m);
    let d = b - a;
    let x0 = cell(a.x.min(b.x) - reach_m, origin.x).max(*within[0].start());
    let x1 = cell(a.x.max(b.x) + reach_m, origin.x).min(*within[0].end());
    for cx in x0..=x1 {
        // The part of the segment whose points lie within reach of this
        // column's slab; the cells it touches, widened by the reach.
        let (lo, hi) = (
            origin.x + cx as f64 * cell_m - reach_m,
            origin.x + (cx + 1) as f64 * cell_m + reach_m,
        );
        let (t0, t1) = if d.x.abs() > 0.0 {
            let (ta, tb) = ((lo - a.x) / d.x, (hi - a.x) / d.x);
            (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
        } else {
            (0.0, 1.0)
        };
        if t0 > t1 {
            continue;
        }
        let (ya, yb) = (a.y + d.y * t0, a.y + d.y * t1);
        let y0 = cell(ya.min(yb) - reach_m, origin.y).max(*within[1].start());
        let y1 = cell(ya.max(yb) + reach_m, origin.y).min(*within[1].end());
        for cy in y0..=y1 {
            if !f(cx, cy) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::pushes::segment_distance;

    #[test]
    fn floor_to_i64_is_the_floor_cast() {
        let values = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999,
            -2.000_001,
            1e-300,
            -1e-300,
            4.5e15,
            -4.5e15,
            1e30,
            -1e30,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for v in values {
            assert_eq!(floor_to_i64(v), v.floor() as i64, "{v}");
        }
    }

    #[test]
    fn nearest_matches_brute_force() {
        let pts: Vec<Vector2<f64>> = (0..200)
            .map(|i| Vector2::new(((i * 37) % 101) as f64, ((i * 53) % 97) as f64))
            .collect();
        let grid = Grid::new(pts.clone(), 5.0);
        let q = Vector2::new(40.3, 61.7);
        let got = grid.nearest(q, 10);
        let mut brute: Vec<(f64, usize)> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| ((p - q).norm(), i))
            .collect();
        brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        assert_eq!(got, brute[..10].to_vec());
        assert_eq!(
            grid.within(q, 8.0).len(),
            brute.iter().filter(|b| b.0 <= 8.0).count()
        );
    }

    /// A nearest query from far outside a one-point grid finds the point.
    #[test]
    fn nearest_from_far_outside_a_one_point_grid_finds_it() {
        let grid = Grid::new([Vector2::new(20e-6, 50e-6)], 0.0);
        let got = grid.nearest(Vector2::new(50e-6, 50e-6), 1);
        assert_eq!(got.len(), 1);
        assert!((got[0].0 - 30e-6).abs() < 1e-12);
    }

    /// One point gives no spread to size the cells by, so they come out a
    /// picometre wide; a long segment query must still end at once (it
    /// walked billions of empty cells before it was bounded to the grid).
    #[test]
    fn segment_query_on_a_one_point_grid_ends_and_finds_it() {
        let grid = Grid::new([Vector2::new(50e-6, 50e-6)], 0.0);
        let mut seen = Vec::new();
        grid.for_each_near_segment(
            Vector2::new(0.0, 50e-6),
            Vector2::new(100e-6, 50e-6),
            10e-6,
            |i| {
                seen.push(i);
                true
            },
        );
        assert_eq!(seen, vec![0]);
    }

    #[test]
    fn segment_query_finds_every_point_within_reach() {
        let pts: Vec<Vector2<f64>> = (0..400)
            .map(|i| Vector2::new(((i * 37) % 101) as f64, ((i * 53) % 97) as f64))
            .collect();
        let grid = Grid::new(pts.clone(), 4.0);
        let segments = [
            (Vector2::new(3.0, 5.0), Vector2::new(90.0, 71.0), 6.0),
            (Vector2::new(50.0, 2.0), Vector2::new(50.0, 95.0), 3.0),
            (Vector2::new(80.0, 40.0), Vector2::new(10.0, 41.0), 2.5),
            (Vector2::new(-20.0, -20.0), Vector2::new(20.0, 20.0), 9.0),
            (Vector2::new(40.0, 40.0), Vector2::new(40.0, 40.0), 7.0),
        ];
        for (a, b, reach) in segments {
            let mut seen = Vec::new();
            assert!(grid.for_each_near_segment(a, b, reach, |i| {
                seen.push(i);
                true
            }));
            let within: Vec<usize> = (0..pts.len())
                .filter(|&i| segment_distance(pts[i], a, b) <= reach)
                .collect();
            assert!(!within.is_empty());
            for i in &within {
                assert!(
                    seen.contains(i),
                    "point {i} within {reach} of {a:?}-{b:?} not visited"
                );
            }
            // It stays near the segment: far fewer points than the bounding square holds.
            let square = (0..pts.len())
                .filter(|&i| {
                    let p = pts[i];
                    p.x >= a.x.min(b.x) - reach
                        && p.x <= a.x.max(b.x) + reach
                        && p.y >= a.y.min(b.y) - reach
                        && p.y <= a.y.max(b.y) + reach
                })
                .count();
            if (b - a).x.abs() > 60.0 && (b - a).y.abs() > 60.0 {
                assert!(
                    seen.len() * 2 < square,
                    "{} visited of {square}",
                    seen.len()
                );
            }
            // Stopping early stops.
            let mut calls = 0;
            assert!(!grid.for_each_near_segment(a, b, reach, |_| {
                calls += 1;
                false
            }));
            assert_eq!(calls, 1);
        }
    }
}
