//! A lower bound of a geometric assignment's optimum from any column prices.
//!
//! Weak duality: for rows `r_t` each assigned to a distinct column `c_j`
//! (rows <= columns) at cost `|r_t - c_j|`, any prices `p_j` and any
//! `u_t <= min_j |r_t - c_j| + p_j` give, for every assignment `a`,
//! `sum_t |r_t - c_a(t)| >= sum_t (u_t - p_a(t)) >= sum_t u_t - (sum of the
//! n largest p)`. So the bound is valid whatever the prices: they may come
//! from a cheaper problem (LB_tip's contracted one) and only its tightness
//! depends on them. Alternating the two best responses (`u_t = min_j d + p_j`,
//! then `p_j = max_t u_t - d`, then `u` again) never lowers it: each step
//! keeps the pair feasible and moves one side to its best value given the
//! other. Every `u_t` is a spatial query (`WeightedPoints`), never a row of
//! the cost matrix.

use super::weighted_nearest::{QueryBuffer, WeightedPoints};
use nalgebra::Vector2;

/// How far below the exact `min_j d + p_j` a row's `u_t` may be (metres):
/// lets the query stop among near ties; the bound loses at most this per row.
const QUERY_TOLERANCE_M: f64 = 1e-9;

/// The weak-duality bound of `prices` (one per column, finite or +infinity)
/// after `rounds` alternations of best responses; 0 when there is no row or
/// no finite price.
pub fn bound_from_prices(
    rows: &[Vector2<f64>],
    cols: &[Vector2<f64>],
    prices: &[f64],
    rounds: usize,
) -> f64 {
    assert!(rows.len() <= cols.len() && prices.len() == cols.len());
    if rows.is_empty() {
        return 0.0;
    }
    let mut priced_cols = WeightedPoints::new(cols, prices);
    let mut u = min_plus_all(&priced_cols, rows);
    let mut p = prices.to_vec();
    let mut valued_rows = WeightedPoints::new(rows, &u);
    for _ in 0..rounds {
        let neg_u: Vec<f64> = u.iter().map(|&x| -x).collect();
        valued_rows.set_weights(&neg_u);
        p = min_plus_all(&valued_rows, cols)
            .into_iter()
            .map(|x| -x)
            .collect();
        priced_cols.set_weights(&p);
        u = min_plus_all(&priced_cols, rows);
    }
    p.sort_unstable_by(|a, b| b.total_cmp(a));
    let bound = u.iter().sum::<f64>() - p[..rows.len()].iter().sum::<f64>();
    if bound.is_finite() {
        bound.max(0.0)
    } else {
        0.0
    }
}

/// `min_j |q - p_j| + w_j` (within the tolerance, never above) for every
/// query, split over the machine's threads.
fn min_plus_all(points: &WeightedPoints, queries: &[Vector2<f64>]) -> Vec<f64> {
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
    let chunk = queries.len().div_ceil(threads).max(1);
    let mut out = vec![0.0; queries.len()];
    std::thread::scope(|scope| {
        for (qs, os) in queries.chunks(chunk).zip(out.chunks_mut(chunk)) {
            scope.spawn(move || {
                let mut buf = QueryBuffer::default();
                for (q, o) in qs.iter().zip(os) {
                    *o = points.min_plus(*q, QUERY_TOLERANCE_M, &mut buf);
                }
            });
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::super::{assignment_cost, dense_jv, dist};
    use super::*;

    #[test]
    fn any_prices_give_a_bound_below_the_optimum_and_rounds_tighten_it() {
        for seed in 0..6 {
            let n = 30 + seed as usize * 7;
            let rows = random_points(n, 100.0, seed);
            let cols = random_points(n + seed as usize % 3, 100.0, seed + 50);
            let opt = assignment_cost(
                &rows,
                &cols,
                &dense_jv::solve(&rows, &cols, |t, j| dist(&rows[t], &cols[j])),
            );
            // Zero prices, random prices, and half the columns unpriced.
            let random: Vec<f64> = random_points(cols.len(), 80.0, seed + 9)
                .iter()
                .map(|p| p.x - 40.0)
                .collect();
            let holes: Vec<f64> = (0..cols.len())
                .map(|j| if j % 2 == 0 { f64::INFINITY } else { 0.0 })
                .collect();
            for prices in [vec![0.0; cols.len()], random, holes] {
                let mut last = f64::NEG_INFINITY;
                for rounds in [1, 2, 4, 8] {
                    let b = bound_from_prices(&rows, &cols, &prices, rounds);
                    assert!(b <= opt + 1e-9, "seed {seed}: {b} above {opt}");
                    assert!(b >= last - 1e-9, "seed {seed}: {b} fell from {last}");
                    last = b;
                }
            }
            // Zero prices: at least every row's nearest column.
            let nearest: f64 = rows
                .iter()
                .map(|r| {
                    cols.iter()
                        .map(|c| dist(r, c))
                        .fold(f64::INFINITY, f64::min)
                })
                .sum();
            let b = bound_from_prices(&rows, &cols, &vec![0.0; cols.len()], 1);
            assert!(b >= nearest - 1e-9, "seed {seed}: {b} below {nearest}");
            // The auction's prices: the optimum itself.
            let prices = super::super::auction::particle_prices_m(&rows, &cols, 0.0);
            let b = bound_from_prices(&rows, &cols, &prices, 1);
            assert!(b >= opt * (1.0 - 1e-6), "seed {seed}: {b} below {opt}");
        }
        assert_eq!(bound_from_prices(&[], &[], &[], 3), 0.0);
    }
}
