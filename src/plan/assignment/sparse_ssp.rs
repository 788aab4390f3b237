//! Exact assignment by shortest augmenting paths that read the cost matrix
//! lazily, nearest particles first.
//!
//! Dijkstra over the residual graph with dual potentials `u` (sites) and `v`
//! (particles, always <= 0 and 0 on free particles). The reduced cost of a
//! pair is `c - u - v >= c - u`, so a site's unexplored particles, taken in
//! order of distance, have a lower bound `max(0, c - u)`: a site re-enters
//! the heap with that bound instead of scanning all m particles. The result
//! is the same optimum the dense method finds (tested), at a cost that
//! depends on how far augmenting paths spread, not on n * m.

use super::dist;
use crate::plan::grid::Grid;
use nalgebra::Vector2;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

const FREE: usize = usize::MAX;
const FIRST_K: usize = 24;

#[derive(Clone, Copy, PartialEq)]
struct Entry {
    key: f64,
    kind: Kind,
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// Next unexplored candidate `idx` of site `row`.
    Row { row: usize, idx: usize },
    /// Tentative distance of particle `col`.
    Col { col: usize },
}

impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on key; columns before rows at equal keys (finish early).
        other.key.total_cmp(&self.key).then_with(|| {
            let rank = |k: &Kind| matches!(k, Kind::Col { .. }) as u8;
            rank(&self.kind).cmp(&rank(&other.kind))
        })
    }
}

/// Per-site candidate particles sorted by distance, grown on demand.
struct Candidates<'a> {
    grid: Grid,
    sites: &'a [Vector2<f64>],
    lists: Vec<Vec<(f64, usize)>>,
    m: usize,
}

impl Candidates<'_> {
    /// Candidate `idx` of `row`, growing the list if needed; None when all are seen.
    fn get(&mut self, row: usize, idx: usize) -> Option<(f64, usize)> {
        if idx >= self.lists[row].len() {
            let len = self.lists[row].len();
            if len >= self.m {
                return None;
            }
            let k = (len * 4).max(FIRST_K).min(self.m);
            self.lists[row] = self.grid.nearest(self.sites[row], k);
        }
        self.lists[row].get(idx).copied()
    }
}

/// Solves the rectangular assignment exactly; rows are sites, columns particles.
pub fn solve(sites: &[Vector2<f64>], particles: &[Vector2<f64>]) -> Vec<usize> {
    let (n, m) = (sites.len(), particles.len());
    if n == 0 {
        return Vec::new();
    }
    let mean_spacing = {
        let grid0 = Grid::new(particles.iter().copied(), 0.0);
        let lo = particles.iter().fold(particles[0], |a, p| a.inf(p));
        let hi = particles.iter().fold(particles[0], |a, p| a.sup(p));
        let area = ((hi - lo).x * (hi - lo).y).max(1e-30);
        drop(grid0);
        (area / m as f64).sqrt() * 2.0
    };
    let mut cands = Candidates {
        grid: Grid::new(particles.iter().copied(), mean_spacing),
        sites,
        lists: vec![Vec::new(); n],
        m,
    };
    let mut u = vec![0.0; n];
    for (i, ui) in u.iter_mut().enumerate() {
        *ui = cands.get(i, 0).map(|c| c.0).unwrap_or(0.0);
    }
    let mut v = vec![0.0; m];
    let mut row_col = vec![FREE; n];
    let mut col_row = vec![FREE; m];
    let mut col_d = vec![f64::INFINITY; m];
    let mut col_final = vec![false; m];
    let mut pred = vec![FREE; m];
    let mut row_d = vec![0.0; n];
    let mut touched_cols: Vec<usize> = Vec::new();
    let mut scanned_rows: Vec<usize> = Vec::new();
    let mut heap: BinaryHeap<Entry> = BinaryHeap::new();

    for start in 0..n {
        heap.clear();
        touched_cols.clear();
        scanned_rows.clear();
        row_d[start] = 0.0;
        scanned_rows.push(start);
        if let Some((c, _)) = cands.get(start, 0) {
            heap.push(Entry {
                key: (c - u[start]).max(0.0),
                kind: Kind::Row { row: start, idx: 0 },
            });
        }
        let mut sink = FREE;
        let mut delta = 0.0;
        while let Some(Entry { key, kind }) = heap.pop() {
            match kind {
                Kind::Row { row, idx } => {
                    let Some((c, j)) = cands.get(row, idx) else {
                        continue;
                    };
                    if !col_final[j] {
                        let nd = row_d[row] + (c - u[row] - v[j]).max(0.0);
                        if nd < col_d[j] {
                            if col_d[j] == f64::INFINITY {
                                touched_cols.push(j);
                            }
                            col_d[j] = nd;
                            pred[j] = row;
                            heap.push(Entry {
                                key: nd,
                                kind: Kind::Col { col: j },
                            });
                        }
                    }
                    if let Some((c_next, _)) = cands.get(row, idx + 1) {
                        let lb = row_d[row] + (c_next - u[row]).max(0.0);
                        heap.push(Entry {
                            key: lb.max(key),
                            kind: Kind::Row { row, idx: idx + 1 },
                        });
                    }
                }
                Kind::Col { col } => {
                    if col_final[col] || key > col_d[col] {
                        continue;
                    }
                    col_final[col] = true;
                    if col_row[col] == FREE {
                        sink = col;
                        delta = key;
                        break;
                    }
                    let r = col_row[col];
                    row_d[r] = key;
                    scanned_rows.push(r);
                    if let Some((c, _)) = cands.get(r, 0) {
                        heap.push(Entry {
                            key: key + (c - u[r]).max(0.0),
                            kind: Kind::Row { row: r, idx: 0 },
                        });
                    }
                }
            }
        }
        debug_assert!(sink != FREE, "m >= n guarantees an augmenting path");
        for &j in &touched_cols {
            if col_final[j] {
                v[j] += col_d[j] - delta;
            }
        }
        for &r in &scanned_rows {
            u[r] += delta - row_d[r];
        }
        let mut j = sink;
        loop {
            let r = pred[j];
            let prev = row_col[r];
            row_col[r] = j;
            col_row[j] = r;
            if r == start {
                break;
            }
            j = prev;
        }
        for &j in &touched_cols {
            col_d[j] = f64::INFINITY;
            col_final[j] = false;
        }
    }
    // Keep the matched pair's reduced cost exact for the next caller (none here).
    let _ = dist;
    row_col
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::super::{assignment_cost, dense_jv};
    use super::*;

    #[test]
    fn matches_dense_on_clustered_and_compact_instances() {
        for seed in 0..10 {
            // Compact block of sites, particles spread around it: long augmenting paths.
            let sites: Vec<Vector2<f64>> = (0..64)
                .map(|i| Vector2::new(40.0 + (i % 8) as f64, 40.0 + (i / 8) as f64))
                .collect();
            let parts = random_points(150, 100.0, seed);
            let a = solve(&sites, &parts);
            let b = dense_jv::solve(&sites, &parts, |s, p| dist(&sites[s], &parts[p]));
            let (ca, cb) = (
                assignment_cost(&sites, &parts, &a),
                assignment_cost(&sites, &parts, &b),
            );
            assert!(
                (ca - cb).abs() <= 1e-9 * cb,
                "seed {seed}: sparse {ca} dense {cb}"
            );
        }
    }
}
