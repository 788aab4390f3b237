//! Dense shortest-augmenting-path assignment (Jonker-Volgenant / Crouse 2016),
//! the method scipy's `linear_sum_assignment` runs: O(n^2 m) worst case.
//! Kept as the exact reference that the sparse method is tested against.

use nalgebra::Vector2;

/// Largest instance whose costs are kept in a table (32 MB).
const TABLE_MAX_PAIRS: usize = 4_000_000;

/// Solves the rectangular assignment (rows = sites <= cols = particles) for a
/// cost function; returns the column of every row. Up to
/// `TABLE_MAX_PAIRS` pairs, each cost is asked once and kept in a table:
/// the search reads it O(n^2 m) times, and callers' costs look pairs up in
/// maps (a tenth of CMU's planning went into hashing them).
pub fn solve(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    cost: impl Fn(usize, usize) -> f64,
) -> Vec<usize> {
    let (n, m) = (sites.len(), particles.len());
    if n * m > TABLE_MAX_PAIRS {
        return shortest_augmenting_paths(n, m, cost);
    }
    let table: Vec<f64> = (0..n)
        .flat_map(|i| (0..m).map(move |j| (i, j)))
        .map(|(i, j)| cost(i, j))
        .collect();
    shortest_augmenting_paths(n, m, |i, j| table[i * m + j])
}

/// The search of [`solve`] on `n` rows and `m` columns.
fn shortest_augmenting_paths(n: usize, m: usize, cost: impl Fn(usize, usize) -> f64) -> Vec<usize> {
    let mut u = vec![0.0; n];
    let mut v = vec![0.0; m];
    let mut col_row = vec![usize::MAX; m];
    let mut row_col = vec![usize::MAX; n];
    let mut shortest = vec![f64::INFINITY; m];
    let mut path = vec![usize::MAX; m];
    let mut scanned_col = vec![false; m];
    let mut remaining: Vec<usize> = Vec::with_capacity(m);
    for cur_row in 0..n {
        shortest.iter_mut().for_each(|x| *x = f64::INFINITY);
        scanned_col.iter_mut().for_each(|x| *x = false);
        remaining.clear();
        remaining.extend((0..m).rev());
        let mut scanned_rows = vec![cur_row];
        let mut i = cur_row;
        let mut min_val = 0.0;
        let sink;
        loop {
            let mut lowest = f64::INFINITY;
            let mut index = usize::MAX;
            for (it, &j) in remaining.iter().enumerate() {
                let r = min_val + cost(i, j) - u[i] - v[j];
                if r < shortest[j] {
                    path[j] = i;
                    shortest[j] = r;
                }
                if shortest[j] < lowest || (shortest[j] == lowest && col_row[j] == usize::MAX) {
                    lowest = shortest[j];
                    index = it;
                }
            }
            min_val = lowest;
            let j = remaining.swap_remove(index);
            scanned_col[j] = true;
            if col_row[j] == usize::MAX {
                sink = j;
                break;
            }
            i = col_row[j];
            scanned_rows.push(i);
        }
        u[cur_row] += min_val;
        for &r in scanned_rows.iter().skip(1) {
            u[r] += min_val - shortest[row_col[r]];
        }
        for j in 0..m {
            if scanned_col[j] {
                v[j] -= min_val - shortest[j];
            }
        }
        let mut j = sink;
        loop {
            let r = path[j];
            col_row[j] = r;
            let prev = row_col[r];
            row_col[r] = j;
            if r == cur_row {
                break;
            }
            j = prev;
        }
    }
    row_col
}
