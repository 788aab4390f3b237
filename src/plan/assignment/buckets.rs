//! Points bucketed into square cells, cells grouped into blocks of
//! `BLOCK_SIDE x BLOCK_SIDE`, each cell and block carrying the bounding box
//! of its own points.
//!
//! Why: the auction asks, thousands of times per solve, "which point
//! minimises distance + price?" with prices that change after every bid. A
//! block or cell whose nearest box corner plus its cheapest price cannot
//! beat the best found so far is skipped whole; points are stored in cell
//! order ("slots") so a cell is one contiguous run of memory. A k-d tree
//! crate could answer plain nearest-neighbour queries, but not queries
//! weighted by per-point prices that change as the search goes on.

use nalgebra::Vector2;

/// Cells per block side.
const BLOCK_SIDE: usize = 8;

/// Points in cell order with cell and block bounding boxes.
#[derive(Debug, Clone)]
pub(crate) struct Buckets {
    /// Original index of the point in each slot.
    pub slot_to_point: Vec<usize>,
    /// x of each slot's point.
    pub xs: Vec<f64>,
    /// y of each slot's point.
    pub ys: Vec<f64>,
    /// Cell of each slot.
    pub cell_of_slot: Vec<u32>,
    /// Slots of cell `c` are `cell_start[c]..cell_start[c + 1]`.
    pub cell_start: Vec<usize>,
    /// Bounding box `[x_min, y_min, x_max, y_max]` of each cell's points.
    pub cell_box: Vec<[f64; 4]>,
    /// Block of each cell.
    pub block_of_cell: Vec<u32>,
    /// Cells of block `b` are `block_start[b]..block_start[b + 1]`.
    pub block_start: Vec<usize>,
    /// Bounding box of each block's points.
    pub block_box: Vec<[f64; 4]>,
}

impl Buckets {
    /// Buckets `points` (all finite) with about `per_cell` points per non-empty cell.
    pub fn new(points: &[Vector2<f64>], per_cell: f64) -> Self {
        let m = points.len();
        let (mut lo, mut hi) = (Vector2::zeros(), Vector2::zeros());
        if let Some(first) = points.first() {
            lo = *first;
            hi = *first;
        }
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let span = hi - lo;
        let area = (span.x.max(span.y * 1e-6) * span.y.max(span.x * 1e-6)).max(0.0);
        let mut cell = (area * per_cell / m.max(1) as f64).sqrt();
        if !(cell.is_finite() && cell > 0.0) {
            cell = 1.0; // all points coincide: one cell
        }
        let nx = ((span.x / cell) as usize + 1).max(1);
        let nbx = nx.div_ceil(BLOCK_SIDE);
        let key = |p: &Vector2<f64>| -> u64 {
            let cx = (((p.x - lo.x) / cell) as usize).min(nx - 1);
            let cy = ((p.y - lo.y) / cell) as usize;
            let block = (cy / BLOCK_SIDE) * nbx + cx / BLOCK_SIDE;
            let within = (cy % BLOCK_SIDE) * BLOCK_SIDE + cx % BLOCK_SIDE;
            (block * BLOCK_SIDE * BLOCK_SIDE + within) as u64
        };
        let mut keyed: Vec<(u64, usize)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (key(p), i))
            .collect();
        keyed.sort_unstable();
        let block_of_key = |k: u64| k / (BLOCK_SIDE * BLOCK_SIDE) as u64;
        let mut b = Buckets {
            slot_to_point: Vec::with_capacity(m),
            xs: Vec::with_capacity(m),
            ys: Vec::with_capacity(m),
            cell_of_slot: Vec::with_capacity(m),
            cell_start: Vec::new(),
            cell_box: Vec::new(),
            block_of_cell: Vec::new(),
            block_start: Vec::new(),
            block_box: Vec::new(),
        };
        let empty = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let grow = |bx: &mut [f64; 4], p: &Vector2<f64>| {
            bx[0] = bx[0].min(p.x);
            bx[1] = bx[1].min(p.y);
            bx[2] = bx[2].max(p.x);
            bx[3] = bx[3].max(p.y);
        };
        let mut prev_key = None;
        for (slot, &(k, i)) in keyed.iter().enumerate() {
            let p = &points[i];
            if prev_key != Some(k) {
                if prev_key.map(block_of_key) != Some(block_of_key(k)) {
                    b.block_start.push(b.cell_start.len());
                    b.block_box.push(empty);
                }
                b.cell_start.push(slot);
                b.cell_box.push(empty);
                b.block_of_cell.push((b.block_box.len() - 1) as u32);
                prev_key = Some(k);
            }
            b.slot_to_point.push(i);
            b.xs.push(p.x);
            b.ys.push(p.y);
            b.cell_of_slot.push((b.cell_box.len() - 1) as u32);
            grow(b.cell_box.last_mut().expect("a cell was pushed"), p);
            grow(b.block_box.last_mut().expect("a block was pushed"), p);
        }
        b.cell_start.push(m);
        b.block_start.push(b.cell_box.len());
        b
    }

    /// Number of non-empty cells.
    pub fn cells(&self) -> usize {
        self.cell_box.len()
    }

    /// Number of non-empty blocks.
    pub fn blocks(&self) -> usize {
        self.block_box.len()
    }
}

/// Distance from `(x, y)` to the box `[x_min, y_min, x_max, y_max]` (0 inside).
/// Never larger than the distance to any point in the box, in floating point too
/// (each step is monotone), so it is a safe lower bound.
#[inline]
pub(crate) fn dist_to_box(b: &[f64; 4], x: f64, y: f64) -> f64 {
    dist2_to_box(b, x, y).sqrt()
}

/// Squared [`dist_to_box`].
#[inline]
pub(crate) fn dist2_to_box(b: &[f64; 4], x: f64, y: f64) -> f64 {
    let dx = (b[0] - x).max(0.0).max(x - b[2]);
    let dy = (b[1] - y).max(0.0).max(y - b[3]);
    dx * dx + dy * dy
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::*;

    #[test]
    fn every_point_is_in_exactly_one_slot_inside_its_cell_and_block_boxes() {
        let pts = random_points(1000, 300.0, 4);
        let b = Buckets::new(&pts, 2.0);
        let mut seen = b.slot_to_point.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..1000).collect::<Vec<_>>());
        assert!(b.blocks() > 1 && b.cells() > b.blocks());
        for c in 0..b.cells() {
            let bb = b.block_box[b.block_of_cell[c] as usize];
            for s in b.cell_start[c]..b.cell_start[c + 1] {
                assert_eq!(b.cell_of_slot[s] as usize, c);
                assert_eq!(dist_to_box(&b.cell_box[c], b.xs[s], b.ys[s]), 0.0);
                assert_eq!(dist_to_box(&bb, b.xs[s], b.ys[s]), 0.0);
                let p = pts[b.slot_to_point[s]];
                assert_eq!((p.x, p.y), (b.xs[s], b.ys[s]));
            }
        }
        // Coincident points: one cell.
        let same = vec![Vector2::new(1.0, 2.0); 5];
        assert_eq!(Buckets::new(&same, 2.0).cells(), 1);
    }
}
