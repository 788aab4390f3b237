//! A uniform bucket grid over points: the neighbour queries the planner needs
//! (within a radius, nearest k) in near-constant time.
//!
//! Written by hand because the queries are tiny and tied to our own indices;
//! a general k-d tree crate would add a dependency for no gain here.

use nalgebra::Vector2;

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
        let cx = ((p.x - self.origin.x) / self.cell_m).floor();
        let cy = ((p.y - self.origin.y) / self.cell_m).floor();
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
            let covers_all = radius > (self.nx.max(self.ny) as f64 + 2.0) * self.cell_m * 1.5;
            if found.len() >= k || covers_all {
                found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                found.truncate(k);
                return found;
            }
            radius *= 2.0;
        }
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
