//! "Which point minimises distance plus its weight?" for fixed weights.
//!
//! Why: a dual bound of a geometric assignment ([`super::dual_bound`]) needs,
//! for every row point, `min_j |q - p_j| + w_j` over all column points with
//! their prices as weights (and the reverse for the prices). The weights are
//! fixed during a pass, so every cell and block of [`Buckets`] carries the
//! least weight of its points, and whatever cannot beat the best value found
//! is skipped. (The auction asks the same with prices that change after
//! every bid; it keeps its own minima.)

use super::buckets::{Buckets, dist_to_box, dist2_to_box};
use nalgebra::Vector2;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Points per cell of the buckets.
const POINTS_PER_CELL: f64 = 2.0;

/// Points with a weight each, bucketed.
pub(crate) struct WeightedPoints {
    buckets: Buckets,
    /// Weight of each slot's point.
    weight: Vec<f64>,
    cell_min: Vec<f64>,
    block_min: Vec<f64>,
}

/// A block and the least value any of its points can take (min-heap order).
#[derive(Clone, Copy, PartialEq)]
struct BlockKey(f64, u32);

impl Eq for BlockKey {}

impl Ord for BlockKey {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

impl PartialOrd for BlockKey {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// A reusable heap for [`WeightedPoints::min_plus`] (one per thread).
#[derive(Default)]
pub(crate) struct QueryBuffer(Vec<BlockKey>);

impl WeightedPoints {
    /// `points` (all finite) with weights `weights[i]` (finite or +infinity,
    /// which takes the point out of every query).
    pub fn new(points: &[Vector2<f64>], weights: &[f64]) -> Self {
        let buckets = Buckets::new(points, POINTS_PER_CELL);
        let mut w = WeightedPoints {
            weight: vec![0.0; points.len()],
            cell_min: vec![0.0; buckets.cells()],
            block_min: vec![0.0; buckets.blocks()],
            buckets,
        };
        w.set_weights(weights);
        w
    }

    /// Replaces every weight (`weights[i]` of point `i`).
    pub fn set_weights(&mut self, weights: &[f64]) {
        let b = &self.buckets;
        for (slot, &i) in b.slot_to_point.iter().enumerate() {
            self.weight[slot] = weights[i];
        }
        for c in 0..b.cells() {
            self.cell_min[c] = self.weight[b.cell_start[c]..b.cell_start[c + 1]]
                .iter()
                .fold(f64::INFINITY, |m, &w| m.min(w));
        }
        for k in 0..b.blocks() {
            self.block_min[k] = self.cell_min[b.block_start[k]..b.block_start[k + 1]]
                .iter()
                .fold(f64::INFINITY, |m, &w| m.min(w));
        }
    }

    /// A lower bound of `min_j |q - p_j| + w_j` within `tol` of it (exact
    /// for `tol = 0`; +infinity when every weight is). A cell or block whose
    /// bound is within `tol` of the best value is not opened, and the least
    /// such bound is returned when it is below the best: far cheaper when
    /// many points nearly tie (prices that grow by the distance along a
    /// line), and never above the true minimum.
    pub fn min_plus(&self, q: Vector2<f64>, tol: f64, buf: &mut QueryBuffer) -> f64 {
        let b = &self.buckets;
        let mut keys = std::mem::take(&mut buf.0);
        keys.clear();
        keys.extend(
            b.block_box
                .iter()
                .zip(&self.block_min)
                .enumerate()
                .map(|(k, (bx, &w))| BlockKey(dist_to_box(bx, q.x, q.y) + w, k as u32)),
        );
        let mut heap = BinaryHeap::from(keys);
        let mut best = f64::INFINITY;
        // The least bound of what was left unopened.
        let mut unopened = f64::INFINITY;
        while let Some(BlockKey(key, k)) = heap.pop() {
            if key >= best - tol {
                unopened = unopened.min(key);
                break;
            }
            let k = k as usize;
            for c in b.block_start[k]..b.block_start[k + 1] {
                let reach = best - tol - self.cell_min[c];
                let d2 = dist2_to_box(&b.cell_box[c], q.x, q.y);
                if reach <= 0.0 || d2 >= reach * reach {
                    unopened = unopened.min(d2.sqrt() + self.cell_min[c]);
                    continue;
                }
                for s in b.cell_start[c]..b.cell_start[c + 1] {
                    let (dx, dy) = (b.xs[s] - q.x, b.ys[s] - q.y);
                    best = best.min((dx * dx + dy * dy).sqrt() + self.weight[s]);
                }
            }
        }
        buf.0 = heap.into_vec();
        best.min(unopened)
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::*;

    fn brute(points: &[Vector2<f64>], w: &[f64], q: Vector2<f64>) -> f64 {
        points
            .iter()
            .zip(w)
            .map(|(p, &w)| (p - q).norm() + w)
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn matches_brute_force_and_stays_below_it_within_the_tolerance() {
        let pts = random_points(700, 300.0, 1);
        let queries = random_points(200, 320.0, 2);
        // Weights: random, growing along x (near ties), and some infinite.
        let rand_w: Vec<f64> = random_points(700, 50.0, 3).iter().map(|p| p.x).collect();
        let slope: Vec<f64> = pts.iter().map(|p| -p.x).collect();
        let mut holes = rand_w.clone();
        for w in holes.iter_mut().step_by(3) {
            *w = f64::INFINITY;
        }
        let mut buf = QueryBuffer::default();
        for (what, w) in [("random", &rand_w), ("slope", &slope), ("holes", &holes)] {
            let wp = WeightedPoints::new(&pts, w);
            for &q in &queries {
                let exact = brute(&pts, w, q);
                let got = wp.min_plus(q, 0.0, &mut buf);
                assert!((got - exact).abs() <= 1e-9, "{what}: {got} vs {exact}");
                let loose = wp.min_plus(q, 0.5, &mut buf);
                assert!(
                    loose <= exact + 1e-12 && loose >= exact - 0.5 - 1e-9,
                    "{what}: {loose} vs {exact}"
                );
            }
        }
        let none = WeightedPoints::new(&pts[..3], &[f64::INFINITY; 3]);
        assert_eq!(
            none.min_plus(Vector2::zeros(), 0.0, &mut buf),
            f64::INFINITY
        );
    }
}
